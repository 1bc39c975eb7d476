// dsmplan: the command-line face of the library. Each subcommand parses its options into the
// library's option structs and calls the library; nothing here computes anything itself.
#include <cpl_progress.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dsmplan/export.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"

using namespace dsmplan;
using json = nlohmann::ordered_json;

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

class Stopwatch {
public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return seconds;
  }

private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// Heights are stored as float32: show them as the shortest decimal of that float (109.18, not
// 109.18000030517578).
double as_stored(double height) {
  char text[32];
  auto [end, ec] = std::to_chars(text, text + sizeof text, static_cast<float>(height));
  *end = '\0';
  return std::strtod(text, nullptr);
}

json crs_json(const Crs& crs) {
  json out;
  out["name"] = crs.name.empty() ? json(nullptr) : json(crs.name);
  out["epsg"] = crs.epsg ? json(crs.epsg) : json(nullptr);
  out["wkt"] = crs.wkt.empty() ? json(nullptr) : json(crs.wkt);
  return out;
}

json vertical_json(const Crs& crs) {
  return {{"name", crs.vertical_name.empty() ? json(nullptr) : json(crs.vertical_name)},
          {"unit", crs.vertical_unit.empty() ? json(nullptr) : json(crs.vertical_unit)}};
}

// ---- info ---------------------------------------------------------------------------------

struct InfoOptions {
  std::string input;
  ReadRasterOptions read;
  bool as_json = false;
};

void run_info(const InfoOptions& options) {
  ReadRasterOptions read = options.read;
  read.allow_no_crs = true;  // info describes what is there, CRS or not
  const Grid grid = read_raster(options.input, read);
  const GridSummary summary = summarize(grid);
  json out;
  out["file"] = options.input;
  out["width"] = grid.width;
  out["height"] = grid.height;
  out["resolution"] = {grid.cell_x, grid.cell_y};
  out["extent"] = {{"xmin", grid.x0}, {"ymin", grid.y1()}, {"xmax", grid.x1()}, {"ymax", grid.y0}};
  out["crs"] = crs_json(grid.crs);
  out["vertical"] = vertical_json(grid.crs);
  out["cells"] = summary.cells;
  out["valid_cells"] = summary.valid;
  out["nodata_cells"] = summary.nodata;
  out["holes"] = summary.holes;
  out["height_range"] = {as_stored(summary.z_min), as_stored(summary.z_max)};
  if (options.as_json) {
    std::cout << out.dump(2) << "\n";
    return;
  }
  std::printf("File:        %s\n", options.input.c_str());
  std::printf("Size:        %d x %d cells\n", grid.width, grid.height);
  std::printf("Resolution:  %.10g x %.10g\n", grid.cell_x, grid.cell_y);
  std::printf("Extent:      x %.10g .. %.10g, y %.10g .. %.10g\n", grid.x0, grid.x1(), grid.y1(), grid.y0);
  std::printf("CRS:         %s", grid.crs.name.empty() ? "none" : grid.crs.name.c_str());
  if (grid.crs.epsg) std::printf(" (EPSG:%d)", grid.crs.epsg);
  std::printf("\nVertical:    %s%s\n",
              grid.crs.vertical_name.empty() ? "datum unknown" : grid.crs.vertical_name.c_str(),
              grid.crs.vertical_unit.empty() ? ", unit unknown" : (", unit " + grid.crs.vertical_unit).c_str());
  std::printf("Nodata:      %zu of %zu cells (%zu holes)\n", summary.nodata, summary.cells, summary.holes);
  std::printf("Heights:     %.10g .. %.10g\n", as_stored(summary.z_min), as_stored(summary.z_max));
}

// ---- grid ---------------------------------------------------------------------------------

struct GridCommandOptions {
  std::vector<std::string> inputs;
  std::string output;
  std::string crs;
  std::string fusion = "median";
  GridPointsOptions grid;
  double fill_distance = 0;
  bool quiet = false;
};

