#!/usr/bin/env bash
# Installs Cascade's Debian packages (tools/install-deps.sh), configures and
# builds into build/ (Release). Idempotent: a second run only rebuilds what changed.
# Usage: tools/setup.sh [extra cmake -D options...]
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build build -j"$jobs"
