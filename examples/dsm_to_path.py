#!/usr/bin/env python3
# A DSM GeoTIFF to a drone path as GeoJSON, as a GIS user scripts it with dsmplan:
# the DSM -> a conservative obstacle mesh (never below a roof, at most 0.4 m above the DSM)
# -> a path through the waypoints keeping 2 m from the mesh and from the DSM's cells as solid
# columns -> GeoJSON in WGS 84 (open it in QGIS or geojson.io over the DSM).
#
#   PYTHONPATH=build/python python3 examples/dsm_to_path.py [DSM.tif] [WAYPOINTS.csv] [OUT.geojson]
#
# WAYPOINTS.csv: x,y,z in the DSM's CRS, a header line, '#' comment lines.
import csv
import sys

import numpy as np

import dsmplan

dsm_file = sys.argv[1] if len(sys.argv) > 1 else "data/nrw-dom1/nrw_dom1_crop500m_1m.tif"
waypoints_file = sys.argv[2] if len(sys.argv) > 2 else "data/nrw-dom1/sample_waypoints.csv"
output = sys.argv[3] if len(sys.argv) > 3 else "path.geojson"

with open(waypoints_file) as f:
    rows = list(csv.reader(line for line in f if line.strip() and not line.startswith("#")))
waypoints = np.array(rows[1:], dtype=float)  # rows[0] is the header x,y,z

dsm = dsmplan.read_dsm(dsm_file)
mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
print(f"mesh: {len(mesh.vertices)} vertices, {len(mesh.faces)} triangles, "
      f"at most {mesh.certified['max_above_m']:.2f} m above the DSM")

try:
    flight = dsmplan.plan(mesh, waypoints, dsm=dsm, safety=2.0, max_agl=120.0)
except dsmplan.InputError as error:  # no path, or a waypoint under a roof: the text says which
    sys.exit(f"no path: {error}")
# GeoJSON heights are above the WGS 84 ellipsoid: the DSM's are DHHN2016 (EPSG:7837), which its
# CRS does not say; without PROJ's geoid grid they go through EGM96, about a metre off.
flight.write(output, vertical_crs="EPSG:7837", allow_approximate_vertical=True)
report = flight.report
print(f"{output}: {report['path_length_m']:.1f} m, at least {report['min_clearance_dsm_m']:.2f} m "
      f"from the DSM, at most {report['max_agl_m']:.1f} m above it")
