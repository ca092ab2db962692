#!/usr/bin/env bash
# The default test suite under AddressSanitizer and UndefinedBehaviorSanitizer (cmake --preset asan:
# -O1 -g1 into build-asan/, every report fatal, the portable SSE2 build of the batched integrator).
# .ci/run runs it after scripts/test.sh.
# The sanitizers slow this code 10-20 times, so the tests labelled "heavy" (4 s or more in Release:
# Monte Carlo checks of a posterior, end-to-end runs of many fits; see tests/CMakeLists.txt) are left
# out by the test preset asan, as are the "long" ones and the "timing" ones (a wall-clock deadline,
# meaningless in a build slowed 10-20 times). The code they drive runs sanitized in the
# lighter tests, bad input included: light tests refuse damaged checkpoints, histories, posterior
# files, road files and simulate's input (the fuzz harnesses of fuzz/ go further).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-debian.sh
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$(nproc)"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --preset asan -j "$(nproc)"
