// Grid bookkeeping: one-pass summary (counts, height range, connected holes) and the vertical
// quantization of Adolf & Hirschmueller, Table 1 ("the vertical resolution is always 10 cm").
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/text.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

GridSummary summarize(const Grid& grid) {
  GridSummary summary;
  summary.cells = grid.cells();
  for (float z : grid.z) {
    if (std::isnan(z)) continue;
    ++summary.valid;
    if (!(z >= summary.z_min)) summary.z_min = z;  // NaN-aware: the first valid height wins
    if (!(z <= summary.z_max)) summary.z_max = z;
  }
  summary.nodata = summary.cells - summary.valid;

  // Holes: 4-connected nodata regions, by flood fill with an explicit stack (no recursion depth).
  std::vector<bool> seen(grid.cells(), false);
  std::vector<size_t> stack;
  for (size_t start = 0; start < grid.cells(); ++start) {
    if (seen[start] || !std::isnan(grid.z[start])) continue;
    ++summary.holes;
    seen[start] = true;
    stack.push_back(start);
    while (!stack.empty()) {
      size_t i = stack.back();
      stack.pop_back();
      int col = static_cast<int>(i % grid.width), row = static_cast<int>(i / grid.width);
      auto visit = [&](int c, int r) {
        if (c < 0 || r < 0 || c >= grid.width || r >= grid.height) return;
        size_t j = grid.index(c, r);
        if (!seen[j] && std::isnan(grid.z[j])) {
          seen[j] = true;
          stack.push_back(j);
        }
      };
      visit(col - 1, row);
      visit(col + 1, row);
      visit(col, row - 1);
      visit(col, row + 1);
    }
  }
  return summary;
}

std::string frame_problem(const Grid& frame) {
  // Beyond any projected CRS, or cells finer than the coordinates can tell apart: every later
  // sum of an origin and an offset would round (a 1 m raster at 1e16 has its cells collapse).
  const double far = std::max({std::abs(frame.x0), std::abs(frame.y0), std::abs(frame.x0 + frame.width * frame.cell_x),
                               std::abs(frame.y0 - frame.height * frame.cell_y)});
  if (!(far <= kMaxCoordinate))
    return "the raster reaches " + short_number(far) +
           " CRS units from the origin: beyond any projected CRS (at most 1e9)";
  const double finest = std::min(frame.cell_x, frame.cell_y);
  if (finest < 1e-9 * std::max(1.0, far))
    return "cells of " + short_number(finest) + " at " + short_number(far) +
           " CRS units from the origin are too fine: their corners would round together";
  return {};
}

void check_grid(const Grid& grid) {
  if (!(grid.cell_x > 0) || !(grid.cell_y > 0))
    throw ArgumentError(
        "DSM", "cells must have a positive size, got " + short_number(grid.cell_x) + " x " + short_number(grid.cell_y));
  if (const std::string problem = frame_problem(grid); !problem.empty()) throw ArgumentError("DSM", problem);
  for (size_t i = 0; i < grid.z.size(); ++i)
    if (!std::isnan(grid.z[i]) && !(std::abs(grid.z[i]) <= kMaxHeight))
      throw ArgumentError("DSM", "cell (col " + std::to_string(i % grid.width) + ", row " +
                                     std::to_string(i / grid.width) + "): height " + short_number(grid.z[i]) +
                                     " is no height on Earth (beyond +-100 km)");
}

HeightQuantizer::HeightQuantizer(double step) : step_(step) {
  // 0 or less keeps heights; NaN, infinity or a step coarser than 100 m would make them NaN or 0,
  // and one finer than 1e-6 (below a float height's own resolution) overflows z / step: 5e-324
  // made every height infinite (fuzz_pipeline).
  if (std::isnan(step) || step > 100 || (step > 0 && step < 1e-6))
    throw ArgumentError(
        "zstep", "must be at least 1e-6 and at most 100 (0 or less: keep the heights), got " + short_number(step));
  if (!(step > 0)) return;
  const double per_unit = 1.0 / step;
  if (std::abs(per_unit - std::round(per_unit)) < 1e-9 * per_unit) per_unit_ = std::round(per_unit);
}

}  // namespace dsmplan

namespace dsmplan {

GridView::GridView(const Grid& grid) : grid_(grid) {
  // A grid made in memory may have any georeference and heights; the streamed stages trust a
  // GridSource's frame as open_raster() checks it (a corner at 1e308 and cells of -1 kept
  // simplify_bounded() flipping edges forever: fuzz_pipeline).
  check_grid(grid);
  frame_ = Grid();
  frame_.width = grid.width;
  frame_.height = grid.height;
  frame_.x0 = grid.x0;
  frame_.y0 = grid.y0;
  frame_.cell_x = grid.cell_x;
  frame_.cell_y = grid.cell_y;
  frame_.crs = grid.crs;
}

Grid read_window(GridSource& source, int col0, int row0, int w, int h) {
  const Grid& frame = source.frame();
  Grid window(w, h, frame.x0 + col0 * frame.cell_x, frame.y0 - row0 * frame.cell_y, frame.cell_x, frame.cell_y);
  window.crs = frame.crs;
  source.read(col0, row0, w, h, window.z.data());
  return window;
}

void GridView::read(int col0, int row0, int w, int h, float* out) {
  for (int row = 0; row < h; ++row) {
    const float* from = grid_.z.data() + grid_.index(col0, row0 + row);
    std::copy(from, from + w, out + static_cast<size_t>(row) * w);
  }
}

}  // namespace dsmplan
