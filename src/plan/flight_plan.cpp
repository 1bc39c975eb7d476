// plan_flight(): the plan stage's whole request (flight.hpp), in the order that refuses what can
// be refused before the costly work: the data's agreement and the waypoints first, then the
// clearance index, the planner (Adolf & Hirschmueller, Section 5), a mission's legs, and the
// verification of the path against the data.
#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <optional>

#include "core/stopwatch.hpp"
#include "core/text.hpp"
#include "dsmplan/columns.hpp"
#include "dsmplan/flight.hpp"
#include "dsmplan/free_airspace.hpp"
#include "plan/nearest_spot.hpp"
#include "plan/path_parts.hpp"

namespace dsmplan {

namespace {

constexpr double kMaxSnap = 50;  // m: the largest FlightQuery::snap

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

// The library's own guard of the unit every distance is in (the faces say more first, with PROJ:
// metric_problem() in raster_io.hpp): data without a CRS, in degrees or in another unit than the
// metre are refused, so that no face plans a safety distance of 2 ft, or of 2 degrees, as 2 m.
void require_metres(const Crs& crs, const std::string& name, const char* what, bool required) {
  const auto refuse = [&](const std::string& problem) { throw InputError(name, "", problem); };
  if (!crs.known()) {
    if (!required) return;
    refuse(std::string("the ") + what +
           " has no CRS, so the unit of its coordinates is unknown: dsmplan measures in metres and plans "
           "only on data that say so (give the DSM its CRS, e.g. EPSG:25832, and mesh it again)");
  }
  if (crs.geographic)
    refuse(std::string("the ") + what + "'s CRS" + (crs.name.empty() ? "" : " '" + crs.name + "'") +
           " is geographic (degrees): dsmplan measures in metres; reproject it to a projected CRS first");
  if (crs.linear_unit_m > 0 && std::abs(crs.linear_unit_m - 1) > 1e-9)
    refuse(std::string("the ") + what + "'s CRS" + (crs.name.empty() ? "" : " '" + crs.name + "'") + " measures in " +
           (crs.linear_unit.empty() ? "units of " + short_number(crs.linear_unit_m) + " m" : crs.linear_unit) +
           ": dsmplan measures in metres; reproject it first");
}

// Every waypoint closer than the safety distance to the DSM's columns, with the column that
// stands nearest.
std::vector<PlanResult::Invalid> near_columns(const std::vector<Point3>& waypoints, const Grid& columns, double safety,
                                              const StopToken* stop) {
  std::vector<PlanResult::Invalid> problems;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    check_stop(stop);  // a waypoint's search grows with the square of the safety distance
    const NearestColumn c = nearest_column(columns, waypoints[i], safety);
    if (!c.found || c.distance >= safety) continue;
    const std::string where =
        "the column at x " + two_decimals(c.x) + ", y " + two_decimals(c.y) + " (top " + two_decimals(c.top) + " m)";
    problems.push_back({i, c.distance <= 0 ? "inside the DSM (under its surface): in " + where
                                           : "closer than the safety distance to the DSM: " + two_decimals(c.distance) +
                                                 " m from " + where + ", --safety " + two_decimals(safety)});
  }
  return problems;
}

// Every waypoint above the ceiling, in the planner's words.
std::vector<PlanResult::Invalid> above_ceiling(const std::vector<Point3>& waypoints, const GroundGrid& ground,
                                               double max_agl) {
  std::vector<PlanResult::Invalid> problems;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    const double above = ground.height_above(waypoints[i]);
    if (above <= max_agl) continue;
    problems.push_back({i, std::isinf(above)
                               ? "outside the ground's extent (no ground below it to count --max-agl from)"
                               : "above the ceiling: " + two_decimals(above) + " m above the ground, --max-agl " +
                                     two_decimals(max_agl)});
  }
  return problems;
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

// The mesh with the DSM's holes' columns joined to it: a mesh has voids there.
std::shared_ptr<const Mesh> with_hole_columns(const std::shared_ptr<const Mesh>& mesh, const Grid& dsm,
                                              const Grid& columns) {
  const Mesh holes = hole_columns(dsm, columns);
  if (holes.triangles.empty()) return mesh;
  auto joined = std::make_shared<Mesh>(*mesh);
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
  std::shared_ptr<const Roadmap> map = store.kept_roadmap(key, plan);
  report.roadmap_reused = map != nullptr;
  if (!map) {
    map = std::make_shared<const Roadmap>(build_roadmap(index, plan, sub_progress(progress, 0, 0.95)));
    if (store.keep_roadmap) store.keep_roadmap(*map, key, plan);
  }
  const double seconds_roadmap = clock.lap();
  PlanResult result = query_roadmap(*map, index, route, plan);
  result.seconds_roadmap = report.roadmap_reused ? 0 : seconds_roadmap;
  if (report.roadmap_reused) report.seconds_load += seconds_roadmap, report.seconds_read += seconds_roadmap;
  return result;
}

void check_query(const FlightQuery& query, const FlightNames& names) {
  check_plan_options(query.options);
  if (!(query.snap >= 0 && query.snap <= kMaxSnap))
    throw ArgumentError("snap",
                        "must lie in [0, " + short_number(kMaxSnap) + "] m (0: off), got " + short_number(query.snap));
  if (query.waypoints.size() < 2)
    throw InputError(names.waypoints, "",
                     "a path needs at least two waypoints, the file has " + std::to_string(query.waypoints.size()));
  for (size_t i = 0; i < query.waypoints.size(); ++i) {  // before any rule measures one
    const Point3& p = query.waypoints[i];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      throw InputError(names.waypoints, "waypoint " + std::to_string(i + 1),
                       "x, y and z must be finite numbers, got " + short_number(p[0]) + ", " + short_number(p[1]) +
                           ", " + short_number(p[2]));
  }
}

// Every waypoint above the ceiling or near a column, refused before the work on the mesh, in
// the order the user has always been told them: the ceiling over the DSM, the columns, the
// ceiling over the terrain.
std::vector<PlanResult::Invalid> refused_before_planning(const FlightArea& area, const std::vector<Point3>& waypoints,
                                                         const PlanOptions& options) {
  const double max_agl = options.max_agl;
  std::vector<PlanResult::Invalid> refused;
  if (area.columns() && !area.terrain()) refused = above_ceiling(waypoints, area.ground(), max_agl);
  if (refused.empty() && area.columns())
    refused = near_columns(waypoints, *area.columns(), options.safety, options.stop.get());
  if (refused.empty() && area.terrain()) refused = above_ceiling(waypoints, *area.terrain(), max_agl);
  return refused;
}

// Every waypoint inside a no-fly zone that blocks, naming the zone and its file.
std::vector<PlanResult::Invalid> inside_zones(const std::vector<Point3>& waypoints, const FlightData& data,
                                              const GroundGrid* ground, const StopToken* stop) {
  std::vector<PlanResult::Invalid> refused;
  for (size_t i = 0; i < waypoints.size(); ++i, check_stop(stop))
    for (const AirspaceZone& zone : data.no_fly)
      if (zone_blocks(zone, data.airspace) && zone_contains(zone, waypoints[i], ground)) {
        refused.push_back({i, "inside no-fly " + zone_label(zone)});
        break;
      }
  return refused;
}

// Every rule a waypoint is held to, for one point, in the order a list is refused: the checks
// before planning, the no-fly zones, then the planner's own (invalid_waypoints()). A point --snap
// moves a waypoint to passes exactly what refused it: one implementation.
struct WaypointRules {
  WaypointRules(const FlightArea& area, const PlanOptions& options)
      : area(area), options(options), plan(area.planner_options(options)) {}
  WaypointRules(const WaypointRules&) = delete;  // `space` refers to `plan`
  WaypointRules& operator=(const WaypointRules&) = delete;

