// plan_flight(): the plan stage's whole request (flight.hpp), in the order that refuses what can
// be refused before the costly work: the data's agreement and the waypoints first, then the
// clearance index, the planner (Adolf & Hirschmueller, Section 5), a mission's legs, and the
// verification of the path against the data.
#include <algorithm>
#include <cmath>
#include <optional>

#include "core/stopwatch.hpp"
#include "core/text.hpp"
#include "dsmplan/columns.hpp"
#include "dsmplan/flight.hpp"

namespace dsmplan {

namespace {

struct Extent {
  double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY;
};

std::string box(double x0, double x1, double y0, double y1) {
  return "x " + two_decimals(x0) + " to " + two_decimals(x1) + ", y " + two_decimals(y0) + " to " + two_decimals(y1);
}

}  // namespace

// Where the mesh reaches beyond the DSM's columns, a path could fly unchecked (the terrain only
// bounds the ceiling, and beyond it nothing flies).
void require_beside(const Grid& grid, const std::string& name, const char* what, const Crs& crs, double xmin,
                    double ymin, double xmax, double ymax) {
  const Extent e{xmin, ymin, xmax, ymax};
  if (grid.crs.epsg && crs.epsg && grid.crs.epsg != crs.epsg)
    throw InputError(name, "",
                     std::string("the ") + what + "'s CRS is EPSG:" + std::to_string(grid.crs.epsg) +
                         ", the mesh's EPSG:" + std::to_string(crs.epsg));
  const std::string mesh_box = box(e.xmin, e.xmax, e.ymin, e.ymax);
  if (!(grid.x1() > e.xmin && grid.x0 < e.xmax && grid.y1() < e.ymax && grid.y0 > e.ymin))
    throw InputError(name, "",
                     std::string("the ") + what + " (" + box(grid.x0, grid.x1(), grid.y1(), grid.y0) +
                         ") does not overlap the mesh (" + mesh_box + ")");
  const double hx = grid.cell_x / 2 + 1e-9, hy = grid.cell_y / 2 + 1e-9;
  if (std::string(what) == "DSM" &&
      !(grid.x0 <= e.xmin + hx && grid.x1() >= e.xmax - hx && grid.y1() <= e.ymin + hy && grid.y0 >= e.ymax - hy))
    throw InputError(name, "",
                     "the DSM (" + box(grid.x0, grid.x1(), grid.y1(), grid.y0) + ") does not cover the mesh (" +
                         mesh_box + "): a path there would go unchecked");
}

namespace {

// Every waypoint closer than the safety distance to the DSM's columns, with the column that
// stands nearest, refused before any work on the mesh.
void refuse_near_columns(const std::vector<Point3>& waypoints, const Grid& columns, double safety,
                         const std::string& file) {
  std::vector<PlanResult::Invalid> problems;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    const NearestColumn c = nearest_column(columns, waypoints[i], safety);
    if (!c.found || c.distance >= safety) continue;
    const std::string where =
        "the column at x " + two_decimals(c.x) + ", y " + two_decimals(c.y) + " (top " + two_decimals(c.top) + " m)";
    problems.push_back({i, c.distance <= 0 ? "inside the DSM (under its surface): in " + where
                                           : "closer than the safety distance to the DSM: " + two_decimals(c.distance) +
                                                 " m from " + where + ", --safety " + two_decimals(safety)});
  }
  refuse_waypoints(file, problems);
}

// Every waypoint above the ceiling, in the planner's words, before any work.
void refuse_above_ceiling(const std::vector<Point3>& waypoints, const GroundGrid& ground, double max_agl,
                          const std::string& file) {
  std::vector<PlanResult::Invalid> problems;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    const double above = ground.height_above(waypoints[i]);
    if (above <= max_agl) continue;
    problems.push_back({i, std::isinf(above)
                               ? "outside the ground's extent (no ground below it to count --max-agl from)"
                               : "above the ceiling: " + two_decimals(above) + " m above the ground, --max-agl " +
                                     two_decimals(max_agl)});
  }
  refuse_waypoints(file, problems);
}

