#!/usr/bin/env bash
# Installs the dependencies, builds everything, runs the test suite, installs the library and builds + runs the
# consumer project against the installed tree (proves find_package(ctr) + ctr::ctr).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${CTR_BUILD_DIR:-build}
JOBS=${CTR_JOBS:-$(nproc)}

scripts/install-deps.sh
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release
cmake --build "$BUILD" -j"$JOBS"
ctest --test-dir "$BUILD" --output-on-failure -j"$JOBS" --timeout 900

rm -rf "$BUILD/install" "$BUILD/consumer" "$BUILD/planning_app"
cmake --install "$BUILD" --prefix "$BUILD/install" > /dev/null
cmake -S tests/consumer -B "$BUILD/consumer" -DCMAKE_PREFIX_PATH="$PWD/$BUILD/install" > /dev/null
cmake --build "$BUILD/consumer" -j"$JOBS"
ctest --test-dir "$BUILD/consumer" --output-on-failure
"$BUILD/install/bin/ctr" --help > /dev/null
# The example application plans the intracardiac query through the installed package.
cmake -S examples/planning_app -B "$BUILD/planning_app" -DCMAKE_PREFIX_PATH="$PWD/$BUILD/install" > /dev/null
cmake --build "$BUILD/planning_app" -j"$JOBS"
"$BUILD/planning_app/planning_app" examples/queries/proc_intracardiac.yaml
echo "run-tests: all passed"
