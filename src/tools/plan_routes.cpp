// dsmplan plan --routes: many routes in one run over one mesh, the paper's multi-query planner
// (plan_routes(): one roadmap, every route a query against it), written as one GeoJSON
// FeatureCollection or a folder of files, a route without a path reported, not fatal.
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>

#include "core/stopwatch.hpp"
#include "core/text.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/waypoints.hpp"
#include "dsmplan/wgs84.hpp"
#include "tools/job_parts.hpp"
#include "tools/plan_parts.hpp"

namespace dsmplan {

namespace {

bool is_geojson_name(const std::string& path) {
  const std::string name = lower_case(path);
  const auto ends = [&](const std::string& tail) {
    return name.size() >= tail.size() && name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
  };
  return ends(".geojson") || ends(".json");
}

bool is_folder(const std::string& output) {
  std::error_code ec;
  return (!output.empty() && output.back() == '/') || std::filesystem::is_directory(output, ec);
}

void check_routes_options(const PlanJobOptions& options) {
  if (!options.waypoints.empty()) throw ArgumentError("--routes", "replaces --waypoints: give one or the other");
  if (!is_mesh_file(options.mesh))
    throw ArgumentError("--routes", "routes are planned over a mesh (" + options.mesh +
                                        " is a raster): mesh it first (dsmplan simplify --conservative) and pass "
                                        "the raster as --dsm");
  if (!options.more_outputs.empty()) throw ArgumentError("-o", "--routes writes one output: a .geojson or a folder");
  for (const auto& [flag, picture] : {std::pair{"--render", &options.render}, std::pair{"--profile", &options.profile}})
    if (!picture->empty()) throw ArgumentError(flag, "draws one flight; with --routes draw a route's file afterwards");
  if (!is_folder(options.output) && !is_geojson_name(options.output))
    throw ArgumentError("-o", "--routes writes a .geojson FeatureCollection or a folder (a name ending in '/'), got '" +
                                  options.output + "'");
  if (!options.roadmap.empty() && options.plan.planner != PlannerKind::prm)
    throw ArgumentError("--roadmap", std::string("only the prm planner keeps a roadmap; ") +
                                         planner_name(options.plan.planner) + " keeps none");
  check_plan_options(options.plan);
  check_route_budget(options.route_budget);
}

// A route's id made a file name: letters, digits, '.', '-' and '_' kept, the rest '_'.
std::string file_name_of(const std::string& id) {
  std::string name;
  for (const char c : id)
    name += std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' ? c : '_';
  return name.empty() || name[0] == '.' ? "_" + name : name;
}

// Every route's file name in a folder, before anything is planned or written: two ids that make
// one name are refused now, not after the files of the routes before them were replaced.
void check_route_files(const std::vector<Route>& routes) {
  std::map<std::string, std::string> taken;  // file name -> id
  for (const Route& route : routes)
    if (const auto [it, added] = taken.emplace(file_name_of(route.id), route.id); !added)
      throw ArgumentError("--routes", "the ids '" + it->second + "' and '" + route.id + "' make one file name");
}

// A route's RouteFailure as JSON: every key always there (null where it does not apply), the
// nearest valid point as `place` gives it (the CRS's coordinates, or WGS 84's).
Json failure_json(const RouteResult& result, const std::function<Point3(const Point3&)>& place) {
  const RouteFailure& f = result.failure;
  Json nearest = nullptr;
  if (f.nearest) {
    const Point3 p = place(*f.nearest);
    nearest = {p[0], p[1], p[2]};
  }
  return Json{{"code", f.code},
              {"waypoint", f.waypoint ? Json(*f.waypoint) : Json(nullptr)},
              {"leg", f.leg ? Json{(*f.leg)[0], (*f.leg)[1]} : Json(nullptr)},
              {"nearest_valid_point", nearest},
              {"message", result.reason()}};
}

Point3 as_is(const Point3& p) { return p; }

Json route_figures(const Route& route, const RouteResult& result,
                   const std::function<Point3(const Point3&)>& place = as_is) {
  Json p{{"id", route.id}, {"solved", result.solved}, {"waypoints", route.waypoints.size()}};
  if (!result.solved) {
    p["reason"] = result.reason();
    p["failure"] = failure_json(result, place);
    return p;
  }
  const FlightReport& r = result.plan.report;
  p["points"] = r.path_points;
  p["path_length_m"] = r.path_length_m;
  p["min_clearance_m"] = r.min_clearance_m;
  if (std::isfinite(r.min_clearance_dsm_m)) p["min_clearance_dsm_m"] = r.min_clearance_dsm_m;
  p["max_agl_m"] = r.max_agl_m;
  p["seconds_query"] = r.seconds_query;
  p["seconds_smooth"] = r.seconds_smooth;
  if (!r.snapped.empty()) p["snapped"] = snapped_json(r.snapped);
  return p;
}

// The FeatureCollection: each route's path in WGS 84 (ellipsoidal heights), its figures or reason.
// The features are made in parallel, each thread with its own transformation (PROJ's objects are
// not shared across threads; each is `wgs84`'s operation made again), and joined in the routes'
// order: the bytes Json::dump() gives of the whole document (its members in their order).
std::string routes_geojson(const std::vector<Route>& routes, const RoutesPlan& planned, const Crs& crs,
                           const Wgs84Transform& wgs84, const VerticalOptions& vertical) {
  std::vector<std::string> features(routes.size());
  tbb::enumerable_thread_specific<std::unique_ptr<Wgs84Transform>> transforms;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, routes.size(), 64), [&](const tbb::blocked_range<size_t>& range) {
    std::unique_ptr<Wgs84Transform>& mine = transforms.local();
    if (!mine) mine = std::make_unique<Wgs84Transform>(crs, HeightReference::Ellipsoid, vertical);
    for (size_t i = range.begin(); i != range.end(); ++i) {
      const RouteResult& result = planned.routes[i];
      Json geometry;  // null for a route without a path
      if (result.solved) {
        Json line = Json::array();
        for (const Point3& p : result.plan.path) {
          const Point3 g = mine->to_wgs84(p);
          line.push_back({g[0], g[1], g[2]});
        }
        geometry = {{"type", "LineString"}, {"coordinates", line}};
      }
      const Json properties = route_figures(routes[i], result, [&](const Point3& p) { return mine->to_wgs84(p); });
      features[i] = Json{{"type", "Feature"}, {"properties", properties}, {"geometry", geometry}}.dump();
    }
  });
  size_t bytes = 0;
  for (const std::string& f : features) bytes += f.size() + 1;
  std::string doc;
  doc.reserve(bytes + 1024);
  doc += "{\"type\":\"FeatureCollection\",\"crs_source\":" + Json(crs.name).dump() +
         ",\"height\":" + Json("metres above the WGS 84 ellipsoid").dump() +
         ",\"transformation\":" + Json(wgs84.description()).dump() + ",\"features\":[";
  for (size_t i = 0; i < features.size(); ++i) {
    if (i) doc += ',';
    doc += features[i];
  }
  doc += "]}\n";
  return doc;
}

