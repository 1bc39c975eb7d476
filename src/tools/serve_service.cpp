// dsmplan serve: the planning service without its transport. The data are read, checked and
// prepared once (FlightArea), the roadmap of the server's options built once; each request is
// read into the `dsmplan plan` run it stands for and answered with the bytes that run writes
// (plan_parts.hpp: the same functions).
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "dsmplan/roadmap_file.hpp"
#include "dsmplan/serve.hpp"
#include "dsmplan/tools.hpp"
#include "tools/job_parts.hpp"
#include "tools/plan_parts.hpp"
#include "tools/serve_parts.hpp"

namespace dsmplan {

namespace fs = std::filesystem;

class PlanService::Worker {
public:
  Transforms transforms;  // PROJ contexts: one thread's
};

struct PlanService::State {
  ServeOptions options;
  std::unique_ptr<FlightArea> area;
  ZoneLayer zones;                // the area's zones as a KML answer draws them, made once
  mutable RoadmapShelf shelf{4};  // the server's roadmap, and four for requests with another safety or ceiling
  Json loaded;                    // what /v1/info says was loaded
  std::string vertical_geojson, vertical_msl;  // the transformations' names, or why there is none
  // What a request without "format" gets: GeoJSON when its heights above the ellipsoid are
  // known, else the CSV in the mesh's CRS, which needs no vertical reference.
  std::string default_format = "geojson";
};

namespace {

std::string dump(const Json& json) { return json.dump(-1, ' ', false, Json::error_handler_t::replace); }

// A file as messages name it to a client: its name without the server's folders.
std::string shown_name(const std::string& path) { return path.empty() ? path : fs::path(path).filename().string(); }

std::string base64(const std::string& bytes) {
  static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t n = uint32_t(uint8_t(bytes[i])) << 16 |
                       (i + 1 < bytes.size() ? uint32_t(uint8_t(bytes[i + 1])) << 8 : 0) |
                       (i + 2 < bytes.size() ? uint32_t(uint8_t(bytes[i + 2])) : 0);
    out += digits[n >> 18 & 63];
    out += digits[n >> 12 & 63];
    out += i + 1 < bytes.size() ? digits[n >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? digits[n & 63] : '=';
  }
  return out;
}

// A .kmz is a ZIP written through GDAL to a file: written to a temporary file of the server's
// own naming, read back, removed.
std::string kmz_bytes(const PlanJobOptions& job, const OutputKind& kind, const FlightOutput& out, const Transforms& t,
                      PlanReport& report) {
  static std::atomic<uint64_t> counter{0};
  const fs::path file = fs::temp_directory_path() /
                        ("dsmplan_serve_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + ".kmz");
  struct Remove {
    fs::path file;
    ~Remove() {
      std::error_code ignored;
      fs::remove(file, ignored);
    }
  } remove{file};
  // A message names the file by what the client asked for, never the server's temporary path.
  const auto named = [&](const std::string& text) {
    std::string shown = text;
    for (size_t at; (at = shown.find(file.string())) != std::string::npos;)
      shown.replace(at, file.string().size(), "path.kmz");
    return shown;
  };
  try {
    write_flight_as(job, file.string(), kind, out, t, report);
  } catch (const Cancelled&) {
    throw;
  } catch (const ArgumentError& e) {
    throw ArgumentError(e.field(), named(e.problem()));
  } catch (const InputError& e) {
    throw InputError("", "", named(e.what()));
  } catch (const Error& e) {
    throw OutputError("", named(e.what()));
  }
  std::ifstream in(file, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return std::move(bytes).str();
}

// The name of a transformation to WGS 84, or why there is none; `made` says which.
std::string transformation_name(const Crs& crs, HeightReference target, const VerticalOptions& vertical,
                                bool* made = nullptr) {
  try {
    std::string name = Wgs84Transform(crs, target, vertical).description();
    if (made) *made = true;
    return name;
  } catch (const Error& e) {
    if (made) *made = false;
    return std::string("unavailable: ") + e.what();
  }
}

// The data made a FlightArea, its index built, and the roadmap of the server's own options
// (prm) read from options.roadmap when that fits, else built (and written there).
void prepare(PlanService::State& state, FlightData data, const Progress& progress) {
  const ServeOptions& options = state.options;
  state.area = std::make_unique<FlightArea>(std::move(data));
  const FlightArea& area = *state.area;
  state.zones = {area.data().no_fly, area.data().airspace};
  report(progress, 0.4);
  (void)area.index();  // built now, not by the first request
  report(progress, 0.7);
  bool ellipsoid_known = false;
  state.vertical_geojson =
      transformation_name(area.crs(), HeightReference::Ellipsoid, options.vertical, &ellipsoid_known);
  state.vertical_msl = transformation_name(area.crs(), HeightReference::MeanSeaLevel, options.vertical);
  if (!ellipsoid_known) state.default_format = "csv";
  if (options.plan.planner != PlannerKind::prm) return;
  const PlanOptions plan = area.planner_options(options.plan);
  const uint64_t key = area.roadmap_key();  // as plan_flight() asks FlightStore::kept_roadmap
  std::shared_ptr<const Roadmap> map;
  bool from_file = false;
  if (!options.roadmap.empty()) {
    require_input_file(options.roadmap);
    if (std::ifstream(options.roadmap).good()) {
      map = std::make_shared<const Roadmap>(read_roadmap(options.roadmap, key, plan));
      from_file = true;
    }
  }
  if (!map) {
    map = std::make_shared<const Roadmap>(build_roadmap(area.index(), plan, sub_progress(progress, 0.7, 1)));
    if (!options.roadmap.empty()) write_roadmap(options.roadmap, *map, key, plan);
  }
  state.loaded["roadmap"] = {{"nodes", map->nodes.size()},
                             {"edges", map->edges()},
                             {"file", shown_name(options.roadmap)},
                             {"reused", from_file}};
  state.shelf.pin(key, plan, std::move(map));
}

// The answer to a request read: the flight planned over the area and written as `dsmplan plan`
// writes it.
std::string plan_answer(const PlanService::State& state, PlanRequest& request, Transforms& t, const Progress& progress,
                        std::shared_ptr<const StopToken> stop) {
  const FlightArea& area = *state.area;
  const Crs& crs = area.crs();
  const Outputs outputs = plan_outputs(request.job);
  Stopwatch clock;
  PlanReport report;
  try {
    make_transforms(t, crs, request.geojson, outputs, request.job.vertical, report.transformation);
  } catch (const ArgumentError& e) {
    // The server's data lack what the request's heights need: the request is well-formed (422).
    if (e.field() != "vertical_crs") throw;
    throw DataFault(request.geojson ? "waypoints" : "format",
                    "'" + (request.geojson ? std::string("geojson") : request.job.format) +
                        "' needs heights the server cannot give: " + e.problem() +
                        " (the server's option; csv needs none)");
  }
  const WaypointHeights heights = request.job.waypoint_heights.empty()
                                      ? WaypointHeights::crs
                                      : parse_waypoint_heights(request.job.waypoint_heights);
  if (request.geojson) from_wgs84(request.waypoints, *t.wgs84, heights);
  FlightQuery query;
  query.waypoints = request.waypoints;
  query.options = request.job.plan;
  query.options.stop = std::move(stop);
  query.heights = heights;
  query.snap = request.job.snap;
  if (outputs.mission) {
    query.mission = MissionEnds{request.job.mission.home, request.job.mission.end, {}};
    query.mission->from_lonlat = [&t](double lon, double lat) { return t.to_msl->from_wgs84({lon, lat, 0}); };
  }
  // RRT-Connect grows its trees per query; a store would have the PRM's roadmap built for it.
  if (query.options.planner == PlannerKind::prm) query.store = state.shelf.store();
  const double before = clock.lap();
  FlightPlan flight = plan_flight(area, query, progress);
  flight.report.seconds_load += before;
  static_cast<FlightReport&>(report) = flight.report;
  const OutputKind& kind = outputs.files.front().second;
  const FlightOutput out{flight, flight.waypoints, crs, state.zones};
  const std::string bytes =
      kind.ext == "kmz" ? kmz_bytes(request.job, kind, out, t, report) : flight_text(request.job, kind, out, t, report);
  Json answer{{"format", kind.ext},
              {kind.ext == "kmz" ? "path_base64" : "path", kind.ext == "kmz" ? base64(bytes) : bytes}};
  if (request.stats) answer["stats"] = to_json(report);
  return dump(answer);
}

}  // namespace

std::string error_body(const std::string& message) { return dump(Json{{"error", message}}); }

std::string budget_message(double budget_seconds, const std::string& stage) {
  return "past the request's time budget of " + short_number(budget_seconds) + " s (--budget)" +
         (stage.empty() ? "" : ", stopped while " + stage);
}

PlanService::PlanService(const ServeOptions& options, const Progress& progress) : state_(std::make_unique<State>()) {
  options.check();
  state_->options = options;
  if (!is_mesh_file(options.mesh))
    throw ArgumentError("MESH",
                        "serve holds a mesh (.ply, .obj, .off); mesh a DSM first with dsmplan mesh or simplify");
  PlanJobOptions job;
  job.mesh = options.mesh, job.dsm = options.dsm, job.dtm = options.dtm, job.index = options.index;
  job.plan = options.plan;
  job.no_fly = options.no_fly, job.no_fly_blocking = options.no_fly_blocking, job.vertical = options.vertical;
  ReadRequest read = read_flight_request(job, {}, sub_progress(progress, 0, 0.3));
  const FlightRequest& request = read.request;
  if (!request.index || request.dsm) require_projected(request.mesh->crs, options.mesh, centre_of(*request.mesh));
  FlightData data = request;
  data.names = {shown_name(options.mesh), "waypoints", shown_name(options.dsm), shown_name(options.dtm)};
  for (AirspaceZone& zone : data.no_fly) zone.source_file = shown_name(zone.source_file);  // no server paths
  state_->loaded = {{"mesh", shown_name(options.mesh)},
                    {"dsm", shown_name(options.dsm)},
                    {"dtm", shown_name(options.dtm)},
                    {"index_file", shown_name(options.index)},
                    {"index_reused", request.index != nullptr},
                    {"seconds_read", read.seconds},
                    {"no_fly", options.no_fly},
                    {"no_fly_zones", request.no_fly.size()}};
  prepare(*state_, std::move(data), progress);
}

PlanService::PlanService(const ServeOptions& options, FlightData data) : state_(std::make_unique<State>()) {
  state_->options = options;
  state_->loaded = {{"mesh", data.names.mesh}};
  data.keep_index = nullptr;  // nothing is written
  prepare(*state_, std::move(data), {});
}

PlanService::~PlanService() = default;

std::shared_ptr<PlanService::Worker> PlanService::worker() const { return std::make_shared<Worker>(); }

const ServeOptions& PlanService::options() const { return state_->options; }

PlanService::Answer PlanService::plan(const std::string& body, Worker& worker, const Progress& progress,
                                      std::shared_ptr<const StopToken> stop) const {
  try {
    PlanRequest request = in_stage("reading the request",
                                   [&] { return parse_plan_request(body, state_->options, state_->default_format); });
    return {200, plan_answer(*state_, request, worker.transforms, progress, std::move(stop))};
  } catch (const Cancelled& cancelled) {
    return {504, error_body(budget_message(state_->options.budget_seconds, cancelled.stage()))};
  } catch (const ArgumentError& e) {
    const std::string key = request_key(e.field());
    return {400, error_body(key.empty() ? e.problem() : key + ": " + e.problem())};
  } catch (const DataFault& e) {  // a well-formed value the data refuse: a home under a roof
    const std::string key = request_key(e.field());
    return {422, error_body(key.empty() ? e.problem() : key + ": " + e.problem())};
  } catch (const InputError& e) {
    return {422, error_body(e.what())};  // waypoints that cannot be flown, a leg without a path
  } catch (const std::bad_alloc&) {
    return {503, error_body("out of memory: try again later")};
  } catch (const std::exception& e) {
    return {500, error_body(std::string("internal error: ") + e.what())};
  }
}

std::string PlanService::info() const {
  const State& s = *state_;
  const FlightArea& area = *s.area;
  const ClearanceIndex::Footprint& box = area.index().footprint();
  const ServeOptions& o = s.options;
  Json limits{{"safety_min_m", o.plan.safety},
              {"max_agl_max_m", o.plan.max_agl},
              {"spacing_m", o.plan.spacing},
              {"max_edge_m", o.plan.max_edge},
              {"refine_rounds", o.plan.refine_rounds},
              {"planner", planner_name(o.plan.planner)},
              {"formats", {"geojson", "csv", "kml", "plan", "waypoints", "kmz"}},
              {"default_format", s.default_format},
              {"max_body_bytes", o.max_body_bytes},
              {"budget_seconds", o.budget_seconds},
              {"threads", o.threads},
              {"queue", o.queue}};
  Json info{{"crs", {{"name", area.crs().name}, {"epsg", area.crs().epsg}}},
            {"extent", {box.xmin, box.ymin, box.xmax, box.ymax}},
            {"height_range", {area.index().lowest_vertex(), area.index().highest_vertex()}},
            {"vertical",
             {{"name", area.crs().vertical_name},
              {"to_wgs84_ellipsoid", s.vertical_geojson},
              {"to_mean_sea_level", s.vertical_msl}}},
            {"ground", area.ground_name()},
            {"loaded", s.loaded},
            {"limits", limits}};
  return dump(info);
}

}  // namespace dsmplan