  // Why `p` cannot be a waypoint, or empty when it can.
  std::string refusal(const Point3& p) const {
    check_stop(options.stop.get());
    const std::vector<Point3> one{p};
    std::vector<PlanResult::Invalid> found = refused_before_planning(area, one, options);
    if (found.empty()) found = inside_zones(one, area.data(), &area.ground(), options.stop.get());
    if (!found.empty()) return found.front().reason;
    // The free-airspace planner holds a waypoint to the DSM's columns themselves (checked above),
    // not to the mesh with the safety widened.
    if (area.plans_on_columns(options)) return {};
    if (!space) space.emplace(detail::flight_space(area.index(), plan));  // the index, built now if not yet
    PlanResult result;
    return detail::invalid_waypoints(one, *space, result) ? result.reason : std::string();
  }
  bool valid(const Point3& p) const { return refusal(p).empty(); }

  const FlightArea& area;
  const PlanOptions& options;
  const PlanOptions plan;                    // the planner's: the safety widened on the mesh, the zones added
  mutable std::optional<FlightSpace> space;  // the planner's own check, made when first asked
};

// The stages a Cancelled names (core.hpp: in_stage()), as a service's 504 says them.
constexpr const char* kCheckingWaypoints = "checking the waypoints";
constexpr const char* kNamingNearest = "searching the nearest valid point to a refused waypoint";

constexpr double kClimbStep = 0.1;   // m: the steps straight up
constexpr double kWiderSearch = 50;  // m: how far a refusal looks for the nearest valid point

// Points a refusal's searches (within 10 m, then 50 m) try at most: a refusal must come in
// seconds, not search a ball of points each checked with a widened safety distance (a tower 20 m
// over the mesh widened it to 22 m on the sample: 100 s for one refusal with no bound, 30 s with
// the wider search bounded alone, since the 10 m ball at 0.5 m steps holds 33,000 points; 16 s
// with both). Of the 1,346 waypoints refused among bench/routes_process.sh's 10,000 routes, the
// bounded search names the same point as the unbounded one for all but one (8.73 m away instead
// of 8.41 m); a bound of 4,000 for both named a farther one for others too (r1946: 7.92 m, not
// 6.75 m).
constexpr size_t kMaxNearTries = 16000, kMaxTries = 4000;

// A try's cost grows with the area within the safety distance (the columns, or the mesh's
// triangles, each check examines), so the bounds above hold up to kCheapSafety and shrink past it
// as 1 / safety²: a search then costs what it costs at kCheapSafety, bounded before it starts
// (issue 49). Unbounded by safety, three refusals took 19 s at --safety 100 over the crop's DSM
// and 117 s at 300; 37 s and 169 s on its mesh alone.
constexpr double kCheapSafety = 10;  // m
constexpr size_t kLeastTries = 16;

size_t tries_for_safety(size_t tries, double safety) {
  if (!(safety > kCheapSafety)) return tries;
  const double share = (kCheapSafety / safety) * (kCheapSafety / safety);
  return std::max(kLeastTries, static_cast<size_t>(static_cast<double>(tries) * share));
}

struct Spot {
  bool found = false;
  Point3 at{NAN, NAN, NAN};
  double distance = INFINITY;
  size_t bound = 0;  // non-zero when stopped at this bound of tries: only the nearest points were tried
};

// The nearest point to `p` within `radius` (3D) that the rules accept. Straight up first, in
// steps of kClimbStep (what a pilot does near a wall: climb over it): with `up_first` a climb
// that works is the answer; without, it only bounds the sideways search, which may find nearer.
// Sideways: search_rings() in steps of max(0.5 m, radius / 40) (at most 40 rings, so a
// refusal's wider search stays a fraction of a second), each offset with the least vertical
// shift that works (0, +1, -1, +2, ... steps), the nearest in 3D kept.
Spot nearest_valid_point(const Point3& p, double radius, bool up_first, const WaypointRules& rules,
                         size_t max_tries = SIZE_MAX) {
  Spot spot;
  size_t tries = 0;
  // The planner's safety is the largest a check measures with: the mesh's widened, or on the
  // columns the columns' own (planner_options() widens only off them).
  max_tries = tries_for_safety(max_tries, rules.plan.safety);
  for (int m = 1; m * kClimbStep <= radius + 1e-9 && !spot.found; ++m) {
    if (++tries > max_tries) {
      spot.bound = max_tries;
      return spot;
    }
    if (const Point3 q{p[0], p[1], p[2] + m * kClimbStep}; rules.valid(q)) spot = {true, q, m * kClimbStep};
  }
  if (spot.found && up_first) return spot;
  const double step = std::max(0.5, radius / 40);
  detail::search_rings(step, std::min(radius, spot.distance), 0, [&](double dx, double dy, double dxy) -> double {
    for (int m = 0;; ++m) {
      const double dz = (m + 1) / 2 * step * (m % 2 ? 1 : -1);
      const double d = std::hypot(dxy, dz);
      if (d > radius || d >= spot.distance) break;
      if (dxy == 0 && dz >= 0) continue;  // the point itself, or climbed already (finer)
      if (++tries > max_tries) {
        spot.bound = max_tries;
        return 0;  // ends the rings: nothing nearer than 0 is left to find
      }
      const Point3 q{p[0] + dx, p[1] + dy, p[2] + dz};
      if (rules.valid(q)) {
        spot = {true, q, d, 0};
        return d;
      }
    }
    return INFINITY;
  });
  return spot;
}

std::string point_in_words(const Point3& p) {
  return "x " + two_decimals(p[0]) + ", y " + two_decimals(p[1]) + ", z " + two_decimals(p[2]);
}

// Where a refused point could be instead: the nearest valid point within 50 m (within 10 m
// first, on the finer steps of a smaller radius).
Spot nearest_spot(const Point3& p, const WaypointRules& rules) {
  const Spot spot = nearest_valid_point(p, 10, false, rules, kMaxNearTries);
  return spot.found ? spot : nearest_valid_point(p, kWiderSearch, false, rules, kMaxTries);
}

// nearest_spot() for a refusal's message.
std::string nearest_in_words(const Spot& spot) {
  if (!spot.found && spot.bound) return "; no valid point among the " + std::to_string(spot.bound) + " nearest tried";
  if (!spot.found) return "; no valid point within " + two_decimals(kWiderSearch) + " m";
  return "; the nearest valid point: " + point_in_words(spot.at) + " (" + two_decimals(spot.distance) +
         " m away; --snap moves a waypoint there)";
}

// Each refusal with the nearest valid point to the refused one (`points[waypoint]`).
std::vector<PlanResult::Invalid> naming_nearest(std::vector<PlanResult::Invalid> invalid,
                                                const std::vector<Point3>& points, const WaypointRules& rules) {
  // Only for those the message names (waypoint_problems()): 3,000 waypoints under the ground cost
  // 79 s of searches before, whose answers nobody read.
  for (size_t k = 0; k < invalid.size() && k <= kListedWaypoints; ++k)
    if (invalid[k].waypoint < points.size()) {
      const Spot spot = nearest_spot(points[invalid[k].waypoint], rules);
      invalid[k].reason += nearest_in_words(spot);
      if (spot.found) invalid[k].nearest = spot.at;
    }
  return invalid;
}

// FlightQuery::snap: every refused waypoint moved to the nearest valid point within the radius
// (up first), each move reported; those with none within, refused and listed. Bounded as a
// refusal's search is: a 50 m radius at 1.25 m steps holds 270,000 points.
std::vector<PlanResult::Invalid> snap_waypoints(std::vector<Point3>& waypoints, double radius,
                                                const WaypointRules& rules, FlightReport& report) {
  std::vector<PlanResult::Invalid> refused;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    const std::string why = rules.refusal(waypoints[i]);
    if (why.empty()) continue;
    const Spot spot = nearest_valid_point(waypoints[i], radius, true, rules, kMaxNearTries);
    if (!spot.found) {
      const Spot nearest = nearest_spot(waypoints[i], rules);
      refused.push_back({i,
                         why + "; no valid point within --snap " + two_decimals(radius) + " m" +
                             (spot.bound ? " among the " + std::to_string(spot.bound) + " nearest tried" : "") +
                             nearest_in_words(nearest),
                         nearest.found ? std::optional(nearest.at) : std::nullopt});
      continue;
    }
    report.snapped.push_back({i + 1, "waypoint " + std::to_string(i + 1), waypoints[i], spot.at, spot.distance, why});
    waypoints[i] = spot.at;
  }
  return refused;
}

