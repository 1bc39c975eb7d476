#!/usr/bin/env bash
# Issue 19, point 2: `dsmplan plan` against OMPL's PRM with an Embree 3 BVH (bench_ompl_plan,
# bench/ompl_plan_process.cpp) as whole processes, on the NRW tile's XY-3 mesh at 1 m and at
# 0.64 m (the tile resampled bilinear, as bench_plan_ompl does), at --max-agl 120 and 30, with
# the same samples, edges and waypoints (4, 3 legs; 30 m above the ground at --max-agl 120, 20 m
# at 30, where 30 m would touch the ceiling). Each configuration: one untimed run of each, then
# PAIRS rounds of dsmplan, OMPL + Embree, OMPL + ClearanceIndex (OMPL given dsmplan's index as
# its checker, for comparison), in an order that rotates from round to round (dsmplan first, then
# second, then third), each timed from outside by /usr/bin/time (wall, user + sys),
# the load average before each round. Prints per configuration the medians with min-max of wall
# and CPU seconds and of the ratios OMPL / dsmplan, both programs' samples and edges (fails when
# they differ or a leg is unsolved) and where each spends its time (dsmplan's --stats, the
# baseline's own phases; medians).
#   bench/plan_process.sh [PAIRS=5]
set -euo pipefail
cd "$(dirname "$0")/.."
pairs=${1:-5}
tile=data/nrw-dom1/dom1_32_356_5699_1_nw_2020.tif
dir=out/bench/plan_process
baseline=build/bench/bench_ompl_plan
[ -x "$baseline" ] || {
  echo "no $baseline: cmake -DDSMPLAN_BUILD_BENCH=ON with OMPL and Embree 3 (scripts/bench_deps.sh)" >&2
  exit 1
}
mkdir -p "$dir"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores;" \
  "dsmplan $(git rev-parse --short HEAD)"
build/dsmplan mesh "$tile" -o "$dir/nrw_1m.ply" -q
"$baseline" --resample "$tile" 0.64 "$dir/nrw_064m.tif"
build/dsmplan mesh "$dir/nrw_064m.tif" -o "$dir/nrw_064m.ply" -q
configs=()
for mesh in 1m 064m; do
  for agl in 120 30; do
    height=$([ "$agl" = 120 ] && echo 30 || echo 20)
    "$baseline" --make-waypoints "$dir/nrw_$mesh.ply" "$height" "$dir/wp_${mesh}_$agl.csv"
    configs+=("${mesh}_$agl")
  done
done
for config in "${configs[@]}"; do
  mesh=${config%_*} agl=${config#*_}
  run() {  # run NAME I: one timed run; I = 0 is the untimed first one
    local name=$1 i=$2 time="$dir/${config}_$1_$2.time"
    case $name in
      dsmplan)
        /usr/bin/time -f "%e %U %S" -o "$time" build/dsmplan plan "$dir/nrw_$mesh.ply" --waypoints \
          "$dir/wp_$config.csv" --max-agl "$agl" -o "$dir/${config}_dsmplan.csv" -q --stats "$dir/${config}_dsmplan_$i.json"
        ;;
      embree | index)
        /usr/bin/time -f "%e %U %S" -o "$time" "$baseline" "$dir/nrw_$mesh.ply" --waypoints "$dir/wp_$config.csv" \
          --max-agl "$agl" -o "$dir/${config}_$name.csv" --checker "$name" > "$dir/${config}_${name}_$i.txt"
        ;;
    esac
  }
  for name in dsmplan embree index; do run $name 0; done
  order=(dsmplan embree index)
  for i in $(seq 1 "$pairs"); do
    cut -d' ' -f1-3 /proc/loadavg > "$dir/${config}_load_$i.txt"
    # The order rotates from round to round, so no program always follows the same one (the
    # kernel's cost of fresh huge pages depends on what ran just before).
    for k in 0 1 2; do run "${order[$(((i - 1 + k) % 3))]}" "$i"; done
  done
done
python3 - "$dir" "$pairs" "${configs[@]}" <<'PY'
import json, statistics, sys
d, pairs, configs = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
rounds = range(1, pairs + 1)
def spread(v, f="%.2f"):
    return f"{f % statistics.median(v)} ({f % min(v)}-{f % max(v)})"
