// Shared by the engine checks: the npm packages' folder, docs/exports.md's snippets, the directions
// file and the output. Each check prints one JSON object on stdout; test_engine_exports.cpp
// compares it with shprobe.
import { mkdtempSync, readFileSync, rmSync, symlinkSync, writeFileSync } from "node:fs";
import { createRequire } from "node:module";
import { tmpdir } from "node:os";
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

// The code of docs/exports.md's block whose first line is "// shprobe-snippet: NAME", the one a
// user pastes; exactly one such block must exist.
export function snippet(name) {
    const docs = new URL("../../docs/exports.md", import.meta.url);
    const blocks = [...readFileSync(docs, "utf8").matchAll(/^```[a-z]+\n(\/\/ shprobe-snippet: (\S+)\n[^]*?)^```$/gm)];
    const found = blocks.filter((block) => block[2] === name);
    if (found.length !== 1) throw new Error(`${docs.pathname}: ${found.length} blocks marked shprobe-snippet: ${name}`);
    return found[0][1];
}

// The snippet as an ES module, its bare imports ("three", "@babylonjs/core") resolved in the npm
// packages' folder (through a node_modules link next to it, as in a user's project).
export async function importSnippet(name) {
    const folder = mkdtempSync(join(tmpdir(), "shprobe-snippet-"));
    try {
        symlinkSync(modulesFolder(), join(folder, "node_modules"), "dir");
        writeFileSync(join(folder, `${name}.mjs`), snippet(name));
        return await import(pathToFileURL(join(folder, `${name}.mjs`)).href);
    } finally {
        rmSync(folder, { recursive: true, force: true });
    }
}

// One direction "x y z" a line, already in the engine's frame.
export function readDirections(path) {
    return readFileSync(path, "utf8").trim().split("\n").map((line) => line.trim().split(/\s+/).map(Number));
}

export function print(result) {
    process.stdout.write(JSON.stringify(result) + "\n");
}
