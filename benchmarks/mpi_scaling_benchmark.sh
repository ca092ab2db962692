#!/usr/bin/env bash
# Scale-out on MPI, measured (docs/sites.md). One joint fit of three
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
# One figure of a variant's last summary line from fit: field VARIANT 'REGEX with one (group)'.
field() { grep -h "rank(s) x" "$1.$reps.err" | tail -1 | sed -nE "s/$2/\1/p"; }
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
  echo "| variant | wall s (median) | speed-up over one | ms per record | tables s (rank 0) | tables s per rank | truck stages with moves s | final sweeps s | truck stages without moves, ms each | rank 0 sent bytes | collectives |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
  base=""
  for variant in one threads ranks; do
    times=()
    for ((r = 1; r <= reps; ++r)); do times+=("${wall[$variant.$r]}"); done
    m=$(median "${times[@]}")
    [[ -n $base ]] || base=$m
    tables=$(field "$variant" '.*of which tables ([0-9.]+) s.*')
    moved=$(field "$variant" '.*sweeps in all ([0-9.]+) s.*')
    final=$(field "$variant" '.*final sweeps ([0-9.]+) s.*')
    plain=$(field "$variant" '.* s, ([0-9.]+) ms each.*')
    per_rank=$(field "$variant" '.*tables per rank ([0-9.]+ to [0-9.]+) s.*')
    bytes=$(field "$variant" '.*rank 0 sent ([0-9]+) bytes.*')
    calls=$(field "$variant" '.*bytes in ([0-9]+) collectives.*')
    printf '| %s | %.1f | %.2f | %.2f | %s | %s | %s | %s | %s | %s | %s |\n' "$variant" "$m" "$(calc "$base / $m")" \
      "$(calc "1000 * $m / $records")" "$tables" "${per_rank:--}" "$moved" "$final" "$plain" "${bytes:--}" "${calls:--}"
    if [[ $variant == ranks ]]; then
      echo
      printf 'Traffic of rank 0 with 2 ranks: %.0f bytes and %.2f collectives per record (%s bytes in %s calls).\n' \
        "$(calc "$bytes / $records")" "$(calc "$calls / $records")" "$bytes" "$calls"
    fi
  done
  # The projection (docs/sites.md), from the figures above: per record, the work that
  # splits over R ranks (tables, stages with moves, final sweeps, each truck's own stage but its
  # reweighting, of the one-thread run), the work that does not (the rest of that run), and the
  # collectives at R ranks, each costed as a tree of ceil(log2 R) steps there and back:
  # 2 ceil(log2 R) (alpha + payload / beta), with rank 0's calls and bytes per record at 2 ranks.
  # Network: HDR InfiniBand, beta = 25 GB/s (200 Gb/s per port) and an MPI latency alpha = 2 us
  # per step (the ConnectX-6 adapter's quoted sub-0.6 us, times 3 for switches and the MPI stack:
  # an assumption, not a measurement).
  # A truck's own stage splits too (each rank its slice of the particles) but for its reweighting:
  # with p1 its time on one thread and p2 on 2 ranks, p2 = s + (p1 - s) / 2 gives the serial part
  # s = 2 p2 - p1 (an overestimate: p2 includes the collectives).
  p2=$(field ranks '.* s, ([0-9.]+) ms each.*')
  total_one=$(field one '.*thread\(s\): ([0-9.]+) s, of which.*')
  p1=$(field one '.* s, ([0-9.]+) ms each.*')
  plain_total=$(field one '.*without moves ([0-9.]+) s,.*')
  stage_serial=$(calc "(2 * $p2 - $p1 > 0 ? 2 * $p2 - $p1 : 0) / 1000")
  split_s=$(calc "$(field one '.*of which tables ([0-9.]+) s.*') + $(field one '.*sweeps in all ([0-9.]+) s.*') + $(field one '.*final sweeps ([0-9.]+) s.*') + $plain_total")
  par=$(calc "$split_s / $records - $stage_serial")
  ser=$(calc "$total_one / $records - $par")
  echo
  echo "## Projection: a 200-site, 20-million-record year (one thread per rank)"
  echo
  printf 'Per record, from the one-thread run: %.2f ms that split over the ranks, %.3f ms that do not\n' \
    "$(calc "1000 * $par")" "$(calc "1000 * $ser")"
  printf '(of which a truck stage'"'"'s serial part, %.3f ms = 2 x %s - %s ms, from its times on 2 ranks and on one thread).\n' \
    "$(calc "1000 * $stage_serial")" "$p2" "$p1"
  echo "Collectives at R ranks: calls and bytes per record as rank 0 sent them at 2 ranks, each a tree of"
  echo "ceil(log2 R) steps there and back; HDR InfiniBand, 25 GB/s, 2 us per step (an assumption)."
  echo
  echo "| ranks | split work s | serial work s | communication s | wall h | records/s | communication / split work |"
  echo "|---|---|---|---|---|---|---|"
  for R in 8 64 512; do
    steps=$(awk -v r="$R" 'BEGIN { s = 0; while (2^s < r) s++; print s }')
    awk -v n=20e6 -v r="$R" -v st="$steps" -v par="$par" -v ser="$ser" -v calls="$(calc "$calls / $records")" \
        -v bytes="$(calc "$bytes / $records")" 'BEGIN {
      split_s = n * par / r; serial_s = n * ser;
      comm_s = n * 2 * st * (calls * 2e-6 + bytes / 25e9);
      wall = split_s + serial_s + comm_s;
      printf "| %d | %.0f | %.0f | %.0f | %.2f | %.0f | %.2f |\n", r, split_s, serial_s, comm_s, wall / 3600, n / wall, comm_s / split_s }'
  done
  echo
  echo "fit's summary lines (last round):"
  echo
  echo '```'
  for variant in one threads ranks; do grep -h "rank(s) x" "$variant.$reps.err" | tail -1; done
  echo '```'
} > "$out"
cat "$out"
