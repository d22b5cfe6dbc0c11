#!/usr/bin/env bash
# Installs the Debian packages shprobe needs (if missing) and builds it into ./build (Release):
# every target, the tests included, or only the targets named (`bash scripts/build.sh shprobe_cli`:
# the program with its codec plugins and its viewer, as scripts/bake-default.sh needs).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
# Tests on even where ./build was configured with SHPROBE_BUILD_TESTS=OFF, so that scripts/test.sh
# always has them.
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSHPROBE_BUILD_TESTS=ON
targets=()
[ $# -eq 0 ] || targets=(--target "$@")
cmake --build build -j"$(nproc)" "${targets[@]}"
