// dsmplan serve: PlanService then serve_plans() (dsmplan/serve.hpp) until SIGTERM; the checks
// of the options are the library's (ServeOptions::check()).
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/serve.hpp"

namespace dsmplan::cli {

namespace {

struct ServeArguments {
  ServeOptions options;
  std::string planner = "prm", objective = "low";
};

bool loopback(const std::string& host) { return host == "127.0.0.1" || host == "localhost" || host == "::1"; }

void run_serve(ServeArguments& request, bool quiet) {
  ServeOptions& options = request.options;
  options.plan.planner = parse_planner(request.planner);
  options.plan.objective = parse_objective(request.objective);
  block_stopping_signals();  // before the index's and roadmap's threads start: serve_plans() takes them
  const PlanService service(options, terminal_progress(quiet));
  serve_plans(service, [&options](const std::string& url) {
    // The first line says where it listens (flushed: a script reading a pipe needs it now).
    if (loopback(options.host))
      std::printf("dsmplan serve: listening on %s (POST /v1/plan, GET /v1/health, GET /v1/info)\n", url.c_str());
    else
      std::printf("dsmplan serve: listening on %s, reachable from other machines (not only 127.0.0.1)%s\n", url.c_str(),
                  options.token_file.empty() ? ", without a token: anyone can ask" : "");
    std::fflush(stdout);
  });
  std::printf("dsmplan serve: stopped, the requests in flight answered\n");
}

}  // namespace

Command serve_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<ServeArguments>();
  ServeOptions& serve = request->options;
  CLI::App* command = app.add_subcommand(
      "serve", "Hold a mesh in memory and answer path requests over HTTP (POST /v1/plan) until SIGTERM");
  command->add_option("MESH", serve.mesh, "Obstacle mesh (.ply, .obj, .off) in a projected CRS")->required();
  command->add_option("--dsm", serve.dsm, "Raw DSM: every path keeps --safety from its cells as solid columns");
  command->add_option("--dtm", serve.dtm, "Terrain raster: the ground --max-agl counts from");
  command->add_option("--no-fly", serve.no_fly,
                      "No-fly zones (ED-269 JSON or GeoJSON; repeatable) every request keeps out of");
  command
      ->add_option("--no-fly-blocking", serve.no_fly_blocking,
                   "Restrictions that block (default PROHIBITED,REQ_AUTHORISATION)")
      ->delimiter(',');
  command->add_option("--no-fly-buffer", serve.plan.no_fly_buffer,
                      "Least distance from the blocking no-fly zones (m), apart from --safety; a request may ask "
                      "for more (default: --safety)");
  command->add_option("--index", serve.index, "Index file of the mesh: opened when it fits, else built and saved");
  command->add_option("--roadmap", serve.roadmap,
                      "Roadmap file of the server's options: read when it fits, else built and saved");
  command->add_option("--host", serve.host, "Address to listen on")->capture_default_str();
  command->add_option("--port", serve.port, "TCP port (0: any free one)")->capture_default_str();
  command->add_option("--threads", serve.threads, "Workers planning at once")->capture_default_str();
  command->add_option("--queue", serve.queue, "Requests waiting for a worker, at most (then 503)")
      ->capture_default_str();
  command
      ->add_option("--budget", serve.budget_seconds, "A request's time from arrival to answer, at most (s; then 504)")
      ->capture_default_str();
  command->add_option("--max-body", serve.max_body_bytes, "A request body's size, at most (bytes; then 413)")
      ->capture_default_str();
  command
      ->add_option("--request-deadline", serve.request_deadline_seconds,
                   "A request's head and body must arrive within this (s; then 408)")
      ->capture_default_str();
  command->add_option("--token-file", serve.token_file,
                      "File whose first line is the bearer token every request must send");
  command
      ->add_option("--safety", serve.plan.safety,
                   "Least distance to the obstacles (m): the default and the least a request may ask")
      ->capture_default_str();
  command
      ->add_option("--max-agl", serve.plan.max_agl,
                   "Ceiling above the ground (m): the default and the highest a request may ask")
      ->capture_default_str();
  command->add_option("--spacing", serve.plan.spacing, "Sample distance of the roadmap (m)")->capture_default_str();
  command->add_option("--max-edge", serve.plan.max_edge, "Longest roadmap edge (m)")->capture_default_str();
  command->add_option("--refine-rounds", serve.plan.refine_rounds, "Refinement rounds where the roadmap fails a leg")
      ->capture_default_str();
  command->add_option("--planner", request->planner, "The default planner: prm, rrtconnect or freespace")
      ->capture_default_str();
  command->add_option("--objective", request->objective, "The default objective of freespace: low or shortest")
      ->capture_default_str();
  command->add_option("--vertical-crs", serve.vertical.vertical_crs,
                      "Vertical CRS of the mesh's heights when the file does not say (e.g. EPSG:7837)");
  command->add_flag("--allow-approximate-vertical", serve.vertical.allow_approximate_vertical,
                    "Heights of an unknown or grid-less vertical datum taken as EGM96 heights (about 1 m off)");
  command->add_flag("-q,--quiet", session.quiet, "No progress output while loading");
  return {command, [request, &session] { run_serve(*request, session.quiet); }};
}

}  // namespace dsmplan::cli
