#!/usr/bin/env bash
# Fails when a file of the repository reads, links or names something outside it: the folder that
# sat beside the checkout during development (its data, its paper copies), design or style notes
# that only lived there, an absolute path of one machine, or a relative path in the build, the
# scripts or a Markdown link that climbs out of the repository. A user who clones the project has
# none of those, so every such reference is printed as FILE:LINE: [what] text, and the exit is 1.
#
#   tests/self_contained_test.sh [ROOT]      check ROOT (default: this repository)
#   tests/self_contained_test.sh --self-test plant each kind of reference in a small scratch tree
#                                            and expect it reported (and a clean tree to pass)
#
# The files checked are the tracked ones (git ls-files) when ROOT is the top of a git work tree,
# otherwise every file under ROOT but build*/, out/ and .git. Binary files are skipped.
# The patterns below are written in pieces so that this file does not match itself.
set -euo pipefail

self="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/$(basename "${BASH_SOURCE[0]}")"

# Names that point outside the repository, wherever they appear (ERE, case-sensitive).
outside_patterns=(
  '\.\./shar''ed'                    # the folder beside the checkout
  'shar''ed/(data|seeds)'            # its data and paper copies
  '(^|[^A-Za-z0-9_])see''ds/'        # the paper copies, under any prefix
  'DESI''GN\.md'                     # design notes that only lived beside the repository
  'STY''LE\.md'                      # style notes likewise
  '(^|[^A-Za-z0-9_.~-])/wo''rk/'     # absolute paths of the development machine
  '(^|[^A-Za-z0-9_.~-])/ho''me/'     # absolute paths of a user's home
)
outside_reasons=(
  "the folder beside the checkout"
  "data or papers beside the checkout"
  "paper copies beside the checkout"
  "design notes outside the repository"
  "style notes outside the repository"
  "an absolute path of one machine"
  "an absolute path of one machine"
)

# The files to check, NUL-separated, paths relative to ROOT.
list_files() {
  local root="$1" top=""
  if command -v git >/dev/null 2>&1; then
    top="$(git -C "$root" rev-parse --show-toplevel 2>/dev/null || true)"
  fi
  if [ -n "$top" ] && [ "$(cd "$top" && pwd -P)" = "$(cd "$root" && pwd -P)" ]; then
    git -C "$root" ls-files -z
  else
    (cd "$root" && find . \( -path ./.git -o -path './build*' -o -path ./out \) -prune -o -type f -print0 |
      sed -z 's|^\./||')
  fi
}