// A hidden folder inside the output folder (so that renaming from it is atomic), removed with
// whatever is left in it when it goes.
class StagingFolder {
public:
  explicit StagingFolder(const std::filesystem::path& folder) {
    std::string pattern = (folder / ".routes.partial-XXXXXX").string();
    if (!::mkdtemp(pattern.data()))
      throw OutputError(folder.string(), std::string("cannot write: ") + std::strerror(errno));
    path_ = pattern;
  }
  ~StagingFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  StagingFolder(const StagingFolder&) = delete;
  StagingFolder& operator=(const StagingFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }

private:
  std::filesystem::path path_;
};

void move_into(const std::filesystem::path& from, const std::filesystem::path& to) {
  std::error_code ec;
  std::filesystem::rename(from, to, ec);
  if (ec) throw OutputError(to.string(), "cannot write: " + ec.message());
}

// One file a solved route, and routes.json with every route's figures or reason. The folder is
// replaced whole: every file is written into a staging folder first, then moved into place, the
// files of routes without a path now removed, routes.json last; the signals that end a run are
// held meanwhile (they act once the move is done). An error while writing leaves the old outputs.
void write_routes_folder(const std::vector<Route>& routes, const RoutesPlan& planned, const FlightArea& area,
                         const PlanJobOptions& options) {
  namespace fs = std::filesystem;
  const fs::path folder(options.output);
  fs::create_directories(folder);
  const std::string ext = options.format.empty() ? "csv" : lower_case(options.format);
  // The transformations once for every route (each costs PROJ's database, milliseconds).
  PlanJobOptions one = options;
  one.output = (folder / ("route." + ext)).string();
  Transforms t;
  std::string transformation;
  make_transforms(t, area.crs(), false, plan_outputs(one), options.vertical, transformation);
  const OutputKind kind = output_kind(one.output, "");
  const ZoneLayer zones{area.data().no_fly, area.data().airspace};
  const SignalsHeld held;
  const StagingFolder staging(folder);
  Json all = Json::array();
  std::vector<std::string> names;  // of the solved routes' files
  for (size_t i = 0; i < routes.size(); ++i) {
    const RouteResult& result = planned.routes[i];
    all.push_back(route_figures(routes[i], result));
    if (!result.solved) continue;
    names.push_back(file_name_of(routes[i].id) + "." + ext);  // unique: check_route_files()
    const std::string file = (staging.path() / names.back()).string();
    if (ext == "csv") {
      write_text_file(file, path_to_csv(result.plan.path));
      continue;
    }
    PlanReport report;
    write_flight_as(one, file, kind, {result.plan, result.plan.waypoints, area.crs(), zones}, t, report);
  }
  write_text_file((staging.path() / "routes.json").string(), all.dump(2) + "\n");
  for (const std::string& name : names) move_into(staging.path() / name, folder / name);
  // A route without a path now has no file: one left by an earlier run would contradict routes.json.
  for (size_t i = 0; i < routes.size(); ++i) {
    std::error_code ignored;
    if (!planned.routes[i].solved) fs::remove(folder / (file_name_of(routes[i].id) + "." + ext), ignored);
  }
  move_into(staging.path() / "routes.json", folder / "routes.json");
}

}  // namespace

