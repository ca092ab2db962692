#!/bin/sh
# The manual page of ssrfleet (no COMMAND: ssrfleet.1) or of one of its commands
# (ssrfleet-COMMAND.1), made by help2man (Debian's help2man) from the command's own --help, so the
# page and the help cannot disagree. The CMake target `man` runs it for every command.
#
#   bin/man_page.sh SSRFLEET_BINARY OUT_FILE [COMMAND]
set -eu
if [ $# -lt 2 ] || [ $# -gt 3 ]; then
  echo "usage: bin/man_page.sh SSRFLEET_BINARY OUT_FILE [COMMAND]" >&2
  exit 64
fi
binary=$1
out=$2
cmd=${3:-}
command -v help2man > /dev/null || { echo "man_page.sh: help2man is not installed (apt-get install help2man)" >&2; exit 69; }
version=$("$binary" --version | sed -n '1s/^ssrfleet //p')
# Unwrapped help: help2man reads the usage and each option's text as one line, and fills them itself.
COLUMNS=1000
export COLUMNS
# The page's date: the binary's, so that the same build makes the same page.
SOURCE_DATE_EPOCH=${SOURCE_DATE_EPOCH:-$(stat -c %Y "$binary")}
export SOURCE_DATE_EPOCH
see_also=$(mktemp)
trap 'rm -f "$see_also"' EXIT
commands=$("$binary" --help | sed -n '/^Commands:/,/^$/s/^  \([a-z][a-z]*\) .*/\1/p' | grep -v '^help$')
if [ -z "$cmd" ]; then
  {
    echo "[SEE ALSO]"
    for c in $commands; do echo ".BR ssrfleet-$c (1),"; done
    echo "and the user guide in the docs folder of the documentation (share/doc/ssrfleet/docs)."
  } > "$see_also"
  help2man --no-info --section=1 --include="$see_also" \
    --name="fleet suspension inference and statistical spatial repeatability from MS-WIM data" \
    --version-string="ssrfleet $version" --output="$out" "$binary"
  exit
fi
# The NAME line: the summary that opens the command's help (its first line after the usage).
summary=$("$binary" help "$cmd" | sed -n '/^$/{n;s/\.$//;s/^./\L&/;p;q;}')
[ -n "$summary" ] || { echo "man_page.sh: '$cmd' is not a command of $binary" >&2; exit 64; }
printf '[SEE ALSO]\n.BR ssrfleet (1)\n' > "$see_also"
help2man --no-info --section=1 --include="$see_also" --name="$summary" \
  --version-string="ssrfleet-$cmd $version" --help-option="help $cmd" --output="$out" "$binary"
