// dsmplan plan: a collision-free path through waypoints over an obstacle mesh, by the paper's
// planner (Adolf & Hirschmueller, Section 5: a Halton PRM with a 2 m safety distance), with the
// path's clearance measured afresh on the written points.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>

#include "core/mapped_file.hpp"
#include "core/stopwatch.hpp"
#include "core/text.hpp"
#include "dsmplan/airspace_io.hpp"
#include "dsmplan/columns.hpp"
#include "dsmplan/corridor.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/flight.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/point_io.hpp"
#include "dsmplan/roadmap_file.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/wgs84.hpp"
#include "dsmplan/wpml.hpp"
#include "tools/job_parts.hpp"
#include "tools/plan_parts.hpp"
#include "tools/report_json.hpp"

namespace dsmplan {

namespace {

std::string lower_extension(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  const size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  return lower_case(path.substr(dot + 1));
}

bool is_geojson(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == "geojson" || ext == "json";
}

}  // namespace

WaypointHeights parse_waypoint_heights(const std::string& name) {
  require_choice("waypoint_heights", name, {"crs", "agl"});
  return name == "agl" ? WaypointHeights::agl : WaypointHeights::crs;
}

WaypointHeights waypoint_heights_of(const std::string& option, bool agl_column, const std::string& file) {
  if (option.empty()) return agl_column ? WaypointHeights::agl : WaypointHeights::crs;
  const WaypointHeights heights = parse_waypoint_heights(option);
  if (agl_column && heights == WaypointHeights::crs)
    throw ArgumentError("waypoint_heights", "is crs, but the header of " + file +
                                                " names its height column agl (heights above the ground)");
  return heights;
}

std::vector<Point3> read_job_waypoints(const PlanJobOptions& options, WaypointHeights& heights) {
  bool agl_column = false;
  std::vector<Point3> waypoints = is_geojson(options.waypoints) ? read_waypoints_geojson(options.waypoints)
                                                                : read_waypoints_csv(options.waypoints, &agl_column);
  heights = waypoint_heights_of(options.waypoint_heights, agl_column, options.waypoints);
  return waypoints;
}

void from_wgs84(std::vector<Point3>& waypoints, const Wgs84Transform& wgs84, WaypointHeights heights) {
  for (Point3& p : waypoints) {
    if (heights == WaypointHeights::crs) {
      p = wgs84.from_wgs84(p);
      continue;
    }
    // Above the ground: only the position is WGS 84's; the height stays the pilot's.
    const Point3 at = wgs84.from_wgs84({p[0], p[1], 0});
    p = {at[0], at[1], p[2]};
  }
}

OutputKind output_kind(const std::string& output, const std::string& format) {
  OutputKind kind;
  kind.ext = lower_case(format.empty() ? lower_extension(output) : format);
  if (kind.ext == "json") kind.ext = "geojson";
  kind.geojson = kind.ext == "geojson";
  kind.mission = kind.ext == "plan" || kind.ext == "waypoints" || kind.ext == "kmz";
  kind.msl = kind.mission || kind.ext == "kml";
  if (!format.empty() && kind.ext != "csv" && !kind.geojson && !kind.msl)
    require_choice("--of", format, {"csv", "geojson", "plan", "waypoints", "kmz", "kml"});
  if (kind.ext != "csv" && !kind.geojson && !kind.msl)
    throw ArgumentError("-o",
                        "the path is written as .csv (x,y,z in the mesh's CRS), .geojson (WGS 84), .plan "
                        "(QGroundControl), .waypoints (QGC WPL 110), .kmz (DJI WPML) or .kml, got '" +
                            output + "'");
  return kind;
}

Outputs plan_outputs(const PlanJobOptions& options) {
  Outputs out;
  if (!options.format.empty() && !options.more_outputs.empty())
    throw ArgumentError("--of", "names the format of one output; with several -o, each says its own by its extension");
  out.files.push_back({options.output, output_kind(options.output, options.format)});
  for (const std::string& more : options.more_outputs) out.files.push_back({more, output_kind(more, "")});
  for (const auto& [file, kind] : out.files)
    out.mission |= kind.mission, out.geojson |= kind.geojson, out.msl |= kind.msl, out.kml |= kind.ext == "kml";
  const std::string& first = out.files.front().second.ext;
  const MissionJobOptions& mission = options.mission;
  if (!out.mission && (!std::isnan(mission.home[0]) || !std::isnan(mission.home[1])))
    throw ArgumentError("--home", "applies to missions (.plan, .waypoints, .kmz), not to a ." + first + " path");
  if (mission.format.extrude && !out.kml)
    throw ArgumentError("--extrude", "applies to .kml paths, not to a ." + first + " path");
  if (!out.mission && mission.end)
    throw ArgumentError("--end", "applies to missions (.plan, .waypoints, .kmz), not to a ." + first + " path");
  if (out.mission)
    for (const auto& [flag, speed] :
         {std::pair{"--speed", mission.format.speed}, std::pair{"--hover-speed", mission.format.hover_speed}})
      if (!(speed > 0 && speed <= 100))
        throw ArgumentError(flag, "must lie in (0, 100] m/s, got " + two_decimals(speed));
  return out;
}

namespace {

// The index kept in `path` when it exists and was built from `input_hash`; std::nullopt when the
// file is missing or stale (then built and written anew); InputError when it is no index file or
// is damaged, so a file the user named by mistake is never overwritten.
std::optional<ClearanceIndex> open_kept_index(const std::string& path, uint64_t input_hash,
                                              ClearanceIndex::Source* source) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::nullopt;
  return ClearanceIndex::open(path, input_hash, {}, source);
}

}  // namespace