void run_grid(GridCommandOptions options) {
  if (std::filesystem::path(options.output).extension() != ".tif" &&
      std::filesystem::path(options.output).extension() != ".tiff") {
    throw ArgumentError(options.output, "output must be a GeoTIFF (.tif)");
  }
  if (options.fusion != "median" && options.fusion != "max") {
    throw ArgumentError("--fusion", "unknown rule '" + options.fusion + "' (use median or max)");
  }
  options.grid.fusion = options.fusion == "max" ? Fusion::Max : Fusion::Median;
  if (!(options.grid.resolution > 0)) throw ArgumentError("--res", "must be a positive number of CRS units");
  if (options.fill_distance < 0) throw ArgumentError("--fill-holes", "must be >= 0");

  const Progress progress = terminal_progress(options.quiet);
  std::vector<PointCloud> clouds;
  for (size_t i = 0; i < options.inputs.size(); ++i) {
    const double begin = 0.6 * i / options.inputs.size(), end = 0.6 * (i + 1) / options.inputs.size();
    clouds.push_back(read_points(options.inputs[i], sub_progress(progress, begin, end)));
    PointCloud& cloud = clouds.back();
    if (cloud.size() == 0) throw InputError(options.inputs[i], "", "holds no points");
    if (!options.crs.empty()) {
      cloud.crs = Crs();
      cloud.crs.definition = options.crs;
    } else if (!cloud.crs.known()) {
      throw InputError(options.inputs[i], "", "has no CRS; give one with --crs (e.g. --crs EPSG:28992)");
    }
  }
  Grid grid = grid_points(clouds, options.grid, sub_progress(progress, 0.6, 0.8));
  resolve_crs(grid.crs);
  if (options.fill_distance > 0) fill_holes(grid, options.fill_distance / options.grid.resolution);
  write_geotiff(grid, options.output, sub_progress(progress, 0.8, 1.0));
}

// ---- mesh ---------------------------------------------------------------------------------

struct MeshCommandOptions {
  std::string input, output, stats;
  ReadRasterOptions read;
  double resolution = 0;  // not given (0): keep the DSM's
  std::string resampling = "median";
  bool resolution_given = false;
  MeshOptions mesh;
  bool quiet = false;
};

