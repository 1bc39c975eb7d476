// dsmplan/tools.hpp: the command-line tools as library functions, as GDAL's gdal_utils.h.
//
// Each tool takes an options struct, does the whole job (reading, every stage, writing, with
// progress) and returns a report. to_json() of a report is exactly what `dsmplan ... --json`
// prints or `--stats` writes: its keys are a contract with users and other tools, so keys are
// added, never renamed. The dsmplan binary does nothing but parse argv into these structs.
//
// Errors: as in core.hpp. Every option is checked before any long work starts.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
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
#include "dsmplan/mission.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/points.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/rpc.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/simplify_streamed.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

// ---- the CRS rule every face applies to a DSM or a mesh before working on it ------------------

/// The centre of a raster's or a mesh's x,y extent, in its CRS: where require_projected() takes
/// the UTM zone of its example.
struct XY {
  double x = 0, y = 0;
};
inline XY centre_of(const Grid& grid) {
  return {grid.x0 + grid.width * grid.cell_x / 2, grid.y0 - grid.height * grid.cell_y / 2};
}
inline XY centre_of(const Mesh& mesh) {
  if (mesh.vertices.empty()) return {};
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  for (const Vertex& v : mesh.vertices) {
    x0 = std::min(x0, v.x), x1 = std::max(x1, v.x);
    y0 = std::min(y0, v.y), y1 = std::max(y1, v.y);
  }
  return {(x0 + x1) / 2, (y0 + y1) / 2};
}

/// Delaunay on degrees with heights in metres means nothing, nor does a metric safety distance,
/// nor do feet taken as metres: InputError naming `path` unless `crs` (of a DSM or a mesh) is
/// projected with x, y in metres and heights in metres or of unknown unit (metric_problem():
/// the one line names the unit and suggests reprojecting to the WGS 84 / UTM zone of `centre`,
/// e.g. "gdalwarp -t_srs EPSG:32617" for a raster in Virginia). A mesh's CRS (name, EPSG, WKT
/// from its header) has its units read from the WKT here.
inline void require_projected(const Crs& crs, const std::string& path, XY centre) {
  const std::string problem = metric_problem(crs, path, centre.x, centre.y);
  if (!problem.empty()) throw InputError(path, "", problem);
}

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
  /// A satellite image's RPC camera (dsmplan/rpc.hpp), when it has one: where it was
  /// read from, the crop's sensor offset, the model's height range (HEIGHT_OFF -/+ HEIGHT_SCALE,
  /// metres above the WGS 84 ellipsoid) and the image's four corners localized at HEIGHT_OFF.
  struct Rpc {
    std::string source;
    double sensor_col = 0, sensor_row = 0;
    double height_min = 0, height_max = 0, footprint_height = 0;
    std::array<GeoPoint, 4> corners{};  ///< top-left, top-right, bottom-right, bottom-left
  };
  std::optional<Rpc> rpc;
};

/// Throws what read_rpc_camera throws for an image whose RPC is there but bad.
RasterReport describe_raster(const InfoOptions& options);
/// How `dsmplan info` prints the report (`--of`).
enum class InfoFormat { Text, Json };
/// "text" (or empty: not given) or "json"; ArgumentError("--of") otherwise.
InfoFormat parse_info_format(const std::string& name);
/// Keys: file, width, height, resolution [x,y], extent {xmin,ymin,xmax,ymax}, crs {name,epsg,wkt},
/// vertical {name,unit}, units {horizontal, horizontal_m, vertical, vertical_m} (unit names and
/// metres per unit, null when not known; info shows a CRS in feet, the other tools refuse it),
/// cells, valid_cells, nodata_cells, holes, height_range [min,max], rpc (null, or {source,
/// sensor_offset [col,row], height_range [min,max], footprint {height, corners [[lon,lat] x4]}}).
Json to_json(const RasterReport& report);
/// The same for people, one "Label: value" line each.
std::string to_text(const RasterReport& report);

// ---- dsmplan grid ---------------------------------------------------------------------------