void make_transforms(Transforms& t, const Crs& crs, bool geo_in, const Outputs& outputs,
                     const VerticalOptions& vertical, std::string& description) {
  if (geo_in || outputs.geojson) {
    if (!t.wgs84) t.wgs84.emplace(crs, HeightReference::Ellipsoid, vertical);
    description = t.wgs84->description();
  }
  if (outputs.msl) {
    if (!t.to_msl) t.to_msl.emplace(crs, HeightReference::MeanSeaLevel, vertical);
    description += (description.empty() ? "" : "; path by: ") + t.to_msl->description();
  }
}

namespace {

MissionEnds mission_ends(const MissionJobOptions& options, const Transforms& t) {
  MissionEnds ends{options.home, options.end, {}};
  ends.from_lonlat = [&t](double lon, double lat) { return t.to_msl->from_wgs84({lon, lat, 0}); };
  return ends;
}

// The no-fly zones' files, in the mesh's CRS, and which restrictions block.
void read_no_fly(const PlanJobOptions& options, const Crs& crs, FlightData& data) {
  if (!options.no_fly_blocking.empty()) data.airspace.blocking = options.no_fly_blocking;
  check_airspace_options(data.airspace);  // before the files are read: a typo is the first thing said
  for (const std::string& file : options.no_fly) {
    std::vector<AirspaceZone> zones = read_airspace(file, crs, options.vertical);
    data.no_fly.insert(data.no_fly.end(), zones.begin(), zones.end());
  }
}

// The flight planned, in the CRS of its data, and what its pictures draw beside it.
struct Planned {
  FlightPlan flight;
  Crs crs;
  PictureData pictures;
};

// A DSM (raster, VRT mosaic) instead of a mesh: planned along a corridor, window by window.
Planned plan_along_corridor(const PlanJobOptions& options, const Outputs& outputs, bool geo_in, WaypointHeights heights,
                            std::vector<Point3>& waypoints, Transforms& t, PlanReport& report,
                            const Progress& progress) {
  Stopwatch clock;
  std::unique_ptr<GridSource> city = open_raster(options.mesh);
  Planned planned;
  planned.crs = city->frame().crs;
  require_projected(planned.crs, options.mesh, centre_of(city->frame()));
  make_transforms(t, planned.crs, geo_in, outputs, options.vertical, report.transformation);
  if (geo_in) from_wgs84(waypoints, *t.wgs84, heights);
  CorridorRequest request;
  request.waypoints = waypoints;
  request.heights = heights;
  request.snap = options.snap;
  request.options = options.plan;
  if (outputs.mission) request.mission = mission_ends(options.mission, t);
  if (!options.dtm.empty()) request.dtm = std::make_shared<const Grid>(read_raster(options.dtm));
  request.corridor = options.corridor;
  request.names = {options.mesh, options.waypoints, options.mesh, options.dtm};
  FlightData zones;
  read_no_fly(options, planned.crs, zones);
  request.no_fly = zones.no_fly;
  request.airspace = zones.airspace;
  planned.pictures = {options.mesh, nullptr, request.dtm, {zones.no_fly, zones.airspace}};
  const double opened = clock.lap();
  planned.flight = plan_flight_along(*city, request, progress);
  planned.flight.report.seconds_load += opened;
  waypoints = planned.flight.waypoints;  // in the CRS: what the outputs mark
  return planned;
}

}  // namespace

