#!/usr/bin/env bash
# A stream's memory under a limit (docs/streaming.md): `ssrfleet stream` over the same log twice, side
# by side, each in its own cgroup-v1 memory limit: the default (tables, truck data and ids in spill
# files the kernel pages) and --tables-in-memory. Needs root and /sys/fs/cgroup/memory.
# Usage: benchmarks/stream_cgroup_demo.sh BINARY LOG LIMIT_MB   (in a scratch directory)
set -u
bin=$1 log=$2 limit=$3 pids=""
for mode in spilled memory; do
  cg=/sys/fs/cgroup/memory/ssrfleet-$mode
  rmdir $cg 2>/dev/null; mkdir -p $cg
  echo $((limit * 1024 * 1024)) > $cg/memory.limit_in_bytes
  echo $((limit * 1024 * 1024)) > $cg/memory.memsw.limit_in_bytes 2>/dev/null
  extra=""; [[ $mode == memory ]] && extra="--tables-in-memory"
  rm -rf cg-$mode
  ( echo $BASHPID > $cg/cgroup.procs; exec "$bin" stream --state cg-$mode --input "$log" --quiet --threads 1 $extra ) > cg-$mode.out 2> cg-$mode.err &
  pids="$pids $!"
done
for p in $pids; do wait $p; echo "pid $p exit $?"; done
for mode in spilled memory; do
  cg=/sys/fs/cgroup/memory/ssrfleet-$mode
  echo "$mode: max_usage $(( $(cat $cg/memory.max_usage_in_bytes) / 1048576 )) MB, failcnt $(cat $cg/memory.failcnt), oom_kill $(awk '$1 == "oom_kill" {print $2}' $cg/memory.oom_control)"
  tail -n 1 cg-$mode.err
done
