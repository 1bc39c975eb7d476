// The DSM read as solid columns (each valid cell a box over its whole square, up to its height)
// and the two grids the guarantees against it are built on:
//   - fill_holes_from_rim(): a nodata region is unknown space, so it is given a height taken
//     from the valid cells around it (its rim): the highest for obstacles (a path never passes
//     through a hole lower than its rim), the lowest for the ground a ceiling counts from (a
//     height above such ground is never understated).
//   - column_envelope(): heights at the cells' corners, each the highest of the cells meeting
//     there. Any surface that lies on or above these corners' piecewise-linear interpolation
//     over every cell encloses the columns: a cell's four corners are all at least its height.
#include <algorithm>
#include <cmath>
#include <vector>

#include "dsmplan/raster.hpp"

namespace dsmplan {

size_t fill_holes_from_rim(Grid& grid, RimHeight rule) {
  const size_t n = grid.cells();
  std::vector<uint8_t> seen(n, 0);
  std::vector<size_t> stack, region;
  size_t filled_regions = 0;
  for (size_t start = 0; start < n; ++start) {
    if (seen[start] || !std::isnan(grid.z[start])) continue;
    // One 4-connected nodata region, by flood fill with an explicit stack (no recursion depth).
    region.clear();
    seen[start] = 1;
    stack.push_back(start);
    double rim = rule == RimHeight::highest ? -INFINITY : INFINITY;
    while (!stack.empty()) {
      const size_t i = stack.back();
      stack.pop_back();
      region.push_back(i);
      const int col = static_cast<int>(i % grid.width), row = static_cast<int>(i / grid.width);
      // The rim is every valid cell touching the region, corners included: a path squeezing
      // diagonally between two cells still passes that corner.
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) {
          const int c = col + dc, r = row + dr;
          if ((dc == 0 && dr == 0) || c < 0 || r < 0 || c >= grid.width || r >= grid.height) continue;
          const size_t j = grid.index(c, r);
          const float z = grid.z[j];
          if (!std::isnan(z)) {
            rim = rule == RimHeight::highest ? std::max<double>(rim, z) : std::min<double>(rim, z);
          } else if (!seen[j] && (dc == 0 || dr == 0)) {
            seen[j] = 1;
            stack.push_back(j);
          }
        }
    }
    if (!std::isfinite(rim)) continue;  // no valid cell at all: nothing to take a height from
    for (size_t i : region) grid.z[i] = static_cast<float>(rim);
    ++filled_regions;
  }
  return filled_regions;
}

Grid column_envelope(const Grid& dsm) {
  Grid corners(dsm.width + 1, dsm.height + 1, dsm.x0 - 0.5 * dsm.cell_x, dsm.y0 + 0.5 * dsm.cell_y, dsm.cell_x,
               dsm.cell_y);
  corners.crs = dsm.crs;
  for (int row = 0; row <= dsm.height; ++row)
    for (int col = 0; col <= dsm.width; ++col) {
      float top = Grid::nodata;
      for (int r = row - 1; r <= row; ++r)
        for (int c = col - 1; c <= col; ++c) {
          if (c < 0 || r < 0 || c >= dsm.width || r >= dsm.height) continue;
          const float z = dsm.at(c, r);
          if (!std::isnan(z) && !(z <= top)) top = z;  // NaN-aware max
        }
      corners.z[corners.index(col, row)] = top;
    }
  return corners;
}

}  // namespace dsmplan
