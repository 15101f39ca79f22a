#!/usr/bin/env bash
# Builds the libFuzzer targets of tests/fuzz with clang (ASan + UBSan, CTR_BUILD_FUZZERS=ON) and runs every target
# for SECONDS_PER_TARGET seconds, starting from a temporary copy of its seed corpus (tests/fuzz/corpus/<target>/,
# plus tests/fuzz/regressions/<target>/), so that runs never write into the checkout.
# Fails (and prints the reproducer path) if any target produces a crash / leak / timeout / OOM artefact.
#
# Usage: scripts/run-fuzzers.sh [SECONDS_PER_TARGET=30] [BUILD_DIR=build-fuzz]
# Environment: CTR_JOBS (build jobs, default nproc), CTR_FUZZ_PARALLEL (targets run at once, default 2),
#              CTR_FUZZ_TARGETS (space-separated subset), CTR_FUZZ_WORK (keep the run folder there),
#              CTR_FUZZ_CONFIGURED=1 (the build folder is already configured: scripts/run-sanitizers.sh uses the
#              same tree).
# Reproduce a finding: BUILD_DIR/tests/fuzz/fuzz_TARGET REPRODUCER   (or fuzz_replay --target TARGET REPRODUCER).
set -euo pipefail
cd "$(dirname "$0")/.."
SECS=${1:-30}
BUILD=${2:-build-fuzz}
JOBS=${CTR_JOBS:-$(nproc)}
PARALLEL=${CTR_FUZZ_PARALLEL:-2}
ROOT=$PWD

if [ "${CTR_FUZZ_CONFIGURED:-0}" != 1 ]; then
  # The same configuration as scripts/run-sanitizers.sh, so that both can share one tree.
  CC=clang CXX=clang++ cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" \
    -DCTR_SANITIZE=ON -DCTR_BUILD_FUZZERS=ON -DCTR_BUILD_BENCHMARKS=OFF -DCTR_BUILD_EXAMPLES=OFF -DCTR_BUILD_REPORTS=OFF > /dev/null
fi
cmake --build "$BUILD" -j"$JOBS" --target ctr_fuzzers

TARGETS=${CTR_FUZZ_TARGETS:-$(cat "$BUILD/tests/fuzz/fuzz_targets.txt")}
if [ -n "${CTR_FUZZ_WORK:-}" ]; then
  WORK=$CTR_FUZZ_WORK
  mkdir -p "$WORK"
else
  WORK=$(mktemp -d "${TMPDIR:-/tmp}/ctr-fuzz-run.XXXXXX")
fi
# The NIfTI / mesh harnesses write each input to a scratch file: keep it in memory when possible (a disk stall on
# a loaded machine once made an open() take 14 s, a false timeout).
if [ -z "${CTR_FUZZ_SCRATCH:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then CTR_FUZZ_SCRATCH=/dev/shm; fi
export CTR_FUZZ_SCRATCH=${CTR_FUZZ_SCRATCH:-${TMPDIR:-/tmp}}
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=0:abort_on_error=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$ROOT/tests/sanitizers/lsan.supp:print_suppressions=0}

max_len() {
  case $1 in
    nifti|mesh) echo 8192 ;;
    *) echo 4096 ;;
  esac
}

# Executions per target in a seeded run: ~SECONDS_PER_TARGET at the idle-machine rates of the CI runs (exec/s).
runs_for() {
  local rate
  case $1 in
    robot_yaml) rate=2400 ;; recording_csv) rate=9300 ;; environment_yaml) rate=1250 ;; query_yaml) rate=3300 ;;
    import) rate=9200 ;; nifti) rate=8300 ;; *) rate=1000 ;;
  esac
  echo $((rate * SECS))
}

run_one() {
  local t=$1 dir=$WORK/$1
  mkdir -p "$dir/corpus" "$dir/artifacts"
  cp tests/fuzz/corpus/"$t"/* "$dir/corpus/"
  if [ -d tests/fuzz/regressions/"$t" ]; then cp tests/fuzz/regressions/"$t"/* "$dir/corpus/" 2>/dev/null || true; fi
  local dict=()
  if [ -f tests/fuzz/dict/"$t".dict ]; then dict=(-dict="$ROOT/tests/fuzz/dict/$t.dict"); fi
  local rc=0
  # CTR_FUZZ_SEED (CI sets 1): a fixed seed and a fixed number of runs per target (about SECONDS_PER_TARGET on an
  # idle machine) make the run reproducible, so CI fails only on findings that a developer run reproduces.
  local budget=(-max_total_time="$SECS")
  if [ -n "${CTR_FUZZ_SEED:-}" ]; then
    budget=(-seed="$CTR_FUZZ_SEED" -runs="$(runs_for "$t")" -max_total_time="$((SECS * 4))")
  fi
  (cd "$dir" && "$ROOT/$BUILD/tests/fuzz/fuzz_$t" "${dict[@]}" "${budget[@]}" -timeout=10 \
      -rss_limit_mb=2048 -malloc_limit_mb=2048 -max_len="$(max_len "$t")" -print_final_stats=1 \
      -artifact_prefix="$dir/artifacts/" corpus > "$dir/log" 2>&1) || rc=$?
  echo "$rc" > "$dir/rc"
}

pids=()
for t in $TARGETS; do
  run_one "$t" &
  pids+=($!)
  if [ "${#pids[@]}" -ge "$PARALLEL" ]; then
    wait "${pids[0]}"
    pids=("${pids[@]:1}")
  fi
done
for p in "${pids[@]}"; do wait "$p"; done

failed=0
printf '%-18s %12s %8s %8s %8s %8s  %s\n' target executions exec/s cov ft corpus result
for t in $TARGETS; do
  dir=$WORK/$t
  rc=$(cat "$dir/rc")
  done_line=$(grep -E '^#[0-9]+[[:space:]]+DONE' "$dir/log" | tail -1 || true)
  [ -n "$done_line" ] || done_line=$(grep -E '^#[0-9]+' "$dir/log" | tail -1 || true)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$dir/log" | tail -1)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<< "$done_line")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<< "$done_line")
  corp=$(sed -n 's/.* corp: \([0-9]*\/[0-9a-zA-Z]*\).*/\1/p' <<< "$done_line")
  artefacts=$(find "$dir/artifacts" -type f | sort)
  result=ok
  if [ "$rc" != 0 ] || [ -n "$artefacts" ]; then
    result="FAILED (exit $rc)"
    failed=1
  fi
  printf '%-18s %12s %8s %8s %8s %8s  %s\n' "$t" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" "$result"
  if [ "$result" != ok ]; then
    grep -E 'ERROR|SUMMARY|runtime error|Test unit written' "$dir/log" | head -20 | sed 's/^/    /' || true
    for a in $artefacts; do echo "    reproducer: $a   ($BUILD/tests/fuzz/fuzz_$t $a)"; done
    echo "    log: $dir/log"
  fi
done
if [ "$failed" != 0 ]; then
  echo "run-fuzzers: FAILED (run folder kept: $WORK)"
  exit 1
fi
[ -n "${CTR_FUZZ_WORK:-}" ] || rm -rf "$WORK"
echo "run-fuzzers: all targets ran ${SECS}s without findings"