// The path held to both limits once more, measured on its own (measure_path()): clearance to the
// DSM's columns at least the safety distance, less 1 cm for the rounding of what is written;
// height above the ground at most max_agl, plus 5 cm. A path planned as above always passes:
// failing is a bug, and nothing is returned.
void verify(const std::vector<Point3>& path, const Grid* columns, const GroundGrid& ground, const PlanOptions& limits,
            double cap, FlightReport& report, const std::string& place) {
  const PathMeasures m = measure_path(path, ground, columns, cap);
  report.max_agl_m = m.max_agl_m;
  if (columns) {
    report.min_clearance_dsm_m = m.min_clearance_dsm_m;
    report.dsm_tolerance_m = 0.01;
    if (!(report.min_clearance_dsm_m >= limits.safety - report.dsm_tolerance_m))
      throw InputError(place, "",
                       "the path passes " + two_decimals(report.min_clearance_dsm_m) +
                           " m from the DSM's columns (segment " + std::to_string(m.min_clearance_dsm_segment) +
                           "), closer than --safety " + two_decimals(limits.safety) +
                           ": a bug, please report it; nothing written");
  }
  if (!(report.max_agl_m <= limits.max_agl + 0.05))
    throw InputError(place, "",
                     "the path rises " + two_decimals(report.max_agl_m) + " m above the ground (segment " +
                         std::to_string(m.max_agl_segment) + "), above --max-agl " + two_decimals(limits.max_agl) +
                         ": a bug, please report it; nothing written");
}

Extent extent_of(const FlightRequest& request) {
  Extent e;
  if (request.index && !request.dsm) {  // the mesh was not read: the extent of its triangles
    const ClearanceIndex::Footprint& f = request.index->footprint();
    return {f.xmin, f.ymin, f.xmax, f.ymax};
  }
  for (const Vertex& v : request.mesh->vertices)
    e.xmin = std::min(e.xmin, v.x), e.ymin = std::min(e.ymin, v.y), e.xmax = std::max(e.xmax, v.x),
    e.ymax = std::max(e.ymax, v.y);
  return e;
}

// The mesh with the DSM's holes' columns joined to it: a mesh has voids there.
std::shared_ptr<const Mesh> with_hole_columns(const Mesh& mesh, const Grid& dsm, const Grid& columns) {
  auto joined = std::make_shared<Mesh>(mesh);
  const Mesh holes = hole_columns(dsm, columns);
  const uint32_t offset = static_cast<uint32_t>(joined->vertices.size());
  joined->vertices.insert(joined->vertices.end(), holes.vertices.begin(), holes.vertices.end());
  for (Triangle t : holes.triangles) joined->triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  return joined;
}

void take_planner_figures(const PlanResult& result, FlightReport& report) {
  report.roadmap_nodes = result.roadmap_nodes;
  report.roadmap_edges = result.roadmap_edges;
  report.seconds_roadmap = result.seconds_roadmap;
  report.seconds_query = result.seconds_query;
  report.seconds_smooth = result.seconds_smooth;
  report.refined_samples = result.refined_samples;
}

// The planner over `route`: a kept roadmap when the store has one (or builds and keeps one), else
// plan_path() with its own.
PlanResult run_planner(const ClearanceIndex& index, const std::vector<Point3>& route, const PlanOptions& plan,
                       const FlightStore& store, uint64_t key, FlightReport& report, Stopwatch& clock,
                       const Progress& progress) {
  if (!store.kept_roadmap) return plan_path(index, route, plan, sub_progress(progress, 0, 0.95));
  Roadmap map;
  if (std::optional<Roadmap> kept = store.kept_roadmap(key, plan)) {
    map = std::move(*kept);
    report.roadmap_reused = true;
  } else {
    map = build_roadmap(index, plan, sub_progress(progress, 0, 0.95));
    if (store.keep_roadmap) store.keep_roadmap(map, key, plan);
  }
  const double seconds_roadmap = clock.lap();
  PlanResult result = query_roadmap(map, index, route, plan);
  result.seconds_roadmap = report.roadmap_reused ? 0 : seconds_roadmap;
  if (report.roadmap_reused) report.seconds_load += seconds_roadmap, report.seconds_read += seconds_roadmap;
  return result;
}

// The DSM's columns, holes as high as their rim (what the path must keep `safety` from), and the
// mesh the planner runs on: the request's, with the holes' columns joined.
struct Obstacles {
  Grid columns;
  std::shared_ptr<const Mesh> mesh;
  double half_diagonal = INFINITY;  ///< of the DSM's cells
};

