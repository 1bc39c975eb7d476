// Ortho-projection of stereo points into the DSM grid and the median per cell: the fusion of
// H. Hirschmüller's pipeline as the seed paper describes it (F. Adolf and H. Hirschmüller,
// "Meshing and Simplification of High Resolution Urban Surface Data for UAV Path Planning",
// Section 2: "all pixels of all depth images are reconstructed and projected into a
// geo-referenced, orthographic DSM. The redundancy is removed by using the median of depth
// values for each cell"). Cells nothing fell into stay nodata.
#include <algorithm>
#include <cmath>

#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {

Grid dsm_grid(const std::array<double, 4>& b, double resolution) {
  if (!(resolution > 0 && std::isfinite(resolution))) throw ArgumentError("resolution", "must be a positive number");
  if (!(b[2] > b[0] && b[3] > b[1])) throw ArgumentError("bounds", "must be x0,y0,x1,y1 with x0 < x1 and y0 < y1");
  const double w = std::ceil((b[2] - b[0]) / resolution - 1e-9), h = std::ceil((b[3] - b[1]) / resolution - 1e-9);
  if (w * h > 4e9) throw ArgumentError("resolution", "makes a grid of more than 4e9 cells");
  return Grid(static_cast<int>(w), static_cast<int>(h), b[0], b[3], resolution, resolution);
}

std::size_t fuse_median(Grid& grid, const std::vector<std::vector<Vec3>>& point_sets) {
  std::vector<std::pair<std::uint64_t, float>> keyed;
  std::size_t total = 0;
  for (const auto& set : point_sets) total += set.size();
  keyed.reserve(total);
  for (const auto& set : point_sets)
    for (const Vec3& p : set) {
      int col, row;
      if (!std::isfinite(p[2]) || !grid.cell_at(p[0], p[1], col, row)) continue;
      keyed.emplace_back(grid.index(col, row), static_cast<float>(p[2]));
    }
  std::sort(keyed.begin(), keyed.end());
  std::fill(grid.z.begin(), grid.z.end(), Grid::nodata);
  for (std::size_t a = 0; a < keyed.size();) {
    std::size_t b = a;
    while (b < keyed.size() && keyed[b].first == keyed[a].first) ++b;
    const std::size_t n = b - a, m = a + n / 2;
    grid.z[keyed[a].first] = n % 2 ? keyed[m].second : 0.5f * (keyed[m - 1].second + keyed[m].second);
    a = b;
  }
  return keyed.size();
}

}  // namespace dsmplan
