#!/usr/bin/env bash
# Sanitizers and fuzzing (CI runs this after scripts/test.sh):
#  1. build-asan: the project built with -fsanitize=address,undefined (SHPROBE_SANITIZE=ON) by clang
#     at -O1 with line tables (the optimization ASan's documentation advises; stack traces keep file
#     and line), and every CPU-side test run under it (`ctest -LE gpu`). clang, because on this
#     code GCC 12 instruments at -O2 -g about 20 times slower (src/sh/fast_projection.cpp: 470 s
#     against clang's 24 s), which made this build the longest step of CI. The tests labelled
#     "gpu" (test_gpu_subgroup*, test_cli, test_render_gpu, test_render_cli, test_render_viewer)
#     are left out: they drive lavapipe, whose LLVM-JITted shaders run inside the instrumented
#     process; under ASan they take several times their normal ~4 minutes and only check
#     uninstrumented Mesa code. scripts/test.sh runs them without sanitizers.
#  2. build-fuzz: the libFuzzer targets of fuzz/ (clang), each run for FUZZ_SECONDS (default 20) on
#     a temporary copy of its seed corpus in fuzz/corpus/, so CI never writes into the repository;
#     fuzz_gltf_scene's also takes the small real glTFs of assimp-testmodels, broken ones included,
#     and the dictionary fuzz/gltf_scene.dict (a target's fuzz/<name>.dict is passed where it exists).
#     A crash, sanitizer report or foreign exception fails the run; the input is kept in
#     $FUZZ_ARTIFACTS (default: a temporary folder, printed) to reproduce with
#     ./build-fuzz/fuzz/fuzz_<name> <file>.
# Idempotent; on a fresh Debian 12 it installs what it needs (as root, or with sudo).
set -euo pipefail
cd "$(dirname "$0")/.."

fuzz_seconds=${FUZZ_SECONDS:-20}
jobs=$(nproc)

# --- packages: the project's own, and clang with its runtime libraries (libFuzzer, ASan, UBSan) ---
bash scripts/install-deps.sh
missing=()
# libclang-rt-dev (libclang-rt-14-dev on Debian 12) holds libFuzzer and clang's sanitizer runtimes;
# clang only recommends it, so it is named here.
for p in clang libclang-rt-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $sudo_cmd apt-get update -qq
  $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# Any sanitizer report ends the process with an error, so the test or fuzzer fails.
export ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:abort_on_error=1:check_initialization_order=1:strict_init_order=1:detect_stack_use_after_return=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1

# --- 1. CPU tests under AddressSanitizer and UndefinedBehaviorSanitizer ---------------------------
echo "== sanitize: CPU tests under -fsanitize=address,undefined (build-asan)"
# A build-asan configured with another compiler (CMake keeps the first one) is started again.
grep -qs '^CMAKE_CXX_COMPILER:.*clang' build-asan/CMakeCache.txt || rm -rf build-asan
asan_flags="-O1 -gline-tables-only -DNDEBUG"
CC=clang CXX=clang++ cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSHPROBE_SANITIZE=ON \
  -DSHPROBE_BUILD_TESTS=ON -DCMAKE_C_FLAGS_RELWITHDEBINFO="$asan_flags" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$asan_flags"
# Build only what the CPU tests run (each test is named after its executable target); if that
# naming ever breaks, build everything rather than miss a test.
mapfile -t cpu_tests < <(ctest --test-dir build-asan -N -LE gpu | sed -n 's/^ *Test *#[0-9]*: *//p')
if [ ${#cpu_tests[@]} -eq 0 ]; then
  echo "sanitize: no CPU tests found in build-asan" >&2
  exit 1
fi
# test_bench_decode is a script around the program: its target is shprobe_cli; test_floors reads
# the sources (target check_floors).
cpu_tests=("${cpu_tests[@]/#test_bench_decode/shprobe_cli}")
cpu_tests=("${cpu_tests[@]/#test_floors/check_floors}")
cmake --build build-asan -j"$jobs" --target "${cpu_tests[@]}" || cmake --build build-asan -j"$jobs"
ctest --test-dir build-asan -LE gpu --output-on-failure

# --- 2. fuzzers -----------------------------------------------------------------------------------
echo "== sanitize: libFuzzer targets, ${fuzz_seconds} s each (build-fuzz)"
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DSHPROBE_BUILD_FUZZERS=ON -DSHPROBE_BUILD_TESTS=OFF
cmake --build build-fuzz -j"$jobs" --target shprobe_fuzzers

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
artifacts=${FUZZ_ARTIFACTS:-$(mktemp -d /tmp/shprobe-fuzz-artifacts.XXXXXX)}
mkdir -p "$artifacts"
failed=()
gltf_models=/usr/share/assimp/models/glTF2
for target in probe_json probe_stdin probe_volume gltf_scene layout cross channels exr_header; do
  corpus="$work/$target"
  mkdir -p "$corpus"
  cp fuzz/corpus/"$target"/* "$corpus"/
  if [ "$target" = gltf_scene ] && [ -d "$gltf_models" ]; then
    # Numbered copies: several models share a file name.
    n=0
    while IFS= read -r -d '' model; do
      n=$((n + 1))
      cp "$model" "$corpus/assimp-$n-$(basename "$model")"
    done < <(find "$gltf_models" -size -64k \( -name '*.gltf' -o -name '*.glb' \) -print0)
  fi
  # A target's dictionary, where it has one, holds the words its format is made of.
  dict=()
  [ -f fuzz/"$target".dict ] && dict=(-dict=fuzz/"$target".dict)
  echo "-- fuzz_$target"
  if ! ./build-fuzz/fuzz/fuzz_"$target" "$corpus" -max_total_time="$fuzz_seconds" -rss_limit_mb=2048 \
       -timeout=25 -print_final_stats=1 -artifact_prefix="$artifacts/$target-" ${dict[@]+"${dict[@]}"} \
       2>"$work/$target.log"; then
    tail -n 60 "$work/$target.log" >&2
    failed+=("fuzz_$target")
  fi
  grep -E '^(#[0-9]+[[:space:]]+DONE|stat::number_of_executed_units|stat::peak_rss_mb)' "$work/$target.log" || true
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "sanitize: findings in ${failed[*]}; inputs kept in $artifacts" >&2
  exit 1
fi
[ -n "${FUZZ_ARTIFACTS:-}" ] || rmdir "$artifacts" 2>/dev/null || true
echo "== sanitize: all passed"
