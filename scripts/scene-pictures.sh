#!/usr/bin/env bash
# The pictures of probes in a scene (docs/commands.md), made by shprobe itself: 2CylinderEngine.glb
# (Debian's assimp-testmodels) under the built-in sky, a 6x3x4 probe volume baked with bounce 0 and
# with 2 bounces, and the latter with its probes shown; and the README's relighting picture
# (docs/relight.md): its per-vertex transfer at order 3, unshadowed, shadowed and interreflected (1
# bounce), relit by the built-in sky, and the interreflected one with the light turned by 120
# degrees on the device, side by side (oiiotool, from openimageio-tools).
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

relit=(--size 240x180 --pitch 20 --yaw 35 --exposure 1)
for model in unshadowed shadowed interreflected; do
    "$shprobe" transfer "$scene" --model "$model" --rays 64 -o "$work/$model.glb" >/dev/null
    "$shprobe" render --scene "$work/$model.glb" --transfer "${relit[@]}" -o "$work/$model.png" >/dev/null
done
"$shprobe" render --scene "$work/interreflected.glb" --transfer --light-yaw 120 "${relit[@]}" \
    -o "$work/turned.png" >/dev/null
oiiotool "$work/unshadowed.png" "$work/shadowed.png" "$work/interreflected.png" "$work/turned.png" \
    --mosaic 4x1 -d uint8 -o docs/relight-engine.png
