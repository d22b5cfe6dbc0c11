#!/usr/bin/env bash
# Fails, naming the files, when a C++ source differs from .clang-format (Debian's clang-format).
# `clang-format -i FILE...` formats them.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
mapfile -t files < <(git ls-files '*.cpp' '*.h')
clang-format --dry-run --Werror "${files[@]}"
echo "check-format: ${#files[@]} files as .clang-format says"