// The path's distance to each zone (for --stats and the summary), and its segments checked once
// more against the zones that block, as the DSM's columns are: failing is a bug.
void measure_zones(FlightPlan& out, const FlightData& data, const FlightRules& rules, const GroundGrid& ground) {
  const std::vector<Point3>& path = out.path;
  for (size_t k = 1; k < path.size(); ++k)
    for (const FlightConstraint* rule : rules.constraints)
      if (const FlightConstraint* zone = rule->refused_by(path[k - 1], path[k]))
        throw InputError(data.names.mesh, "",
                         "the path enters " + zone->name() +
                             " or comes closer to it than the zones are kept (segment " + std::to_string(k) +
                             "): a bug, please report it; nothing written");
  for (const AirspaceZone& zone : data.no_fly)
    check_stop(rules.stop),
        out.report.no_fly_zones.push_back({zone_label(zone), zone.id, zone.name, zone.source_file,
                                           zone_blocks(zone, data.airspace), zone_distance(zone, path, &ground)});
}

PlanResult refused(std::vector<PlanResult::Invalid> invalid) {
  PlanResult result;
  result.status = PlanStatus::InvalidWaypoint;
  result.waypoint = invalid.front().waypoint;
  result.reason = invalid.front().reason;
  result.invalid = std::move(invalid);
  return result;
}

