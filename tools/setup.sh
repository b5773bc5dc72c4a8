#!/usr/bin/env bash
# Installs Cascade's Debian packages (tools/install-deps.sh), configures and
# builds into build/ (Release). Idempotent: a second run only rebuilds what changed.
# Usage: tools/setup.sh [--no-tests] [extra cmake -D options...]
#   --no-tests  build only the `cascade` program (README's first command);
#               without it the tests are configured and built too.
set -euo pipefail
cd "$(dirname "$0")/.."
tests=ON
target=()
if [ "${1:-}" = "--no-tests" ]; then
  tests=OFF
  target=(--target cascade)
  shift
fi
bash tools/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
# The test option is always passed, so a cached OFF never hides the tests.
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCASCADE_BUILD_TESTS=$tests "$@" >/dev/null
cmake --build build -j"$jobs" "${target[@]}"
