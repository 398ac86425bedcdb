#!/usr/bin/env bash
# Installs the dependencies (Debian 12 packages), configures build/ (Release
# unless CMAKE_BUILD_TYPE says otherwise) and builds what rendering needs,
# the spm executable; `cmake --build build -j2` adds the test binaries.
# Idempotent: a second run only checks and rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE="${CMAKE_BUILD_TYPE:-Release}" >/dev/null
cmake --build build -j2 --target spm
