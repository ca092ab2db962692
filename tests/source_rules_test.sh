#!/usr/bin/env bash
# Fails when the sources break three of the project's rules (CONTRIBUTING.md), printing FILE:LINE:
#   - no file of lib/ is over 500 lines: a longer file holds more than one job, split it by concern;
#   - no comment or message cites the tracker: an issue number or an issue's item says nothing to
#     a reader of the code, who needs the reason itself;
#   - no code outside the inference folder (lib/fleet, and its own tests tests/fleet_*) asks a fit
#     for its core, as in `fit->marginal()` or `online.latent()`: the rule for choosing a core is
#     fleet::choose_core, and what a caller needs of a fit is an OnlineFit method, or
#     fleet::visit_core where only one core can give it. A MarginalTarget's `target.marginal()` (its
#     fleet marginal, not a core) is not such a call.
#
#   tests/source_rules_test.sh [ROOT]       check ROOT (default: this repository)
#   tests/source_rules_test.sh --self-test  plant each kind of break in a scratch tree and expect it
#                                           reported (and a clean tree to pass)
#
# Dated records under benchmarks/results/ and the changelog keep their history and are not checked.
# The patterns are written in pieces so that this file does not match itself.
set -euo pipefail

self="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/$(basename "${BASH_SOURCE[0]}")"
max_lines=500
# An item is cited as "item 5:", "(item 5)", "items 2 and 4," or "item 5 of": a number in prose
# ("2 items per node", "items 3 to 5") is not a citation.
cite_pattern='([Ii]ss''ue #?[0-9]+|(^|[^A-Za-z_-])[Ii]te''ms? [0-9]+( and [0-9]+)?([):;,]| of |$))'
# A call of latent() or marginal() through . or ->; a MarginalTarget's (target.marginal(),
# target_.marginal(), target().marginal()) is taken out of the line before it is matched.
core_pattern='(\.|->)(late''nt|margi''nal)\(\)'
target_pattern='(^|[^A-Za-z0-9_])target_?(\(\))?(\.|->)margi''nal\(\)'

