#!/usr/bin/env python3
"""Street-level routes as issue 48 tried them: two waypoints 5-8 m above street cells that stand
at least 2.5 m from every building (no cell more than 1 m above the street within 3 cells),
MIN-MAX m apart (x,y), drawn with a fixed seed. A street cell is as bench/make_routes.py says.
  bench/make_street_routes.py DSM.tif COUNT OUT.csv [SEED=7] [MIN=100] [MAX=570]"""
import sys

import numpy as np
from osgeo import gdal

from make_routes import street_cells


def main():
    dsm_path, count, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    seed = int(sys.argv[4]) if len(sys.argv) > 4 else 7
    low, high = (float(sys.argv[5]), float(sys.argv[6])) if len(sys.argv) > 6 else (100, 570)
    source = gdal.Open(dsm_path)
    z = source.GetRasterBand(1).ReadAsArray().astype(np.float64)
    x0, cx, _, y0, _, cy = source.GetGeoTransform()
    rows, cols = street_cells(z, abs(cx), 20)
    open_cells = [(r, c) for r, c in zip(rows, cols) if np.nanmax(z[r - 3:r + 4, c - 3:c + 4]) <= z[r, c] + 1.0]
    rng = np.random.default_rng(seed)
    xs = np.array([x0 + (c + 0.5) * cx for _, c in open_cells])
    ys = np.array([y0 + (r + 0.5) * cy for r, _ in open_cells])
    with open(out, "w") as f:
        f.write("route,x,y,z\n")
        made = 0
        while made < count:
            a, b = rng.integers(0, len(open_cells), 2)
            if not low <= np.hypot(xs[a] - xs[b], ys[a] - ys[b]) <= high:
                continue
            made += 1
            for k in (a, b):
                r, c = open_cells[k]
                f.write("r%d,%.2f,%.2f,%.2f\n" % (made, xs[k], ys[k], z[r, c] + rng.uniform(5, 8)))


if __name__ == "__main__":
    main()
