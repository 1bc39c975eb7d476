// dsmplan grid: point clouds to a GeoTIFF DSM, median height per cell (Adolf & Hirschmueller,
// Section 2), holes kept unless filling is asked for; with --classes 2 (ground) a DTM.
#include <filesystem>

#include "dsmplan/point_io.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan {

void GridOptions::check() const {
  // grid's own class lists would be replaced by points_options(), not silently.
  const GridPointsOptions defaults;
  if (grid.keep_classes != defaults.keep_classes || grid.drop_classes != defaults.drop_classes)
    throw ArgumentError("grid", "its classes are set by GridOptions::classes, drop_classes and keep_all_classes");
  if (keep_all_classes && !classes.empty())
    throw ArgumentError("--classes", "keeps only the classes listed, --keep-all-classes every class: give one");
  const std::string extension = std::filesystem::path(output).extension().string();
  if (extension != ".tif" && extension != ".tiff") throw ArgumentError(output, "output must be a GeoTIFF (.tif)");
  if (!(grid.resolution > 0)) throw ArgumentError("--res", "must be a positive number of CRS units");
  if (!(fill_distance >= 0)) throw ArgumentError("--fill-holes", "must be >= 0");
  if (inputs.empty()) throw ArgumentError("POINTS", "no point cloud given");
}

GridPointsOptions GridOptions::points_options() const {
  GridPointsOptions points = grid;
  points.keep_classes = classes;
  // `classes` alone: exactly the classes listed, noise too if listed.
  if (keep_all_classes || (!classes.empty() && !drop_classes))
    points.drop_classes.clear();
  else if (drop_classes)
    points.drop_classes = *drop_classes;
  return points;
}

GridSummary grid_to_geotiff(const GridOptions& options, const Progress& progress) {
  options.check();
  check_writable(options.output);  // a missing folder is known now, not after the gridding

  std::vector<PointCloud> clouds;
  const double files = static_cast<double>(options.inputs.size());
  for (size_t i = 0; i < options.inputs.size(); ++i) {
    clouds.push_back(read_points(options.inputs[i], sub_progress(progress, 0.6 * i / files, 0.6 * (i + 1) / files)));
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
  grid_options.other_bytes += geotiff_buffer_bytes();  // the GeoTIFF writer's, while the grid lives
  if (options.fill_distance > 0) grid_options.other_bytes_per_cell += fill_holes_bytes_per_cell();
  Grid grid;
  try {
    grid = grid_points(clouds, grid_options, sub_progress(progress, 0.6, 0.8));
  } catch (const ArgumentError& error) {
    if (error.field() != "points") throw;
    // What is wrong lies in the files: name them, not a flag.
    std::string files;
    for (const std::string& input : options.inputs) files += (files.empty() ? "" : ", ") + input;
    throw InputError(files, "", error.problem());
  }
  resolve_crs(grid.crs);
  if (options.fill_distance > 0) fill_holes(grid, options.fill_distance / options.grid.resolution);
  write_geotiff(grid, options.output, sub_progress(progress, 0.8, 1.0));
  return summarize(grid);
}

Json to_json(const GridSummary& summary) {
  const auto number = [](double v) { return std::isnan(v) ? Json() : Json(v); };
  return {{"cells", summary.cells}, {"valid", summary.valid},         {"nodata", summary.nodata},
          {"holes", summary.holes}, {"z_min", number(summary.z_min)}, {"z_max", number(summary.z_max)}};
}

}  // namespace dsmplan
