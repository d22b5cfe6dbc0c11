// The Khronos glTF validator's counts on a file: {"numErrors", "numWarnings", "messages"} (the
// first messages), for the checks of files shprobe writes (test_transfer.cpp).
// Usage: node gltf_validate.mjs FILE
import { readFileSync } from "node:fs";
import { print, requirePackage } from "./common.mjs";

const validator = requirePackage("gltf-validator");
const [file] = process.argv.slice(2);
const report = await validator.validateBytes(new Uint8Array(readFileSync(file)), { uri: file, maxIssues: 100 });
const messages = report.issues.messages.filter((m) => m.severity <= 1).slice(0, 10);
print({ numErrors: report.issues.numErrors, numWarnings: report.issues.numWarnings, messages });
