// glTF: the Khronos glTF validator's report on the file (numErrors must be 0), and the light's
// irradianceCoefficients as Babylon's glTF loader takes them (loaders EXT_lights_image_based:
// SphericalHarmonics.FromArray, scaled by intensity, convertIrradianceToLambertianRadiance), then
// evaluated like babylon.mjs: E(n)/pi in glTF's frame; and the specular chain as the light lists it:
// per mip, the width and height of each face's PNG (from its IHDR chunk).
// Usage: node gltf.mjs ASSET.gltf DIRECTIONS
import { readFileSync } from "node:fs";
import { importPackage, print, readDirections, requirePackage } from "./common.mjs";

const validator = requirePackage("gltf-validator");
const [file, directionsFile] = process.argv.slice(2);
const bytes = new Uint8Array(readFileSync(file));
const report = await validator.validateBytes(bytes, { uri: file, maxIssues: 100 });
const { SphericalHarmonics, SphericalPolynomial } = await importPackage("@babylonjs/core/Maths/sphericalPolynomial.js");
const asset = JSON.parse(new TextDecoder().decode(bytes));
const scene = asset.scenes[asset.scene ?? 0];
const light = asset.extensions.EXT_lights_image_based.lights[scene.extensions.EXT_lights_image_based.light];
const harmonics = SphericalHarmonics.FromArray(light.irradianceCoefficients);
harmonics.scaleInPlace(light.intensity ?? 1);
harmonics.convertIrradianceToLambertianRadiance();
const sh = SphericalPolynomial.FromHarmonics(harmonics).preScaledHarmonics;
const irradianceOverPi = readDirections(directionsFile).map(([x, y, z]) => {
    const terms = [[sh.l00, 1], [sh.l1_1, y], [sh.l10, z], [sh.l11, x], [sh.l2_2, y * x], [sh.l2_1, y * z],
                   [sh.l20, 3 * z * z - 1], [sh.l21, z * x], [sh.l22, x * x - y * y]];
    const sum = [0, 0, 0];
    for (const [c, p] of terms) sum[0] += c.x * p, sum[1] += c.y * p, sum[2] += c.z * p;
    return sum;
});
// A data-URI PNG's size: the IHDR chunk's width and height, big-endian at bytes 16 and 20.
const pngSize = (uri) => {
    const png = Buffer.from(uri.slice(uri.indexOf(",") + 1), "base64");
    return [png.readUInt32BE(16), png.readUInt32BE(20)];
};
print({
    numErrors: report.issues.numErrors,
    numWarnings: report.issues.numWarnings,
    messages: report.issues.messages.map((m) => `${m.severity} ${m.code} ${m.pointer ?? ""}: ${m.message}`),
    irradianceOverPi,
    specularImageSize: light.specularImageSize,
    specularMips: light.specularImages.map((faces) => faces.map((index) => pngSize(asset.images[index].uri))),
});
