#!/usr/bin/env bash
# Issue 19, point 2: `dsmplan plan` against OMPL's PRM with an Embree 3 BVH (bench_ompl_plan,
# bench/ompl_plan_process.cpp) as whole processes, on the NRW tile's XY-3 mesh at 1 m and at
# 0.64 m (the tile resampled bilinear, as bench_plan_ompl does), at --max-agl 120 and 30, with
# the same samples, edges and waypoints (4, 3 legs; 30 m above the ground at --max-agl 120, 20 m
# at 30, where 30 m would touch the ceiling). Each configuration: one untimed run of each, then
# PAIRS rounds of dsmplan, dsmplan with its index kept in a file (--index: the untimed run built
# and wrote it, the timed runs open it), OMPL + Embree, OMPL + ClearanceIndex (OMPL given
# dsmplan's index as its checker, for comparison) and the same opening dsmplan's kept index file
# (bench_ompl_plan --index-file), in an order that rotates from round to round,
# each timed from outside by bench/timed.py (wall, user + sys, to the microsecond),
# the load average before each round. Prints per configuration the medians with min-max of wall
# and CPU seconds and of the ratios OMPL / dsmplan, both programs' samples and edges (fails when
# they differ, a leg is unsolved, a kept index was not reused or gave another path) and where
# each spends its time (dsmplan's --stats, the baseline's own phases; medians).
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
        bench/timed.py "$time" build/dsmplan plan "$dir/nrw_$mesh.ply" --waypoints \
          "$dir/wp_$config.csv" --max-agl "$agl" -o "$dir/${config}_dsmplan.csv" -q --stats "$dir/${config}_dsmplan_$i.json"
        ;;
      kept)
        bench/timed.py "$time" build/dsmplan plan "$dir/nrw_$mesh.ply" --waypoints \
          "$dir/wp_$config.csv" --max-agl "$agl" -o "$dir/${config}_kept.csv" -q --stats "$dir/${config}_kept_$i.json" \
          --index "$dir/nrw_$mesh.index"
        ;;
      keptompl)
        bench/timed.py "$time" "$baseline" "$dir/nrw_$mesh.ply" --waypoints "$dir/wp_$config.csv" \
          --max-agl "$agl" -o "$dir/${config}_$name.csv" --checker index --index-file "$dir/nrw_$mesh.index" \
          > "$dir/${config}_${name}_$i.txt"
        ;;
      embree | index)
        bench/timed.py "$time" "$baseline" "$dir/nrw_$mesh.ply" --waypoints "$dir/wp_$config.csv" \
          --max-agl "$agl" -o "$dir/${config}_$name.csv" --checker "$name" > "$dir/${config}_${name}_$i.txt"
        ;;
    esac
  }
  rm -f "$dir/nrw_$mesh.index"  # built by the untimed run, from this build
  for name in dsmplan kept embree index keptompl; do run $name 0; done
  order=(dsmplan kept embree index keptompl)
  for i in $(seq 1 "$pairs"); do
    cut -d' ' -f1-3 /proc/loadavg > "$dir/${config}_load_$i.txt"
    # The order rotates from round to round, so no program always follows the same one (the
    # kernel's cost of fresh huge pages depends on what ran just before).
    for k in 0 1 2 3 4; do run "${order[$(((i - 1 + k) % 5))]}" "$i"; done
  done
done
python3 - "$dir" "$pairs" "${configs[@]}" <<'PY'
import json, statistics, sys
d, pairs, configs = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
rounds = range(1, pairs + 1)
def spread(v, f="%.3f"):
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
print(f"\n{pairs} interleaved rounds per configuration (dsmplan, dsmplan --index kept, OMPL + Embree, "
      "OMPL + ClearanceIndex in rotating order); seconds: median (min-max); ratios per round, OMPL / dsmplan\n")
print("| mesh | max-agl | samples / edges | dsmplan wall s | OMPL + Embree wall s | ratio wall | dsmplan CPU s | "
      "OMPL + Embree CPU s | ratio CPU | OMPL + ClearanceIndex wall s | its ratio wall | its ratio CPU | load |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
kept_rows = []
phases = []
for c in configs:
    mesh, agl = c.split("_")
    dw, dc = times(c, "dsmplan"); ew, ec = times(c, "embree"); iw, ic = times(c, "index"); kw, kc = times(c, "kept")
    ow, oc = times(c, "keptompl")
    stats = [json.load(open(f"{d}/{c}_dsmplan_{i}.json")) for i in rounds]
    kept = [json.load(open(f"{d}/{c}_kept_{i}.json")) for i in rounds]
    ours = {(s["roadmap_nodes"], s["roadmap_edges"]) for s in stats}
    if {(s["roadmap_nodes"], s["roadmap_edges"]) for s in kept} != ours:
        failed.append(f"{c}: dsmplan with a kept index built another roadmap")
    if not all(s["index_reused"] for s in kept):
        failed.append(f"{c}: dsmplan --index did not reuse its index")
    if open(f"{d}/{c}_kept.csv").read() != open(f"{d}/{c}_dsmplan.csv").read():
        failed.append(f"{c}: dsmplan with a kept index wrote another path")
    for name in ("embree", "index", "keptompl"):
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
    kept_rows.append(
        f"| {mesh.replace('064m', '0.64 m').replace('1m', '1 m')} | {agl} | {spread(kw)} | {spread(ew)} | "
        f"{spread([b / a for a, b in zip(kw, ew)], '%.2fx')} | {spread(kc)} | "
        f"{spread([b / a for a, b in zip(kc, ec)], '%.2fx')} | "
        f"{statistics.median(s['seconds_read'] for s in kept):.3f} | {statistics.median(s['seconds_index'] for s in kept):.3f} | "
        f"{spread(ow)} | {spread([b / a for a, b in zip(kw, ow)], '%.2fx')} | {spread([b / a for a, b in zip(kc, oc)], '%.2fx')} |")
    med = lambda key, rows: statistics.median(float(r[key]) for r in rows)
    e_rows = baseline(c, "embree")
    phases.append(
        f"| {c} | {med('seconds_read', stats):.3f} | {med('seconds_index', stats):.3f} | "
        f"{med('seconds_roadmap', stats):.3f} | {med('seconds_query', stats) + med('seconds_smooth', stats):.4f} | "
        f"{med('read_s', e_rows):.3f} | {med('bvh_s', e_rows):.3f} | "
        f"{med('index_s', e_rows) - med('bvh_s', e_rows):.3f} | {med('roadmap_s', e_rows):.3f} | "
        f"{med('query_s', e_rows) + med('simplify_s', e_rows):.4f} |")
print("\nThe same runs, dsmplan with its index kept in a file (`--index`, opened, not built; the same path):\n")
print("| mesh | max-agl | dsmplan --index wall s | OMPL + Embree wall s | ratio wall | dsmplan --index CPU s | ratio CPU | "
      "read s (hash, header, index file) | index s | OMPL + the kept index wall s | its ratio wall | its ratio CPU |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
print("\n".join(kept_rows))
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
