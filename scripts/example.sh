#!/usr/bin/env bash
# The installed package seen by an engine: installs shprobe into a temporary prefix and builds the
# examples against that prefix alone; neither CMake configure may print a warning.
#
# examples/bake_probe (find_package(shprobe) for the .spv folder and the shared headers; no shprobe
# library) runs on lavapipe with the validation layer, and its plan and coefficients are checked:
#   0. each bake's dispatch plan, as the example prints it, is a row of the installed INTERFACE.md's
#      table of plans (which test_interface recomputes with dispatch_plan.h, the baker's plan);
#   1. white furnace (radiance 1 everywhere): L_00 = sqrt(4 pi), E_00 = pi sqrt(4 pi), the rest 0,
#      within 1e-5 of L_00 (fp32 sums of 6 x 32^2 texels; measured 3.5e-7 for L_00 and 1.7e-6 for
#      E_00, about an ulp of each fp32 value);
#   2. a sky with a sun, order 5, 6 x 128^2: the example writes its texels as six PFM faces and
#      `shprobe bake` projects the same file; radiance and irradiance must agree within 1e-6 of each
#      channel's first coefficient (L_00 or E_00; same modules, and the same dispatch plan, as both
#      take dispatch_plan.h's defaults: in practice identical);
#   3. the same radiance against `shprobe bake --backend reference`, the double-precision reference, within
#      1e-5 of L_00 (fp32 texel weights and sums; measured about 1e-7).
#
# examples/probe_reader (the C++ library: readProbe, rotate, evaluate) is built twice, with CMake
# (find_package + shprobe::shprobe) and with pkg-config alone, and both are run on probes that the
# installed `shprobe light` writes, against closed forms:
#   4. ambient radiance c, written as irradiance: E(n) = pi c at any normal, under any rotation;
#   5. a directional light of intensity I from d (Sloan's normalization), rotated by R: E(R d) = pi I
#      at the probe's order, for every order.
#   Both within 1e-7 of the value: the files keep 9 significant digits (at most 5e-9 of each
#   coefficient), the band rotations are orthogonal and, at the light's own direction, every term of
#   E is positive, so the stored rounding moves E by at most 5e-9 of itself; the rest is double
#   arithmetic (measured: 6e-10 and 4e-10). Any slip of convention (pi, sqrt(4 pi), a band factor,
#   a rotation's sense) is off by far more.
#
# The installed program reads an EXR and a PFM through the installed codec plugins (lib/shprobe),
# not the build tree's.
# Last, INTERFACE.md's "Sources": every installed module's source is installed, and glslang, with the
# options the document gives, compiles it into the installed module, byte for byte.
# SHPROBE_BUILD_DIR picks the build to install (default ./build, built here if needed); the same
# checks serve a -DBUILD_SHARED_LIBS=ON build. SHPROBE_PREFIX=/usr checks what is installed there
# instead (the Debian package, scripts/package.sh), with its own program; only the examples are built.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${SHPROBE_BUILD_DIR:-build}
export VK_ICD_FILENAMES=${VK_ICD_FILENAMES:-/usr/share/vulkan/icd.d/lvp_icd.x86_64.json}

bash scripts/install-deps.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ -n "${SHPROBE_PREFIX:-}" ]; then
  prefix=$SHPROBE_PREFIX
  shprobe=$prefix/bin/shprobe
  [ -x "$shprobe" ] || { echo "FAIL: no $shprobe: shprobe is not installed in $prefix"; exit 1; }
else
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release > /dev/null
  cmake --build "$build" -j"$(nproc)"
  cmake --install "$build" --prefix "$work/prefix" > /dev/null
  prefix=$work/prefix
  shprobe=$build/shprobe
fi

# The package config finds only what the installed headers include, so none may include these.
if grep -rlE '#include *[<"](OpenImageIO|nlohmann)/' "$prefix/include/shprobe"; then
  echo "FAIL: installed headers include a private dependency"; exit 1
fi

# CMake configure of an example against the prefix, which must print nothing but "-- " status lines:
# no "CMake Warning", and no notice of a dependency's config (such as Imath's missing-file message).
configure() { # source folder, build folder
  if ! cmake -S "$1" -B "$2" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" > "$2.log" 2>&1; then
    cat "$2.log"; echo "FAIL: configure of $1"; exit 1
  fi
  if grep -q 'CMake.*Warning' "$2.log" || grep -v -e '^-- ' -e '^$' "$2.log" > /dev/null; then
    cat "$2.log"; echo "FAIL: the configure of $1 is not silent"; exit 1
  fi
}
configure examples/bake_probe "$work/example"
cmake --build "$work/example" > /dev/null
example=$work/example/bake_probe

