// Shared by the engine checks: the npm packages' folder, the directions file and the output.
// Each check prints one JSON object on stdout; test_engine_exports.cpp compares it with shprobe.
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";
import { join } from "node:path";
import { pathToFileURL } from "node:url";

// The node_modules folder `npm install --prefix BUILD/npm` made (SHPROBE_NODE_MODULES).
export function modulesFolder() {
    const folder = process.env.SHPROBE_NODE_MODULES;
    if (!folder) throw new Error("SHPROBE_NODE_MODULES is not set");
    return folder;
}

// An ES module of an installed package, by its path inside node_modules.
export function importPackage(path) {
    return import(pathToFileURL(join(modulesFolder(), path)).href);
}

// A CommonJS package.
export function requirePackage(name) {
    return createRequire(join(modulesFolder(), "index.js"))(name);
}

// One direction "x y z" a line, already in the engine's frame.
export function readDirections(path) {
    return readFileSync(path, "utf8").trim().split("\n").map((line) => line.trim().split(/\s+/).map(Number));
}

export function print(result) {
    process.stdout.write(JSON.stringify(result) + "\n");
}
