#!/usr/bin/env bash
# Builds the libFuzzer harnesses of tests/fuzz with clang 14 (AddressSanitizer and
# UBSan on every library) into build-fuzz/ and runs them: first each seed corpus
# alone (ctest label fuzz-corpus), then each harness for SECONDS (label fuzz).
# Usage: tools/fuzz.sh [SECONDS]   (default 60; docs/testing.md)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
bash tools/install-deps.sh --fuzz
# The Release build's cascade checks what the VDB harnesses find (run_past_library_aborts.sh).
[ -x build/cascade ] || bash tools/setup.sh --no-tests
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang-14 \
  -DCMAKE_CXX_COMPILER=clang++-14 -DCASCADE_FUZZ=ON -DCASCADE_FUZZ_SECONDS="$seconds" >/dev/null
cmake --build build-fuzz -j"$(nproc 2>/dev/null || echo 2)" \
  --target fuzz_scene fuzz_particle_cache fuzz_mesh fuzz_whitewater
ctest --test-dir build-fuzz -L fuzz-corpus --output-on-failure
ctest --test-dir build-fuzz -L '^fuzz$' --output-on-failure