// The figures measured on the path on their own, not taken from the planner (the numbers a user
// checks the path by), and the verification against the data.
void measure_flight(FlightPlan& out, const FlightArea& area, const FlightQuery& query) {
  FlightReport& report = out.report;
  const std::vector<Point3>& path = out.path;
  report.path_points = path.size();
  report.path_length_m = path_length(path);
  // The least clearance up to `cap`: within a reach of the safety distance plus 1 m first (a
  // path keeps the safety distance and most pass within a metre or two of it), doubled until some
  // segment comes within it, and each segment up to the least so far. The same minimum as one
  // pass within the whole cap, but a query's cost grows with the square of its reach: the first
  // segment searched within 122 m cost more than planning the route (issue 35's routes at 120 m).
  const double cap = query.options.safety + query.options.max_agl;
  report.min_clearance_m = NAN;  // without the mesh's index (freespace over the DSM's columns): not measured
  for (double reach = std::min(cap, query.options.safety + 1); out.index; reach = std::min(cap, 2 * reach)) {
    double least = reach;
    for (size_t k = 1; k < path.size(); ++k)
      check_stop(query.options.stop.get()), least = out.index->clearance(path[k - 1], path[k], least);
    report.min_clearance_m = least;
    if (least < reach || reach >= cap) break;
  }
  const FlightNames& names = area.data().names;
  verify(path, area.columns(), area.ground(), query.options, cap, report, area.columns() ? names.dsm : names.mesh);
  if (out.site) report_site(*out.site, report);
}

}  // namespace

