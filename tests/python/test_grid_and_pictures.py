# grid(), Dsm.write(), render() and profile() give what the command line gives: the same library
# functions, so the same bytes (the GeoTIFF, the PNGs), the same reports (`--json`) and the same
# refusals, worded alike (a keyword argument where the CLI names a flag). Oracles: the CLI's own
# outputs and words, GDAL's Python bindings for the GeoTIFF, and medians worked out by hand for
# an XYZ file written here.
import json
import os
import subprocess

import numpy as np
import pytest
from osgeo import gdal

import dsmplan

gdal.UseExceptions()
DATA = os.environ.get("DSMPLAN_DATA_DIR", "data")
DELFT = [os.path.join(DATA, "delft-ahn3", f"ahn3_cropped_{i}.laz") for i in (1, 2)]
NRW_DSM = os.path.join(DATA, "nrw-dom1", "nrw_dom1_crop500m_1m.tif")
NRW_WAYPOINTS = os.path.join(DATA, "nrw-dom1", "sample_waypoints.csv")


def run_cli(*args):
    return subprocess.run([os.environ.get("DSMPLAN_CLI", "dsmplan"), *args], capture_output=True, text=True)


def cli_words(result):
    """The CLI's one-line error, without "dsmplan: " and the flag it names."""
    assert result.returncode != 0
    line = result.stderr.strip().splitlines()[0]
    return line.split(": ", 2)[2] if line.startswith("dsmplan: --") else line


def test_grid_gives_the_median_per_cell_of_the_points(tmp_path):
    # Four cells of 2 m; the median of an even count is the mean of the two middle heights.
    points = [(0.5, 3.5, 10), (1.5, 2.5, 12), (1.0, 3.0, 30),  # cell (0, 0): 12
              (2.5, 3.5, 5), (3.5, 2.5, 7),  # cell (0, 1): 6
              (0.5, 0.5, 1), (1.5, 1.5, 2), (1.0, 1.0, 3), (0.2, 0.2, 100)]  # cell (1, 0): 2.5
    xyz = tmp_path / "points.xyz"
    xyz.write_text("".join(f"{x} {y} {z}\n" for x, y, z in points))
    dsm = dsmplan.grid(str(xyz), res=2.0, crs="EPSG:25832")
    expected = np.array([[12, 6], [2.5, np.nan]], dtype=np.float32)
    np.testing.assert_array_equal(dsm.heights, expected)
    assert dsm.transform == (0.0, 2.0, 0.0, 4.0, 0.0, -2.0)
    assert "UTM zone 32N" in dsm.crs
    assert not dsm.heights.flags.writeable
    assert dsmplan.grid([str(xyz)], res=2.0, crs="EPSG:25832", fusion="max").heights[0, 0] == 30


def test_grid_and_write_give_the_geotiff_of_dsmplan_grid(tmp_path):
    for extra, kwargs in (([], {}), (["--classes", "2", "--fill-holes", "30"], {"classes": [2], "fill_holes": 30})):
        cli = str(tmp_path / "cli.tif")
        result = run_cli("grid", *DELFT, "--crs", "EPSG:7415", "--res", "2", *extra, "-o", cli, "-q")
        assert result.returncode == 0, result.stderr
        dsm = dsmplan.grid(DELFT, res=2, crs="EPSG:7415", **kwargs)
        py = str(tmp_path / "py.tif")
        dsm.write(py)
        assert open(py, "rb").read() == open(cli, "rb").read()
        # And as GDAL reads it: the heights of the Dsm, holes as nodata.
        ds = gdal.Open(py)  # held: a band outlives no dataset
        band = ds.GetRasterBand(1)
        heights = band.ReadAsArray()
        np.testing.assert_array_equal(np.where(heights == band.GetNoDataValue(), np.nan, heights), dsm.heights)
    # A written Dsm reads back as it was.
    again = dsmplan.read_dsm(py)
    np.testing.assert_array_equal(again.heights, dsm.heights)
    assert again.transform == dsm.transform