ReadRequest read_flight_request(const PlanJobOptions& options, std::vector<Point3> waypoints,
                                const Progress& progress) {
  Stopwatch clock;
  ReadRequest read;
  FlightRequest& request = read.request;
  request.names = {options.mesh, options.waypoints, options.dsm, options.dtm};
  request.waypoints = std::move(waypoints);
  request.options = options.plan;
  const auto open_kept = [&](uint64_t key) {
    ClearanceIndex::Source source;
    if (auto kept = open_kept_index(options.index, key, &source)) {
      request.index = std::make_shared<const ClearanceIndex>(std::move(*kept));
      request.index_fingerprint = source.mesh_fingerprint;
    }
  };
  uint64_t mesh_file_hash = 0;
  if (!options.index.empty()) {
    mesh_file_hash = file_content_hash(options.mesh);
    if (options.dsm.empty()) open_kept(mesh_file_hash);
  }
  auto mesh = std::make_shared<Mesh>();
  if (request.index) {
    mesh->crs = read_mesh_crs(options.mesh);
  } else {
    *mesh = read_mesh(options.mesh, sub_progress(progress, 0, 0.2));
    if (mesh->triangles.empty()) throw InputError(options.mesh, "", "the mesh has no triangles");
  }
  request.mesh = mesh;
  if (!options.dsm.empty()) request.dsm = std::make_shared<const Grid>(read_raster(options.dsm));
  if (!options.dtm.empty()) request.dtm = std::make_shared<const Grid>(read_raster(options.dtm));
  read_no_fly(options, mesh->crs, request);
  read.index_key = obstacle_key(mesh_file_hash, request.dsm.get());
  if (!options.index.empty() && request.dsm) open_kept(read.index_key);
  if (!options.index.empty())  // written as soon as it is built
    request.keep_index = [path = options.index, key = read.index_key](const ClearanceIndex& index,
                                                                      uint64_t fingerprint) {
      index.save(path, {key, fingerprint});
    };
  read.seconds = clock.lap();
  return read;
}

// The kept roadmap: read when its file exists (and fits this mesh, ground and options), else
// built and written there.
FlightStore file_store(const PlanJobOptions& options) {
  FlightStore store;
  if (options.roadmap.empty()) return store;
  store.kept_roadmap = [path = options.roadmap](uint64_t key,
                                                const PlanOptions& plan) -> std::shared_ptr<const Roadmap> {
    require_input_file(path);  // before asking whether it can be opened: a FIFO would wait
    if (!std::ifstream(path).good()) return nullptr;
    return std::make_shared<const Roadmap>(read_roadmap(path, key, plan));
  };
  store.keep_roadmap = [path = options.roadmap](const Roadmap& map, uint64_t key, const PlanOptions& plan) {
    write_roadmap(path, map, key, plan);
  };
  return store;
}

