# The Python module (python/dsmplan_module.cpp) as a GIS user scripts it, on a crop of the real
# NRW DSM. Oracles: GDAL's own Python bindings for the raster, brute force in numpy for the
# certified error (every valid cell centre against the triangle above it) and for the path's
# clearance (every 0.25 m of it against every triangle), a numpy reader of the PLY written.
import json
import os
import subprocess
import re

import numpy as np
import pytest
from osgeo import gdal

import dsmplan

gdal.UseExceptions()
SAMPLE = os.path.join(os.environ.get("DSMPLAN_DATA_DIR", "data"), "nrw-dom1", "nrw_dom1_crop500m_1m.tif")


@pytest.fixture(scope="module")
def crop(tmp_path_factory):
    """120 x 100 cells of the real DSM, with a block of nodata cut into it."""
    path = str(tmp_path_factory.mktemp("dsm") / "crop.tif")
    gdal.Translate(path, SAMPLE, srcWin=[200, 150, 120, 100], noData=-9999)
    ds = gdal.Open(path, gdal.GA_Update)
    band = ds.GetRasterBand(1)
    heights = band.ReadAsArray()
    heights[40:46, 60:70] = -9999
    band.WriteArray(heights)
    ds = None
    return path


def gdal_heights(path):
    ds = gdal.Open(path)
    band = ds.GetRasterBand(1)
    heights = band.ReadAsArray().astype(np.float32)
    heights[heights == band.GetNoDataValue()] = np.nan
    return heights, ds.GetGeoTransform()


def test_read_dsm_gives_gdals_heights_and_geotransform_without_a_copy(crop):
    dsm = dsmplan.read_dsm(crop)
    expected, transform = gdal_heights(crop)
    heights = dsm.heights
    assert heights.shape == (100, 120) and heights.dtype == np.float32
    np.testing.assert_array_equal(heights, expected)  # NaN where GDAL has nodata, equal elsewhere
    assert np.isnan(heights).sum() == 60
    assert dsm.transform == pytest.approx(transform, abs=0)
    assert "UTM zone 32N" in dsm.crs
    assert not heights.flags["OWNDATA"]  # a view of the DSM's own memory
    assert np.shares_memory(heights, dsm.heights)


def cell_centres(transform, shape):
    x0, cx, _, y0, _, ny = transform
    cols, rows = np.meshgrid(np.arange(shape[1]), np.arange(shape[0]))
    return x0 + (cols + 0.5) * cx, y0 + (rows + 0.5) * ny


def mesh_height_at_cells(vertices, faces, xs, ys):
    """The mesh's height above every cell centre (NaN where no triangle covers it), brute force."""
    out = np.full(xs.shape, np.nan)
    for a, b, c in vertices[faces]:
        lo = np.minimum(np.minimum(a, b), c)
        hi = np.maximum(np.maximum(a, b), c)
        inside = (xs >= lo[0] - 1e-9) & (xs <= hi[0] + 1e-9) & (ys >= lo[1] - 1e-9) & (ys <= hi[1] + 1e-9)
        if not inside.any():
            continue
        px, py = xs[inside], ys[inside]
        det = (b[1] - c[1]) * (a[0] - c[0]) + (c[0] - b[0]) * (a[1] - c[1])
        l1 = ((b[1] - c[1]) * (px - c[0]) + (c[0] - b[0]) * (py - c[1])) / det
        l2 = ((c[1] - a[1]) * (px - c[0]) + (a[0] - c[0]) * (py - c[1])) / det
        l3 = 1 - l1 - l2
        hit = (l1 >= -1e-9) & (l2 >= -1e-9) & (l3 >= -1e-9)
        z = l1 * a[2] + l2 * b[2] + l3 * c[2]
        sub = out[inside]
        sub[hit] = np.fmax(sub[hit], z[hit])  # on a shared edge both triangles give the same height
        out[inside] = sub
    return out


def test_simplify_is_conservative_and_its_certificate_holds_cell_by_cell(crop):
    dsm = dsmplan.read_dsm(crop)
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    vertices, faces = mesh.vertices, mesh.faces
    assert vertices.shape[1] == 3 and vertices.dtype == np.float64
    assert faces.shape[1] == 3 and faces.max() < len(vertices)
    assert not vertices.flags["OWNDATA"] and not faces.flags["OWNDATA"]
    assert len(vertices) < 0.5 * np.isfinite(dsm.heights).sum()  # it did simplify
    certified = mesh.certified
    assert certified["max_below_m"] == 0 and 0 < certified["max_above_m"] <= 0.4

    heights, transform = gdal_heights(crop)
    xs, ys = cell_centres(transform, heights.shape)
    above = mesh_height_at_cells(vertices, faces, xs, ys) - heights
    valid = np.isfinite(heights)
    assert np.isfinite(above[valid]).all(), "a valid cell no triangle covers"
    assert above[valid].min() >= -1e-6  # never below the DSM
    assert above[valid].max() <= 0.4 + 1e-6
    assert above[valid].max() == pytest.approx(certified["max_above_m"], abs=1e-4)
    assert dsmplan.mesh(dsm).certified is None


