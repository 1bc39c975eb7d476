// A mission's site (flight.hpp): home on the ground, a vertical takeoff, the legs to and from
// home planned like any other, and the vertical climb and descent checked against the data. The
// fewest straight items: straight_legs.cpp; the item order and what the autopilots check of it:
// src/io/mission_writers.cpp.
#include <array>
#include <cmath>
#include <optional>

#include "core/text.hpp"
#include "dsmplan/columns.hpp"
#include "dsmplan/flight.hpp"
#include "plan/nearest_spot.hpp"

namespace dsmplan {

namespace {

constexpr double kSameSpot = 1e-6;         // m: a home this close to the first waypoint is under it
constexpr double kTouchdown = 1.0;         // m above the ground where the check of a climb starts
constexpr double kWrittenRounding = 0.01;  // m: what plan_flight()'s verification allows for written decimals

bool same_point(const Point3& a, const Point3& b) {
  return std::abs(a[0] - b[0]) <= kSameSpot && std::abs(a[1] - b[1]) <= kSameSpot && std::abs(a[2] - b[2]) <= kSameSpot;
}

}  // namespace

MissionSite mission_site(const MissionEnds& options, const std::vector<Point3>& waypoints,
                         const std::function<double(double, double)>& ground_z) {
  MissionSite site;
  site.end = options.end.value_or(MissionEnd::rtl);
  const Point3& first = waypoints.front();
  const Point3& last = waypoints.back();
  const double under_first = ground_z(first[0], first[1]);
  if (!std::isfinite(under_first))
    throw DataFault("--home", "no ground under the first waypoint to count its height from");
  double x = first[0], y = first[1];
  const auto& [a, b] = options.home;
  if (!std::isnan(a) || !std::isnan(b)) {
    if (!std::isfinite(a) || !std::isfinite(b))
      throw ArgumentError("--home", "must be two finite numbers, x,y or lon,lat");
    const bool degrees = std::abs(a) <= 180 && std::abs(b) <= 90;
    if (degrees && !options.from_lonlat)
      throw ArgumentError("--home", "is in degrees, but no transformation from longitude, latitude was given");
    const Point3 p = degrees ? options.from_lonlat(a, b) : Point3{a, b, 0};
    x = p[0], y = p[1];
  }
  const double ground = ground_z(x, y);
  if (!std::isfinite(ground))
    throw DataFault("--home", "x " + two_decimals(x) + ", y " + two_decimals(y) +
                                  " lies outside the DSM (no ground known there to take off from)");
  site.home = {x, y, ground};
  site.takeoff_top = {x, y, ground + (first[2] - under_first)};
  site.leading = std::hypot(x - first[0], y - first[1]) > kSameSpot;
  if (!site.leading) site.takeoff_top = first;
  site.returns = site.end == MissionEnd::rtl && !same_point(last, site.takeoff_top);
  if (site.end == MissionEnd::land) {
    const double below = ground_z(last[0], last[1]);
    if (!std::isfinite(below)) throw DataFault("--end", "no ground known under the last waypoint to land on");
    site.land = {last[0], last[1], below};
  }
  return site;
}

std::vector<Point3> route_waypoints(const std::vector<Point3>& waypoints, const MissionSite& site) {
  std::vector<Point3> route;
  if (site.leading) route.push_back(site.takeoff_top);
  route.insert(route.end(), waypoints.begin(), waypoints.end());
  if (site.returns) route.push_back(site.takeoff_top);
  return route;
}

namespace {

// The vertical leg from `top` down to 1 m plus the safety distance above `ground` (or only `top`
// when it is lower) against the limits; the refusal names `flag` and what stands there.
void check_vertical(const Point3& top, double ground, const FlightRules& limits,
                    const std::function<double(double, double)>& dsm_z, const char* flag, const char* what) {
  const Point3 bottom{top[0], top[1], std::min(top[2], ground + kTouchdown + limits.obstacles->safety())};
  const double safety = limits.obstacles->safety();
  const double d = limits.obstacles->clearance(bottom, top);
  if (d >= safety - kWrittenRounding) {
    if (limits.ground && std::isfinite(limits.max_agl) &&
        !limits.ground->below_ceiling(bottom, top, limits.max_agl + 0.05))
      throw DataFault(flag, std::string("the ") + what + " rises above --max-agl " + two_decimals(limits.max_agl));
    // A zone holds from the ground up: a drone on the ground is in it too.
    const Point3 foot{top[0], top[1], std::min(top[2], ground)};
    for (const FlightConstraint* rule : limits.constraints)
      if (const FlightConstraint* zone = rule->refused_by(foot, top))
        throw DataFault(flag, std::string("the ") + what + " at x " + two_decimals(top[0]) + ", y " +
                                  two_decimals(top[1]) + " enters " + zone->name() +
                                  " or comes closer to it than the distance kept from the zones");
    return;
  }
  const double surface = dsm_z ? dsm_z(top[0], top[1]) : NAN;
  if (surface > ground + kTouchdown)
    throw DataFault(flag, std::string("under a roof or tree: the DSM stands ") + two_decimals(surface - ground) +
                              " m above the ground there (x " + two_decimals(top[0]) + ", y " + two_decimals(top[1]) +
                              ")");
  throw DataFault(flag, std::string("the ") + what + " at x " + two_decimals(top[0]) + ", y " + two_decimals(top[1]) +
                            (d <= 0 ? " goes through an obstacle"
                                    : " passes " + two_decimals(d) + " m from an obstacle, closer than --safety " +
                                          two_decimals(safety)) +
                            " (checked from " + two_decimals(kTouchdown) + " m plus --safety above the ground up)");
}

// The nearest place to `top` (within `radius`, horizontally, on the ground's cells) whose climb,
// as high above the ground as `top`'s, keeps the limits and whose top `top_valid` accepts (when
// given); NaN, NaN when there is none.
std::array<double, 2> nearest_clear_climb(const Point3& top, double ground, const FlightRules& limits,
                                          const std::function<double(double, double)>& dsm_z, double radius = 50,
                                          const std::function<bool(const Point3&)>& top_valid = {}) {
  if (!limits.ground || limits.ground->empty()) return {NAN, NAN};
  const double step = std::max(limits.ground->grid().cell_x, 0.5), above = top[2] - ground;
  std::array<double, 2> found{NAN, NAN};
  detail::search_rings(step, radius, 1, [&](double dx, double dy, double d) -> double {
    if (d > radius) return INFINITY;  // a ring's corners lie beyond it
    const double x = top[0] + dx, y = top[1] + dy;
    const double g = -limits.ground->height_above({x, y, 0});
    if (!std::isfinite(g)) return INFINITY;
    try {
      check_vertical({x, y, g + above}, g, limits, dsm_z, "--home", "climb from home");
    } catch (const DataFault&) {
      return INFINITY;
    }
    if (top_valid && !top_valid({x, y, g + above})) return INFINITY;
    found = {x, y};
    return d;
  });
  return found;
}

}  // namespace

void check_vertical_legs(const MissionSite& site, const std::vector<Point3>& waypoints, const FlightRules& limits,
                         const std::function<double(double, double)>& dsm_z) {
  try {
    check_vertical(site.takeoff_top, site.home[2], limits, dsm_z, "--home", "climb from home");
  } catch (const DataFault& error) {
    // Where it could take off instead: a user moves home there and runs again.
    const auto [x, y] = nearest_clear_climb(site.takeoff_top, site.home[2], limits, dsm_z);
    if (std::isnan(x)) throw DataFault("--home", error.problem() + "; no clear spot within 50 m");
    throw DataFault("--home",
                    error.problem() + "; the nearest clear spot: --home " + two_decimals(x) + "," + two_decimals(y) +
                        " (" + two_decimals(std::hypot(x - site.home[0], y - site.home[1])) + " m away)",
                    Point3{x, y, -limits.ground->height_above({x, y, 0})});
  }
  if (site.end == MissionEnd::land)
    check_vertical(waypoints.back(), site.land[2], limits, dsm_z, "--end", "descent to land");
}

std::optional<FlightReport::Snap> snap_home(MissionSite& site, const std::vector<Point3>& waypoints,
                                            const FlightRules& limits,
                                            const std::function<double(double, double)>& dsm_z, double radius,
                                            const std::function<bool(const Point3&)>& top_valid) {
  std::string why;
  try {
    check_vertical(site.takeoff_top, site.home[2], limits, dsm_z, "--home", "climb from home");
    return std::nullopt;
  } catch (const DataFault& error) {
    why = error.problem();
  }
  const auto [x, y] = nearest_clear_climb(site.takeoff_top, site.home[2], limits, dsm_z, radius, top_valid);
  if (std::isnan(x)) return std::nullopt;  // check_vertical_legs() refuses it, naming the nearest
  const double ground = -limits.ground->height_above({x, y, 0});
  FlightReport::Snap move{0, "home", site.home, {x, y, ground}, std::hypot(x - site.home[0], y - site.home[1]), why};
  site.takeoff_top = {x, y, ground + (site.takeoff_top[2] - site.home[2])};
  site.home = move.to;
  site.leading = true;  // the takeoff top is no longer the first waypoint: a leg leads to it
  site.returns = site.end == MissionEnd::rtl && !same_point(waypoints.back(), site.takeoff_top);
  return move;
}

std::string mission_place(const PlanResult& result, const MissionSite& site, size_t user_waypoints) {
  const size_t leading = site.leading ? 1 : 0;
  const size_t count = user_waypoints + leading + (site.returns ? 1 : 0);
  const size_t w = result.waypoint;
  if (result.status == PlanStatus::InvalidWaypoint) {
    if ((site.leading && w == 0) || (site.returns && w + 1 == count)) return "the takeoff's top above --home";
    return "waypoint " + std::to_string(w - leading + 1);
  }
  if (result.status == PlanStatus::NoPath) {
    if (site.leading && w == 0) return "the leg from the takeoff above --home to waypoint 1";
    if (site.returns && w + 2 == count)
      return "the leg from waypoint " + std::to_string(user_waypoints) + " back above home (--end rtl)";
    return "waypoints " + std::to_string(w - leading + 1) + " to " + std::to_string(w - leading + 2);
  }
  return {};
}

RouteFailure route_failure(const PlanResult& result, const MissionSite* site, size_t user_waypoints) {
  const size_t leading = site && site->leading ? 1 : 0;
  const size_t count = user_waypoints + leading + (site && site->returns ? 1 : 0);
  // A waypoint of the planner's route as the user numbers it: 0 for the takeoff's top.
  const auto user_number = [&](size_t w) -> size_t {
    if ((leading && w == 0) || (site && site->returns && w + 1 == count)) return 0;
    return w - leading + 1;
  };
  RouteFailure failure;
  if (result.status == PlanStatus::InvalidWaypoint) {
    failure.code = "waypoint_refused";
    failure.waypoint = user_number(result.waypoint);
    if (!result.invalid.empty()) failure.nearest = result.invalid.front().nearest;
  } else if (result.status == PlanStatus::NoPath) {
    failure.code = "no_path";
    failure.leg = {{user_number(result.waypoint), user_number(result.waypoint + 1)}};
  }
  return failure;
}

FailureInWords failure_in_words(const PlanResult& result, const MissionSite* site, size_t user_waypoints) {
  const auto place = [&](const PlanResult& r) { return site ? mission_place(r, *site, user_waypoints) : r.place(); };
  return {place(result), result.problems([&](size_t k) {
            PlanResult other = result;
            other.waypoint = k;
            return place(other);
          })};
}

void check_vertical_legs_in(GridSource& dsm, const MissionSite& site, const std::vector<Point3>& waypoints,
                            double safety, const ZonesAround& zones) {
  const Grid& frame = dsm.frame();
  const auto check = [&](const Point3& top, double ground, const char* flag, const char* what) {
    const double r = safety + 2 * std::max(frame.cell_x, frame.cell_y);
    const int c0 = std::max(0, static_cast<int>(std::floor((top[0] - r - frame.x0) / frame.cell_x)));
    const int r0 = std::max(0, static_cast<int>(std::floor((frame.y0 - top[1] - r) / frame.cell_y)));
    const int c1 = std::min(frame.width, static_cast<int>(std::ceil((top[0] + r - frame.x0) / frame.cell_x)));
    const int r1 = std::min(frame.height, static_cast<int>(std::ceil((frame.y0 - top[1] + r) / frame.cell_y)));
    if (c1 <= c0 || r1 <= r0) throw DataFault(flag, "lies outside the DSM");
    Grid columns = read_window(dsm, c0, r0, c1 - c0, r1 - r0);
    // The zones' AGL limits count from the terrain, else from the DSM read here.
    const std::shared_ptr<const GroundGrid> zone_ground =
        zones.terrain ? zones.terrain : std::make_shared<const GroundGrid>(columns);
    fill_holes_from_rim(columns, RimHeight::highest);
    const ColumnsClearance obstacles(columns, safety);
    FlightRules limits{&obstacles, nullptr, INFINITY, {}};
    const double keep = std::isnan(zones.distance) ? safety : zones.distance;
    const auto held = zones.zones ? airspace_constraints(*zones.zones, keep, zone_ground, zones.airspace)
                                  : std::vector<std::shared_ptr<const FlightConstraint>>{};
    for (const auto& zone : held) limits.constraints.push_back(zone.get());
    check_vertical(
        top, ground, limits, [&](double x, double y) { return columns.height_at(x, y); }, flag, what);
  };
  check(site.takeoff_top, site.home[2], "--home", "climb from home");
  if (site.end == MissionEnd::land) check(waypoints.back(), site.land[2], "--end", "descent to land");
}

}  // namespace dsmplan
