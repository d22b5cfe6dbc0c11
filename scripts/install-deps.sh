#!/usr/bin/env bash
# Installs every Debian 12 package shprobe needs to build, run and test.
# Idempotent: packages already present are left alone; apt-get runs only when something is missing.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools
  glslang-tools spirv-tools spirv-cross
  libglm-dev libglfw3-dev
  libopenimageio-dev openimageio-tools
  libopenexr-dev libstb-dev  # EXR, HDR, PNG, JPEG read and written directly (src/image/codec.h)
  libgtest-dev libcli11-dev nlohmann-json3-dev
  libtinygltf-dev libembree-dev  # glTF scenes; the scene probes' ray-traced reference
  clang-format  # scripts/check-format.sh
  hyperfine time python3  # scripts/bench-job.sh (whole processes, peak memory, its report)
  xvfb xauth
  blender-data  # real HDR environments for the tests (eight equirect EXRs)
  assimp-testmodels  # real and broken glTF scenes for the tests
  mono-mcs  # C#: test_engine_exports compiles and runs docs/exports.md's Unity snippet (mcs, mono)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# node and npm run the engines' own code in test_engine_exports; a node already installed (e.g.
# NodeSource's, which bundles npm) is kept.
command -v node >/dev/null && command -v npm >/dev/null || missing+=(nodejs npm)
[ ${#missing[@]} -eq 0 ] && exit 0

sudo_cmd=""
[ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo_cmd apt-get update -qq
$sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
