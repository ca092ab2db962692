#!/usr/bin/env bash
# The default test suite under AddressSanitizer and UndefinedBehaviorSanitizer (cmake --preset asan:
# RelWithDebInfo into build-asan/, every report fatal). .ci/run runs it after scripts/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-debian.sh
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$(nproc)"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# Three diagnose tests run near or past their 600 s under the sanitizers (about 100-220 s in
# Release; the 6 % gain case took 587 s sanitized on a 2-core machine), so they are left out here;
# the diagnose code they drive still runs sanitized in the other diagnose tests. The two statistical
# checks of several sites (27 s each in Release: a joint posterior sharper than each site's, the
# site check naming the odd site) are left out for the same reason; the code of several sites still
# runs sanitized in their other tests (resume, refusals, a truck's ℓ to the bit, the CLI). So is the
# check that the pooled final sweeps cut the Monte Carlo error (16 fits, 36 s in Release); the pool
# itself runs sanitized in "the final sweeps' clouds are pooled". So is the EM's recovery of two
# sites' sensor gains (up to 8 fits of 160 trucks, 65 s in Release); the EM and its M-step run
# sanitized in the thread-count test and the CLI's --calibrate test. Four more statistical checks
# (24-53 s each in Release on a loaded 2-core machine) are left out so that the whole CI stays inside
# its 90 minutes: the evidence of three samplers compared (the table proposals still run sanitized in
# the latent-draw and proposal tests), the marginal core against the batch MCMC on 40 trucks (both
# run sanitized in many other tests), a diagnose's report at two thread counts (diagnose runs
# sanitized in the second-class and collapsed-cloud tests) and the tables' lateral check on AS1 and
# AS2 (the tables run sanitized in every marginal-core test); and R-hat over four long MCMC chains
# (the chains run sanitized in their thread-count test). Every other test of the default suite runs
# sanitized.
ctest --preset asan -j "$(nproc)" \
  -E "diagnose answers none on a 40-truck log with no effect|diagnose names two effects hidden at once|diagnose names a 6 % gain on sensor 9|a fit of three sites is sharper than each|of three sites, the one whose fleet differs|the pooled final sweeps estimate the posterior means|sensor calibration by Monte Carlo EM recovers|with table proposals the latent core estimates the evidence|the marginal core's posterior agrees with the exact batch MCMC on a small fleet|a diagnose's report does not depend on its thread count|the tables check their lateral approximation|MCMC chains that sample one posterior agree by R-hat"
