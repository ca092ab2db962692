#!/usr/bin/env bash
# Fails on an #include that goes up a layer of lib/ (or sideways into a folder not on its line).
# The table is cmake/layers.txt, the same file CMakeLists.txt builds the per-folder libraries from.
#
#   scripts/check-layers.sh [ROOT]      check ROOT/lib against ROOT/cmake/layers.txt (ROOT: this repo)
#   scripts/check-layers.sh --self-test plant a forbidden include in a copy of lib/ and expect a failure
#
# Also fails when a folder of lib/ has no line in the table, when a line names an unknown folder,
# and when the table is not closed (a folder may use Y, Y may use Z, but Z is missing from the line):
# every line states the whole set, so nothing is allowed only indirectly.
set -euo pipefail

self="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/$(basename "${BASH_SOURCE[0]}")"

check() {
  local root="$1"
  local table="$root/cmake/layers.txt"
  [ -f "$table" ] || { echo "check-layers: no table at $table" >&2; return 2; }
  [ -d "$root/lib" ] || { echo "check-layers: no lib/ under $root" >&2; return 2; }

  declare -A allowed=()
  local line folder deps
  while IFS= read -r line || [ -n "$line" ]; do
    line="${line%%#*}"
    [[ "$line" =~ ^[[:space:]]*$ ]] && continue
    if [[ ! "$line" =~ ^[[:space:]]*([a-z_0-9]+):(.*)$ ]]; then
      echo "check-layers: $table: cannot read line '$line' (want 'folder: dep dep ...')" >&2
      return 2
    fi
    folder="${BASH_REMATCH[1]}"
    deps="$(echo ${BASH_REMATCH[2]})"  # squeeze whitespace
    allowed[$folder]=" $folder $deps "
  done <"$table"

  local status=0 d e dir
  # Every folder of lib/ has a row; every name on a row is a row; rows are closed.
  for dir in "$root"/lib/*/; do
    folder="$(basename "$dir")"
    if [ -z "${allowed[$folder]+x}" ]; then
      echo "check-layers: lib/$folder has no line in cmake/layers.txt: add one (a new folder takes the row of what it does: docs/ARCHITECTURE.md)" >&2
      status=1
    fi
  done
  for folder in "${!allowed[@]}"; do
    for d in ${allowed[$folder]}; do
      if [ -z "${allowed[$d]+x}" ]; then
        echo "check-layers: cmake/layers.txt: '$folder' names '$d', which has no line" >&2
        status=1
        continue
      fi
      for e in ${allowed[$d]}; do
        if [[ "${allowed[$folder]}" != *" $e "* ]]; then
          echo "check-layers: cmake/layers.txt: '$folder' may use '$d', which may use '$e', so '$folder' must name '$e' too" >&2
          status=1
        fi
      done
    done
  done

  # Every #include "a/b.hpp" (or <a/b.hpp>) whose first component is a folder of the table must
  # name an allowed folder. One awk pass over all sources; the table goes in as "folder=deps".
  local rows=() f
  for f in "${!allowed[@]}"; do rows+=("$f=${allowed[$f]}"); done
  local files=()
  mapfile -d '' files < <(find "$root/lib" -type f \( -name '*.hpp' -o -name '*.cpp' -o -name '*.h' -o -name '*.cc' \) -print0 | sort -z)
  if ((${#files[@]})); then
    awk -v root="$root/" -v rows="$(printf '%s\n' "${rows[@]}")" '
      BEGIN {
        n = split(rows, r, "\n")
        for (i = 1; i <= n; i++) {
          if (r[i] == "") continue
          eq = index(r[i], "="); name = substr(r[i], 1, eq - 1)
          known[name] = 1; may[name] = substr(r[i], eq + 1)
        }
        bad = 0
      }
      FNR == 1 {
        rel = FILENAME; sub("^" root, "", rel)
        split(rel, parts, "/"); folder = parts[2]
      }
      match($0, /^[ \t]*#[ \t]*include[ \t]*["<][^">]+[">]/) {
        inc = substr($0, RSTART, RLENGTH); sub(/^[^"<]*["<]/, "", inc); sub(/[">]$/, "", inc)
        slash = index(inc, "/")
        if (slash == 0 || !(folder in known)) next
        first = substr(inc, 1, slash - 1)
        if (!(first in known)) next  # not ours: Eigen/Core, boost/..., nlohmann/...
        if (index(may[folder], " " first " ") == 0) {
          allowed_list = may[folder]; sub(/ +$/, "", allowed_list)
          printf "%s:%d: #include \"%s\": lib/%s may not include %s/ (a layer above or beside it; lib/%s may use:%s)\n", \
                 rel, FNR, inc, folder, first, folder, allowed_list > "/dev/stderr"
          bad = 1
        }
      }
      END { exit bad }' "${files[@]}" || status=1
  fi

  if [ "$status" -ne 0 ]; then
    echo "check-layers: FAILED (the layers are in cmake/layers.txt and docs/ARCHITECTURE.md; move the code down, do not widen a line)" >&2
  fi
  return "$status"
}

self_test() {
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  local root
  root="$(cd "$(dirname "$self")/.." && pwd)"
  mkdir -p "$tmp/cmake"
  cp "$root/cmake/layers.txt" "$tmp/cmake/"
  cp -R "$root/lib" "$tmp/lib"

  # 1. The real tree passes.
  if ! check "$tmp" 2>"$tmp/clean.err"; then
    cat "$tmp/clean.err" >&2
    echo "check-layers self-test: FAILED: the unmodified tree does not pass" >&2
    return 1
  fi
  # 2. An include going up a layer (fleet -> io) fails, naming the file, the line and the include.
  local victim="$tmp/lib/fleet/fleet_smc.cpp"
  local n
  n=$(($(wc -l <"$victim") + 1))
  echo '#include "io/wim_log.hpp"' >>"$victim"
  if check "$tmp" 2>"$tmp/up.err"; then
    echo "check-layers self-test: FAILED: a planted fleet -> io include passed" >&2
    return 1
  fi
  if ! grep -q "^lib/fleet/fleet_smc.cpp:$n: #include \"io/wim_log.hpp\"" "$tmp/up.err"; then
    cat "$tmp/up.err" >&2
    echo "check-layers self-test: FAILED: the message does not name lib/fleet/fleet_smc.cpp:$n and the include" >&2
    return 1
  fi
  # 3. A sideways include (smc -> road: the engine never knows a road) fails too, in a header.
  cp "$root/lib/fleet/fleet_smc.cpp" "$victim"
  sed -i '1i #include <road/surface.hpp>' "$tmp/lib/smc/engine.hpp"
  if check "$tmp" 2>"$tmp/side.err" || ! grep -q '^lib/smc/engine.hpp:1: ' "$tmp/side.err"; then
    cat "$tmp/side.err" >&2
    echo "check-layers self-test: FAILED: a planted smc -> road include was not reported" >&2
    return 1
  fi
  # 4. A new folder without a line fails (a name no real folder will take).
  cp "$root/lib/smc/engine.hpp" "$tmp/lib/smc/engine.hpp"
  mkdir -p "$tmp/lib/planted_unlisted" && echo '#include "util/errors.hpp"' >"$tmp/lib/planted_unlisted/planted.cpp"
  if check "$tmp" 2>"$tmp/new.err" || ! grep -q 'lib/planted_unlisted has no line' "$tmp/new.err"; then
    cat "$tmp/new.err" >&2
    echo "check-layers self-test: FAILED: a folder without a line in the table passed" >&2
    return 1
  fi
  echo "check-layers self-test: passed (clean tree passes; planted up, sideways and unlisted cases fail)"
}

if [ "${1:-}" = "--self-test" ]; then
  self_test
else
  root="${1:-$(cd "$(dirname "$self")/.." && pwd)}"
  check "$root"
  echo "check-layers: lib/ keeps to cmake/layers.txt"
fi
