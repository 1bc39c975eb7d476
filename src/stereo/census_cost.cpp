// The matching cost: the Census transform and the Hamming distance of two transforms.
// R. Zabih and J. Woodfill, "Non-parametric local transforms for computing visual
// correspondence", ECCV 1994 (the transform); H. Hirschmüller and D. Scharstein, "Evaluation of
// stereo matching costs on images with radiometric differences", IEEE PAMI 31(9), 2009 (Census
// over a 9 x 7 window as SGM's cost). The kernels of sgm_simd.cpp compute the Hamming distances
// row by row inside the aggregation; cost_volume_reference() is the plain version they are
// tested against.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <vector>

#include "stereo/sgm_parts.hpp"

namespace dsmplan::stereo {

std::vector<std::uint16_t> to_u16(const ImageView& image, int row0, int rows) {
  std::vector<std::uint16_t> out(static_cast<std::size_t>(image.width) * rows);
  for (int y = 0; y < rows; ++y) {
    std::uint16_t* row = out.data() + static_cast<std::size_t>(y) * image.width;
    const std::ptrdiff_t start = static_cast<std::ptrdiff_t>(row0 + y) * image.row_pixels();
    if (image.bits == 16) {
      std::copy_n(static_cast<const std::uint16_t*>(image.pixels) + start, image.width, row);
    } else {
      std::copy_n(static_cast<const std::uint8_t*>(image.pixels) + start, image.width, row);
    }
  }
  return out;
}

namespace {

// One bit plane of the transform for a whole row: written for the compiler to vectorise, and
// cloned for x86-64-v4 (AVX-512) and AVX2 (chosen at load time by the CPU; the baseline stays SSE2).
__attribute__((target_clones("arch=x86-64-v4", "avx2", "default"))) void shift_in_comparisons(
    std::uint64_t* census, const std::uint16_t* neighbours, const std::uint16_t* centres, int n) {
  for (int x = 0; x < n; ++x) census[x] = (census[x] << 1) | static_cast<std::uint64_t>(neighbours[x] < centres[x]);
}

}  // namespace

std::vector<std::uint64_t> census_transform(const std::uint16_t* pixels, int width, int height, int census_width,
                                            int census_height) {
  const int half_w = census_width / 2, half_h = census_height / 2;
  const int padded_width = width + 2 * half_w;
  std::vector<std::uint64_t> census(static_cast<std::size_t>(width) * height, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, height, 16), [&](const tbb::blocked_range<int>& rows) {
    // The window's rows with the border pixels repeated, so the inner loop has no tests.
    std::vector<std::uint16_t> window(static_cast<std::size_t>(padded_width) * census_height);
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int dy = 0; dy < census_height; ++dy) {
        const int source_row = std::clamp(y + dy - half_h, 0, height - 1);
        const std::uint16_t* source = pixels + static_cast<std::size_t>(source_row) * width;
        std::uint16_t* row = window.data() + static_cast<std::size_t>(dy) * padded_width;
        std::fill_n(row, half_w, source[0]);
        std::copy_n(source, width, row + half_w);
        std::fill_n(row + half_w + width, half_w, source[width - 1]);
      }
      std::uint64_t* out = census.data() + static_cast<std::size_t>(y) * width;
      const std::uint16_t* centres = window.data() + static_cast<std::size_t>(half_h) * padded_width + half_w;
      for (int dy = 0; dy < census_height; ++dy)
        for (int dx = 0; dx < census_width; ++dx) {
          if (dy == half_h && dx == half_w) continue;
          shift_in_comparisons(out, window.data() + static_cast<std::size_t>(dy) * padded_width + dx, centres, width);
        }
    }
  });
  return census;
}

std::vector<std::int16_t> cost_volume_reference(const std::uint64_t* census_left, const std::uint64_t* census_right,
                                                int width, int height, int min_disparity, int num_disparities,
                                                int out_of_view_cost) {
  std::vector<std::int16_t> costs(static_cast<std::size_t>(width) * height * num_disparities);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int k = 0; k < num_disparities; ++k) {
        const int xr = x - (min_disparity + k);
        const std::size_t p = static_cast<std::size_t>(y) * width;
        costs[(p + x) * num_disparities + k] = static_cast<std::int16_t>(
            xr < 0 || xr >= width ? out_of_view_cost : std::popcount(census_left[p + x] ^ census_right[p + xr]));
      }
  return costs;
}

}  // namespace dsmplan::stereo
