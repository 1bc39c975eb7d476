#!/usr/bin/env bash
# Two builds of the dsmplan CLI on one command as whole processes (issue 19, point 5: "nothing
# gets slower elsewhere"), timed from outside by /usr/bin/time: paired and interleaved (base, new,
# base, new, ...; the method of bench/simplify_process.sh and bench/pairs.sh), the load average
# before each pair, then the medians with min-max of wall and CPU seconds (user + sys) and of the
# per-pair ratios new / base (< 1: the new build is faster). OUT in the arguments is replaced by a
# scratch file name (the output each run writes), so the command can name its output.
#   bench/versions.sh BASE_CLI NEW_CLI PAIRS ARGS...
# e.g. git worktree add --detach /tmp/base <commit> && (cd /tmp/base && cmake -S . -B build
#        -DCMAKE_BUILD_TYPE=Release && cmake --build build --target dsmplan)
#      bench/versions.sh /tmp/base/build/dsmplan build/dsmplan 7 mesh data/nrw-dom1/TILE.tif -o OUT.ply -q
set -euo pipefail
base=$1 new=$2 pairs=$3
shift 3
out=$(mktemp -d /tmp/versions-XXXXXX)
trap 'rm -rf "$out"' EXIT
args=()
for a in "$@"; do args+=("${a//OUT/$out/out}"); done
echo "command: dsmplan ${*}"
for i in $(seq 1 "$pairs"); do
  echo "pair $i: load average $(cut -d' ' -f1-3 /proc/loadavg)"
  /usr/bin/time -f "%e %U %S" -o "$out/base_$i.time" "$base" "${args[@]}" > /dev/null
  /usr/bin/time -f "%e %U %S" -o "$out/new_$i.time" "$new" "${args[@]}" > /dev/null
done
python3 - "$out" "$pairs" <<'PY'
import statistics, sys
out, pairs = sys.argv[1], int(sys.argv[2])
def times(name):
    rows = [list(map(float, open(f"{out}/{name}_{i}.time").read().split())) for i in range(1, pairs + 1)]
    return [r[0] for r in rows], [r[1] + r[2] for r in rows]
bw, bc = times("base"); nw, nc = times("new")
def line(label, values):
    print(f"| {label} | {statistics.median(values):.3f} | {min(values):.3f}-{max(values):.3f} |")
print(f"\n{pairs} interleaved pairs\n\n| measure | median | min-max |\n|---|---|---|")
line("base wall s", bw); line("new wall s", nw)
line("base CPU s (user + sys)", bc); line("new CPU s (user + sys)", nc)
line("ratio new / base, wall", [n / b for n, b in zip(nw, bw)])
line("ratio new / base, CPU", [n / b for n, b in zip(nc, bc)])
PY
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
