// three.js: the LightProbe file loaded by docs/exports.md's three.js snippet (ObjectLoader.parse,
// then scene.add), then the LightProbe it added evaluated by getAt (radiance) and
// getIrradianceAt (irradiance E(n)), each times its intensity.
// Usage: node threejs.mjs PROBE.three.json DIRECTIONS
import { readFileSync } from "node:fs";
import { importPackage, importSnippet, print, readDirections } from "./common.mjs";

const THREE = await importPackage("three/build/three.module.js");
const { addShprobeLightProbe } = await importSnippet("threejs");
const [file, directionsFile] = process.argv.slice(2);
const scene = new THREE.Scene();
addShprobeLightProbe(scene, JSON.parse(readFileSync(file, "utf8")));
const probes = scene.children.filter((child) => child.isLightProbe);
if (probes.length !== 1) throw new Error(`${file}: the snippet added ${probes.length} LightProbes to the scene`);
const [probe] = probes;
const radiance = [], irradiance = [];
for (const [x, y, z] of readDirections(directionsFile)) {
    const n = new THREE.Vector3(x, y, z);
    radiance.push(probe.sh.getAt(n, new THREE.Vector3()).multiplyScalar(probe.intensity).toArray());
    irradiance.push(probe.sh.getIrradianceAt(n, new THREE.Vector3()).multiplyScalar(probe.intensity).toArray());
}
print({ radiance, irradiance });
