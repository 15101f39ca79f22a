#!/usr/bin/env bash
# Builds the libraries, the `ctr` CLI and the test suite with AddressSanitizer + UndefinedBehaviorSanitizer
# (clang, -O1, line tables; CTR_SANITIZE=ON) and runs the whole CTest suite under them. Any sanitizer report fails
# the test that produced it (UBSan is fatal: -fno-sanitize-recover=undefined; LeakSanitizer is on, with the
# third-party suppressions of tests/sanitizers/lsan.supp).
#
# The tree is the one scripts/run-fuzzers.sh uses (CTR_BUILD_FUZZERS=ON: the libraries also carry libFuzzer's
# coverage instrumentation), so CI builds the libraries once for both.
# Usage: scripts/run-sanitizers.sh [BUILD_DIR=build-asan]    Environment: CTR_JOBS (default nproc), CTR_CTEST_ARGS.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build-asan}
JOBS=${CTR_JOBS:-$(nproc)}
start=$(date +%s)

CC=clang CXX=clang++ cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" \
  -DCTR_SANITIZE=ON -DCTR_BUILD_FUZZERS=ON -DCTR_BUILD_BENCHMARKS=OFF -DCTR_BUILD_EXAMPLES=OFF -DCTR_BUILD_REPORTS=OFF > /dev/null
cmake --build "$BUILD" -j"$JOBS"
built=$(date +%s)

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:strict_string_checks=1:check_initialization_order=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/sanitizers/lsan.supp:print_suppressions=0}
# shellcheck disable=SC2086
ctest --test-dir "$BUILD" --output-on-failure -j"$JOBS" --timeout 1800 ${CTR_CTEST_ARGS:-}
end=$(date +%s)
echo "run-sanitizers: build $((built - start)) s, tests $((end - built)) s, all passed under ASan + UBSan"
