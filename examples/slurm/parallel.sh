#!/usr/bin/env bash
# Runs a campaign as N shards with GNU parallel (one machine, or several with parallel's --sshloginfile and a shared
# folder), then merges them.
# Usage: examples/slurm/parallel.sh CAMPAIGN.yaml OUT_DIR [N=number of CPUs] [JOBS=N]
# Environment: CTR = the ctr executable (default: ctr on PATH).
set -euo pipefail
campaign=${1:?usage: parallel.sh CAMPAIGN.yaml OUT_DIR [N] [JOBS]}
out=${2:?usage: parallel.sh CAMPAIGN.yaml OUT_DIR [N] [JOBS]}
n=${3:-$(nproc)}
jobs=${4:-$n}
ctr=${CTR:-ctr}
mkdir -p "$out"
# --halt now,fail=1: stop at the first failing shard; --joblog: what ran where and how long.
parallel --will-cite --jobs "$jobs" --halt now,fail=1 --joblog "$out/parallel.joblog" --line-buffer \
  "$ctr" bench "$campaign" --out "$out" --shard {}/"$n" ::: $(seq 0 $((n - 1)))
"$ctr" bench merge "$out" --out "$out/merged" --html "$out/merged/report.html"
