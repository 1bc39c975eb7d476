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
  // The image framed by one pixel of NaN, and the pixels to visit marked seen up front (NaN ones
  // and the frame): a neighbour then costs one test of `seen` and one of the step, with no
  // bounds tests and no division (indices are the framed image's throughout).
  const int framed_width = width + 2;
  const std::size_t framed = static_cast<std::size_t>(framed_width) * (height + 2);
  std::vector<float> d(framed, std::numeric_limits<float>::quiet_NaN());
  std::vector<std::uint8_t> seen(framed, 1);
  for (int y = 0; y < height; ++y) {
    const float* row = disparity.data() + static_cast<std::size_t>(y) * width;
    const std::size_t start = static_cast<std::size_t>(y + 1) * framed_width + 1;
    for (int x = 0; x < width; ++x) d[start + x] = row[x], seen[start + x] = std::isnan(row[x]);
  }
  const std::size_t limit = static_cast<std::size_t>(min_pixels);
  std::vector<std::size_t> stack, region;  // region: only the first min_pixels pixels matter
  std::size_t removed = 0;
  for (std::size_t seed = 0; seed < framed; ++seed) {
    if (seen[seed]) continue;
    std::size_t size = 0;
    region.clear(), stack.assign(1, seed), seen[seed] = 1;
    while (!stack.empty()) {
      const std::size_t p = stack.back();
      stack.pop_back();
      if (size++ < limit) region.push_back(p);
      const float here = d[p];
      const std::size_t row = framed_width;
      for (const std::size_t q : {p - 1, p + 1, p - row, p + row})
        if (!seen[q] && std::abs(d[q] - here) <= max_difference) seen[q] = 1, stack.push_back(q);
    }
    if (size < limit) {
      for (const std::size_t p : region) {
        const std::size_t x = p % framed_width - 1, y = p / framed_width - 1;
        disparity[y * width + x] = std::numeric_limits<float>::quiet_NaN();
      }
      removed += size;
    }
  }
  return removed;
}

}  // namespace dsmplan