void report_site(const MissionSite& site, FlightReport& report) {
  report.home = site.home;
  report.takeoff_height_m = site.takeoff_top[2] - site.home[2];
  report.mission_end = site.end == MissionEnd::rtl ? "rtl" : site.end == MissionEnd::land ? "land" : "none";
}

std::vector<Point3> waypoints_in_crs(std::vector<Point3> waypoints, WaypointHeights heights,
                                     const std::function<double(double, double)>& ground_z, const std::string& file,
                                     const std::string& ground_name) {
  if (heights != WaypointHeights::agl) return waypoints;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    Point3& p = waypoints[i];
    const double z = ground_z(p[0], p[1]);
    if (!std::isfinite(z))
      throw InputError(file, "waypoint " + std::to_string(i + 1),
                       "x " + two_decimals(p[0]) + ", y " + two_decimals(p[1]) + " lies over no ground (the " +
                           ground_name + ") to count its height above the ground from");
    p[2] += z;
  }
  return waypoints;
}

// ---- the area ----------------------------------------------------------------------------------

struct FlightArea::Lazy {
  std::once_flag built, keyed;
  std::shared_ptr<const Mesh> obstacles;  // the mesh with the holes' columns joined
  std::shared_ptr<const ClearanceIndex> index;
  uint64_t key = 0;
  std::once_flag roadmap_keyed, margin_measured;
  double margin = 0, mesh_max_below = NAN, column_max_above = NAN;  // measure_margin()
  uint64_t roadmap_key = 0;
  // The zones kept at a safety distance, one set per distance asked (few: a service bounds them),
  // so that every query at that distance holds the same constraints (and shares a roadmap).
  std::mutex zones_mutex;
  std::map<double, std::vector<std::shared_ptr<const FlightConstraint>>> zones_at;
  // The free airspace (free_airspace.hpp) per safety distance and ceiling asked, as the zones.
  std::mutex air_mutex;
  std::map<std::pair<double, double>, std::shared_ptr<const FreeAirspace>> air_at;
  // O(mesh), once: after the index is built (it makes `obstacles`).
  uint64_t obstacles_key() {
    std::call_once(keyed, [&] { key = mesh_fingerprint(*obstacles); });
    return key;
  }
};

FlightArea::FlightArea(FlightData data) : data_(std::move(data)), lazy_(std::make_unique<Lazy>()) {
  const FlightNames& names = data_.names;
  if (!data_.mesh) throw ArgumentError("mesh", "a flight needs the mesh (with a kept index, at least its CRS)");
  check_airspace_options(data_.airspace);
  require_metres(data_.mesh->crs, names.mesh, "mesh", true);
  if (data_.dsm) require_metres(data_.dsm->crs, names.dsm, "DSM", false);
  if (data_.dtm) require_metres(data_.dtm->crs, names.dtm, "DTM", false);
  const bool indexed = data_.index && !data_.dsm;  // the mesh's triangles are in the index
  if (!indexed && data_.mesh->triangles.empty()) throw InputError(names.mesh, "", "the mesh has no triangles");
  Extent e;
  if (indexed) {  // the mesh was not read: the extent of its triangles
    const ClearanceIndex::Footprint& f = data_.index->footprint();
    e = {f.xmin, f.ymin, f.xmax, f.ymax};
  } else {
    for (const Vertex& v : data_.mesh->vertices)
      e.xmin = std::min(e.xmin, v.x), e.ymin = std::min(e.ymin, v.y), e.xmax = std::max(e.xmax, v.x),
      e.ymax = std::max(e.ymax, v.y);
  }
  if (const Grid* dsm = data_.dsm.get()) {
    require_beside(*dsm, names.dsm, "DSM", crs(), e.xmin, e.ymin, e.xmax, e.ymax);
    columns_ = *dsm;
    fill_holes_from_rim(columns_, RimHeight::highest);
    dsm_ground_ = std::make_shared<GroundGrid>(*dsm);
  }
  if (data_.terrain) {
    terrain_ = data_.terrain;
  } else if (data_.dtm) {
    require_beside(*data_.dtm, names.dtm, "DTM", crs(), e.xmin, e.ymin, e.xmax, e.ymax);
    terrain_ = std::make_shared<GroundGrid>(*data_.dtm);
  }
}

FlightArea::~FlightArea() = default;

void FlightArea::measure_margin() const {
  std::call_once(lazy_->margin_measured, [&] {
    if (!data_.dsm) return;
    ColumnError above;
    VerticalError below;
    // A mesh of the filled DSM covers the holes: measured over every column. Else over the
    // valid cells, the holes' columns joining the mesh exactly.
    lazy_->margin = column_margin(*data_.mesh, data_.mesh_fills_holes ? columns_ : *data_.dsm, &above, &below);
    lazy_->mesh_max_below = below.max_below;
    lazy_->column_max_above = above.max_below;
  });
}

