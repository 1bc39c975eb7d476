#!/usr/bin/env bash
# The main job on the bundled real sample (500 m x 500 m of the NRW DOM1, 1 m cells):
# describe the DSM, then build the paper's XY-3 Delaunay mesh at 1 m and 2 m, into out/sample/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh
dsm=data/nrw-dom1/nrw_dom1_crop500m_1m.tif
out=out/sample
mkdir -p "$out"
build/dsmplan info "$dsm" | tee "$out/info.txt"
build/dsmplan info "$dsm" --json > "$out/info.json"
for res in 1 2; do
  echo "Meshing at ${res} m:"
  build/dsmplan mesh "$dsm" --res "$res" -o "$out/mesh_${res}m.ply" --stats "$out/mesh_${res}m.json"
done
echo
echo "Outputs in $out/:"
ls -l "$out"
