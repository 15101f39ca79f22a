#!/bin/sh
# Builds and runs the concealed-case evaluation of `ctr diagnose`; writes the Markdown tables to $2 (default
# build-diag/diagnosis_evaluation.md). Usage: scripts/evaluate_diagnosis.sh [--quick|--calibrate] [OUT.md]
set -e
here=$(cd "$(dirname "$0")/.." && pwd)
build=${CTR_BUILD_DIR:-$here/build-diag}
mode=${1:-}
out=${2:-$build/diagnosis_evaluation.md}
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j2 --target ctr_evaluate_diagnosis
"$build/apps/ctr_evaluate_diagnosis" $mode --out "$out"
echo "wrote $out"
