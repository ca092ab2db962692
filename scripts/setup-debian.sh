#!/usr/bin/env bash
# Installs every build, test and plotting dependency of ssrfleet on Debian 12 (Open MPI for the
# -DSSRFLEET_MPI=ON build that scripts/test.sh makes). Idempotent.
set -euo pipefail
packages=(build-essential cmake git libeigen3-dev libboost-dev libboost-program-options-dev
          catch2 nlohmann-json3-dev libsqlite3-dev sqlite3 gnuplot-nox parallel libopenmpi-dev openmpi-bin)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  echo "setup: installing ${missing[*]}" >&2
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "setup: all dependencies present" >&2
fi
