#!/usr/bin/env bash
# Runs every ```sh block of README.md, in order and as written, with `set -e -o pipefail`, in a
# scratch folder whose ./build is the folder of the shprobe given (so `./build/shprobe` is the
# program under test, and every output lands in the scratch folder). Fails when any block fails,
# naming it; all are run. A block whose fence follows the line
#   <!-- readme-test: skip (REASON) -->
# (blank lines between allowed) is skipped, its reason printed: the set-up commands themselves
# (installing, the whole build, the whole test suite) and the viewer's window.
# Usage: readme_examples.sh BUILD/shprobe [README.md]
set -euo pipefail
program=$(realpath "${1:?usage: readme_examples.sh BUILD/shprobe [README.md]}")
readme=$(realpath "${2:-$(dirname "$0")/../README.md}")
[ -x "$program" ] || { echo "readme_examples: $program is not a program" >&2; exit 1; }

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
ln -s "$(dirname "$program")" "$scratch/build"
mkdir "$scratch/.blocks"

# Split the README into .blocks/N.sh (and N.skip holding the reason) with the block's first line.
awk -v dir="$scratch/.blocks" '
  /^<!-- readme-test: skip \(.*\) -->$/ && !inside {
    skip = $0; sub(/^<!-- readme-test: skip \(/, "", skip); sub(/\) -->$/, "", skip); next }
  /^```sh[[:space:]]*$/ && !inside {
    inside = 1; n++; file = sprintf("%s/%02d.sh", dir, n); printf "" > file
    if (skip != "") { print skip > sprintf("%s/%02d.skip", dir, n) }
    printf "%d\n", NR > sprintf("%s/%02d.line", dir, n); skip = ""; next }
  /^```/ && inside { inside = 0; close(file); next }
  /^```/ && !inside { inside = 2; skip = ""; next }   # a block of another language: not run
  inside == 1 { print >> file; next }
  inside == 2 { next }
  /^[[:space:]]*$/ { next }
  { skip = "" }                                        # a marker holds only for the next fence
' "$readme"

blocks=("$scratch"/.blocks/*.sh)
[ -e "${blocks[0]}" ] || { echo "readme_examples: no \`\`\`sh block in $readme" >&2; exit 1; }

cd "$scratch"
ran=0 skipped=0 failed=()
for block in "${blocks[@]}"; do
  base=${block%.sh}
  where="$(basename "$readme"):$(cat "$base.line")"
  if [ -e "$base.skip" ]; then
    echo "SKIP $where ($(cat "$base.skip"))"
    skipped=$((skipped + 1))
    continue
  fi
  echo "RUN  $where"
  sed 's/^/       /' "$block"
  start=$(date +%s.%N)
  if bash -e -o pipefail "$block" > "$base.out" 2>&1; then status=ok; else status="FAILED (exit $?)"; fi
  seconds=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.2f", b - a }')
  echo "     $status in $seconds s"
  if [ "$status" != ok ]; then
    sed 's/^/     | /' "$base.out"
    failed+=("$where")
  fi
  ran=$((ran + 1))
done
echo "readme_examples: $ran blocks run, $skipped skipped, ${#failed[@]} failed"
[ ${#failed[@]} -eq 0 ] || { printf 'readme_examples: failed: %s\n' "${failed[@]}" >&2; exit 1; }
