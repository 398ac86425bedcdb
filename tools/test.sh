#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run): installs and builds
# (tools/setup.sh), runs ctest on the Release build, runs the same suite again
# on an AddressSanitizer + UndefinedBehaviorSanitizer build of the host code
# (tools/sanitize.sh), and fuzzes the scene, OBJ and .vol parsers briefly
# (tools/fuzz.sh). Exits non-zero at the first failure.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
ctest --test-dir build --output-on-failure -j2
bash tools/sanitize.sh
bash tools/fuzz.sh 30 fuzz_scene
bash tools/fuzz.sh 30 fuzz_obj
bash tools/fuzz.sh 30 fuzz_vol
echo "tools/test.sh: Release suite, sanitizer suite and fuzzing passed"
