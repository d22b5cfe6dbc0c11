#!/usr/bin/env bash
# The pictures of probes in a scene (docs/commands.md), made by shprobe itself: 2CylinderEngine.glb
# (Debian's assimp-testmodels) under the built-in sky, a 6x3x4 probe volume baked with bounce 0 and
# with 2 bounces, and the latter with its probes shown.
#   bash scripts/scene-pictures.sh [BUILD_DIR]     (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
shprobe="${1:-build}/shprobe"
scene=/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
view=(--size 400x260 --pitch 8 --yaw 35 --exposure 1.5)
for bounces in 0 2; do
    "$shprobe" scene "$scene" --grid 6,3,4 --bounces "$bounces" -q -o "$work/engine$bounces.shpv"
done
"$shprobe" render --scene "$scene" --volume "$work/engine0.shpv" "${view[@]}" -o docs/scene-engine-bounce0.png
"$shprobe" render --scene "$scene" --volume "$work/engine2.shpv" "${view[@]}" --show-probes \
    -o docs/scene-engine-bounce2-probes.png
