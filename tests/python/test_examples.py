# The scripts in examples/ run as a user runs them (a python3 process, the module on
# PYTHONPATH) into a temporary folder, and what they write is checked by independent oracles:
# the GeoJSON parsed with json, its points taken back to the DSM's CRS by GDAL's own Python
# bindings (osr) and the path's distance to the DSM's cells as solid columns re-measured with
# numpy every 0.25 m; the .plan parsed with json, its waypoints found where the CSV puts them.
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from osgeo import gdal, osr

import dsmplan

gdal.UseExceptions()
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
DATA = os.path.abspath(os.environ.get("DSMPLAN_DATA_DIR", os.path.join(ROOT, "data")))
NRW_DSM = os.path.join(DATA, "nrw-dom1", "nrw_dom1_crop500m_1m.tif")
NRW_WAYPOINTS = os.path.join(DATA, "nrw-dom1", "sample_waypoints.csv")
DELFT_WAYPOINTS = os.path.join(DATA, "delft-ahn3", "low_waypoints.csv")
DELFT_LAZ = [os.path.join(DATA, "delft-ahn3", f"ahn3_cropped_{i}.laz") for i in (1, 2)]


def run_example(name, *args, cwd):
    env = dict(os.environ, PYTHONPATH=os.path.dirname(dsmplan.__file__))
    script = os.path.join(ROOT, "examples", name)
    assert sum(1 for _ in open(script)) <= 40, f"{name}: an example stays short"
    result = subprocess.run([sys.executable, script, *args], capture_output=True, text=True, env=env, cwd=cwd)
    assert result.returncode == 0, result.stderr
    return result.stdout


def read_waypoints(path):
    rows = [line for line in open(path) if line.strip() and not line.startswith("#")]
    return np.array([[float(v) for v in row.split(",")] for row in rows[1:]])


def to_crs(epsg, lonlat):
    """lon, lat (WGS 84) to x, y in EPSG:epsg, by GDAL's osr."""
    wgs84, target = osr.SpatialReference(), osr.SpatialReference()
    wgs84.ImportFromEPSG(4326)
    target.ImportFromEPSG(epsg)
    for srs in (wgs84, target):
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    transform = osr.CoordinateTransformation(wgs84, target)
    return np.array([transform.TransformPoint(lon, lat)[:2] for lon, lat in lonlat])


def column_distances(point, heights, transform):
    """Distance from a 3D point to every DSM cell within 4 m as a solid column (-inf to its height)."""
    x0, cx, _, y0, _, ny = transform
    col, row = (point[0] - x0) / cx, (point[1] - y0) / ny
    c0, c1 = int(max(0, col - 5)), int(min(heights.shape[1], col + 6))
    r0, r1 = int(max(0, row - 5)), int(min(heights.shape[0], row + 6))
    cols, rows = np.meshgrid(np.arange(c0, c1), np.arange(r0, r1))
    west, north = x0 + cols * cx, y0 + rows * ny
    dx = np.maximum(np.maximum(west - point[0], point[0] - (west + cx)), 0)
    dy = np.maximum(np.maximum(point[1] - north, (north + ny) - point[1]), 0)
    dz = np.maximum(point[2] - heights[r0:r1, c0:c1], 0)
    d = np.sqrt(dx**2 + dy**2 + dz**2)
    return d[np.isfinite(d)]


