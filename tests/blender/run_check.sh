#!/usr/bin/env bash
# ctest blender_import (tests/blender/CMakeLists.txt): a short real sequence
# checked inside Blender.
#   tests/blender/run_check.sh CASCADE SRC WORK
# CASCADE: the cascade binary; SRC: the source tree; WORK: a scratch folder
# (emptied). Blender is $BLENDER, else `blender` on PATH. Fails if any step does.
set -euo pipefail
if [ $# -ne 3 ]; then
  echo "usage: $0 CASCADE SRC WORK" >&2
  exit 2
fi
CASCADE=$1
SRC=$2
WORK=$3
BLENDER=${BLENDER:-blender}

step() {  # step NAME COMMAND...: runs it, prints its time, stops the script on failure
  local name=$1 start end
  shift
  echo "run_check: $name: $*"
  start=$(date +%s.%N)
  if ! "$@"; then
    echo "run_check: FAIL: $name exited non-zero" >&2
    exit 1
  fi
  end=$(date +%s.%N)
  echo "run_check: $name done in $(awk "BEGIN {printf \"%.1f\", $end - $start}") s"
}

command -v "$BLENDER" >/dev/null || { echo "run_check: FAIL: no blender ($BLENDER)" >&2; exit 1; }
"$BLENDER" --version | head -n 1
if ! "$BLENDER" -b --factory-startup --python-exit-code 1 --python-expr "import numpy" >/dev/null 2>&1; then
  echo "run_check: FAIL: Blender's Python has no numpy (Debian: apt-get install python3-numpy)" >&2
  exit 1
fi

rm -rf "$WORK"
mkdir -p "$WORK"
OUT=$WORK/out
# The Martin & Moyce dam break at its seed size (spacing 5 mm, about 1,000
# particles), first 0.25 s: 15 frames at the scene's 60 fps.
step bake "$CASCADE" bake "$SRC/scenes/dambreak.json" -o "$OUT" --set size=seed --set output.end_time=0.25
step surface "$CASCADE" surface "$OUT" --mesh-format ply
if ! ls "$OUT"/mesh/fluid.*.ply >/dev/null 2>&1; then
  echo "run_check: FAIL: cascade surface wrote no $OUT/mesh/fluid.NNNN.ply" >&2
  exit 1
fi
step blender "$BLENDER" -b --factory-startup --python-exit-code 1 \
  -P "$SRC/tools/blender/check_import.py" -- "$OUT" --keep "$WORK/images"
echo "run_check: PASS"
