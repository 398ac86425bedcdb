#!/usr/bin/env bash
# Builds the renderer's host code with AddressSanitizer and
# UndefinedBehaviorSanitizer (CMake option SPM_SANITIZE; -O1 with line
# tables, which build in less than half the time of -O2 -g) in build-asan/
# (SPM_ASAN_BUILD_DIR overrides it) and runs the whole ctest suite there.
# Any sanitizer report (memory error, undefined behaviour, leak) aborts the
# process it happens in, so the test fails; this script then exits
# non-zero. SPM_RELEASE_BINARY names a Release spm for the valgrind test,
# which cannot run a sanitized one (tools/test.sh sets it); without it that
# test skips itself. Idempotent: a second run only rebuilds what changed.
set -euo pipefail
cd "$(dirname "$0")/.."

fail() {
  echo "sanitize.sh: $*" >&2
  exit 1
}

build="${SPM_ASAN_BUILD_DIR:-build-asan}"
bash tools/install-deps.sh >/dev/null || fail "tools/install-deps.sh failed"
mkdir -p "$build"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
  -DSPM_SANITIZE=ON >"$build/configure.log" 2>&1 ||
  fail "configuring $build failed (see $build/configure.log)"
cmake --build "$build" -j2 >"$build/build.log" 2>&1 || fail "building $build failed (see $build/build.log)"

# halt_on_error/abort_on_error: the first report ends the process with
# SIGABRT, which no test mistakes for an expected exit code (the CLI tests run
# the spm binary as a child process, with these settings inherited).
# verify_asan_link_order=0: the oclgrind test runs spm under the oclgrind
# launcher, which LD_PRELOADs its OpenCL runtime ahead of libasan; that
# library defines no allocator, so the order does not matter.
# intercept_tls_get_addr=0: GCC 12's sanitizer runtime takes some dynamic TLS
# blocks (PoCL's, here) for glibc 2.19 ones by their address alone and hands
# LeakSanitizer a bogus range, which crashes its tracer at exit ("Tracer
# caught signal 11", google/sanitizers#1322). Without it, LeakSanitizer does
# not scan dynamic TLS: a pointer held only there would show as a leak.
# Leaks of the MPI runtime are suppressed by tools/lsan.supp (each entry
# explained there). Their stacks reach Open MPI's frames only with the slow
# unwinder (fast_unwind_on_malloc=0), which makes every allocation about 4x
# slower (PoCL's kernel builds too), so only MPI ranks get it: Open MPI's
# mpirun sets the variables of mca_base_env_list in every rank it starts.
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=1:detect_leaks=1:check_initialization_order=1:strict_init_order=1:detect_stack_use_after_return=1:verify_asan_link_order=0:intercept_tls_get_addr=0"
export LSAN_OPTIONS="suppressions=$PWD/tools/lsan.supp:print_suppressions=0"
export OMPI_MCA_mca_base_env_list="LSAN_OPTIONS=$LSAN_OPTIONS:fast_unwind_on_malloc=0"
export UBSAN_OPTIONS="halt_on_error=1:abort_on_error=1:print_stacktrace=1"

log="$build/ctest.log"
status=0
ctest --test-dir "$build" --output-on-failure -j2 2>&1 | tee "$log" || status=$?
[ "$status" -eq 0 ] || fail "tests failed under ASan + UBSan (see $log)"
echo "sanitize.sh: every test passed under ASan + UBSan ($build)"
