#!/usr/bin/env bash
# The test command: installs every dependency, checks the layers of lib/ (cmake/layers.txt), builds
# everything (with ssrfleet-mpi beside ssrfleet: -DSSRFLEET_MPI=ON), runs the default test suite (its
# "mpi" test runs mpirun -np 1, 2 and 4).
# The slow statistical checks carry the CTest label "long"; run them with: ctest --test-dir build -L long
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-debian.sh
bash scripts/check-layers.sh
bash scripts/build.sh -DSSRFLEET_MPI=ON
ctest --test-dir build -LE long --output-on-failure -j "$(nproc)"
