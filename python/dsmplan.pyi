# Type stubs of the module `dsmplan` (python/dsmplan_module.cpp), installed beside it: the
# reference of the Python face. tests/python/test_stubs.py checks that every public name of the
# module and of its classes is here with the same parameters, and has a docstring.
import os
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

__version__: str

class Error(Exception):
    """Every error dsmplan raises, with the library's one-line text (the command line's words)."""

class InputError(Error):
    """A file or data that cannot be used: missing, damaged, in feet, no path through it, a
    waypoint under a roof; the text names the file and the place."""

class ArgumentError(Error):
    """An argument out of range or contradicting another; the text starts with the keyword
    argument's name (the CLI shows the flag)."""

class OutputError(Error):
    """A file that could not be written (nothing is left half-written)."""

class Dsm:
    """A DSM raster in memory: read_dsm(), grid(), or a numpy array (Dsm(heights, transform, crs))."""

    def __init__(
        self,
        heights: npt.ArrayLike,
        transform: Sequence[float],
        crs: str = "",
        nodata: float | None = None,
    ) -> None:
        """A DSM from a numpy array (row 0 north) with rasterio's affine transform
        (a, b, c, d, e, f) = (cell width, 0, west, 0, -cell height, north) and a CRS; NaN,
        infinite or `nodata` heights are holes. The heights are copied."""
    @property
    def heights(self) -> npt.NDArray[np.float32]:
        """rows x columns float32 heights (row 0 north), nodata as NaN; a read-only view."""
    @property
    def transform(self) -> tuple[float, float, float, float, float, float]:
        """GDAL geotransform (x0, cell_x, 0, y0, 0, -cell_y)."""
    @property
    def crs(self) -> str:
        """The CRS as WKT (empty when unknown)."""
    def write(self, path: str) -> None:
        """Writes a Float32 GeoTIFF (.tif, .tiff) as `dsmplan grid` does; a DSM dsmplan could not
        read back (no CRS, not in metres, no valid cell) raises ArgumentError."""

class Mesh:
    """A triangle mesh in the DSM's CRS: mesh() or simplify()."""

    @property
    def vertices(self) -> npt.NDArray[np.float64]:
        """N x 3 float64 x, y, z (a read-only view)."""
    @property
    def faces(self) -> npt.NDArray[np.uint32]:
        """M x 3 vertex indices, counter-clockwise from above (a read-only view)."""
    @property
    def certified(self) -> dict[str, float] | None:
        """simplify()'s certified error (max_above_m, max_below_m, rms_m, cells); None for mesh()."""
    def write(self, path: str) -> None:
        """Writes .ply, .obj, .off or .glb (by the extension), atomically, with the CRS."""

class Flight:
    """A path planned and verified by plan()."""

    @property
    def path(self) -> npt.NDArray[np.float64]:
        """K x 3 float64 x, y, z in the mesh's CRS, through every waypoint (a read-only view)."""
    @property
    def report(self) -> dict[str, Any]:
        """The figures of `dsmplan plan --stats`: path_length_m, min_clearance_m, max_agl_m, ..."""
    def write(
        self,
        path: str,
        format: str = "",
        firmware: str = "generic",
        altitude_frame: str = "relative",
        speed: float = 5.0,
        vertical_crs: str = "",
        allow_approximate_vertical: bool = False,
        drone: str = "m3e",
    ) -> None:
        """Writes the path as `dsmplan plan -o`: .csv, .geojson, .kml; a mission also .plan,
        .waypoints, .kmz."""

def read_dsm(path: str) -> Dsm:
    """Reads a DSM raster (any GDAL raster or VRT, with a CRS, in metres)."""

def grid(
    points: str | Sequence[str],
    res: float,
    *,
    crs: str = "",
    fusion: str = "median",
    classes: Sequence[int] = (),
    drop_classes: Sequence[int] | None = None,
    keep_all_classes: bool = False,
    fill_holes: float = 0.0,
) -> Dsm:
    """LAS, LAZ or XYZ point clouds to a DSM in memory, median per cell, as `dsmplan grid`."""

def mesh(dsm: Dsm, zstep: float = 0.1) -> Mesh:
    """The XY-3 Delaunay mesh of the DSM, heights in `zstep` steps (0 keeps them)."""

def simplify(dsm: Dsm, max_error: float = 0.4, conservative: bool = True, delaunay: bool = False) -> Mesh:
    """The bounded simplification: 0 <= mesh - DSM <= max_error (conservative), certified."""

