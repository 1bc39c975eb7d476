// The area of a zone (airspace.hpp): rings read by the even-odd rule, boundaries included.
// Point in polygon by the crossing number (O'Rourke, "Computational Geometry in C", 2nd ed.
// 1998, Section 7.4), each ring's edges counted alike, so holes need no orientation.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace dsmplan::detail {

using Xy = std::array<double, 2>;
using Ring = std::vector<Xy>;

/// The ring without a closing corner equal to the first.
inline Ring open_ring(Ring ring) {
  if (ring.size() > 1 && ring.front() == ring.back()) ring.pop_back();
  return ring;
}

/// Distance from p to the closed segment a-b.
inline double point_segment_distance(const Xy& p, const Xy& a, const Xy& b) {
  const double dx = b[0] - a[0], dy = b[1] - a[1], len2 = dx * dx + dy * dy;
  double t = len2 > 0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2 : 0;
  t = std::clamp(t, 0.0, 1.0);
  // sqrt, not hypot: coordinates in metres square far below overflow, and hypot cost a quarter of
  // a plan's time with 20,000 zones.
  const double ex = p[0] - (a[0] + t * dx), ey = p[1] - (a[1] + t * dy);
  return std::sqrt(ex * ex + ey * ey);
}

/// Whether the closed segments a-b and c-d meet (orientations, collinear overlaps included).
inline bool segments_meet(const Xy& a, const Xy& b, const Xy& c, const Xy& d) {
  const auto orient = [](const Xy& p, const Xy& q, const Xy& r) {
    const double v = (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]);
    return (v > 0) - (v < 0);
  };
  const int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (o1 != o2 && o3 != o4) return true;
  return (o1 == 0 && point_segment_distance(c, a, b) == 0) || (o2 == 0 && point_segment_distance(d, a, b) == 0) ||
         (o3 == 0 && point_segment_distance(a, c, d) == 0) || (o4 == 0 && point_segment_distance(b, c, d) == 0);
}

/// Least distance between the closed segments a-b and c-d.
inline double segment_segment_distance(const Xy& a, const Xy& b, const Xy& c, const Xy& d) {
  if (segments_meet(a, b, c, d)) return 0;
  return std::min({point_segment_distance(a, c, d), point_segment_distance(b, c, d), point_segment_distance(c, a, b),
                   point_segment_distance(d, a, b)});
}

/// Least distance from p to any edge of the rings.
inline double distance_to_edges(const std::vector<Ring>& rings, const Xy& p) {
  double best = INFINITY;
  for (const Ring& ring : rings)
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
      best = std::min(best, point_segment_distance(p, ring[j], ring[i]));
  return best;
}

/// p in the area (even-odd over all rings), or on an edge.
inline bool inside_rings(const std::vector<Ring>& rings, const Xy& p) {
  bool odd = false;
  for (const Ring& ring : rings)
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
      const Xy &a = ring[j], &b = ring[i];
      if (point_segment_distance(p, a, b) == 0) return true;
      if ((a[1] > p[1]) != (b[1] > p[1]) && p[0] < a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])) odd = !odd;
    }
  return odd;
}

}  // namespace dsmplan::detail
