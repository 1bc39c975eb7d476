# stereo() gives what `dsmplan stereo` gives: the same library functions (stereo_job_for(), then
# stereo_job() or satellite_stereo_job()), so the same GeoTIFF byte for byte, the same DSM cell for
# cell in memory, the same report as --stats and the same refusals, worded alike. Oracles: the
# CLI's own outputs and words on the same inputs; for the frame cameras also the scene they were
# rendered from (two views of boxes on a textured floor, ray-cast here in numpy), so that the
# equality is not that of two empty DSMs.
import copy
import json
import os
import subprocess

import numpy as np
import pytest
from osgeo import gdal, osr

import dsmplan

gdal.UseExceptions()
DATA = os.environ.get("DSMPLAN_DATA_DIR", "data")
PLEIADES = [os.path.join(DATA, "pleiades-kahramanmaras", f"pre_event_img{i}.tif") for i in (1, 2)]


def run_cli(*args):
    return subprocess.run([os.environ.get("DSMPLAN_CLI", "dsmplan"), *args], capture_output=True, text=True)


def cli_error(result):
    """The CLI's one-line error without "dsmplan: "."""
    assert result.returncode != 0
    line = result.stderr.strip().splitlines()[0]
    assert line.startswith("dsmplan: ")
    return line[len("dsmplan: "):]


def without_seconds(report):
    """The report without its timings (at every level) and the output's name."""
    if isinstance(report, list):
        return [without_seconds(item) for item in report]
    if isinstance(report, dict):
        return {key: without_seconds(value) for key, value in report.items() if key not in ("seconds", "output")}
    return report


def assert_same_dsm(dsm, other):
    np.testing.assert_array_equal(dsm.heights, other.heights)  # NaN where NaN
    assert dsm.transform == other.transform
    assert dsm.crs == other.crs


# ---- a frame-camera block, rendered here ------------------------------------------------------

FLOOR = 100.0
X0, Y0 = 356480.0, 5699520.0  # the north-west corner of the 40 m x 40 m scene, EPSG:25832
BOXES = [(X0 + 6, Y0 - 22, X0 + 18, Y0 - 10, FLOOR + 12),  # x0, y0, x1, y1, top
         (X0 + 24, Y0 - 34, X0 + 32, Y0 - 26, FLOOR + 7)]
NADIR = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]  # x east, y south, z down
SIZE, FOCAL = 240, 380.0


def truth():
    """The scene's heights at the centres of its 1 m cells, rows from the north."""
    xs = X0 + 0.5 + np.arange(40)
    ys = Y0 - 0.5 - np.arange(40)
    x, y = np.meshgrid(xs, ys)
    z = np.full(x.shape, FLOOR)
    for bx0, by0, bx1, by1, top in BOXES:
        z[(x > bx0) & (x < bx1) & (y > by0) & (y < by1)] = top
    return z


def texture(points):
    """Value noise on a 0.5 m lattice (trilinear), so that walls are textured too: 0..255."""
    table = np.random.default_rng(7).uniform(0, 1, (64, 64, 64))
    f = points / 0.5
    i = np.floor(f).astype(np.int64)
    t = f - i
    out = np.zeros(len(points))
    for corner in np.ndindex(2, 2, 2):
        weight = np.prod(np.where(np.array(corner), t, 1 - t), axis=1)
        j = (i + corner) % 64
        out += weight * table[j[:, 0], j[:, 1], j[:, 2]]
    return 255 * out


