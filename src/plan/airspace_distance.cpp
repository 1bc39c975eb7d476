// The least distance from a path to a zone (airspace.hpp), for --stats. First the horizontal
// distance h from the path's polyline to the zone's area (exact, segment to segment): the
// distance itself for a zone without vertical limits; for the others a lower bound from the
// heights their limits reach over their area (distance_bounds()), given as it is from 10 m on.
// Those nearer are bisected on the safety distance of AirspaceConstraint, whose test is conservative and grows
// with the distance, so "every segment passes at d" proves the path farther than d from the
// zone: doubled from h (or 50 cm) until a segment fails, then the interval halved to 1 cm or 1 %
// of the distance, whichever is larger; the answer is the largest distance at which every segment
// passed. Each step builds the constraint over the path's box alone (an AGL zone's ground
// envelope near the path): 500 zones with AGL floors took 88 % of a 15 s plan when each step
// built the envelope around the whole zone from a distance of 50 cm up (issue 49).
#include <algorithm>
#include <cmath>

#include "dsmplan/airspace.hpp"
#include "plan/airspace_rings.hpp"

namespace dsmplan {

namespace {

constexpr double kResolution = 0.01;  // metres, and relative to the distance
constexpr double kFirstStep = 0.5;    // metres
constexpr double kCap = 1e5;          // metres: beyond, "at least 100 km" is all --stats needs
constexpr double kNear = 10;          // metres: beyond, the lower bound of distance_bounds() is given

bool clear_at(const AirspaceZone& zone, const std::vector<Point3>& path,
              const std::shared_ptr<const GroundGrid>& ground, double d, const std::array<double, 4>& box) {
  const AirspaceConstraint kept(zone, d, ground, &box);
  if (path.size() == 1) return kept.state_valid(path[0]);
  for (size_t k = 1; k < path.size(); ++k)
    if (!kept.motion_valid(path[k - 1], path[k])) return false;
  return true;
}

// The lowest and highest ground of the cells over the box (widened by a cell: a point on a
// cell's side stands on the cell beyond too); -inf, +inf where the ground is unknown.
std::pair<double, double> ground_range(const GroundGrid* ground, double x0, double y0, double x1, double y1) {
  if (!ground || ground->empty()) return {-INFINITY, INFINITY};
  const Grid& g = ground->grid();
  const double c0 = std::floor((x0 - g.x0) / g.cell_x) - 1, c1 = std::floor((x1 - g.x0) / g.cell_x) + 1;
  const double r0 = std::floor((g.y0 - y1) / g.cell_y) - 1, r1 = std::floor((g.y0 - y0) / g.cell_y) + 1;
  if (c0 < 0 || r0 < 0 || c1 >= g.width || r1 >= g.height) return {-INFINITY, INFINITY};
  float low = INFINITY, high = -INFINITY;
  for (int r = static_cast<int>(r0); r <= static_cast<int>(r1); ++r)
    for (int c = static_cast<int>(c0); c <= static_cast<int>(c1); ++c) {
      const float z = g.z[g.index(c, r)];
      low = std::min(low, z), high = std::max(high, z);
    }
  return {low, high};
}

// A lower bound of the distance from the path to the zone's volume, and the horizontal distance:
// each segment's horizontal distance h to the area, with the gap between its heights and the
// lowest the zone's floor comes (its lowest ground plus the floor) or the highest its ceiling
// comes; sqrt(h^2 + gap^2) at the nearest segment.
struct Bounds {
  double horizontal = INFINITY, lower = INFINITY;
};

Bounds distance_bounds(const AirspaceZone& zone, const std::vector<Point3>& path, const GroundGrid* ground) {
  std::vector<detail::Ring> rings;
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  for (const auto& ring : zone.rings) {
    rings.push_back(detail::open_ring(ring));
    for (const auto& c : ring)
      x0 = std::min(x0, c[0]), y0 = std::min(y0, c[1]), x1 = std::max(x1, c[0]), y1 = std::max(y1, c[1]);
  }
  using R = ZoneLimit::Reference;
  const bool agl = zone.lower.reference == R::above_ground || zone.upper.reference == R::above_ground;
  const auto [low, high] = agl ? ground_range(ground, x0, y0, x1, y1) : std::pair<double, double>{0, 0};
  const double floor = zone.lower.reference == R::crs            ? zone.lower.height
                       : zone.lower.reference == R::above_ground ? low + zone.lower.height
                                                                 : -INFINITY;
  const double ceiling = zone.upper.reference == R::crs            ? zone.upper.height
                         : zone.upper.reference == R::above_ground ? high + zone.upper.height
                                                                   : INFINITY;
  Bounds b;
  const auto add = [&](double h, double z_low, double z_high) {
    const double gap = std::max({0.0, floor - z_high, z_low - ceiling});
    b.horizontal = std::min(b.horizontal, h);
    b.lower = std::min(b.lower, std::isfinite(gap) ? std::hypot(h, gap) : INFINITY);
  };
  // A segment whose box lies farther from the zone's box than the least so far cannot be nearer:
  // skipped before its edges are measured (most segments, for most zones).
  const auto box_gap2 = [&](double ax, double ay, double bx, double by) {
    const double dx = std::max({0.0, x0 - std::max(ax, bx), std::min(ax, bx) - x1});
    const double dy = std::max({0.0, y0 - std::max(ay, by), std::min(ay, by) - y1});
    return dx * dx + dy * dy;
  };
  // The segments (the first point alone as segment 0) nearest the zone's box first: after the
  // first few, the others' boxes lie farther than the least so far and are skipped.
  std::vector<std::pair<double, size_t>> order(path.size());
  for (size_t k = 0; k < path.size(); ++k) {
    const size_t o = k ? k - 1 : 0;
    order[k] = {box_gap2(path[o][0], path[o][1], path[k][0], path[k][1]), k};
  }
  std::sort(order.begin(), order.end());
  for (const auto& [near2, k] : order) {
    const size_t o = k ? k - 1 : 0;
    const double z_low = std::min(path[o][2], path[k][2]), z_high = std::max(path[o][2], path[k][2]);
    const double gap = std::max({0.0, floor - z_high, z_low - ceiling});
    if (near2 >= b.horizontal * b.horizontal && near2 + gap * gap >= b.lower * b.lower) continue;
    const detail::Xy p{path[k][0], path[k][1]}, q{path[o][0], path[o][1]};
    double h = detail::inside_rings(rings, p) || detail::inside_rings(rings, q) ? 0 : INFINITY;
    for (const detail::Ring& ring : rings)
      for (size_t i = 0, j = ring.size() - 1; i < ring.size() && h > 0; j = i++)
        h = std::min(h, detail::segment_segment_distance(q, p, ring[j], ring[i]));
    add(h, z_low, z_high);
  }
  return b;
}

}  // namespace

double zone_distance(const AirspaceZone& zone, const std::vector<Point3>& path, const GroundGrid* ground) {
  if (path.empty()) return INFINITY;
  check_zone(zone);
  const Bounds bounds = distance_bounds(zone, path, ground);
  // Without vertical limits the volume's nearest point is level with the path's: the horizontal
  // distance is the distance. Farther than kNear, the lower bound is given: bisecting there
  // builds envelopes tens of metres wide, for a figure nobody flies by (50 ms a zone: 500 zones
  // with AGL floors made a 0.35 s plan take 18 s, issue 49).
  using R = ZoneLimit::Reference;
  if (zone.lower.reference == R::unlimited && zone.upper.reference == R::unlimited)
    return std::min(bounds.horizontal, kCap);
  if (bounds.lower >= kNear) return std::min(bounds.lower, kCap);
  // Not owned: the grid outlives this call, which is all the constraints built here need.
  const std::shared_ptr<const GroundGrid> held(std::shared_ptr<const GroundGrid>(), ground);
  std::array<double, 4> box{INFINITY, INFINITY, -INFINITY, -INFINITY};  // the path's: all the constraint is asked
  for (const Point3& p : path)
    box = {std::min(box[0], p[0]), std::min(box[1], p[1]), std::max(box[2], p[0]), std::max(box[3], p[1])};
  // Invariant: every segment passes at lo (so the path is farther than lo), not at hi. The
  // constraint refuses nothing farther than its distance horizontally: it passes below h.
  double lo = std::max(0.0, bounds.horizontal * (1 - 1e-9) - 1e-5);
  if (lo == 0 && !clear_at(zone, path, held, 0, box)) return 0;
  double hi = std::max(kFirstStep, 2 * lo);
  while (clear_at(zone, path, held, hi, box)) {
    lo = hi, hi *= 2;
    if (lo >= kCap) return kCap;
  }
  while (hi - lo > kResolution * std::max(1.0, lo)) {
    const double mid = (lo + hi) / 2;
    (clear_at(zone, path, held, mid, box) ? lo : hi) = mid;
  }
  return std::max(lo, bounds.lower);  // both lower bounds
}

}  // namespace dsmplan
