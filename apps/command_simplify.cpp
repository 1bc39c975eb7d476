// dsmplan simplify: simplify_job() (dsmplan/tools.hpp); under mpirun, rank 0 runs the job and the
// other ranks make the bounded mode's blocks for it (MpiFarm).
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "dsmplan/export.hpp"

namespace dsmplan::cli {

namespace {

// What CLI11 parses into, and whether each flag with a default was given: the library tells a
// parameter given from its default (SimplifyJobOptions::check()).
struct SimplifyArguments {
  SimplifyJobOptions options;
  std::string method = "bounded", resampling = "median", stats, of;
  CLI::Option *method_given = nullptr, *max_error_given = nullptr, *dz_given = nullptr, *dco_given = nullptr,
              *res_given = nullptr;
  double max_error = 0, resolution = 0, dz = PaperSimplifyOptions().dz, dco = PaperSimplifyOptions().dco;
  bool json = false;
};

// Rank 0 of an MPI run releases the workers however its job ends.
struct ReleaseWorkers {
  const MpiFarm& farm;
  ~ReleaseWorkers() {
    if (farm.active()) farm.release_workers();
  }
};

// The numbers given, as the options hold them: none throws, so that a worker rank takes them
// too (its blocks need max_error) without refusing anything itself.
void take_given_numbers(SimplifyArguments& request) {
  SimplifyJobOptions& simplify = request.options;
  if (request.res_given->count()) simplify.resolution = request.resolution;
  if (request.max_error_given->count()) simplify.max_error = request.max_error;
  if (request.dz_given->count()) simplify.dz = request.dz;
  if (request.dco_given->count()) simplify.dco = request.dco;
}

void run_simplify(SimplifyArguments& request, const Session& session) {
  const ReleaseWorkers release{session.farm};
  take_given_numbers(request);
  SimplifyJobOptions& simplify = request.options;
  simplify.resampling = parse_resampling(request.resampling);
  if (!request.of.empty()) simplify.format = parse_mesh_format(request.of, "--of");
  if (request.method_given->count()) simplify.method = parse_simplify_method(request.method);
  const std::string tileset = simplify.tileset ? tileset_path_for(simplify.output) : "";
  refuse_overwrites({{"INPUT", simplify.input}, {"--dsm", simplify.dsm}},
                    {{"-o", simplify.output}, {"--stats", request.stats}, {"--3dtiles", tileset}});
  if (!request.stats.empty()) check_writable(request.stats);
  if (session.farm.active()) simplify.bounded_engine = session.farm.master();
  const SimplifyReport report = simplify_job(simplify, terminal_progress(session.quiet));
  write_stats(request.stats, to_json(report), {simplify.output, tileset});
  if (request.json)
    print_json(to_json(report));
  else if (!session.quiet)
    std::fputs(to_text(report).c_str(), stdout);
}

}  // namespace

Command simplify_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<SimplifyArguments>();
  SimplifyJobOptions& simplify = request->options;
  CLI::App* command = app.add_subcommand(
      "simplify", "Simplify a DSM's mesh: the paper's variant one or two, or the bounded mode (--max-error)");
  command->add_option("INPUT", simplify.input, "DSM raster, or a mesh (.ply, .obj, .off) with --dsm")->required();
  command->add_option("-o,--output", simplify.output, "Mesh file: .ply, .obj, .off or .glb (glTF)")->required();
  command->add_option("--of", request->of, "Output format, overriding the extension: ply, obj, off or glb");
  request->method_given =
      command
          ->add_option("--method", request->method,
                       "bounded (certified; by default conservative at --max-error 0.4), or the paper's variant1, "
                       "variant2 (no error bound)")
          ->capture_default_str();
  request->dz_given = command->add_option("--dz", request->dz, "Paper's variants: co-planar tolerance (m, vertical)")
                          ->capture_default_str();
  request->dco_given =
      command->add_option("--dco", request->dco, "Paper's variants: co-linear tolerance (m)")->capture_default_str();
  request->max_error_given = command->add_option("--max-error", request->max_error,
                                                 "Bounded mode: certified |mesh - DSM| <= E (m) at every cell");
  command->add_flag("--conservative", simplify.conservative,
                    "Bounded mode: the mesh never below the DSM (0 <= mesh - DSM <= E); the default unless "
                    "--max-error is given alone");
  command->add_flag("--delaunay", simplify.delaunay,
                    "Bounded mode: one global Delaunay triangulation (single-threaded) instead of tiles");
  command->add_option("--threads", simplify.threads, "Bounded mode: threads (0: every core)")->capture_default_str();
  command->add_option("--tile-size", simplify.tile_size, "Bounded mode: cells a tile side (0: 24)")
      ->capture_default_str();
  command
      ->add_option("--block-tiles", simplify.block_tiles,
                   "Bounded mode: tiles a block side, the unit read and farmed out (0: 42)")
      ->capture_default_str();
  command->add_option("--dsm", simplify.dsm, "With a mesh input: the DSM it was made from (for the error)");
  request->res_given =
      command->add_option("--res", request->resolution, "Resample the DSM to this x/y resolution (m) first");
  command->add_option("--resampling", request->resampling, "median, max, mean, min or nearest")->capture_default_str();
  command->add_option("--zstep", simplify.mesh.zstep, "Vertical resolution of the paper's mesh (m; 0: keep)")
      ->capture_default_str();
  command->add_option("--stats", request->stats, "Write statistics as JSON to this file");
  command->add_flag("--json", request->json, "Print the statistics as JSON instead of the summary line");
  command->add_option("--band", simplify.read.band, "Band to read")->capture_default_str();
  command->add_option("--crs", simplify.read.assign_crs, kCrsHelp);
  add_tileset_options(command, simplify.tileset, simplify.vertical);
  command->add_flag("-q,--quiet", session.quiet, "No progress output");
  // A worker rank makes blocks for rank 0 and says nothing.
  return {command, [request, &session] { run_simplify(*request, session); },
          [request, &session] {
            take_given_numbers(*request);
            session.farm.serve(request->options);
          }};
}

}  // namespace dsmplan::cli
