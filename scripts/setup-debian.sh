#!/usr/bin/env bash
# Installs the Debian 12 packages ssrfleet needs. Idempotent: only missing packages are installed,
# without recommends.
#
#   scripts/setup-debian.sh          everything: build, tests, benchmarks, plots, Open MPI for the
#                                    -DSSRFLEET_MPI=ON build, help2man for the man pages (what
#                                    scripts/test.sh needs)
#   scripts/setup-debian.sh --main   only what the `ssrfleet` command and `ssrfleet reproduce` need
#                                    (what scripts/run-main.sh needs): compiler, CMake, the libraries
#                                    it links or includes, gnuplot for the plots
set -euo pipefail
# The ssrfleet target: Eigen, Boost (headers, program_options), nlohmann-json, SQLite (the stream's
# history), NetCDF (the draws file, NetCDF4 in ArviZ's layout), cpp-httplib and Chart.js (serve's
# HTTP server and its page's charts, compiled into the command); gnuplot renders reproduce's plots
# (without it the scripts are written, not run).
main_packages=(build-essential cmake libeigen3-dev libboost-dev libboost-program-options-dev
               nlohmann-json3-dev libsqlite3-dev libnetcdf-dev libcpp-httplib-dev libjs-chart.js gnuplot-nox)
# Beyond the main job: git (CI clones the checkout), Catch2 (tests), sqlite3 (the tests query the
# history), python3-numpy (the independent check of the convergence diagnostics), python3-xarray
# and python3-netcdf4 (the draws files opened as a notebook would), GNU parallel
# (scripts/fit-sites.sh), Open MPI (ssrfleet-mpi and its test), help2man (the man pages), and the
# Python module `import ssrfleet` (python3-dev, pybind11-dev) with its tests (python3-pytest) and
# what notebooks use beside it (python3-pandas, python3-matplotlib), and chromium (the browser test of
# serve's page, headless).
full_packages=("${main_packages[@]}" git catch2 sqlite3 python3-numpy python3-xarray python3-netcdf4 parallel
               libopenmpi-dev openmpi-bin help2man python3-dev pybind11-dev python3-pytest python3-pandas
               python3-matplotlib chromium)
case "${1:-}" in
  --main) packages=("${main_packages[@]}") ;;
  "") packages=("${full_packages[@]}") ;;
  *) echo "usage: scripts/setup-debian.sh [--main]" >&2; exit 64 ;;
esac
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