void run_mesh(const MeshCommandOptions& options) {
  // Check everything that can be checked before the long work starts.
  const MeshFormat format = mesh_format_for(options.output);
  const Resampling resampling = parse_resampling(options.resampling);
  if (options.resolution_given && !(options.resolution > 0 && std::isfinite(options.resolution))) {
    throw ArgumentError("--res", "must be a positive number of CRS units");
  }
  const Progress progress = terminal_progress(options.quiet);
  Stopwatch clock;
  json seconds;
  Grid dsm = read_raster(options.input, options.read, sub_progress(progress, 0, 0.3));
  if (dsm.crs.geographic) {
    // Delaunay on degrees, heights in metres: neither the mesh nor a safety distance means anything.
    throw InputError(options.input, "",
                     "CRS '" + dsm.crs.name +
                         "' is geographic (degrees); reproject to a projected CRS in metres first, "
                         "e.g. gdalwarp -t_srs EPSG:25832");
  }
  seconds["read"] = clock.lap();
  const double source_resolution = dsm.cell_x;
  const bool resampled =
      options.resolution_given && (options.resolution != dsm.cell_x || options.resolution != dsm.cell_y);
  if (resampled) dsm = resample(dsm, options.resolution, resampling, sub_progress(progress, 0.3, 0.4));
  seconds["resample"] = clock.lap();
  const Mesh mesh = triangulate_xy3(dsm, options.mesh, sub_progress(progress, 0.4, 0.7));
  seconds["triangulate"] = clock.lap();
  write_mesh(mesh, options.output, format, sub_progress(progress, 0.7, 1.0));
  seconds["write"] = clock.lap();
  double total = 0;
  for (const auto& [stage, value] : seconds.items()) total += value.get<double>();
  seconds["total"] = total;
  if (options.stats.empty()) return;

  const GridSummary summary = summarize(dsm);
  json stats;
  stats["input"] = options.input;
  stats["output"] = options.output;
  stats["vertices"] = mesh.vertices.size();
  stats["faces"] = mesh.triangles.size();
  stats["cells"] = summary.cells;
  stats["valid_cells"] = summary.valid;
  stats["nodata_cells"] = summary.nodata;
  stats["holes"] = summary.holes;
  stats["width"] = dsm.width;
  stats["height"] = dsm.height;
  stats["source_resolution"] = source_resolution;
  stats["resolution"] = dsm.cell_x;
  stats["resampling"] = resampled ? to_string(resampling) : "none";
  stats["zstep"] = options.mesh.zstep;
  stats["max_edge_length"] = max_edge_length(dsm, options.mesh);
  stats["file_bytes"] = std::filesystem::file_size(options.output);
  stats["crs"] = crs_json(mesh.crs);
  stats["vertical"] = vertical_json(mesh.crs);
  stats["seconds"] = seconds;
  write_text_file(options.stats, stats.dump(2) + "\n");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dsmplan: DSM to conservative obstacle mesh and UAV paths (Adolf & Hirschmueller)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "dsmplan " DSMPLAN_VERSION);

  InfoOptions info;
  CLI::App* info_cmd =
      app.add_subcommand("info", "Describe a DSM raster: size, resolution, extent, CRS, nodata, heights");
  info_cmd->add_option("DSM", info.input, "Raster file (GeoTIFF, VRT, ASCII grid, any GDAL raster)")->required();
  info_cmd->add_flag("--json", info.as_json, "Print JSON");
  info_cmd->add_option("--band", info.read.band, "Band to read")->capture_default_str();
  info_cmd->add_option("--crs", info.read.assign_crs,
                       "CRS to assume when the raster has none (EPSG:n, WKT, PROJ string)");

  GridCommandOptions grid;
  std::vector<int> drop_classes;
  bool keep_all_classes = false;
  CLI::App* grid_cmd =
      app.add_subcommand("grid", "Grid point clouds (LAS, XYZ) into a GeoTIFF DSM, median height per cell");
  grid_cmd->add_option("POINTS", grid.inputs, "LAS 1.0-1.4 (uncompressed) or XYZ text files")->required();
  grid_cmd->add_option("-o,--output", grid.output, "Output GeoTIFF")->required();
  grid_cmd->add_option("--res", grid.grid.resolution, "Cell size in CRS units")->required();
  grid_cmd->add_option("--fusion", grid.fusion, "Height per cell: median or max")->capture_default_str();
  grid_cmd->add_option("--drop-classes", drop_classes, "ASPRS classes to drop (default 7 18: noise)")->delimiter(',');
  grid_cmd->add_flag("--keep-all-classes", keep_all_classes, "Keep every class, noise included");
  grid_cmd->add_option("--crs", grid.crs, "CRS of the points (overrides the files'; needed when they have none)");
  grid_cmd->add_option("--fill-holes", grid.fill_distance,
                       "Fill holes up to this distance (CRS units) from data, by GDAL's inverse-distance FillNodata");
  grid_cmd->add_flag("-q,--quiet", grid.quiet, "No progress output");

  MeshCommandOptions mesh;
  CLI::App* mesh_cmd =
      app.add_subcommand("mesh", "Build the XY-3 Delaunay mesh of a DSM (PLY, OBJ or OFF by extension)");
  mesh_cmd->add_option("DSM", mesh.input, "Raster file")->required();
  mesh_cmd->add_option("-o,--output", mesh.output, "Mesh file: .ply (binary, double x,y,z), .obj or .off")->required();
  CLI::Option* mesh_res =
      mesh_cmd->add_option("--res", mesh.resolution, "Resample to this x/y resolution (CRS units) first");
  mesh_cmd->add_option("--resampling", mesh.resampling, "median, max (conservative), mean, min or nearest")
      ->capture_default_str();
  mesh_cmd->add_option("--zstep", mesh.mesh.zstep, "Vertical resolution: heights are rounded to multiples (0: keep)")
      ->capture_default_str();
  mesh_cmd
      ->add_option("--max-edge", mesh.mesh.max_edge_length,
                   "Drop triangles with a longer x,y edge, so holes stay holes (0: 2.5 cells)")
      ->capture_default_str();
  mesh_cmd->add_option("--stats", mesh.stats, "Write statistics as JSON to this file");
  mesh_cmd->add_option("--band", mesh.read.band, "Band to read")->capture_default_str();
  mesh_cmd->add_option("--crs", mesh.read.assign_crs, "CRS to assume when the raster has none");
  mesh_cmd->add_flag("-q,--quiet", mesh.quiet, "No progress output");

  try {
    app.parse(argc, argv);
    mesh.resolution_given = mesh_res->count() > 0;
    if (keep_all_classes)
      grid.grid.drop_classes.clear();
    else if (!drop_classes.empty())
      grid.grid.drop_classes = drop_classes;
    if (*info_cmd) run_info(info);
    if (*grid_cmd) run_grid(grid);
    if (*mesh_cmd) run_mesh(mesh);
  } catch (const CLI::ParseError& error) {
    return app.exit(error);
  } catch (const Error& error) {
    if (progress_line_open) std::printf("\n");
    std::fflush(stdout);
    std::fprintf(stderr, "dsmplan: %s\n", error.what());
    return 1;
  } catch (const std::exception& error) {
    if (progress_line_open) std::printf("\n");
    std::fflush(stdout);
    std::fprintf(stderr, "dsmplan: internal error: %s\n", error.what());
    return 3;
  }
  return 0;
}
