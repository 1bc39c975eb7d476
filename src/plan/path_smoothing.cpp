// Finishing a planned path: greedy shortcuts as OMPL's PathSimplifier::shortcutPath does them
// deterministically (Geraerts & Overmars, "Creating High-quality Paths for Motion Planning",
// IJRR 26(8), 2007), then corner rounding by the clamped uniform quadratic B-spline of the
// shortcut polygon (de Boor, "A Practical Guide to Splines", 1978; each span is the quadratic
// Bezier from the middle of one segment over the corner to the middle of the next, as in
// Chaikin's corner cutting, Chaikin 1974), drawn as chords and every chord re-checked.
// Also the waypoint checks every planner runs first.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "core/text.hpp"
#include "dsmplan/plan.hpp"
#include "plan/path_parts.hpp"

namespace dsmplan {

namespace detail {

std::string format_number(double v) { return two_decimals(v); }

void check_waypoint_list(const std::vector<Point3>& waypoints) {
  if (waypoints.size() < 2)
    throw ArgumentError("waypoints", "need at least two, got " + std::to_string(waypoints.size()));
  for (size_t i = 0; i < waypoints.size(); ++i)
    for (double v : waypoints[i])
      if (!std::isfinite(v)) throw ArgumentError("waypoints", "waypoint " + std::to_string(i + 1) + " is not finite");
}

namespace {

// Why waypoint `w` cannot be flown to, or empty when it can.
std::string waypoint_problem(const Point3& w, const FlightSpace& space) {
  const ClearanceIndex& index = space.index();
  const double safety = space.safety();
  const ClearanceIndex::Footprint& e = index.footprint();
  if (!(w[0] >= e.xmin && w[0] <= e.xmax && w[1] >= e.ymin && w[1] <= e.ymax))
    return "outside the mesh's extent (x " + format_number(e.xmin) + " to " + format_number(e.xmax) + ", y " +
           format_number(e.ymin) + " to " + format_number(e.ymax) + ")";
  const double g = index.ground(w[0], w[1]);
  if (std::isnan(g)) return "outside the mesh's extent (over a hole: no surface below it)";
  if (w[2] < g) return "under the surface (z " + format_number(w[2]) + ", surface " + format_number(g) + ")";
  if (!index.point_clear(w, safety))
    return "closer than the safety distance " + format_number(safety) + " to the mesh (clearance " +
           format_number(index.clearance(w, w, safety)) + ")";
  if (!space.below_ceiling(w)) {
    const double above = space.ground().height_above(w);
    return std::isinf(above) ? "outside the ground's extent (no ground below it to count --max-agl from)"
                             : "above the ceiling: " + format_number(above) + " m above the ground, --max-agl " +
                                   format_number(space.max_agl());
  }
  if (const FlightConstraint* rule = space.broken_by(w)) {
    const FlightConstraint* named = rule->refused_by(w, w);  // a set's member, by its own name
    return "inside the " + (named ? named : rule)->name();
  }
  return {};
}

// space.motion_valid(p, q), with cheap refusals first, since nearly all the candidates below
// fail: the ground rasters' samples (FlightSpace::surely_invalid: most failing shortcuts cut
// through a building or rise over the ceiling), then three point checks (a motion is valid only
// if each of its points is), both cheaper than the segment's exact check. The answer is
// motion_valid's (p and q are points of a checked path).
bool shortcut_valid(const FlightSpace& space, const Point3& p, const Point3& q) {
  if (space.surely_invalid(p, q)) return false;
  for (double t : {0.5, 0.25, 0.75})
    if (!space.state_valid({p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), p[2] + t * (q[2] - p[2])}))
      return false;
  return space.motion_valid(p, q);
}

// From each point, straight on to the farthest later point the segment to which is clear
// (the next point always is: it is a checked edge), tried from the far end down. Nearly every
// candidate is refused by shortcut_valid's quick checks, so one core does it: with the
// refusals that cheap, spreading a point's candidates over both cores measured no faster
// (bench/README.md, issue 14).
std::vector<Point3> shortcut(const std::vector<Point3>& leg, const FlightSpace& space) {
  std::vector<Point3> out{leg.front()};
  for (size_t i = 0; i + 1 < leg.size();) {
    size_t j = leg.size() - 1;
    while (j > i + 1 && !shortcut_valid(space, leg[i], leg[j])) --j;
    out.push_back(leg[j]);
    i = j;
  }
  return out;
}

Point3 lerp(const Point3& a, const Point3& b, double t) {
  return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

// The chords of corner c's curve, from a point on the incoming segment (from a) to one on the
// outgoing segment (to b): the quadratic Bezier over the corner from half of each segment (the
// clamped quadratic B-spline of the polygon), or cutting a quarter, an eighth, a sixteenth when
// a chord is not clear; empty when none is (the corner stays sharp). The curve lies in the
// triangle of its ends and the corner and is convex, so it is no longer than the two straight
// pieces it replaces, and its chords are shorter still: rounding never makes the path longer.
std::vector<Point3> corner_curve(const Point3& a, const Point3& c, const Point3& b, const FlightSpace& space) {
  constexpr double kChord = 2.0;  // CRS units: chords of about 2 m follow the curve within cm
  constexpr int kTries = 4;       // cuts of 1/2, 1/4, 1/8, 1/16 of each segment
  for (int attempt = 0; attempt < kTries; ++attempt) {
    const double t = 0.5 / static_cast<double>(1 << attempt);
    const Point3 p0 = lerp(c, a, t), p2 = lerp(c, b, t);
    const double length = distance(p0, c) + distance(c, p2);
    const int pieces = std::clamp(static_cast<int>(std::ceil(length / kChord)), 2, 64);
    std::vector<Point3> points{p0};
    bool clear = true;
    for (int i = 1; i <= pieces && clear; ++i) {
      const double s = static_cast<double>(i) / pieces;
      points.push_back(lerp(lerp(p0, c, s), lerp(c, p2, s), s));
      clear = space.candidate_valid(points[i - 1], points[i]);
    }
    if (clear) return points;
  }
  return {};
}

// The polygon with each interior corner replaced by its curve's chords. A curve cuts at most half
// of each segment, so neighbouring curves never overlap and the straight pieces between them lie
// on the polygon's checked segments: the corners are independent, and rounded on every core.
std::vector<Point3> round_corners(const std::vector<Point3>& polygon, const FlightSpace& space) {
  if (polygon.size() < 3) return polygon;
  std::vector<std::vector<Point3>> curves(polygon.size());
  tbb::parallel_for(size_t{1}, polygon.size() - 1,
                    [&](size_t k) { curves[k] = corner_curve(polygon[k - 1], polygon[k], polygon[k + 1], space); });
  std::vector<Point3> out{polygon.front()};
  for (size_t k = 1; k + 1 < polygon.size(); ++k) {
    const std::vector<Point3>& curve = curves[k];
    if (curve.empty()) {
      out.push_back(polygon[k]);
      continue;
    }
    if (distance(curve.front(), out.back()) > 0) out.push_back(curve.front());
    out.insert(out.end(), curve.begin() + 1, curve.end());
  }
  out.push_back(polygon.back());
  return out;
}

}  // namespace

bool invalid_waypoints(const std::vector<Point3>& waypoints, const FlightSpace& space, PlanResult& result) {
  result.invalid.clear();
  for (size_t i = 0; i < waypoints.size(); ++i) {
    std::string problem = waypoint_problem(waypoints[i], space);
    if (!problem.empty()) result.invalid.push_back({i, std::move(problem)});
  }
  if (result.invalid.empty()) return false;
  result.status = PlanStatus::InvalidWaypoint;
  result.waypoint = result.invalid.front().waypoint;
  result.reason = result.invalid.front().reason;
  return true;
}

void finish_path(const std::vector<std::vector<Point3>>& legs, const FlightSpace& space, const PlanOptions& options,
                 PlanResult& result) {
  result.path.clear();
  result.raw_path.clear();
  for (size_t i = 0; i < legs.size(); ++i) {
    std::vector<Point3> smooth = legs[i];
    if (options.smooth) smooth = shortcut(smooth, space);
    if (options.spline) smooth = round_corners(smooth, space);
    for (size_t k = i ? 1 : 0; k < legs[i].size(); ++k) result.raw_path.push_back(legs[i][k]);
    for (size_t k = i ? 1 : 0; k < smooth.size(); ++k) result.path.push_back(smooth[k]);
  }
  // Every segment was checked on its way in; this says so once more, on every core, because a
  // path that is not clear must never leave the library.
  const bool clear = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(1, result.path.size(), 64), true,
      [&](const tbb::blocked_range<size_t>& range, bool ok) {
        for (size_t k = range.begin(); ok && k < range.end(); ++k)
          ok = space.motion_valid(result.path[k - 1], result.path[k]);
        return ok;
      },
      [](bool a, bool b) { return a && b; });
  if (!clear) throw std::logic_error("planner produced a segment closer than the safety distance or above the ceiling");
  result.status = PlanStatus::Solved;
}

}  // namespace detail

