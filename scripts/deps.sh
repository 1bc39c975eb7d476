#!/usr/bin/env bash
# Installs the Debian 12 packages dsmplan builds with, when any is missing.
# With arguments, installs those packages instead (scripts/bench_deps.sh: the optional
# benchmark dependencies), so there is one installer.
set -euo pipefail
packages=(cmake make g++ libcgal-dev libeigen3-dev libgmp-dev libmpfr-dev libgdal-dev libproj-dev
          libcli11-dev nlohmann-json3-dev libgtest-dev libgmock-dev libtbb-dev libpng-dev libtinygltf-dev libxxhash-dev
          libopenmpi-dev openmpi-bin libcpp-httplib-dev pkgconf
          pybind11-dev python3-dev
          colmap)  # the real structure-from-motion of colmap_test (ColmapBinary.*) and scripts/sample.sh
# The tests run the Khronos glTF validator (scripts/test.sh installs it with npm) and the 3D
# viewer needs three (scripts/build.sh installs it with npm): Debian's nodejs and npm, unless a
# node with npm is there already (NodeSource's nodejs bundles npm and conflicts with Debian's npm
# package).
command -v npm >/dev/null 2>&1 || packages+=(nodejs npm)
[ $# -gt 0 ] && packages=("$@")
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
if ! { $sudo apt-get update -qq && $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"; } >"$log" 2>&1; then
  tail -n 30 "$log"
  echo "deps.sh: apt-get failed; full log in $log" >&2
  exit 1
fi
rm -f "$log"
echo "Installed."
