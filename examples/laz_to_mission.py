#!/usr/bin/env python3
# LiDAR (LAZ) to a drone mission between buildings, as a GIS user scripts it with dsmplan:
# the points -> a DSM (median per 1 m cell) and a DTM (ground points, class 2, holes filled)
# -> a conservative obstacle mesh -> a mission through the waypoints at most 10 m above the
# terrain, 2 m from every roof and wall -> a QGroundControl .plan (takeoff, waypoints, return).
#
#   PYTHONPATH=build/python python3 examples/laz_to_mission.py [OUT.plan] [WAYPOINTS.csv] [LAZ ...]
#
# The Delft AHN3 crops state no CRS: they are RD New with NAP heights, EPSG:7415.
import csv
import sys

import numpy as np

import dsmplan

output = sys.argv[1] if len(sys.argv) > 1 else "mission.plan"
waypoints_file = sys.argv[2] if len(sys.argv) > 2 else "data/delft-ahn3/low_waypoints.csv"
laz = sys.argv[3:] or ["data/delft-ahn3/ahn3_cropped_1.laz", "data/delft-ahn3/ahn3_cropped_2.laz"]

dsm = dsmplan.grid(laz, res=1.0, crs="EPSG:7415")
dtm = dsmplan.grid(laz, res=1.0, crs="EPSG:7415", classes=[2], fill_holes=30)
print(f"DSM {dsm.heights.shape[1]} x {dsm.heights.shape[0]} cells, "
      f"{np.isnan(dsm.heights).mean():.1%} without points")
mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)

with open(waypoints_file) as f:
    rows = list(csv.reader(line for line in f if line.strip() and not line.startswith("#")))
waypoints = np.array(rows[1:], dtype=float)  # rows[0] is the header x,y,z

mission = dsmplan.plan(mesh, waypoints, dsm=dsm, dtm=dtm, max_agl=10, spacing=4, mission=True)
# Home's height above mean sea level from NAP: through EGM96 (about a metre off) when PROJ lacks
# the Dutch geoid grid; the waypoints' heights are relative to home, exact.
mission.write(output, firmware="px4", allow_approximate_vertical=True)
report = mission.report
print(f"{output}: {report['path_length_m']:.1f} m, at least {report['min_clearance_dsm_m']:.2f} m "
      f"from the DSM, at most {report['max_agl_m']:.2f} m above the terrain")
