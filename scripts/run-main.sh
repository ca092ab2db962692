#!/usr/bin/env bash
# The README's main-job command: installs dependencies, builds, and reproduces the paper's
# theoretical test end to end (figure data, PNG/SVG plots, summary.md) into out/reproduce.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-debian.sh
bash scripts/build.sh
mkdir -p out
./build/ssrfleet reproduce --out out/reproduce
echo "wrote out/reproduce (summary.md, figure CSVs, plots)" >&2
