#!/usr/bin/env bash
# Scale-out on MPI, measured (issue 21 item 4; README "Scale-out on MPI"). One joint fit of three
# sites (AS1 with 16 sensors, AS2 with 8, AS3 with 12; TRUCKS each) run side by side, REPS times in
# turn so a noisy shared machine hits every variant alike:
#   one    ssrfleet fit --sites, 1 process, 1 thread
#   threads  ssrfleet fit --sites, 1 process, 2 threads
#   ranks  mpirun -np 2 ssrfleet-mpi fit --sites, 2 ranks of 1 thread
# It checks the three posterior files are identical, and reports per variant the median wall
# time, its split (tables / stages and moves) from fit's summary line, the speed-up over `one`,
# the cost per record, the truck stages' serial part, and rank 0's traffic (bytes and collective
# calls, per record and per move phase). Needs a build with -DSSRFLEET_MPI=ON.
# usage: benchmarks/mpi_scaling_benchmark.sh [TRUCKS=1000] [REPS=2] [PARTICLES=1024] [OUT=benchmarks/results/mpi-scaling-2core.md]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
trucks=${1:-1000}
reps=${2:-2}
particles=${3:-1024}
out=${4:-$root/benchmarks/results/mpi-scaling-2core.md}
single=$root/build/ssrfleet
multi=$root/build/ssrfleet-mpi
[[ -x $multi ]] || { echo "mpi_scaling_benchmark: $multi missing: configure with -DSSRFLEET_MPI=ON" >&2; exit 1; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none
calc() { awk "BEGIN { printf \"%.6f\", $* }"; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
"$single" simulate --road AS1 --trucks "$trucks" --seed 11 --quiet --out a.csv
"$single" simulate --road AS2 --sensors 70,2,8 --trucks "$trucks" --seed 12 --quiet --out b.csv
"$single" simulate --road AS3 --sensors 76,1.5,12 --trucks "$trucks" --seed 13 --quiet --out c.csv
cat > m.json <<'JSON'
{"sites": [{"name": "AS1", "road": "AS1", "sensors": "76,1.5,16", "log": "a.csv"},
           {"name": "AS2", "road": "AS2", "sensors": "70,2,8", "log": "b.csv"},
           {"name": "AS3", "road": "AS3", "sensors": "76,1.5,12", "log": "c.csv"}]}
JSON
fit=(fit --sites m.json --particles "$particles" --seed 5)
started=$(date -u +%FT%TZ)
load_start=$(cut -d' ' -f1 /proc/loadavg)
declare -A wall
for ((r = 1; r <= reps; ++r)); do
  for variant in one threads ranks; do
    case $variant in
      one) cmd=("$single" "${fit[@]}" --threads 1) ;;
      threads) cmd=("$single" "${fit[@]}" --threads 2) ;;
      ranks) cmd=(mpirun -np 2 "$multi" "${fit[@]}" --threads 1) ;;
    esac
    t0=$(date +%s.%N)
    "${cmd[@]}" --out "$variant.json" 2> "$variant.$r.err"
    t1=$(date +%s.%N)
    wall[$variant.$r]=$(calc "$t1 - $t0")
    echo "rep $r $variant: ${wall[$variant.$r]} s" >&2
  done
  cmp -s one.json threads.json || { echo "2 threads gave another posterior" >&2; exit 1; }
  cmp -s one.json ranks.json || { echo "2 ranks gave another posterior" >&2; exit 1; }
done
load_end=$(cut -d' ' -f1 /proc/loadavg)
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }
records=$((3 * trucks))
{
  echo "# MPI scaling benchmark: a joint fit of three sites"
  echo
  echo "Sites AS1 (16 sensors), AS2 (8), AS3 (12), $trucks trucks each ($records records), Table 1 fleet;"
  echo "$particles particles, seed 5. \`benchmarks/mpi_scaling_benchmark.sh $trucks $reps $particles\`, commit"
  echo "$(git -C "$root" rev-parse --short HEAD)$(git -C "$root" diff --quiet || echo ' (with local changes)'), nproc $(nproc), 1-min load $load_start at start, $load_end at end;"
  echo "started $started, written $(date -u +%FT%TZ). $reps runs of each variant in turn; medians."
  echo "The three posterior files were byte-identical in every round."
  echo
  echo "| variant | wall s (median) | speed-up over one | ms per record | tables s | stages and moves s | move phases | truck stage without moves, ms | rank 0 sent | collectives |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  base=""
  for variant in one threads ranks; do
    times=()
    for ((r = 1; r <= reps; ++r)); do times+=("${wall[$variant.$r]}"); done
    m=$(median "${times[@]}")
    [[ -n $base ]] || base=$m
    line=$(grep -h "rank(s) x" "$variant.$reps.err" | tail -1)
    tables=$(sed -E 's/.*of which tables ([0-9.]+) s.*/\1/' <<< "$line")
    moves=$(sed -E 's/.*stages and moves ([0-9.-]+) s.*/\1/' <<< "$line")
    phases=$(sed -E 's/.*; ([0-9]+) move phases.*/\1/' <<< "$line")
    plain=$(sed -E 's/.*without moves, ([0-9.]+) ms each.*/\1/' <<< "$line")
    bytes="-"; calls="-"
    if grep -q "rank 0 sent" <<< "$line"; then
      bytes=$(sed -E 's/.*rank 0 sent ([0-9]+) bytes.*/\1/' <<< "$line")
      calls=$(sed -E 's/.*bytes in ([0-9]+) collectives.*/\1/' <<< "$line")
    fi
    printf '| %s | %.1f | %.2f | %.2f | %s | %s | %s | %s | %s | %s |\n' "$variant" "$m" "$(calc "$base / $m")" \
      "$(calc "1000 * $m / $records")" "$tables" "$moves" "$phases" "$plain" "$bytes" "$calls"
    if [[ $variant == ranks ]]; then
      echo
      printf 'Traffic of rank 0 with 2 ranks: %.0f bytes and %.1f collectives per record; %s bytes in %s calls over %s move phases.\n' \
        "$(calc "$bytes / $records")" "$(calc "$calls / $records")" "$bytes" "$calls" "$phases"
    fi
  done
  echo
  echo "fit's summary lines (last round):"
  echo
  echo '```'
  for variant in one threads ranks; do grep -h "rank(s) x" "$variant.$reps.err" | tail -1; done
  echo '```'
} > "$out"
cat "$out"