std::string flight_text(const PlanJobOptions& options, const OutputKind& kind, const FlightOutput& out,
                        const Transforms& t, PlanReport& report) {
  const FlightPlan& flight = out.flight;
  const Crs& crs = out.crs;
  // A mission is its items; every other format shows the flight as flown, home legs included.
  const std::vector<Point3> path = kind.mission ? flight.path : flown_path(flight);
  if (kind.ext == "csv") return path_to_csv(path);
  if (kind.geojson) {
    std::vector<Point3> lonlath;
    lonlath.reserve(path.size());
    for (const Point3& p : path) lonlath.push_back(t.wgs84->to_wgs84(p));
    Json properties{{"crs_source", crs.name},
                    {"transformation", report.transformation},
                    {"height", "metres above the WGS 84 ellipsoid"},
                    {"safety_m", options.plan.safety},
                    {"path_length_m", report.path_length_m},
                    {"min_clearance_m", report.min_clearance_m}};
    if (!report.snapped.empty()) properties["snapped"] = snapped_json(report.snapped);
    return path_to_geojson(lonlath, properties.dump());
  }
  std::vector<Point3> lonlatamsl, marks;
  for (const Point3& p : path) lonlatamsl.push_back(t.to_msl->to_wgs84(p));
  if (!kind.mission) {
    for (const Point3& p : out.waypoints) marks.push_back(t.to_msl->to_wgs84(p));
    MissionOptions kml = options.mission.format;
    kml.description =
        "dsmplan path from " + crs.name + "; heights above mean sea level (EGM96) by: " + t.to_msl->description();
    // The zones it was planned around, drawn with it (kml_zones.cpp).
    return path_to_kml(lonlatamsl, marks, kml, kml_zones_of(out.zones, *t.to_msl));
  }
  Mission mission = flight_mission(flight, lonlatamsl, t, report);
  if (kind.ext != "plan") return mission_to_qgc_wpl(mission, options.mission.format);
  // The zones it was planned around, as far as a flat geofence holds them (fence_zones.cpp).
  KeepOut fence = keep_out_areas(out.zones, flown_path(flight), *t.to_msl);
  mission.keep_out = std::move(fence.areas);
  report.geofence_zones = fence.zones;
  report.geofence_left_out = std::move(fence.left_out);
  return mission_to_qgc_plan(mission, options.mission.format);
}

Mission flight_mission(const FlightPlan& flight, const std::vector<Point3>& lonlatamsl, const Transforms& t,
                       PlanReport& report) {
  const MissionSite& site = *flight.site;
  Mission mission;
  mission.home = t.to_msl->to_wgs84(site.home);
  mission.route = lonlatamsl;
  mission.route.front() = t.to_msl->to_wgs84(site.takeoff_top);  // exactly above home
  mission.end = site.end;
  if (site.end == MissionEnd::land) mission.land = t.to_msl->to_wgs84(site.land);
  report.mission_items = 2 + (mission.route.size() - 1) + (site.end == MissionEnd::none ? 0 : 1);
  return mission;
}

void write_flight_as(const PlanJobOptions& options, const std::string& output, const OutputKind& kind,
                     const FlightOutput& out, const Transforms& t, PlanReport& report) {
  if (kind.ext != "kmz") return write_text_file(output, flight_text(options, kind, out, t, report));
  std::vector<Point3> lonlatamsl;
  for (const Point3& p : out.flight.path) lonlatamsl.push_back(t.to_msl->to_wgs84(p));
  write_wpml_kmz(flight_mission(out.flight, lonlatamsl, t, report), options.mission.format, output);
}