// With a DSM: waypoints above the ceiling or near a column refused now, before the work on the
// mesh; the safety distance widened on the mesh by as far as the columns may lie inside it.
Obstacles hold_to_dsm(const FlightRequest& request, const Extent& extent, PlanOptions& plan, FlightReport& report) {
  Obstacles out;
  out.mesh = request.mesh;
  if (!request.dsm) return out;
  const Grid& dsm = *request.dsm;
  const FlightNames& names = request.names;
  require_beside(dsm, names.dsm, "DSM", request.mesh->crs, extent.xmin, extent.ymin, extent.xmax, extent.ymax);
  out.columns = dsm;
  fill_holes_from_rim(out.columns, RimHeight::highest);
  plan.ground = std::make_shared<GroundGrid>(dsm);
  if (!request.dtm) refuse_above_ceiling(request.waypoints, *plan.ground, plan.max_agl, names.waypoints);
  refuse_near_columns(request.waypoints, out.columns, plan.safety, names.waypoints);
  ColumnError above;
  VerticalError below;
  report.safety_margin_m = column_margin(*request.mesh, dsm, &above, &below);
  report.mesh_max_below_dsm_m = below.max_below;
  report.column_max_above_mesh_m = above.max_below;
  out.half_diagonal = std::hypot(dsm.cell_x, dsm.cell_y) / 2;
  plan.safety += report.safety_margin_m;
  if (!request.index) out.mesh = with_hole_columns(*request.mesh, dsm, out.columns);
  return out;
}

// Why the planner found no path, every invalid waypoint named as the user numbers them.
[[noreturn]] void refuse_no_path(const PlanResult& result, const MissionSite* site, const FlightRequest& request,
                                 const FlightReport& report, double half_diagonal) {
  FailureInWords words = failure_in_words(result, site, request.waypoints.size());
  std::string& why = words.why;
  // Worth a word only when the mesh does not fit its DSM (more than a conservative mesh needs).
  if (report.safety_margin_m > half_diagonal + 1e-9)
    why += " (on the mesh the safety distance is --safety " + two_decimals(request.options.safety) + " widened by " +
           two_decimals(report.safety_margin_m) + " m, as far as the DSM's columns may lie inside this mesh; a " +
           "conservative mesh of the DSM itself needs half a cell diagonal)";
  throw InputError(request.names.waypoints, words.place, why);
}

// The figures measured on the path on their own, not taken from the planner (the numbers a user
// checks the path by), and the verification against the data.
void measure_flight(FlightPlan& out, const FlightRequest& request, const Grid& columns, const GroundGrid& ground,
                    double max_agl) {
  FlightReport& report = out.report;
  const std::vector<Point3>& path = out.path;
  report.path_points = path.size();
  report.path_length_m = path_length(path);
  const double cap = request.options.safety + max_agl;
  report.min_clearance_m = cap;
  for (size_t k = 1; k < path.size(); ++k)
    // Up to the least so far: the same minimum, without searching 100 m around every segment.
    report.min_clearance_m = out.index->clearance(path[k - 1], path[k], report.min_clearance_m);
  verify(path, request.dsm ? &columns : nullptr, ground, request.options, cap, report,
         request.dsm ? request.names.dsm : request.names.mesh);
  if (const MissionSite* site = out.site ? &*out.site : nullptr) {
    report.home = site->home;
    report.takeoff_height_m = site->takeoff_top[2] - site->home[2];
    report.mission_end = site->end == MissionEnd::rtl ? "rtl" : site->end == MissionEnd::land ? "land" : "none";
  }
}

}  // namespace

void refuse_terrain_above(const GroundGrid& terrain, const std::function<double(double, double)>& surface_z,
                          const std::vector<Point3>& waypoints, const MissionSite* site,
                          const std::string& terrain_name, const std::string& surface_name) {
  std::vector<NamedPlace> places;
  if (site) places.push_back({"home", site->home[0], site->home[1]});
  for (size_t i = 0; i < waypoints.size(); ++i)
    places.push_back({"waypoint " + std::to_string(i + 1), waypoints[i][0], waypoints[i][1]});
  if (site && site->end == MissionEnd::land) places.push_back({"the landing", site->land[0], site->land[1]});
  if (const auto problem = terrain_above_surface(terrain, surface_z, places, surface_name))
    throw InputError(terrain_name, problem->place, problem->problem);
}

void refuse_waypoints(const std::string& file, const std::vector<PlanResult::Invalid>& invalid) {
  if (invalid.empty()) return;
  throw InputError(file, "waypoint " + std::to_string(invalid.front().waypoint + 1), waypoint_problems(invalid));
}