def plan(
    mesh: Mesh,
    waypoints: npt.ArrayLike,
    dsm: Dsm | None = None,
    dtm: Dsm | None = None,
    safety: float = 2.0,
    max_agl: float = 120.0,
    spacing: float = 20.0,
    planner: str = "prm",
    mission: bool = False,
    home: tuple[float, float] | None = None,
    end: str | None = None,
    vertical_crs: str = "",
    no_fly: Sequence[str] = [],
    no_fly_blocking: Sequence[str] | None = None,
    allow_approximate_vertical: bool = False,
    snap: float = 0.0,
    waypoint_heights: str = "crs",
    objective: str = "low",
    no_fly_buffer: float | None = None,
) -> Flight:
    """A collision-free path through the waypoints with every check of `dsmplan plan`."""

def plan_routes(
    mesh: Mesh,
    routes: Sequence[npt.ArrayLike],
    *,
    dsm: Dsm | None = None,
    dtm: Dsm | None = None,
    safety: float = 2.0,
    max_agl: float = 120.0,
    spacing: float = 20.0,
    planner: str = "prm",
    no_fly: Sequence[str] = (),
    no_fly_blocking: Sequence[str] | None = None,
    vertical_crs: str = "",
    allow_approximate_vertical: bool = False,
    snap: float = 0.0,
    waypoint_heights: str = "crs",
    objective: str = "low",
    no_fly_buffer: float | None = None,
    route_budget: float = 0.0,
) -> list[Flight | InputError]:
    """Many routes over one roadmap, as `dsmplan plan --routes`: a Flight a route, or the
    InputError plan() would raise for it (returned, not raised: one route stops no other),
    with the route's failure as attributes: code ("waypoint_refused", "no_path",
    "home_refused", "end_refused", "route_budget", "refused"), waypoint, leg (from, to),
    nearest_valid_point (x, y, z in the mesh's CRS) or None. route_budget: each route's own
    time limit in seconds (0: none)."""

def render(
    dsm: str | Dsm,
    output: str,
    *,
    meshes: str | Sequence[str] | None = None,
    titles: str | Sequence[str] | None = None,
    paths: str | Flight | Sequence[str | Flight] | None = None,
    waypoints: str | npt.ArrayLike | None = None,
    roadmap: str | None = None,
    window: tuple[float, float, float, float] | None = None,
    zoom: float = 4.0,
    edges: bool = True,
    res: float | None = None,
    band: int = 1,
    crs: str = "",
    no_fly: Sequence[str] = (),
    no_fly_blocking: Sequence[str] | None = None,
    vertical_crs: str = "",
    allow_approximate_vertical: bool = False,
) -> dict[str, Any]:
    """The DSM (a file or a Dsm) from above with meshes' edges, paths (CSVs, or Flights as flown
    with their waypoints and zones), waypoints and no-fly zones, as `dsmplan render`, to a PNG;
    returns the report of `--json` (output, width, height, panels, window, zoom)."""

def profile(
    dsm: str | Dsm,
    path: str | Flight,
    output: str,
    *,
    dtm: str | Dsm | None = None,
    waypoints: str | npt.ArrayLike | None = None,
    safety: float | None = None,
    max_agl: float | None = None,
    title: str = "",
    width: int = 1200,
    height: int = 500,
    no_fly: Sequence[str] = (),
    no_fly_blocking: Sequence[str] | None = None,
    vertical_crs: str = "",
    allow_approximate_vertical: bool = False,
) -> dict[str, Any]:
    """A path's height profile as `dsmplan profile`, to a PNG: a path CSV, or a Flight as flown
    with its waypoints, zones, DTM, safety and ceiling unless given; returns the report of
    `--json` (length_m, min_above_dsm_m, min_above_lowest_clear_m, max_above_ground_m, ground, max_agl_m, ...)."""

def stereo(
    images: str | Sequence[str] | None = None,
    *,
    cameras: str | os.PathLike[str] | dict[str, Any] | None = None,
    res: float,
    output: str | None = None,
    pairs: str = "auto",
    bounds: tuple[float, float, float, float] | None = None,
    crs: str = "",
    allow_approximate_vertical: bool = False,
    fusion_memory: float = 1024.0,
    band_memory: float = 1024.0,
    colmap: str | os.PathLike[str] | None = None,
    centres: str | os.PathLike[str] | None = None,
    gcps: str | os.PathLike[str] | None = None,
    transform: str | os.PathLike[str] | None = None,
    colmap_images: str | os.PathLike[str] | None = None,
) -> Dsm | dict[str, Any]:
    """A DSM from satellite images with RPCs (`images`) or frame cameras (`cameras`: a
    CAMERAS.json path or a dict in its schema, a dict's relative image paths taken from the
    current directory; or `colmap`: a COLMAP text model put in `crs` by `centres` (a CSV of
    image,x,y,z, or "exif"), `gcps` or `transform`, its images in `colmap_images`), as `dsmplan stereo`. Returns the Dsm when `output` is None, else writes
    the GeoTIFF and returns the report of `--stats` as a dict."""
