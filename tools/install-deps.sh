#!/usr/bin/env bash
# Installs every Debian 12 package Cascade needs to build, test and benchmark.
# Idempotent: packages already present are left alone; apt lists are refreshed
# only when something is missing. Run as root on a fresh Debian 12 machine.
# Opt-in: --blender (or CASCADE_WITH_BLENDER=1) also installs Blender and the
# numpy its Python needs (tools/blender/, ctest -L blender, docs/blender.md);
# --fuzz installs clang 14 and libFuzzer (tools/fuzz.sh, tests/fuzz).
set -euo pipefail

with_blender=${CASCADE_WITH_BLENDER:-0}
with_fuzz=0
for arg in "$@"; do
  case "$arg" in
    --blender) with_blender=1 ;;
    --fuzz) with_fuzz=1 ;;
    *) echo "install-deps: unknown argument $arg (known: --blender, --fuzz)" >&2; exit 2 ;;
  esac
done

PACKAGES=(
  build-essential cmake pkg-config git
  libopenvdb-dev libboost-iostreams-dev libblosc-dev libopenvdb-tools
  libeigen3-dev libassimp-dev libtbb-dev libcgal-dev libgmp-dev libmpfr-dev
  libosmesa6-dev libpng-dev
  libcli11-dev nlohmann-json3-dev libgtest-dev libgmock-dev libbenchmark-dev
  gnuplot-nox
  slurm-wlm munge
  openmpi-bin libopenmpi-dev
)
if [ "$with_blender" = 1 ]; then
  PACKAGES+=(blender python3-numpy)
fi
if [ "$with_fuzz" = 1 ]; then
  PACKAGES+=(clang-14 libfuzzer-14-dev llvm-14)
fi

missing=()
for pkg in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
