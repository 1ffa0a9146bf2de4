#!/usr/bin/env bash
# Installs the Debian packages digilap needs, only those that are missing.
# Extra package names given as arguments are installed too (scripts/fuzz.sh adds clang).
set -euo pipefail
packages=(g++ cmake make pkg-config libeigen3-dev libspectra-dev libgtest-dev libbenchmark-dev libcli11-dev libstb-dev zlib1g-dev libnifti2-dev python3 python3-dev python3-numpy python3-scipy python3-pybind11 python3-pytest python3-matplotlib python3-skimage python3-nibabel petsc-dev slepc-dev libopenmpi-dev openmpi-bin "$@")
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "setup: installing ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