double FlightArea::safety_margin() const { return measure_margin(), lazy_->margin; }
double FlightArea::mesh_max_below_dsm() const { return measure_margin(), lazy_->mesh_max_below; }
double FlightArea::column_max_above_mesh() const { return measure_margin(), lazy_->column_max_above; }

const ClearanceIndex& FlightArea::index() const { return *shared_index(); }

std::shared_ptr<const ClearanceIndex> FlightArea::shared_index() const {
  std::call_once(lazy_->built, [&] {
    if (data_.index) {
      lazy_->index = data_.index;
      return;
    }
    lazy_->obstacles =
        data_.dsm && !data_.mesh_fills_holes ? with_hole_columns(data_.mesh, *data_.dsm, columns_) : data_.mesh;
    lazy_->index = std::make_shared<const ClearanceIndex>(lazy_->obstacles);
    if (data_.keep_index) data_.keep_index(*lazy_->index, lazy_->obstacles_key());
  });
  return lazy_->index;
}

uint64_t FlightArea::obstacles_key() const {
  if (data_.index) return data_.index_fingerprint;
  shared_index();
  return lazy_->obstacles_key();
}

const GroundGrid& FlightArea::ground() const {
  return terrain_ ? *terrain_ : dsm_ground_ ? *dsm_ground_ : index().floor();
}

std::shared_ptr<const GroundGrid> FlightArea::shared_ground() const {
  if (terrain_) return terrain_;
  if (dsm_ground_) return dsm_ground_;
  const std::shared_ptr<const ClearanceIndex> index = shared_index();
  return std::shared_ptr<const GroundGrid>(index, &index->floor());
}

const char* FlightArea::ground_name() const { return terrain_ ? "dtm" : dsm_ground_ ? "dsm" : "mesh floor"; }

std::vector<std::shared_ptr<const FlightConstraint>> FlightArea::zone_constraints(double safety) const {
  if (data_.no_fly.empty()) return {};
  constexpr size_t kKept = 16;  // distances whose constraints are kept
  {
    const std::lock_guard<std::mutex> lock(lazy_->zones_mutex);
    if (const auto found = lazy_->zones_at.find(safety); found != lazy_->zones_at.end()) return found->second;
  }
  auto made = airspace_constraints(data_.no_fly, safety, shared_ground(), data_.airspace);
  const std::lock_guard<std::mutex> lock(lazy_->zones_mutex);
  if (lazy_->zones_at.size() >= kKept) return made;
  return lazy_->zones_at.emplace(safety, std::move(made)).first->second;  // the first made, if two raced
}

const char* planner_name(PlannerKind kind) {
  switch (kind) {
    case PlannerKind::prm:
      return "prm";
    case PlannerKind::rrt_connect:
      return "rrtconnect";
    case PlannerKind::free_space:
      return "freespace";
  }
  return "?";
}

const char* objective_name(Objective objective) { return objective == Objective::low ? "low" : "shortest"; }

double climb_weight(Objective objective) { return objective == Objective::low ? 1.0 : 0.25; }

std::shared_ptr<const FreeAirspace> FlightArea::free_airspace(double safety, double max_agl,
                                                              const StopToken* stop) const {
  constexpr size_t kKept = 4;  // a 1 km tile's airspace is 13 MB
  const std::pair<double, double> key{safety, max_agl};
  {
    const std::lock_guard<std::mutex> lock(lazy_->air_mutex);
    if (const auto found = lazy_->air_at.find(key); found != lazy_->air_at.end()) return found->second;
  }
  // Over a mesh alone, the columns that enclose it on its floor's cells.
  std::optional<Grid> enclosing;
  if (!columns()) {
    if (data_.mesh->triangles.empty() && index().triangles() > 0)
      throw ArgumentError("--planner",
                          "freespace over a mesh alone needs its triangles, not only a kept index; "
                          "give --dsm, or plan without the kept index");
    enclosing = mesh_columns(*data_.mesh, index().floor().grid());
  }
  auto made = dsmplan::free_airspace(columns() ? *columns() : *enclosing, ground(), safety, max_agl, stop);
  const std::lock_guard<std::mutex> lock(lazy_->air_mutex);
  if (lazy_->air_at.size() >= kKept) return made;
  return lazy_->air_at.emplace(key, std::move(made)).first->second;  // the first made, if two raced
}

PlanOptions FlightArea::planner_options(const PlanOptions& options) const {
  PlanOptions plan = options;
  plan.ground = terrain_ ? terrain_ : dsm_ground_;
  if (!plans_on_columns(options)) plan.safety += safety_margin();  // on the columns: nothing to widen
  for (std::shared_ptr<const FlightConstraint>& zone : zone_constraints(zone_keep_distance(options)))
    plan.constraints.push_back(std::move(zone));
  return plan;
}