def times(c, name):
    rows = [list(map(float, open(f"{d}/{c}_{name}_{i}.time").read().split()[-3:])) for i in rounds]
    return [r[0] for r in rows], [r[1] + r[2] for r in rows]
def baseline(c, name):
    out = []
    for i in rounds:
        kv = dict(w.split("=", 1) for w in open(f"{d}/{c}_{name}_{i}.txt").read().split())
        out.append(kv)
    return out
failed = []
print(f"\n{pairs} interleaved rounds per configuration (dsmplan, OMPL + Embree, OMPL + ClearanceIndex in rotating order); "
      "seconds: median (min-max); ratios per round, OMPL / dsmplan\n")
print("| mesh | max-agl | samples / edges | dsmplan wall s | OMPL + Embree wall s | ratio wall | dsmplan CPU s | "
      "OMPL + Embree CPU s | ratio CPU | OMPL + ClearanceIndex wall s | its ratio wall | its ratio CPU | load |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
phases = []
for c in configs:
    mesh, agl = c.split("_")
    dw, dc = times(c, "dsmplan"); ew, ec = times(c, "embree"); iw, ic = times(c, "index")
    stats = [json.load(open(f"{d}/{c}_dsmplan_{i}.json")) for i in rounds]
    ours = {(s["roadmap_nodes"], s["roadmap_edges"]) for s in stats}
    for name in ("embree", "index"):
        for kv in baseline(c, name):
            theirs = (int(kv["samples"]), int(kv["edges"]))
            if {theirs} != ours:
                failed.append(f"{c}: dsmplan samples/edges {ours}, OMPL + {name} {theirs}")
            if kv["solved"] != kv["legs"]:
                failed.append(f"{c}: OMPL + {name} solved {kv['solved']} of {kv['legs']} legs")
    if any(s["refined_samples"] for s in stats):
        failed.append(f"{c}: dsmplan refined (its roadmap alone did not solve every leg)")
    loads = [open(f"{d}/{c}_load_{i}.txt").read().split()[0] for i in rounds]
    n, e = next(iter(ours))
    print(f"| {mesh.replace('064m', '0.64 m').replace('1m', '1 m')} | {agl} | {n:,} / {e:,} | {spread(dw)} | "
          f"{spread(ew)} | {spread([b / a for a, b in zip(dw, ew)], '%.2fx')} | {spread(dc)} | {spread(ec)} | "
          f"{spread([b / a for a, b in zip(dc, ec)], '%.2fx')} | {spread(iw)} | "
          f"{spread([b / a for a, b in zip(dw, iw)], '%.2fx')} | {spread([b / a for a, b in zip(dc, ic)], '%.2fx')} | "
          f"{min(loads)}-{max(loads)} |")
    med = lambda key, rows: statistics.median(float(r[key]) for r in rows)
    e_rows = baseline(c, "embree")
    phases.append(
        f"| {c} | {med('seconds_read', stats):.3f} | {med('seconds_index', stats):.3f} | "
        f"{med('seconds_roadmap', stats):.3f} | {med('seconds_query', stats) + med('seconds_smooth', stats):.4f} | "
        f"{med('read_s', e_rows):.3f} | {med('bvh_s', e_rows):.3f} | "
        f"{med('index_s', e_rows) - med('bvh_s', e_rows):.3f} | {med('roadmap_s', e_rows):.3f} | "
        f"{med('query_s', e_rows) + med('simplify_s', e_rows):.4f} |")
print("\nWhere the time goes (medians, seconds; dsmplan's --stats, the baseline's own clock):\n")
print("| config | dsmplan read | index | roadmap | query + smooth | OMPL read | Embree BVH | floor | roadmap | "
      "query + simplify |")
print("|---|---|---|---|---|---|---|---|---|---|")
print("\n".join(phases))
if failed:
    print("\nFAILED:\n" + "\n".join(failed))
    sys.exit(1)
print("\nsame samples and edges in every run, every leg solved by both")
PY
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
