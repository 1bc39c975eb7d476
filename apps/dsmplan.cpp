// dsmplan: the command-line face of the library. It parses argv into the option structs of
// dsmplan/tools.hpp, calls the tool, and prints or writes the report; nothing else.
#include <cpl_progress.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <new>
#include <string>
#include <tuple>
#include <vector>

#include "dsmplan/export.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/mpi_farm.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/picture_job.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/satellite_stereo_job.hpp"
#include "dsmplan/stereo_job.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/view.hpp"
#include "dsmplan/wgs84.hpp"
#include "usage.hpp"

using namespace dsmplan;

namespace {

// True while a progress line is unfinished, so an error message starts on a line of its own.
bool progress_line_open = false;

// GDAL's terminal progress ("0...10...20...100 - done."), or nothing with -q.
Progress terminal_progress(bool quiet) {
  if (quiet) return {};
  return [](double fraction) {
    progress_line_open = fraction < 1;
    return GDALTermProgress(fraction, nullptr, nullptr) != 0;
  };
}

// --stats after the main output: when it cannot be written, the main output is removed too,
// so a run leaves all its files or none.
void write_stats(const std::string& stats, const Json& report, const std::vector<std::string>& outputs) {
  if (!stats.empty()) write_text_file_or_remove(stats, report.dump(2) + "\n", outputs);
}

// --3dtiles and the heights it needs, on `dsmplan mesh` and `simplify`.
void add_tileset_options(CLI::App* command, bool& tileset, VerticalOptions& vertical) {
  command->add_flag(
      "--3dtiles", tileset,
      "With a .glb: write a 3D Tiles 1.1 tileset.json beside it that places the mesh on the globe (Cesium)");
  command->add_option("--vertical-crs", vertical.vertical_crs,
                      "With --3dtiles: vertical CRS of the heights when the DSM does not say (e.g. EPSG:7837)");
  command->add_flag(
      "--allow-approximate-vertical", vertical.allow_approximate_vertical,
      "With --3dtiles: heights of an unknown or grid-less vertical datum taken as EGM96 heights (about 1 m off)");
}

// One line on stderr, on a line of its own; returns the exit code.
int fail(const std::string& message, int exit_code) {
  if (progress_line_open) std::printf("\n");
  std::fflush(stdout);
  std::fprintf(stderr, "dsmplan: %s\n", message.c_str());
  return exit_code;
}

// --crs means the same for every command.
constexpr const char* kCrsHelp =
    "CRS of the input (EPSG:n, WKT or PROJ), overriding what the file states, as gdal_translate -a_srs; "
    "needed when it states none";

// One of a flag's named values, else ArgumentError listing them.
template <typename T>
T parse_choice(const char* flag, const std::string& value, const std::vector<std::pair<std::string, T>>& choices) {
  std::string names;
  for (const auto& [name, choice] : choices) {
    if (name == value) return choice;
    names += (names.empty() ? "" : ", ") + name;
  }
  throw ArgumentError(flag, "must be one of " + names + ", got '" + value + "'");
}

// --home "a,b": two numbers, or NaN, NaN when not given.
std::array<double, 2> parse_home(const std::string& text) {
  if (text.empty()) return {NAN, NAN};
  const size_t comma = text.find(',');
  try {
    size_t used_a = 0, used_b = 0;
    if (comma == std::string::npos) throw std::invalid_argument("");
    const std::string a = text.substr(0, comma), b = text.substr(comma + 1);
    const std::array<double, 2> home{std::stod(a, &used_a), std::stod(b, &used_b)};
    if (used_a != a.size() || used_b != b.size() || !std::isfinite(home[0]) || !std::isfinite(home[1]))
      throw std::invalid_argument("");
    return home;
  } catch (const std::exception&) {
    throw ArgumentError("--home", "must be x,y in the mesh's CRS or lon,lat in degrees, got '" + text + "'");
  }
}

// A list of ASPRS classes as one word, "2,9" (an empty word: none): as one word, the list cannot
// take the point files after it for classes ("--classes 2 a.laz b.laz" kept both files).
std::vector<int> parse_classes(const char* flag, const std::string& text) {
  std::vector<int> classes;
  size_t start = 0;
  while (!text.empty() && start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    size_t used = 0;
    int value = -1;
    try {
      value = std::stoi(item, &used);
    } catch (const std::exception&) {
    }
    if (item.empty() || used != item.size() || value < 0 || value > 255)
      throw ArgumentError(flag, "takes ASPRS classes 0-255 separated by commas (e.g. 2,9), got '" + text + "'");
    classes.push_back(value);
    start = comma + 1;
  }
  return classes;
}

}  // namespace

// Rank 0 of an MPI run releases the workers however its job ends.
struct ReleaseWorkers {
  const MpiFarm& farm;
  bool armed = false;
  ~ReleaseWorkers() {
    if (armed) farm.release_workers();
  }
};

