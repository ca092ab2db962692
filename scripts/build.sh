#!/usr/bin/env bash
# Configures and builds everything (Release: the command, the tests, the benchmarks) into build/.
# Extra arguments go to cmake's configure. The tests and benchmarks are switched on explicitly, so
# a build/ that scripts/run-main.sh configured for the command alone gets them back.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSSRFLEET_WERROR=ON \
  -DSSRFLEET_BUILD_TESTS=ON -DSSRFLEET_BUILD_BENCHMARKS=ON "$@" >/dev/null
cmake --build build -j "$(nproc)"
