#!/usr/bin/env bash
# Issue 37, point 2: dsmplan's bounded conservative simplification against hmm itself
# (fogleman/hmm, Fogleman's greedy-insertion heightmap mesher, built here from its public
# repository at a pinned commit with its own Makefile: -O3 -flto -march=native) as whole
# processes, at the same band width: `dsmplan simplify DSM --max-error 0.4 --conservative`
# (0 <= mesh - DSM <= 0.4 m) against `hmm -z Z -e 0.2/Z` (|mesh - DSM| <= 0.2 m), on the NRW
# DOM1 tile and on the Delft AHN3 DSM (gridded at 1 m as scripts/sample.sh grids it, its holes
# filled by `--fill-holes 30`, since hmm cannot take nodata; both programs get the same filled
# DSM). hmm reads a 16-bit PNG: each DSM is scaled by gdal_translate over its own height range
# (min-max to 0-65535), so Z = max - min and hmm's heights are quantised to Z / 65535 (1.2 mm on
# the tile); the script prints that step and the round trip's largest error. (On the tile this
# is the issue's set-up, 87.29-167.74 m, Z 80.45: hmm's 435,856 vertices; its rounded figures,
# 87.3-167.8 m with -z 80.5 -e 0.0024845, give 435,667.) hmm writes a binary STL (its vertices
# counted as unique positions), dsmplan a binary PLY (its header's count). About 30 s a run.
# Each DSM: one untimed run of each (hmm with its own report of points and error), then PAIRS
# rounds of the two in an order that alternates from round to round, each timed from outside by
# bench/timed.py (wall, user + sys, to the microsecond), the load average before each round.
# Prints per DSM the medians with min-max of wall and CPU seconds, of the ratios hmm / dsmplan
# (per round; the issue's goal: >= 3x wall, >= 2.5x CPU, no more vertices) and where dsmplan's
# time goes (its --stats).
#   bench/hmm_process.sh [PAIRS=5]
#   env: DSMPLAN (default build/dsmplan), HMM_SRC (git URL or path, default
#   https://github.com/fogleman/hmm; the commit below is checked out)
set -euo pipefail
cd "$(dirname "$0")/.."
pairs=${1:-5}
dsmplan=${DSMPLAN:-build/dsmplan}
hmm_src=${HMM_SRC:-https://github.com/fogleman/hmm}
hmm_commit=5ea611461e9f8b40f3d97e9f10fcf0f40592030b  # 2020-12-07, "Update README.md"
error=0.4
dir=out/bench/hmm
tile=data/nrw-dom1/dom1_32_356_5699_1_nw_2020.tif
[ -x "$dsmplan" ] || {
  echo "no $dsmplan: scripts/build.sh, or DSMPLAN=path/to/dsmplan" >&2
  exit 1
}
# GLM is hmm's one dependency; gdal_translate writes its PNGs; Python's GDAL and numpy check them.
scripts/deps.sh libglm-dev gdal-bin python3-gdal python3-numpy
py=python3
$py -c 'import numpy, osgeo.gdal' 2> /dev/null || py=/usr/bin/python3  # Debian's, not a pyenv one
mkdir -p "$dir"
hmm=$dir/src/bin/release/hmm
if [ ! -x "$hmm" ] || [ "$(git -C "$dir/src" rev-parse HEAD)" != "$hmm_commit" ]; then
  rm -rf "$dir/src"
  git clone -q "$hmm_src" "$dir/src"
  git -C "$dir/src" -c advice.detachedHead=false checkout -q "$hmm_commit"
  make -C "$dir/src" release > "$dir/build.log" 2>&1 || {
    tail -n 20 "$dir/build.log"
    exit 1
  }
fi
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores;" \
  "dsmplan $("$dsmplan" --version | cut -d' ' -f2) ($dsmplan) at $(git rev-parse --short HEAD);" \
  "hmm ${hmm_commit:0:7}; $(gcc --version | head -1)"

# The inputs: the tile as it is, Delft gridded and filled; each as hmm's 16-bit PNG.
"$dsmplan" grid data/delft-ahn3/ahn3_cropped_1.laz data/delft-ahn3/ahn3_cropped_2.laz --crs EPSG:7415 --res 1 \
  --fill-holes 30 -o "$dir/delft_dsm.tif" -q --json > "$dir/delft_grid.json"
names=(nrw delft)
declare -A dsm=([nrw]=$tile [delft]=$dir/delft_dsm.tif)
for name in "${names[@]}"; do
  # The height range, exactly (float32 values), and that nothing is nodata.
  range=$($py - "${dsm[$name]}" <<'PY'
import sys
import numpy as np
from osgeo import gdal
dataset = gdal.Open(sys.argv[1])  # kept: its band dies with it
band = dataset.GetRasterBand(1)
a = band.ReadAsArray()
bad = np.isnan(a) if band.GetNoDataValue() is None else np.isnan(a) | (a == band.GetNoDataValue())
if bad.any():
    sys.exit(f"{sys.argv[1]}: {bad.sum()} nodata cells; hmm cannot take them")
print(repr(float(a.min())), repr(float(a.max())))
PY
  )
  read -r lo hi <<< "$range"
  gdal_translate -q -ot UInt16 -scale "$lo" "$hi" 0 65535 -a_nodata none -of PNG "${dsm[$name]}" "$dir/$name.png"
  rm -f "$dir/$name.png.aux.xml"
  # hmm's error is a fraction of its z scale, two-sided: E / 2 in metres.
  $py - "${dsm[$name]}" "$dir/$name.png" "$lo" "$hi" "$error" > "$dir/${name}_scale.txt" <<'PY'
import sys
import numpy as np
from osgeo import gdal
dsm, png, lo, hi, error = sys.argv[1], sys.argv[2], *map(float, sys.argv[3:])
z = hi - lo
a = gdal.Open(dsm).ReadAsArray().astype(np.float64)
q = gdal.Open(png).ReadAsArray().astype(np.float64)
trip = np.abs(lo + q * z / 65535 - a).max()
print(f"{z!r} {error / 2 / z!r} {lo} {hi} {z / 65535 * 1000:.3f} {trip * 1000:.3f} {a.shape[1]} {a.shape[0]}")
PY
done

for name in "${names[@]}"; do
  read -r z e _ < "$dir/${name}_scale.txt"
  run() {  # run PROGRAM I: one timed run; I = 0 is the untimed first one
    case $1 in
      dsmplan)
        bench/timed.py "$dir/${name}_dsmplan_$2.time" "$dsmplan" simplify "${dsm[$name]}" --max-error "$error" \
          --conservative -o "$dir/${name}_dsmplan.ply" -q --stats "$dir/${name}_dsmplan_$2.json"
        ;;
      hmm)
        if [ "$2" = 0 ]; then  # its own report: points, triangles, error reached
          bench/timed.py "$dir/${name}_hmm_$2.time" "$hmm" -z "$z" -e "$e" "$dir/$name.png" "$dir/${name}_hmm.stl" \
            > "$dir/${name}_hmm_report.txt"
        else
          bench/timed.py "$dir/${name}_hmm_$2.time" "$hmm" -z "$z" -e "$e" -q "$dir/$name.png" "$dir/${name}_hmm.stl"
        fi
        ;;
    esac
  }
  run dsmplan 0
  run hmm 0
  order=(dsmplan hmm)
  for i in $(seq 1 "$pairs"); do
    cut -d' ' -f1-3 /proc/loadavg > "$dir/${name}_load_$i.txt"
    # The order alternates, so neither program always follows the other.
    for k in 0 1; do run "${order[$(((i - 1 + k) % 2))]}" "$i"; done
  done