RoutesReport plan_routes_job(const PlanJobOptions& options, const Progress& progress) {
  check_routes_options(options);
  Stopwatch clock;
  bool agl_column = false;
  std::vector<Route> routes = is_geojson_name(options.routes) ? read_routes_geojson(options.routes)
                                                              : read_routes_csv(options.routes, &agl_column);
  if (is_folder(options.output)) check_route_files(routes);
  ReadRequest read = read_flight_request(options, {}, sub_progress(progress, 0, 0.1));
  FlightRequest& request = read.request;
  const Crs crs = request.mesh->crs;
  if (!request.index || request.dsm) require_projected(crs, options.mesh, centre_of(*request.mesh));
  // WGS 84 only where GeoJSON is read or written: a folder of CSV needs no vertical reference.
  std::optional<Wgs84Transform> wgs84;
  if (is_geojson_name(options.routes) || !is_folder(options.output))
    wgs84.emplace(crs, HeightReference::Ellipsoid, options.vertical);
  const WaypointHeights heights = waypoint_heights_of(options.waypoint_heights, agl_column, options.routes);
  if (is_geojson_name(options.routes))
    for (Route& route : routes) from_wgs84(route.waypoints, *wgs84, heights);
  RoutesReport report;
  report.output = options.output;
  report.routes = routes.size();
  report.seconds_read = clock.lap();

  const FlightArea area(request);
  FlightQuery common;
  common.options = options.plan;
  common.heights = heights;
  common.snap = options.snap;
  common.store = file_store(options);
  if (options.format == "plan" || options.format == "waypoints" || options.format == "kmz") {
    MissionEnds ends{options.mission.home, options.mission.end, {}};
    // Every route has the one home: turned into the CRS once, by the first route that asks
    // (routes are planned in parallel, and a PROJ transformation is not shared across threads).
    auto home = std::make_shared<std::pair<std::once_flag, Point3>>();
    ends.from_lonlat = [&, home](double lon, double lat) {
      std::call_once(home->first, [&] {
        home->second = Wgs84Transform(crs, HeightReference::MeanSeaLevel, options.vertical).from_wgs84({lon, lat, 0});
      });
      return home->second;
    };
    common.mission = ends;
  }
  std::vector<std::vector<Point3>> waypoints;
  for (const Route& route : routes) waypoints.push_back(route.waypoints);
  const RoutesPlan planned =
      plan_routes(area, waypoints, common, sub_progress(progress, 0.1, 0.95), options.route_budget);
  report.seconds_index = planned.seconds_index;
  report.seconds_roadmap = planned.seconds_roadmap;
  report.seconds_plan = planned.seconds - planned.seconds_index - planned.seconds_roadmap;
  report.roadmap_nodes = planned.roadmap_nodes, report.roadmap_edges = planned.roadmap_edges;
  report.roadmap_reused = planned.roadmap_reused;
  for (size_t i = 0; i < routes.size(); ++i) {
    const RouteResult& r = planned.routes[i];
    if (r.solved) {
      ++report.solved;
      continue;
    }
    report.failed.push_back(routes[i].id + ": " + r.reason());
    Json failure = failure_json(r, as_is);
    failure["id"] = routes[i].id;
    report.failures.push_back(std::move(failure));
  }
  clock.lap();
  if (is_folder(options.output))
    write_routes_folder(routes, planned, area, options);
  else
    write_text_file(options.output, routes_geojson(routes, planned, crs, *wgs84, options.vertical));
  report.seconds_write = clock.lap();
  dsmplan::report(progress, 1);
  return report;
}