uint64_t FlightArea::roadmap_key() const {
  std::call_once(lazy_->roadmap_keyed, [&] {
    const GroundGrid* ground = terrain_ ? terrain_.get() : dsm_ground_.get();
    uint64_t zones = 0;  // FNV-1a over what makes the zones that block
    const auto mix = [&zones](const void* bytes, size_t size) {
      for (size_t i = 0; i < size; ++i) zones = (zones ^ static_cast<const unsigned char*>(bytes)[i]) * 1099511628211u;
    };
    for (const AirspaceZone& zone : data_.no_fly) {
      if (!zone_blocks(zone, data_.airspace)) continue;
      for (const auto& ring : zone.rings) mix(ring.data(), ring.size() * sizeof ring[0]), mix("|", 1);
      for (const ZoneLimit& limit : {zone.lower, zone.upper})
        mix(&limit.reference, sizeof limit.reference), mix(&limit.height, sizeof limit.height);
    }
    lazy_->roadmap_key = obstacles_key() ^ (ground ? ground->fingerprint() : 0) ^ zones;
  });
  return lazy_->roadmap_key;
}

// ---- a flight ----------------------------------------------------------------------------------

std::vector<Point3> flown_path(const FlightPlan& flight) {
  if (!flight.site) return flight.path;
  const MissionSite& site = *flight.site;
  std::vector<Point3> path{site.home};
  path.insert(path.end(), flight.path.begin(), flight.path.end());
  if (site.end == MissionEnd::rtl) path.push_back(site.home);
  if (site.end == MissionEnd::land) path.push_back(site.land);
  return path;
}

FlightAttempt attempt_flight(const FlightArea& area, const FlightQuery& query, const Progress& progress) {
  const FlightData& data = area.data();
  const FlightNames& names = data.names;
  check_query(query, names);
  Stopwatch clock;
  FlightAttempt attempt;
  FlightPlan& out = attempt.plan;
  FlightReport& report = out.report;
  report.planner = planner_name(query.options.planner);
  report.waypoint_count = query.waypoints.size();
  report.ground = area.ground_name();
  // The free-airspace planner over the DSM's columns needs neither the mesh's index nor its margin
  // (1.1 s and 0.4 s of 1.5 s for a first plan on the NRW tile).
  const bool on_columns = area.plans_on_columns(query.options);
  if (data.dsm && !on_columns) {
    report.safety_margin_m = area.safety_margin();
    report.mesh_max_below_dsm_m = area.mesh_max_below_dsm();
    report.column_max_above_mesh_m = area.column_max_above_mesh();
  }
  const GroundGrid& ground_in_use = area.ground();
  std::vector<Point3> waypoints = waypoints_in_crs(
      query.waypoints, query.heights,
      [&](double x, double y) {
        return -ground_in_use.height_above({x, y, 0});
      },
      data.names.waypoints, area.ground_name());
  out.waypoints = waypoints;
  std::vector<PlanResult::Invalid> early =
      in_stage(kCheckingWaypoints, [&] { return refused_before_planning(area, waypoints, query.options); });
  // Refused without --snap: before the index is built, unless it is needed to name the nearest
  // valid point (the planner's own check is one of the rules).
  if (!early.empty() && query.snap <= 0) {
    const WaypointRules rules(area, query.options);
    attempt.failure =
        refused(in_stage(kNamingNearest, [&] { return naming_nearest(std::move(early), waypoints, rules); }));
    return attempt;
  }
  report.index_reused = data.index != nullptr;
  if (!on_columns) out.index = area.shared_index();
  report.seconds_index = clock.lap();
  const WaypointRules checks(area, query.options);
  const PlanOptions& plan = checks.plan;
  // What a mission's straight items and vertical legs are held to: the DSM's columns when known,
  // else the mesh; the ceiling over the ground in use; the zones that block, at the safety distance.
  const std::shared_ptr<const GroundGrid> ground_held = area.shared_ground();
  const GroundGrid& ground = *ground_held;
  std::vector<PlanResult::Invalid> invalid =
      query.snap > 0
          ? in_stage("snapping the waypoints", [&] { return snap_waypoints(waypoints, query.snap, checks, report); })
          : in_stage(kNamingNearest, [&] {
              return naming_nearest(inside_zones(waypoints, data, &ground, plan.stop.get()), waypoints, checks);
            });
  out.waypoints = waypoints;
  if (!invalid.empty()) {
    attempt.failure = refused(std::move(invalid));
    return attempt;
  }
  const double safety = query.options.safety;
  const std::unique_ptr<ObstacleClearance> clearance =
      area.columns() ? std::unique_ptr<ObstacleClearance>(std::make_unique<ColumnsClearance>(*area.columns(), safety))
                     : std::make_unique<MeshClearance>(*out.index, safety);
  FlightRules rules{clearance.get(), &ground, plan.max_agl, {}, plan.stop.get()};
  for (const std::shared_ptr<const FlightConstraint>& constraint : plan.constraints)
    rules.constraints.push_back(constraint.get());

  std::vector<Point3> route = waypoints;
  const auto dsm_z = [&](double x, double y) { return area.columns() ? double(area.columns()->height_at(x, y)) : NAN; };
  if (query.mission) {
    const auto ground_z = [&](double x, double y) { return -ground.height_above({x, y, 0}); };
    out.site = mission_site(*query.mission, waypoints, ground_z);
    if (query.snap > 0)
      if (auto moved = snap_home(*out.site, waypoints, rules, dsm_z, query.snap,
                                 [&](const Point3& p) { return checks.valid(p); }))
        report.snapped.push_back(std::move(*moved));
    report.home_ground = report.ground;
    report.home_ground_uncertainty_m = ground.spread_at(out.site->home[0], out.site->home[1]);
  }
  const MissionSite* site = out.site ? &*out.site : nullptr;
  if (area.terrain()) {
    const auto surface_z = [&](double x, double y) {
      return area.columns() ? double(area.columns()->height_at(x, y)) : out.index->ground(x, y);
    };
    refuse_terrain_above(*area.terrain(), surface_z, waypoints, site, names.dtm,
                         area.columns() ? "the DSM " + names.dsm : "the mesh " + names.mesh);
  }
  if (site) {
    check_vertical_legs(*site, waypoints, rules, dsm_z);
    route = route_waypoints(waypoints, *site);
  }
  report.seconds_load = report.seconds_index + clock.lap();

  const FlightStore& store = query.store;
  const uint64_t roadmap_key = store.kept_roadmap ? area.roadmap_key() : 0;
  PlanResult result = in_stage("planning", [&] {
    if (plan.planner != PlannerKind::free_space)
      return run_planner(*out.index, route, plan, store, roadmap_key, report, clock, progress);
    const FreeAirspaceRules air_rules{[&rules](const Point3& p, const Point3& q) { return rules.keeps(p, q); },
                                      rules.constraints, plan.stop.get(), climb_weight(plan.objective)};
    const auto air = area.free_airspace(safety, plan.max_agl, plan.stop.get());
    report.seconds_roadmap = clock.lap();
    PlanResult planned = plan_free_airspace(*air, route, air_rules);
    planned.seconds_roadmap = report.seconds_roadmap;
    planned.roadmap_nodes = air->open_cells();  // the free airspace's cells are its nodes
    planned.roadmap_edges = 0;
    return planned;
  });
  take_planner_figures(result, report);
  if (result.status == PlanStatus::InvalidWaypoint && !result.invalid.empty()) {  // the planner's check: where instead
    result.invalid = in_stage(kNamingNearest, [&] { return naming_nearest(std::move(result.invalid), route, checks); });
    result.reason = result.invalid.front().reason;
  }
  if (result.status != PlanStatus::Solved) {
    attempt.failure = std::move(result);
    return attempt;
  }
  // A mission flies straight from item to item: as few items as keep the limits on those lines
  // (before the clearance below is measured on them).
  if (site || query.straight_legs)
    result.path = in_stage("merging straight legs", [&] { return merge_straight_legs(result.path, route, rules); });
  out.path = std::move(result.path);
  in_stage("measuring the path", [&] {
    measure_flight(out, area, query);
    measure_zones(out, data, rules, ground);
  });
  attempt.solved = true;
  return attempt;
}