def render(center):
    """A nadir view from `center`: each pixel the mean of 2 x 2 rays, cast exactly against the
    floor and the boxes (slabs)."""
    c = (SIZE - 1) / 2
    sub = (np.arange(2 * SIZE) + 0.5) / 2 - 0.5
    u, v = np.meshgrid(sub, sub)
    d = np.stack([(u - c) / FOCAL, -(v - c) / FOCAL, -np.ones_like(u)], axis=-1).reshape(-1, 3)  # R^T (x, y, 1)
    o = np.asarray(center, dtype=float)
    hit = (FLOOR - o[2]) / d[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        for bx0, by0, bx1, by1, top in BOXES:
            t1 = (np.array([bx0, by0, FLOOR]) - o) / d
            t2 = (np.array([bx1, by1, top]) - o) / d
            near = np.minimum(t1, t2).max(axis=1)
            far = np.maximum(t1, t2).min(axis=1)
            inside = (near <= far) & (near > 0)
            hit = np.where(inside & (near < hit), near, hit)
    grey = texture(o + hit[:, None] * d).reshape(2 * SIZE, 2 * SIZE)
    return grey.reshape(SIZE, 2, SIZE, 2).mean(axis=(1, 3)).round().astype(np.uint8)


def write_png(image, path):
    mem = gdal.GetDriverByName("MEM").Create("", image.shape[1], image.shape[0], 1, gdal.GDT_Byte)
    mem.GetRasterBand(1).WriteArray(image)
    gdal.GetDriverByName("PNG").CreateCopy(path, mem)


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    """Two views 24 m apart, 110 m above the floor (0.29 m a pixel), and their CAMERAS.json as a
    dict with image paths relative to the folder and as the file in that folder."""
    folder = tmp_path_factory.mktemp("block")
    cameras = []
    for i, center in enumerate([(X0 + 8, Y0 - 20, FLOOR + 110), (X0 + 32, Y0 - 19, FLOOR + 111)]):
        write_png(render(center), str(folder / f"img_{i}.png"))
        cameras.append({"image": f"img_{i}.png", "width": SIZE, "height": SIZE, "fx": FOCAL, "fy": FOCAL,
                        "cx": (SIZE - 1) / 2, "cy": (SIZE - 1) / 2, "rotation": NADIR, "center": list(center)})
    spec = {"crs": "EPSG:25832", "height_range": [FLOOR - 5, FLOOR + 20], "cameras": cameras}
    (folder / "cameras.json").write_text(json.dumps(spec, indent=1))
    return folder, spec


BOUNDS = (X0, Y0 - 40, X0 + 40, Y0)


def test_frame_stereo_gives_the_geotiff_report_and_dsm_of_the_command_line(block, tmp_path, monkeypatch):
    folder, spec = block
    cameras = str(folder / "cameras.json")
    cli, stats = str(tmp_path / "cli.tif"), str(tmp_path / "stats.json")
    bounds = ",".join(str(v) for v in BOUNDS)
    result = run_cli("stereo", "--cameras", cameras, "--res", "1", "--bounds", bounds, "-o", cli, "--stats", stats,
                     "-q")
    assert result.returncode == 0, result.stderr
    # Not two empty DSMs: the CLI's is the scene, boxes included.
    expected = dsmplan.read_dsm(cli)
    heights = expected.heights
    assert heights.shape == (40, 40) and expected.transform == (X0, 1.0, 0.0, Y0, 0.0, -1.0)
    valid = ~np.isnan(heights)
    error = np.abs(heights - truth())[valid]
    assert valid.mean() > 0.8 and np.median(error) < 0.3 and (error < 1).mean() > 0.9
    assert np.nanmax(heights) > FLOOR + 11

    # The same GeoTIFF, byte for byte, and the report of --stats.
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))  # where a temporary folder would go
    os.mkdir(tmp_path / "tmp")
    py = str(tmp_path / "py.tif")
    report = dsmplan.stereo(cameras=cameras, res=1, bounds=BOUNDS, output=py)
    assert open(py, "rb").read() == open(cli, "rb").read()
    cli_report = json.load(open(stats))
    assert without_seconds(report) == without_seconds(cli_report)
    assert report["output"] == py and report["pairs"] == [[0, 1]]
    assert set(report["seconds"]) == set(cli_report["seconds"])

    # In memory: the DSM read_dsm() gives of the CLI's file; the temporary folder is gone.
    assert_same_dsm(dsmplan.stereo(cameras=cameras, res=1, bounds=BOUNDS), expected)
    # The cameras as a dict: its relative image paths from the current directory, the same DSM;
    # the caller's dict is not changed.
    given = copy.deepcopy(spec)
    monkeypatch.chdir(folder)
    assert_same_dsm(dsmplan.stereo(cameras=given, res=1, bounds=BOUNDS), expected)
    assert given == spec
    dict_report = dsmplan.stereo(cameras=given, res=1, bounds=BOUNDS, output=str(tmp_path / "dict.tif"))
    assert open(tmp_path / "dict.tif", "rb").read() == open(cli, "rb").read()
    assert dict_report["cameras"] is None
    assert without_seconds(dict(dict_report, cameras=cameras)) == without_seconds(cli_report)
    # Without bounds, "auto" pairs named: the pairs' footprint, as the CLI makes it.
    result = run_cli("stereo", "--cameras", cameras, "--res", "2", "--pairs", "0-1", "-o", cli, "-q")
    assert result.returncode == 0, result.stderr
    assert_same_dsm(dsmplan.stereo(cameras=cameras, res=2, pairs="0-1"), dsmplan.read_dsm(cli))
    assert os.listdir(tmp_path / "tmp") == []


