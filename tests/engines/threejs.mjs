// three.js: the LightProbe file read by ObjectLoader.parse (what LightProbe.toJSON writes), then
// its SphericalHarmonics3 evaluated by getAt (radiance) and getIrradianceAt (irradiance E(n)).
// Usage: node threejs.mjs PROBE.three.json DIRECTIONS
import { readFileSync } from "node:fs";
import { importPackage, print, readDirections } from "./common.mjs";

const THREE = await importPackage("three/build/three.module.js");
const [file, directionsFile] = process.argv.slice(2);
const probe = new THREE.ObjectLoader().parse(JSON.parse(readFileSync(file, "utf8")));
if (!probe.isLightProbe) throw new Error(`${file}: ObjectLoader made a ${probe.type}, not a LightProbe`);
const radiance = [], irradiance = [];
for (const [x, y, z] of readDirections(directionsFile)) {
    const n = new THREE.Vector3(x, y, z);
    radiance.push(probe.sh.getAt(n, new THREE.Vector3()).multiplyScalar(probe.intensity).toArray());
    irradiance.push(probe.sh.getIrradianceAt(n, new THREE.Vector3()).multiplyScalar(probe.intensity).toArray());
}
print({ radiance, irradiance });
