// sgm_match(): Semi-Global Matching of a rectified pair (H. Hirschmüller, "Stereo Processing by
// Semiglobal Matching and Mutual Information", IEEE PAMI 30(2), 2008) from checked arguments to
// the filtered disparity images: census (census_cost.cpp), aggregation and winners
// (sgm_aggregate.cpp, sgm_simd.cpp, disparity_refine.cpp), left-right check, small segments
// (speckle_filter.cpp). Large images go in overlapping bands of rows, the way tiled SGM
// implementations bound their memory (Hirschmüller, "Semi-Global Matching - Motivation,
// Developments and Applications", Photogrammetric Week 2011: tiles with overlap, each keeping its
// centre).
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "stereo/sgm_parts.hpp"

namespace dsmplan {

namespace {

using namespace stereo;

std::string size_text(const ImageView& image) {
  return std::to_string(image.width) + " x " + std::to_string(image.height) + " pixels";
}

void check_image(const ImageView& image, const std::string& name) {
  if (!image.pixels || image.width <= 0 || image.height <= 0)
    throw ArgumentError(name, "is empty (" + size_text(image) + ")");
  if (image.bits != 8 && image.bits != 16)
    throw ArgumentError(name, "has " + std::to_string(image.bits) + " bits per pixel; 8 or 16 are matched");
  if (image.row_pixels() < image.width)
    throw ArgumentError(name, "has rows of " + std::to_string(image.row_pixels()) + " pixels, less than its width " +
                                  std::to_string(image.width));
}

void check_options(const SgmOptions& o, int width) {
  const auto fail = [](const std::string& option, const std::string& problem) { throw ArgumentError(option, problem); };
  if (o.num_disparities < 1)
    fail("num_disparities", "is " + std::to_string(o.num_disparities) + "; at least 1 disparity is searched");
  if (o.num_disparities > 16384) fail("num_disparities", "is " + std::to_string(o.num_disparities) + "; at most 16384");
  const long long first = o.min_disparity, last = first + o.num_disparities - 1;
  if (first <= -width || last >= width)
    fail("num_disparities", "the disparity range [" + std::to_string(first) + ", " + std::to_string(last + 1) +
                                ") does not fit the image width " + std::to_string(width) +
                                ": every disparity must be less than the width in magnitude");
  for (const auto& [name, size] :
       {std::pair{"census_width", o.census_width}, std::pair{"census_height", o.census_height}})
    if (size < 3 || size > 15 || size % 2 == 0) fail(name, "is " + std::to_string(size) + "; odd, 3 to 15");
  if (o.census_width * o.census_height > 65)
    fail("census_width", "the window " + std::to_string(o.census_width) + " x " + std::to_string(o.census_height) +
                             " has more than 64 neighbours");
  if (o.paths != 8 && o.paths != 4) fail("paths", "is " + std::to_string(o.paths) + "; 8 or 4");
  if (o.p1 < 1 || o.p1 >= o.p2 || o.p2 > 1000)
    fail("p2", "P1 = " + std::to_string(o.p1) + ", P2 = " + std::to_string(o.p2) + "; 1 <= P1 < P2 <= 1000");
  if (!(o.intensity_unit >= 0) || !std::isfinite(o.intensity_unit)) fail("intensity_unit", "must be >= 0");
  if (std::isnan(o.lr_max_difference)) fail("lr_max_difference", "is NaN");
  if (o.speckle_min_pixels < 0) fail("speckle_min_pixels", "must be >= 0");
  if (!(o.speckle_max_difference >= 0) || !std::isfinite(o.speckle_max_difference))
    fail("speckle_max_difference", "must be >= 0");
  if (o.threads < 0) fail("threads", "must be >= 0");
  if (!(o.max_memory_bytes >= 0)) fail("max_memory_bytes", "must be >= 0");
  if (o.band_overlap < 0) fail("band_overlap", "must be >= 0");
}

// Bytes of one band of `rows` rows (see stereo.hpp, "Complexity and memory").
double band_bytes(int width, int rows, int d16) {
  const double w = width;
  return 2.0 * w * rows * d16 + 28.0 * w * path_stride(d16) + 28.0 * w * rows;
}

}  // namespace

double sgm_memory_bytes(int width, int height, const SgmOptions& options) {
  return band_bytes(width, height, padded_disparities(std::max(1, options.num_disparities)));
}

struct SgmMatcher::Workspace {
  std::unique_ptr<stereo::LargeBuffer> sums;
};

SgmMatcher::SgmMatcher(const SgmOptions& options) : options_(options), workspace_(std::make_unique<Workspace>()) {}
SgmMatcher::~SgmMatcher() = default;
SgmMatcher::SgmMatcher(SgmMatcher&&) noexcept = default;
SgmMatcher& SgmMatcher::operator=(SgmMatcher&&) noexcept = default;

Disparity sgm_match(const ImageView& left, const ImageView& right, const SgmOptions& options) {
  return SgmMatcher(options).match(left, right);
}

Disparity SgmMatcher::match(const ImageView& left, const ImageView& right) {
  const SgmOptions& options = options_;
  check_image(left, "left image");
  check_image(right, "right image");
  if (right.width != left.width || right.height != left.height)
    throw ArgumentError("right image", "is " + size_text(right) + ", the left one " + size_text(left) +
                                           ": a rectified pair has one size");
  if (right.bits != left.bits)
    throw ArgumentError("right image", "has " + std::to_string(right.bits) + " bits per pixel, the left one " +
                                           std::to_string(left.bits));
  const int width = left.width, height = left.height;
  check_options(options, width);
  const int d16 = padded_disparities(options.num_disparities);

  // Bands: as many rows as the bound holds, each with band_overlap rows more on both sides.
  const double bound = options.max_memory_bytes > 0 ? options.max_memory_bytes : machine_memory_bytes() / 2;
  int core_rows = height;
  if (band_bytes(width, height, d16) > bound) {
    const double per_row = band_bytes(width, 1, d16) - band_bytes(width, 0, d16);
    const double rows_fit = std::floor((bound - band_bytes(width, 0, d16)) / per_row);
    core_rows = static_cast<int>(std::clamp(rows_fit - 2.0 * options.band_overlap, 0.0, double(height)));
    const int least_rows = std::min(height, 16);
    if (core_rows < least_rows) {
      const int band = std::min(height, least_rows + 2 * options.band_overlap);
      throw InputError("", "sgm_match",
                       "a band of " + std::to_string(band) + " rows of " + std::to_string(width) + " pixels and " +
                           std::to_string(options.num_disparities) + " disparities needs about " +
                           format_bytes(band_bytes(width, band, d16)) + ", more than the memory bound " +
                           format_bytes(bound) + " (max_memory_bytes; by default half the machine's memory)");
    }
  }
  require_memory("", "sgm_match",
                 band_bytes(width, std::min(height, core_rows + 2 * options.band_overlap), d16) + 8.0 * width * height);

  Disparity out;
  out.width = width, out.height = height;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  out.left.assign(pixels, std::numeric_limits<float>::quiet_NaN());
  out.right.assign(pixels, std::numeric_limits<float>::quiet_NaN());

  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    const bool concurrent = arena.max_concurrency() >= 2;
    const Simd simd = best_simd();
    for (int core0 = 0; core0 < height; core0 += core_rows) {
      const int core1 = std::min(height, core0 + core_rows);
      const int band0 = std::max(0, core0 - options.band_overlap),
                band1 = std::min(height, core1 + options.band_overlap);
      const int rows = band1 - band0;
      const std::vector<std::uint16_t> left_pixels = to_u16(left, band0, rows),
                                       right_pixels = to_u16(right, band0, rows);
      const std::vector<std::uint64_t> census_left =
          census_transform(left_pixels.data(), width, rows, options.census_width, options.census_height);
      const std::vector<std::uint64_t> census_right =
          census_transform(right_pixels.data(), width, rows, options.census_width, options.census_height);
      unsigned largest = 0;
      for (const auto* image : {&left_pixels, &right_pixels})
        for (const std::uint16_t v : *image) largest = std::max<unsigned>(largest, v);
      double unit = options.intensity_unit;
      if (unit == 0) unit = left.bits == 8 ? 1.0 : std::max(1.0, largest / 255.0);

      Problem problem;
      problem.width = width, problem.height = rows;
      problem.census_left = census_left.data(), problem.census_right = census_right.data();
      problem.intensity = left_pixels.data();
      problem.min_disparity = options.min_disparity, problem.num_disparities = options.num_disparities;
      set_penalties(problem, options, options.census_width * options.census_height - 1, unit, largest);
      aggregate(
          problem, simd, concurrent,
          [&](int y, const std::int16_t* sums) {
            const int image_row = band0 + y;
            if (image_row < core0 || image_row >= core1) return;
            std::vector<std::int32_t> best(width);
            std::vector<std::int16_t> right_cost(width + d16), best_right(width + d16);
            winners_row(sums, width, d16, options.num_disparities, best.data(), right_cost.data(), best_right.data(),
                        simd);
            const std::size_t start = static_cast<std::size_t>(image_row) * width;
            refine_row(sums, width, d16, options.num_disparities, options.min_disparity, options.subpixel, best.data(),
                       right_cost.data(), best_right.data(), out.left.data() + start, out.right.data() + start);
            if (options.lr_max_difference >= 0)
              left_right_check_row(out.left.data() + start, out.right.data() + start, width, options.lr_max_difference);
          },
          workspace_->sums);
    }
  });
  if (options.speckle_min_pixels > 0)
    remove_small_segments(out.left, width, height, options.speckle_min_pixels, options.speckle_max_difference);
  if (!options.right_disparity) out.right.clear(), out.right.shrink_to_fit();
  return out;
}

}  // namespace dsmplan
