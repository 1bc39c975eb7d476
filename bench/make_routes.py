#!/usr/bin/env python3
"""Random street-to-street routes over a DSM, for `dsmplan plan --routes` (issue 35, point 5).

A street cell is one no higher than 0.5 m above the lowest cell within 10 m (no roof, no tree
crown: the open ground between buildings). Each route has two waypoints 5-15 m above such cells,
200-1,500 m apart (x,y), drawn with a fixed seed; the CSV is route,x,y,z in the DSM's CRS.
  bench/make_routes.py DSM.tif COUNT OUT.csv [SEED=1]"""
import sys

import numpy as np
from osgeo import gdal


def street_cells(z, cell, margin_m):
    """Rows and columns of the street cells of heights `z` (cells of `cell` m), `margin_m` away
    from the raster's edge."""
    r = int(round(10 / cell))
    padded = np.pad(z, r, mode="edge")
    low = np.full_like(z, np.inf)
    for dy in range(0, 2 * r + 1, 2):
        for dx in range(0, 2 * r + 1, 2):
            low = np.minimum(low, padded[dy:dy + z.shape[0], dx:dx + z.shape[1]])
    rows, cols = np.nonzero(np.isfinite(z) & (z <= low + 0.5))
    margin = margin_m / cell
    keep = (rows > margin) & (cols > margin) & (rows < z.shape[0] - margin) & (cols < z.shape[1] - margin)
    return rows[keep], cols[keep]


def main():
    dsm_path, count, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    rng = np.random.default_rng(int(sys.argv[4]) if len(sys.argv) > 4 else 1)
    source = gdal.Open(dsm_path)
    z = source.GetRasterBand(1).ReadAsArray().astype(np.float64)
    x0, cx, _, y0, _, cy = source.GetGeoTransform()
    rows, cols = street_cells(z, abs(cx), 20)  # away from the tile's edge
    xs, ys = x0 + (cols + 0.5) * cx, y0 + (rows + 0.5) * cy
    with open(out, "w") as f:
        f.write("route,x,y,z\n")
        made = 0
        while made < count:
            a, b = rng.integers(0, len(xs), 2)
            if not 200 <= np.hypot(xs[a] - xs[b], ys[a] - ys[b]) <= 1500:
                continue
            made += 1
            for k in (a, b):
                f.write("r%d,%.2f,%.2f,%.2f\n" % (made, xs[k], ys[k], z[rows[k], cols[k]] + rng.uniform(5, 15)))


if __name__ == "__main__":
    main()
