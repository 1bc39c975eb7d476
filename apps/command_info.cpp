// dsmplan info: describe_raster() (dsmplan/tools.hpp), printed as text or JSON.
#include <cstdio>
#include <memory>

#include "command.hpp"

namespace dsmplan::cli {

namespace {

struct InfoArguments {
  InfoOptions options;
  bool json = false;
  std::string of;
};

void run_info(const InfoArguments& request) {
  const RasterReport report = describe_raster(request.options);
  if (request.json || parse_info_format(request.of) == InfoFormat::Json)
    print_json(to_json(report));
  else
    std::fputs(to_text(report).c_str(), stdout);
}

}  // namespace

Command info_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<InfoArguments>();
  InfoOptions& info = request->options;
  CLI::App* command =
      app.add_subcommand("info", "Describe a DSM raster: size, resolution, extent, CRS, nodata, heights");
  command->add_option("DSM", info.input, "Raster file (GeoTIFF, VRT, ASCII grid, any GDAL raster)")->required();
  command->add_flag("--json", request->json, "Print JSON");
  command->add_option("--band", info.read.band, "Band to read")->capture_default_str();
  command->add_option("--crs", info.read.assign_crs, kCrsHelp);
  command->add_option("--of", request->of, "Output format: text or json (as --json)");
  command->add_flag("-q,--quiet", session.quiet, "Accepted for every command; info has no progress to silence");
  return {command, [request] { run_info(*request); }};
}

}  // namespace dsmplan::cli
