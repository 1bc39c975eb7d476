// The least distance from a path to a zone (airspace.hpp), for --stats: bisection on the safety
// distance of AirspaceConstraint, whose test is conservative and grows with the distance, so
// "every segment passes at d" proves the path farther than d from the zone. The distance is
// doubled from 50 cm until a segment fails, then the interval halved to 1 cm or 1 % of the
// distance, whichever is larger; the answer is the largest distance at which every segment
// passed. Each step builds the constraint (an AGL zone's ground envelope): about 15 steps, not
// the 30 of a 1 cm resolution at every distance.
#include <algorithm>
#include <cmath>

#include "dsmplan/airspace.hpp"

namespace dsmplan {

namespace {

constexpr double kResolution = 0.01;  // metres, and relative to the distance
constexpr double kFirstStep = 0.5;    // metres
constexpr double kCap = 1e5;          // metres: beyond, "at least 100 km" is all --stats needs

bool clear_at(const AirspaceZone& zone, const std::vector<Point3>& path,
              const std::shared_ptr<const GroundGrid>& ground, double d) {
  const AirspaceConstraint kept(zone, d, ground);
  if (path.size() == 1) return kept.state_valid(path[0]);
  for (size_t k = 1; k < path.size(); ++k)
    if (!kept.motion_valid(path[k - 1], path[k])) return false;
  return true;
}

}  // namespace

double zone_distance(const AirspaceZone& zone, const std::vector<Point3>& path, const GroundGrid* ground) {
  if (path.empty()) return INFINITY;
  // Not owned: the grid outlives this call, which is all the constraints built here need.
  const std::shared_ptr<const GroundGrid> held(std::shared_ptr<const GroundGrid>(), ground);
  // Invariant: every segment passes at lo (so the path is farther than lo), not at hi.
  if (!clear_at(zone, path, held, 0)) return 0;
  double lo = 0, hi = kFirstStep;
  while (clear_at(zone, path, held, hi)) {
    lo = hi, hi *= 2;
    if (lo >= kCap) return kCap;
  }
  while (hi - lo > kResolution * std::max(1.0, lo)) {
    const double mid = (lo + hi) / 2;
    (clear_at(zone, path, held, mid) ? lo : hi) = mid;
  }
  return lo;
}

}  // namespace dsmplan
