#!/usr/bin/env bash
# Installs the dependencies (Debian 12 packages), configures and builds spm and
# its tests in build/ (Release unless CMAKE_BUILD_TYPE says otherwise).
# Idempotent: a second run only checks and rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE="${CMAKE_BUILD_TYPE:-Release}" >/dev/null
cmake --build build -j2
