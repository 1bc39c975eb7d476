// What plan_job() does for a mission (.plan, .waypoints): where it takes off and lands, the
// legs that takes, the checks of the vertical climb and descent, and the fewest straight items.
#pragma once

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "dsmplan/columns.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/plan_job.hpp"

namespace dsmplan::detail {

/// What a straight segment of a mission is held to, measured on the data: the safety distance
/// to the DSM's columns (holes as high as their rim) or, without a DSM, to the mesh; the
/// ceiling above `ground` when there is one.
struct FlightLimits {
  const Grid* columns = nullptr;
  const ClearanceIndex* mesh = nullptr;
  const GroundGrid* ground = nullptr;
  double safety = 0, max_agl = INFINITY;
  /// min(safety, distance of the segment to the obstacles).
  double clearance(const Point3& p, const Point3& q) const;
  bool keeps(const Point3& p, const Point3& q) const;
};

/// The fewest points of `path` (first and last kept, and every one of `waypoints`, which the
/// path passes in order) whose straight segments keep `limits`: greedy, from each kept point to
/// the farthest point before the first whose direct segment fails. Every segment of the result
/// keeps the limits, or is one of `path`'s own. O(n x run) clearance queries.
std::vector<Point3> fewest_straight_legs(const std::vector<Point3>& path, const std::vector<Point3>& waypoints,
                                         const FlightLimits& limits);

/// Home, the top of the takeoff above it, and the landing; the legs they add to the route.
struct MissionSite {
  Point3 home{NAN, NAN, NAN};         ///< x, y in the CRS; z the ground there
  Point3 takeoff_top{NAN, NAN, NAN};  ///< above home, as high above the ground as the first waypoint
  Point3 land{NAN, NAN, NAN};         ///< --end land: the ground under the last waypoint
  MissionEnd end = MissionEnd::rtl;
  bool leading = false;  ///< the takeoff top is a waypoint of its own, before the first
  bool returns = false;  ///< a leg back to the takeoff top follows the last waypoint
};

/// The site of a mission through `waypoints` (CRS). `ground_z(x, y)`: the ground's height there,
/// not finite where unknown; `from_lonlat`: longitude, latitude to x, y in the CRS (for a home in
/// degrees). InputError/ArgumentError("--home") for a home or landing over no ground.
MissionSite mission_site(const MissionJobOptions& options, const std::vector<Point3>& waypoints,
                         const std::function<double(double, double)>& ground_z,
                         const std::function<Point3(double, double)>& from_lonlat);

/// The waypoints the planner goes through: the takeoff top first when it is a leg of its own,
/// the takeoff top last when the mission returns.
std::vector<Point3> route_waypoints(const std::vector<Point3>& waypoints, const MissionSite& site);

/// ArgumentError("--home") or ArgumentError("--end") when the vertical climb at home or the
/// descent at the landing passes nearer the obstacles than the safety distance (less 1 cm)
/// from 1 m plus `safety` above the ground up, or rises above the ceiling; `dsm`, when known,
/// also refuses a home or landing under a roof or tree (DSM more than 1 m above the ground).
void check_vertical_legs(const MissionSite& site, const std::vector<Point3>& waypoints, const FlightLimits& limits,
                         const std::function<double(double, double)>& dsm_z);

/// The planner's place of a failure in the user's words: "waypoint k" of the user's file, or
/// the takeoff above --home, or the leg back above home (--end rtl).
std::string mission_place(const PlanResult& result, const MissionSite& site, size_t user_waypoints);

/// check_vertical_legs() for a DSM read window by window (plan along a corridor): the columns
/// around each vertical leg read from `dsm` (holes as high as their rim); no ceiling check (the
/// takeoff top is as high above the ground as the first waypoint, which is checked).
void check_vertical_legs_in(GridSource& dsm, const MissionSite& site, const std::vector<Point3>& waypoints,
                            double safety);

}  // namespace dsmplan::detail
