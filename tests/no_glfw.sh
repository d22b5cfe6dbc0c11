#!/usr/bin/env bash
# test_no_glfw: shprobe bakes where no display library is installed. The viewer, the only code that
# links GLFW, is a program of its own, shprobe-view, which `shprobe view` runs. Checked, on the
# program given as $1:
#   1. no NEEDED entry (readelf -d) of shprobe, nor of the project's shared libraries it loads (a
#      -DBUILD_SHARED_LIBS=ON build), names GLFW, X11 (libX*), xcb, Wayland, xkbcommon or GLX; and
#      nothing the dynamic loader loads for shprobe at all (ldd: every library, however deep) is a
#      window-system library, OpenImageIO (whose Debian build needs X11 through OpenCV and
#      others) or OpenEXR: they are plugins, loaded only for the files that need them;
#   2. a GPU bake of the built-in sky succeeds; it, `--help`, `info` and `convert` load no image library at
#      all (LD_DEBUG=files: nothing through dlopen either), and writing an EXR does load OpenEXR
#      (so that the check sees a plugin when one is loaded);
#   3. `shprobe view` with no shprobe-view beside it (shprobe copied alone into a folder) exits 4 with
#      one line, "shprobe: error: the viewer is not installed ...", naming the file it looked for;
#   4. where the viewer is built: it does need GLFW (so that check 1 would see it), `shprobe view
#      --help` is its help, and its errors read as shprobe's through `shprobe view` and as its own
#      when run directly.
set -euo pipefail
shprobe=$1
viewer=$(dirname "$shprobe")/shprobe-view
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
window_system='\[lib(glfw|X[A-Za-z0-9_-]*|xcb|wayland-|xkbcommon|GLX)'
fail() { echo "FAIL: $*" >&2; exit 1; } # stderr: also seen from inside $(...)

needed() { readelf -d "$1" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/[\1]/p'; }
files=("$shprobe")
while read -r library; do files+=("$library"); done < <(ldd "$shprobe" | awk '$1 ~ /^libshprobe/ { print $3 }')
for file in "${files[@]}"; do
  [ -n "$(needed "$file")" ] || fail "readelf finds no NEEDED entry in $file"
  if needed "$file" | grep -E "$window_system"; then fail "$file needs a window-system library (above)"; fi
  echo "no window-system library needed by $file"
done
image_libraries='lib(OpenImageIO|OpenEXR|Imath|Iex|IlmThread)[^ ]*'
loaded="lib(glfw|X[A-Za-z0-9_-]*|xcb|wayland-|xkbcommon|GLX)[^ ]*|$image_libraries"
if ldd "$shprobe" | grep -E "$loaded"; then fail "$shprobe loads a window-system or image library (above)"; fi
echo "no window-system or image library among the $(ldd "$shprobe" | wc -l) libraries $shprobe loads"

# The shared libraries a run of shprobe loads, at start and through dlopen, one file name a line.
loads() {
  rm -f "$work"/ld.*
  LD_DEBUG=files LD_DEBUG_OUTPUT="$work/ld" "$shprobe" "$@" > /dev/null || fail "shprobe $* failed"
  cat "$work"/ld.* | sed -n 's/.*file=\([^ ]*\).*/\1/p' | sort -u
}
without_image_libraries() {
  local libraries
  libraries=$(loads "$@") || exit 1
  if grep -E "$image_libraries" <<< "$libraries"; then fail "shprobe $* loads an image library (above)"; fi
  echo "shprobe $*: no image library loaded"
}
without_image_libraries bake --backend gpu --face-size 8 -q -o "$work/probe.json"
[ -s "$work/probe.json" ] || fail "shprobe bake wrote no probe"
without_image_libraries --help
without_image_libraries info
without_image_libraries convert "$work/probe.json" -o "$work/probe.three.json"
libraries=$(loads bake --face-size 8 -q --format irradiance-equirect -o "$work/irradiance.exr") || exit 1
grep -q '^libOpenEXR' <<< "$libraries" || fail "writing an EXR did not load OpenEXR"
[ -s "$work/irradiance.exr" ] || fail "shprobe bake wrote no EXR"
echo "shprobe bake: OK; writing an EXR loads OpenEXR"

# shellcheck source=tests/run_capture.sh
source "$(dirname "$0")/run_capture.sh"
expect_error() { # exit code, prefix of the single error line, command...
  local expected=$1 prefix=$2
  shift 2
  run "$@"
  [ "$code" = "$expected" ] || fail "$*: exit $code, not $expected: $err"
  [ "$(wc -l < "$work/err")" = 1 ] || fail "$*: not one error line: $err"
  [[ "$err" == "$prefix"* ]] || fail "$*: the error does not start with '$prefix': $err"
}

mkdir "$work/alone"
cp "$shprobe" "$work/alone/shprobe"
expect_error 4 "shprobe: error: the viewer is not installed" "$work/alone/shprobe" view --frames 1
[[ "$err" == *"$work/alone/shprobe-view"* ]] || fail "the error does not name $work/alone/shprobe-view: $err"
echo "shprobe view without shprobe-view: $err"

if [ -x "$viewer" ]; then
  needed "$viewer" | grep -q '\[libglfw' || fail "$viewer does not need libglfw: check 1 would not see it"
  run "$shprobe" view --help
  [ "$code" = 0 ] || fail "shprobe view --help: exit $code: $err"
  [[ "$out" == *"Usage: shprobe view"* && "$out" == *"--screenshot"* ]] || fail "shprobe view --help: $out"
  expect_error 2 "shprobe: error: " "$shprobe" view --order 4
  expect_error 2 "shprobe-view: error: " "$viewer" --order 4
  echo "shprobe view runs $viewer: OK"
fi
echo "test_no_glfw: OK"