namespace {

// A mesh (with the DSM's columns, the terrain and a kept index and roadmap when given).
Planned plan_over_mesh(const PlanJobOptions& options, const Outputs& outputs, bool geo_in, WaypointHeights heights,
                       std::vector<Point3>& waypoints, Transforms& t, PlanReport& report, const Progress& progress) {
  Stopwatch clock;
  ReadRequest read = read_flight_request(options, waypoints, progress);
  FlightRequest& request = read.request;
  Planned planned;
  planned.crs = request.mesh->crs;
  // A kept index was saved only after this very mesh passed the check (its CRS comments are in
  // the bytes that name the index): not asked again, which would cost PROJ's database (5-7 ms).
  if (!request.index || request.dsm) require_projected(planned.crs, options.mesh, centre_of(*request.mesh));
  make_transforms(t, planned.crs, geo_in, outputs, options.vertical, report.transformation);
  request.heights = heights;
  request.snap = options.snap;
  if (geo_in) from_wgs84(request.waypoints, *t.wgs84, heights);
  if (outputs.mission) request.mission = mission_ends(options.mission, t);
  request.store = file_store(options);
  planned.pictures = {options.dsm, request.dsm, request.dtm, {request.no_fly, request.airspace}};
  const double before = clock.lap();
  planned.flight = plan_flight(request, sub_progress(progress, 0.2, 0.95));
  waypoints = planned.flight.waypoints;  // in the CRS, snapped: what the outputs mark
  planned.flight.report.seconds_load += before;
  planned.flight.report.seconds_read += read.seconds;
  return planned;
}

}  // namespace

PlanReport plan_job(const PlanJobOptions& options, const Progress& progress) {
  if (options.waypoints.empty())
    throw ArgumentError("--waypoints", "is required: the waypoints to fly through (or --routes, many routes)");
  if (!options.routes.empty()) throw ArgumentError("--routes", "is planned by plan_routes_job(), not plan_job()");
  if (options.route_budget != 0) throw ArgumentError("--route-budget", "is a time limit of each of --routes");
  const Outputs outputs = plan_outputs(options);
  check_plan_options(options.plan);
  for (const auto& [output, kind] : outputs.files)
    check_writable(output);  // a missing folder is known now, not after the planning
  if (!options.roadmap.empty() && options.plan.planner != PlannerKind::prm)
    throw ArgumentError("--roadmap", std::string("only the prm planner keeps a roadmap; ") +
                                         planner_name(options.plan.planner) + " keeps none");
  // A DSM (raster, VRT mosaic) instead of a mesh: planned along a corridor, window by window.
  const bool corridor = !is_mesh_file(options.mesh);
  if (corridor && !options.index.empty())
    throw ArgumentError("--index", "a DSM input is planned window by window along a corridor; no index is kept");
  if (corridor && !options.roadmap.empty())
    throw ArgumentError("--roadmap", "a DSM input is planned window by window along a corridor; no roadmap is kept");
  if (corridor && !options.dsm.empty())
    throw ArgumentError("--dsm", "the input " + options.mesh + " is the DSM already; its columns are checked");
  check_flight_pictures(options, corridor);
  PlanReport report;
  const bool geo_in = is_geojson(options.waypoints);
  WaypointHeights heights = WaypointHeights::crs;
  std::vector<Point3> waypoints = read_job_waypoints(options, heights);
  if (waypoints.size() < 2)
    throw InputError(options.waypoints, "",
                     "a path needs at least two waypoints, the file has " + std::to_string(waypoints.size()));

  Transforms t;
  const Planned planned = corridor
                              ? plan_along_corridor(options, outputs, geo_in, heights, waypoints, t, report, progress)
                              : plan_over_mesh(options, outputs, geo_in, heights, waypoints, t, report, progress);
  const FlightPlan& flight = planned.flight;
  static_cast<FlightReport&>(report) = flight.report;
  report.mesh = options.mesh;
  report.waypoints = options.waypoints;
  report.output = options.output;
  const FlightPictures pictures =
      draw_flight_pictures(options, flight, waypoints, planned.pictures, sub_progress(progress, 0.95, 0.99));
  for (const auto& [output, kind] : outputs.files)
    write_flight_as(options, output, kind, {flight, waypoints, planned.crs, planned.pictures.zones}, t, report);
  write_flight_pictures(options, pictures);
  report.render = pictures.render_report;
  report.profile = pictures.profile_report;
  dsmplan::report(progress, 1);
  return report;
}

