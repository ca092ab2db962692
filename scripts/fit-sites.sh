#!/usr/bin/env bash
# Fits every site of a manifest alone, several at once on one machine with GNU parallel, and
# collects their posteriors into one table (docs/sites.md).
#   scripts/fit-sites.sh MANIFEST OUTDIR [fit options...]
# writes OUTDIR/NAME.json per site (ssrfleet fit --sites MANIFEST --site NAME), OUTDIR/NAME.log
# (its progress) and OUTDIR/sites.csv (ssrfleet sites --collect). The fit options are passed to
# every fit (for example --particles 2048 --seed 7 --m1 450). Environment: SSRFLEET (the binary,
# default build/ssrfleet beside this script), JOBS (fits at once, default: the cores / 2, since each
# fit uses 2 threads; at least 1), THREADS (threads per fit, default 2).
# Exit status: 0 if every site was fitted and collected; the `sites` check's status if the manifest
# is bad (no fit starts then); 1 if a fit failed (each failed site named on standard error with the
# last line of its log); the collect step's status if that fails.
set -euo pipefail
if [[ $# -lt 2 ]]; then
  echo "usage: scripts/fit-sites.sh MANIFEST OUTDIR [fit options...]" >&2
  exit 64
fi
manifest=$1 outdir=$2
shift 2
root=$(cd "$(dirname "$0")/.." && pwd)
bin=${SSRFLEET:-$root/build/ssrfleet}
threads=${THREADS:-2}
jobs=${JOBS:-$(( $(nproc) / threads ))}
(( jobs >= 1 )) || jobs=1
command -v parallel >/dev/null || { echo "fit-sites.sh: GNU parallel not found (Debian: apt-get install parallel; scripts/setup-debian.sh installs it)" >&2; exit 69; }
[[ -x $bin ]] || { echo "fit-sites.sh: no ssrfleet binary at $bin (build it, or set SSRFLEET)" >&2; exit 69; }
mkdir -p "$outdir"
# The vehicle constants among the fit options: `sites` needs them too, since they are part of
# every site's fingerprint, which --collect checks each posterior against.
constants=()
args=("$@")
for ((i = 0; i < ${#args[@]}; ++i)); do
  case ${args[i]} in
    --m1 | --cb | --ct | --envelopment) constants+=("${args[i]}" "${args[i + 1]:-}"); ((++i)) ;;
    --m1=* | --cb=* | --ct=* | --envelopment=*) constants+=("${args[i]}") ;;
  esac
done
# The manifest is checked first (every site's road, sensors and log), so a bad entry stops the run
# before any fit starts.
"$bin" sites "$manifest" --quiet "${constants[@]}" --out "$outdir/sites-checked.csv"
mapfile -t names < <("$bin" sites "$manifest" --names)
echo "fit-sites.sh: ${#names[@]} sites, $jobs at once, $threads threads each -> $outdir" >&2
# A posterior left by an earlier run must not pass for this run's.
for name in "${names[@]}"; do rm -f "$outdir/$name.json"; done
# The command line parallel runs through the shell: every piece quoted with %q. Site names are
# safe as they stand (A-Z a-z 0-9 _ . -, the manifest's rule).
fit_args=""
(( $# )) && fit_args=$(printf ' %q' "$@")
bin_q=$(printf '%q' "$bin") manifest_q=$(printf '%q' "$manifest") outdir_q=$(printf '%q' "$outdir")
printf '%s\n' "${names[@]}" |
  parallel --jobs "$jobs" --halt never --joblog "$outdir/joblog.tsv" \
    "$bin_q fit --sites $manifest_q --site {} --threads $threads --out $outdir_q/{}.json$fit_args > $outdir_q/{}.log 2>&1" ||
  true
failed=()
for name in "${names[@]}"; do [[ -s $outdir/$name.json ]] || failed+=("$name"); done
if (( ${#failed[@]} )); then
  echo "fit-sites.sh: ${#failed[@]} of ${#names[@]} fits failed:" >&2
  for name in "${failed[@]}"; do echo "  $name: $(tail -1 "$outdir/$name.log") (log $outdir/$name.log)" >&2; done
  exit 1
fi
"$bin" sites "$manifest" --collect "$outdir" "${constants[@]}" --out "$outdir/sites.csv"
echo "fit-sites.sh: posteriors collected in $outdir/sites.csv" >&2
