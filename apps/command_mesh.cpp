// dsmplan mesh: mesh_dsm() (dsmplan/tools.hpp).
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "dsmplan/export.hpp"

namespace dsmplan::cli {

namespace {

struct MeshArguments {
  MeshJobOptions options;
  double resolution = 0;
  CLI::Option* res = nullptr;  // given or not: without --res the DSM keeps its own
  std::string resampling = "median", stats, of;
  bool json = false;
};

void run_mesh(MeshArguments& request, bool quiet) {
  MeshJobOptions& mesh = request.options;
  if (request.res->count()) mesh.resolution = request.resolution;
  mesh.resampling = parse_resampling(request.resampling);
  if (!request.of.empty()) mesh.format = parse_mesh_format(request.of, "--of");
  const std::string tileset = mesh.tileset ? tileset_path_for(mesh.output) : "";
  refuse_overwrites({{"DSM", mesh.input}}, {{"-o", mesh.output}, {"--stats", request.stats}, {"--3dtiles", tileset}});
  if (!request.stats.empty()) check_writable(request.stats);
  const MeshReport report = mesh_dsm(mesh, terminal_progress(quiet));
  write_stats(request.stats, to_json(report), {mesh.output, tileset});
  if (request.json) print_json(to_json(report));
}

}  // namespace

Command mesh_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<MeshArguments>();
  MeshJobOptions& mesh = request->options;
  CLI::App* command =
      app.add_subcommand("mesh", "Build the XY-3 Delaunay mesh of a DSM (PLY, OBJ, OFF or GLB by extension)");
  command->add_option("DSM", mesh.input, "Raster file")->required();
  command->add_option("-o,--output", mesh.output, "Mesh file: .ply (binary, double x,y,z), .obj, .off or .glb (glTF)")
      ->required();
  command->add_option("--of", request->of, "Output format, overriding the extension: ply, obj, off or glb");
  request->res = command->add_option("--res", request->resolution, "Resample to this x/y resolution (m) first");
  command->add_option("--resampling", request->resampling, "median, max (conservative), mean, min or nearest")
      ->capture_default_str();
  command->add_option("--zstep", mesh.mesh.zstep, "Vertical resolution (m): heights are rounded to multiples (0: keep)")
      ->capture_default_str();
  command
      ->add_option("--max-edge", mesh.mesh.max_edge_length,
                   "Drop triangles with a longer x,y edge (m), so holes stay holes (0: 2.5 cells)")
      ->capture_default_str();
  command->add_flag("--stream", mesh.stream,
                    "Band by band into a .ply, whatever the raster's size (chosen by itself when it would not fit)");
  command->add_option("--stats", request->stats, "Write statistics as JSON to this file");
  command->add_option("--band", mesh.read.band, "Band to read")->capture_default_str();
  command->add_option("--crs", mesh.read.assign_crs, kCrsHelp);
  add_tileset_options(command, mesh.tileset, mesh.vertical);
  command->add_flag("-q,--quiet", session.quiet, "No progress output");
  command->add_flag("--json", request->json, "Print the statistics as JSON");
  return {command, [request, &session] { run_mesh(*request, session.quiet); }};
}

}  // namespace dsmplan::cli
