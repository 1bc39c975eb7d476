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
  // NaN pixels start as seen: one test per neighbour instead of two.
  std::vector<std::uint8_t> seen(pixels);
  for (std::size_t i = 0; i < pixels; ++i) seen[i] = std::isnan(disparity[i]);
  // The stack holds coordinates, not indices: no division per pixel.
  struct Pixel {
    int x, y;
  };
  std::vector<Pixel> stack;
  std::vector<std::size_t> region;
  std::size_t removed = 0;
  for (int seed_y = 0; seed_y < height; ++seed_y)
    for (int seed_x = 0; seed_x < width; ++seed_x) {
      const std::size_t seed = static_cast<std::size_t>(seed_y) * width + seed_x;
      if (seen[seed]) continue;
      region.clear(), stack.assign(1, Pixel{seed_x, seed_y}), seen[seed] = 1;
      while (!stack.empty()) {
        const auto [x, y] = stack.back();
        stack.pop_back();
        const std::size_t p = static_cast<std::size_t>(y) * width + x;
        region.push_back(p);
        const float here = disparity[p];
        const auto visit = [&](std::size_t q, int qx, int qy) {
          if (!seen[q] && std::abs(disparity[q] - here) <= max_difference) seen[q] = 1, stack.push_back(Pixel{qx, qy});
        };
        if (x > 0) visit(p - 1, x - 1, y);
        if (x + 1 < width) visit(p + 1, x + 1, y);
        if (y > 0) visit(p - width, x, y - 1);
        if (y + 1 < height) visit(p + width, x, y + 1);
      }
      if (region.size() < static_cast<std::size_t>(min_pixels)) {
        for (const std::size_t p : region) disparity[p] = std::numeric_limits<float>::quiet_NaN();
        removed += region.size();
      }
    }
  return removed;
}

}  // namespace dsmplan
