#!/usr/bin/env bash
# Fuzzes the input parsers with libFuzzer (clang-14, AddressSanitizer and
# UndefinedBehaviorSanitizer):
#
#   tools/fuzz.sh [SECONDS] [TARGET]
#
# SECONDS (default 60) of fuzz_scene (the XML loader, default), fuzz_obj
# (the OBJ reader), fuzz_ply (the PLY reader), fuzz_serialized (the reader of
# Mitsuba's serialized meshes) or fuzz_vol (the .vol reader). Configures and builds
# build-fuzz/ (SPM_FUZZ_BUILD_DIR overrides it), seeds a corpus from the
# target's files in scenes/ and tests/data (a copy: the source tree is never
# written), and keeps what the fuzzer finds in
# build-fuzz/corpus-TARGET/ for the next run. Exits non-zero on a finding (a
# crash, a sanitizer report, a leak, a hang of more than 10 s per input, an
# exception other than spm::InputError) and saves the input that caused it
# under build-fuzz/findings/. The fuzzer's output is in build-fuzz/fuzz-TARGET.log.
#
# A long run: for t in fuzz_scene fuzz_obj fuzz_ply fuzz_serialized fuzz_vol; do tools/fuzz.sh 3600 $t; done
set -euo pipefail
cd "$(dirname "$0")/.."

fail() {
  echo "fuzz.sh: $*" >&2
  exit 1
}

seconds="${1:-60}"
target="${2:-fuzz_scene}"
[[ "$seconds" =~ ^[0-9]+$ && "$seconds" -gt 0 ]] || fail "SECONDS must be a positive whole number, got '$seconds'"
# The shipped scenes' meshes (scenes/meshes/, the bunny: 1.3 MB) are no seeds:
# an input that large makes every run slow; tests/data holds small ones.
seed_dirs="scenes tests/data"
case "$target" in
  fuzz_scene) pattern='*.xml' dict=tests/fuzz/scene.dict ;;
  fuzz_obj) pattern='*.obj' dict=tests/fuzz/obj.dict ;;
  fuzz_ply) pattern='*.ply' dict=tests/fuzz/ply.dict seed_dirs=tests/data ;;
  fuzz_serialized) pattern='*.serialized' dict=tests/fuzz/serialized.dict ;;
  fuzz_vol) pattern='*.vol' dict=tests/fuzz/vol.dict ;;
  *) fail "unknown target '$target' (fuzz_scene, fuzz_obj, fuzz_ply, fuzz_serialized or fuzz_vol)" ;;
esac
build="${SPM_FUZZ_BUILD_DIR:-build-fuzz}"

# The project's packages, clang-14 with libFuzzer (clang-14 and
# libclang-rt-14-dev) among them.
bash tools/install-deps.sh >/dev/null || fail "tools/install-deps.sh failed"

mkdir -p "$build"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang-14 \
  -DCMAKE_CXX_COMPILER=clang++-14 -DSPM_FUZZ=ON -DSPM_BUILD_TESTS=OFF >"$build/configure.log" 2>&1 ||
  fail "configuring $build failed (see $build/configure.log)"
cmake --build "$build" --target "$target" -j2 >"$build/build-$target.log" 2>&1 ||
  fail "building $target failed (see $build/build-$target.log)"

# Seeds: a fresh copy of the files each run; the corpus the fuzzer grows
# lives on between runs.
seeds="$build/seeds-$target"
corpus="$build/corpus-$target"
findings="$build/findings"
rm -rf "$seeds"
mkdir -p "$seeds" "$corpus" "$findings"
# (tests/data/fuzz holds the inputs of earlier findings, regression tests now.)
# Named by their paths: files of one name in several folders (quad.obj) all seed.
find $seed_dirs -type f -name "$pattern" | while IFS= read -r f; do cp "$f" "$seeds/${f//\//_}"; done
[ -n "$(ls -A "$seeds")" ] || fail "no seed files ($pattern) found"

log="$build/fuzz-$target.log"
before=$(ls "$findings" | wc -l)
status=0
"$build/$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
  -dict="$dict" -artifact_prefix="$findings/$target-" "$corpus" "$seeds" >"$log" 2>&1 </dev/null || status=$?
if [ "$status" -ne 0 ]; then
  found=$(ls -t "$findings" | head -n 1 || true)
  if [ "$(ls "$findings" | wc -l)" -gt "$before" ] && [ -n "$found" ]; then
    fail "$target found a bug: input saved as $findings/$found (reproduce: $build/$target $findings/$found; log $log)"
  fi
  fail "$target exited with status $status and saved no input (see $log)"
fi
runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
echo "fuzz.sh: $target: no finding in ${seconds} s (${runs:-?} inputs; corpus $corpus: $(ls "$corpus" | wc -l) files)"
