#!/usr/bin/env bash
# test_auto_backend: `bake --backend auto` (the default) with a job too large to be done before
# Vulkan could start, on a machine with and without a GPU's device file. On Linux a GPU's Vulkan
# driver needs its device file (/dev/dri/renderD*, /dev/nvidia*, ...; shprobe/vk/context.h,
# findGpuFile), so where there is none any Vulkan device is a CPU, and auto bakes on the CPU
# without starting Vulkan. Each case runs in a private mount namespace whose /dev is made of links
# to the real one's files, with every GPU file left out, and /proc/driver hidden (NVIDIA's module),
# and a plain file dri/renderD128 added for the cases "with a GPU file". Checked, on the program
# given as $1:
#   1. no GPU file: the CPU path, saying why; the Vulkan loader is not even loaded
#      (LD_DEBUG=files); the probe is byte for byte that of `--backend cpu`;
#   2. a GPU file: Vulkan is started and its device asked: lavapipe is a CPU, so the CPU path
#      runs, saying so; the probe is again that of `--backend cpu`;
#   3. a GPU file, the loader hidden (an empty file bound over it): the CPU path, "no usable
#      Vulkan device".
# Skipped, and said so, where no mount namespace can be made (unshare needs root).
set -euo pipefail
shprobe=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

if ! unshare --mount true 2> /dev/null; then
  echo "test_auto_backend: SKIPPED: no mount namespace can be made here"
  exit 0
fi
loader=$(ldconfig -p | awk '$1 == "libvulkan.so.1" && /x86-64|AArch64/ && !found { print $NF; found = 1 }')
[ -n "$loader" ] || fail "ldconfig knows no libvulkan.so.1"
: > "$work/empty.so"
# A job auto does not call small: 4 times the work its threshold allows on this machine's cores
# (20 ms at 1e9 texel-coefficients per core-second, as test_cli's), in 6 x N^2 texels at order 8
# (64 coefficients), N a multiple of 16.
cores=$(getconf _NPROCESSORS_ONLN)
face=$(awk -v cores="$cores" 'BEGIN { n = sqrt(4 * 0.02e9 * cores / (6 * 64)); print 16 * int((n + 15) / 16) }')
large=(bake --order 8 --face-size "$face" -q)
"$shprobe" "${large[@]}" --backend cpu -o "$work/cpu.json" > /dev/null

# CASE GPU_FILE HIDE_LOADER: runs the large bake under auto in a namespace of its own, with its
# summary in $work/CASE.out, its probe in $work/CASE.json and the loader's files in $work/CASE.ld.*
in_namespace() {
  unshare --mount --propagation private bash -s "$shprobe" "$work" "$1" "$2" "$3" "$(readlink -f "$loader")" "${large[@]}" << 'NAMESPACE'
set -euo pipefail
shprobe=$1 work=$2 case=$3 gpu_file=$4 hide_loader=$5 loader=$6
shift 6
mkdir -p "$work/$case/real-dev" "$work/$case/dev"
mount --rbind /dev "$work/$case/real-dev"
for entry in "$work/$case"/real-dev/*; do
  name=${entry##*/}
  # The names findGpuFile looks for, and all of dri.
  case $name in dri | nvidia* | nvhost* | nvmap* | nvgpu* | dxg | mali* | kgsl* | galcore | pvrsrvkm) continue ;; esac
  ln -s "$entry" "$work/$case/dev/$name"
done
if [ "$gpu_file" = yes ]; then
  mkdir "$work/$case/dev/dri"
  : > "$work/$case/dev/dri/renderD128"
fi
mount --bind "$work/$case/dev" /dev
[ ! -d /proc/driver ] || mount -t tmpfs none /proc/driver
[ "$hide_loader" = no ] || mount --bind "$work/empty.so" "$loader"
LD_DEBUG=files LD_DEBUG_OUTPUT="$work/$case.ld" "$shprobe" "$@" -o "$work/$case.json" > "$work/$case.out"
NAMESPACE
  echo "$1: $(grep backend "$work/$1.out")"
}
loads_vulkan() { grep -q 'file=libvulkan\.so\.1' "$work/$1".ld.*; }

in_namespace no-gpu no no
grep -q 'backend  cpu: .*(auto: no GPU device file: any Vulkan device here is a CPU' "$work/no-gpu.out" ||
  fail "no GPU file: $(cat "$work/no-gpu.out")"
if loads_vulkan no-gpu; then fail "no GPU file: auto loaded the Vulkan loader"; fi
cmp -s "$work/cpu.json" "$work/no-gpu.json" || fail "no GPU file: the probe differs from --backend cpu's"

in_namespace gpu yes no
grep -q 'backend  cpu: .*(auto: the Vulkan device is a CPU (llvmpipe' "$work/gpu.out" ||
  fail "a GPU file: $(cat "$work/gpu.out")"
loads_vulkan gpu || fail "a GPU file: auto did not start Vulkan"
cmp -s "$work/cpu.json" "$work/gpu.json" || fail "a GPU file: the probe differs from --backend cpu's"

in_namespace gpu-no-loader yes yes
grep -q 'backend  cpu: .*(auto: no usable Vulkan device)' "$work/gpu-no-loader.out" ||
  fail "a GPU file, no loader: $(cat "$work/gpu-no-loader.out")"
echo "test_auto_backend: OK"
