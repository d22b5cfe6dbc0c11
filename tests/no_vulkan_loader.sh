#!/usr/bin/env bash
# test_no_vulkan_loader: shprobe does what needs no device where no Vulkan loader is installed, and
# says in one line what is missing where a device is needed. Vulkan's commands are loaded from
# libvulkan.so.1 at the first call of any (src/vk/vulkan_commands.h), not linked. Checked, on the
# program given as $1:
#   1. neither shprobe nor shprobe-bench beside it has libvulkan among its NEEDED entries;
#   2. `--help`, `convert`, `rotate`, `light` and bakes on the CPU (--backend cpu, and auto's small job) do not load
#      it (LD_DEBUG=files: not through dlopen either), and a bake on the GPU does;
#   3. with the loader hidden (in a mount namespace of its own, an empty file lies over the file
#      libvulkan.so.1 names): a CPU bake writes the same probe as with it, and `bake --backend gpu`
#      and `info` each fail with one line, "shprobe: error: no Vulkan loader: ...", exit 4, writing
#      nothing (auto's large job without a loader: tests/auto_backend.sh). Skipped, and said so,
#      where no mount namespace can be made (unshare needs root).
set -euo pipefail
shprobe=$1
bench=$(dirname "$shprobe")/shprobe-bench
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

for program in "$shprobe" "$bench"; do
  needed=$(readelf -d "$program" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
  [ -n "$needed" ] || fail "readelf finds no NEEDED entry in $program"
  if grep '^libvulkan' <<< "$needed"; then fail "$program links the Vulkan loader (above)"; fi
  echo "$program needs: $(tr '\n' ' ' <<< "$needed")"
done

# Whether a run of shprobe loads the Vulkan loader, at start or through dlopen.
loads_vulkan() {
  rm -f "$work"/ld.*
  LD_DEBUG=files LD_DEBUG_OUTPUT="$work/ld" "$shprobe" "$@" > /dev/null || fail "shprobe $* failed"
  grep -q 'file=libvulkan\.so\.1' "$work"/ld.*
}
"$shprobe" bake --backend cpu --face-size 16 -q -o "$work/sky.json" > /dev/null
for command in "--help" "convert $work/sky.json -o $work/sky.three.json" \
               "rotate $work/sky.json --euler 10,20,30 -o $work/rotated.json" "light --ambient 1,1,1 -o $work/light.json" \
               "bake --backend cpu --face-size 16 -q -o $work/cpu.json" "bake --face-size 16 -q -o $work/auto.json"; do
  # shellcheck disable=SC2086 # the command's words
  if loads_vulkan $command; then fail "shprobe $command loads the Vulkan loader"; fi
  echo "shprobe $command: the Vulkan loader is not loaded"
done
loads_vulkan bake --backend gpu --face-size 16 -q -o "$work/gpu.json" || fail "a GPU bake did not load the Vulkan loader"
echo "shprobe bake --backend gpu: the Vulkan loader is loaded"

loader=$(ldconfig -p | awk '$1 == "libvulkan.so.1" && /x86-64|AArch64/ && !found { print $NF; found = 1 }')
[ -n "$loader" ] || fail "ldconfig knows no libvulkan.so.1"
if ! unshare --mount true 2> /dev/null; then
  echo "test_no_vulkan_loader: SKIPPED the runs without a loader: no mount namespace can be made here"
  exit 0
fi
: > "$work/empty.so"
# One shell in a private mount namespace: the bind mount is seen by its runs alone.
unshare --mount bash -s "$shprobe" "$work" "$(readlink -f "$loader")" << 'HIDDEN'
set -euo pipefail
shprobe=$1 work=$2 loader=$3
fail() { echo "FAIL: $*" >&2; exit 1; }
mount --bind "$work/empty.so" "$loader"
"$shprobe" bake --backend cpu --face-size 16 -q -o "$work/hidden.json" > /dev/null
cmp -s "$work/cpu.json" "$work/hidden.json" || fail "the CPU bake without a loader differs from the one with it"
echo "bake --backend cpu without a loader: the same probe"
for command in "bake --backend gpu --face-size 16 -q -o $work/none.json" "info"; do
  code=0
  # shellcheck disable=SC2086 # the command's words
  "$shprobe" $command > "$work/out" 2> "$work/err" || code=$?
  [ "$code" = 4 ] || fail "shprobe $command without a loader: exit $code, not 4: $(cat "$work/err")"
  [ "$(wc -l < "$work/err")" = 1 ] || fail "shprobe $command: not one error line: $(cat "$work/err")"
  grep -q '^shprobe: error: no Vulkan loader: .*install libvulkan1' "$work/err" ||
    fail "shprobe $command: $(cat "$work/err")"
  echo "shprobe $command without a loader: $(cat "$work/err")"
done
[ ! -e "$work/none.json" ] || fail "the failed GPU bake left $work/none.json"
HIDDEN
echo "test_no_vulkan_loader: OK"
