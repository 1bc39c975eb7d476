// dsmplan render: render_job() (dsmplan/picture_job.hpp).
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "dsmplan/picture_job.hpp"
#include "usage.hpp"

namespace dsmplan::cli {

namespace {

struct RenderArguments {
  RenderJobOptions options;
  double resolution = 0;
  CLI::Option* res = nullptr;  // given or not: without --res the DSM keeps its own
  std::string window, of;
  bool no_edges = false, no_grid = false, json = false;
};

void run_render(RenderArguments& request, bool quiet) {
  RenderJobOptions& render = request.options;
  if (request.res->count()) render.resolution = request.resolution;
  if (!request.window.empty()) render.render.window = parse_window(request.window);
  render.render.edges = !request.no_edges;
  render.render.grid = !request.no_grid;
  std::vector<NamedFile> inputs{{"DSM", render.dsm}, {"--waypoints", render.waypoints}, {"--roadmap", render.roadmap}};
  for (const std::string& m : render.meshes) inputs.push_back({"--mesh", m});
  for (const std::string& p : render.paths) inputs.push_back({"--path", p});
  add_zone_inputs(render.no_fly, inputs);
  check_single_format(request.of, {"png"});
  refuse_overwrites(inputs, {{"-o", render.output}});
  const RenderReport report = render_job(render, terminal_progress(quiet));
  if (request.json) print_json(to_json(report));
}

}  // namespace

Command render_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<RenderArguments>();
  RenderJobOptions& render = request->options;
  CLI::App* command = app.add_subcommand(
      "render", "Draw a DSM from above, hillshaded, with meshes' edges over it, side by side, as a PNG");
  command->add_option("DSM", render.dsm, "Raster file")->required();
  command->add_option("--mesh", render.meshes, "Mesh file (.ply, .obj, .off) in the DSM's CRS; one panel each");
  command->add_option("--title", render.titles, "Panel title, in --mesh order (default: the file names)");
  command->add_option("-o,--output", render.output, "Picture: .png")->required();
  command->add_option("--window", request->window, "Area to draw: xmin,ymin,xmax,ymax in the CRS (m) (default: all)");
  command->add_option("--zoom", render.render.pixels_per_cell, "Pixels per DSM cell")->capture_default_str();
  command->add_flag("--no-edges", request->no_edges, "Do not draw the meshes' edges");
  command->add_flag("--no-grid", request->no_grid, "Do not draw the coordinate grid and its labels");
  command->add_option("--path", render.paths, "Path CSV (from dsmplan plan) to draw; repeatable");
  command->add_option("--waypoints", render.waypoints, "Waypoint CSV: numbered discs");
  command->add_option("--roadmap", render.roadmap, "Roadmap file (dsmplan plan --roadmap): its edges");
  add_zone_options(command, render.no_fly);
  request->res = command->add_option("--res", request->resolution, "Resample the DSM to this x/y resolution (m) first");
  command->add_option("--band", render.read.band, "Band to read")->capture_default_str();
  command->add_option("--crs", render.read.assign_crs, kCrsHelp);
  command->add_flag("-q,--quiet", session.quiet, "No progress output");
  command->add_flag("--json", request->json, "Print the picture's size as JSON");
  command->add_option("--of", request->of, "Output format: png (the only one)");
  return {command, [request, &session] { run_render(*request, session.quiet); }};
}

}  // namespace dsmplan::cli
