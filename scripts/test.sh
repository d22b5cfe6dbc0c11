#!/usr/bin/env bash
# Set up, build, and run every test. GPU tests run on lavapipe, with the validation layer on, once
# per lavapipe subgroup size; a missing Vulkan device fails them.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
ctest --test-dir build --output-on-failure