check() {
  local root="$1" report file n
  [ -d "$root" ] || { echo "source rules: no directory $root" >&2; return 2; }
  root="$(cd "$root" && pwd)"
  report="$(mktemp)"
  while IFS= read -r -d '' file; do
    n="$(wc -l <"$root/$file")"
    if [ "$n" -gt "$max_lines" ]; then
      echo "$file:$n: [over $max_lines lines] split it by concern" >>"$report"
    fi
  done < <(cd "$root" && find lib -type f \( -name '*.cpp' -o -name '*.hpp' \) -print0 2>/dev/null | sort -z)
  local me="${self#"$root"/}"
  while IFS= read -r -d '' file; do
    [ "$file" = "$me" ] && continue
    { grep -n -H -E -e "$cite_pattern" "$root/$file" || true; } | while IFS= read -r line; do
      line="${line#"$root"/}"
      file="${line%%:*}" && line="${line#*:}"
      echo "$file:${line%%:*}: [cites the tracker, not the reason] ${line#*:}"
    done >>"$report"
  done < <(cd "$root" && find lib bin tests benchmarks python fuzz scripts web .ci cmake -maxdepth 4 -type f \
             \( -name '*.cpp' -o -name '*.hpp' -o -name '*.py' -o -name '*.sh' -o -name '*.js' -o -name '*.html' \
                -o -name 'CMakeLists.txt' -o -name '*.cmake' -o -name 'run' \) -not -path 'benchmarks/results/*' \
             -print0 2>/dev/null | sort -z)
  while IFS= read -r -d '' file; do
    case "$file" in lib/fleet/* | tests/fleet_*) continue ;; esac
    { grep -n -E -e "$core_pattern" "$root/$file" || true; } | while IFS= read -r line; do
      sed -E "s/$target_pattern/\1/g" <<<"${line#*:}" | grep -q -E -e "$core_pattern" || continue
      echo "$file:${line%%:*}: [asks a fit for its core outside lib/fleet] ${line#*:}"
    done >>"$report"
  done < <(cd "$root" && find lib bin tests benchmarks python fuzz -type f \( -name '*.cpp' -o -name '*.hpp' \) \
             -print0 2>/dev/null | sort -z)
  if [ -s "$report" ]; then
    sort -t: -k1,1 -k2,2n -u "$report"
    echo "source rules: FAILED: $(wc -l <"$report") line(s) above (FILE:LINE)." >&2
    rm -f "$report"
    return 1
  fi
  rm -f "$report"
  echo "source rules: every lib file at most $max_lines lines; no comment cites the tracker; no fit is asked for its core outside lib/fleet"
}

self_test() {
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  mkdir -p "$tmp/tree/lib/x" "$tmp/tree/tests" "$tmp/tree/benchmarks/results"
  seq 1 "$max_lines" | sed 's|^|// line |' >"$tmp/tree/lib/x/full.cpp"
  printf '// Why: the tables hold 2 items per node (items 3 to 5 are spares).\n' >"$tmp/tree/lib/x/ok.hpp"
  printf '// version 1.2, the issue of scale\n' >"$tmp/tree/tests/ok_test.cpp"
  printf 'Measured for iss''ue 7.\n' >"$tmp/tree/benchmarks/results/2026-01-01-x.md"
  mkdir -p "$tmp/tree/lib/fleet" "$tmp/tree/bin"
  # The core's own folder and tests may reach it; a MarginalTarget's fleet marginal is no core.
  printf 'const MarginalSmc* m = fit.margi''nal();\n' >"$tmp/tree/lib/fleet/core.cpp"
  printf 'auto* m = fit->margi''nal();\n' >"$tmp/tree/tests/fleet_core_test.cpp"
  printf 'const auto& f = target.margi''nal();\nuse(target_.margi''nal(), target().margi''nal());\n' \
    >"$tmp/tree/lib/x/draws.cpp"
  printf 'int main() {}\n' >"$tmp/tree/bin/main.cpp"
  if ! check "$tmp/tree" >"$tmp/clean.out" 2>&1; then
    cat "$tmp/clean.out" >&2
    echo "source rules self-test: FAILED: the clean scratch tree does not pass" >&2
    return 1
  fi
  # Each plant: file|text appended|the FILE:LINE the report must name.
  local plants=(
    "lib/x/full.cpp|// one line too many|lib/x/full.cpp:$((max_lines + 1))"
    "lib/x/ok.hpp|// As iss""ue 41 asks.|lib/x/ok.hpp:2"
    "tests/ok_test.cpp|// (iss""ue #12)|tests/ok_test.cpp:2"
    "tests/CMakeLists.txt|# It""em 5 of the accuracy targets|tests/CMakeLists.txt:1"
    "lib/x/ok.hpp|// the window (it""ems 2 and 4)|lib/x/ok.hpp:2"
    "bin/main.cpp|if (const auto* m = smc->margi""nal()) use(m);|bin/main.cpp:2"
    "lib/x/draws.cpp|return posterior_draws(site, *f.online->late""nt());|lib/x/draws.cpp:3"
    "lib/x/draws.cpp|use(target.margi""nal(), online.margi""nal());|lib/x/draws.cpp:3"
  )
  local plant file text want
  for plant in "${plants[@]}"; do
    IFS='|' read -r file text want <<<"$plant"
    rm -rf "$tmp/work" && cp -R "$tmp/tree" "$tmp/work"
    printf '%s\n' "$text" >>"$tmp/work/$file"
    if check "$tmp/work" >"$tmp/plant.out" 2>&1; then
      echo "source rules self-test: FAILED: a planted '$text' in $file passed" >&2
      return 1
    fi
    if ! grep -q "^$want: " "$tmp/plant.out"; then
      cat "$tmp/plant.out" >&2
      echo "source rules self-test: FAILED: the report does not name $want for '$text'" >&2
      return 1
    fi
  done
  echo "source rules self-test: passed (a clean tree passes; ${#plants[@]} planted breaks each fail at their FILE:LINE)"
}

if [ "${1:-}" = "--self-test" ]; then
  self_test
else
  check "${1:-$(cd "$(dirname "$self")/.." && pwd)}"
fi