def test_satellite_stereo_gives_the_dsm_of_the_command_line(tmp_path):
    cli, stats = str(tmp_path / "cli.tif"), str(tmp_path / "stats.json")
    result = run_cli("stereo", *PLEIADES, "--res", "1", "-o", cli, "--stats", stats, "-q")
    assert result.returncode == 0, result.stderr
    expected = dsmplan.read_dsm(cli)
    assert np.isfinite(expected.heights).mean() > 0.5
    dsm = dsmplan.stereo(PLEIADES, res=1)
    assert_same_dsm(dsm, expected)
    assert "ellipsoid" in dsm.crs.lower()  # the heights as the file states them (VERTICAL_CRS)
    # Written from memory, the DSM still says its heights are ellipsoidal (as the CLI's file does,
    # by GDAL's metadata), and reads back as the same DSM in the same CRS.
    written = str(tmp_path / "written.tif")
    dsm.write(written)
    assert gdal.Open(written).GetMetadataItem("VERTICAL_CRS") == gdal.Open(cli).GetMetadataItem("VERTICAL_CRS")
    assert_same_dsm(dsmplan.read_dsm(written), expected)
    py = str(tmp_path / "py.tif")
    report = dsmplan.stereo(PLEIADES, res=1, output=py)
    assert open(py, "rb").read() == open(cli, "rb").read()
    cli_report = json.load(open(stats))
    # The CRS's WKT as GDAL spells it depends on what the process read before (a GeoTIFF's
    # EPSG:32637 is cached with the datum, "EPSG:32637" from PROJ's database has the ensemble):
    # the same CRS, not always the same text, in a process that outlives one command.
    wkt, cli_wkt = report["crs"].pop("wkt"), cli_report["crs"].pop("wkt")
    assert osr.SpatialReference(wkt).IsSame(osr.SpatialReference(cli_wkt))
    assert without_seconds(report) == without_seconds(cli_report)
    assert report["crs"]["epsg"] == 32637