struct GridOptions {
  std::vector<std::string> inputs;  ///< LAS or XYZ files, all in one CRS
  std::string output;               ///< GeoTIFF (.tif, .tiff)
  std::string crs;                  ///< overrides the files' CRS; required when they have none
  GridPointsOptions grid;           ///< resolution, fusion (its class lists: from the three below)
  // The ASPRS classes gridded, as asked (a list not given is not the same as an empty one):
  std::vector<int> classes;                      ///< only these (e.g. {2}: ground, a DTM); empty: all not dropped
  std::optional<std::vector<int>> drop_classes;  ///< left out; none: 7, 18 (noise), or nothing with `classes`
  bool keep_all_classes = false;                 ///< every class, noise included; not with `classes`
  double fill_distance = 0;                      ///< > 0: fill holes up to this distance (CRS units) from data

  /// Every option, before any file is opened (grid_to_geotiff calls it first): ArgumentError for
  /// `classes` with keep_all_classes, grid's own class lists changed (they would be replaced),
  /// an output not .tif, a resolution that is not positive, a negative fill_distance, no input.
  void check() const;
  /// `grid` with the classes resolved: what grid_points() runs with.
  GridPointsOptions points_options() const;
};

/// Reads the point clouds, grids them (median or max per cell), optionally fills holes, writes
/// the GeoTIFF atomically. Returns the written grid's summary.
GridSummary grid_to_geotiff(const GridOptions& options, const Progress& progress = {});
/// grid_to_geotiff() without the writing: the DSM in memory (options.output is not used), with
/// the same checks of the options and the files (ArgumentError "--res", "--fill-holes",
/// "POINTS"; InputError for a file with no points, no CRS and none given, or in feet).
Grid grid_point_files(const GridOptions& options, const Progress& progress = {});
/// Writes a DSM as `dsmplan grid` does (write_geotiff(): Float32, DEFLATE, atomic), refusing
/// before anything is written what dsmplan's own readers would refuse: an output not named
/// .tif or .tiff (ArgumentError naming it), a DSM without CRS or with x, y or heights in a unit
/// other than the metre ("crs"), one without a valid cell ("heights").
void write_dsm(const Grid& grid, const std::string& output, const Progress& progress = {});
/// cells, valid, nodata, holes, z_min, z_max (null when there is no valid cell).
Json to_json(const GridSummary& summary);

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
  bool streamed = false;                                ///< meshed band by band: holes were not counted (null)
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
  // The method and its parameters as asked: what is not given (none, false) takes its default,
  // so that a parameter of one method given with the other can be refused (check()). The default
  // is the safe one: the bounded mode, conservative, at E = 0.4 m (the paper's Δz): the mesh
  // never below the DSM. The paper's variants have no error bound (variant two leaves the sample
  // tile's mesh 8.4 m below the DSM): asked for by name.
  std::optional<SimplifyMethod> method;  ///< none: the bounded mode
  std::optional<double> max_error;       ///< the bounded mode's E (m); none: 0.4, conservative
  bool conservative = false;             ///< the bounded mode: 0 <= mesh - DSM <= E (implied without max_error)
  std::optional<double> dz, dco;         ///< the paper's tolerances; none: PaperSimplifyOptions' 0.4 m, 1e-5 m
  bool delaunay = false;                 ///< the bounded mode: one global Delaunay triangulation (one thread)
  int tile_size = 0;                     ///< the bounded mode: cells a tile side; 0: 24
  int block_tiles = 0;                   ///< the bounded mode: tiles a block side (read and farmed out); 0: 42
  int threads = 0;                       ///< the bounded mode: threads; 0: every core
  /// Who makes the blocks of the bounded mode when it streams (a DSM input without --res):
  /// empty = this process, on its threads; the dsmplan binary under mpirun sets MpiFarm's.
  BoundedEngine bounded_engine;
  bool tileset = false;      ///< `--3dtiles`, as MeshJobOptions::tileset
  VerticalOptions vertical;  ///< --vertical-crs, --allow-approximate-vertical (for --3dtiles)

  /// Every option, before any file is opened (simplify_job calls it first): ArgumentError for a
  /// parameter of the other method (max_error, conservative with a paper's variant; dz, dco
  /// with the bounded mode: named by its flag), an unknown output format, a resolution that is
  /// not positive, a parameter out of range, --3dtiles without a .glb.
  void check() const;
  /// The method that runs: `method`, else the bounded mode.
  SimplifyMethod chosen_method() const { return method.value_or(SimplifyMethod::Bounded); }
  /// The bounded mode's options as it runs them: max_error and conservative resolved.
  BoundedSimplifyOptions bounded_options() const;
  /// The paper's variant's options as it runs them: the variant, dz and dco resolved.
  PaperSimplifyOptions paper_options() const;
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

}  // namespace dsmplan
