// dsmplan plan: plan_job() (dsmplan/plan_job.hpp), which checks the options and their rules; the
// choices' names are the library's (parse_planner(), ...), as Python takes them.
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include "command.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/plan_job.hpp"

namespace dsmplan::cli {

namespace {

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

struct PlanArguments {
  PlanJobOptions options;
  std::vector<std::string> outputs;  // -o, repeated: the first is options.output
  std::string stats;
  std::string planner = "prm", objective = "low";
  int64_t seed = 1;  // signed: CLI11 would wrap -3 round to 2^64 - 3 as an unsigned
  bool json = false;
  std::string home, end, altitude_frame = "relative", firmware = "generic", drone = "m3e";
  double hover_speed = NAN;
};

// --routes: many routes in one run; a route without a path is reported and exits 4.
void run_routes(const PlanArguments& request, Session& session) {
  const RoutesReport report = plan_routes_job(request.options, terminal_progress(session.quiet));
  write_stats(request.stats, to_json(report), request.outputs);
  if (request.json)
    print_json(to_json(report));
  else if (!session.quiet || !report.failed.empty())
    std::fputs(to_text(report).c_str(), stdout);
  if (!report.failed.empty()) session.exit_code = 4;
}

void run_plan(PlanArguments& request, Session& session) {
  const bool quiet = session.quiet;
  PlanJobOptions& plan = request.options;
  plan.output = request.outputs.front();
  plan.more_outputs.assign(request.outputs.begin() + 1, request.outputs.end());
  plan.plan.planner = parse_planner(request.planner);
  plan.plan.objective = parse_objective(request.objective);
  if (request.seed < 0) throw ArgumentError("--seed", "must be >= 0, got " + std::to_string(request.seed));
  plan.plan.seed = static_cast<uint64_t>(request.seed);
  plan.mission.home = parse_home(request.home);
  if (!request.end.empty()) plan.mission.end = parse_mission_end(request.end);
  plan.mission.format.altitude_frame = parse_altitude_frame(request.altitude_frame);
  plan.mission.format.firmware = parse_firmware(request.firmware);
  plan.mission.format.drone = parse_drone(request.drone);
  plan.mission.format.hover_speed = std::isnan(request.hover_speed) ? plan.mission.format.speed : request.hover_speed;
  // The roadmap and index files are read when they exist and written when not: each may be
  // none of the others.
  std::vector<NamedFile> outputs{{"--stats", request.stats},
                                 {"--roadmap", plan.roadmap},
                                 {"--index", plan.index},
                                 {"--render", plan.render},
                                 {"--profile", plan.profile}};
  for (auto it = request.outputs.rbegin(); it != request.outputs.rend(); ++it)
    outputs.insert(outputs.begin(), {"-o", *it});
  std::vector<NamedFile> inputs{{"MESH", plan.mesh},
                                {"--waypoints", plan.waypoints},
                                {"--routes", plan.routes},
                                {"--dsm", plan.dsm},
                                {"--dtm", plan.dtm}};
  for (const std::string& zones : plan.no_fly) inputs.push_back({"--no-fly", zones});
  refuse_overwrites(inputs, outputs);
  if (!request.stats.empty()) check_writable(request.stats);
  if (!plan.routes.empty()) return run_routes(request, session);
  const PlanReport report = plan_job(plan, terminal_progress(quiet));
  write_stats(request.stats, to_json(report), request.outputs);
  if (request.json)
    std::fputs((to_json(report).dump(2) + "\n").c_str(), stdout);
  else if (!quiet)
    std::fputs(to_text(report).c_str(), stdout);
}

}  // namespace

Command plan_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<PlanArguments>();
  PlanJobOptions& plan = request->options;
  CLI::App* command = app.add_subcommand("plan",
                                         "Plan a collision-free path through waypoints over an obstacle mesh (Halton "
                                         "PRM or RRT-Connect, shortcuts, spline)");
  command
      ->add_option("MESH", plan.mesh,
                   "Obstacle mesh (.ply, .obj, .off) in a projected CRS, or a DSM (raster, VRT mosaic of a city): "
                   "planned along a corridor, window by window")
      ->required();
  command->add_option("--corridor-chunk", plan.corridor.chunk, "DSM input: longest piece of a leg in one window (m)")
      ->capture_default_str();
  command->add_option("--corridor-margin", plan.corridor.margin, "DSM input: flight area around a piece's box (m)")
      ->capture_default_str();
  command
      ->add_option("--max-error", plan.corridor.mesh.max_error,
                   "DSM input: the windows' conservative bounded meshes' error bound (m)")
      ->capture_default_str();
  command->add_option("--waypoints", plan.waypoints,
                      "Waypoints: .csv (x,y,z in the mesh's CRS) or .geojson (WGS 84 lon, lat, ellipsoidal height)");
  command->add_option("--waypoint-heights", plan.waypoint_heights,
                      "crs (z in the mesh's CRS, GeoJSON's ellipsoidal heights) or agl (above the ground: the DTM, "
                      "else the DSM, else the mesh); default crs, or agl when a CSV's header is x,y,agl");
  command
      ->add_option("--snap", plan.snap,
                   "Move a refused waypoint (near the DSM's columns, under a roof, above the ceiling, in a zone) "
                   "to the nearest valid point within this many metres, straight up first (0: off, at most 50)")
      ->capture_default_str();
  command->add_option("--routes", plan.routes,
                      "Many routes instead of --waypoints, over one roadmap: .csv (route,x,y,z) or .geojson "
                      "(LineStrings with an id); -o a .geojson FeatureCollection or a folder/ (exit 4: some failed)");
  command->add_option("--route-budget", plan.route_budget,
                      "With --routes: each route's own time limit in seconds; a route past it fails (code "
                      "route_budget) and the others go on (0: none, at most 3600)");
  command
      ->add_option("-o,--output", request->outputs,
                   "Path: .csv (x,y,z in the mesh's CRS), .geojson (WGS 84, ellipsoidal heights), or with heights "
                   "above mean sea level: .plan (QGroundControl), .waypoints (QGC WPL 110), .kmz (DJI WPML), .kml; "
                   "repeat -o for several files of the same flight")
      ->required();
  command->add_option("--safety", plan.plan.safety, "Least distance to the mesh, and with --dsm to the DSM's cells (m)")
      ->capture_default_str();
  command->add_option("--spacing", plan.plan.spacing, "Sample distance (m): samples = volume / spacing^3")
      ->capture_default_str();
  command->add_option("--max-edge", plan.plan.max_edge, "Longest roadmap edge (m)")->capture_default_str();
  command
      ->add_option(
          "--max-agl", plan.plan.max_agl,
          "Ceiling, metres above the ground (the DTM, else the DSM's cells, else the mesh) for every point of the path")
      ->capture_default_str();
  command
      ->add_option("--refine-rounds", plan.plan.refine_rounds,
                   "Where the roadmap fails a leg: a lattice search, then at most this many rounds of denser "
                   "samples (0: neither)")
      ->capture_default_str();
  command->add_option("--threads", plan.plan.threads, "Threads (0: every core)")->capture_default_str();
  // Checked in run_plan(), not by CLI::IsMember: CLI11 adds a second line ("Run with --help") to its errors.
  command
      ->add_option("--planner", request->planner,
                   "prm (Halton roadmap, A*), rrtconnect (RRT-Connect, single query) or freespace (a search over the "
                   "free airspace's cells: low paths, and a proof when none exists)")
      ->capture_default_str();
  command
      ->add_option("--objective", request->objective,
                   "freespace: low (climb only where it pays) or shortest (over low roofs where shorter)")
      ->capture_default_str();
  command->add_option("--seed", request->seed, "Random seed of rrtconnect (>= 0): the same seed, the same path")
      ->capture_default_str();
  command->add_option("--render", plan.render,
                      "Picture of the flight as flown from above over the DSM (.png), with the waypoints and zones: "
                      "as `dsmplan render DSM --path` draws the written CSV (needs --dsm or a DSM input)");
  command->add_option("--profile", plan.profile,
                      "Height profile of the flight as flown (.png) over the DSM and --dtm, with --safety and "
                      "--max-agl: as `dsmplan profile` draws the written CSV (needs --dsm or a DSM input)");
  command->add_option("--of", plan.format,
                      "Path format, overriding the extension: csv, geojson, plan, waypoints, kmz, kml");
  command->add_flag("--json", request->json, "Print the statistics as JSON instead of the summary line");
  command->add_option("--roadmap", plan.roadmap,
                      "Roadmap file: reused when it exists (same mesh and options), else built and saved");
  command->add_option("--index", plan.index,
                      "Index file of the mesh: opened when it exists (built from the same mesh and DSM), else built "
                      "and saved; later runs skip building it");
  command->add_option("--dsm", plan.dsm,
                      "Raw DSM: the path keeps --safety from its cells as solid columns (holes as high as their rim)");
  command->add_option("--no-fly", plan.no_fly,
                      "No-fly zones (EUROCAE ED-269 JSON or GeoJSON; repeatable): kept out of by --safety, "
                      "AGL limits over the DTM, else the DSM");
  command
      ->add_option("--no-fly-blocking", plan.no_fly_blocking,
                   "Restrictions that block (default PROHIBITED,REQ_AUTHORISATION); the others are shown")
      ->delimiter(',');
  command->add_option("--no-fly-buffer", plan.plan.no_fly_buffer,
                      "Least distance from the blocking no-fly zones (m), apart from --safety (default: --safety)");
  command->add_option("--dtm", plan.dtm,
                      "Terrain raster (the mesh's CRS, any resolution): the ground --max-agl counts from");
  command->add_option("--vertical-crs", plan.vertical.vertical_crs,
                      "Vertical CRS of the mesh's heights when the file does not say (e.g. EPSG:7837; EPSG:4979: "
                      "WGS 84 ellipsoidal heights, as satellite DSMs)");
  command->add_flag(
      "--allow-approximate-vertical", plan.vertical.allow_approximate_vertical,
      "Heights of an unknown or grid-less vertical datum taken as EGM96 heights (about 1 m off) for WGS 84 output");
  command->add_option("--stats", request->stats, "Write statistics as JSON to this file");
  command->add_flag("-q,--quiet", session.quiet, "No progress output");
  command->add_option("--home", request->home,
                      "Missions: where the drone takes off, x,y in the mesh's CRS (m) or lon,lat (degrees); "
                      "default: the ground under the first waypoint");
  command->add_option("--end", request->end,
                      "Missions: rtl (a planned leg back above home, then return to launch), land "
                      "(at the last waypoint) or none; default rtl");
  command
      ->add_option("--altitude-frame", request->altitude_frame,
                   "Missions: relative (m above home) or amsl (m above mean sea level)")
      ->capture_default_str();
  command->add_option("--firmware", request->firmware, "Missions: px4, ardupilot or generic")->capture_default_str();
  command
      ->add_option("--drone", request->drone,
                   "DJI .kmz: the aircraft, m350, m300, m30, m30t, m3e, m3t, m3m, m3d or m3td (docs/formats.md)")
      ->capture_default_str();
  command->add_option("--speed", plan.mission.format.speed, "Missions: speed along the route (m/s, (0, 100])")
      ->capture_default_str();
  command->add_flag("--extrude", plan.mission.format.extrude,
                    "KML: a wall from the path and the waypoints down to the ground");
  command->add_option("--hover-speed", request->hover_speed,
                      "Missions: the .plan's hoverSpeed (m/s, (0, 100]); default --speed");
  return {command, [request, &session] { run_plan(*request, session); }};
}

}  // namespace dsmplan::cli