Json to_json(const RoutesReport& r) {
  const double seconds = r.seconds_roadmap + r.seconds_plan;
  return Json{{"routes", r.routes},
              {"solved", r.solved},
              {"failed", r.failed},
              {"failures", r.failures},
              {"roadmap_nodes", r.roadmap_nodes},
              {"roadmap_edges", r.roadmap_edges},
              {"roadmap_reused", r.roadmap_reused},
              {"seconds_read", r.seconds_read},
              {"seconds_index", r.seconds_index},
              {"seconds_roadmap", r.seconds_roadmap},
              {"seconds_plan", r.seconds_plan},
              {"seconds_write", r.seconds_write},
              {"routes_per_second", seconds > 0 ? double(r.routes) / seconds : 0.0}};
}

std::string to_text(const RoutesReport& r) {
  char line[400];
  std::snprintf(line, sizeof line,
                "%s: %zu of %zu routes planned; roadmap %zu nodes, %zu edges (%.2f s%s), routes %.2f s (%.0f a "
                "second)\n",
                r.output.c_str(), r.solved, r.routes, r.roadmap_nodes, r.roadmap_edges, r.seconds_roadmap,
                r.roadmap_reused ? ", reused" : "", r.seconds_plan,
                r.seconds_plan > 0 ? double(r.routes) / r.seconds_plan : 0.0);
  std::string text = line;
  for (size_t i = 0; i < r.failed.size() && i < 10; ++i) text += "no path: " + r.failed[i] + "\n";
  if (r.failed.size() > 10) text += "and " + std::to_string(r.failed.size() - 10) + " more without a path\n";
  return text;
}

}  // namespace dsmplan
