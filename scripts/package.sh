#!/usr/bin/env bash
# Builds the Debian package build-package/shprobe_<version>_amd64.deb (cmake/Package.cmake: what
# `cmake --install` installs, under /usr, with Depends and Recommends from dpkg-shlibdeps) and prints
# its path. The build is Release with prefix /usr, in ./build-package, configured without tests the
# first time. SHPROBE_BUILD_DIR=build makes it from ./build instead, tests and all (they are not
# installed, so the package is the same), which CI configures for /usr before its tests so that no
# file is built twice; another prefix there would rebuild the common floor (its plugin places) and relink every program.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${SHPROBE_BUILD_DIR:-build-package}
exec 3>&1 1>&2 # standard output carries the path alone (deb=$(bash scripts/package.sh)); the rest to stderr

bash scripts/install-deps.sh
options=(-DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr)
[ -e "$build/CMakeCache.txt" ] || options+=(-DSHPROBE_BUILD_TESTS=OFF)
cmake -S . -B "$build" "${options[@]}" > /dev/null
cmake --build "$build" -j"$(nproc)"
rm -f "$build"/shprobe_*.deb
if ! (cd "$build" && cpack -G DEB > cpack.log 2>&1); then
  cat "$build/cpack.log"; echo "FAIL: cpack -G DEB in $build"; exit 1
fi
grep -E '^-- (Depends|Recommends):' "$build/cpack.log" | sed 's/^-- /package: /'
realpath "$build"/shprobe_*_amd64.deb >&3