namespace {

// One of a field's named values, else ArgumentError listing them (require_choice(): with the
// nearest name when the value looks like a typo).
template <typename T>
T parse_choice(const char* field, const std::string& value, const std::vector<std::pair<std::string, T>>& choices) {
  std::vector<std::string> names;
  for (const auto& [name, choice] : choices) {
    if (name == value) return choice;
    names.push_back(name);
  }
  require_choice(field, value, names);
  return choices.front().second;  // not reached: require_choice() threw
}

}  // namespace

Objective parse_objective(const std::string& name) {
  return parse_choice<Objective>(
      "objective", name,
      {{objective_name(Objective::low), Objective::low}, {objective_name(Objective::shortest), Objective::shortest}});
}

PlannerKind parse_planner(const std::string& name) {
  return parse_choice<PlannerKind>("planner", name,
                                   {{planner_name(PlannerKind::prm), PlannerKind::prm},
                                    {planner_name(PlannerKind::rrt_connect), PlannerKind::rrt_connect},
                                    {planner_name(PlannerKind::free_space), PlannerKind::free_space}});
}

MissionEnd parse_mission_end(const std::string& name) {
  return parse_choice<MissionEnd>("end", name,
                                  {{"rtl", MissionEnd::rtl}, {"land", MissionEnd::land}, {"none", MissionEnd::none}});
}

Firmware parse_firmware(const std::string& name) {
  return parse_choice<Firmware>(
      "firmware", name, {{"px4", Firmware::px4}, {"ardupilot", Firmware::ardupilot}, {"generic", Firmware::generic}});
}

std::string parse_drone(const std::string& name) {
  std::vector<std::pair<std::string, std::string>> choices;
  for (const DjiDrone& d : dji_drones()) choices.push_back({d.name, d.name});
  return parse_choice<std::string>("drone", name, choices);
}

AltitudeFrame parse_altitude_frame(const std::string& name) {
  return parse_choice<AltitudeFrame>("altitude_frame", name,
                                     {{"relative", AltitudeFrame::relative}, {"amsl", AltitudeFrame::amsl}});
}

void write_flight(const FlightPlan& flight, const std::vector<Point3>& waypoints, const Crs& crs,
                  const ZoneLayer& zones, const PlanJobOptions& options, PlanReport& report) {
  const Outputs outputs = plan_outputs(options);
  for (const auto& [output, kind] : outputs.files) {
    if (kind.mission && !flight.site)
      throw ArgumentError(
          "mission", "a ." + kind.ext + " file is a mission: plan the flight as one (a home and an end) to write it");
    check_writable(output);
  }
  Transforms t;
  make_transforms(t, crs, false, outputs, options.vertical, report.transformation);
  for (const auto& [output, kind] : outputs.files)
    write_flight_as(options, output, kind, {flight, waypoints, crs, zones}, t, report);
}

Json snapped_json(const std::vector<FlightReport::Snap>& snapped) {
  Json moves = Json::array();
  for (const FlightReport::Snap& s : snapped)
    moves.push_back({{"waypoint", s.waypoint},
                     {"place", s.place},
                     {"from", {s.from[0], s.from[1], s.from[2]}},
                     {"to", {s.to[0], s.to[1], s.to[2]}},
                     {"distance_m", s.distance_m},
                     {"reason", s.reason}});
  return moves;
}

