#!/usr/bin/env bash
# The Slurm path of the benchmark campaigns, for real: starts a single-node Slurm cluster on localhost (scripts/slurm-local.sh),
# submits the tiny campaign as a job array of 3 shards plus the dependent merge job (examples/slurm/submit.sh),
# waits, and checks that every run is present exactly once, the shards ran as distinct array tasks, and the
# database opens with the expected runs per planner. The daemons are stopped at the end, also on failure. Where the
# cluster cannot start, the test fails with the reason (no skip).
# Usage: slurm_campaign.sh CTR SOURCE_DIR WORK_DIR
set -euo pipefail
ctr=$1
src=$2
work=$3
state=$work/cluster
campaign=$src/examples/campaigns/intracardiac_tiny.yaml
out=$work/out
t0=$(date +%s)
rm -rf "$work"
mkdir -p "$work"
export CTR_SLURM_PORT=${CTR_SLURM_PORT:-16837}
stop() { "$src/scripts/slurm-local.sh" stop "$state" > /dev/null 2>&1 || true; }
trap stop EXIT
fail() {
  echo "FAIL: $*" >&2
  for f in "$out"/slurm/*.out; do [ -f "$f" ] && { echo "--- $f" >&2; tail -n 20 "$f" >&2; }; done
  [ -f "$state/slurmctld.log" ] && { echo "--- slurmctld.log" >&2; tail -n 20 "$state/slurmctld.log" >&2; }
  exit 1
}
"$src/scripts/slurm-local.sh" start "$state" || fail "the local Slurm cluster did not start (reason above)"
export SLURM_CONF=$state/slurm.conf
up=$(date +%s)
CTR=$ctr WAIT=1 timeout 240 "$src/examples/slurm/submit.sh" "$campaign" "$out" 3 ||
  fail "the job array or its merge job failed (sacct is not configured; job outputs below)"
done_t=$(date +%s)
# Three shards, each run by its own array task.
for i in 0 1 2; do
  [ -f "$out/shards/shard-$i-of-3.json" ] || fail "shard $i/3 left no record"
done
n_out=$(ls "$out"/slurm/shard-*_*.out | wc -l)
[ "$n_out" = 3 ] || fail "$n_out array task outputs, expected 3"
/usr/bin/python3 - "$out" <<'PY' || fail "the merged campaign is not as expected"
import json, sqlite3, sys, collections
out = sys.argv[1]
s = json.load(open(f"{out}/merged/summary.json"))
assert s["complete"], "summary says incomplete"
assert s["runs"] == 6 and s["expected_runs"] == 6, (s["runs"], s["expected_runs"])
keys = collections.Counter((r["planner"], r["seed"], r["run"]) for r in s["run_outcomes"])
want = {(p, seed, 0) for p in ("kpiece", "rrt") for seed in (1, 2, 3)}
assert set(keys) == want and all(v == 1 for v in keys.values()), keys
shards = [json.load(open(f"{out}/shards/shard-{i}-of-3.json")) for i in range(3)]
units = [u for sh in shards for u in sh["units_run"]]
assert len(units) == 6 and len(set(units)) == 6, units
db = sqlite3.connect(f"file:{out}/merged/benchmark.db?mode=ro", uri=True)
per = dict(db.execute("select p.name, count(*) from runs r join plannerConfigs p on r.plannerid = p.id group by p.name"))
assert per == {"control_KPIECE1": 3, "control_RRT": 3}, per
seeds = sorted(r[0] for r in db.execute("select seed from runs"))
assert seeds == [1, 1, 2, 2, 3, 3], seeds
exps = [r[0] for r in db.execute("select name from experiments")]
assert exps == ["proc_intracardiac_exact"], exps
print("database:", per, "experiments:", exps)
PY
echo "slurm campaign: cluster up in $((up - t0)) s, array + merge in $((done_t - up)) s, total $(($(date +%s) - t0)) s"
echo PASS