def test_grid_refuses_what_the_command_line_refuses_in_the_same_words(tmp_path):
    out = str(tmp_path / "dsm.tif")
    common = [*DELFT, "--crs", "EPSG:7415", "-o", out, "-q"]
    cases = [
        (["--res", "0"], dict(res=0), "res"),
        (["--res", "1", "--classes", "2", "--keep-all-classes"], dict(res=1, classes=[2], keep_all_classes=True),
         "classes"),
        (["--res", "1", "--classes", "2", "--drop-classes", "2"], dict(res=1, classes=[2], drop_classes=[2]),
         "classes"),
        (["--res", "1", "--fusion", "mean"], dict(res=1, fusion="mean"), "fusion"),
        (["--res", "1", "--fill-holes", "-1"], dict(res=1, fill_holes=-1), "fill_holes"),
    ]
    for flags, kwargs, keyword in cases:
        words = cli_words(run_cli("grid", *common, *flags))
        with pytest.raises(dsmplan.ArgumentError) as caught:
            dsmplan.grid(DELFT, crs="EPSG:7415", **kwargs)
        assert str(caught.value) == f"{keyword}: {words}"
    with pytest.raises(dsmplan.InputError, match="has no CRS"):
        dsmplan.grid(DELFT, res=1)  # the Delft crops state none
    with pytest.raises(dsmplan.ArgumentError, match="^points: no point cloud given"):
        dsmplan.grid([], res=1)
    with pytest.raises(dsmplan.InputError, match="no-such.laz"):
        dsmplan.grid(str(tmp_path / "no-such.laz"), res=1, crs="EPSG:7415")
    assert not os.path.exists(out)


def test_write_refuses_a_dsm_dsmplan_could_not_read_back(tmp_path):
    heights = np.arange(12, dtype=np.float32).reshape(3, 4)
    affine = (1.0, 0.0, 356000.0, 0.0, -1.0, 5699000.0)
    cases = [
        (dsmplan.Dsm(heights, affine), "out.tif", "^crs: "),  # no CRS
        (dsmplan.Dsm(heights, affine, "EPSG:2263"), "out.tif", "^crs: .*foot"),  # New York, in feet
        (dsmplan.Dsm(np.full((3, 4), np.nan), affine, "EPSG:25832"), "out.tif", "^heights: "),
        (dsmplan.Dsm(heights, affine, "EPSG:25832"), "out.png", "GeoTIFF"),
    ]
    for dsm, name, words in cases:
        with pytest.raises(dsmplan.ArgumentError, match=words):
            dsm.write(str(tmp_path / name))
    assert os.listdir(tmp_path) == []
    dsmplan.Dsm(heights, affine, "EPSG:25832").write(str(tmp_path / "out.tif"))
    np.testing.assert_array_equal(dsmplan.read_dsm(str(tmp_path / "out.tif")).heights, heights)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """The sample's bounded mesh and a path over it, as files (what render and profile read)."""
    folder = tmp_path_factory.mktemp("pictures")
    dsm = dsmplan.read_dsm(NRW_DSM)
    mesh = dsmplan.simplify(dsm, max_error=0.4)
    mesh_file, path_file = str(folder / "bounded.ply"), str(folder / "path.csv")
    mesh.write(mesh_file)
    rows = [line for line in open(NRW_WAYPOINTS) if line[0].isdigit()]
    waypoints = np.array([[float(v) for v in row.split(",")] for row in rows])
    dsmplan.plan(mesh, waypoints, dsm=dsm).write(path_file)
    return folder, mesh_file, path_file


