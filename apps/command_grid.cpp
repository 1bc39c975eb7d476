// dsmplan grid: grid_to_geotiff() (dsmplan/tools.hpp).
#include <algorithm>
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "usage.hpp"

namespace dsmplan::cli {

namespace {

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

struct GridArguments {
  GridOptions options;
  std::string fusion = "median", drop_classes, classes, of;
  bool json = false;
};

// The class lists as the library takes them: an empty --drop-classes word is the default.
void run_grid(GridArguments& request, bool quiet) {
  GridOptions& grid = request.options;
  grid.grid.fusion = parse_fusion(request.fusion);
  const std::vector<int> drop_classes = parse_classes("--drop-classes", request.drop_classes);
  grid.classes = parse_classes("--classes", request.classes);
  if (!drop_classes.empty()) grid.drop_classes = drop_classes;
  std::vector<NamedFile> inputs;
  for (const std::string& points : grid.inputs) inputs.push_back({"POINTS", points});
  check_single_format(request.of, {"gtiff", "geotiff", "tif", "tiff"});
  refuse_overwrites(inputs, {{"-o", grid.output}});
  const GridSummary summary = grid_to_geotiff(grid, terminal_progress(quiet));
  if (request.json) print_json(to_json(summary));
}

}  // namespace

Command grid_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<GridArguments>();
  GridOptions& grid = request->options;
  CLI::App* command =
      app.add_subcommand("grid", "Grid point clouds (LAS, XYZ) into a GeoTIFF DSM, median height per cell");
  command->add_option("POINTS", grid.inputs, "LAS or LAZ 1.0-1.4, or XYZ text files")->required();
  command->add_option("-o,--output", grid.output, "Output GeoTIFF")->required();
  command->add_option("--res", grid.grid.resolution, "Cell size (CRS units: m for a projected CRS in metres)")
      ->required();
  command->add_option("--fusion", request->fusion, "Height per cell: median or max")->capture_default_str();
  // Lists are one comma-separated value ("--classes 2,6"): a list of separate words would take
  // the point files after it as classes ("--classes 2 a.laz b.laz").
  command->add_option("--drop-classes", request->drop_classes,
                      "ASPRS classes to drop, comma-separated (default 7,18: noise)");
  command->add_flag("--keep-all-classes", grid.keep_all_classes, "Keep every class, noise included");
  command->add_option("--classes", request->classes,
                      "Keep only these ASPRS classes, comma-separated (e.g. 2: ground, a DTM; 2,9: ground and water)");
  command->add_option("--crs", grid.crs, kCrsHelp);
  command->add_option("--fill-holes", grid.fill_distance,
                      "Fill holes up to this distance (CRS units, m) from data, by GDAL's inverse-distance FillNodata");
  command->add_flag("-q,--quiet", session.quiet, "No progress output");
  command->add_flag("--json", request->json, "Print the DSM's counts and height range as JSON");
  command->add_option("--of", request->of, "Output format: gtiff (the only one)");

  return {command, [request, &session] { run_grid(*request, session.quiet); }};
}

}  // namespace dsmplan::cli