# The example's "plan:" line (INTERFACE.md's columns) must be a row of the installed document's table
# of plans (the table whose header starts "| N | n | probes |").
check_plan() { # example output
  local plan rows
  plan=$(awk '$1 == "plan:" { $1 = ""; print substr($0, 2) }' "$1")
  rows=$(awk -F'|' '/^\| N \| n \| probes \|/ { on = 1; next }
    on && /^\| ---/ { next }
    on && /^\|/ { line = ""; for (i = 2; i < NF; ++i) { gsub(/ /, "", $i); line = line (i > 2 ? " " : "") $i }
                  print line; next }
    on { exit }' "$prefix/share/shprobe/spirv/INTERFACE.md")
  if [ -z "$plan" ] || ! grep -Fxq -- "$plan" <<< "$rows"; then
    echo "FAIL: the example's plan '$plan' is not a row of INTERFACE.md's table of plans"; exit 1
  fi
  echo "plan $plan: a row of INTERFACE.md's table of plans"
}

# Rows "L i r g b" / "E i r g b" of the example; prints them as "i r g b".
rows() { awk -v tag="$1" '$1 == tag { print $2, $3, $4, $5 }' "$2"; }
# Coefficient rows of a probe file, numbered.
json_rows() { awk '/"coefficients"/ { on = 1; next } on && /\[/ { gsub(/[][,]/, " "); print n++, $1, $2, $3 }' "$1"; }

echo "== white furnace"
"$example" --environment white --face-size 32 --order 3 --validation | tee "$work/white.txt"
check_plan "$work/white.txt"
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
check_plan "$work/sky.txt"
"$shprobe" bake "$work/faces/{face}.pfm" --order 5 -o "$work/radiance.json" -q
"$shprobe" bake "$work/faces/{face}.pfm" --order 5 --irradiance -o "$work/irradiance.json" -q
"$shprobe" bake "$work/faces/{face}.pfm" --order 5 --backend reference -o "$work/cpu.json" -q
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

echo "== probe_reader: the C++ library through the package, built with CMake and with pkg-config"
configure examples/probe_reader "$work/reader"
cmake --build "$work/reader" > /dev/null
PKG_CONFIG_PATH=$(dirname "$(find "$prefix"/lib* -path "*/pkgconfig/shprobe.pc")")
export PKG_CONFIG_PATH
libdir=$(pkg-config --variable=libdir shprobe)
if [ -e "$libdir/libshprobe.so" ]; then # shared: the program finds the libraries by its RUNPATH
  pc_options=(); link_options=("-Wl,-rpath,$libdir")
else # static: Libs.private and Requires.private as well
  pc_options=(--static); link_options=()
fi
# shellcheck disable=SC2046 # pkg-config's flags are words
c++ -std=c++20 -O2 -Wall -Wextra -Wpedantic examples/probe_reader/main.cpp -o "$work/probe_reader_pc" \
  $(pkg-config --cflags --libs "${pc_options[@]}" shprobe) "${link_options[@]}"
version=$(sed -n 's/^project(shprobe VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
if [ "$(pkg-config --modversion shprobe)" != "$version" ]; then
  echo "FAIL: shprobe.pc is not version $version"; exit 1
fi

echo "== codec plugins: the installed program reads EXR and PFM through the installed plugins"
# The build tree's plugins are also on the program's search path (the last place it looks), so the
# loader's own log says which file each bake loaded. The program runs through PATH, as a user runs
# it, where its own name is no path to its folder.
"$prefix/bin/shprobe" bake --format irradiance-equirect --map-size 32 -q -o "$work/sky.exr" > /dev/null
{ printf 'PF\n32 16\n-1.0\n'; head -c $((32 * 16 * 3 * 4)) /dev/zero; } > "$work/sky.pfm" # OpenImageIO's alone
plugins=$(dirname "$(find "$(realpath "$prefix")"/lib* -name libshprobe_exr.so)")
for input in sky.exr:exr sky.pfm:oiio; do
  file=$work/${input%%:*}
  plugin=libshprobe_${input##*:}.so
  if ! (cd "$work" && PATH="$prefix/bin:$PATH" LD_DEBUG=files shprobe bake "$file" -q -o plugin.json \
    > /dev/null 2> loader.log); then
    grep -v '^ *[0-9]*:' "$work/loader.log"
    echo "FAIL: the installed shprobe could not bake $file"
    exit 1
  fi
  if ! grep -q "file=$plugins/$plugin .*dynamically loaded" "$work/loader.log"; then
    echo "FAIL: the installed shprobe did not load $plugins/$plugin for $file:"
    grep "$plugin .*dynamically loaded" "$work/loader.log" || echo "(no $plugin loaded)"
    exit 1
  fi
  echo "${input%%:*}: $plugins/$plugin"
done

"$prefix/bin/shprobe" light --order 3 --irradiance --ambient 0.25,0.5,2 -o "$work/ambient.json" > /dev/null
"$prefix/bin/shprobe" light --order 5 --directional 1,0,0 1,2,4 -o "$work/directional.json" > /dev/null
# R d for R = Rz(gamma) Ry(beta) Rz(alpha) (degrees) and d = +x, as "x,y,z".
rotated_x() {
  awk -v a="$1" -v b="$2" -v g="$3" 'BEGIN { r = atan2(0, -1) / 180; a *= r; b *= r; g *= r
    x = cos(a); y = sin(a); z = 0                                   # Rz(alpha) x
    t = cos(b) * x + sin(b) * z; z = cos(b) * z - sin(b) * x; x = t # Ry(beta)
    t = cos(g) * x - sin(g) * y; y = sin(g) * x + cos(g) * y; x = t # Rz(gamma)
    printf "%.17g,%.17g,%.17g\n", x, y, z }'
}
# Runs probe_reader and checks its version line and E against pi * (r, g, b), within 1e-7 (see the top).
expect() { # label, r g b, probe_reader arguments...
  local label=$1 rgb=$2 out
  shift 2
  out=$("$@")
  echo "$out"
  awk -v label="$label" -v version="$version" -v rgb="$rgb" '
    BEGIN { pi = atan2(0, -1); split(rgb, e, " ") }
    NR == 1 && $2 != version "," { print "FAIL: " label ": prints version " $2 ", not " version; exit 1 }
    $1 == "irradiance" { seen = 1
      for (c = 1; c <= 3; ++c) {
        d = ($(c + 1) - pi * e[c]) / (pi * e[c]); if (d < 0) d = -d; if (d > worst) worst = d } }
    END { if (!seen) { print "FAIL: " label ": no irradiance line"; exit 1 }
          printf "%s: largest difference %.3g of the closed form (tolerance 1e-7)\n", label, worst
          if (worst > 1e-7) { print "FAIL: " label; exit 1 } }' <<< "$out"
}
for how in CMake pkg-config; do
  reader=$work/reader/probe_reader
  [ "$how" = pkg-config ] && reader=$work/probe_reader_pc
  expect "$how: ambient 0.25,0.5,2, E = pi c" "0.25 0.5 2" "$reader" "$work/ambient.json" 30,60,45 1,-2,0.5
  expect "$how: directional 1,2,4 from x rotated by 30,60,45, E(R x) = pi I" "1 2 4" \
    "$reader" "$work/directional.json" 30,60,45 "$(rotated_x 30 60 45)"
done
echo "== module sources: installed, and compiled as INTERFACE.md says into the installed modules"
glsl_dir=$prefix/include/shprobe/glsl
for spv in "$prefix"/share/shprobe/spirv/*.spv; do
  module=$(basename "$spv" .spv) # project.comp
  source=$prefix/share/shprobe/shaders/$module.glsl
  if [ ! -f "$source" ]; then
    echo "FAIL: $module's source is not installed (INTERFACE.md: share/shprobe/shaders/$module.glsl)"; exit 1
  fi
  glslangValidator --target-env vulkan1.1 -S "${module##*.}" -I"$glsl_dir" -o "$work/$module.spv" "$source" > /dev/null
  if ! cmp -s "$spv" "$work/$module.spv"; then
    echo "FAIL: the installed $module.glsl does not compile into the installed $module.spv"; exit 1
  fi
done
echo "every installed module compiles from its installed source"
echo "example: OK"
