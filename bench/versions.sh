#!/usr/bin/env bash
# Two builds of the dsmplan CLI on one command as whole processes (issue 19, point 5: "nothing
# gets slower elsewhere"): paired and interleaved (base, new, base, new, ...; the method of
# bench/simplify_process.sh and bench/pairs.sh), each run's wall time and CPU time (user + sys of
# the child, from wait4(): microseconds, where /usr/bin/time rounds to hundredths), the load
# average before each pair, then the medians with min-max of wall and CPU seconds and of the
# per-pair ratios new / base (< 1: the new build is faster). OUT in the arguments is replaced by a
# scratch file name (the output each run writes), so the command can name its output.
#   bench/versions.sh BASE_CLI NEW_CLI PAIRS ARGS...
# e.g. git worktree add --detach /tmp/base <commit> && (cd /tmp/base && cmake -S . -B build
#        -DCMAKE_BUILD_TYPE=Release && cmake --build build --target dsmplan)
#      bench/versions.sh /tmp/base/build/dsmplan build/dsmplan 7 mesh data/nrw-dom1/TILE.tif -o OUT.ply -q
set -euo pipefail
out=$(mktemp -d /tmp/versions-XXXXXX)
trap 'rm -rf "$out"' EXIT
python3 - "$out" "$@" <<'PY'
import os, statistics, subprocess, sys, time
out, base, new, pairs, args = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5:]
args = [a.replace("OUT", f"{out}/out") for a in args]
print("command: dsmplan " + " ".join(sys.argv[5:]))

def run(cli):
    start = time.perf_counter()
    child = subprocess.Popen([cli] + args, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"{cli} failed")
    return wall, usage.ru_utime + usage.ru_stime

times = {"base": [], "new": []}
for i in range(1, pairs + 1):
    print(f"pair {i}: load average {' '.join(open('/proc/loadavg').read().split()[:3])}", flush=True)
    times["base"].append(run(base))
    times["new"].append(run(new))

def line(label, values):
    print(f"| {label} | {statistics.median(values):.3f} | {min(values):.3f}-{max(values):.3f} |")

bw, bc = [t[0] for t in times["base"]], [t[1] for t in times["base"]]
nw, nc = [t[0] for t in times["new"]], [t[1] for t in times["new"]]
print(f"\n{pairs} interleaved pairs\n\n| measure | median | min-max |\n|---|---|---|")
line("base wall s", bw); line("new wall s", nw)
line("base CPU s (user + sys)", bc); line("new CPU s (user + sys)", nc)
line("ratio new / base, wall", [n / b for n, b in zip(nw, bw)])
line("ratio new / base, CPU", [n / b for n, b in zip(nc, bc)])
print(f"load average after: {' '.join(open('/proc/loadavg').read().split()[:3])}")
PY