def test_stereo_refuses_what_the_command_line_refuses_in_the_same_words(block, tmp_path):
    folder, spec = block
    cameras = str(folder / "cameras.json")
    out = str(tmp_path / "dsm.tif")
    cases = [
        (["--cameras", cameras, *PLEIADES], dict(images=PLEIADES, cameras=cameras), "cameras"),
        ([], dict(), "cameras"),
        ([*PLEIADES, "--pairs", "0-1"], dict(images=PLEIADES, pairs="0-1"), "pairs"),
        (["--cameras", cameras, "--pairs", "0-x"], dict(cameras=cameras, pairs="0-x"), "pairs"),
        (["--cameras", cameras, "--pairs", "0-0"], dict(cameras=cameras, pairs="0-0"), "pairs"),
        (["--cameras", cameras, "--crs", "EPSG:32637"], dict(cameras=cameras, crs="EPSG:32637"), "crs"),
        (["--cameras", cameras, "--allow-approximate-vertical"], dict(cameras=cameras, allow_approximate_vertical=True),
         "allow_approximate_vertical"),
        (["--cameras", cameras, "--fusion-memory", "0.01"], dict(cameras=cameras, fusion_memory=0.01), "fusion_memory"),
        (["--cameras", cameras, "--band-memory", "0"], dict(cameras=cameras, band_memory=0), "band_memory"),
        ([PLEIADES[0]], dict(images=PLEIADES[0]), "images"),
    ]
    for flags, kwargs, keyword in cases:
        words = cli_error(run_cli("stereo", *flags, "--res", "1", "-o", out, "-q"))
        flag = "--" + keyword.replace("_", "-") if keyword not in ("images",) else "IMAGES"
        assert words.startswith(flag + ": "), words
        with pytest.raises(dsmplan.ArgumentError) as caught:
            dsmplan.stereo(res=1, output=out, **kwargs)
        assert str(caught.value) == keyword + ": " + words[len(flag) + 2:]
    for res in ("0", "-1"):
        words = cli_error(run_cli("stereo", "--cameras", cameras, "--res", res, "-o", out, "-q"))
        with pytest.raises(dsmplan.ArgumentError) as caught:
            dsmplan.stereo(cameras=cameras, res=float(res), output=out)
        assert str(caught.value) == "res: " + words[len("--res: "):]
    # A CAMERAS.json the reader refuses: the same words, the dict's named as `cameras`.
    broken = copy.deepcopy(spec)
    del broken["cameras"][1]["fx"]
    (tmp_path / "broken.json").write_text(json.dumps(broken))
    words = cli_error(run_cli("stereo", "--cameras", str(tmp_path / "broken.json"), "--res", "1", "-o", out, "-q"))
    assert words == f"{tmp_path / 'broken.json'}: cameras[1].fx: missing"
    with pytest.raises(dsmplan.InputError) as caught:
        dsmplan.stereo(cameras=str(tmp_path / "broken.json"), res=1)
    assert str(caught.value) == words
    with pytest.raises(dsmplan.InputError) as caught:
        dsmplan.stereo(cameras=broken, res=1)
    assert str(caught.value) == "cameras: cameras[1].fx: missing"
    with pytest.raises(dsmplan.ArgumentError, match="^cameras: is not a dict JSON can hold"):
        dsmplan.stereo(cameras=dict(spec, height_range=[float("nan"), 1]), res=1)
    with pytest.raises(dsmplan.ArgumentError, match="^cameras: must be a path"):
        dsmplan.stereo(cameras=42, res=1)
    # An output that is one of the inputs, before any work.
    with pytest.raises(dsmplan.ArgumentError, match="^output: .* is the same file as"):
        dsmplan.stereo(PLEIADES, res=1, output=PLEIADES[0])
    assert os.listdir(tmp_path) == ["broken.json"]


# ---- a COLMAP model of the block ------------------------------------------------------------------

def quaternion(r):
    """The Hamilton quaternion (w, x, y, z) of the rotation matrix r (Shepperd's method)."""
    r = np.asarray(r)
    w = np.sqrt(max(0.0, 1 + np.trace(r))) / 2
    x = np.copysign(np.sqrt(max(0.0, 1 + r[0, 0] - r[1, 1] - r[2, 2])) / 2, r[2, 1] - r[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1 - r[0, 0] + r[1, 1] - r[2, 2])) / 2, r[0, 2] - r[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1 - r[0, 0] - r[1, 1] + r[2, 2])) / 2, r[1, 0] - r[0, 1])
    return w, x, y, z


def write_colmap_model(folder, spec):
    """The block's cameras as a COLMAP text model in the frame X_model = Qᵀ (X - T) / s (COLMAP's
    pixel centres half a pixel further), and the transform file (s, Q by rows, T) back."""
    a, b = np.radians(30), np.radians(10)
    q = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]) @ \
        np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    s, t = 7.5, np.array([X0 - 100, Y0 + 50, 20.0])
    os.makedirs(folder, exist_ok=True)
    cameras, images = "", ""
    for i, c in enumerate(spec["cameras"]):
        cameras += f"{i + 1} PINHOLE {c['width']} {c['height']} {c['fx']} {c['fy']} {c['cx'] + 0.5} {c['cy'] + 0.5}\n"
        r_model = np.asarray(c["rotation"]) @ q
        t_model = -r_model @ (q.T @ (np.asarray(c["center"]) - t) / s)
        values = " ".join(repr(float(v)) for v in (*quaternion(r_model), *t_model))
        images += f"{i + 1} {values} {i + 1} {c['image']}\n\n"
    (folder / "cameras.txt").write_text(cameras)
    (folder / "images.txt").write_text(images)
    (folder / "transform.txt").write_text(" ".join(repr(float(v)) for v in (s, *q.ravel(), *t)) + "\n")


