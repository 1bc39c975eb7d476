// A no-fly zone as a FlightConstraint (flight_space.hpp): the vertical prism over a polygon.
// A segment meets the prism when its part inside the prism's height range, projected to x,y,
// meets the polygon: an end of that part inside it (crossing number, O'Rourke, "Computational
// Geometry in C", 2nd ed. 1998, Section 7.4, with points on an edge counted inside) or the part
// crossing or touching an edge (orientation tests, ibid. Section 1.5).
#include <algorithm>
#include <cmath>

#include "dsmplan/flight_space.hpp"

namespace dsmplan {

namespace {

using P2 = std::array<double, 2>;

double orient(const P2& a, const P2& b, const P2& c) {
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

// c on the segment a-b, given that the three are collinear.
bool within(const P2& a, const P2& b, const P2& c) {
  return std::min(a[0], b[0]) <= c[0] && c[0] <= std::max(a[0], b[0]) && std::min(a[1], b[1]) <= c[1] &&
         c[1] <= std::max(a[1], b[1]);
}

// The closed segments a-b and c-d share a point.
bool meet(const P2& a, const P2& b, const P2& c, const P2& d) {
  const double o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) return true;
  return (o1 == 0 && within(a, b, c)) || (o2 == 0 && within(a, b, d)) || (o3 == 0 && within(c, d, a)) ||
         (o4 == 0 && within(c, d, b));
}

}  // namespace

NoFlyZone::NoFlyZone(std::string name, std::vector<std::array<double, 2>> polygon, double bottom, double top)
    : name_(std::move(name)), polygon_(std::move(polygon)), bottom_(bottom), top_(top) {
  if (polygon_.size() > 1 && polygon_.front() == polygon_.back()) polygon_.pop_back();
  if (polygon_.size() < 3)
    throw ArgumentError("no_fly_zone",
                        "'" + name_ + "' needs at least 3 corners, got " + std::to_string(polygon_.size()));
  for (const P2& c : polygon_)
    if (!std::isfinite(c[0]) || !std::isfinite(c[1]))
      throw ArgumentError("no_fly_zone", "'" + name_ + "' has a corner that is not finite");
  if (std::isnan(bottom_) || std::isnan(top_) || bottom_ > top_)
    throw ArgumentError("no_fly_zone", "'" + name_ + "': bottom must not be above top");
  xmin_ = ymin_ = INFINITY, xmax_ = ymax_ = -INFINITY;
  for (const P2& c : polygon_) {
    xmin_ = std::min(xmin_, c[0]), xmax_ = std::max(xmax_, c[0]);
    ymin_ = std::min(ymin_, c[1]), ymax_ = std::max(ymax_, c[1]);
  }
}

bool NoFlyZone::inside(double x, double y) const {
  if (x < xmin_ || x > xmax_ || y < ymin_ || y > ymax_) return false;
  const P2 p{x, y};
  bool odd = false;
  for (size_t i = 0, j = polygon_.size() - 1; i < polygon_.size(); j = i++) {
    const P2 &a = polygon_[j], &b = polygon_[i];
    if (orient(a, b, p) == 0 && within(a, b, p)) return true;  // on the boundary
    // Crossing number: edges straddling the horizontal through p, crossed right of it.
    if ((a[1] > y) != (b[1] > y) && x < a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1])) odd = !odd;
  }
  return odd;
}

bool NoFlyZone::state_valid(const Point3& p) const { return !(p[2] >= bottom_ && p[2] <= top_ && inside(p[0], p[1])); }

bool NoFlyZone::motion_valid(const Point3& p, const Point3& q) const {
  // The part of p-q within [bottom, top]: t in [t0, t1].
  double t0 = 0, t1 = 1;
  const double dz = q[2] - p[2];
  if (dz == 0) {
    if (p[2] < bottom_ || p[2] > top_) return true;
  } else {
    double a = (bottom_ - p[2]) / dz, b = (top_ - p[2]) / dz;  // +-inf for an unbounded zone
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a), t1 = std::min(t1, b);
    if (t0 > t1) return true;
  }
  const P2 a{p[0] + t0 * (q[0] - p[0]), p[1] + t0 * (q[1] - p[1])};
  const P2 b{p[0] + t1 * (q[0] - p[0]), p[1] + t1 * (q[1] - p[1])};
  if (std::max(a[0], b[0]) < xmin_ || std::min(a[0], b[0]) > xmax_ || std::max(a[1], b[1]) < ymin_ ||
      std::min(a[1], b[1]) > ymax_)
    return true;
  if (inside(a[0], a[1]) || inside(b[0], b[1])) return false;
  for (size_t i = 0, j = polygon_.size() - 1; i < polygon_.size(); j = i++)
    if (meet(a, b, polygon_[j], polygon_[i])) return false;
  return true;
}

}  // namespace dsmplan
