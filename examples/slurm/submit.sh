#!/usr/bin/env bash
# Submits a campaign as a Slurm job array of N shards plus a merge job that runs when every shard succeeded.
# Usage: examples/slurm/submit.sh CAMPAIGN.yaml OUT_DIR N [extra sbatch options, e.g. --partition=cpu]
# Environment: CTR (the ctr executable, passed to the jobs), WAIT=1 to block until the merge job has finished
# (its exit code becomes this script's).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
campaign=${1:?usage: submit.sh CAMPAIGN.yaml OUT_DIR N [sbatch options]}
out=${2:?usage: submit.sh CAMPAIGN.yaml OUT_DIR N [sbatch options]}
n=${3:?usage: submit.sh CAMPAIGN.yaml OUT_DIR N [sbatch options]}
shift 3
mkdir -p "$out/slurm"
export CTR=${CTR:-$(command -v ctr || echo ctr)}
array=$(sbatch --parsable --export=ALL --array=0-$((n - 1)) --output="$out/slurm/shard-%A_%a.out" "$@" \
  "$here/campaign.sbatch" "$campaign" "$out")
array=${array%%;*}
echo "array job $array: $n shards of $campaign -> $out"
wait_flag=()
[ "${WAIT:-0}" = 1 ] && wait_flag=(--wait)
merge=$(sbatch --parsable --export=ALL --dependency=afterok:"$array" --kill-on-invalid-dep=yes \
  --output="$out/slurm/merge-%j.out" "${wait_flag[@]}" "$@" "$here/merge.sbatch" "$out")
echo "merge job ${merge%%;*} (after $array): $out/merged/benchmark.db"
