#!/usr/bin/env bash
# Why friction-aware planning matters, measured: plans every example query in frictionless, robust and exact mode
# (several seeds), replays each path on the friction model and tabulates planner successes and replay failures.
# Usage: scripts/planning_evidence.sh [BUILD_DIR] [SEEDS] [TIME]   -> markdown on stdout, JSON in $OUT (default /tmp/ctr_evidence)
set -uo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
SEEDS=${2:-3}
TIME=${3:-20}
OUT=${OUT:-/tmp/ctr_evidence}
mkdir -p "$OUT"
CTR="$BUILD/apps/ctr"
echo "| query | mode | planner solved | replay solved | replay collisions | replay snaps | goal missed | mean planning time (s) | mean min clearance (mm) |"
echo "|---|---|---|---|---|---|---|---|---|"
for q in examples/queries/*.yaml; do
  n=$(basename "$q" .yaml)
  for mode in frictionless robust exact; do
    ps=0; rs=0; col=0; snap=0; miss=0; t=0; c=0
    for seed in $(seq 1 "$SEEDS"); do
      j="$OUT/${n}_${mode}_${seed}.json"
      "$CTR" plan "$q" --mode "$mode" --seed "$seed" --time "$TIME" --json "$j" > /dev/null 2> "$OUT/${n}_${mode}_${seed}.err"
      [ -f "$j" ] || continue
      read -r p r cf sn gr pt mc < <(python3 -c "
import json,sys
d=json.load(open('$j')); r=d['replay']
print(int(d['planner_solved']), int(d['solved']), int(d['planner_solved'] and r['collisions']>0), int(d['planner_solved'] and r['snaps']>0),
      int(d['planner_solved'] and r['completed'] and not r['goal_reached']), d['planning_time'], r['min_clearance'])")
      ps=$((ps+p)); rs=$((rs+r)); col=$((col+cf)); snap=$((snap+sn)); miss=$((miss+gr))
      t=$(python3 -c "print($t+$pt)"); c=$(python3 -c "print($c+($mc if $p else 0))")
    done
    mt=$(python3 -c "print(round($t/$SEEDS,2))"); mc=$(python3 -c "print(round(1000*$c/max($ps,1),2))")
    echo "| $n | $mode | $ps/$SEEDS | $rs/$SEEDS | $col | $snap | $miss | $mt | $mc |"
  done
done