def point_triangle_distances(p, a, b, c):
    """Distance from point p to each triangle (a[i], b[i], c[i]) (Ericson, Real-Time Collision
    Detection, 5.1.5), vectorised over the triangles."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = p - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = p - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    vc, vb, va = d1 * d4 - d3 * d2, d5 * d2 - d1 * d6, d3 * d6 - d5 * d4
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = 1 / (va + vb + vc)
        q = a + ab * (vb * denom)[:, None] + ac * (vc * denom)[:, None]  # inside the face
        t_ab = np.clip(d1 / (d1 - d3), 0, 1)
        t_ac = np.clip(d2 / (d2 - d6), 0, 1)
        t_bc = np.clip((d4 - d3) / ((d4 - d3) + (d5 - d6)), 0, 1)
    cases = [
        ((d1 <= 0) & (d2 <= 0), a),
        ((d3 >= 0) & (d4 <= d3), b),
        ((d6 >= 0) & (d5 <= d6), c),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * t_ab[:, None]),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * t_ac[:, None]),
        ((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), b + (c - b) * t_bc[:, None]),
    ]
    for mask, point in reversed(cases):  # the first case that applies wins
        q = np.where(mask[:, None], point, q)
    return np.linalg.norm(p - q, axis=1)


def test_plan_keeps_the_safety_distance_from_every_triangle(crop):
    dsm = dsmplan.read_dsm(crop)
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    x0, cx, _, y0, _, ny = dsm.transform
    top = float(np.nanmax(dsm.heights))
    waypoints = np.array([[x0 + 10, y0 - 10, top - 5], [x0 + 110, y0 - 90, top - 5]])
    flight = dsmplan.plan(mesh, waypoints, safety=2.0, max_agl=60.0, spacing=8.0)
    path = flight.path
    assert flight.report["min_clearance_m"] >= 2.0 - 1e-9
    assert path.shape[1] == 3 and path.dtype == np.float64 and len(path) >= 2
    np.testing.assert_array_equal(path[0], waypoints[0])
    np.testing.assert_array_equal(path[-1], waypoints[-1])
    a, b, c = (mesh.vertices[mesh.faces[:, k]] for k in range(3))
    nearest = np.inf
    for p, q in zip(path[:-1], path[1:]):
        steps = max(1, int(np.ceil(np.linalg.norm(q - p) / 0.25)))
        for t in np.linspace(0, 1, steps + 1):
            nearest = min(nearest, point_triangle_distances(p + t * (q - p), a, b, c).min())
    assert nearest >= 2.0 - 1e-6
    assert nearest < 10  # it flew among the buildings, not far above them


def read_ply(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    n = int(re.search(r"element vertex (\d+)", header).group(1))
    m = int(re.search(r"element face (\d+)", header).group(1))
    assert "property double x" in header and re.search(r"property list uchar uint(32)? vertex_indices", header)
    vertices = np.frombuffer(data, "<f8", 3 * n, end).reshape(n, 3)
    records = np.frombuffer(data, np.dtype([("count", "u1"), ("index", "<u4", 3)]), m, end + 24 * n)
    assert (records["count"] == 3).all()
    return header, vertices, records["index"]


def test_write_gives_a_ply_with_the_mesh_and_its_crs(crop, tmp_path):
    mesh = dsmplan.simplify(dsmplan.read_dsm(crop), max_error=0.4)
    path = str(tmp_path / "mesh.ply")
    mesh.write(path)
    header, vertices, faces = read_ply(path)
    np.testing.assert_array_equal(vertices, mesh.vertices)
    np.testing.assert_array_equal(faces, mesh.faces)
    assert "crs_epsg 25832" in header
    assert os.listdir(tmp_path) == ["mesh.ply"]  # nothing else left behind


def test_errors_are_dsmplan_errors_with_the_one_line_text(crop, tmp_path):
    with pytest.raises(dsmplan.Error, match="no-such.tif"):
        dsmplan.read_dsm(str(tmp_path / "no-such.tif"))
    dsm = dsmplan.read_dsm(crop)
    # The field is named as the keyword argument that sets it (the CLI shows --max-error).
    with pytest.raises(dsmplan.Error, match="^max_error: "):
        dsmplan.simplify(dsm, max_error=0)
    mesh = dsmplan.simplify(dsm, max_error=0.4)
    x0, _, _, y0, _, _ = dsm.transform
    underground = np.array([[x0 + 10, y0 - 10, -50.0], [x0 + 110, y0 - 90, 200.0]])
    with pytest.raises(dsmplan.Error, match="waypoint 1") as caught:
        dsmplan.plan(mesh, underground)
    assert "\n" not in str(caught.value)
    with pytest.raises(dsmplan.Error, match="K x 3"):
        dsmplan.plan(mesh, np.zeros((2, 2)))
    with pytest.raises(dsmplan.Error, match="unknown mesh format"):
        mesh.write(str(tmp_path / "mesh.xyz"))


def test_arrays_handed_out_are_read_only_and_paths_with_nul_are_refused(crop, tmp_path):
    # A view written through would change what the library checked behind its back: a face
    # naming a vertex that is not there, written as it is, is a file dsmplan's reader refuses.
    dsm = dsmplan.read_dsm(crop)
    mesh = dsmplan.simplify(dsm, max_error=0.4)
    for array in (dsm.heights, mesh.vertices, mesh.faces):
        assert not array.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            array[0, 0] = 10**6
    faces = mesh.faces.copy()  # a copy is the user's to change
    faces[0, 0] = 10**6
    assert mesh.faces[0, 0] != 10**6
    # A NUL byte would cut the name where the system reads it: refused, nothing written.
    with pytest.raises(dsmplan.Error, match="NUL byte"):
        mesh.write(str(tmp_path / "mesh.ply") + "\0.obj")
    assert os.listdir(tmp_path) == []
    with pytest.raises(dsmplan.Error, match="NUL byte"):
        dsmplan.read_dsm(crop + "\0ignored")


def test_read_dsm_refuses_what_is_no_file_instead_of_waiting(tmp_path):
    # A FIFO with no writer would hold GDAL's open() forever; /dev/zero never ends.
    fifo = tmp_path / "pipe.tif"
    os.mkfifo(fifo)
    with pytest.raises(dsmplan.Error, match="pipe.tif: is a FIFO"):
        dsmplan.read_dsm(str(fifo))
    with pytest.raises(dsmplan.Error, match="is a directory"):
        dsmplan.read_dsm(str(tmp_path))


# ---- one library, three faces: the Python face gives what the command line gives ----------------

LOW_WAYPOINTS = os.path.join(os.path.dirname(SAMPLE), "low_waypoints.csv")


def read_waypoints(path):
    rows = [line for line in open(path) if line[0].isdigit() or line[0] == "-"]
    return np.array([[float(v) for v in row.split(",")] for row in rows])


def run_cli(*args):
    return subprocess.run([os.environ.get("DSMPLAN_CLI", "dsmplan"), *args], capture_output=True, text=True)


@pytest.fixture(scope="module")
def sample_plan(tmp_path_factory):
    """The sample's conservative mesh (written, so that both faces plan on the same bytes) and a
    DTM under it: the lowest DSM cell within 15 m, a ground no roof stands on."""
    folder = tmp_path_factory.mktemp("parity")
    dsm = dsmplan.read_dsm(SAMPLE)
    mesh_file = str(folder / "mesh.ply")
    dsmplan.simplify(dsm, max_error=0.4, conservative=True).write(mesh_file)
    heights = np.where(np.isnan(dsm.heights), np.inf, dsm.heights)
    r = 15
    padded = np.pad(heights, r, mode="edge")
    low = np.full_like(heights, np.inf)
    for dy in range(0, 2 * r + 1, 3):
        for dx in range(0, 2 * r + 1, 3):
            low = np.minimum(low, padded[dy : dy + heights.shape[0], dx : dx + heights.shape[1]])
    dtm_file = str(folder / "dtm.tif")
    source = gdal.Open(SAMPLE)
    out = gdal.GetDriverByName("GTiff").Create(dtm_file, low.shape[1], low.shape[0], 1, gdal.GDT_Float32)
    out.SetGeoTransform(source.GetGeoTransform())
    out.SetProjection(source.GetProjection())
    out.GetRasterBand(1).WriteArray(low.astype(np.float32))
    out = None
    return folder, mesh_file, dtm_file, low.astype(np.float32)


def test_plan_in_python_writes_what_the_command_line_writes(sample_plan):
    folder, mesh_file, dtm_file, dtm_heights = sample_plan
    cli_csv, cli_mission = str(folder / "cli.csv"), str(folder / "cli.waypoints")
    common = ["--waypoints", LOW_WAYPOINTS, "--dsm", SAMPLE, "--dtm", dtm_file, "--max-agl", "30", "--spacing", "10"]
    result = run_cli("plan", mesh_file, *common, "-o", cli_csv, "-q")
    assert result.returncode == 0, result.stderr
    vertical = ["--vertical-crs", "EPSG:7837", "--allow-approximate-vertical"]
    result = run_cli("plan", mesh_file, *common, *vertical, "-o", cli_mission, "-q")
    assert result.returncode == 0, result.stderr

    dsm = dsmplan.read_dsm(SAMPLE)
    # The DTM from the numpy array itself, as a rasterio user holds one: affine (a, b, c, d, e, f).
    x0, cx, _, y0, _, ny = dsm.transform
    dtm = dsmplan.Dsm(dtm_heights, (cx, 0.0, x0, 0.0, ny, y0), "EPSG:25832")
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    waypoints = read_waypoints(LOW_WAYPOINTS)
    flight = dsmplan.plan(mesh, waypoints, dsm=dsm, dtm=dtm, max_agl=30, spacing=10)
    py_csv = str(folder / "py.csv")
    flight.write(py_csv)
    assert open(py_csv, "rb").read() == open(cli_csv, "rb").read()
    assert flight.report["ground"] == "dtm" and flight.report["min_clearance_dsm_m"] >= 2.0 - 0.01
    mission = dsmplan.plan(mesh, waypoints, dsm=dsm, dtm=dtm, max_agl=30, spacing=10, mission=True)
    py_mission = str(folder / "py.waypoints")
    mission.write(py_mission, vertical_crs="EPSG:7837", allow_approximate_vertical=True)
    assert open(py_mission, "rb").read() == open(cli_mission, "rb").read()
    with pytest.raises(dsmplan.ArgumentError, match="is a mission"):
        flight.write(str(folder / "not_a_mission.plan"))


def test_the_free_airspace_planner_gives_the_command_lines_path_and_refusal(sample_plan, tmp_path):
    """planner="freespace" and objective= through plan_flight(), as `--planner freespace`: the same
    bytes for both objectives, and the same one-line proof for a leg between enclosed regions."""
    _, mesh_file, _, _ = sample_plan
    dsm = dsmplan.read_dsm(SAMPLE)
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    waypoints = read_waypoints(LOW_WAYPOINTS)
    for objective in ("low", "shortest"):
        cli_csv = str(tmp_path / f"cli_{objective}.csv")
        result = run_cli("plan", mesh_file, "--waypoints", LOW_WAYPOINTS, "--dsm", SAMPLE, "--max-agl", "30",
                         "--planner", "freespace", "--objective", objective, "-o", cli_csv, "-q")
        assert result.returncode == 0, result.stderr
        flight = dsmplan.plan(mesh, waypoints, dsm=dsm, max_agl=30, planner="freespace", objective=objective)
        assert flight.report["planner"] == "freespace" and flight.report["min_clearance_dsm_m"] >= 2.0 - 0.01
        py_csv = str(tmp_path / f"py_{objective}.csv")
        flight.write(py_csv)
        assert open(py_csv, "rb").read() == open(cli_csv, "rb").read()
    apart = np.array([[356681.5, 5699302.5, 127.44], [356570.5, 5699579.5, 127.15]])
    apart_csv = str(tmp_path / "apart.csv")
    np.savetxt(apart_csv, apart, delimiter=",", header="x,y,z", comments="", fmt="%.2f")
    result = run_cli("plan", mesh_file, "--waypoints", apart_csv, "--dsm", SAMPLE, "--max-agl", "10",
                     "--planner", "freespace", "-o", str(tmp_path / "apart_path.csv"), "-q")
    assert result.returncode == 1 and "no path exists at the DSM's resolution" in result.stderr
    with pytest.raises(dsmplan.InputError) as refused:
        dsmplan.plan(mesh, apart, dsm=dsm, max_agl=10, planner="freespace")
    assert str(refused.value).split(": ", 1)[1] in result.stderr
    with pytest.raises(dsmplan.ArgumentError, match="objective: must be low or shortest"):
        dsmplan.plan(mesh, waypoints, dsm=dsm, planner="freespace", objective="lowest")


def test_a_waypoint_under_a_roof_is_refused_in_the_same_words(sample_plan, tmp_path):
    folder, mesh_file, _, _ = sample_plan
    waypoints = read_waypoints(LOW_WAYPOINTS)
    waypoints[1, 2] = 90.0  # under the street's surface
    under = str(tmp_path / "under.csv")
    np.savetxt(under, waypoints, delimiter=",", header="x,y,z", comments="", fmt="%.3f")
    result = run_cli("plan", mesh_file, "--waypoints", under, "--dsm", SAMPLE, "-o", str(tmp_path / "p.csv"), "-q")
    assert result.returncode == 1
    cli_words = result.stderr.strip().split("waypoint 2: ", 1)[1]
    dsm = dsmplan.read_dsm(SAMPLE)
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    with pytest.raises(dsmplan.InputError) as caught:
        dsmplan.plan(mesh, waypoints, dsm=dsm)
    assert str(caught.value).split("waypoint 2: ", 1)[1] == cli_words
    assert "inside the DSM" in cli_words


NRW_ZONES = os.path.join(os.path.dirname(__file__), "..", "data", "airspace", "nrw_zones_ed269.json")


def test_no_fly_zones_give_the_command_lines_path_and_refusal(sample_plan, tmp_path):
    """The hand-made ED-269 zones over the sample: the same path bytes and figures from both faces;
    a waypoint moved into the 40 m circle is refused in the same words."""
    folder, mesh_file, _, _ = sample_plan
    vertical = ["--vertical-crs", "EPSG:7837", "--allow-approximate-vertical"]
    cli_csv = str(tmp_path / "cli.csv")
    common = ["--waypoints", LOW_WAYPOINTS, "--dsm", SAMPLE, "--max-agl", "30", "--spacing", "10"]
    result = run_cli("plan", mesh_file, *common, "--no-fly", NRW_ZONES, *vertical, "-o", cli_csv, "--json", "-q")
    assert result.returncode == 0, result.stderr
    cli_zones = json.loads(result.stdout)["no_fly_zones"]
    dsm = dsmplan.read_dsm(SAMPLE)
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    waypoints = read_waypoints(LOW_WAYPOINTS)
    flight = dsmplan.plan(mesh, waypoints, dsm=dsm, max_agl=30, spacing=10, no_fly=[NRW_ZONES],
                          vertical_crs="EPSG:7837", allow_approximate_vertical=True)
    py_csv = str(tmp_path / "py.csv")
    flight.write(py_csv)
    assert open(py_csv, "rb").read() == open(cli_csv, "rb").read()
    assert flight.report["no_fly_zones"] == cli_zones
    assert all(z["min_distance_m"] >= 2.0 - 0.01 for z in cli_zones if z["blocks"])

    # A zone buffer apart from the safety (issue 52): both faces keep it, to the byte.
    result = run_cli("plan", mesh_file, *common, "--no-fly", NRW_ZONES, *vertical, "--no-fly-buffer", "8",
                     "-o", cli_csv, "--json", "-q")
    assert result.returncode == 0, result.stderr
    buffered_zones = json.loads(result.stdout)["no_fly_zones"]
    buffered = dsmplan.plan(mesh, waypoints, dsm=dsm, max_agl=30, spacing=10, no_fly=[NRW_ZONES],
                            vertical_crs="EPSG:7837", allow_approximate_vertical=True, no_fly_buffer=8)
    buffered.write(py_csv)
    assert open(py_csv, "rb").read() == open(cli_csv, "rb").read()
    assert buffered.report["no_fly_zones"] == buffered_zones
    assert all(z["min_distance_m"] >= 8.0 - 0.01 for z in buffered_zones if z["blocks"])
    assert min(z["min_distance_m"] for z in cli_zones if z["blocks"]) < 8.0, "the buffer changed nothing"

    inside = waypoints.copy()
    inside[1] = (356550.0, 5699500.0, 160.0)  # the centre of the 40 m circle, 30 m above the roofs
    moved = str(tmp_path / "inside.csv")
    np.savetxt(moved, inside, delimiter=",", header="x,y,z", comments="", fmt="%.3f")
    result = run_cli("plan", mesh_file, "--waypoints", moved, "--dsm", SAMPLE, "--no-fly", NRW_ZONES, *vertical,
                     "-o", str(tmp_path / "p.csv"), "-q")
    assert result.returncode == 1
    cli_words = result.stderr.strip().split("waypoint 2: ", 1)[1]
    assert "inside no-fly zone 'Centre circle'" in cli_words
    with pytest.raises(dsmplan.InputError) as caught:
        dsmplan.plan(mesh, inside, dsm=dsm, no_fly=[NRW_ZONES], vertical_crs="EPSG:7837",
                     allow_approximate_vertical=True)
    assert str(caught.value).split("waypoint 2: ", 1)[1] == cli_words


def test_pictures_of_a_flight_are_the_command_lines(sample_plan, tmp_path):
    """render() and profile() take the Flight in hand (and a Dsm): the mission as flown, with its
    waypoints, zones, DTM, safety and ceiling, the same bytes as one `dsmplan plan --render
    --profile` run draws, given the window, zoom and titles that run reports."""
    folder, mesh_file, dtm_file, dtm_heights = sample_plan
    vertical = ["--vertical-crs", "EPSG:7837", "--allow-approximate-vertical"]
    zones = ["--no-fly", NRW_ZONES, "--no-fly-blocking", "NONE"]
    above, side, stats = (str(tmp_path / name) for name in ("above.png", "side.png", "stats.json"))
    result = run_cli("plan", mesh_file, "--waypoints", LOW_WAYPOINTS, "--dsm", SAMPLE, "--dtm", dtm_file,
                     "--max-agl", "30", "--spacing", "10", *zones, *vertical, "-o", str(tmp_path / "m.plan"),
                     "-o", str(tmp_path / "flown.csv"), "--render", above, "--profile", side, "--stats", stats, "-q")
    assert result.returncode == 0, result.stderr
    drawn = json.load(open(stats))

    dsm = dsmplan.read_dsm(SAMPLE)
    x0, cx, _, y0, _, ny = dsm.transform
    dtm = dsmplan.Dsm(dtm_heights, (cx, 0.0, x0, 0.0, ny, y0), "EPSG:25832")
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    flight = dsmplan.plan(mesh, read_waypoints(LOW_WAYPOINTS), dsm=dsm, dtm=dtm, max_agl=30, spacing=10,
                          mission=True, no_fly=[NRW_ZONES], no_fly_blocking=["NONE"], vertical_crs="EPSG:7837",
                          allow_approximate_vertical=True)
    title = "flown.csv over " + os.path.basename(SAMPLE)
    py_above, py_side = str(tmp_path / "py_above.png"), str(tmp_path / "py_side.png")
    report = dsmplan.render(dsm, py_above, paths=flight, window=tuple(drawn["render"]["window"]),
                            zoom=drawn["render"]["zoom"], titles=title)
    assert open(py_above, "rb").read() == open(above, "rb").read()
    assert report == dict(drawn["render"], output=py_above)
    report = dsmplan.profile(SAMPLE, flight, py_side, title="Height profile: " + title)
    assert open(py_side, "rb").read() == open(side, "rb").read()
    assert report["max_above_ground_m"] == flight.report["max_agl_m"] == drawn["max_agl_m"]
    assert report["ground"] == "dtm" and report["max_agl_m"] == 30
    # Without the flight's zones the picture differs: they were drawn.
    dsmplan.profile(SAMPLE, flight, py_side, title="Height profile: " + title, no_fly=[])
    bare = dsmplan.plan(mesh, read_waypoints(LOW_WAYPOINTS), dsm=dsm, dtm=dtm, max_agl=30, spacing=10, mission=True)
    bare_side = str(tmp_path / "bare_side.png")
    dsmplan.profile(SAMPLE, bare, bare_side, title="Height profile: " + title)
    assert open(bare_side, "rb").read() != open(side, "rb").read()
    with pytest.raises(dsmplan.ArgumentError, match="^path: must be a path CSV"):
        dsmplan.profile(SAMPLE, 3, str(tmp_path / "x.png"))
    assert not os.path.exists(tmp_path / "x.png")


def test_snap_and_heights_above_the_ground_give_the_command_lines_path(sample_plan, tmp_path):
    """--snap and --waypoint-heights agl are the plan stage's: a waypoint 0.5 m above its street
    cell (read here from the DSM's array) is moved up by both faces to the same point, and the
    path bytes and the reported moves are the same."""
    folder, mesh_file, _, _ = sample_plan
    dsm = dsmplan.read_dsm(SAMPLE)
    x0, cx, _, y0, _, ny = dsm.transform
    waypoints = read_waypoints(LOW_WAYPOINTS)
    x, y = waypoints[1, 0] + 0.5, waypoints[1, 1] - 0.5  # inside one cell
    street = float(dsm.heights[int((y - y0) // ny), int((x - x0) // cx)])
    waypoints[1] = (x, y, street + 0.5)
    low = str(tmp_path / "low.csv")
    np.savetxt(low, waypoints, delimiter=",", header="x,y,z", comments="", fmt="%.17g")
    cli_csv = str(tmp_path / "cli.csv")
    common = ["--dsm", SAMPLE, "--max-agl", "30", "--spacing", "10"]
    result = run_cli("plan", mesh_file, "--waypoints", low, *common, "--snap", "5", "-o", cli_csv, "--json", "-q")
    assert result.returncode == 0, result.stderr
    cli_moves = json.loads(result.stdout)["snapped"]
    assert [m["waypoint"] for m in cli_moves] == [2]
    assert cli_moves[0]["to"][:2] == [x, y] and 1.5 <= cli_moves[0]["to"][2] - street <= 5.5  # straight up
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    flight = dsmplan.plan(mesh, waypoints, dsm=dsm, max_agl=30, spacing=10, snap=5)
    py_csv = str(tmp_path / "py.csv")
    flight.write(py_csv)
    assert open(py_csv, "rb").read() == open(cli_csv, "rb").read()
    assert flight.report["snapped"] == cli_moves

    agl = waypoints.copy()
    agl[:, 2] = 10.0
    agl_file = str(tmp_path / "agl.csv")
    np.savetxt(agl_file, agl, delimiter=",", header="x,y,agl", comments="", fmt="%.17g")
    cli_agl = str(tmp_path / "cli_agl.csv")
    result = run_cli("plan", mesh_file, "--waypoints", agl_file, *common, "-o", cli_agl, "-q")
    assert result.returncode == 0, result.stderr
    flight = dsmplan.plan(mesh, agl, dsm=dsm, max_agl=30, spacing=10, waypoint_heights="agl")
    py_agl = str(tmp_path / "py_agl.csv")
    flight.write(py_agl)
    assert open(py_agl, "rb").read() == open(cli_agl, "rb").read()
    with pytest.raises(dsmplan.ArgumentError, match="waypoint_heights"):
        dsmplan.plan(mesh, agl, dsm=dsm, waypoint_heights="above")


def test_plan_routes_gives_the_command_lines_routes_and_reasons(sample_plan, tmp_path):
    """Many routes over one roadmap: each solved route's path the bytes `dsmplan plan --routes`
    writes for it, and a route without a path its InputError (returned, not raised) in the words
    of routes.json."""
    folder, mesh_file, _, _ = sample_plan
    waypoints = read_waypoints(LOW_WAYPOINTS)
    under = waypoints[0].copy()
    under[2] = 90.0  # under the street's surface
    routes = [waypoints[0:2], waypoints[1:3], waypoints[2:4], np.array([under, waypoints[1]])]
    csv = tmp_path / "routes.csv"
    csv.write_text("route,x,y,z\n" + "".join(f"r{i},{x!r},{y!r},{z!r}\n" for i, route in enumerate(routes)
                                               for x, y, z in route))
    out = str(tmp_path / "paths") + "/"
    result = run_cli("plan", mesh_file, "--routes", str(csv), "--dsm", SAMPLE, "--max-agl", "30", "--spacing", "10",
                     "-o", out, "-q")
    assert result.returncode == 4, result.stderr
    listed = json.load(open(out + "routes.json"))

    dsm = dsmplan.read_dsm(SAMPLE)
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    flights = dsmplan.plan_routes(mesh, routes, dsm=dsm, max_agl=30, spacing=10)
    assert len(flights) == 4
    for i, flight in enumerate(flights[:3]):
        assert isinstance(flight, dsmplan.Flight), flight
        mine = str(tmp_path / f"py_r{i}.csv")
        flight.write(mine)
        assert open(mine, "rb").read() == open(out + f"r{i}.csv", "rb").read()
        assert flight.report["min_clearance_dsm_m"] >= 2.0 - 0.01
    assert isinstance(flights[3], dsmplan.InputError)
    assert not listed[3]["solved"] and str(flights[3]) == listed[3]["reason"]
    assert "waypoint 1: inside the DSM" in str(flights[3])
    # The failure for a program, as routes.json's "failure" object says it.
    failure = listed[3]["failure"]
    assert (flights[3].code, flights[3].waypoint, flights[3].leg) == (failure["code"], failure["waypoint"], None)
    assert list(flights[3].nearest_valid_point or []) == (failure["nearest_valid_point"] or [])
    assert flights[3].code == "waypoint_refused" and flights[3].waypoint == 1
    with pytest.raises(dsmplan.ArgumentError, match="^planner: "):
        dsmplan.plan_routes(mesh, routes, planner="astar")
    with pytest.raises(dsmplan.ArgumentError, match="^route_budget: "):
        dsmplan.plan_routes(mesh, routes, route_budget=-1)
    late = dsmplan.plan_routes(mesh, routes, dsm=dsm, max_agl=30, spacing=10, route_budget=1e-6)
    assert [f.code for f in late] == ["route_budget"] * 4


def test_delft_zones_are_kept_away_from_and_one_on_the_path_is_flown_around(tmp_path):
    """Issue 35 point 3 over the Delft sample (AHN3 LiDAR, RD New + NAP): the mission between the
    blocks planned with the hand-made GeoJSON zones, and again with a square zone the test puts on
    the middle of the unconstrained path. Oracle: every 5 cm of each path, GDAL's planar distance
    (EPSG:28992) to each blocking zone that spans the flight's heights is at least the safety
    distance, and the square is flown around (a longer path)."""
    from osgeo import ogr, osr

    laz = [os.path.join(os.path.dirname(os.path.dirname(SAMPLE)), "delft-ahn3", f"ahn3_cropped_{i}.laz")
           for i in (1, 2)]
    dsm = dsmplan.grid(laz, res=1.0, crs="EPSG:7415")
    dtm = dsmplan.grid(laz, res=1.0, crs="EPSG:7415", classes=[2], fill_holes=30)
    mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)
    waypoints = read_waypoints(os.path.join(os.path.dirname(os.path.dirname(SAMPLE)), "delft-ahn3",
                                            "low_waypoints.csv"))
    common = dict(dsm=dsm, dtm=dtm, max_agl=10, spacing=4, allow_approximate_vertical=True)
    bare = dsmplan.plan(mesh, waypoints, **common)
    wgs84, rd = osr.SpatialReference(), osr.SpatialReference()
    wgs84.ImportFromEPSG(4326), rd.ImportFromEPSG(28992)
    for srs in (wgs84, rd):
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    to_rd, to_wgs84 = osr.CoordinateTransformation(wgs84, rd), osr.CoordinateTransformation(rd, wgs84)

    # A 6 m square, ground to unlimited, on the unconstrained path's middle point (a street:
    # a wider one would close it under this ceiling).
    path = np.asarray(bare.path)
    mx, my = path[len(path) // 2, :2]
    corners = [(mx - 3, my - 3), (mx + 3, my - 3), (mx + 3, my + 3), (mx - 3, my + 3), (mx - 3, my - 3)]
    ring = [list(to_wgs84.TransformPoint(x, y)[:2]) for x, y in corners]
    square = tmp_path / "square.geojson"
    square.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"id": "SQ", "name": "Square on the path"},
         "geometry": {"type": "Polygon", "coordinates": [ring]}}]}))

    def zone_shapes(files):
        """The blocking zones that span 0-40 m above the ground, as OGR polygons in RD New."""
        shapes = []
        for file in files:
            for feature in json.load(open(file))["features"]:
                p = feature["properties"]
                if p.get("restriction", "PROHIBITED") not in ("PROHIBITED", "REQ_AUTHORISATION"):
                    continue
                if p.get("lower_ref", "AGL") != "AGL" or p.get("lower", 0) > 0:
                    continue  # floor above the flight (the mast's 200-400 ft), or in another reference
                geometry = ogr.CreateGeometryFromJson(json.dumps(feature["geometry"]))
                geometry.Transform(to_rd)
                shapes.append((p["name"], geometry))
        return shapes

    zones = os.path.join(os.path.dirname(__file__), "..", "data", "airspace", "delft_zones.geojson")
    for files in ([zones], [zones, str(square)]):
        flight = dsmplan.plan(mesh, waypoints, no_fly=files, **common)
        shapes = zone_shapes(files)
        assert len(shapes) == len(files) + 1  # the church precinct, the canal stops (and the square)
        points = np.asarray(flight.path)
        nearest = {name: np.inf for name, _ in shapes}
        for a, b in zip(points[:-1], points[1:]):
            steps = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.05)))
            for t in np.linspace(0, 1, steps + 1):
                x, y = a[:2] + t * (b[:2] - a[:2])
                point = ogr.Geometry(ogr.wkbPoint)
                point.AddPoint_2D(float(x), float(y))
                for name, shape in shapes:
                    nearest[name] = min(nearest[name], shape.Distance(point))
        for name, distance in nearest.items():
            assert distance >= 2.0 - 0.01, (name, distance)
        if len(files) == 2:
            assert nearest["Square on the path"] < 10  # it goes close by, around it
            assert flight.report["path_length_m"] > bare.report["path_length_m"] + 1