done

$py - "$dir" "$pairs" "$error" "${names[@]}" <<'PY'
import json, re, statistics, sys
import numpy as np
d, pairs, error, names = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), sys.argv[4:]
rounds = range(1, pairs + 1)
label = {"nrw": "NRW DOM1 tile", "delft": "Delft AHN3, holes filled"}
def spread(v, f="%.3f"):
    return f"{f % statistics.median(v)} ({f % min(v)}-{f % max(v)})"
def times(n, prog):
    rows = [list(map(float, open(f"{d}/{n}_{prog}_{i}.time").read().split())) for i in rounds]
    return [r[0] for r in rows], [r[1] + r[2] for r in rows]
def ply_vertices(path):
    with open(path, "rb") as f:
        for line in f:
            if line.startswith(b"element vertex"):
                return int(line.split()[2])
            if line.startswith(b"end_header"):
                break
    raise SystemExit(f"{path}: no vertex count")
def stl_vertices(path):  # unique positions of a binary STL's corners
    raw = np.fromfile(path, dtype=np.uint8, offset=84).reshape(-1, 50)
    corners = np.ascontiguousarray(raw[:, 12:48]).view("<u4").reshape(-1, 3)
    return len(np.unique(corners, axis=0)), len(raw)
print(f"\n{pairs} interleaved rounds per DSM (dsmplan, hmm; the order alternating), band {error} m: "
      f"dsmplan --max-error {error} --conservative, hmm -e {error / 2} m / Z; seconds: median (min-max); "
      "ratios per round, hmm / dsmplan\n")
