// dsmplan/tools.hpp: the command-line tools as library functions, as GDAL's gdal_utils.h.
//
// Each tool takes an options struct, does the whole job (reading, every stage, writing, with
// progress) and returns a report. to_json() of a report is exactly what `dsmplan ... --json`
// prints or `--stats` writes: its keys are a contract with users and other tools, so keys are
// added, never renamed. The dsmplan binary does nothing but parse argv into these structs.
//
// Errors: as in core.hpp. Every option is checked before any long work starts.
#pragma once

#include <array>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/corridor.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/simplify.hpp"

namespace dsmplan {

using Json = nlohmann::ordered_json;

// ---- what every tool checks first ------------------------------------------------------------

/// A file a tool is given, with the flag it came by ("-o", "--dsm", "DSM", ...).
struct NamedFile {
  std::string flag, path;
};

/// ArgumentError naming the flag of the first output that is, or resolves to (through "..",
/// symbolic and hard links), one of the inputs or another output: an output must never replace
/// what the job reads, nor another output of the same run. A VRT input's source rasters (GDAL's
/// file list of it) count as inputs too ("DSM's source"). Empty paths are skipped. Called
/// before any work. O(files^2) path resolutions.
void refuse_overwrites(const std::vector<NamedFile>& inputs, const std::vector<NamedFile>& outputs);

// ---- dsmplan info ---------------------------------------------------------------------------

struct InfoOptions {
  std::string input;
  ReadRasterOptions read;  ///< a raster without CRS is described, not refused
};

struct RasterReport {
  std::string input;
  int width = 0, height = 0;
  double cell_x = 0, cell_y = 0;
  double xmin = 0, ymin = 0, xmax = 0, ymax = 0;  ///< outer edges of the cells, CRS units
  Crs crs;
  GridSummary summary;
};

RasterReport describe_raster(const InfoOptions& options);
/// Keys: file, width, height, resolution [x,y], extent {xmin,ymin,xmax,ymax}, crs {name,epsg,wkt},
/// vertical {name,unit}, units {horizontal, horizontal_m, vertical, vertical_m} (unit names and
/// metres per unit, null when not known; info shows a CRS in feet, the other tools refuse it),
/// cells, valid_cells, nodata_cells, holes, height_range [min,max].
Json to_json(const RasterReport& report);
/// The same for people, one "Label: value" line each.
std::string to_text(const RasterReport& report);

// ---- dsmplan grid ---------------------------------------------------------------------------

struct GridOptions {
  std::vector<std::string> inputs;  ///< LAS or XYZ files, all in one CRS
  std::string output;               ///< GeoTIFF (.tif, .tiff)
  std::string crs;                  ///< overrides the files' CRS; required when they have none
  GridPointsOptions grid;
  double fill_distance = 0;  ///< > 0: fill holes up to this distance (CRS units) from data
};

/// Reads the point clouds, grids them (median or max per cell), optionally fills holes, writes
/// the GeoTIFF atomically. Returns the written grid's summary.
GridSummary grid_to_geotiff(const GridOptions& options, const Progress& progress = {});
/// cells, valid, nodata, holes, z_min, z_max (null when there is no valid cell).
Json to_json(const GridSummary& summary);

// ---- dsmplan stereo -------------------------------------------------------------------------

/// `dsmplan stereo`: a DSM from frame-camera images with known poses (stereo_frames.hpp).
///
/// CAMERAS.json (a contract; README, "Stereo from frame cameras"):
///   {"crs": "EPSG:25832", "height_range": [100, 180],
///    "cameras": [{"image": "img_0.png", "width": 1200, "height": 900, "fx": 2400.0, "fy": 2400.0,
///                 "cx": 599.5, "cy": 449.5, "distortion": [k1, k2, p1, p2, k3],
///                 "rotation": [[1,0,0],[0,-1,0],[0,0,-1]], "center": [x, y, z]}, ...]}
/// crs, cameras and every camera key are required but "distortion" (default none);
/// "height_range" (the scene's lowest and highest heights, world units) bounds the disparity
/// search and sets the plane footprints are cut with; required (aerial disparities cannot be
/// searched without it). `image` is any GDAL raster, relative to the JSON's folder: one band
/// (grey) or three or more (RGB taken as luminance 0.299 R + 0.587 G + 0.114 B), 8 or 16 bit.
struct StereoJobOptions {
  std::string cameras;  ///< CAMERAS.json
  std::string output;   ///< GeoTIFF (.tif, .tiff)
  double resolution = 0;
  std::string pairs = "auto";  ///< "auto" or "0-1,1-2,..."
  std::optional<std::array<double, 4>> bounds;  ///< x0, y0, x1, y1; none: the pairs' overlap on the ground
};

struct StereoReport {
  std::string cameras, output;
  size_t camera_count = 0;
  std::vector<std::pair<int, int>> pairs;
  double min_height = 0, max_height = 0;
  std::array<double, 4> bounds{};
  int width = 0, height = 0;
  size_t matched_pixels = 0, points = 0, points_in_grid = 0;
  size_t points_outside_range = 0;  ///< triangulated outside height_range, dropped as mismatches
  GridSummary summary;
  double seconds_read = 0, seconds_rectify = 0, seconds_match = 0, seconds_triangulate = 0, seconds_fuse = 0,
         seconds_write = 0;
};

/// Reads CAMERAS.json and the images, checks everything (one InputError naming the file and the
/// camera/key), selects the pairs, runs stereo_dsm() and writes the Float32 GeoTIFF atomically.
/// InputError when no pair overlaps, when --bounds lies outside every pair's footprint, or when
/// nothing was matched (no output is written then).
StereoReport stereo_job(const StereoJobOptions& options, const Progress& progress = {});
/// Keys: cameras, output, camera_count, pairs [[i,j],...], height_range, bounds, width, height,
/// matched_pixels, points, points_outside_height_range, points_in_grid, dsm {cells, valid, nodata,
/// holes, z_min, z_max},
/// seconds {read, rectify, match, triangulate, fuse, write, total}.
Json to_json(const StereoReport& report);

// ---- dsmplan mesh ---------------------------------------------------------------------------

struct MeshJobOptions {
  std::string input;                 ///< DSM raster
  std::string output;                ///< .ply, .obj, .off or .glb (see write_mesh)
  std::optional<MeshFormat> format;  ///< overrides the output's extension (`--of`)
  ReadRasterOptions read;
  std::optional<double> resolution;  ///< resample to this x/y cell size first; none: keep the DSM's
  Resampling resampling = Resampling::Median;
  MeshOptions mesh;
  /// Band by band from the raster into the PLY (triangulate_xy3 over a GridSource): memory
  /// O(width x band), any height. Chosen by itself for a raster whose mesh would not fit in
  /// memory (without --res, to .ply); the mesh is the same either way.
  bool stream = false;
  /// `--3dtiles`: a 3D Tiles 1.1 tileset.json beside the GLB output (place_on_globe), its
  /// heights made WGS 84 ellipsoidal through `vertical` (refused before the work when they cannot be).
  bool tileset = false;
  VerticalOptions vertical;  ///< --vertical-crs, --allow-approximate-vertical
};

/// What `--3dtiles` wrote: tileset.json beside the GLB.
struct TilesetReport {
  std::string path;
  double max_placement_error_m = 0;  ///< TilesetPlacement::max_error_m
  std::string heights;               ///< the PROJ operation the heights went through
};

/// Where `--3dtiles` writes the tileset of the GLB `output`: "tileset.json" in its folder.
std::string tileset_path_for(const std::string& output);

struct MeshReport {
  std::string input, output;
  size_t vertices = 0, faces = 0;
  GridSummary summary;  ///< of the DSM as meshed (after resampling)
  int width = 0, height = 0;
  double source_resolution = 0, resolution = 0;
  std::optional<Resampling> resampling;  ///< none when the DSM was meshed at its own resolution
  double zstep = 0, max_edge_length = 0;
  uint64_t file_bytes = 0;
  size_t dropped_triangles = 0;  ///< left out of a GLB as degenerate in float32 (write_mesh)
  Crs crs;
  std::vector<std::pair<std::string, double>> seconds;  ///< read, resample, triangulate, write, total
  bool streamed = false;  ///< meshed band by band: holes were not counted (null)
  std::optional<TilesetReport> tileset;
};

/// DSM raster -> resampled, quantized grid -> XY-3 Delaunay mesh -> mesh file. Refuses
/// geographic CRSs (x,y in degrees cannot carry a metric safety distance).
MeshReport mesh_dsm(const MeshJobOptions& options, const Progress& progress = {});
/// Keys: input, output, vertices, faces, cells, valid_cells, nodata_cells, holes (null when
/// streamed), width, height, source_resolution, resolution, resampling, zstep, max_edge_length,
/// file_bytes, dropped_triangles, crs, vertical, seconds {read, resample, triangulate, write,
/// total} (streamed: read, triangulate and write are one pass, under triangulate), streamed,
/// tileset {path, max_placement_error_m, heights} (null without --3dtiles).
Json to_json(const MeshReport& report);

// ---- dsmplan simplify -----------------------------------------------------------------------

enum class SimplifyMethod { Variant1, Variant2, Bounded };
const char* to_string(SimplifyMethod);
/// Parses "variant1", "variant2", "bounded"; ArgumentError otherwise.
SimplifyMethod parse_simplify_method(const std::string& name);

/// Makes and assembles every block of a streamed bounded simplification (simplify.hpp).
using BoundedEngine = std::function<BoundedStreamResult(GridSource& dsm, const BoundedSimplifyOptions& options,
                                                        MeshSink& sink, const Progress& progress)>;

struct SimplifyJobOptions {
  std::string input;                 ///< DSM raster, or a mesh file (.ply, .obj, .off) made from `dsm`
  std::string output;                ///< .ply, .obj, .off or .glb (see write_mesh)
  std::optional<MeshFormat> format;  ///< overrides the output's extension (`--of`)
  std::string dsm;                   ///< with a mesh input: the DSM to certify against (required)
  ReadRasterOptions read;
  std::optional<double> resolution;  ///< resample the DSM to this x/y cell size first
  Resampling resampling = Resampling::Median;
  MeshOptions mesh;  ///< how a DSM input is meshed before the paper's variants
  SimplifyMethod method = SimplifyMethod::Variant2;
  PaperSimplifyOptions paper;      ///< dz, dco (the variant comes from `method`)
  BoundedSimplifyOptions bounded;  ///< max_error, conservative, delaunay, threads
  /// Who makes the blocks of the bounded mode when it streams (a DSM input without --res):
  /// empty = this process, on its threads; the dsmplan binary under mpirun sets MpiFarm's.
  BoundedEngine bounded_engine;
  bool tileset = false;      ///< `--3dtiles`, as MeshJobOptions::tileset
  VerticalOptions vertical;  ///< --vertical-crs, --allow-approximate-vertical (for --3dtiles)
};

struct SimplifyReport {
  std::string input, output;
  SimplifyMethod method = SimplifyMethod::Variant2;
  PaperSimplifyOptions paper;
  BoundedSimplifyOptions bounded;
  double source_resolution = 0, resolution = 0;
  size_t vertices_in = 0, vertices_out = 0, faces_in = 0, faces_out = 0;
  std::optional<size_t> removed_coplanar, removed_colinear;  ///< the paper's variants only
  std::optional<size_t> restored_colinear;                   ///< marked co-linear, put back
  VerticalError error;                                       ///< certified on the output
  size_t dropped_triangles = 0;  ///< left out of a GLB as degenerate in float32 (write_mesh)
  Crs crs;
  std::vector<std::pair<std::string, double>> seconds;  ///< per stage, and total
  std::optional<TilesetReport> tileset;
};

/// DSM (meshed as `dsmplan mesh` does) or mesh + DSM -> simplified mesh, certified against
/// the DSM, written atomically. The bounded mode needs the DSM as input (it works on the grid).
SimplifyReport simplify_job(const SimplifyJobOptions& options, const Progress& progress = {});
/// Keys (Table 2's columns and the certified error): input, output, method, dz, dco, max_error,
/// conservative, delaunay, source_resolution, resolution, vertices_in, vertices_out, reduction,
/// removed_coplanar, removed_colinear, restored_colinear (null in the bounded mode), faces_in, faces_out,
/// max_above_m, max_below_m, rms_m, certified_cells, uncovered_cells, dropped_triangles, crs, vertical,
/// seconds {read, mesh, search, triangulate | simplify, certify, write, total}, tileset (as dsmplan mesh's).
Json to_json(const SimplifyReport& report);
/// One summary line for people.
std::string to_text(const SimplifyReport& report);

// ---- dsmplan render -------------------------------------------------------------------------

struct RenderJobOptions {
  std::string dsm;                  ///< DSM raster: the ground of every panel
  std::vector<std::string> meshes;  ///< one panel each (.ply, .obj, .off, in the DSM's CRS)
  std::vector<std::string> titles;  ///< per panel; missing ones are the mesh (or DSM) file names
  std::string output;               ///< .png
  ReadRasterOptions read;
  std::optional<double> resolution;  ///< resample the DSM (median) to this cell size first
  RenderOptions render;              ///< window, zoom, edges, scale bar, north arrow (title: per panel)
  std::vector<std::string> paths;    ///< path CSVs (x,y,z as `dsmplan plan` writes them), drawn on every panel
  std::string waypoints;             ///< waypoint CSV: numbered discs on every panel
  std::string roadmap;               ///< roadmap file (`dsmplan plan --roadmap`): its edges, thin, under the paths
};

struct RenderReport {
  std::string output;
  int width = 0, height = 0;  ///< of the whole picture, pixels
  size_t panels = 0;
};

/// The paper's Figures 3 and 6-8: one hillshaded panel per mesh with its edges drawn (and the
/// roadmap, paths and waypoints over it when given), side by
/// side (8 pixels apart), or one panel of the DSM alone when there is no mesh; written as a PNG
/// atomically. Checks before reading: the output ends in .png, --res, the window and the zoom
/// (ArgumentError), at most one title per panel ("--title"). A mesh whose header names an EPSG
/// code other than the DSM's, or that lies wholly outside the DSM, is an InputError naming it.
RenderReport render_job(const RenderJobOptions& options, const Progress& progress = {});
/// Keys: output, width, height, panels.
Json to_json(const RenderReport& report);

// ---- dsmplan profile ------------------------------------------------------------------------

struct ProfileJobOptions {
  std::string dsm;        ///< DSM raster: the silhouette under the path
  std::string path;       ///< path CSV (x,y,z as `dsmplan plan` writes them), in the DSM's CRS
  std::string output;     ///< .png
  std::string dtm;        ///< terrain raster (optional): the ground of the ceiling, a brown line
  std::string waypoints;  ///< waypoint CSV (optional): numbered markers on the path
  ProfileOptions profile;  ///< size, title (empty: "PATH over DSM"), safety, max_agl
};

struct ProfileReport {
  std::string output;
  int width = 0, height = 0;
  double length = 0;                        ///< the path's x,y length
  double min_above_dsm = NAN, min_above_dsm_at = NAN;        ///< least height above the DSM cell below, where
  double max_above_ground = NAN, max_above_ground_at = NAN;  ///< greatest above the ground, where
  bool ground_is_dtm = false;
  double max_agl = 0;  ///< the ceiling above the ground
};

/// The height profile of a path (render_profile()) as a PNG, written atomically. Refused before
/// anything is written: an output not named .png (ArgumentError); a path with fewer than two
/// points or a point outside the DSM's extent, a DSM in degrees, a DTM whose EPSG code differs
/// from the DSM's or that does not overlap the DSM (InputError naming the file). Only the DSM's
/// and DTM's windows around the path are read, so the DSM may be a city's VRT mosaic.
ProfileReport profile_job(const ProfileJobOptions& options, const Progress& progress = {});
/// One line: "PROFILE.png: path 659.2 m long, least 3.82 m above the DSM below it (at 587.9 m),
/// at most 25.60 m above the DSM (at 294.8 m), ceiling DSM + 30 m kept with 4.40 m to spare"
/// ("EXCEEDED by X m" when the path rises above the ceiling).
std::string to_text(const ProfileReport& report);
/// output, width, height, length_m, min_above_dsm_m (and _at_m), max_above_ground_m (and _at_m),
/// ground ("dtm" or "dsm"), max_agl_m.
Json to_json(const ProfileReport& report);

// ---- dsmplan plan ---------------------------------------------------------------------------

/// Waypoints from a CSV file: one "x,y,z" line each, in the mesh's CRS (blanks around the
/// numbers allowed). Empty lines and lines starting with '#' are skipped; a first line that is
/// not numbers (e.g. "x,y,z") is a header. Throws InputError(path, "line N", ...) for any other
/// line that is not three finite numbers, and InputError(path) for a missing file.
std::vector<Point3> read_waypoints_csv(const std::string& path);

/// Waypoints from GeoJSON (RFC 7946): a FeatureCollection of Point features (one waypoint each,
/// in order; MultiPoint and LineString features give theirs in order), a Feature, or a bare
/// geometry. Positions are [longitude, latitude, height] in WGS 84 degrees and metres; the height
/// is required. InputError(path, "feature N[, position K]" or "byte N", why) otherwise.
std::vector<Point3> read_waypoints_geojson(const std::string& path);

/// How a mission (.plan, .waypoints) takes off and ends. The takeoff is vertical at home, to the
/// first waypoint's height above the ground (with the default home, the first waypoint itself);
/// when home is elsewhere, the route from there to the first waypoint is planned like any leg.
/// `--end rtl` plans a leg back above home, so that the autopilot's RTL, which flies a straight
/// unchecked line at its own altitude, finds nothing left to fly but the descent; `land` descends
/// at the last waypoint. The vertical climb and descent keep the safety distance from 1 m plus
/// `safety` above the ground up (below, a drone is taking off or landing). Without a DTM the
/// ground is the DSM's (or the mesh floor's) surface: a roof cannot be told from a street.
struct MissionJobOptions {
  /// x, y in the mesh's CRS, or longitude, latitude in degrees when |a| <= 180 and |b| <= 90;
  /// NaN: the ground under the first waypoint.
  std::array<double, 2> home{NAN, NAN};
  std::optional<MissionEnd> end;  ///< unset: rtl; --home and --end apply to missions only
  MissionOptions format;          ///< firmware, altitude frame, speeds
};

struct PlanJobOptions {
  std::string mesh;       ///< mesh file (read_mesh: .ply, .obj, .off), a 2.5D obstacle surface
  /// .csv: x,y,z in the mesh's CRS (read_waypoints_csv); .geojson/.json: WGS 84 longitude,
  /// latitude, ellipsoidal height (read_waypoints_geojson), transformed by Wgs84Transform.
  std::string waypoints;
  /// The path, by extension: .csv "x,y,z" in the mesh's CRS (shortest exact decimals);
  /// .geojson/.json an RFC 7946 LineString Feature (WGS 84, ellipsoidal heights); missions in
  /// WGS 84 with heights above mean sea level (EGM96): .plan a QGroundControl plan
  /// (mission_to_qgc_plan), .waypoints a "QGC WPL 110" text mission (mission_to_qgc_wpl), both
  /// flyable (MissionJobOptions) with the fewest items whose straight lines keep the limits, and
  /// .kmz the same mission for DJI aircraft (write_wpml_kmz); .kml a KML 2.2 LineString
  /// with altitudeMode absolute and the waypoints as Points (path_to_kml), every path point.
  std::string output;
  std::string format;     ///< csv, geojson, plan, waypoints or kml; empty: from the output's extension
  PlanOptions plan;       ///< planner (prm, rrt_connect), seed, safety, spacing, max_edge, max_agl, threads
  /// Roadmap file (PRM): read when it exists (read_roadmap(): refused when made for another mesh
  /// or other options), else built and written there for the next query.
  std::string roadmap;
  /// Raw DSM: when given, every point of the path keeps `safety` from its columns (each valid
  /// cell a box over its square; holes as high as their rim), planned with the safety widened
  /// by how far the mesh lies inside them (certify_columns()) and measured on the written path.
  std::string dsm;
  /// Terrain (any GDAL raster in the mesh's CRS, any resolution): the ground --max-agl counts
  /// from. Without it: the DSM's cells, else the mesh's floor (ground.hpp).
  std::string dtm;
  VerticalOptions vertical;  ///< heights for GeoJSON, missions, KML: --vertical-crs, --allow-approximate-vertical
  /// When `mesh` is a DSM (a raster or VRT mosaic, not a mesh file): planned along a corridor,
  /// window by window (plan_corridor()), on conservative bounded meshes made on the fly.
  CorridorOptions corridor;
  MissionJobOptions mission;  ///< .plan and .waypoints: home, end, firmware, altitude frame, speeds
};

struct PlanReport {
  std::string mesh, waypoints, output;
  size_t waypoint_count = 0, path_points = 0;
  double path_length_m = 0;
  /// Least distance of the written path to the mesh, measured on its own with
  /// ClearanceIndex::clearance() (capped at safety + max_agl).
  double min_clearance_m = 0;
  /// With a DSM: least distance of the path to the DSM's columns (column_clearance(), same cap); NaN without.
  double min_clearance_dsm_m = NAN;
  /// With a DSM: the mesh's certified depth below it (certify().max_below) and the tolerance
  /// the path is held to, sqrt((cell diagonal / 2)^2 + max_below^2): the path is written only
  /// when min_clearance_dsm_m >= safety - tolerance and > 0.
  double mesh_max_below_dsm_m = NAN, dsm_tolerance_m = NAN;
  /// With a DSM: the most a column rises above the mesh anywhere (certify_columns()), and the
  /// margin the safety distance was widened by on the mesh to hold against the columns.
  double column_max_above_mesh_m = NAN, safety_margin_m = NAN;
  /// Greatest height of the written path above the ground in use (exact), and which ground.
  double max_agl_m = NAN;
  std::string ground;
  size_t roadmap_nodes = 0, roadmap_edges = 0;
  bool roadmap_reused = false;  ///< the roadmap came from the --roadmap file
  size_t refined_samples = 0;   ///< samples the query added where the roadmap failed a leg (plan.hpp, "Refinement")
  std::string planner = "prm";
  size_t corridor_windows = 0;               ///< a DSM input: windows planned in (0: a mesh input)
  size_t corridor_largest_window_cells = 0;  ///< a DSM input: cells of the largest window
  /// The PROJ operation(s) used: GeoJSON waypoints' and GeoJSON output's (to ellipsoidal
  /// heights), then "; path by: " the missions' and KML's (to EGM96 heights); empty when none.
  std::string transformation;
  double seconds_load = 0, seconds_roadmap = 0, seconds_query = 0, seconds_smooth = 0;
  /// seconds_load split: reading the files (mesh, DSM, DTM, a reused roadmap) and the rest
  /// (the clearance index, the mesh's floor, the DSM's columns against the mesh).
  double seconds_read = 0, seconds_index = 0;
  /// Missions: the items written (takeoff, speed, waypoints, end), home (x, y in the CRS, z its
  /// ground) and the height of the takeoff above it.
  size_t mission_items = 0;
  Point3 home{NAN, NAN, NAN};
  double takeoff_height_m = NAN;
  std::string mission_end;  ///< rtl, land or none
};

/// Mesh file + waypoints -> roadmap -> path (plan_path(), see plan.hpp) -> CSV, GeoJSON, a
/// mission (.plan, .waypoints) or KML, written atomically. The transformation to WGS 84 is made
/// before planning: ArgumentError("--vertical-crs") then for an unknown or approximate vertical
/// reference that is not allowed (Wgs84Transform). Options and the output's extension are checked before anything is read.
/// A bad waypoint is an InputError(waypoints file, "waypoint N", why: outside the extent, under
/// the surface, closer than the safety distance); a leg without a path InputError(waypoints
/// file, "waypoints N to M", why); fewer than two waypoints InputError(waypoints file); a
/// roadmap file of another mesh or other options InputError(roadmap file); with a DSM, a path
/// closer to its columns than safety - dsm_tolerance_m InputError(DSM file). Nothing is
/// written then. seconds_load includes reading a reused roadmap.
PlanReport plan_job(const PlanJobOptions& options, const Progress& progress = {});
/// Keys: path_length_m, min_clearance_m, roadmap_nodes, roadmap_edges, seconds_load (=
/// seconds_read + seconds_index), seconds_roadmap, seconds_query, seconds_smooth; min_clearance_dsm_m, dsm_tolerance_m,
/// mesh_max_below_dsm_m with a DSM;
/// roadmap_reused, refined_samples, planner; transformation when WGS 84 was involved.
Json to_json(const PlanReport& report);
/// One summary line for people.
std::string to_text(const PlanReport& report);

// ---- dsmplan view ---------------------------------------------------------------------------

struct ViewOptions {
  std::string mesh;       ///< GLB of `dsmplan mesh|simplify -o X.glb`
  std::string path;       ///< optional path CSV (x,y,z in the mesh's CRS, as `dsmplan plan -o X.csv`)
  std::string waypoints;  ///< optional waypoint CSV (x,y,z)
  std::string host = "127.0.0.1";
  int port = 8080;  ///< 0: any free port (the URL names the one taken)
  /// The viewer's static files: index.html, viewer.js and node_modules/three (the build puts
  /// them in build/web/viewer). Empty: default_viewer_dir().
  std::string viewer_dir;
};

/// web/viewer beside the running executable (build/dsmplan -> build/web/viewer).
std::string default_viewer_dir();

/// The 3D viewer (web/viewer: three.js) over HTTP: serves the viewer folder at / and the given
/// files as /data/mesh.glb, /data/path.csv, /data/waypoints.csv, nothing else (a request naming
/// ".." is refused). Checks every file first (the mesh a GLB, the CSVs readable as x,y,z, the
/// viewer folder complete: InputError), binds (ArgumentError("--port") when the port is taken), calls
/// `listening` with the page's URL, then serves until the process is stopped.
void serve_view(const ViewOptions& options, const std::function<void(const std::string& url)>& listening);

// ---- MPI: the bounded mode as a task farm -------------------------------------------------
//
// `mpirun -np N dsmplan simplify DSM --max-error E ... -o MESH.ply` runs the streamed bounded
// mode as a task farm: rank 0 hands out blocks (their indices), ranks 1..N-1 open the DSM
// themselves, make the blocks they are given (simplify_bounded_block(), on their threads) and
// send them back; rank 0 assembles them in order and writes the mesh. The mesh is the same, bit
// for bit, as a run without mpirun (blocks do not depend on where they are made, and only rank
// 0 numbers them). Rank 0 keeps at most two blocks a worker in flight, so its memory stays
// bounded too. Other commands run on rank 0 alone. Built when CMake finds MPI (DSMPLAN_MPI).

class MpiFarm {
public:
  /// Starts MPI when this process was launched by mpirun with two or more ranks (and dsmplan
  /// was built with MPI); otherwise the farm is inactive and MPI is not touched.
  MpiFarm(int& argc, char**& argv);
  ~MpiFarm();  ///< MPI_Finalize
  MpiFarm(const MpiFarm&) = delete;
  MpiFarm& operator=(const MpiFarm&) = delete;

  bool active() const { return size_ > 1; }
  int rank() const { return rank_; }
  int size() const { return size_; }

  /// Rank 0: the engine to put into SimplifyJobOptions::bounded_engine.
  BoundedEngine master() const;
  /// Ranks >= 1: opens `options.input` and makes blocks until rank 0 says stop. A failure is
  /// sent to rank 0, which reports it.
  void serve(const SimplifyJobOptions& options) const;
  /// Rank 0, once its job is over (done or failed): releases the workers still waiting.
  void release_workers() const;

private:
  int rank_ = 0, size_ = 1;
};

}  // namespace dsmplan
