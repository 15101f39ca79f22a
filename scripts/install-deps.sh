#!/usr/bin/env bash
# Idempotent dependency installer for Debian 12 (bookworm). apt packages only.
# Usage: scripts/install-deps.sh   (as root, or with sudo available)
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git ca-certificates
  libeigen3-dev
  libyaml-cpp-dev
  libcli11-dev
  nlohmann-json3-dev
  libompl-dev libboost-serialization-dev libboost-filesystem-dev libboost-system-dev libboost-program-options-dev
  libfcl-dev
  liboctomap-dev libdynamicedt3d-dev
  libceres-dev
  libpagmo-dev                    # the design search (pagmo::gaco)
  libnifti2-dev
  libassimp-dev
  libgtest-dev libgmock-dev
  libbenchmark-dev
  zlib1g-dev
  clang libclang-rt-14-dev llvm   # fuzzing (libFuzzer runtime) and the sanitizer build; llvm: llvm-symbolizer
  chromium fonts-liberation       # HTML report tests (headless Chromium)
  ompl-demos parallel munge slurmctld slurmd slurm-client   # benchmark campaigns: ompl_benchmark_statistics, GNU parallel, the local Slurm test
  python3-dev pybind11-dev python3-pybind11   # the `ctr` Python module (python/, CTR_BUILD_PYTHON)
  python3-numpy python3-matplotlib python3-pytest   # its tests and examples/python (Debian's /usr/bin/python3)
)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  SUDO="sudo"
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# HTML reports: Node.js + npm bundle the report scripts at build time (reports/web). Any node/npm on PATH will do
# (a NodeSource nodejs already ships npm and conflicts with Debian's npm package), else Debian's.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  missing+=(nodejs npm)
fi

if [ "${#missing[@]}" -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install-deps: done"
