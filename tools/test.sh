#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run): installs and builds the
# Release spm (tools/setup.sh), checks that every file the code cites is in
# the repository (tools/check_citations.py), runs every GoogleTest test once
# on an AddressSanitizer + UndefinedBehaviorSanitizer build of the renderer
# (tools/sanitize.sh; the valgrind test there runs the Release spm, which
# valgrind can run), and fuzzes the scene, OBJ, PLY, serialized and .vol parsers briefly
# (tools/fuzz.sh). Exits non-zero at the first failure.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
python3 tools/check_citations.py
SPM_RELEASE_BINARY="$PWD/build/spm" bash tools/sanitize.sh
bash tools/fuzz.sh 30 fuzz_scene
bash tools/fuzz.sh 30 fuzz_obj
bash tools/fuzz.sh 30 fuzz_ply
bash tools/fuzz.sh 30 fuzz_serialized
bash tools/fuzz.sh 30 fuzz_vol
echo "tools/test.sh: citations, the test suite under the sanitizers and fuzzing passed"