FlightPlan plan_flight(const FlightRequest& request, const Progress& progress) {
  const FlightNames& names = request.names;
  const std::vector<Point3>& waypoints = request.waypoints;
  check_plan_options(request.options);
  if (!request.mesh) throw ArgumentError("mesh", "a flight needs the mesh (with a kept index, at least its CRS)");
  if (waypoints.size() < 2)
    throw InputError(names.waypoints, "",
                     "a path needs at least two waypoints, the file has " + std::to_string(waypoints.size()));
  const bool indexed = request.index && !request.dsm;  // the mesh's triangles are in the index
  if (!indexed && request.mesh->triangles.empty()) throw InputError(names.mesh, "", "the mesh has no triangles");
  Stopwatch clock;
  FlightPlan out;
  FlightReport& report = out.report;
  report.planner = request.options.planner == PlannerKind::prm ? "prm" : "rrtconnect";
  report.waypoint_count = waypoints.size();
  const Crs& crs = request.mesh->crs;
  PlanOptions plan = request.options;
  plan.ground = nullptr;
  const Extent extent = extent_of(request);

  const Obstacles obstacles = hold_to_dsm(request, extent, plan, report);
  const Grid& columns = obstacles.columns;
  if (request.dtm) {
    require_beside(*request.dtm, names.dtm, "DTM", crs, extent.xmin, extent.ymin, extent.xmax, extent.ymax);
    plan.ground = std::make_shared<GroundGrid>(*request.dtm);
    refuse_above_ceiling(waypoints, *plan.ground, plan.max_agl, names.waypoints);
  }
  report.index_reused = request.index != nullptr;
  out.index = request.index ? request.index : std::make_shared<const ClearanceIndex>(*obstacles.mesh);
  // Kept files are named by the obstacles (the mesh and the DSM's holes' columns); a kept index holds it.
  const FlightStore& store = request.store;
  std::optional<uint64_t> fingerprint;  // O(mesh): computed once, when a kept file asks for it
  const auto obstacles_key = [&] {
    if (!fingerprint) fingerprint = request.index ? request.index_fingerprint : mesh_fingerprint(*obstacles.mesh);
    return *fingerprint;
  };
  if (!request.index && store.keep_index) store.keep_index(*out.index, obstacles_key());
  const ClearanceIndex& index = *out.index;
  report.ground = request.dtm ? "dtm" : request.dsm ? "dsm" : "mesh floor";
  // What a mission's straight items and vertical legs are held to: the DSM's columns when known,
  // else the mesh; the ceiling over the ground in use.
  const GroundGrid& ground = plan.ground ? *plan.ground : index.floor();
  const double safety = request.options.safety;
  const std::unique_ptr<ObstacleClearance> clearance =
      request.dsm ? std::unique_ptr<ObstacleClearance>(std::make_unique<ColumnsClearance>(columns, safety))
                  : std::make_unique<MeshClearance>(index, safety);
  const FlightRules rules{clearance.get(), &ground, plan.max_agl};

  std::vector<Point3> route = waypoints;
  if (request.mission) {
    const auto ground_z = [&](double x, double y) { return -ground.height_above({x, y, 0}); };
    out.site = mission_site(*request.mission, waypoints, ground_z);
    report.home_ground = report.ground;
    report.home_ground_uncertainty_m = ground.spread_at(out.site->home[0], out.site->home[1]);
  }
  const MissionSite* site = out.site ? &*out.site : nullptr;
  if (request.dtm) {
    const auto surface_z = [&](double x, double y) {
      return request.dsm ? double(columns.height_at(x, y)) : index.ground(x, y);
    };
    refuse_terrain_above(*plan.ground, surface_z, waypoints, site, names.dtm,
                         request.dsm ? "the DSM " + names.dsm : "the mesh " + names.mesh);
  }
  if (site) {
    const auto dsm_z = [&](double x, double y) { return request.dsm ? double(columns.height_at(x, y)) : NAN; };
    check_vertical_legs(*site, waypoints, rules, dsm_z);
    route = route_waypoints(waypoints, *site);
  }
  report.seconds_load = clock.lap();

  const uint64_t roadmap_key =
      store.kept_roadmap ? obstacles_key() ^ (plan.ground ? plan.ground->fingerprint() : 0) : 0;
  PlanResult result = run_planner(index, route, plan, store, roadmap_key, report, clock, progress);
  take_planner_figures(result, report);
  if (result.status != PlanStatus::Solved) refuse_no_path(result, site, request, report, obstacles.half_diagonal);
  // A mission flies straight from item to item: as few items as keep the limits on those lines
  // (before the clearance below is measured on them).
  if (site) result.path = merge_straight_legs(result.path, route, rules);
  out.path = std::move(result.path);

  measure_flight(out, request, columns, ground, plan.max_agl);
  return out;
}

}  // namespace dsmplan
