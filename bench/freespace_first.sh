#!/usr/bin/env bash
# Issue 48, point 5: a first `dsmplan plan` on the NRW 1 km tile with --dsm (its XY-3 mesh at 1 m,
# 2 M triangles; the sample's low mission, --max-agl 30), the planner on the free airspace against
# the paper's PRM, whole processes timed by bench/timed.py, ROUNDS rounds, the order alternating;
# prints the median wall seconds of each (min-max), the median ratio prm / freespace of the rounds
# (min-max), and the load before each round. (OMPL's PRM with Embree, issue 48's named anchor, is
# bench/plan_process.sh's; it needs the bench build: scripts/bench_deps.sh.)
#   bench/freespace_first.sh [ROUNDS=7]
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-7}
tile=data/nrw-dom1/dom1_32_356_5699_1_nw_2020.tif
dir=out/bench/freespace_first
mkdir -p "$dir"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores;" \
  "dsmplan $(git rev-parse --short HEAD)"
[ -f "$dir/nrw_1m.ply" ] || build/dsmplan mesh "$tile" -o "$dir/nrw_1m.ply" -q
run() {
  bench/timed.py "$dir/$1_$2.time" build/dsmplan plan "$dir/nrw_1m.ply" --dsm "$tile" \
    --waypoints data/nrw-dom1/low_waypoints.csv --max-agl 30 --planner "$1" -o "$dir/$1.csv" -q
}
for round in $(seq 1 "$rounds"); do
  echo "round $round, load $(cut -d' ' -f1 /proc/loadavg)"
  if [ $((round % 2)) = 1 ]; then run prm "$round" && run freespace "$round"; else run freespace "$round" && run prm "$round"; fi
done
/usr/bin/python3 - "$dir" "$rounds" <<'PY'
import statistics, sys
folder, rounds = sys.argv[1], int(sys.argv[2])
wall = {p: [float(open(f"{folder}/{p}_{r}.time").read().split()[0]) for r in range(1, rounds + 1)] for p in ("prm", "freespace")}
for p, w in wall.items():
    print(f"{p}: {statistics.median(w):.3f} s ({min(w):.3f}-{max(w):.3f})")
ratio = [a / b for a, b in zip(wall["prm"], wall["freespace"])]
print(f"prm / freespace: {statistics.median(ratio):.2f}x ({min(ratio):.2f}-{max(ratio):.2f})")
PY
