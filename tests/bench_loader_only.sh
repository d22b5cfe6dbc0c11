#!/usr/bin/env bash
# test_bench_loader_only: shprobe-bench runs where only the Vulkan loader is installed, so that the
# file alone can be copied to a GPU machine (docs/benchmark.md). Checked, on the program given as $1:
#   1. its NEEDED entries (readelf -d) and everything the dynamic loader loads for it (ldd: every
#      library, however deep) are within the C and C++ runtimes: libstdc++, libm, libgcc_s, libc
#      and the dynamic loader itself (no image codec, no project library, in a
#      -DBUILD_SHARED_LIBS=ON build too); the Vulkan loader, libvulkan.so.1, is loaded when it
#      creates its device (src/vk/vulkan_commands.h), which 3. does;
#   2. --help and --version run;
#   3. copied alone into an empty folder, it measures a tiny cube map (face 16, order 3, one run) on
#      the device of VK_ICD_FILENAMES (lavapipe in ctest), with every row and the JSON report;
#   4. `shprobe bench`'s image options, --decode and --write-layouts, are refused in one line that
#      points to `shprobe bench`, exit 2.
set -euo pipefail
bench=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
allowed='^(linux-vdso\.so\.1|libstdc\+\+\.so\.6|libm\.so\.6|libgcc_s\.so\.1|libc\.so\.6|ld-linux-x86-64\.so\.2|ld-linux-aarch64\.so\.1)$'

needed=$(readelf -d "$bench" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
[ -n "$needed" ] || fail "readelf finds no NEEDED entry in $bench"
if grep -Ev "$allowed" <<< "$needed"; then fail "$bench needs more than the C and C++ runtimes (above)"; fi
echo "NEEDED: $(tr '\n' ' ' <<< "$needed")"
# ldd's first word is the library's name ("libc.so.6 => /lib/...", "/lib64/ld-linux-x86-64.so.2").
ldd "$bench" > "$work/ldd" || fail "ldd $bench failed"
if grep -q 'not found' "$work/ldd"; then cat "$work/ldd"; fail "$bench has libraries the loader cannot find"; fi
loaded=$(awk '{ n = split($1, path, "/"); print path[n] }' "$work/ldd")
if grep -Ev "$allowed" <<< "$loaded"; then
  cat "$work/ldd"; fail "$bench loads more than the C and C++ runtimes (above)"
fi
echo "ldd: $(tr '\n' ' ' <<< "$loaded")"

# shellcheck source=tests/run_capture.sh
source "$(dirname "$0")/run_capture.sh"
run "$bench" --help
[ "$code" = 0 ] || fail "--help: exit $code: $err"
[[ "$out" == *"Usage:"* && "$out" == *"--sizes"* && "$out" == *"--orders"* ]] || fail "--help: $out"
if grep -E '^ +--(decode|write-layouts)' <<< "$out"; then fail "--help lists an option that shprobe-bench refuses (above)"; fi
run "$bench" --version
[[ "$code" = 0 && "$out" == "shprobe-bench "[0-9]* ]] || fail "--version: exit $code: $out $err"
echo "--help and --version: OK ($out)"

mkdir "$work/alone"
cp "$bench" "$work/alone/shprobe-bench"
(cd "$work/alone" && ./shprobe-bench --sizes 16 --orders 3 --repeat 1 --json bench.json) > "$work/run" ||
  { cat "$work/run"; fail "shprobe-bench --sizes 16 --orders 3 --repeat 1 failed"; }
cat "$work/run"
for row in "cpu memory read (bound)" "cpu memcpy" "gpu buffer read (device)" "gpu buffer copy (device)" "host-to-device copy, pinned (transfer bound)" "gpu texel reads only (device)" "gpu texel reads only, buffer (device)" "gpu multiply-adds at peak (arithmetic bound)" "gpu projection (device)" "gpu bake (wall" "cpu reference (double)" "cpu fast"; do
  grep -qF "$row" "$work/run" || fail "no '$row' row"
done
for key in '"device":' '"multiply_adds_per_second":' '"measurements":' '"face_size": 16' '"pipeline_creation":'; do
  grep -qF "$key" "$work/alone/bench.json" || fail "no $key in bench.json"
done
echo "a run of shprobe-bench alone: OK"

for option in --decode --write-layouts; do
  run "$bench" "$option" a.exr b
  [ "$code" = 2 ] || fail "$option: exit $code, not 2: $err"
  [ "$(wc -l < "$work/err")" = 1 ] || fail "$option: not one error line: $err"
  # shellcheck disable=SC2016 # the backquotes are the message's own
  [[ "$err" == "shprobe-bench: error: $option "*'`shprobe bench`'* ]] || fail "$option: $err"
  echo "$option: $err"
done
echo "test_bench_loader_only: OK"
