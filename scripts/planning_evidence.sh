#!/usr/bin/env bash
# Why friction-aware planning matters, measured: plans every example query in frictionless, robust and exact mode
# (several seeds), replays each path on the friction model and tabulates planner successes and replay failures.
# Time limits are CPU seconds of each planning process (`ctr plan --cpu-time`), so the table does not depend on
# what else the machine runs; JOBS runs that many plans at once.
# Usage: [JOBS=2] [OUT=/tmp/ctr_evidence] scripts/planning_evidence.sh [BUILD_DIR] [SEEDS] [TIME]
#   -> markdown on stdout, one JSON per run in $OUT
set -uo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
SEEDS=${2:-3}
TIME=${3:-20}
JOBS=${JOBS:-1}
OUT=${OUT:-/tmp/ctr_evidence}
mkdir -p "$OUT"
CTR="$BUILD/apps/ctr"
# 1. All runs (query x mode x seed), JOBS at a time.
for q in examples/queries/*.yaml; do
  for mode in frictionless robust exact; do
    for seed in $(seq 1 "$SEEDS"); do echo "$q $mode $seed"; done
  done
done | xargs -P "$JOBS" -L 1 bash -c '
  n=$(basename "$0" .yaml)
  "'"$CTR"'" plan "$0" --mode "$1" --seed "$2" --time "'"$TIME"'" --cpu-time --json "'"$OUT"'/${n}_$1_$2.json" \
    > /dev/null 2> "'"$OUT"'/${n}_$1_$2.err" || true'
# 2. The table.
python3 - "$OUT" "$SEEDS" <<'PY'
import glob, json, os, sys
out, seeds = sys.argv[1], int(sys.argv[2])
print("| query | mode | planner solved | replay solved | replays with collisions | replays with snaps | goal missed (no collision) | median planning time, solved runs (CPU s) | mean min clearance (mm) |")
print("|---|---|---|---|---|---|---|---|---|")
for q in sorted(glob.glob("examples/queries/*.yaml")):
    n = os.path.basename(q)[:-5]
    for mode in ("frictionless", "robust", "exact"):
        ps = rs = col = snap = miss = 0; times = []; clear = []; errors = 0
        for s in range(1, seeds + 1):
            f = f"{out}/{n}_{mode}_{s}.json"
            if not os.path.exists(f):
                errors += 1
                continue
            d = json.load(open(f)); r = d["replay"]
            p = bool(d["planner_solved"])
            ps += p; rs += bool(d["solved"])
            if p:
                col += r["collisions"] > 0; snap += r["snaps"] > 0
                miss += bool(r["completed"] and not r["goal_reached"] and r["collisions"] == 0)
                times.append(d["planning_time"]); clear.append(1000 * r["min_clearance"])
        times.sort()
        med = f"{times[len(times) // 2]:.1f}" if times else "–"
        mc = f"{sum(clear) / len(clear):.2f}" if clear else "–"
        note = f" ({errors} runs without result)" if errors else ""
        print(f"| {n} | {mode} | {ps}/{seeds} | {rs}/{seeds}{note} | {col} | {snap} | {miss} | {med} | {mc} |")
PY