int main(int argc, char** argv) {
  remove_partial_outputs_on_signals();
  const MpiFarm farm(argc, argv);  // active only under mpirun with 2 or more ranks
  CLI::App app{"dsmplan: DSM to conservative obstacle mesh and UAV paths (Adolf & Hirschmueller)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "dsmplan " DSMPLAN_VERSION);
  bool quiet = false;

  InfoOptions info;
  bool info_json = false;
  CLI::App* info_cmd =
      app.add_subcommand("info", "Describe a DSM raster: size, resolution, extent, CRS, nodata, heights");
  info_cmd->add_option("DSM", info.input, "Raster file (GeoTIFF, VRT, ASCII grid, any GDAL raster)")->required();
  info_cmd->add_flag("--json", info_json, "Print JSON");
  info_cmd->add_option("--band", info.read.band, "Band to read")->capture_default_str();
  info_cmd->add_option("--crs", info.read.assign_crs, kCrsHelp);
  std::string info_of;
  info_cmd->add_option("--of", info_of, "Output format: text or json (as --json)");
  info_cmd->add_flag("-q,--quiet", quiet, "Accepted for every command; info has no progress to silence");

  GridOptions grid;
  std::string fusion = "median";
  std::string drop_classes_text, keep_classes_text;
  bool keep_all_classes = false;
  CLI::App* grid_cmd =
      app.add_subcommand("grid", "Grid point clouds (LAS, XYZ) into a GeoTIFF DSM, median height per cell");
  grid_cmd->add_option("POINTS", grid.inputs, "LAS or LAZ 1.0-1.4, or XYZ text files")->required();
  grid_cmd->add_option("-o,--output", grid.output, "Output GeoTIFF")->required();
  grid_cmd->add_option("--res", grid.grid.resolution, "Cell size (CRS units: m for a projected CRS in metres)")
      ->required();
  grid_cmd->add_option("--fusion", fusion, "Height per cell: median or max")->capture_default_str();
  // Lists are one comma-separated value ("--classes 2,6"): a list of separate words would take
  // the point files after it as classes ("--classes 2 a.laz b.laz").
  grid_cmd->add_option("--drop-classes", drop_classes_text,
                       "ASPRS classes to drop, comma-separated (default 7,18: noise)");
  grid_cmd->add_flag("--keep-all-classes", keep_all_classes, "Keep every class, noise included");
  grid_cmd->add_option("--classes", keep_classes_text,
                       "Keep only these ASPRS classes, comma-separated (e.g. 2: ground, a DTM; 2,9: ground and water)");
  grid_cmd->add_option("--crs", grid.crs, kCrsHelp);
  grid_cmd->add_option(
      "--fill-holes", grid.fill_distance,
      "Fill holes up to this distance (CRS units, m) from data, by GDAL's inverse-distance FillNodata");
  grid_cmd->add_flag("-q,--quiet", quiet, "No progress output");
  bool grid_json = false;
  std::string grid_of;
  grid_cmd->add_flag("--json", grid_json, "Print the DSM's counts and height range as JSON");
  grid_cmd->add_option("--of", grid_of, "Output format: gtiff (the only one)");

  StereoJobOptions stereo;
  SatelliteStereoOptions satellite;
  std::string stereo_bounds, stereo_stats;
  CLI::App* stereo_cmd = app.add_subcommand(
      "stereo",
      "DSM from images: satellite images with RPCs (IMG1 IMG2 ...) or frame cameras with known poses (--cameras): "
      "rectification, SGM, triangulation, median per cell");
  stereo_cmd->add_option("images", satellite.images,
                         "Satellite images with RPC cameras (TIFF tags, _RPC.TXT, .RPB or an OSSIM .geom beside "
                         "them), two or more: every overlapping pair is matched");
  stereo_cmd->add_option("--cameras", stereo.cameras,
                         "CAMERAS.json: CRS, cameras and images, optionally the height range (README)");
  stereo_cmd->add_option("--crs", satellite.crs,
                         "With satellite images: output CRS (default: WGS 84 / UTM of the scene; heights above the "
                         "WGS 84 ellipsoid)");
  stereo_cmd->add_flag("--allow-approximate-vertical", satellite.allow_approximate_vertical,
                       "With satellite images and a compound --crs whose geoid grid PROJ lacks: heights through "
                       "EGM96 (about 1 m off; --stats' transformation says so) instead of refusing");
  stereo_cmd->add_option("-o,--output", stereo.output, "Output GeoTIFF (Float32, nodata where nothing matched)")
      ->required();
  stereo_cmd->add_option("--res", stereo.resolution, "Cell size (CRS units: m)")->required();
  stereo_cmd->add_option("--pairs", stereo.pairs, "auto (overlap and base-to-height ratio) or pairs like 0-1,1-2")
      ->capture_default_str();
  stereo_cmd->add_option("--bounds", stereo_bounds, "x0,y0,x1,y1 of the DSM (CRS units); default: the pairs' overlap");
  stereo_cmd->add_option("--stats", stereo_stats, "Write counts and seconds per stage as JSON");
  double fusion_memory_mb = 1024;
  stereo_cmd
      ->add_option("--fusion-memory", fusion_memory_mb,
                   "MB of memory for the points before the fusion spills sorted runs to $TMPDIR (or /tmp)")
      ->capture_default_str();
  double band_memory_mb = 1024;
  stereo_cmd
      ->add_option("--band-memory", band_memory_mb,
                   "MB for one band of a frame pair's rectified images and matching (taller pairs go in bands of rows)")
      ->capture_default_str();
  stereo_cmd->add_flag("-q,--quiet", quiet, "No progress output");

  MeshJobOptions mesh;
  double mesh_resolution = 0;
  std::string resampling = "median", stats_path;
  CLI::App* mesh_cmd =
      app.add_subcommand("mesh", "Build the XY-3 Delaunay mesh of a DSM (PLY, OBJ, OFF or GLB by extension)");
  mesh_cmd->add_option("DSM", mesh.input, "Raster file")->required();
  mesh_cmd->add_option("-o,--output", mesh.output, "Mesh file: .ply (binary, double x,y,z), .obj, .off or .glb (glTF)")
      ->required();
  std::string mesh_of;
  mesh_cmd->add_option("--of", mesh_of, "Output format, overriding the extension: ply, obj, off or glb");
  CLI::Option* mesh_res = mesh_cmd->add_option("--res", mesh_resolution, "Resample to this x/y resolution (m) first");
  mesh_cmd->add_option("--resampling", resampling, "median, max (conservative), mean, min or nearest")
      ->capture_default_str();
  mesh_cmd
      ->add_option("--zstep", mesh.mesh.zstep, "Vertical resolution (m): heights are rounded to multiples (0: keep)")
      ->capture_default_str();
  mesh_cmd
      ->add_option("--max-edge", mesh.mesh.max_edge_length,
                   "Drop triangles with a longer x,y edge (m), so holes stay holes (0: 2.5 cells)")
      ->capture_default_str();
  mesh_cmd->add_flag("--stream", mesh.stream,
                     "Band by band into a .ply, whatever the raster's size (chosen by itself when it would not fit)");
  mesh_cmd->add_option("--stats", stats_path, "Write statistics as JSON to this file");
  mesh_cmd->add_option("--band", mesh.read.band, "Band to read")->capture_default_str();
  mesh_cmd->add_option("--crs", mesh.read.assign_crs, kCrsHelp);
  add_tileset_options(mesh_cmd, mesh.tileset, mesh.vertical);
  mesh_cmd->add_flag("-q,--quiet", quiet, "No progress output");
  bool mesh_json = false;
  mesh_cmd->add_flag("--json", mesh_json, "Print the statistics as JSON");

  SimplifyJobOptions simplify;
  double simplify_resolution = 0;
  std::string method = "bounded", simplify_resampling = "median", simplify_stats;
  bool simplify_json = false;
  CLI::App* simplify_cmd = app.add_subcommand(
      "simplify", "Simplify a DSM's mesh: the paper's variant one or two, or the bounded mode (--max-error)");
  simplify_cmd->add_option("INPUT", simplify.input, "DSM raster, or a mesh (.ply, .obj, .off) with --dsm")->required();
  simplify_cmd->add_option("-o,--output", simplify.output, "Mesh file: .ply, .obj, .off or .glb (glTF)")->required();
  std::string simplify_of;
  simplify_cmd->add_option("--of", simplify_of, "Output format, overriding the extension: ply, obj, off or glb");
  CLI::Option* method_option =
      simplify_cmd
          ->add_option("--method", method,
                       "bounded (certified; by default conservative at --max-error 0.4), or the paper's variant1, "
                       "variant2 (no error bound)")
          ->capture_default_str();
  CLI::Option* dz =
      simplify_cmd->add_option("--dz", simplify.paper.dz, "Paper's variants: co-planar tolerance (m, vertical)")
          ->capture_default_str();
  CLI::Option* dco = simplify_cmd->add_option("--dco", simplify.paper.dco, "Paper's variants: co-linear tolerance (m)")
                         ->capture_default_str();
  CLI::Option* max_error = simplify_cmd->add_option("--max-error", simplify.bounded.max_error,
                                                    "Bounded mode: certified |mesh - DSM| <= E (m) at every cell");
  CLI::Option* conservative =
      simplify_cmd->add_flag("--conservative", simplify.bounded.conservative,
                             "Bounded mode: the mesh never below the DSM (0 <= mesh - DSM <= E); the default unless "
                             "--max-error is given alone");
  simplify_cmd->add_flag("--delaunay", simplify.bounded.delaunay,
                         "Bounded mode: one global Delaunay triangulation (single-threaded) instead of tiles");
  simplify_cmd->add_option("--threads", simplify.bounded.threads, "Bounded mode: threads (0: every core)")
      ->capture_default_str();
  simplify_cmd->add_option("--tile-size", simplify.bounded.tile_size, "Bounded mode: cells a tile side (0: 64)")
      ->capture_default_str();
  simplify_cmd
      ->add_option("--block-tiles", simplify.bounded.block_tiles,
                   "Bounded mode: tiles a block side, the unit read and farmed out (0: 16)")
      ->capture_default_str();
  simplify_cmd->add_option("--dsm", simplify.dsm, "With a mesh input: the DSM it was made from (for the error)");
  CLI::Option* simplify_res =
      simplify_cmd->add_option("--res", simplify_resolution, "Resample the DSM to this x/y resolution (m) first");
  simplify_cmd->add_option("--resampling", simplify_resampling, "median, max, mean, min or nearest")
      ->capture_default_str();
  simplify_cmd->add_option("--zstep", simplify.mesh.zstep, "Vertical resolution of the paper's mesh (m; 0: keep)")
      ->capture_default_str();
  simplify_cmd->add_option("--stats", simplify_stats, "Write statistics as JSON to this file");
  simplify_cmd->add_flag("--json", simplify_json, "Print the statistics as JSON instead of the summary line");
  simplify_cmd->add_option("--band", simplify.read.band, "Band to read")->capture_default_str();
  simplify_cmd->add_option("--crs", simplify.read.assign_crs, kCrsHelp);
  add_tileset_options(simplify_cmd, simplify.tileset, simplify.vertical);
  simplify_cmd->add_flag("-q,--quiet", quiet, "No progress output");

  RenderJobOptions render;
  double render_resolution = 0;
  std::string window;
  bool no_edges = false;
  CLI::App* render_cmd = app.add_subcommand(
      "render", "Draw a DSM from above, hillshaded, with meshes' edges over it, side by side, as a PNG");
  render_cmd->add_option("DSM", render.dsm, "Raster file")->required();
  render_cmd->add_option("--mesh", render.meshes, "Mesh file (.ply, .obj, .off) in the DSM's CRS; one panel each");
  render_cmd->add_option("--title", render.titles, "Panel title, in --mesh order (default: the file names)");
  render_cmd->add_option("-o,--output", render.output, "Picture: .png")->required();
  render_cmd->add_option("--window", window, "Area to draw: xmin,ymin,xmax,ymax in the CRS (m) (default: all)");
  render_cmd->add_option("--zoom", render.render.pixels_per_cell, "Pixels per DSM cell")->capture_default_str();
  render_cmd->add_flag("--no-edges", no_edges, "Do not draw the meshes' edges");
  render_cmd->add_option("--path", render.paths, "Path CSV (from dsmplan plan) to draw; repeatable");
  render_cmd->add_option("--waypoints", render.waypoints, "Waypoint CSV: numbered discs");
  render_cmd->add_option("--roadmap", render.roadmap, "Roadmap file (dsmplan plan --roadmap): its edges");
  CLI::Option* render_res =
      render_cmd->add_option("--res", render_resolution, "Resample the DSM to this x/y resolution (m) first");
  render_cmd->add_option("--band", render.read.band, "Band to read")->capture_default_str();
  render_cmd->add_option("--crs", render.read.assign_crs, kCrsHelp);
  render_cmd->add_flag("-q,--quiet", quiet, "No progress output");
  bool render_json = false;
  std::string render_of;
  render_cmd->add_flag("--json", render_json, "Print the picture's size as JSON");
  render_cmd->add_option("--of", render_of, "Output format: png (the only one)");

  ProfileJobOptions profile;
  CLI::App* profile_cmd = app.add_subcommand(
      "profile", "Draw a path's height profile over the DSM below it, the terrain and the ceiling, as a PNG");
  profile_cmd->add_option("DSM", profile.dsm, "Raster file (the DSM the path was planned over)")->required();
  profile_cmd->add_option("--path", profile.path, "Path CSV (dsmplan plan -o PATH.csv): x,y,z in the DSM's CRS")
      ->required();
  profile_cmd->add_option("-o,--output", profile.output, "Picture: .png")->required();
  profile_cmd->add_option("--dtm", profile.dtm,
                          "Terrain raster (the DSM's CRS, any resolution): a line, and the ceiling's ground");
  profile_cmd->add_option("--waypoints", profile.waypoints, "Waypoint CSV: numbered markers on the path");
  profile_cmd->add_option("--safety", profile.profile.safety, "Half-height of the band around the path (m)")
      ->capture_default_str();
  profile_cmd->add_option("--max-agl", profile.profile.max_agl, "Ceiling above the ground (m; the DTM, else the DSM)")
      ->capture_default_str();
  profile_cmd->add_option("--title", profile.profile.title, "Title (default: the path's and the DSM's file names)");
  profile_cmd->add_option("--width", profile.profile.width, "Picture width, pixels")->capture_default_str();
  profile_cmd->add_option("--height", profile.profile.height, "Picture height, pixels")->capture_default_str();
  profile_cmd->add_flag("-q,--quiet", quiet, "No progress output and no summary line");
  bool profile_json = false;
  std::string profile_of;
  profile_cmd->add_flag("--json", profile_json, "Print the summary as JSON");
  profile_cmd->add_option("--of", profile_of, "Output format: png (the only one)");

  PlanJobOptions plan;
  std::string plan_stats;
  CLI::App* plan_cmd = app.add_subcommand("plan",
                                          "Plan a collision-free path through waypoints over an obstacle mesh (Halton "
                                          "PRM or RRT-Connect, shortcuts, spline)");
  plan_cmd
      ->add_option("MESH", plan.mesh,
                   "Obstacle mesh (.ply, .obj, .off) in a projected CRS, or a DSM (raster, VRT mosaic of a city): "
                   "planned along a corridor, window by window")
      ->required();
  plan_cmd->add_option("--corridor-chunk", plan.corridor.chunk, "DSM input: longest piece of a leg in one window (m)")
      ->capture_default_str();
  plan_cmd->add_option("--corridor-margin", plan.corridor.margin, "DSM input: flight area around a piece's box (m)")
      ->capture_default_str();
  plan_cmd
      ->add_option("--max-error", plan.corridor.mesh.max_error,
                   "DSM input: the windows' conservative bounded meshes' error bound (m)")
      ->capture_default_str();
  plan_cmd
      ->add_option("--waypoints", plan.waypoints,
                   "Waypoints: .csv (x,y,z in the mesh's CRS) or .geojson (WGS 84 lon, lat, ellipsoidal height)")
      ->required();
  plan_cmd
      ->add_option("-o,--output", plan.output,
                   "Path: .csv (x,y,z in the mesh's CRS), .geojson (WGS 84, ellipsoidal heights), or with heights "
                   "above mean sea level: .plan (QGroundControl), .waypoints (QGC WPL 110), .kmz (DJI WPML), .kml")
      ->required();
  plan_cmd
      ->add_option("--safety", plan.plan.safety, "Least distance to the mesh, and with --dsm to the DSM's cells (m)")
      ->capture_default_str();
  plan_cmd->add_option("--spacing", plan.plan.spacing, "Sample distance (m): samples = volume / spacing^3")
      ->capture_default_str();
  plan_cmd->add_option("--max-edge", plan.plan.max_edge, "Longest roadmap edge (m)")->capture_default_str();
  plan_cmd
      ->add_option(
          "--max-agl", plan.plan.max_agl,
          "Ceiling, metres above the ground (the DTM, else the DSM's cells, else the mesh) for every point of the path")
      ->capture_default_str();
  plan_cmd
      ->add_option("--refine-rounds", plan.plan.refine_rounds,
                   "Where the roadmap fails a leg: a lattice search, then at most this many rounds of denser "
                   "samples (0: neither)")
      ->capture_default_str();
  plan_cmd->add_option("--threads", plan.plan.threads, "Threads (0: every core)")->capture_default_str();
  std::string planner = "prm";
  // Checked below, not by CLI::IsMember: CLI11 adds a second line ("Run with --help") to its errors.
  plan_cmd->add_option("--planner", planner, "prm (Halton roadmap, A*) or rrtconnect (RRT-Connect, single query)")
      ->capture_default_str();
  int64_t seed = 1;  // signed: CLI11 would wrap -3 round to 2^64 - 3 as an unsigned
  plan_cmd->add_option("--seed", seed, "Random seed of rrtconnect (>= 0): the same seed, the same path")
      ->capture_default_str();
  plan_cmd->add_option("--of", plan.format,
                       "Path format, overriding the extension: csv, geojson, plan, waypoints, kmz, kml");
  bool plan_json = false;
  plan_cmd->add_flag("--json", plan_json, "Print the statistics as JSON instead of the summary line");
  plan_cmd->add_option("--roadmap", plan.roadmap,
                       "Roadmap file: reused when it exists (same mesh and options), else built and saved");
  plan_cmd->add_option("--index", plan.index,
                       "Index file of the mesh: opened when it exists (built from the same mesh and DSM), else built "
                       "and saved; later runs skip building it");
  plan_cmd->add_option("--dsm", plan.dsm,
                       "Raw DSM: the path keeps --safety from its cells as solid columns (holes as high as their rim)");
  plan_cmd->add_option("--dtm", plan.dtm,
                       "Terrain raster (the mesh's CRS, any resolution): the ground --max-agl counts from");
  plan_cmd->add_option("--vertical-crs", plan.vertical.vertical_crs,
                       "Vertical CRS of the mesh's heights when the file does not say (e.g. EPSG:7837; EPSG:4979: "
                       "WGS 84 ellipsoidal heights, as satellite DSMs)");
  plan_cmd->add_flag(
      "--allow-approximate-vertical", plan.vertical.allow_approximate_vertical,
      "Heights of an unknown or grid-less vertical datum taken as EGM96 heights (about 1 m off) for WGS 84 output");
  plan_cmd->add_option("--stats", plan_stats, "Write statistics as JSON to this file");
  plan_cmd->add_flag("-q,--quiet", quiet, "No progress output");
  std::string home, end, altitude_frame = "relative", firmware = "generic";
  plan_cmd->add_option("--home", home,
                       "Missions: where the drone takes off, x,y in the mesh's CRS (m) or lon,lat (degrees); "
                       "default: the ground under the first waypoint");
  plan_cmd->add_option("--end", end,
                       "Missions: rtl (a planned leg back above home, then return to launch), land "
                       "(at the last waypoint) or none; default rtl");
  plan_cmd
      ->add_option("--altitude-frame", altitude_frame,
                   "Missions: relative (m above home) or amsl (m above mean sea level)")
      ->capture_default_str();
  plan_cmd->add_option("--firmware", firmware, "Missions: px4, ardupilot or generic")->capture_default_str();
  plan_cmd->add_option("--speed", plan.mission.format.speed, "Missions: speed along the route (m/s, (0, 100])")
      ->capture_default_str();
  plan_cmd->add_flag("--extrude", plan.mission.format.extrude,
                     "KML: a wall from the path and the waypoints down to the ground");
  double hover_speed = NAN;
  plan_cmd->add_option("--hover-speed", hover_speed,
                       "Missions: the .plan's hoverSpeed (m/s, (0, 100]); default --speed");

  ViewOptions view;
  CLI::App* view_cmd = app.add_subcommand(
      "view", "Show a GLB mesh and a path in 3D in the browser: serves the three.js viewer on localhost until Ctrl-C");
  view_cmd->add_option("MESH", view.mesh, "Mesh: .glb (dsmplan mesh|simplify -o MESH.glb)")->required();
  view_cmd->add_option("--path", view.path, "Path CSV (dsmplan plan -o PATH.csv): x,y,z in the mesh's CRS");
  view_cmd->add_option("--waypoints", view.waypoints, "Waypoint CSV: x,y,z in the mesh's CRS");
  view_cmd->add_option("--port", view.port, "TCP port (0: any free one)")->capture_default_str();
  view_cmd->add_option("--host", view.host, "Address to listen on")->capture_default_str();
  view_cmd->add_option("--viewer-dir", view.viewer_dir,
                       "The viewer's files (index.html, viewer.js, node_modules/three); default: web/viewer beside "
                       "the dsmplan binary");
  bool view_json = false;
  view_cmd->add_flag("--json", view_json, "Print the viewer's address as JSON ({\"url\": ...})");
  view_cmd->add_flag("-q,--quiet", quiet, "Accepted for every command; the address is still printed");

  try {
    cli::refuse_unknown_names(app, argc, argv);
    cli::refuse_single_dash_long_options(app, argc, argv);
    app.parse(argc, argv);
    if (farm.active() && farm.rank() > 0) {  // a worker: makes blocks for rank 0, says nothing
      if (*simplify_cmd) {
        // The blocks as rank 0 asks for them: --max-error alone is not conservative (see below).
        if (max_error->count()) simplify.bounded.conservative = conservative->count() > 0;
        farm.serve(simplify);
      }
      return 0;
    }
    ReleaseWorkers release{farm, farm.active() && *simplify_cmd};
    if (*info_cmd) {
      const RasterReport report = describe_raster(info);
      if (!info_of.empty() && info_of != "json" && info_of != "text")
        throw ArgumentError("--of", "info prints text or json, got '" + info_of + "'");
      info_json = info_json || info_of == "json";
      std::fputs(info_json ? (to_json(report).dump(2) + "\n").c_str() : to_text(report).c_str(), stdout);
    }
    if (*grid_cmd) {
      grid.grid.fusion = parse_fusion(fusion);
      const std::vector<int> drop_classes = parse_classes("--drop-classes", drop_classes_text);
      grid.grid.keep_classes = parse_classes("--classes", keep_classes_text);
      if (keep_all_classes && !grid.grid.keep_classes.empty())
        throw ArgumentError("--classes", "keeps only the classes listed, --keep-all-classes every class: give one");
      if (keep_all_classes || (!grid.grid.keep_classes.empty() && drop_classes.empty())) {
        grid.grid.drop_classes.clear();  // --classes alone: exactly the classes listed, noise too if listed
      } else if (!drop_classes.empty()) {
        grid.grid.drop_classes = drop_classes;
      }
      std::vector<NamedFile> inputs;
      for (const std::string& points : grid.inputs) inputs.push_back({"POINTS", points});
      cli::check_single_format(grid_of, {"gtiff", "geotiff", "tif", "tiff"});
      refuse_overwrites(inputs, {{"-o", grid.output}});
      const GridSummary summary = grid_to_geotiff(grid, terminal_progress(quiet));
      if (grid_json) std::fputs((to_json(summary).dump(2) + "\n").c_str(), stdout);
    }
    if (*stereo_cmd) {
      if (!stereo_bounds.empty()) {
        try {
          const Window w = parse_window(stereo_bounds);
          stereo.bounds = std::array<double, 4>{w.xmin, w.ymin, w.xmax, w.ymax};
        } catch (const ArgumentError&) {
          throw ArgumentError("--bounds",
                              "expected four numbers x0,y0,x1,y1, got '" + stereo_bounds.substr(0, 80) + "'");
        }
      }
      if (stereo.cameras.empty() == satellite.images.empty())
        throw ArgumentError("--cameras",
                            "give either satellite images with RPCs (dsmplan stereo IMG1 IMG2 ...) or "
                            "--cameras CAMERAS.json for frame cameras, not both");
      for (const auto& [flag, megabytes, least] :
           {std::tuple{"--fusion-memory", fusion_memory_mb, 0.0625}, std::tuple{"--band-memory", band_memory_mb, 1.0}})
        if (!(megabytes >= least && megabytes < 1e9)) {
          char range[96];  // %g: 1e300 as typed, not as 301 digits
          std::snprintf(range, sizeof range, "must lie in [%g, 1e9) MB, got %g", least, megabytes);
          throw ArgumentError(flag, range);
        }
      stereo.band_memory_bytes = static_cast<std::size_t>(band_memory_mb * 1048576.0);
      stereo.fusion_memory_bytes = satellite.fusion_memory_bytes =
          static_cast<std::size_t>(fusion_memory_mb * 1048576.0);
      if (!stereo.cameras.empty()) {
        if (!satellite.crs.empty())
          throw ArgumentError("--crs", "belongs to satellite images; CAMERAS.json states its CRS");
        if (satellite.allow_approximate_vertical)
          throw ArgumentError("--allow-approximate-vertical", "belongs to satellite images with a compound --crs");
        refuse_overwrites(stereo_job_inputs(stereo), {{"-o", stereo.output}, {"--stats", stereo_stats}});
        if (!stereo_stats.empty()) check_writable(stereo_stats);
        const StereoReport report = stereo_job(stereo, terminal_progress(quiet));
        write_stats(stereo_stats, to_json(report), {stereo.output});
      } else {
        if (stereo.pairs != "auto")
          throw ArgumentError("--pairs", "belongs to --cameras; satellite images are paired by overlap");
        satellite.output = stereo.output;
        satellite.resolution = stereo.resolution;
        satellite.bounds = stereo.bounds;
        std::vector<NamedFile> inputs;
        for (const std::string& image : satellite.images) {
          inputs.push_back({"IMAGES", image});
          const std::string geom = std::filesystem::path(image).replace_extension(".geom").string();
          if (std::filesystem::exists(geom)) inputs.push_back({"IMAGES", geom});
        }
        refuse_overwrites(inputs, {{"-o", satellite.output}, {"--stats", stereo_stats}});
        if (!stereo_stats.empty()) check_writable(stereo_stats);
        const SatelliteStereoReport report = satellite_stereo_job(satellite, terminal_progress(quiet));
        write_stats(stereo_stats, to_json(report), {satellite.output});
      }
    }
    if (*mesh_cmd) {
      if (mesh_res->count()) mesh.resolution = mesh_resolution;
      mesh.resampling = parse_resampling(resampling);
      if (!mesh_of.empty()) mesh.format = parse_mesh_format(mesh_of, "--of");
      const std::string mesh_tileset = mesh.tileset ? tileset_path_for(mesh.output) : "";
      refuse_overwrites({{"DSM", mesh.input}},
                        {{"-o", mesh.output}, {"--stats", stats_path}, {"--3dtiles", mesh_tileset}});
      if (!stats_path.empty()) check_writable(stats_path);
      const MeshReport report = mesh_dsm(mesh, terminal_progress(quiet));
      write_stats(stats_path, to_json(report), {mesh.output, mesh_tileset});
      if (mesh_json) std::fputs((to_json(report).dump(2) + "\n").c_str(), stdout);
    }
    if (*simplify_cmd) {
      if (simplify_res->count()) simplify.resolution = simplify_resolution;
      simplify.resampling = parse_resampling(simplify_resampling);
      if (!simplify_of.empty()) simplify.format = parse_mesh_format(simplify_of, "--of");
      simplify.method = parse_simplify_method(method);
      // Without --method nor --max-error: the bounded mode, conservative, at E = 0.4 m
      // (SimplifyJobOptions). --max-error E alone keeps its meaning: |mesh - DSM| <= E.
      if (max_error->count()) {
        if (method_option->count() && simplify.method != SimplifyMethod::Bounded) {
          throw ArgumentError("--max-error", "belongs to the bounded mode, not --method " + method);
        }
        simplify.method = SimplifyMethod::Bounded;
        simplify.bounded.conservative = conservative->count() > 0;
      }
      if (simplify.method != SimplifyMethod::Bounded && conservative->count())
        throw ArgumentError("--conservative", "belongs to the bounded mode, not --method " + method);
      for (const CLI::Option* paper : {dz, dco})
        if (simplify.method == SimplifyMethod::Bounded && paper->count())
          throw ArgumentError(paper->get_name(),
                              "belongs to the paper's variants (--method variant1|variant2); the "
                              "bounded mode (the default) is bounded by --max-error");
      const std::string simplify_tileset = simplify.tileset ? tileset_path_for(simplify.output) : "";
      refuse_overwrites({{"INPUT", simplify.input}, {"--dsm", simplify.dsm}},
                        {{"-o", simplify.output}, {"--stats", simplify_stats}, {"--3dtiles", simplify_tileset}});
      if (!simplify_stats.empty()) check_writable(simplify_stats);
      if (farm.active()) simplify.bounded_engine = farm.master();
      const SimplifyReport report = simplify_job(simplify, terminal_progress(quiet));
      write_stats(simplify_stats, to_json(report), {simplify.output, simplify_tileset});
      if (simplify_json)
        std::fputs((to_json(report).dump(2) + "\n").c_str(), stdout);
      else if (!quiet)
        std::fputs(to_text(report).c_str(), stdout);
    }
    if (*render_cmd) {
      if (render_res->count()) render.resolution = render_resolution;
      if (!window.empty()) render.render.window = parse_window(window);
      render.render.edges = !no_edges;
      std::vector<NamedFile> inputs{
          {"DSM", render.dsm}, {"--waypoints", render.waypoints}, {"--roadmap", render.roadmap}};
      for (const std::string& m : render.meshes) inputs.push_back({"--mesh", m});
      for (const std::string& p : render.paths) inputs.push_back({"--path", p});
      cli::check_single_format(render_of, {"png"});
      refuse_overwrites(inputs, {{"-o", render.output}});
      const RenderReport report = render_job(render, terminal_progress(quiet));
      if (render_json) std::fputs((to_json(report).dump(2) + "\n").c_str(), stdout);
    }
    if (*profile_cmd) {
      refuse_overwrites(
          {{"DSM", profile.dsm}, {"--path", profile.path}, {"--dtm", profile.dtm}, {"--waypoints", profile.waypoints}},
          {{"-o", profile.output}});
      cli::check_single_format(profile_of, {"png"});
      const ProfileReport report = profile_job(profile, terminal_progress(quiet));
      if (profile_json)
        std::fputs((to_json(report).dump(2) + "\n").c_str(), stdout);
      else if (!quiet)
        std::fputs(to_text(report).c_str(), stdout);
    }
    if (*plan_cmd) {
      if (planner != "prm" && planner != "rrtconnect")
        throw ArgumentError("--planner", "must be prm or rrtconnect, got '" + planner + "'");
      plan.plan.planner = planner == "rrtconnect" ? PlannerKind::rrt_connect : PlannerKind::prm;
      if (seed < 0) throw ArgumentError("--seed", "must be >= 0, got " + std::to_string(seed));
      plan.plan.seed = static_cast<uint64_t>(seed);
      plan.mission.home = parse_home(home);
      if (!end.empty())
        plan.mission.end = parse_choice<MissionEnd>(
            "--end", end, {{"rtl", MissionEnd::rtl}, {"land", MissionEnd::land}, {"none", MissionEnd::none}});
      plan.mission.format.altitude_frame = parse_choice<AltitudeFrame>(
          "--altitude-frame", altitude_frame, {{"relative", AltitudeFrame::relative}, {"amsl", AltitudeFrame::amsl}});
      plan.mission.format.firmware = parse_choice<Firmware>(
          "--firmware", firmware,
          {{"px4", Firmware::px4}, {"ardupilot", Firmware::ardupilot}, {"generic", Firmware::generic}});
      plan.mission.format.hover_speed = std::isnan(hover_speed) ? plan.mission.format.speed : hover_speed;
      // The roadmap and index files are read when they exist and written when not: each may be
      // none of the others.
      refuse_overwrites(
          {{"MESH", plan.mesh}, {"--waypoints", plan.waypoints}, {"--dsm", plan.dsm}, {"--dtm", plan.dtm}},
          {{"-o", plan.output}, {"--stats", plan_stats}, {"--roadmap", plan.roadmap}, {"--index", plan.index}});
      if (!plan_stats.empty()) check_writable(plan_stats);
      const PlanReport report = plan_job(plan, terminal_progress(quiet));
      write_stats(plan_stats, to_json(report), {plan.output});
      if (plan_json)
        std::fputs((to_json(report).dump(2) + "\n").c_str(), stdout);
      else if (!quiet)
        std::fputs(to_text(report).c_str(), stdout);
    }
    if (*view_cmd) {
      serve_view(view, [view_json](const std::string& url) {
        // Flushed: a script or test reading stdout through a pipe needs the URL now.
        if (view_json)
          std::printf("%s\n", Json{{"url", url}}.dump().c_str());
        else
          std::printf("Serving the 3D viewer at %s (Ctrl-C stops)\n", url.c_str());
        std::fflush(stdout);
      });
    }
  } catch (const CLI::ParseError& error) {
    if (error.get_exit_code() == 0) return app.exit(error);  // --help, --version
    // Usage errors: one line, exit 2.
    std::string message = error.what();
    if (message.empty()) message = "the command line is incomplete (dsmplan --help)";
    return fail(message, 2);
  } catch (const ArgumentError& error) {
    return fail(cli::flag_message(error), 2);  // a bad option value: a usage error too
  } catch (const Error& error) {
    return fail(error.what(), 1);
  } catch (const std::bad_alloc&) {
    return fail("out of memory: use a coarser --res or a smaller area", 1);
  } catch (const std::exception& error) {
    return fail(std::string("internal error: ") + error.what(), 3);
  }
  return 0;
}
