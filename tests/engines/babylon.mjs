// Babylon.js: the array through SphericalHarmonics.FromArray, SphericalPolynomial.FromHarmonics
// (what a texture's sphericalPolynomial holds) and its preScaledHarmonics, the values the PBR
// material uploads as vSphericalL00..L22 (materialHelper.functions BindIBLParameters); evaluated as
// harmonicsFunctions.fx computeEnvironmentIrradiance does with SPHERICAL_HARMONICS: E(n)/pi.
// Usage: node babylon.mjs PROBE.babylon.json DIRECTIONS
import { readFileSync } from "node:fs";
import { importPackage, print, readDirections } from "./common.mjs";

const { SphericalHarmonics, SphericalPolynomial } = await importPackage("@babylonjs/core/Maths/sphericalPolynomial.js");
const [file, directionsFile] = process.argv.slice(2);
const harmonics = SphericalHarmonics.FromArray(JSON.parse(readFileSync(file, "utf8")));
const sh = SphericalPolynomial.FromHarmonics(harmonics).preScaledHarmonics;
// computeEnvironmentIrradiance's nine terms (harmonicsFunctions.fx), transcribed.
const terms = (x, y, z) => [
    [sh.l00, 1], [sh.l1_1, y], [sh.l10, z], [sh.l11, x], [sh.l2_2, y * x],
    [sh.l2_1, y * z], [sh.l20, 3 * z * z - 1], [sh.l21, z * x], [sh.l22, x * x - y * y],
];
const irradianceOverPi = [];
for (const [x, y, z] of readDirections(directionsFile)) {
    const sum = [0, 0, 0];
    for (const [c, p] of terms(x, y, z)) {
        sum[0] += c.x * p, sum[1] += c.y * p, sum[2] += c.z * p;
    }
    irradianceOverPi.push(sum);
}
print({ irradianceOverPi });
