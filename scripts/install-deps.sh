#!/usr/bin/env bash
# Install what ohm needs from Debian's packages, if anything is missing.
# Idempotent: when every package is present it changes nothing and says so.
# Needs root (or sudo) only when something must be installed.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libopenvdb-dev libboost-dev libboost-iostreams-dev libtbb-dev libblosc-dev libimath-dev
  zlib1g-dev libnifti2-dev libteem-dev libgdcm-dev
  libcgal-dev libgmp-dev libmpfr-dev
  libsuitesparse-dev libmetis-dev libopenblas-dev
  libpetsc-real-dev libhypre-dev openmpi-bin libopenmpi-dev
  libopenimageio-dev
  python3 python3-openvdb python3-numpy python3-pydicom
  gnuplot-nox
  libembree-dev
  blender
  povray python3-pil
  opencl-headers ocl-icd-opencl-dev pocl-opencl-icd
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present" >&2
  exit 0
fi

echo "install-deps: installing ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  SUDO=sudo
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
