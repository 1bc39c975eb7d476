#!/usr/bin/env bash
# Installs the Debian 12 packages dsmplan builds with, when any is missing (the library, the
# command, the Python module and the tests: the small ones; scripts/sample.sh needs no more).
# With arguments, installs those packages instead (scripts/bench_deps.sh: the optional
# benchmark dependencies; scripts/test.sh: the programs the tests open files with), so there is
# one installer. `--npm`: Debian's nodejs and npm, unless a node with npm is there already
# (NodeSource's nodejs bundles npm and conflicts with Debian's npm package): the 3D viewer's three
# and the tests' glTF validator and CesiumJS are installed with it (scripts/npm_pinned.sh).
# apt-get waits up to 10 minutes for another apt-get to finish (scripts/sample.sh installs
# COLMAP in the background).
set -euo pipefail
packages=(cmake make g++ libcgal-dev libeigen3-dev libgmp-dev libmpfr-dev libgdal-dev libproj-dev
          libcli11-dev nlohmann-json3-dev libgtest-dev libgmock-dev libtbb-dev libpng-dev libtinygltf-dev libxxhash-dev
          libopenmpi-dev openmpi-bin libcpp-httplib-dev pkgconf
          pybind11-dev python3-dev)
if [ "${1:-}" = "--npm" ]; then
  command -v npm >/dev/null 2>&1 && exit 0
  packages=(nodejs npm)
elif [ $# -gt 0 ]; then
  packages=("$@")
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "Installing Debian packages: ${missing[*]}"
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
log=$(mktemp /tmp/dsmplan-apt-XXXXXX.log)
export DEBIAN_FRONTEND=noninteractive
wait_lock=(-o DPkg::Lock::Timeout=600)
if ! { $sudo apt-get "${wait_lock[@]}" update -qq &&
       $sudo apt-get "${wait_lock[@]}" install -y -qq --no-install-recommends "${missing[@]}"; } >"$log" 2>&1; then
  tail -n 30 "$log"
  echo "deps.sh: apt-get failed; full log in $log" >&2
  exit 1
fi
rm -f "$log"
echo "Installed."