FlightPlan plan_flight(const FlightArea& area, const FlightQuery& query, const Progress& progress) {
  FlightAttempt attempt = attempt_flight(area, query, progress);
  if (attempt.solved) return std::move(attempt.plan);
  const FlightPlan& out = attempt.plan;
  const MissionSite* site = out.site ? &*out.site : nullptr;
  FailureInWords words = failure_in_words(attempt.failure, site, query.waypoints.size());
  // Worth a word only when the mesh does not fit its DSM (more than a conservative mesh needs).
  const Grid* columns = area.columns();
  const double half_diagonal = columns ? std::hypot(columns->cell_x, columns->cell_y) / 2 : INFINITY;
  if (out.report.safety_margin_m > half_diagonal + 1e-9)
    words.why += " (on the mesh the safety distance is --safety " + two_decimals(query.options.safety) +
                 " widened by " + two_decimals(out.report.safety_margin_m) +
                 " m, as far as the DSM's columns may lie inside this mesh; a " +
                 "conservative mesh of the DSM itself needs half a cell diagonal)";
  throw InputError(area.data().names.waypoints, words.place, words.why);
}

FlightPlan plan_flight(const FlightRequest& request, const Progress& progress) {
  check_query(request, request.names);  // before the data are read through
  Stopwatch clock;
  const FlightArea area(request);
  const double prepared = clock.lap();
  FlightPlan out = plan_flight(area, request, progress);
  out.report.seconds_load += prepared;
  return out;
}

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

}  // namespace dsmplan
