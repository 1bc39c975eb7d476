#!/usr/bin/env bash
# Issue 49, point 2: no-fly zones with floors above the ground cost what no zones cost. On the
# bundled NRW crop (1 m) and its bounded mesh, the sample's low mission planned with --dsm, a
# whole `dsmplan plan` process each, with COUNT small zones (10 m squares, PROHIBITED, from 40 m
# above the ground up, scattered over the crop by a fixed seed; most lie off the path) against
# the same plan without zones and with the same zones without their floors, interleaved: ROUNDS
# rounds, the order rotating. DSMPLAN=path runs another build (a before, say).
# Prints per COUNT: the median ratios (floors / none, floors / floorless) with their min-max, the
# medians, and the 1-minute load average before the rounds.
#   bench/zones_process.sh [ROUNDS=7] [COUNTS="500 2000 20000"]
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-7} counts=${2:-"500 2000 20000"}
dsm=data/nrw-dom1/nrw_dom1_crop500m_1m.tif wp=data/nrw-dom1/low_waypoints.csv
dir=out/bench/zones
mkdir -p "$dir"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores;" \
  "dsmplan $(git rev-parse --short HEAD)"
[ -f "$dir/safe.ply" ] || build/dsmplan simplify "$dsm" -o "$dir/safe.ply" -q
plan=("${DSMPLAN:-build/dsmplan}" plan "$dir/safe.ply" --waypoints "$wp" --dsm "$dsm" --max-agl 30 -q
      --vertical-crs EPSG:7837 --allow-approximate-vertical)
for count in $counts; do
  /usr/bin/python3 - "$dsm" "$count" "$dir/zones_$count.geojson" << 'PY'
import json, random, sys
from osgeo import gdal, osr
dsm, count, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
ds = gdal.Open(dsm)
x0, cx, _, y0, _, cy = ds.GetGeoTransform()
w, h = ds.RasterXSize * cx, ds.RasterYSize * -cy
utm = osr.SpatialReference(); utm.ImportFromEPSG(25832)
wgs = osr.SpatialReference(); wgs.ImportFromEPSG(4326); wgs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
to = osr.CoordinateTransformation(utm, wgs)
rng = random.Random(49)
features = []
for i in range(count):
    x, y = x0 + rng.uniform(10, w - 10), y0 - rng.uniform(10, h - 10)
    ring = [list(to.TransformPoint(x + dx, y + dy)[:2]) for dx, dy in ((-5, -5), (5, -5), (5, 5), (-5, 5), (-5, -5))]
    features.append({"type": "Feature", "properties": {"id": f"z{i}", "name": f"floor {i}", "lower": 40,
                     "lower_ref": "AGL"}, "geometry": {"type": "Polygon", "coordinates": [ring]}})
json.dump({"type": "FeatureCollection", "features": features}, open(out, "w"))
for f in features:
    del f["properties"]["lower"], f["properties"]["lower_ref"]
json.dump({"type": "FeatureCollection", "features": features}, open(out.replace(".geojson", "_floorless.geojson"), "w"))
PY
  load=$(cut -d' ' -f1 /proc/loadavg)
  : > "$dir/times_$count"
  for round in $(seq 1 "$rounds"); do
    case $((round % 3)) in 0) arms="none floorless zones" ;; 1) arms="zones none floorless" ;; *) arms="floorless zones none" ;; esac
    # From 2,000 on, zones from the ground up stand on the waypoints: no plan to compare with.
    [ "$count" -le 500 ] || arms=$(echo "$arms" | sed 's/floorless//')
    for which in $arms; do
      extra=()
      [ "$which" = zones ] && extra=(--no-fly "$dir/zones_$count.geojson")
      [ "$which" = floorless ] && extra=(--no-fly "$dir/zones_${count}_floorless.geojson")
      bench/timed.py "$dir/t" "${plan[@]}" "${extra[@]}" -o "$dir/p_$which.csv" --stats "$dir/s_$which.json"
      echo "$round $which $(cut -d' ' -f1 "$dir/t")" >> "$dir/times_$count"
    done
  done
  /usr/bin/python3 - "$dir/times_$count" "$count" "$load" << 'PY'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1])]
t = {(r, w): float(s) for r, w, s in rows}
rounds = sorted({r for r, _, _ in rows})
med = lambda w: statistics.median(t[(r, w)] for r in rounds)
def ratio(a, b):
    v = [t[(r, a)] / t[(r, b)] for r in rounds]
    return f"{statistics.median(v):.2f}x ({min(v):.2f}-{max(v):.2f})"
floorless = any(w == "floorless" for _, w, _ in rows)
print(f"{sys.argv[2]} zones with 40 m AGL floors: {ratio('zones', 'none')} no zones"
      + (f", {ratio('zones', 'floorless')} the same zones without floors" if floorless else "")
      + f"; medians {med('zones'):.2f} s, {med('none'):.2f} s" + (f", {med('floorless'):.2f} s" if floorless else "")
      + f"; {len(rounds)} rounds; load {sys.argv[3]}")
PY
done
