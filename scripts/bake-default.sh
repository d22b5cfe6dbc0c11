#!/usr/bin/env bash
# The main job: set up, build the program (shprobe, its codec plugins and its viewer; not the tests,
# which scripts/test.sh builds), and bake the built-in default sky on the GPU (lavapipe when there is
# no GPU), printing the coefficients and writing probe.json.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh shprobe_cli
./build/shprobe bake --backend gpu -o probe.json # --backend gpu: the Vulkan path even where auto would choose the CPU
