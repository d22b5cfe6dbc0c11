// Babylon.js: the array given to docs/exports.md's Babylon.js snippet (SphericalHarmonics.FromArray,
// SphericalPolynomial.FromHarmonics into the environment texture's sphericalPolynomial), on a
// NullEngine scene whose environment texture stands for a loaded one (an internal texture, ready).
// Then the texture's preScaledHarmonics, the values the PBR material uploads as vSphericalL00..L22
// (materialHelper.functions BindIBLParameters), evaluated as harmonicsFunctions.fx
// computeEnvironmentIrradiance does with SPHERICAL_HARMONICS: E(n)/pi.
// Usage: node babylon.mjs PROBE.babylon.json DIRECTIONS
import { readFileSync } from "node:fs";
import { importPackage, importSnippet, print, readDirections } from "./common.mjs";

const { BaseTexture, InternalTexture, InternalTextureSource, Logger, NullEngine, Scene } =
    await importPackage("@babylonjs/core/index.js");
const { useShprobeDiffuse } = await importSnippet("babylon");
const [file, directionsFile] = process.argv.slice(2);
Logger.LogLevels = Logger.ErrorLogLevel; // no banner on stdout
const engine = new NullEngine();
const scene = new Scene(engine);
const internal = new InternalTexture(engine, InternalTextureSource.Unknown);
internal.isReady = true;
scene.environmentTexture = new BaseTexture(scene, internal);
useShprobeDiffuse(scene, JSON.parse(readFileSync(file, "utf8")));
const polynomial = scene.environmentTexture.sphericalPolynomial;
if (!polynomial) throw new Error(`${file}: the snippet left the environment texture without a sphericalPolynomial`);
const sh = polynomial.preScaledHarmonics;
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
