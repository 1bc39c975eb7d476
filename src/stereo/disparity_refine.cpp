// From the sums S to disparities (H. Hirschmüller, "Stereo Processing by Semiglobal Matching and
// Mutual Information", IEEE PAMI 30(2), 2008, sec. 3.4): the winner's sub-pixel position by the
// parabola through S(d-1), S(d), S(d+1), the right image's disparity from the same S along the
// epipolar line, and the left-right consistency check (|D_b(p) - D_m(q)| <= 1 with q the right
// pixel p matches). The winners themselves are searched by the kernels (sgm_simd.cpp).
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "stereo/sgm_parts.hpp"

namespace dsmplan::stereo {

namespace {

constexpr float invalid = std::numeric_limits<float>::quiet_NaN();

// The vertex of the parabola through (-1, before), (0, at), (1, after), relative to 0.
double parabola_vertex(int before, int at, int after) {
  const int curvature = before - 2 * at + after;
  return curvature > 0 ? (before - after) / (2.0 * curvature) : 0.0;
}

}  // namespace

void refine_row(const std::int16_t* sums, int width, int d16, int num_disparities, int min_disparity, bool subpixel,
                const std::int32_t* best, const std::int16_t* right_cost, const std::int16_t* best_right, float* left,
                float* right) {
  const auto sum = [&](int x, int k) { return static_cast<int>(sums[static_cast<std::size_t>(x) * d16 + k]); };
  for (int x = 0; x < width; ++x) {
    const int k = best[x];
    const int x_right = x - min_disparity - k;
    if (x_right < 0 || x_right >= width) {
      left[x] = invalid;  // the least cost is a disparity that leaves the right image
      continue;
    }
    double d = min_disparity + k;
    if (subpixel && k > 0 && k + 1 < num_disparities) d += parabola_vertex(sum(x, k - 1), sum(x, k), sum(x, k + 1));
    left[x] = static_cast<float>(d);
  }
  if (!right) return;
  (void)right_cost;
  for (int x_right = 0; x_right < width; ++x_right) {
    const long j = static_cast<long>(width) - 1 - x_right - min_disparity;
    const int k = j >= 0 && j < width + d16 ? best_right[j] : -1;
    if (k < 0 || k >= num_disparities) {
      right[x_right] = invalid;  // no left pixel in the image matches at a real disparity
      continue;
    }
    const int x = x_right + min_disparity + k;
    double d = min_disparity + k;
    // Along the right pixel's diagonal of S: the neighbours are (x - 1, k - 1) and (x + 1, k + 1).
    if (subpixel && k > 0 && k + 1 < num_disparities && x > 0 && x + 1 < width)
      d += parabola_vertex(sum(x - 1, k - 1), sum(x, k), sum(x + 1, k + 1));
    right[x_right] = static_cast<float>(d);
  }
}

std::size_t left_right_check_row(float* left, const float* right, int width, double max_difference) {
  std::size_t removed = 0;
  for (int x = 0; x < width; ++x) {
    float& d = left[x];
    if (std::isnan(d)) continue;
    const long x_right = std::lround(x - d);
    const bool confirmed = x_right >= 0 && x_right < width && std::abs(d - right[x_right]) <= max_difference;
    if (!confirmed) d = std::numeric_limits<float>::quiet_NaN(), ++removed;  // NaN compares false: removed
  }
  return removed;
}

}  // namespace dsmplan::stereo

namespace dsmplan {

std::size_t left_right_check(std::vector<float>& left, const std::vector<float>& right, int width, int height,
                             double max_difference) {
  std::size_t removed = 0;
  for (int y = 0; y < height; ++y) {
    const std::size_t start = static_cast<std::size_t>(y) * width;
    removed += stereo::left_right_check_row(left.data() + start, right.data() + start, width, max_difference);
  }
  return removed;
}

}  // namespace dsmplan
