#!/usr/bin/env bash
# The main job: installs only what the `ssrfleet` command needs (scripts/setup-debian.sh --main),
# builds that command alone into build/ (no tests, benchmarks or ssrfleet-mpi), and reproduces the
# paper's theoretical test end to end (figure data, PNG/SVG plots, summary.md) into out/reproduce.
# It prints the time each part took. scripts/test.sh later configures the same build/ with the
# tests and benchmarks on and reuses the library objects built here.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS=0
bash scripts/setup-debian.sh --main
setup_s=$SECONDS
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSSRFLEET_WERROR=ON \
  -DSSRFLEET_BUILD_TESTS=OFF -DSSRFLEET_BUILD_BENCHMARKS=OFF -DSSRFLEET_MPI=OFF >/dev/null
cmake --build build -j "$(nproc)" --target ssrfleet
build_s=$((SECONDS - setup_s))
mkdir -p out
./build/ssrfleet reproduce --out out/reproduce
reproduce_s=$((SECONDS - setup_s - build_s))
echo "wrote out/reproduce (summary.md, figure CSVs, plots)" >&2
echo "main job: setup ${setup_s} s, build ${build_s} s, reproduce ${reproduce_s} s, total ${SECONDS} s" >&2
