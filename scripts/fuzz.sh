#!/usr/bin/env bash
# The fuzz campaign (CONTRIBUTING.md): configures build-fuzz/ with clang and
# libFuzzer (-DSSRFLEET_FUZZ=ON: ASan + UBSan, coverage instrumentation), builds every harness of
# fuzz/, then runs each in turn for SECONDS (default 60) over a copy of its seed corpus, printing per
# harness the executions, coverage (cov: edges, ft: features, from -print_final_stats=1) and crashes.
#   scripts/fuzz.sh            60 s each (what CTest's label "fuzz" runs)
#   scripts/fuzz.sh 3600       the one-CPU-hour campaign per harness
#   scripts/fuzz.sh 300 crg    only the harnesses named
# Runs land in build-fuzz/fuzz-runs/<name>/ (corpus grown by the run, artifacts/ with any crash and
# its reproducer, log.txt). Exit 1 if any harness found something. Niced: the machine is shared.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:-60}
shift || true
build=$root/build-fuzz
command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ not found (Debian: apt-get install clang)" >&2; exit 1; }
CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DSSRFLEET_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" \
  -DSSRFLEET_BUILD_TESTS=OFF -DSSRFLEET_BUILD_BENCHMARKS=OFF >/dev/null
names=("$@")
if [[ ${#names[@]} -eq 0 ]]; then
  # The list in fuzz/CMakeLists.txt, comments dropped first (they hold parentheses too).
  names=($(sed -E 's/#.*//' "$root/fuzz/CMakeLists.txt" | sed -n '/^set(SSRFLEET_FUZZERS/,/)/p' |
    sed -E 's/set\(SSRFLEET_FUZZERS//; s/\)//' | tr -s ' \n' ' '))
fi
targets=()
for n in "${names[@]}"; do targets+=("${n}_fuzzer"); done
nice -n 5 cmake --build "$build" -j2 --target "${targets[@]}"
failed=0
for n in "${names[@]}"; do
  # Inputs that build sites take seconds here (fuzz/run-harness.sh): a longer limit per input.
  case $n in site_manifest | stream_state) limit=60 ;; *) limit=10 ;; esac
  FUZZ_TIMEOUT=$limit nice -n 5 bash "$root/fuzz/run-harness.sh" "$build/fuzz/${n}_fuzzer" "$root/fuzz/corpus/$n" \
    "$build/fuzz-runs/$n" "$seconds" || failed=1
done
exit $failed
