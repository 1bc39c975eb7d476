// What every planner of plan.hpp shares: waypoint checks and the path's finishing (smoothing,
// assembly, the last clearance check), so PRM and RRT-Connect answer alike.
#pragma once

#include <string>
#include <vector>

#include "dsmplan/plan.hpp"

namespace dsmplan::detail {

/// The flight space of a plan (flight_space.hpp): the index, options.ground (else the mesh's
/// floor), the safety distance, the ceiling, options.constraints and options.stop.
inline FlightSpace flight_space(const ClearanceIndex& index, const PlanOptions& options) {
  std::vector<const FlightConstraint*> rules;
  for (const auto& rule : options.constraints)
    if (rule) rules.push_back(rule.get());
  return FlightSpace(index, options.ground ? *options.ground : index.floor(), options.safety, options.max_agl,
                     std::move(rules), options.stop.get());
}

inline double distance(const Point3& a, const Point3& b) { return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }

/// A number with two decimals, for messages.
std::string format_number(double v);

/// ArgumentError("waypoints") for fewer than two or a non-finite one.
void check_waypoint_list(const std::vector<Point3>& waypoints);

/// Marks `result` InvalidWaypoint when a waypoint cannot be flown to (outside the extent, under
/// the surface, closer than the safety distance), `invalid` listing every such one; false if none.
bool invalid_waypoints(const std::vector<Point3>& waypoints, const FlightSpace& space, PlanResult& result);

/// Joins the legs (each from one waypoint to the next, every segment clear) into
/// result.raw_path and, smoothed leg by leg when options.smooth (path_smoothing.cpp),
/// result.path; checks every segment of the path once more (std::logic_error if one is not
/// clear: a bug, never a user's error) and marks the result Solved.
void finish_path(const std::vector<std::vector<Point3>>& legs, const FlightSpace& space, const PlanOptions& options,
                 PlanResult& result);

}  // namespace dsmplan::detail
