// Removal of small segments (H. Hirschmüller, "Stereo Processing by Semiglobal Matching and
// Mutual Information", IEEE PAMI 30(2), 2008, sec. 4.3 "Removal of peaks"): the disparity image
// is segmented into 4-connected regions whose neighbouring disparities differ by at most a
// threshold, and regions smaller than a size are made invalid. The same idea as OpenCV's
// filterSpeckles(); written here as a flood fill with an explicit stack, linear in the pixels.
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "dsmplan/stereo.hpp"

namespace dsmplan {

std::size_t remove_small_segments(std::vector<float>& disparity, int width, int height, int min_pixels,
                                  double max_difference) {
  if (min_pixels <= 1) return 0;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  std::vector<std::uint8_t> seen(pixels, 0);
  std::vector<std::size_t> region, stack;
  std::size_t removed = 0;
  for (std::size_t seed = 0; seed < pixels; ++seed) {
    if (seen[seed] || std::isnan(disparity[seed])) continue;
    region.clear(), stack.assign(1, seed), seen[seed] = 1;
    while (!stack.empty()) {
      const std::size_t p = stack.back();
      stack.pop_back();
      region.push_back(p);
      const int x = static_cast<int>(p % width), y = static_cast<int>(p / width);
      const auto visit = [&](std::size_t q) {
        if (!seen[q] && !std::isnan(disparity[q]) && std::abs(disparity[q] - disparity[p]) <= max_difference)
          seen[q] = 1, stack.push_back(q);
      };
      if (x > 0) visit(p - 1);
      if (x + 1 < width) visit(p + 1);
      if (y > 0) visit(p - width);
      if (y + 1 < height) visit(p + width);
    }
    if (region.size() < static_cast<std::size_t>(min_pixels)) {
      for (const std::size_t p : region) disparity[p] = std::numeric_limits<float>::quiet_NaN();
      removed += region.size();
    }
  }
  return removed;
}

}  // namespace dsmplan
