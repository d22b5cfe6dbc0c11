#!/usr/bin/env bash
# Bakes light probes in CI, offscreen, and checks them: installs Mesa's lavapipe (Vulkan on the CPU)
# and the shprobe package, bakes each environment on the Vulkan backend and on the CPU, and fails
# unless every probe has order^2 finite rows, a positive L00 and the same coefficients on both
# backends. docs/ci.md has the workflow that runs it.
#
# Usage: bake-and-check.sh [shprobe_VERSION_amd64.deb] [ENVIRONMENT ...]
#   the .deb        installed with apt-get (without it, shprobe must already be installed)
#   ENVIRONMENT     what `shprobe bake` reads (EXR, HDR, PNG, JPEG: equirect, crosses, face folders or
#                   patterns), each baked after the built-in sky, whose L00 must also be the one
#                   shprobe 0.1 bakes, within 0.1%
# Environment: SHPROBE_OUT, the folder of the probes (default ./probes): NAME.json from the Vulkan
# backend, NAME.glsl for the installed glsl/sh_irradiance.glsl; SHPROBE_ORDER (default 3); VK_ICD_FILENAMES,
# the Vulkan driver (default: lavapipe's, so a machine's GPU is never picked by chance).
set -euo pipefail
deb=""
if [ $# -gt 0 ] && [[ $1 == *.deb ]]; then
  deb=$(realpath "$1")
  shift
fi
out=${SHPROBE_OUT:-probes}
order=${SHPROBE_ORDER:-3}

sudo=""
[ "$(id -u)" -eq 0 ] || sudo=sudo
export DEBIAN_FRONTEND=noninteractive
# --no-install-recommends: the package recommends the viewer's GLFW and the OpenImageIO plugin's
# libraries, which a bake of EXR, HDR, PNG or JPEG files does not load; drop it to read PFM, TIFF, ...
packages=(mesa-vulkan-drivers libvulkan1)
[ -z "$deb" ] || packages+=("$deb")
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${packages[@]}" > /dev/null
command -v shprobe > /dev/null || { echo "FAIL: shprobe is not installed (give its .deb)"; exit 1; }
export VK_ICD_FILENAMES=${VK_ICD_FILENAMES:-/usr/share/vulkan/icd.d/lvp_icd.$(uname -m).json}

shprobe --version
shprobe info # the Vulkan device the bakes use; fails when there is none
mkdir -p "$out"

# Checks two probe files of one environment: rows, finite values, L00 > 0 and the Vulkan backend's
# coefficients against the CPU's within 1e-4 of L00 (both sum in float; on lavapipe they differ by
# about 1e-7). With an expected L00 "r g b", each channel's must also be within 0.1% of it.
check() { # name, vulkan.json, cpu.json, [expected L00]
  paste -d ' ' <(rows "$2") <(rows "$3") | awk -v name="$1" -v n=$((order * order)) -v expected="${4:-}" '
    function abs(x) { return x < 0 ? -x : x }
    function finite(x) { return x ~ /^-?[0-9]+(\.[0-9]*)?([eE][-+]?[0-9]+)?$/ && abs(x) < 1e30 } # no nan, inf, null
    { for (c = 1; c <= 6; ++c) if (!finite($c)) { print "FAIL: " name ": row " NR - 1 " is not finite: " $0; exit 1 }
      if (NR == 1) {
        for (c = 1; c <= 3; ++c) { l00[c] = $c; if ($c <= 0) { print "FAIL: " name ": L00 " $c " <= 0"; exit 1 } }
        if (expected != "") { split(expected, e, " ")
          for (c = 1; c <= 3; ++c) if (abs($c - e[c]) > 1e-3 * e[c]) {
            print "FAIL: " name ": L00 " $c " is not " e[c] " (within 0.1%)"; exit 1 } } }
      for (c = 1; c <= 3; ++c) { d = abs($c - $(c + 3)) / l00[c]; if (d > worst) worst = d } }
    END { if (NR != n) { print "FAIL: " name ": " NR " rows, not " n; exit 1 }
          printf "%s: %d rows, L00 %.6g %.6g %.6g, Vulkan against CPU %.2g of L00 (tolerance 1e-4)\n",
                 name, NR, l00[1], l00[2], l00[3], worst
          if (worst > 1e-4) { print "FAIL: " name ": the backends disagree"; exit 1 } }'
}
# The coefficient rows of a probe file, "r g b" each (the format of docs/conventions.md).
rows() {
  awk '/"coefficients"/ { on = 1; next } on && /^ *\]/ { exit } on { gsub(/[][,]/, " "); print $1, $2, $3 }' "$1"
}

bake() { # name, [input]
  local name=$1
  shift
  shprobe bake "$@" --order "$order" --backend gpu -q -o "$out/$name.json"
  shprobe bake "$@" --order "$order" --backend cpu -q -o "$out/$name.cpu.json"
  shprobe convert "$out/$name.json" -o "$out/$name.glsl" > /dev/null # read back by shprobe itself
}
# The built-in sky first: its L00, as shprobe 0.1 bakes it (the radiance's mean times sqrt(4 pi),
# whatever the order), proves the installed program and the driver.
bake built-in-sky
check built-in-sky "$out/built-in-sky.json" "$out/built-in-sky.cpu.json" "22.6545 20.7021 18.0985"
for input in "$@"; do
  name=$(basename "${input%.*}")
  bake "$name" "$input"
  check "$name" "$out/$name.json" "$out/$name.cpu.json"
done
rm -f "$out"/*.cpu.json
echo "bake-and-check: OK ($out)"
