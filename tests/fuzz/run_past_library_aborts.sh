#!/bin/sh
# Fuzzes a VDB harness past the failures of Debian's OpenVDB 10 (built with
# assertions, it aborts on some corrupt point attribute pages; on others it overruns
# a buffer or allocates gigabytes). libFuzzer runs in fork mode and keeps going after
# a crash, an out-of-memory or a timeout; afterwards every such input must be refused
# by the `cascade` program itself, which turns those aborts and faults into exit 2
# (VdbReadScope, libsph/io/VdbFile.h): an exit status 0 or 2 within 120 s, never a
# signal.
# Usage: run_past_library_aborts.sh HARNESS SECONDS FOUND SEEDS ARTIFACTS CASCADE [libFuzzer options]
set -u
harness=$1 seconds=$2 found=$3 seeds=$4 artifacts=$5 cascade=$6
shift 6
mkdir -p "$found" "$artifacts"
rm -f "$artifacts"/crash-* "$artifacts"/leak-* "$artifacts"/timeout-* "$artifacts"/oom-*
"$harness" "$@" -fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1 -max_total_time="$seconds" -artifact_prefix="$artifacts/" "$found" "$seeds"
status=$?
if [ ! -x "$cascade" ]; then
  echo "run_past_library_aborts: $cascade not built (the Release build's cascade checks the crash inputs)" >&2
  exit 1
fi
crashes=0 bad=0
scratch=$(mktemp -d)
for input in "$artifacts"/crash-* "$artifacts"/oom-* "$artifacts"/timeout-*; do
  [ -e "$input" ] || continue
  crashes=$((crashes + 1))
  for extension in vdb ply; do
    cp "$input" "$scratch/input.$extension"
    timeout 120 "$cascade" inspect "$scratch/input.$extension" >/dev/null 2>"$scratch/stderr"
    code=$?
    if [ "$code" -ne 0 ] && [ "$code" -ne 2 ]; then
      echo "run_past_library_aborts: $input as .$extension: cascade inspect exits $code" >&2
      bad=$((bad + 1))
    fi
  done
done
rm -rf "$scratch"
echo "run_past_library_aborts: $crashes crash, out-of-memory or timeout inputs, $bad not refused cleanly by cascade inspect"
[ "$status" -eq 0 ] && [ "$bad" -eq 0 ]