# Where a path with a ".." component lands, lexically, with the repository at /@root@. $1: the
# file's folder (relative to ROOT, "." at the top), $2: the path as written (prefixes resolved).
lands_inside() {
  local dir="$1" path="$2" full
  case "$path" in
    /@root@*) full="$path" ;;
    /*) return 1 ;;  # absolute: outside whatever it is
    \$*) return 1 ;; # a variable this check cannot resolve: say so rather than guess
    *) full="/@root@/$dir/$path" ;;
  esac
  full="$(realpath -m -s "$full")"
  [ "$full" = "/@root@" ] || [[ "$full" == /@root@/* ]]
}

# Prints FILE:LINE: [..] text for each relative path in a build file, script or Markdown link that
# leaves the repository. $1: ROOT, $2: file relative to ROOT.
check_relative_paths() {
  local root="$1" file="$2" dir kind line_no text work token
  dir="$(dirname "$file")"
  case "$file" in
    CMakeLists.txt | */CMakeLists.txt | *.cmake | CMakePresets.json | *.sh | *.bash | *.sbatch | .ci/* | scripts/*)
      kind=build ;;
    *.md) kind=markdown ;;
    *.c | *.cc | *.cpp | *.h | *.hpp) kind=include ;;
    *) return 0 ;;
  esac
  { grep -n -F '..' "$root/$file" 2>/dev/null || true; } | while IFS= read -r line; do
    line_no="${line%%:*}"
    text="${line#*:}"
    case "$kind" in
      build)
        work="$text"
        # What the build and the scripts mean by the top and by "here".
        work="${work//\$\{PROJECT_SOURCE_DIR\}//@root@}"
        work="${work//\$\{CMAKE_SOURCE_DIR\}//@root@}"
        work="${work//\$\{sourceDir\}//@root@}"
        work="${work//\$\{CMAKE_CURRENT_SOURCE_DIR\}//@root@/$dir}"
        work="${work//\$\{CMAKE_CURRENT_LIST_DIR\}//@root@/$dir}"
        work="${work//\$(dirname \"\$0\")//@root@/$dir}"
        work="${work//\$(dirname \"\$\{BASH_SOURCE\[0\]\}\")//@root@/$dir}"
        work="${work//\$(dirname \"\$self\")//@root@/$dir}"  # $self: a script's own path, by convention
        ;;
      markdown)
        # Only link targets: ](target) and <target>.
        work="$(grep -o -E '\]\([^)[:space:]]+' <<<"$text" | sed 's/^](//' | tr '\n' ' ' || true)"
        ;;
      include)
        [[ "$text" =~ ^[[:space:]]*#[[:space:]]*include[[:space:]]*\"([^\"]+)\" ]] || continue
        work="${BASH_REMATCH[1]}"
        ;;
    esac
    # Split on what cannot be part of a path here, keep the tokens with a ".." component.
    for token in $(tr '"'"'"'(){}<>;,=|&`:[:space:]' '\n' <<<"$work"); do
      [[ "$token" =~ (^|/)\.\.(/|$) ]] || continue
      if [ "$kind" = markdown ]; then token="${token%%#*}"; fi
      if ! lands_inside "$dir" "$token"; then
        echo "$file:$line_no: [a relative path that leaves the repository: $token]$text"
      fi
    done
  done
}

check() {
  local root="$1" i file line found
  [ -d "$root" ] || { echo "self-contained: no directory $root" >&2; return 2; }
  root="$(cd "$root" && pwd)"
  local tmp
  tmp="$(mktemp -d)"
  # The text files (grep -I skips binary ones), NUL-separated, relative to ROOT.
  (cd "$root" && list_files "$root" | while IFS= read -r -d '' file; do
    if [ -f "$file" ]; then printf '%s\0' "$file"; fi  # a tracked file may be deleted in the work tree
  done) >"$tmp/files"
  for i in "${!outside_patterns[@]}"; do
    (cd "$root" && xargs -0 -r grep -n -H -I -E -e "${outside_patterns[$i]}" <"$tmp/files" || true) |
      while IFS= read -r line; do
        file="${line%%:*}" && line="${line#*:}"
        echo "$file:${line%%:*}: [${outside_reasons[$i]}] ${line#*:}"
      done >>"$tmp/report"
  done
  # This file spells out paths that climb out in its own self-test; its patterns are split above.
  local me="${self#"$root"/}"
  while IFS= read -r -d '' file; do
    [ "$file" = "$me" ] && continue
    check_relative_paths "$root" "$file"
  done <"$tmp/files" >>"$tmp/report"
  if [ -s "$tmp/report" ]; then
    sort -t: -k1,1 -k2,2n -u "$tmp/report"
    found="$(cut -d: -f1,2 "$tmp/report" | sort -u | wc -l)"
    rm -rf "$tmp"
    echo "self-contained: FAILED: $found line(s) refer to something outside the repository (above, FILE:LINE)." >&2
    echo "  Cite a paper or standard by its full reference, put data the tests need under tests/data/," >&2
    echo "  and document in docs/ what a reader needs." >&2
    return 1
  fi
  rm -rf "$tmp"
  echo "self-contained: no file refers outside the repository"
}

# A small tree with every legitimate kind of path (which must pass), then one planted reference at a
# time (each must fail, naming the file and the line). Runs without git (find) and, where git is
# installed, with it (an untracked file is not the repository's).
self_test() {
  scratch="$(mktemp -d)"
  trap 'rm -rf "$scratch"' EXIT
  local tmp="$scratch"
  local tree="$tmp/tree"
  mkdir -p "$tree/scripts" "$tree/tests/data" "$tree/docs" "$tree/mpi" "$tree/bin" "$tree/.ci"
  cat >"$tree/CMakeLists.txt" <<'EOF'
set(LAYERS ${PROJECT_SOURCE_DIR}/cmake/layers.txt)
add_subdirectory(tests)
EOF
  cat >"$tree/tests/CMakeLists.txt" <<'EOF'
target_compile_definitions(t PRIVATE DATA="${CMAKE_CURRENT_SOURCE_DIR}/data" UP="${CMAKE_CURRENT_SOURCE_DIR}/../bin")
EOF
  cat >"$tree/scripts/test.sh" <<'EOF'
#!/usr/bin/env bash
cd "$(dirname "$0")/.."
for i in {1..3}; do echo "k_1..N" ...; done
EOF
  printf '#!/usr/bin/env bash\ncd "$(dirname "$0")/.."\n' >"$tree/.ci/run"
  printf '# Guide\nSee [the map](ARCHITECTURE.md), [the front page](../README.md#top) and ../../x in prose.\n' \
    >"$tree/docs/guide.md"
  printf '#include "../bin/process_ranks.hpp"\n' >"$tree/mpi/ranks.cpp"
  printf 'y,x\n1,2\n' >"$tree/tests/data/known.csv"
  printf '\0binary /%s/ and %s\n' "wo""rk" "DESI""GN.md" >"$tree/bin/blob.bin"

  # 1. The clean tree passes.
  if ! check "$tree" >"$tmp/clean.out" 2>&1; then
    cat "$tmp/clean.out" >&2
    echo "self-contained self-test: FAILED: the clean scratch tree does not pass" >&2
    return 1
  fi

  # 2. Each planted reference fails, naming FILE:LINE. Each entry: file|line to append|expected line.
  local plants=(
    "tests/CMakeLists.txt|set(D \"\${PROJECT_SOURCE_DIR}/../shar""ed/data\")|2"
    "tests/t.cpp|// data in shar""ed/data/radiata.csv|1"
    "lib.cpp|// as DESI""GN.md §4 says|1"
    "docs/guide.md|Style: STY""LE.md.|3"
    "README.md|The paper: see""ds/000.txt|1"
    "scripts/run.sh|cd /wo""rk/main && make|1"
    "benchmarks/r.md|ran in /ho""me/user/ssrfleet|1"
    "CMakeLists.txt|include(\${CMAKE_SOURCE_DIR}/../other/cmake/x.cmake)|3"
    "scripts/test.sh|source \"\$(dirname \"\$0\")/../../env.sh\"|4"
    "docs/guide.md|[the data](../../data/README.md)|3"
    "mpi/ranks.cpp|#include \"../../outside/x.hpp\"|2"
  )
  local plant file text want
  for plant in "${plants[@]}"; do
    IFS='|' read -r file text want <<<"$plant"
    rm -rf "$tmp/work" && cp -R "$tree" "$tmp/work"
    mkdir -p "$(dirname "$tmp/work/$file")"
    printf '%s\n' "$text" >>"$tmp/work/$file"
    if check "$tmp/work" >"$tmp/plant.out" 2>&1; then
      echo "self-contained self-test: FAILED: a planted '$text' in $file passed" >&2
      return 1
    fi
    if ! grep -q "^$file:$want: " "$tmp/plant.out"; then
      cat "$tmp/plant.out" >&2
      echo "self-contained self-test: FAILED: the report does not name $file:$want for '$text'" >&2
      return 1
    fi
  done

  # 3. With git, only tracked files count: an untracked file with a reference is not reported, the
  #    same file once added is.
  if command -v git >/dev/null 2>&1; then
    rm -rf "$tmp/work" && cp -R "$tree" "$tmp/work"
    git -C "$tmp/work" init -q && git -C "$tmp/work" add -A
    printf '%s\n' "see ../shar""ed/data" >"$tmp/work/untracked.txt"
    if ! check "$tmp/work" >"$tmp/git.out" 2>&1; then
      cat "$tmp/git.out" >&2
      echo "self-contained self-test: FAILED: an untracked file was checked in a git work tree" >&2
      return 1
    fi
    git -C "$tmp/work" add untracked.txt
    if check "$tmp/work" >"$tmp/git.out" 2>&1 || ! grep -q '^untracked.txt:1: ' "$tmp/git.out"; then
      cat "$tmp/git.out" >&2
      echo "self-contained self-test: FAILED: a tracked file's reference was not reported" >&2
      return 1
    fi
  fi
  echo "self-contained self-test: passed (a clean tree passes; ${#plants[@]} planted references each fail at their FILE:LINE)"
}

if [ "${1:-}" = "--self-test" ]; then
  self_test
else
  check "${1:-$(cd "$(dirname "$self")/.." && pwd)}"
fi
