#!/usr/bin/env bash
# The README's main-job command: installs dependencies, builds, runs the main job.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-debian.sh
bash scripts/build.sh
mkdir -p out
./build/ssrfleet simulate --road AS1 --trucks 100 --seed 1 --out out/wim_as1.csv
echo "wrote out/wim_as1.csv" >&2
