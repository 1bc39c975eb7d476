#!/usr/bin/env python3
"""Random street-to-street missions on a held-out crop, with and without --snap (issue 35, point 4).

A new user's try: on a crop of the NRW tile that the tests do not use (its south-west 400 m,
outside the bundled sample), COUNT missions of three waypoints 4-12 m above street cells (a cell
no higher than 0.5 m above the lowest within 10 m, as bench/make_routes.py), 60-300 m apart, drawn
with a fixed seed. Each is planned by `dsmplan plan MESH --dsm CROP --max-agl 120` without and with
`--snap R`; prints how many are refused and why, how many --snap plans, how far it moved the
waypoints, and checks every planned path against the DSM's cells as columns by brute force, every
5 cm (numpy, independent of dsmplan's own verification).
  bench/snap_missions.py DSMPLAN TILE.tif OUTDIR [COUNT=30] [SNAP=5] [SEED=7]"""
import json
import os
import subprocess
import sys

import numpy as np
from osgeo import gdal

from make_routes import street_cells  # this folder's: the street cells the routes bench draws from

SAFETY = 2.0


def column_distance(p, z, x0, y0, cx, cy):
    """Distance of p to the DSM's cells as solid columns (a cell's square from below to its top)."""
    reach = SAFETY + 1
    c0, c1 = int((p[0] - reach - x0) // cx), int((p[0] + reach - x0) // cx) + 1
    r0, r1 = int((y0 - p[1] - reach) // -cy), int((y0 - p[1] + reach) // -cy) + 1
    c0, r0 = max(c0, 0), max(r0, 0)
    block = z[r0:r1, c0:c1]
    cols = x0 + np.arange(c0, c0 + block.shape[1]) * cx
    rows = y0 + np.arange(r0, r0 + block.shape[0]) * cy  # top edge of each row
    dx = np.maximum(0, np.maximum(cols - p[0], p[0] - (cols + cx)))[None, :]
    dy = np.maximum(0, np.maximum((rows + cy) - p[1], p[1] - rows))[:, None]
    top = np.where(np.isnan(block), np.inf, block)
    dz = np.maximum(0, p[2] - top)
    return float(np.sqrt(dx * dx + dy * dy + dz * dz).min())


def path_clearance(path, z, gt):
    x0, cx, _, y0, _, cy = gt
    worst = np.inf
    for a, b in zip(path[:-1], path[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.05)))
        for t in np.linspace(0, 1, n + 1):
            worst = min(worst, column_distance(a + t * (b - a), z, x0, y0, cx, cy))
    return worst


def main():
    dsmplan, tile, out = sys.argv[1], sys.argv[2], sys.argv[3]
    count = int(sys.argv[4]) if len(sys.argv) > 4 else 30
    snap = sys.argv[5] if len(sys.argv) > 5 else "5"
    rng = np.random.default_rng(int(sys.argv[6]) if len(sys.argv) > 6 else 7)
    os.makedirs(out, exist_ok=True)
    crop, mesh = f"{out}/crop.tif", f"{out}/crop.ply"
    if not os.path.exists(crop):
        gdal.Translate(crop, tile, projWin=[356000, 5699400, 356400, 5699000])
    if not os.path.exists(mesh):
        subprocess.run([dsmplan, "simplify", crop, "--max-error", "0.4", "--conservative", "-o", mesh, "-q"],
                       check=True)
    source = gdal.Open(crop)
    z = source.GetRasterBand(1).ReadAsArray().astype(np.float64)
    nodata = source.GetRasterBand(1).GetNoDataValue()
    if nodata is not None:
        z[z == nodata] = np.nan
    gt = source.GetGeoTransform()
    rows, cols = street_cells(z, abs(gt[1]), 15)
    xs, ys = gt[0] + (cols + 0.5) * gt[1], gt[3] + (rows + 0.5) * gt[5]
    plain = {"planned": 0, "refused_wall": 0, "refused_other": 0}
    snapped = {"planned": 0, "refused": 0, "moves": [], "worst_clearance": np.inf}
    for m in range(count):
        picks = [int(rng.integers(0, len(xs)))]
        while len(picks) < 3:
            k = int(rng.integers(0, len(xs)))
            if 60 <= np.hypot(xs[k] - xs[picks[-1]], ys[k] - ys[picks[-1]]) <= 300:
                picks.append(k)
        wp = f"{out}/m{m}.csv"
        with open(wp, "w") as f:
            f.write("x,y,z\n")
            for k in picks:
                f.write("%.2f,%.2f,%.2f\n" % (xs[k], ys[k], z[rows[k], cols[k]] + rng.uniform(4, 12)))
        base = [dsmplan, "plan", mesh, "--dsm", crop, "--waypoints", wp, "--max-agl", "120", "-q"]
        run = subprocess.run(base + ["-o", f"{out}/m{m}_plain.csv"], capture_output=True, text=True)
        if run.returncode == 0:
            plain["planned"] += 1
        elif "closer than the safety distance" in run.stderr:
            plain["refused_wall"] += 1
        else:
            plain["refused_other"] += 1
        stats = f"{out}/m{m}.json"
        run = subprocess.run(base + ["-o", f"{out}/m{m}_snap.csv", "--snap", snap, "--stats", stats],
                             capture_output=True, text=True)
        if run.returncode != 0:
            snapped["refused"] += 1
            print(f"m{m} refused with --snap {snap}: {run.stderr.strip()[:200]}")
            continue
        snapped["planned"] += 1
        snapped["moves"] += [s["distance_m"] for s in json.load(open(stats)).get("snapped", [])]
        path = np.loadtxt(f"{out}/m{m}_snap.csv", delimiter=",", skiprows=1)
        snapped["worst_clearance"] = min(snapped["worst_clearance"], path_clearance(path, z, gt))
    moves = snapped["moves"]
    print(f"{count} missions on the held-out crop: without --snap {plain['planned']} planned, "
          f"{plain['refused_wall']} refused for a waypoint within {SAFETY:g} m of the columns, "
          f"{plain['refused_other']} refused otherwise; with --snap {snap}: {snapped['planned']} planned, "
          f"{snapped['refused']} refused; {len(moves)} waypoints moved, "
          f"median {np.median(moves) if moves else 0:.2f} m, at most {max(moves) if moves else 0:.2f} m; "
          f"least clearance of the snapped paths to the DSM's columns (brute force every 5 cm): "
          f"{snapped['worst_clearance']:.3f} m")


if __name__ == "__main__":
    main()
