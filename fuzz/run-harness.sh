#!/usr/bin/env bash
# Runs one libFuzzer harness for a given time over a copy of its seed corpus and prints one line:
#   <name>: <execs> execs in <wall> s (CPU <cpu> s), cov <cov>, ft <ft>, corpus <n> inputs, crashes <k>
# usage: fuzz/run-harness.sh FUZZER SEED_CORPUS_DIR WORK_DIR SECONDS
# The repository's corpus is never written: the run works in WORK_DIR/corpus (new inputs land there)
# and WORK_DIR/artifacts (crash-*, timeout-*, oom-*, leak-* files, each a reproducer:
# FUZZER WORK_DIR/artifacts/crash-...). Exit 0 only if the run ended with none of those (slow-unit-*
# files are listed, not failures).
# Limits per input: 10 s (a hang; FUZZ_TIMEOUT=N sets another), 1 GiB in one malloc or 2 GiB
# resident (an allocation from a small input that large is a bug). libFuzzer's
# timeout is wall time: a valid manifest that names two preset roads builds both sites, 3.2 s of CPU
# in this sanitized -O1 build, and passed 10 s on a loaded machine; site_manifest and stream_state
# (each input a resume) are run with FUZZ_TIMEOUT=60.
set -euo pipefail
fuzzer=$1 seeds=$2 work=$3 seconds=$4
name=$(basename "$fuzzer" _fuzzer)
rm -rf "$work"
mkdir -p "$work/corpus" "$work/artifacts"
cp -r "$seeds"/. "$work/corpus/"
# Inputs up to 64 KiB, or the largest seed (a stream state holds whole truck tables).
max_len=$(find "$seeds" -type f -printf '%s\n' | sort -n | tail -1)
(( max_len < 65536 )) && max_len=65536
start=$SECONDS
# -max_total_time is wall time: on a shared machine the harness gets less CPU than that, so the CPU
# seconds it used (user + system, bash's `time`) are reported beside it.
TIMEFORMAT='%U %S'
# A crash or a timeout makes the fuzzer exit non-zero: caught here (set -e would otherwise end
# the script before the summary and the artifacts below are printed).
{ time { status=0; "$fuzzer" "$work/corpus" -max_total_time="$seconds" -print_final_stats=1 -timeout="${FUZZ_TIMEOUT:-10}" \
  -malloc_limit_mb=1024 -rss_limit_mb=2048 -max_len="$max_len" -artifact_prefix="$work/artifacts/" \
  >"$work/log.txt" 2>&1 || status=$?; echo "$status" > "$work/status"; }; } 2> "$work/cpu.txt"
status=$(cat "$work/status")
took=$((SECONDS - start))
cpu=$(awk '{printf "%.0f", $1 + $2}' "$work/cpu.txt")
stat() { grep -E "^stat::$1:" "$work/log.txt" | tail -1 | awk '{print $2}'; }
cov=$(grep -E '#[0-9]+.*cov: ' "$work/log.txt" | tail -1 | sed -E 's/.*cov: ([0-9]+).*/\1/' || true)
ft=$(grep -E '#[0-9]+.*ft: ' "$work/log.txt" | tail -1 | sed -E 's/.*ft: ([0-9]+).*/\1/' || true)
# libFuzzer also writes slow-unit-* files: inputs that ran past 10 s of wall time but within the
# limit. They are not failures (under load a valid two-site manifest takes that long at 1/4 of a
# core) and are listed apart; every other artifact is one.
crashes=$(find "$work/artifacts" -type f ! -name 'slow-unit-*' | wc -l)
slow=$(find "$work/artifacts" -type f -name 'slow-unit-*' | wc -l)
echo "$name: $(stat number_of_executed_units) execs in ${took} s (CPU ${cpu} s), cov ${cov:-?}, ft ${ft:-?}," \
     "corpus $(find "$work/corpus" -type f | wc -l) inputs, crashes $crashes (log $work/log.txt)"
if [[ $slow -gt 0 ]]; then
  echo "  $slow slow units (not failures; slowest $(stat slowest_unit_time_sec) s of wall time, limit ${FUZZ_TIMEOUT:-10} s):"
  find "$work/artifacts" -type f -name 'slow-unit-*' | sed 's/^/    /'
fi
if [[ $crashes -gt 0 || $status -ne 0 ]]; then
  find "$work/artifacts" -type f ! -name 'slow-unit-*' | sed 's/^/  artifact: /'
  grep -E "ERROR: |SUMMARY: |runtime error" "$work/log.txt" | head -5 | sed 's/^/  /'
  exit 1
fi