print("| DSM | cells | dsmplan wall s | hmm wall s | ratio wall | dsmplan CPU s | hmm CPU s | ratio CPU | "
      "vertices dsmplan | vertices hmm | load |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
notes, goals, phases = [], [], []
for n in names:
    z, e, lo, hi, step_mm, trip_mm, w, h = open(f"{d}/{n}_scale.txt").read().split()
    dw, dc = times(n, "dsmplan"); hw, hc = times(n, "hmm")
    rw = [b / a for a, b in zip(dw, hw)]; rc = [b / a for a, b in zip(dc, hc)]
    dv = ply_vertices(f"{d}/{n}_dsmplan.ply")
    hv, ht = stl_vertices(f"{d}/{n}_hmm.stl")
    stats = [json.load(open(f"{d}/{n}_dsmplan_{i}.json")) for i in rounds]
    if {s["vertices_out"] for s in stats} != {dv}:
        raise SystemExit(f"{n}: dsmplan's vertex counts differ between runs or from its PLY")
    report = open(f"{d}/{n}_hmm_report.txt").read()
    hmm_points = int(re.search(r"points = (\d+)", report).group(1))
    hmm_error = float(re.search(r"error = (\S+)", report).group(1))
    loads = [open(f"{d}/{n}_load_{i}.txt").read().split()[0] for i in rounds]
    print(f"| {label.get(n, n)} | {int(w) * int(h):,} | {spread(dw)} | {spread(hw)} | {spread(rw, '%.2fx')} | "
          f"{spread(dc)} | {spread(hc)} | {spread(rc, '%.2fx')} | {dv:,} | {hv:,} | {min(loads)}-{max(loads)} |")
    notes.append(f"- {n}: {w} x {h} cells, heights {float(lo):.3f}-{float(hi):.3f} m scaled to 0-65535: "
                 f"hmm -z {float(z):.4f} -e {float(e):.7f} (+-{float(e) * float(z):.3f} m), 16-bit step "
                 f"{step_mm} mm, round trip at most {trip_mm} mm; hmm's own report: {hmm_points:,} points "
                 f"({hv:,} unique positions in its STL, {ht:,} triangles), error reached "
                 f"{hmm_error * float(z):.4f} m; dsmplan: max above {stats[0]['max_above_m']:.4f} m, "
                 f"below {stats[0]['max_below_m']:.4f} m")
    for what, v, bar in (("wall", rw, 3.0), ("CPU", rc, 2.5)):
        m = statistics.median(v)
        goals.append(f"- {n}, {what} >= {bar}x: {'holds' if m >= bar else 'does not hold'} "
                     f"(median {m:.2f}x, min {min(v):.2f}x)")
    goals.append(f"- {n}, no more vertices: {'holds' if dv <= hv else 'does not hold'} "
                 f"(dsmplan {dv:,}, hmm {hv:,}: {100 * (dv - hv) / hv:+.1f} %)")
    med = lambda k: statistics.median(s["seconds"][k] for s in stats)
    phases.append(f"| {n} | {med('read'):.3f} | {med('simplify'):.3f} | {med('write'):.3f} | {med('total'):.3f} | "
                  f"{statistics.median(w - s['seconds']['total'] for w, s in zip(dw, stats)):.3f} |")
print("\n" + "\n".join(notes))
print("\nThe goal (issue 37, point 2), on the medians:\n" + "\n".join(goals))
print("\nWhere dsmplan's time goes (its --stats, medians, seconds; outside = process wall - total):\n")
print("| DSM | read | simplify | write | total | outside |")
print("|---|---:|---:|---:|---:|---:|")
print("\n".join(phases))
PY
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
