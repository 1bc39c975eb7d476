// dsmplan grid: point clouds to a GeoTIFF DSM, median height per cell (Adolf & Hirschmueller,
// Section 2), holes kept unless filling is asked for; with --classes 2 (ground) a DTM.
#include <filesystem>

#include "dsmplan/point_io.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan {

namespace {

void check_geotiff_name(const std::string& output) {
  const std::string extension = std::filesystem::path(output).extension().string();
  if (extension != ".tif" && extension != ".tiff") throw ArgumentError(output, "output must be a GeoTIFF (.tif)");
}

// Every option but the output, before any file is read.
void check_points_options(const GridOptions& options) {
  // grid's own class lists would be replaced by points_options(), not silently.
  const GridPointsOptions defaults;
  if (options.grid.keep_classes != defaults.keep_classes || options.grid.drop_classes != defaults.drop_classes)
    throw ArgumentError("grid", "its classes are set by GridOptions::classes, drop_classes and keep_all_classes");
  options.points_options();  // the class flags' rule (choose_classes())
  if (!(options.grid.resolution > 0)) throw ArgumentError("--res", "must be a positive number of CRS units");
  if (!(options.fill_distance >= 0)) throw ArgumentError("--fill-holes", "must be >= 0");
  if (options.inputs.empty()) throw ArgumentError("POINTS", "no point cloud given");
}

// Reads (progress to `read_end`) and grids (to `done`); `writer_bytes`: what the writer that
// follows will hold beside the grid, counted in grid_points()' memory refusal.
Grid read_and_grid(const GridOptions& options, double writer_bytes, double read_end, double done,
                   const Progress& progress) {
  check_points_options(options);
  std::vector<PointCloud> clouds;
  const double files = static_cast<double>(options.inputs.size());
  for (size_t i = 0; i < options.inputs.size(); ++i) {
    clouds.push_back(
        read_points(options.inputs[i], sub_progress(progress, read_end * i / files, read_end * (i + 1) / files)));
    PointCloud& cloud = clouds.back();
    if (cloud.size() == 0) throw InputError(options.inputs[i], "", "holds no points");
    if (!options.crs.empty()) {
      cloud.crs = Crs();
      cloud.crs.definition = options.crs;
    } else if (!cloud.crs.known()) {
      throw InputError(options.inputs[i], "", "has no CRS; give one with --crs (e.g. --crs EPSG:28992)");
    }
    // x, y and heights in feet would make a DSM that every later stage takes as metres.
    resolve_crs(cloud.crs);
    const std::string problem = metric_problem(cloud.crs, options.inputs[i], (cloud.min_x + cloud.max_x) / 2,
                                               (cloud.min_y + cloud.max_y) / 2, /*units_only=*/true);
    if (!problem.empty()) throw InputError(options.inputs[i], "", problem);
  }
  GridPointsOptions grid_options = options.points_options();
  grid_options.other_bytes += writer_bytes;
  if (options.fill_distance > 0) grid_options.other_bytes_per_cell += fill_holes_bytes_per_cell();
  Grid grid;
  try {
    grid = grid_points(clouds, grid_options, sub_progress(progress, read_end, done));
  } catch (const ArgumentError& error) {
    if (error.field() != "points") throw;
    // What is wrong lies in the files: name them, not a flag.
    std::string names;
    for (const std::string& input : options.inputs) names += (names.empty() ? "" : ", ") + input;
    throw InputError(names, "", error.problem());
  }
  resolve_crs(grid.crs);
  if (options.fill_distance > 0) fill_holes(grid, options.fill_distance / options.grid.resolution);
  return grid;
}

}  // namespace

void GridOptions::check() const {
  points_options();  // the class flags' rule first, as the command line always had it
  check_geotiff_name(output);
  check_points_options(*this);
}

GridPointsOptions GridOptions::points_options() const {
  GridPointsOptions points = grid;
  choose_classes(points, classes, drop_classes, keep_all_classes);
  return points;
}

Grid grid_point_files(const GridOptions& options, const Progress& progress) {
  return read_and_grid(options, 0, 0.75, 1, progress);
}

void write_dsm(const Grid& grid, const std::string& output, const Progress& progress) {
  check_geotiff_name(output);
  check_writable(output);
  // What dsmplan's own readers (read_raster()) would refuse is not written.
  if (!grid.crs.known())
    throw ArgumentError("crs", "the DSM has no CRS: dsmplan reads no raster without one (give one, e.g. EPSG:25832)");
  const std::string problem = metric_problem(grid.crs, output, (grid.x0 + grid.x1()) / 2, (grid.y0 + grid.y1()) / 2,
                                             /*units_only=*/true);
  if (!problem.empty()) throw ArgumentError("crs", problem);
  if (summarize(grid).valid == 0) throw ArgumentError("heights", "the DSM has no valid cell: nothing to write");
  write_geotiff(grid, output, progress);
}

GridSummary grid_to_geotiff(const GridOptions& options, const Progress& progress) {
  options.check();
  check_writable(options.output);  // a missing folder is known now, not after the gridding
  // The GeoTIFF writer's buffers are held while the grid lives: counted in the memory refusal.
  // grid_points() leaves no grid without a valid cell, and the files' CRSs were checked: no
  // need for write_dsm()'s checks.
  const Grid grid = read_and_grid(options, geotiff_buffer_bytes(), 0.6, 0.8, progress);
  write_geotiff(grid, options.output, sub_progress(progress, 0.8, 1.0));
  return summarize(grid);
}

Json to_json(const GridSummary& summary) {
  const auto number = [](double v) { return std::isnan(v) ? Json() : Json(v); };
  return {{"cells", summary.cells}, {"valid", summary.valid},         {"nodata", summary.nodata},
          {"holes", summary.holes}, {"z_min", number(summary.z_min)}, {"z_max", number(summary.z_max)}};
}

}  // namespace dsmplan
