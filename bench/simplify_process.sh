#!/usr/bin/env bash
# Issue 19, point 3: dsmplan's bounded simplification against greedy insertion as whole
# processes, at the same band width (--max-error E --conservative: 0 <= mesh - DSM <= E, against
# the two-sided greedy baseline at E/2), timed from outside by /usr/bin/time: paired and
# interleaved (dsmplan, greedy, dsmplan, ...), the load average before each pair, then the medians
# with min-max of wall seconds, CPU seconds (user + sys) and their ratios greedy/dsmplan, and both
# meshes' vertex counts.
#   bench/simplify_process.sh [PAIRS=7] [DSM=the NRW DOM1 tile] [E=0.4]
set -euo pipefail
cd "$(dirname "$0")/.."
pairs=${1:-7}
dsm=${2:-data/nrw-dom1/dom1_32_356_5699_1_nw_2020.tif}
error=${3:-0.4}
out=$(mktemp -d /tmp/simplify_process-XXXXXX)
trap 'rm -rf "$out"' EXIT
half=$(python3 -c "print($error / 2)")
for i in $(seq 1 "$pairs"); do
  echo "pair $i: load average $(cut -d' ' -f1-3 /proc/loadavg)"
  /usr/bin/time -f "%e %U %S" -o "$out/dsmplan_$i.time" build/dsmplan simplify "$dsm" --max-error "$error" \
    --conservative -o "$out/dsmplan.ply" -q --stats "$out/dsmplan.json"
  /usr/bin/time -f "%e %U %S" -o "$out/greedy_$i.time" build/bench/greedy_simplify "$dsm" "$half" "$out/greedy.ply" \
    > "$out/greedy.txt"
done
python3 - "$out" "$pairs" "$error" <<'PY'
import json, statistics, sys
out, pairs, error = sys.argv[1], int(sys.argv[2]), sys.argv[3]
def times(name):
    rows = [list(map(float, open(f"{out}/{name}_{i}.time").read().split())) for i in range(1, pairs + 1)]
    return [r[0] for r in rows], [r[1] + r[2] for r in rows]
dw, dc = times("dsmplan"); gw, gc = times("greedy")
def line(label, values, unit):
    print(f"| {label} | {statistics.median(values):.3f}{unit} | {min(values):.3f}-{max(values):.3f} |")
print(f"\n{pairs} interleaved pairs, E = {error} m\n\n| measure | median | min-max |\n|---|---|---|")
line("dsmplan wall s", dw, ""); line("greedy wall s", gw, "")
line("dsmplan CPU s (user + sys)", dc, ""); line("greedy CPU s (user + sys)", gc, "")
line("ratio greedy / dsmplan, wall (both cores)", [g / d for g, d in zip(gw, dw)], "x")
line("ratio greedy / dsmplan, CPU (per core)", [g / d for g, d in zip(gc, dc)], "x")
stats = json.load(open(f"{out}/dsmplan.json"))
print(f"\nvertices: dsmplan {stats['vertices_out']:,}, greedy {open(f'{out}/greedy.txt').read().split()[0]}")
PY
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