def test_dsm_to_path_writes_a_geojson_path_that_keeps_its_distance_to_the_dsm(tmp_path):
    output = str(tmp_path / "path.geojson")
    out = run_example("dsm_to_path.py", NRW_DSM, NRW_WAYPOINTS, output, cwd=tmp_path)
    assert "path.geojson:" in out
    assert os.listdir(tmp_path) == ["path.geojson"]
    geojson = json.load(open(output))
    features = geojson["features"] if geojson["type"] == "FeatureCollection" else [geojson]
    lines = [f["geometry"] for f in features if f["geometry"]["type"] == "LineString"]
    assert len(lines) == 1
    lonlath = np.array(lines[0]["coordinates"])
    assert lonlath.shape[1] == 3 and len(lonlath) >= 3
    # Where the DSM lies (its corners by osr): Essen, about 7.0 E, 51.4 N.
    ds = gdal.Open(NRW_DSM)
    x0, cx, _, y0, _, ny = ds.GetGeoTransform()
    assert ((lonlath[:, 0] > 6.9) & (lonlath[:, 0] < 7.1) & (lonlath[:, 1] > 51.3) & (lonlath[:, 1] < 51.5)).all()
    xy = to_crs(25832, lonlath[:, :2])
    assert (xy[:, 0] > x0).all() and (xy[:, 0] < x0 + cx * ds.RasterXSize).all()
    assert (xy[:, 1] < y0).all() and (xy[:, 1] > y0 + ny * ds.RasterYSize).all()
    # Through every waypoint; the heights are above the ellipsoid: the geoid's undulation there
    # (about 47 m, constant to a few cm over 500 m) is what the waypoints tell.
    waypoints = read_waypoints(NRW_WAYPOINTS)
    undulation = []
    for w in waypoints:
        k = np.argmin(np.hypot(*(xy - w[:2]).T))
        assert np.hypot(*(xy[k] - w[:2])) < 0.01
        undulation.append(lonlath[k, 2] - w[2])
    assert 40 < np.mean(undulation) < 55 and np.ptp(undulation) < 0.05
    path = np.column_stack([xy, lonlath[:, 2] - np.mean(undulation)])
    heights = ds.GetRasterBand(1).ReadAsArray().astype(float)
    nodata = ds.GetRasterBand(1).GetNoDataValue()
    if nodata is not None:
        heights[heights == nodata] = np.nan
    nearest = np.inf
    for p, q in zip(path[:-1], path[1:]):
        for t in np.linspace(0, 1, max(1, int(np.ceil(np.linalg.norm(q - p) / 0.25))) + 1):
            d = column_distances(p + t * (q - p), heights, (x0, cx, 0, y0, 0, ny))
            nearest = min(nearest, d.min() if d.size else np.inf)
    assert nearest >= 2.0 - 0.05  # safety 2 m, less the heights' rounding and the undulation's spread
    # And the figure the script printed (the plan stage's verification) is the one measured here.
    printed = float(re.search(r"at least ([0-9.]+) m from the DSM", out).group(1))
    assert nearest == pytest.approx(printed, abs=0.05)


def test_laz_to_mission_writes_a_plan_through_the_waypoints(tmp_path):
    output = str(tmp_path / "mission.plan")
    run_example("laz_to_mission.py", output, DELFT_WAYPOINTS, *DELFT_LAZ, cwd=tmp_path)
    assert os.listdir(tmp_path) == ["mission.plan"]
    plan = json.load(open(output))
    assert plan["fileType"] == "Plan"
    items = plan["mission"]["items"]
    commands = [item["command"] for item in items]
    assert commands[0] == 22  # MAV_CMD_NAV_TAKEOFF first
    assert commands[-1] in (20, 21)  # then home: return to launch, or land
    home = plan["mission"]["plannedHomePosition"]
    # Delft, by the data's own corner (RD New, EPSG:28992): 4.37 E, 52.0 N.
    assert 4.3 < home[1] < 4.45 and 51.95 < home[0] < 52.05
    positions = np.array([item["params"][4:7] for item in items if item["command"] == 16])  # NAV_WAYPOINT
    xy = to_crs(28992, positions[:, [1, 0]])
    for w in read_waypoints(DELFT_WAYPOINTS):
        assert np.hypot(*(xy - w[:2]).T).min() < 0.01, f"waypoint {w} not in the mission"
    # Relative altitudes: above home, at most the ceiling (10 m over the terrain) plus the street's slope.
    assert (positions[:, 2] > 0).all() and (positions[:, 2] < 20).all()
