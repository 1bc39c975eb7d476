// The street-level waypoints of the very-low-altitude scenario, shared by tests/plan_test.cpp
// and bench/table3.cpp so that the benchmark measures the scenario the tests check.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <utility>
#include <vector>

#include "dsmplan/plan.hpp"

namespace scenario {

/// A point on a street near (x, y): of a 2 m lattice within 100 m, the point nearest (x, y)
/// (ties in row order: deterministic) whose ground is within 1 m of the lowest ground within
/// 30 m (a street or square, not a roof), with no surface more than 1 m above it within 4 m (no
/// wall, tree or car right beside it), and for which `accept(x, y, ground)` holds. Returns
/// x, y and the ground; nullopt when no lattice point qualifies.
template <typename Accept>
std::optional<dsmplan::Point3> street_point(const dsmplan::ClearanceIndex& index, double x, double y,
                                            const Accept& accept) {
  constexpr double step = 2;
  constexpr int search = 50, low = 15, open = 2;  // lattice steps
  const int n = search + low, side = 2 * n + 1;
  std::vector<double> g(static_cast<size_t>(side) * side);
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i)
      g[static_cast<size_t>(j) * side + i] = index.ground(x + (i - n) * step, y + (j - n) * step);
  auto at = [&](int i, int j) { return g[static_cast<size_t>(j) * side + i]; };
  std::vector<std::pair<int, std::pair<int, int>>> order;
  for (int j = -search; j <= search; ++j)
    for (int i = -search; i <= search; ++i)
      if (i * i + j * j <= search * search) order.push_back({i * i + j * j, {i, j}});
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [r2, ij] : order) {
    const int ci = ij.first + n, cj = ij.second + n;
    const double z = at(ci, cj);
    if (std::isnan(z)) continue;
    bool ok = true;
    for (int dj = -low; dj <= low && ok; ++dj)
      for (int di = -low; di <= low && ok; ++di) {
        const int d2 = di * di + dj * dj;
        if (d2 > low * low) continue;
        const double h = at(ci + di, cj + dj);
        ok = !std::isnan(h) && h >= z - 1 && (d2 > open * open || h <= z + 1);
      }
    const dsmplan::Point3 p{x + ij.first * step, y + ij.second * step, z};
    if (ok && accept(p)) return p;
  }
  return std::nullopt;
}

}  // namespace scenario
