#!/usr/bin/env bash
# Scale-out on MPI (docs/sites.md; CTest label "mpi", registered when -DSSRFLEET_MPI=ON):
#   1. mpirun -np 1, 2 and 4 of ssrfleet-mpi fit --sites M write the very posterior file of the
#      single-process ssrfleet fit --sites M (byte for byte);
#   2. a run that loses a rank (kill -9 of one rank's process) after a checkpoint resumes on
#      another number of ranks (4) to that same file;
#   3. commands that do not spread over ranks, and fit --calibrate, refuse several ranks by name.
# usage: mpi_fit_test.sh SSRFLEET SSRFLEET_MPI
set -euo pipefail
single=$1
multi=$2
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1  # CI runs as root
# One machine, no network interfaces to probe: shared memory and loopback only.
export OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }

"$single" simulate --road AS1 --trucks 120 --seed 3 --quiet --out a.csv
"$single" simulate --road AS2 --sensors 70,2,8 --trucks 120 --seed 4 --quiet --out b.csv
cat > m.json <<'JSON'
{"sites": [{"name": "north", "road": "AS1", "sensors": "76,1.5,16", "log": "a.csv"},
           {"name": "south", "road": "AS2", "sensors": "70,2,8", "log": "b.csv"}]}
JSON
fit=(fit --sites m.json --particles 256 --threads 1 --seed 5 --quiet)
"$single" "${fit[@]}" --out single.json

for ranks in 1 2 4; do
  mpirun -np "$ranks" --oversubscribe "$multi" "${fit[@]}" --out "ranks$ranks.json"
  cmp -s single.json "ranks$ranks.json" || fail "$ranks rank(s): the posterior differs from the single-process build's"
  echo "ok: $ranks rank(s) give the single-process posterior byte for byte"
done

# A lost rank: 2 ranks checkpoint every 20 trucks; once a checkpoint exists, one rank is killed.
mkdir ckpt
mpirun -np 2 --oversubscribe "$multi" "${fit[@]}" --checkpoint ckpt --checkpoint-every-trucks 20 --out lost.json \
  > lost.out 2> lost.err &
job=$!
for _ in $(seq 1 600); do
  [[ -n $(ls ckpt 2>/dev/null) ]] && break
  sleep 0.05
done
[[ -n $(ls ckpt) ]] || fail "no checkpoint appeared"
# The rank processes (their command line starts with the binary; mpirun's does not); kill one.
victim=$(pgrep -f -- "^$multi fit --sites m.json" | tail -1)
[[ -n $victim ]] || fail "no rank process to kill"
kill -9 "$victim"
if wait "$job"; then fail "the job survived the loss of a rank"; fi
[[ ! -e lost.json ]] || fail "the fit finished before the rank was lost: make the log longer"
mpirun -np 4 --oversubscribe "$multi" fit --sites m.json --particles 256 --threads 1 --seed 5 --checkpoint ckpt \
  --out resumed.json 2> resumed.err
grep -q "resumed from" resumed.err || fail "the rerun did not resume from the checkpoint"
cmp -s single.json resumed.json || fail "the run resumed on 4 ranks differs from the straight single-process fit"
echo "ok: a run that lost a rank resumes on 4 ranks to the single-process posterior ($(grep -m1 'resumed from' resumed.err))"

# Commands other than fit refuse several ranks, by name.
if mpirun -np 2 --oversubscribe "$multi" predict --posterior single.json > /dev/null 2> refused.err; then
  fail "predict ran on 2 ranks"
fi
grep -q "only fit spreads over MPI ranks" refused.err || fail "predict on 2 ranks did not say why"
echo "ok: predict on 2 ranks is refused by name"

# fit --calibrate draws every truck's latents from its table, which one rank alone holds: refused.
status=0
mpirun -np 2 --oversubscribe "$multi" fit --sites m.json --calibrate --particles 256 --quiet --out cal.json \
  > /dev/null 2> calibrate.err || status=$?
[[ $status -eq 64 ]] || fail "fit --calibrate on 2 ranks exited $status, not 64"
grep -q "runs on one process" calibrate.err || fail "fit --calibrate on 2 ranks did not say why"
echo "ok: fit --calibrate on 2 ranks is refused by name"