def test_render_gives_the_png_and_report_of_dsmplan_render(planned):
    folder, mesh_file, path_file = planned
    cli_png, py_png = str(folder / "cli_render.png"), str(folder / "py_render.png")
    flags = ["--mesh", mesh_file, "--path", path_file, "--waypoints", NRW_WAYPOINTS, "--zoom", "1"]
    result = run_cli("render", NRW_DSM, *flags, "--window", "356300,5699250,356600,5699550", "-o", cli_png,
                     "--json", "-q")
    assert result.returncode == 0, result.stderr
    report = dsmplan.render(NRW_DSM, py_png, meshes=mesh_file, paths=[path_file], waypoints=NRW_WAYPOINTS,
                            zoom=1, window=(356300, 5699250, 356600, 5699550))
    assert open(py_png, "rb").read() == open(cli_png, "rb").read()
    assert report == dict(json.loads(result.stdout), output=py_png)
    assert report["panels"] == 1 and report["width"] == 300
    # Two panels, no edges, titles: the same as the CLI too.
    result = run_cli("render", NRW_DSM, "--mesh", mesh_file, "--mesh", mesh_file, "--title", "a", "--title", "b",
                     "--no-edges", "--res", "4", "-o", cli_png, "-q")
    assert result.returncode == 0, result.stderr
    dsmplan.render(NRW_DSM, py_png, meshes=[mesh_file, mesh_file], titles=["a", "b"], edges=False, res=4)
    assert open(py_png, "rb").read() == open(cli_png, "rb").read()


def test_render_refuses_what_the_command_line_refuses(planned, tmp_path):
    folder, mesh_file, _ = planned
    out = str(tmp_path / "r.png")
    for flags, kwargs, keyword in [
        (["--zoom", "0"], dict(zoom=0), "zoom"),
        (["--res", "-1"], dict(res=-1), "res"),
        (["--window", "10,10,5,5"], dict(window=(10, 10, 5, 5)), "window"),
        (["--title", "a", "--title", "b"], dict(titles=["a", "b"]), "titles"),
    ]:
        words = cli_words(run_cli("render", NRW_DSM, *flags, "-o", out, "-q"))
        with pytest.raises(dsmplan.ArgumentError) as caught:
            dsmplan.render(NRW_DSM, out, **kwargs)
        assert str(caught.value) == f"{keyword}: {words}"
    with pytest.raises(dsmplan.ArgumentError, match="name it .png"):
        dsmplan.render(NRW_DSM, str(tmp_path / "r.jpg"))
    # An output that is an input is refused before anything is read or written.
    with pytest.raises(dsmplan.ArgumentError, match="^output: .* is the same file as meshes"):
        dsmplan.render(NRW_DSM, mesh_file, meshes=mesh_file)
    assert os.listdir(tmp_path) == []


def test_profile_gives_the_png_and_report_of_dsmplan_profile(planned, tmp_path):
    folder, _, path_file = planned
    cli_png, py_png = str(folder / "cli_profile.png"), str(folder / "py_profile.png")
    result = run_cli("profile", NRW_DSM, "--path", path_file, "--waypoints", NRW_WAYPOINTS, "--max-agl", "40",
                     "--title", "over Essen", "--width", "800", "-o", cli_png, "--json", "-q")
    assert result.returncode == 0, result.stderr
    report = dsmplan.profile(NRW_DSM, path_file, py_png, waypoints=NRW_WAYPOINTS, max_agl=40, title="over Essen",
                             width=800)
    assert open(py_png, "rb").read() == open(cli_png, "rb").read()
    assert report == dict(json.loads(result.stdout), output=py_png)
    assert report["ground"] == "dsm" and report["min_above_dsm_m"] > 2
    for flags, kwargs, keyword in [
        (["--width", "100"], dict(width=100), "width"),
        (["--max-agl", "0"], dict(max_agl=0), "max_agl"),
        (["--safety", "-1"], dict(safety=-1), "safety"),
    ]:
        out = str(tmp_path / "p.png")
        words = cli_words(run_cli("profile", NRW_DSM, "--path", path_file, *flags, "-o", out, "-q"))
        with pytest.raises(dsmplan.ArgumentError) as caught:
            dsmplan.profile(NRW_DSM, path_file, out, **kwargs)
        assert str(caught.value) == f"{keyword}: {words}"
    with pytest.raises(dsmplan.ArgumentError, match="^output: "):
        dsmplan.profile(NRW_DSM, path_file, path_file)
    assert os.listdir(tmp_path) == []
