#!/usr/bin/env bash
# Installs every Debian 12 package the project builds, tests and renders with.
# Idempotent: when everything is present it only checks and returns.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  ocl-icd-libopencl1 ocl-icd-opencl-dev opencl-c-headers opencl-clhpp-headers
  pocl-opencl-icd clinfo oclgrind valgrind
  libopenexr-dev libglm-dev librandom123-dev libpugixml-dev libtinyobjloader-dev
  libcli11-dev nlohmann-json3-dev libstb-dev zlib1g-dev
  # FindOpenVDB.cmake also asks for Boost.Iostreams, which libopenvdb-dev does not pull in.
  libopenvdb-dev libboost-iostreams-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  openmpi-bin libopenmpi-dev
  clang-14 libclang-rt-14-dev
  python3 python3-jsonschema
  # The Mitsuba 3 judge in tools/ (reference.py, convergence.py): its venv, and
  # an LLVM new enough for Dr.Jit's llvm_ad_rgb (Debian 12's default 15 is not).
  python3-venv libllvm19
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done

if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update
  $sudo apt-get install -y --no-install-recommends "${missing[@]}"
fi
