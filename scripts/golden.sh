#!/usr/bin/env bash
# The outputs the README shows, made small, and their SHA-256 (issue 18, point 6: a restructuring
# must leave every output byte-identical where it was before).
#
#   scripts/golden.sh DSMPLAN           prints "sha256  file" for every output, made in a temporary folder
#   scripts/golden.sh --check DSMPLAN   compares with tests/data/golden_outputs.sha256 (a test, `golden_outputs`)
#   scripts/golden.sh --update DSMPLAN  rewrites that file: only for a change whose outputs are meant to differ,
#                                       and the commit says why
#
# The oracle is the program as it was: the file records the outputs of the commit that wrote it.
# Everything here is deterministic (threads or not); timings (--stats) are left out.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=print
case "${1:-}" in --check | --update) mode=${1#--}; shift ;; esac
[ $# -eq 1 ] || { echo "usage: scripts/golden.sh [--check|--update] DSMPLAN" >&2; exit 2; }
bin=$(realpath "$1")
root=$PWD
manifest=tests/data/golden_outputs.sha256
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

run() { "$bin" "$@" -q > /dev/null; }
(
  cd "$work"
  # Inputs by relative names, as a file may record them (info's "file"): the same in any checkout.
  ln -s "$root/data" data
  dsm=data/nrw-dom1/nrw_dom1_crop500m_1m.tif
  waypoints=data/nrw-dom1/sample_waypoints.csv
  vertical=(--vertical-crs EPSG:7837 --allow-approximate-vertical)
  "$bin" info "$dsm" --json > info.json
  for format in ply obj off; do run mesh "$dsm" --res 4 -o "mesh.$format"; done
  run mesh "$dsm" --res 4 -o mesh.glb --3dtiles "${vertical[@]}" && mv tileset.json mesh_tileset.json
  run simplify "$dsm" --res 4 --method variant1 -o variant1.ply
  run simplify "$dsm" --res 4 --method variant2 -o variant2.ply
  run simplify "$dsm" --max-error 0.4 --conservative -o bounded.ply
  for format in csv geojson plan waypoints kml; do
    run plan bounded.ply --dsm "$dsm" --waypoints "$waypoints" -o "path.$format" "${vertical[@]}"
  done
  run plan "$dsm" --waypoints "$waypoints" --max-agl 40 -o path_from_dsm.csv
  run render "$dsm" --mesh bounded.ply --path path.csv --waypoints "$waypoints" --zoom 1 -o render.png
  run profile "$dsm" --path path.csv --waypoints "$waypoints" --max-agl 40 -o profile.png
  delft=(data/delft-ahn3/ahn3_cropped_{1,2}.laz)
  run grid "${delft[@]}" --crs EPSG:7415 --res 2 -o delft_dsm.tif
  run grid "${delft[@]}" --crs EPSG:7415 --res 4 --classes 2 --fill-holes 30 -o delft_dtm.tif
  rm data
  sha256sum -- * | sort -k 2
) > "$work.sums"
trap 'rm -rf "$work" "$work.sums"' EXIT

case $mode in
  print) cat "$work.sums" ;;
  update) cp "$work.sums" "$manifest" && echo "wrote $manifest ($(wc -l < "$manifest") outputs)" ;;
  check)
    if ! diff -u "$manifest" "$work.sums"; then
      echo "golden.sh: outputs differ from $manifest (lines - before, + now). If the change is meant," >&2
      echo "run scripts/golden.sh --update build/dsmplan and say why in the commit." >&2
      exit 1
    fi
    echo "golden.sh: $(wc -l < "$manifest") outputs byte-identical to $manifest"
    ;;
esac
