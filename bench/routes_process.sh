#!/usr/bin/env bash
# Issue 35, point 5: many routes in one run against the same routes run one process each.
# On the NRW tile's XY-3 mesh at 1 m (2 M triangles), COUNT random street-to-street routes
# (bench/make_routes.py: 2 waypoints 5-15 m above a street cell, 200-1,500 m apart), at
# --max-agl 120 and 30. Per ceiling, ROUNDS rounds, each timed from outside by bench/timed.py:
#   - routes: `dsmplan plan MESH --routes ROUTES -o OUT.geojson` (one roadmap, every route a
#     query, both cores), the whole process;
#   - single: SAMPLE of the same routes as one `dsmplan plan` process each, with --index and
#     --roadmap kept (built by an untimed run first), one after another.
# Prints per ceiling: routes a second of the one run (median, min-max over rounds), of single
# processes (one core: 1 / median process; two cores at once would at most double it), the ratio,
# the share of routes planned, and the 1-minute load average before each round.
#   bench/routes_process.sh [COUNT=10000] [ROUNDS=3] [SAMPLE=40]
set -euo pipefail
cd "$(dirname "$0")/.."
count=${1:-10000} rounds=${2:-3} sample=${3:-40}
tile=data/nrw-dom1/dom1_32_356_5699_1_nw_2020.tif
dir=out/bench/routes
mkdir -p "$dir"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores;" \
  "dsmplan $(git rev-parse --short HEAD)"
[ -f "$dir/nrw_1m.ply" ] || build/dsmplan mesh "$tile" -o "$dir/nrw_1m.ply" -q
/usr/bin/python3 bench/make_routes.py "$tile" "$count" "$dir/routes.csv"
vertical=(--vertical-crs EPSG:7837 --allow-approximate-vertical)
for agl in 120 30; do
  # The kept index and roadmap the single processes open (built here, untimed).
  rm -f "$dir/kept_$agl.roadmap"
  head -3 "$dir/routes.csv" | tail -2 | cut -d, -f2- | sed '1i x,y,z' > "$dir/one.csv"
  build/dsmplan plan "$dir/nrw_1m.ply" --waypoints "$dir/one.csv" --max-agl "$agl" -o "$dir/one_out.csv" -q \
    --index "$dir/nrw_1m.index" --roadmap "$dir/kept_$agl.roadmap" || true
  for round in $(seq 1 "$rounds"); do
    load=$(cut -d' ' -f1 /proc/loadavg)
    status=0
    bench/timed.py "$dir/routes_${agl}_$round.time" build/dsmplan plan "$dir/nrw_1m.ply" --routes "$dir/routes.csv" \
      --max-agl "$agl" -o "$dir/routes_$agl.geojson" --stats "$dir/routes_${agl}_$round.json" -q "${vertical[@]}" \
      > /dev/null || status=$?
    [ "$status" = 0 ] || [ "$status" = 4 ] || exit "$status"
    : > "$dir/single_${agl}_$round.times"
    for r in $(seq 1 "$sample"); do
      grep "^r$((r * (count / sample))),"  "$dir/routes.csv" | cut -d, -f2- | sed '1i x,y,z' > "$dir/single.csv"
      bench/timed.py "$dir/single.time" build/dsmplan plan "$dir/nrw_1m.ply" --waypoints "$dir/single.csv" \
        --max-agl "$agl" -o "$dir/single_out.csv" -q --index "$dir/nrw_1m.index" \
        --roadmap "$dir/kept_$agl.roadmap" 2> /dev/null || true
      cat "$dir/single.time" >> "$dir/single_${agl}_$round.times"
    done
    echo "$agl $round $load" >> "$dir/loads"
  done
  /usr/bin/python3 - "$dir" "$agl" "$rounds" "$count" << 'PY'
import json, statistics, sys
d, agl, rounds, count = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
one, single, ratio, solved, loads = [], [], [], [], []
for r in range(1, rounds + 1):
    wall = float(open(f"{d}/routes_{agl}_{r}.time").read().split()[0])
    per = statistics.median(float(l.split()[0]) for l in open(f"{d}/single_{agl}_{r}.times"))
    one.append(count / wall); single.append(1 / per); ratio.append((count / wall) * per)
    solved.append(json.load(open(f"{d}/routes_{agl}_{r}.json"))["solved"] / count)
lo = [l.split()[2] for l in open(f"{d}/loads") if l.split()[0] == agl][-rounds:]
f = lambda v: "%.0f (%.0f-%.0f)" % (statistics.median(v), min(v), max(v))
print(f"--max-agl {agl}: one run {f(one)} routes/s; single processes {f(single)} routes/s on one core;"
      f" ratio {statistics.median(ratio):.1f} ({min(ratio):.1f}-{max(ratio):.1f});"
      f" planned {statistics.median(solved):.1%}; load before rounds {' '.join(lo)}")
PY
done