Json to_json(const PlanReport& r) {
  Json j;
  j["path_length_m"] = r.path_length_m;
  j["min_clearance_m"] = r.min_clearance_m;
  j["roadmap_nodes"] = r.roadmap_nodes;
  j["roadmap_edges"] = r.roadmap_edges;
  j["seconds_load"] = r.seconds_load;
  if (r.corridor_windows == 0) {  // a corridor reads and meshes its windows as it plans
    j["seconds_read"] = r.seconds_read;
    j["seconds_index"] = r.seconds_load - r.seconds_read;
  }
  j["seconds_roadmap"] = r.seconds_roadmap;
  j["seconds_query"] = r.seconds_query;
  j["seconds_smooth"] = r.seconds_smooth;
  if (!std::isnan(r.min_clearance_dsm_m)) {
    j["min_clearance_dsm_m"] = r.min_clearance_dsm_m;
    j["dsm_tolerance_m"] = r.dsm_tolerance_m;
    j["mesh_max_below_dsm_m"] = r.mesh_max_below_dsm_m;
    j["column_max_above_mesh_m"] = r.column_max_above_mesh_m;
    j["safety_margin_m"] = r.safety_margin_m;
  }
  j["max_agl_m"] = r.max_agl_m;
  j["ground"] = r.ground;
  j["roadmap_reused"] = r.roadmap_reused;
  j["index_reused"] = r.index_reused;
  j["refined_samples"] = r.refined_samples;
  j["planner"] = r.planner;
  if (!r.transformation.empty()) j["transformation"] = r.transformation;
  if (r.mission_items) {
    j["mission_items"] = r.mission_items;
    j["home"] = {r.home[0], r.home[1], r.home[2]};
    j["home_ground"] = r.home_ground;
    j["home_ground_uncertainty_m"] = r.home_ground_uncertainty_m;
    j["takeoff_height_m"] = r.takeoff_height_m;
    j["mission_end"] = r.mission_end;
  }
  if (r.geofence_zones || !r.geofence_left_out.empty()) {
    j["geofence_zones"] = r.geofence_zones;
    Json left = Json::array();
    for (const auto& [zone, why] : r.geofence_left_out) left.push_back({{"zone", zone}, {"why", why}});
    j["geofence_left_out"] = std::move(left);
  }
  if (!r.no_fly_zones.empty()) {
    Json zones = Json::array();
    for (const FlightReport::ZoneFigure& z : r.no_fly_zones)
      zones.push_back({{"zone", z.label},
                       {"id", z.id},
                       {"name", z.name},
                       {"file", z.file},
                       {"blocks", z.blocks},
                       {"min_distance_m", z.min_distance_m}});
    j["no_fly_zones"] = zones;
  }
  if (!r.snapped.empty()) j["snapped"] = snapped_json(r.snapped);
  if (r.render) j["render"] = to_json(*r.render);
  if (r.profile) j["profile"] = to_json(*r.profile);
  if (r.corridor_windows) {
    j["corridor_windows"] = r.corridor_windows;
    j["corridor_largest_window_cells"] = r.corridor_largest_window_cells;
  }
  return j;
}

namespace {

// The zone the path passes nearest (at least this far: zone_distance() is a lower bound).
const FlightReport::ZoneFigure* nearest_zone(const FlightReport& r) {
  const FlightReport::ZoneFigure* nearest = nullptr;
  for (const FlightReport::ZoneFigure& z : r.no_fly_zones)
    if (!nearest || z.min_distance_m < nearest->min_distance_m) nearest = &z;
  return nearest;
}

}  // namespace

