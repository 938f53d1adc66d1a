#!/usr/bin/env bash
# Installs what caustica needs on Debian 12, idempotently: the apt packages
# that are missing, and a virtual environment (.venv) with the pip packages.
# Fast when everything is already there.
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES=(build-essential pkg-config python3 python3-venv python3-dev
  libembree-dev libtbb-dev libopenexr-dev libstb-dev nlohmann-json3-dev libgtest-dev libnanoflann-dev libtinyobjloader-dev libtinygltf-dev libpugixml-dev
  libopenvdb-dev libboost-dev zlib1g-dev libwebp-dev libdraco-dev libmeshoptimizer-dev)

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "install-deps: apt packages: ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "install-deps: creating .venv with $($PYTHON --version)"
  $PYTHON -m venv .venv
fi
stamp=".venv/.requirements-$(sha256sum scripts/requirements.txt | cut -c1-16)"
if [ ! -f "$stamp" ]; then
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -r scripts/requirements.txt
  rm -f .venv/.requirements-*
  touch "$stamp"
fi

# nvcc from PyPI looks for its libraries in lib64/, the wheel ships lib/.
for cu in .venv/lib/python3*/site-packages/nvidia/cu13; do
  [ -d "$cu/lib" ] && [ ! -e "$cu/lib64" ] && ln -s lib "$cu/lib64"
done
exit 0
