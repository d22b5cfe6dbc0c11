#!/usr/bin/env bash
# The installed package seen by an engine: installs shprobe into a temporary prefix, builds
# examples/bake_probe against that prefix alone (find_package(shprobe) for the .spv folder; no
# shprobe C++), runs it on lavapipe with the validation layer, and checks its coefficients:
#   1. white furnace (radiance 1 everywhere): L_00 = sqrt(4 pi), E_00 = pi sqrt(4 pi), the rest 0,
#      within 1e-5 of L_00 (fp32 sums of 6 x 32^2 texels; measured about 3e-8);
#   2. a sky with a sun, order 5, 6 x 128^2: the example writes its texels as six PFM faces and
#      `shprobe bake` projects the same file; radiance and irradiance must agree within 1e-6 of each
#      channel's first coefficient (L_00 or E_00; same modules, same dispatch plan: in practice identical);
#   3. the same radiance against `shprobe bake --backend reference`, the double-precision reference, within
#      1e-5 of L_00 (fp32 texel weights and sums; measured about 1e-7).
# SHPROBE_BUILD_DIR picks the build to install (default ./build, built here if needed).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${SHPROBE_BUILD_DIR:-build}
export VK_ICD_FILENAMES=${VK_ICD_FILENAMES:-/usr/share/vulkan/icd.d/lvp_icd.x86_64.json}

bash scripts/install-deps.sh
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$build" -j"$(nproc)"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > /dev/null
cmake -S examples/bake_probe -B "$work/example" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$work/prefix" > /dev/null
cmake --build "$work/example" > /dev/null
example=$work/example/bake_probe

# Rows "L i r g b" / "E i r g b" of the example; prints them as "i r g b".
rows() { awk -v tag="$1" '$1 == tag { print $2, $3, $4, $5 }' "$2"; }
# Coefficient rows of a probe file, numbered.
json_rows() { awk '/"coefficients"/ { on = 1; next } on && /\[/ { gsub(/[][,]/, " "); print n++, $1, $2, $3 }' "$1"; }

echo "== white furnace"
"$example" --environment white --face-size 32 --order 3 --validation | tee "$work/white.txt"
for tag in L E; do
  rows "$tag" "$work/white.txt" | awk -v tag="$tag" '
    BEGIN { pi = atan2(0, -1); l00 = sqrt(4 * pi); expected0 = (tag == "L") ? l00 : pi * l00; worst = 0 }
    { for (c = 2; c <= 4; ++c) {
        expected = ($1 == 0) ? expected0 : 0; d = $c - expected; if (d < 0) d = -d
        if (d > worst) worst = d } }
    END { printf "%s: largest difference from the closed form %.3g (tolerance %.3g)\n", tag, worst, 1e-5 * l00
          if (worst > 1e-5 * l00) { print "FAIL: white furnace " tag; exit 1 } }'
done

echo "== sky: the example against shprobe bake on the same texels"
mkdir -p "$work/faces"
"$example" --environment sky --face-size 128 --order 5 --write-faces "$work/faces" --validation | tee "$work/sky.txt"
"$build/shprobe" bake "$work/faces/{face}.pfm" --order 5 -o "$work/radiance.json" -q
"$build/shprobe" bake "$work/faces/{face}.pfm" --order 5 --irradiance -o "$work/irradiance.json" -q
"$build/shprobe" bake "$work/faces/{face}.pfm" --order 5 --backend reference -o "$work/cpu.json" -q
compare() { # tag, probe file, tolerance relative to the first coefficient
  paste -d ' ' <(rows "$1" "$work/sky.txt") <(json_rows "$2") | awk -v tag="$1" -v file="${2##*/}" -v tolerance="$3" '
    NR == 1 { for (c = 2; c <= 4; ++c) scale[c] = ($c < 0 ? -$c : $c) }
    { if ($1 != $5) { print "FAIL: row mismatch " $1 " / " $5; exit 1 }
      for (c = 2; c <= 4; ++c) { d = $c - $(c + 4); if (d < 0) d = -d; r = d / scale[c]; if (r > worst) worst = r } }
    END { printf "%s against %s: %d coefficients, largest difference %.3g of the first (tolerance %g)\n",
                 tag, file, NR, worst, tolerance
          if (NR != 25 || worst > tolerance) { print "FAIL: sky " tag " against " file; exit 1 } }'
}
compare L "$work/radiance.json" 1e-6
compare E "$work/irradiance.json" 1e-6
compare L "$work/cpu.json" 1e-5
echo "example: OK"