def test_colmap_model_gives_the_dsm_and_report_of_the_command_line(block, tmp_path):
    folder, spec = block
    model = tmp_path / "model"
    write_colmap_model(model, spec)
    cli, stats = str(tmp_path / "cli.tif"), str(tmp_path / "stats.json")
    bounds = ",".join(str(v) for v in BOUNDS)
    result = run_cli("stereo", "--colmap", str(model), "--transform", str(model / "transform.txt"), "--crs",
                     "EPSG:25832", "--images", str(folder), "--res", "1", "--bounds", bounds, "-o", cli, "--stats",
                     stats, "-q")
    assert result.returncode == 0, result.stderr
    heights = dsmplan.read_dsm(cli).heights
    valid = ~np.isnan(heights)
    assert valid.mean() > 0.8 and np.median(np.abs(heights - truth())[valid]) < 0.3  # the scene, not an empty DSM
    py = str(tmp_path / "py.tif")
    report = dsmplan.stereo(colmap=model, transform=model / "transform.txt", crs="EPSG:25832", colmap_images=folder,
                            res=1, bounds=BOUNDS, output=py)
    assert open(py, "rb").read() == open(cli, "rb").read()
    assert without_seconds(report) == without_seconds(json.load(open(stats)))
    assert report["georeference"]["method"] == "transform"
    assert report["cameras"] == str(model / "images.txt")
    assert abs(report["georeference"]["scale"] - 7.5) < 1e-9

    # The flags' rules are the library's, worded alike; --images is `colmap_images`.
    out = str(tmp_path / "dsm.tif")
    cases = [
        (["--colmap", str(model), "--transform", "t.txt"], dict(colmap=model, transform="t.txt"), "crs", "--crs"),
        (["--colmap", str(model), "--crs", "EPSG:25832"], dict(colmap=model, crs="EPSG:25832"), "centres",
         "--centres"),
        (["--colmap", str(model), "--crs", "EPSG:25832", "--centres", "c.csv", "--gcps", "g.csv"],
         dict(colmap=model, crs="EPSG:25832", centres="c.csv", gcps="g.csv"), "gcps", "--gcps"),
        (["--cameras", "c.json", "--images", str(folder)], dict(cameras="c.json", colmap_images=folder),
         "colmap_images", "--images"),
        (["--cameras", "c.json", "--gcps", "g.csv"], dict(cameras="c.json", gcps="g.csv"), "gcps", "--gcps"),
    ]
    for flags, kwargs, keyword, flag in cases:
        words = cli_error(run_cli("stereo", *flags, "--res", "1", "-o", out, "-q"))
        assert words.startswith(flag + ": "), words
        with pytest.raises(dsmplan.ArgumentError) as caught:
            dsmplan.stereo(res=1, output=out, **kwargs)
        assert str(caught.value) == keyword + ": " + words[len(flag) + 2:]
    with pytest.raises(dsmplan.ArgumentError, match="^gcps: must be a path"):
        dsmplan.stereo(colmap=model, gcps=3, crs="EPSG:25832", res=1)
    # A model file refused: the reader's line, as the CLI says it.
    (model / "images.txt").write_text("1 1 0 0 0 0 0 0 1\n\n")
    words = cli_error(run_cli("stereo", "--colmap", str(model), "--transform", str(model / "transform.txt"), "--crs",
                              "EPSG:25832", "--res", "1", "-o", out, "-q"))
    with pytest.raises(dsmplan.InputError) as caught:
        dsmplan.stereo(colmap=model, transform=model / "transform.txt", crs="EPSG:25832", res=1, output=out)
    assert str(caught.value) == words
    assert "images.txt: line 1: needs IMAGE_ID" in words
    assert not os.path.exists(out)
