// What every planner of plan.hpp shares: waypoint checks and the path's finishing (smoothing,
// assembly, the last clearance check), so PRM and RRT-Connect answer alike.
#pragma once

#include <string>
#include <vector>

#include "dsmplan/plan.hpp"

namespace dsmplan::detail {

/// The validity checker every planner asks, in OMPL's sense (StateValidityChecker and
/// MotionValidator in one): a state or a straight motion is valid when it keeps the safety
/// distance from every triangle of the mesh and no point of it is more than max_agl above the
/// ground (options.ground, else the mesh's floor). New constraints belong here, not in a planner.
class FlightSpace {
public:
  FlightSpace(const ClearanceIndex& index, const PlanOptions& options)
      : index_(index), ground_(options.ground ? *options.ground : index.floor()), safety_(options.safety),
        max_agl_(options.max_agl) {}
  const ClearanceIndex& index() const { return index_; }
  const GroundGrid& ground() const { return ground_; }
  double safety() const { return safety_; }
  double max_agl() const { return max_agl_; }
  /// The top of the flight volume at (x, y): max_agl above the ground there (-inf over none).
  double ceiling_at(double x, double y) const { return max_agl_ - ground_.height_above({x, y, 0}); }
  /// The point `u` (in [0, 1)) of the way from the surface `surface` (ClearanceIndex::ground())
  /// up to the ceiling at (x, y): how every planner draws a sample. False where there is no room.
  bool place(double x, double y, double surface, double u, Point3& out) const {
    const double top = ceiling_at(x, y);
    if (std::isnan(surface) || !(top > surface)) return false;
    out = {x, y, surface + u * (top - surface)};
    return true;
  }
  bool below_ceiling(const Point3& p) const { return ground_.height_above(p) <= max_agl_; }
  bool below_ceiling(const Point3& p, const Point3& q) const { return ground_.below_ceiling(p, q, max_agl_); }
  bool state_valid(const Point3& p) const { return below_ceiling(p) && index_.point_clear(p, safety_); }
  /// The ceiling first: a walk over a few cells costs less than the clearance.
  bool motion_valid(const Point3& p, const Point3& q) const {
    return below_ceiling(p, q) && index_.segment_clear(p, q, safety_);
  }

private:
  const ClearanceIndex& index_;
  const GroundGrid& ground_;
  double safety_, max_agl_;
};

inline double distance(const Point3& a, const Point3& b) {
  return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

/// A number with two decimals, for messages.
std::string format_number(double v);

/// ArgumentError("waypoints") for fewer than two or a non-finite one.
void check_waypoint_list(const std::vector<Point3>& waypoints);

/// Marks `result` InvalidWaypoint for the first waypoint that cannot be flown to (outside the
/// extent, under the surface, closer than the safety distance); false if none.
bool first_invalid_waypoint(const std::vector<Point3>& waypoints, const FlightSpace& space, PlanResult& result);

/// Joins the legs (each from one waypoint to the next, every segment clear) into
/// result.raw_path and, smoothed leg by leg when options.smooth (path_smoothing.cpp),
/// result.path; checks every segment of the path once more (std::logic_error if one is not
/// clear: a bug, never a user's error) and marks the result Solved.
void finish_path(const std::vector<std::vector<Point3>>& legs, const FlightSpace& space, const PlanOptions& options,
                 PlanResult& result);

}  // namespace dsmplan::detail
