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
  return std::hypot(p[0] - (a[0] + t * dx), p[1] - (a[1] + t * dy));
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
