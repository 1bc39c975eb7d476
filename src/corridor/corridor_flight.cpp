// plan_flight_along(): plan_flight()'s rules for a city read window by window (dsmplan/corridor.hpp):
// the terrain beside and below the DSM, a mission's home, takeoff and landing checked against the
// DSM read around them, then plan_corridor(), whose pieces are flights verified on their windows.
#include <algorithm>
#include <cmath>

#include "core/stopwatch.hpp"
#include "dsmplan/corridor.hpp"

namespace dsmplan {

namespace {

// The DSM's 3 x 3 cells around (x, y) as the ground (GroundGrid: a point on a cell's edge counts
// the lowest cell it touches, as over a mesh with its DSM); empty outside the DSM.
GroundGrid dsm_ground_around(GridSource& city, double x, double y) {
  const Grid& frame = city.frame();
  int col = 0, row = 0;
  if (!frame.cell_at(x, y, col, row)) return {};
  const int c0 = std::max(0, col - 1), r0 = std::max(0, row - 1);
  return GroundGrid(
      read_window(city, c0, r0, std::min(frame.width, col + 2) - c0, std::min(frame.height, row + 2) - r0));
}

// The corridor's ground at (x, y): the DTM, else the DSM read around it; NaN where unknown.
double corridor_ground(GridSource& city, const GroundGrid* terrain, double x, double y) {
  const double above =
      terrain ? terrain->height_above({x, y, 0}) : dsm_ground_around(city, x, y).height_above({x, y, 0});
  return std::isfinite(above) ? -above : NAN;
}

// How uncertain the ground under home is (GroundGrid::spread_at()).
double corridor_home_spread(GridSource& city, const GroundGrid* terrain, const Point3& home) {
  if (terrain) return terrain->spread_at(home[0], home[1]);
  return dsm_ground_around(city, home[0], home[1]).spread_at(home[0], home[1]);
}

// The DTM against the DSM a row at a time: the comparison walks its lattice row by row.
void check_corridor_terrain(GridSource& city, const GroundGrid& terrain, const std::vector<Point3>& waypoints,
                            const MissionSite* site, const FlightNames& names) {
  const Grid& frame = city.frame();
  std::vector<float> heights(frame.width);
  int row_read = -1;
  const auto surface_z = [&](double x, double y) {
    int col = 0, row = 0;
    if (!frame.cell_at(x, y, col, row)) return double(NAN);
    if (row != row_read) city.read(0, row, frame.width, 1, heights.data()), row_read = row;
    return double(heights[col]);
  };
  refuse_terrain_above(terrain, surface_z, waypoints, site, names.dtm, "the DSM " + names.mesh);
}

void take_corridor_figures(const CorridorResult& planned, FlightReport& report) {
  const PlanResult& result = planned.plan;
  report.seconds_load += planned.seconds_windows;
  report.roadmap_nodes = result.roadmap_nodes, report.roadmap_edges = result.roadmap_edges;
  report.seconds_roadmap = result.seconds_roadmap, report.seconds_query = result.seconds_query;
  report.seconds_smooth = result.seconds_smooth, report.refined_samples = result.refined_samples;
  report.corridor_windows = planned.windows;
  report.corridor_largest_window_cells = planned.largest_window_cells;
  report.path_points = result.path.size();
  report.path_length_m = path_length(result.path);
  // Each piece was verified on its window (plan_flight()'s verification): the least and the most.
  report.min_clearance_m = planned.min_clearance_m;
  report.min_clearance_dsm_m = planned.min_clearance_dsm_m;
  report.mesh_max_below_dsm_m = planned.mesh_error.max_below;
  report.safety_margin_m = planned.safety_margin_m;
  report.dsm_tolerance_m = 0.01;
  report.max_agl_m = planned.max_agl_m;
  report.no_fly_zones = planned.no_fly_zones;
}

}  // namespace

FlightPlan plan_flight_along(GridSource& city, const CorridorRequest& request, const Progress& progress) {
  Stopwatch clock;
  FlightPlan out;
  FlightReport& report = out.report;
  const FlightNames& names = request.names;
  // Snapping holds a moved point to the columns around it, which a corridor reads window by window.
  if (request.snap != 0)
    throw ArgumentError("snap", "applies to a mesh input; the DSM " + names.mesh + " is planned along a corridor");
  CorridorOptions along = request.corridor;
  const Grid& frame = city.frame();
  if (request.dtm) {
    require_beside(*request.dtm, names.dtm, "DTM", frame.crs, frame.x0, frame.y1(), frame.x1(), frame.y0);
    along.terrain = std::make_shared<GroundGrid>(*request.dtm);
  }
  report.planner = planner_name(request.options.planner);
  report.waypoint_count = request.waypoints.size();
  report.ground = along.terrain ? "dtm" : "dsm";
  const GroundGrid* terrain = along.terrain.get();
  out.waypoints = waypoints_in_crs(
      request.waypoints, request.heights, [&](double x, double y) { return corridor_ground(city, terrain, x, y); },
      names.waypoints, report.ground);
  const std::vector<Point3>& waypoints = out.waypoints;
  std::vector<Point3> route = waypoints;
  if (request.mission) {
    out.site = mission_site(*request.mission, waypoints,
                            [&](double x, double y) { return corridor_ground(city, terrain, x, y); });
    report.home_ground = report.ground;
    report.home_ground_uncertainty_m = corridor_home_spread(city, terrain, out.site->home);
    along.straight_legs = true;  // a mission flies straight from item to item
  }
  const MissionSite* site = out.site ? &*out.site : nullptr;
  if (along.terrain) check_corridor_terrain(city, *along.terrain, waypoints, site, names);
  if (site) {
    check_vertical_legs_in(city, *site, waypoints, request.options.safety,
                           {&request.no_fly, request.airspace, along.terrain, zone_keep_distance(request.options)});
    route = route_waypoints(waypoints, *site);
  }
  report.seconds_load = clock.lap();
  const CorridorResult planned = plan_corridor(city, route, request.options, along, sub_progress(progress, 0, 0.95),
                                               names, request.no_fly, request.airspace);
  take_corridor_figures(planned, report);
  if (planned.plan.status != PlanStatus::Solved) {
    const FailureInWords words = failure_in_words(planned.plan, site, waypoints.size());
    throw InputError(names.waypoints, words.place, words.why);
  }
  out.path = planned.plan.path;
  if (site) report_site(*site, report);
  return out;
}

}  // namespace dsmplan
