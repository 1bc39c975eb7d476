// dsmplan/flight_space.hpp: where the drone may be. The validity checker every planner of
// plan.hpp asks (OMPL's StateValidityChecker and MotionValidator in one), and the constraints
// that plug into it.
//
// A point or a straight motion is valid when
//   - it keeps the safety distance from every triangle of the mesh (ClearanceIndex, exact),
//   - no point of it is more than max_agl above the ground (PlanOptions::ground, else the mesh's
//     floor; GroundGrid::below_ceiling(), exact over the ground's cells),
//   - and every FlightConstraint of PlanOptions::constraints allows it.
// PRM (roadmap, query, refinement, lattice), RRT-Connect, the smoothing and the corridor planner
// ask this one class and nothing else, so a new rule (a geofence, a no-fly zone, a corridor the
// authority allows) is a FlightConstraint, written once, and holds for every planner and for
// every segment of every path, not only for the samples.
//
// Complexity: the ceiling is a walk over the ground cells the segment crosses (few, by blocks);
// the clearance as ClearanceIndex; each constraint as its own motion_valid().
#pragma once

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/clearance.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/ground.hpp"

namespace dsmplan {

/// A rule on where the drone may fly, beside the clearance and the ceiling. Implementations must
/// be exact or conservative (never call an invalid motion valid), deterministic, and safe to
/// call from many threads at once (the roadmap checks edges in parallel).
class FlightConstraint {
public:
  virtual ~FlightConstraint() = default;
  /// True when the drone may be at `p`.
  virtual bool state_valid(const Point3& p) const = 0;
  /// True when every point of the straight segment p-q is allowed.
  virtual bool motion_valid(const Point3& p, const Point3& q) const = 0;
  /// What it is, for messages: "no-fly zone 'stadium'".
  virtual std::string name() const = 0;
  /// The constraint a message should name for the motion p-q (p = q: the point): this one when it
  /// refuses the motion, null when it allows it; a set of rules (ZoneSet) names its member.
  virtual const FlightConstraint* refused_by(const Point3& p, const Point3& q) const {
    return motion_valid(p, q) ? nullptr : this;
  }
};

/// A no-fly zone: the vertical prism over a simple polygon (x, y in the mesh's CRS, either
/// orientation, closed or not), from `bottom` to `top` (CRS heights; -inf/+inf: all heights).
/// Its boundary belongs to it. Exact for segments: the part of a segment within the prism's
/// height range is clipped first, then tested against the polygon (an end inside, or a crossing
/// with an edge). ArgumentError("no_fly_zone") for fewer than 3 corners, a non-finite one, or
/// bottom > top. O(corners) a check.
class NoFlyZone : public FlightConstraint {
public:
  NoFlyZone(std::string name, std::vector<std::array<double, 2>> polygon, double bottom = -INFINITY,
            double top = INFINITY);
  bool state_valid(const Point3& p) const override;
  bool motion_valid(const Point3& p, const Point3& q) const override;
  std::string name() const override { return "no-fly zone '" + name_ + "'"; }

private:
  bool inside(double x, double y) const;  ///< in the polygon or on its boundary
  std::string name_;
  std::vector<std::array<double, 2>> polygon_;
  double bottom_, top_;
  double xmin_, xmax_, ymin_, ymax_;
};

/// The flight volume a plan runs in: the mesh's clearance, the ceiling over the ground, the
/// constraints. Holds references: the index, the ground, the constraints and `stop` must outlive
/// it. With a `stop` (core.hpp), every check below first calls stop->check(), which throws
/// Cancelled once the request is given up on: so every search over this space can be stopped.
class FlightSpace {
public:
  FlightSpace(const ClearanceIndex& index, const GroundGrid& ground, double safety, double max_agl,
              std::vector<const FlightConstraint*> constraints = {}, const StopToken* stop = nullptr)
      : index_(index),
        ground_(ground),
        safety_(safety),
        max_agl_(max_agl),
        constraints_(std::move(constraints)),
        stop_(stop) {}

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
  /// The first constraint `p` or the motion p-q breaks, or null.
  const FlightConstraint* broken_by(const Point3& p) const {
    for (const FlightConstraint* c : constraints_)
      if (!c->state_valid(p)) return c;
    return nullptr;
  }
  const FlightConstraint* broken_by(const Point3& p, const Point3& q) const {
    for (const FlightConstraint* c : constraints_)
      if (!c->motion_valid(p, q)) return c;
    return nullptr;
  }
  /// Everything but the mesh: under the ceiling and allowed by every constraint (the roadmap
  /// proves most edges clear of the mesh without a segment check, never these).
  bool within_limits(const Point3& p) const {
    check_stop();
    return below_ceiling(p) && !broken_by(p);
  }
  bool within_limits(const Point3& p, const Point3& q) const {
    check_stop();
    return below_ceiling(p, q) && !broken_by(p, q);
  }
  /// Throws Cancelled when the request was given up on (no-op without a stop).
  void check_stop() const { dsmplan::check_stop(stop_); }

  bool state_valid(const Point3& p) const { return within_limits(p) && index_.point_clear(p, safety_); }
  /// The ceiling and the constraints first: a walk over a few cells costs less than the clearance.
  bool motion_valid(const Point3& p, const Point3& q) const {
    return within_limits(p, q) && index_.segment_clear(p, q, safety_);
  }
  /// A quick refusal from the two ground rasters alone (no triangle read, no walk), for the
  /// planners' candidate motions, most of which fail: true when a point of [p, q] sampled once a
  /// cell is less than the safety distance above the mesh's floor (GroundGrid::dips_below on
  /// ClearanceIndex::floor()), or above the ceiling. Then motion_valid(p, q) is false too
  /// when p and q are valid states and the mesh covers the cells between them: such a point is
  /// within the safety distance of the surface below it, or under that surface, which a segment
  /// from above it must cross (the floor's holes, cells no triangle meets, are left out). False
  /// proves nothing. O(cells crossed).
  bool surely_invalid(const Point3& p, const Point3& q) const {
    check_stop();
    return index_.floor().dips_below(p, q, safety_) || ground_.rises_above(p, q, max_agl_);
  }
  /// motion_valid(p, q) with surely_invalid(p, q) asked first: the same answer between valid
  /// states, for candidate motions many of which fail.
  bool candidate_valid(const Point3& p, const Point3& q) const { return !surely_invalid(p, q) && motion_valid(p, q); }

private:
  const ClearanceIndex& index_;
  const GroundGrid& ground_;
  double safety_, max_agl_;
  std::vector<const FlightConstraint*> constraints_;
  const StopToken* stop_;
};

}  // namespace dsmplan
