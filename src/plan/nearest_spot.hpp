// The one search for the nearest spot that keeps the rules, shared by home (mission_site.cpp:
// the nearest clear climb) and the waypoints (flight_plan.cpp: --snap and the refusals' nearest
// valid point), so that both answer "nearest" the same way.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace dsmplan::detail {

/// Square rings of Chebyshev radius k = first_ring .. ceil(radius / step) around a place, nearest
/// ring first, each ring's offsets in a fixed order (deterministic). `try_at(dx, dy, d)` is
/// called for every offset whose horizontal distance d is less than the best so far and returns
/// the distance of the spot it found there (at least d), or INFINITY. A ring's offsets lie at least k
/// steps away, so the search stops past the best distance found, which it returns.
template <typename TryAt>
double search_rings(double step, double radius, int first_ring, TryAt&& try_at) {
  double best = INFINITY;
  const int rings = static_cast<int>(std::ceil(radius / step));
  for (int k = first_ring; k <= rings && k * step < best; ++k)
    for (int i = -k; i <= k; ++i)
      for (int j = -k; j <= k; ++j) {
        if (std::max(std::abs(i), std::abs(j)) != k) continue;
        const double d = std::hypot(i, j) * step;
        if (d >= best) continue;
        best = std::min(best, try_at(i * step, j * step, d));
      }
  return best;
}

}  // namespace dsmplan::detail
