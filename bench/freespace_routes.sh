#!/usr/bin/env bash
# Issue 48: street-level routes over the NRW crop, the paper's PRM against the planner on the free
# airspace (both objectives), as `plan --routes --safety 2` on the conservative mesh with --dsm, at
# 10, 20 and 40 m ceilings. COUNT routes (bench/make_street_routes.py, 100-570 m, 5-8 m above the
# street, 2.5 m from every building); per ceiling the quality of each arm (bench/compare_routes.py)
# and ROUNDS interleaved whole-process times per arm (median, min-max; load before each round).
#   bench/freespace_routes.sh [COUNT=200] [ROUNDS=3]
set -euo pipefail
cd "$(dirname "$0")/.."
count=${1:-200} rounds=${2:-3}
dsm=data/nrw-dom1/nrw_dom1_crop500m_1m.tif
dir=out/bench/freespace
mkdir -p "$dir"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores;" \
  "dsmplan $(git rev-parse --short HEAD)"
[ -f "$dir/bounded.ply" ] || build/dsmplan simplify "$dsm" --max-error 0.4 --conservative -o "$dir/bounded.ply" -q
/usr/bin/python3 bench/make_street_routes.py "$dsm" "$count" "$dir/routes.csv"
arms=("prm:--planner prm" "low:--planner freespace --objective low" "shortest:--planner freespace --objective shortest")
for agl in 10 20 40; do
  echo "ceiling $agl m:"
  for round in $(seq 1 "$rounds"); do
    load=$(cut -d' ' -f1 /proc/loadavg)
    echo "  round $round, load $load"
    for k in $(seq 0 $((${#arms[@]} - 1))); do
      arm=${arms[$(((k + round) % ${#arms[@]}))]}  # the order rotates round by round
      name=${arm%%:*}
      rm -rf "$dir/${name}_$agl"
      status=0
      # shellcheck disable=SC2086
      bench/timed.py "$dir/${name}_${agl}_$round.time" build/dsmplan plan "$dir/bounded.ply" --dsm "$dsm" \
        --routes "$dir/routes.csv" --max-agl "$agl" --safety 2 ${arm#*:} -o "$dir/${name}_$agl/" -q \
        > /dev/null 2>&1 || status=$?
      [ "$status" = 0 ] || [ "$status" = 4 ] || exit "$status"
    done
  done
  for arm in "${arms[@]}"; do
    name=${arm%%:*}
    printf '  %s: seconds median ' "$name"
    cat "$dir/${name}_${agl}"_*.time | cut -d' ' -f1 | sort -n | awk '{a[NR]=$1} END {printf "%.2f (%.2f-%.2f)\n", a[int((NR+1)/2)], a[1], a[NR]}'
  done
  /usr/bin/python3 bench/compare_routes.py "$dir/routes.csv" prm="$dir/prm_$agl" low="$dir/low_$agl" \
    shortest="$dir/shortest_$agl" | sed 's/^/  /'
done