std::string PlanResult::place() const {
  switch (status) {
    case PlanStatus::Solved:
      return {};
    case PlanStatus::InvalidWaypoint:
      return "waypoint " + std::to_string(waypoint + 1);
    case PlanStatus::NoPath:
      return "waypoints " + std::to_string(waypoint + 1) + " to " + std::to_string(waypoint + 2);
  }
  return {};
}

std::string waypoint_problems(const std::vector<PlanResult::Invalid>& invalid,
                              const std::function<std::string(size_t)>& name) {
  constexpr size_t kListed = kListedWaypoints;
  if (invalid.empty()) return {};
  std::string text = invalid.front().reason;
  for (size_t k = 1; k < invalid.size() && k <= kListed; ++k)
    text += "; also " + (name ? name(invalid[k].waypoint) : "waypoint " + std::to_string(invalid[k].waypoint + 1)) +
            ": " + invalid[k].reason;
  if (invalid.size() > kListed + 1) text += "; and " + std::to_string(invalid.size() - kListed - 1) + " more";
  return text;
}

std::string PlanResult::problems(const std::function<std::string(size_t)>& name) const {
  return invalid.empty() ? reason : waypoint_problems(invalid, name);
}

double path_length(const std::vector<Point3>& path) {
  double length = 0;
  for (size_t i = 1; i < path.size(); ++i) length += detail::distance(path[i - 1], path[i]);
  return length;
}

}  // namespace dsmplan