std::string to_text(const PlanReport& r) {
  // Each clearance measured: to the mesh (none for freespace over the DSM's columns, which plans
  // without the mesh), to the DSM's columns.
  std::vector<std::string> clearances;
  if (!std::isnan(r.min_clearance_m)) clearances.push_back(two_decimals(r.min_clearance_m) + " m to the mesh");
  if (!std::isnan(r.min_clearance_dsm_m))
    clearances.push_back(two_decimals(std::floor(r.min_clearance_dsm_m * 100) / 100) + " m to the DSM's columns");
  std::string clearance = clearances.empty() ? "" : ", min clearance " + clearances.front();
  if (clearances.size() > 1) clearance += ", " + clearances[1];
  char buffer[512];
  std::snprintf(buffer, sizeof buffer,
                "%s: %zu points, %.1f m%s; %s %zu nodes, %zu edges (%.2f s%s), query %.3f s, smoothing %.3f s\n",
                r.output.c_str(), r.path_points, r.path_length_m, clearance.c_str(),
                r.planner == "prm"         ? "roadmap"
                : r.planner == "freespace" ? "free airspace: open cells as"
                                           : "trees",
                r.roadmap_nodes, r.roadmap_edges, r.seconds_roadmap, r.roadmap_reused ? ", reused" : "",
                r.seconds_query, r.seconds_smooth);
  std::string text = buffer;
  if (std::isfinite(r.max_agl_m)) {
    char ceiling[160];
    std::snprintf(ceiling, sizeof ceiling, "at most %.2f m above the ground (%s) anywhere on the path\n", r.max_agl_m,
                  r.ground.c_str());
    text += ceiling;
  }
  if (r.mission_items) {
    char mission[320];
    std::snprintf(
        mission, sizeof mission,
        "mission: %zu items: takeoff at home (x %.2f, y %.2f, ground %.2f m from the %s, uncertain by %.2f m) "
        "to %.2f m above it, %zu more points, then %s\n",
        r.mission_items, r.home[0], r.home[1], r.home[2],
        r.home_ground == "mesh floor" ? "mesh floor"
        : r.home_ground == "dtm"      ? "DTM"
                                      : "DSM",
        r.home_ground_uncertainty_m, r.takeoff_height_m, r.path_points - 1, r.mission_end.c_str());
    text += mission;
  }
  if (r.geofence_zones || !r.geofence_left_out.empty()) {
    text +=
        "geofence: " + std::to_string(r.geofence_zones) + (r.geofence_zones == 1 ? " zone" : " zones") + " kept out";
    for (const auto& [zone, why] : r.geofence_left_out) text += "; left out: " + zone + " (" + why + ")";
    text += "\n";
  }
  if (const FlightReport::ZoneFigure* nearest = nearest_zone(r)) {
    char zone[64];
    std::snprintf(zone, sizeof zone, " %.2f m from the path", nearest->min_distance_m);
    text += "nearest no-fly zone: " + nearest->label + zone + (nearest->blocks ? "" : " (not blocking)") + "\n";
  }
  for (const FlightReport::Snap& s : r.snapped) {
    char move[240];
    std::snprintf(move, sizeof move, "%s snapped %.2f m: x %.2f, y %.2f, z %.2f to x %.2f, y %.2f, z %.2f (--snap; ",
                  s.place.c_str(), s.distance_m, s.from[0], s.from[1], s.from[2], s.to[0], s.to[1], s.to[2]);
    text += move + s.reason + ")\n";
  }
  if (!r.transformation.empty()) text += "heights and coordinates to WGS 84 by: " + r.transformation + "\n";
  if (r.render) {
    const Window& w = r.render->window;
    char picture[320];
    std::snprintf(picture, sizeof picture, "%s: %d x %d pixels from above, window %.10g,%.10g,%.10g,%.10g, zoom %g\n",
                  r.render->output.c_str(), r.render->width, r.render->height, w.xmin, w.ymin, w.xmax, w.ymax,
                  r.render->zoom);
    text += picture;
  }
  if (r.profile) text += to_text(*r.profile);
  return text;
}

}  // namespace dsmplan
