// Stereo: Semi-Global Matching (dsmplan/stereo.hpp; H. Hirschmüller, "Stereo Processing
// by Semiglobal Matching and Mutual Information", IEEE PAMI 30(2), 2008), each step against an
// oracle that shares none of its code:
//   - the Census transform (Zabih & Woodfill, ECCV 1994) against a loop over the clamped window;
//   - the kernels' costs (SSE2 and AVX2) against std::popcount of the census words;
//   - the SIMD aggregation (both sweeps, one or two threads) against the recurrence written out
//     per path over the whole image (aggregate_reference), integer for integer;
//   - the winners and sub-pixel step against a plain argmin and the parabola formula;
//   - the speckle filter against a union-find labelling, the left-right check by hand;
//   - the whole matcher on a rendered pair with known sub-pixel disparity (a slanted textured
//     plane and a box in front of it), and on Middlebury's Aloe against its ground truth, held to
//     the bad-pixel rates OpenCV's StereoSGBM MODE_HH reaches on the same pair (bench_sgm).
#include "dsmplan/stereo.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "aloe_pair.hpp"
#include "dsmplan/core.hpp"
#include "stereo/sgm_parts.hpp"
#include "testkit.hpp"

using namespace dsmplan;
using namespace dsmplan::stereo;

namespace {

std::vector<Simd> simd_levels() {
  std::vector<Simd> levels = {Simd::sse2};
  if (best_simd() != Simd::sse2) levels.push_back(Simd::avx2);
  if (best_simd() == Simd::avx2_vpopcnt || best_simd() == Simd::avx512) levels.push_back(Simd::avx2_vpopcnt);
  if (best_simd() == Simd::avx512) levels.push_back(Simd::avx512);
  return levels;
}

std::vector<std::uint16_t> random_image(int width, int height, unsigned largest, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<unsigned> value(0, largest);
  std::vector<std::uint16_t> image(static_cast<std::size_t>(width) * height);
  for (auto& v : image) v = static_cast<std::uint16_t>(value(random));
  return image;
}

// A textured image with some structure (a smoothed random field): SGM on pure noise is not a test.
std::vector<std::uint16_t> smooth_random_image(int width, int height, unsigned seed) {
  const std::vector<std::uint16_t> noise = random_image(width, height, 255, seed);
  std::vector<std::uint16_t> image(noise.size());
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      int sum = 0, n = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = std::clamp(x + dx, 0, width - 1), yy = std::clamp(y + dy, 0, height - 1);
          sum += noise[static_cast<std::size_t>(yy) * width + xx], ++n;
        }
      image[static_cast<std::size_t>(y) * width + x] = static_cast<std::uint16_t>(sum / n);
    }
  return image;
}

// ---- census ----------------------------------------------------------------------------------

std::uint64_t naive_census(const std::vector<std::uint16_t>& image, int width, int height, int x, int y, int cw,
                           int ch) {
  const auto at = [&](int xx, int yy) {
    return image[static_cast<std::size_t>(std::clamp(yy, 0, height - 1)) * width + std::clamp(xx, 0, width - 1)];
  };
  std::uint64_t bits = 0;
  for (int dy = -ch / 2; dy <= ch / 2; ++dy)
    for (int dx = -cw / 2; dx <= cw / 2; ++dx) {
      if (dx == 0 && dy == 0) continue;
      bits = (bits << 1) | (at(x + dx, y + dy) < at(x, y) ? 1u : 0u);
    }
  return bits;
}

TEST(Census, EqualsTheClampedWindowLoop) {
  for (const auto& [cw, ch] : {std::pair{9, 7}, std::pair{5, 5}, std::pair{3, 3}, std::pair{13, 5}}) {
    const int width = 37, height = 23;
    const auto image = random_image(width, height, 7, 11u * cw + ch);  // few levels: ties are common
    const auto census = census_transform(image.data(), width, height, cw, ch);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        ASSERT_EQ(census[static_cast<std::size_t>(y) * width + x], naive_census(image, width, height, x, y, cw, ch))
            << cw << "x" << ch << " at " << x << "," << y;
  }
}

// ---- the kernels' costs ------------------------------------------------------------------------

TEST(Cost, KernelsGiveHammingDistancesAndTheOutOfViewAndPaddingCosts) {
  const int width = 41;
  std::mt19937_64 random(5);
  std::vector<std::uint64_t> left(width), right(width);
  for (auto& v : left) v = random() >> 2;  // 62 bits
  for (auto& v : right) v = random() >> 2;
  for (const int min_disparity : {0, -7, 5})
    for (const int num_disparities : {1, 13, 16, 35, 64}) {
      if (min_disparity + num_disparities > width) continue;
      const int d16 = padded_disparities(num_disparities);
      std::vector<std::uint64_t> reversed(width + 2 * widest_lanes, 0);
      for (int t = 0; t < width; ++t) reversed[widest_lanes + t] = right[width - 1 - t];
      SweepRow row;
      row.width = width, row.d16 = d16, row.num_disparities = num_disparities, row.min_disparity = min_disparity;
      row.out_of_view_cost = 62, row.pad_cost = 1000;
      row.census_left = left.data(), row.right_reversed = reversed.data() + widest_lanes;
      const auto expected =
          cost_volume_reference(left.data(), right.data(), width, 1, min_disparity, num_disparities, 62);
      for (const Simd simd : simd_levels())
        for (int x = 0; x < width; ++x) {
          std::vector<std::int16_t> cost(d16);
          cost_pixel(row, x, cost.data(), simd);
          for (int k = 0; k < d16; ++k) {
            const int want = k < num_disparities ? expected[static_cast<std::size_t>(x) * num_disparities + k] : 1000;
            ASSERT_EQ(cost[k], want) << simd_name(simd) << " x " << x << " k " << k << " min " << min_disparity;
          }
        }
    }
  // The reference itself against the definition, once by hand.
  const auto one = cost_volume_reference(left.data(), right.data(), width, 1, 0, 3, 62);
  EXPECT_EQ(one[10 * 3 + 2], std::popcount(left[10] ^ right[8]));
  EXPECT_EQ(one[1 * 3 + 2], 62);  // x - d = -1: outside
}

// ---- aggregation -------------------------------------------------------------------------------

struct SmallProblem {
  int width, height;
  std::vector<std::uint16_t> left, right;
  std::vector<std::uint64_t> census_left, census_right;
  Problem problem;
  double unit = 1;
};

SmallProblem small_problem(int width, int height, int min_disparity, int num_disparities, const SgmOptions& options,
                           unsigned largest, unsigned seed) {
  SmallProblem s{
      width, height, random_image(width, height, largest, seed), random_image(width, height, largest, seed + 1), {},
      {},    {},     largest > 255 ? largest / 255.0 : 1.0};
  s.census_left = census_transform(s.left.data(), width, height, options.census_width, options.census_height);
  s.census_right = census_transform(s.right.data(), width, height, options.census_width, options.census_height);
  s.problem.width = width, s.problem.height = height;
  s.problem.census_left = s.census_left.data(), s.problem.census_right = s.census_right.data();
  s.problem.intensity = s.left.data();
  s.problem.min_disparity = min_disparity, s.problem.num_disparities = num_disparities;
  set_penalties(s.problem, options, options.census_width * options.census_height - 1, s.unit, largest);
  return s;
}

TEST(Aggregation, SimdSweepsEqualThePlainRecurrence) {
  struct Case {
    int width, height, min_disparity, num_disparities, paths;
    bool adapt;
    unsigned largest;
    int census_width, census_height;
  };
  for (const Case c : {Case{23, 17, 0, 21, 8, true, 255, 9, 7}, Case{19, 11, -3, 16, 8, true, 255, 5, 5},
                       Case{30, 9, 2, 5, 4, true, 255, 9, 7}, Case{17, 13, 1, 33, 8, false, 255, 7, 7},
                       Case{25, 14, 0, 12, 8, true, 4095, 9, 7}, Case{70, 12, -5, 64, 8, true, 255, 9, 7},
                       Case{45, 10, 3, 40, 4, true, 255, 9, 7}}) {
    SgmOptions options;
    options.paths = c.paths, options.adapt_p2 = c.adapt, options.p1 = 9, options.p2 = 130;
    options.census_width = c.census_width, options.census_height = c.census_height;
    SmallProblem s = small_problem(c.width, c.height, c.min_disparity, c.num_disparities, options, c.largest,
                                   static_cast<unsigned>(c.width * 100 + c.num_disparities));
    const int out_of_view = c.census_width * c.census_height - 1;
    const auto costs = cost_volume_reference(s.census_left.data(), s.census_right.data(), c.width, c.height,
                                             c.min_disparity, c.num_disparities, out_of_view);
    const auto expected = aggregate_reference(s.problem, costs, options, s.unit);
    const int d = c.num_disparities, d16 = padded_disparities(d);
    for (const Simd simd : simd_levels())
      for (const bool concurrent : {false, true}) {
        std::vector<std::int32_t> got(expected.size(), -1);
        std::vector<int> calls(c.height, 0);
        std::unique_ptr<LargeBuffer> storage;
        aggregate(
            s.problem, simd, concurrent,
            [&](int y, const std::int16_t* sums) {
              ++calls[y];
              for (int x = 0; x < c.width; ++x)
                for (int k = 0; k < d; ++k)
                  got[(static_cast<std::size_t>(y) * c.width + x) * d + k] =
                      sums[static_cast<std::size_t>(x) * d16 + k];
            },
            storage);
        EXPECT_EQ(calls, std::vector<int>(c.height, 1));
        for (std::size_t i = 0; i < got.size(); ++i)
          ASSERT_EQ(got[i], expected[i]) << simd_name(simd) << (concurrent ? " concurrent" : " one thread") << " pixel "
                                         << i / d << " k " << i % d << " case " << c.width << "x" << c.height
                                         << " paths " << c.paths;
      }
  }
}

TEST(Aggregation, PenaltyFollowsTheIntensityStep) {
  SgmOptions options;
  options.p1 = 7, options.p2 = 100;
  EXPECT_EQ(adapted_p2(options, 1, 0), 100);
  EXPECT_EQ(adapted_p2(options, 1, 1), 50);
  EXPECT_EQ(adapted_p2(options, 1, 3), 25);
  EXPECT_EQ(adapted_p2(options, 1, 200), 8);  // never below P1 + 1
  EXPECT_EQ(adapted_p2(options, 16, 16), 50);
  options.adapt_p2 = false;
  EXPECT_EQ(adapted_p2(options, 1, 200), 100);
}

// ---- winners, sub-pixel ------------------------------------------------------------------------

// The disparities are floats: about one float step (2^-23 relative), at least 1e-6.
double float_tolerance(double want) { return std::max(1e-6, 1.2e-7 * std::abs(want)); }

TEST(Winners, LeastSumsOfBothImagesAndTheParabola) {
  // D16 = 16 and 64: the AVX-512 kernel takes the second, 32 disparities at a time.
  for (const auto& [width, d] : {std::pair{29, 11}, std::pair{83, 60}}) {
    const int d16 = padded_disparities(d), min_disparity = -2;
    std::mt19937 random(3);
    std::uniform_int_distribution<int> value(0, 40);  // few values: ties
    std::vector<std::int16_t> sums(static_cast<std::size_t>(width) * d16);
    for (int x = 0; x < width; ++x)
      for (int k = 0; k < d16; ++k) sums[static_cast<std::size_t>(x) * d16 + k] = k < d ? value(random) : 30000;
    const auto s = [&](int x, int k) { return sums[static_cast<std::size_t>(x) * d16 + k]; };
    for (const Simd simd : simd_levels()) {
      std::vector<std::int32_t> best(width);
      std::vector<std::int16_t> right_cost(width + d16), best_right(width + d16);
      winners_row(sums.data(), width, d16, d, best.data(), right_cost.data(), best_right.data(), simd);
      std::vector<float> left(width), right(width);
      refine_row(sums.data(), width, d16, d, min_disparity, true, best.data(), right_cost.data(), best_right.data(),
                 left.data(), right.data());
      for (int x = 0; x < width; ++x) {
        int k = 0;
        for (int j = 1; j < d; ++j)
          if (s(x, j) < s(x, k)) k = j;
        const int xr = x - min_disparity - k;
        if (xr < 0 || xr >= width) {
          EXPECT_TRUE(std::isnan(left[x])) << x;
          continue;
        }
        double want = min_disparity + k;
        if (k > 0 && k < d - 1) {
          const double a = s(x, k - 1), b = s(x, k), c = s(x, k + 1);
          if (a - 2 * b + c > 0) want += (a - c) / (2 * (a - 2 * b + c));
        }
        EXPECT_NEAR(left[x], want, float_tolerance(want)) << simd_name(simd) << " x " << x;
      }
      for (int xr = 0; xr < width; ++xr) {
        int k_best = -1;
        for (int k = 0; k < d; ++k) {
          const int x = xr + min_disparity + k;
          if (x < 0 || x >= width) continue;
          if (k_best < 0 || s(x, k) < s(xr + min_disparity + k_best, k_best)) k_best = k;
        }
        if (k_best < 0) {
          EXPECT_TRUE(std::isnan(right[xr]));
          continue;
        }
        const int x = xr + min_disparity + k_best;
        double want = min_disparity + k_best;
        if (k_best > 0 && k_best < d - 1 && x > 0 && x + 1 < width) {
          const double a = s(x - 1, k_best - 1), b = s(x, k_best), c = s(x + 1, k_best + 1);
          if (a - 2 * b + c > 0) want += (a - c) / (2 * (a - 2 * b + c));
        }
        EXPECT_NEAR(right[xr], want, float_tolerance(want)) << simd_name(simd) << " right x " << xr;
      }
    }
  }
}

// ---- speckle filter, left-right check ------------------------------------------------------------

// Union-find over 4-neighbours within the threshold: the oracle of the segment sizes.
std::vector<float> speckle_oracle(std::vector<float> d, int width, int height, int min_pixels, double max_difference) {
  std::vector<std::size_t> parent(d.size());
  std::iota(parent.begin(), parent.end(), 0);
  const auto find = [&](std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * width + x;
      for (const std::size_t q : {x + 1 < width ? p + 1 : p, y + 1 < height ? p + width : p})
        if (q != p && !std::isnan(d[p]) && !std::isnan(d[q]) && std::abs(d[p] - d[q]) <= max_difference)
          parent[find(p)] = find(q);
    }
  std::vector<std::size_t> size(d.size(), 0);
  for (std::size_t i = 0; i < d.size(); ++i) size[find(i)]++;
  for (std::size_t i = 0; i < d.size(); ++i)
    if (size[find(i)] < static_cast<std::size_t>(min_pixels)) d[i] = NAN;
  return d;
}

bool same_images(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!(std::isnan(a[i]) && std::isnan(b[i])) && a[i] != b[i]) return false;
  return true;
}

TEST(Speckle, PlantedBlobGoesTheLargeRegionsStay) {
  const int width = 40, height = 30;
  std::vector<float> d(static_cast<std::size_t>(width) * height, 10.0f);
  for (int y = 5; y < 10; ++y)
    for (int x = 5; x < 10; ++x) d[static_cast<std::size_t>(y) * width + x] = 30.0f;  // 25 pixels
  for (int y = 15; y < 22; ++y)
    for (int x = 20; x < 27; ++x) d[static_cast<std::size_t>(y) * width + x] = 40.0f;  // 49 pixels
  EXPECT_EQ(remove_small_segments(d, width, height, 30, 1.0), 25u);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const bool blob = x >= 5 && x < 10 && y >= 5 && y < 10;
      EXPECT_EQ(std::isnan(d[static_cast<std::size_t>(y) * width + x]), blob) << x << "," << y;
    }
}

TEST(Speckle, EqualsUnionFindOnRandomImages) {
  std::mt19937 random(8);
  std::uniform_int_distribution<int> level(0, 5);
  for (int trial = 0; trial < 20; ++trial) {
    const int width = 31, height = 19;
    std::vector<float> d(static_cast<std::size_t>(width) * height);
    for (auto& v : d) {
      const int l = level(random);
      v = l == 5 ? NAN : l * 0.7f;
    }
    const auto want = speckle_oracle(d, width, height, 6, 1.0);
    remove_small_segments(d, width, height, 6, 1.0);
    ASSERT_TRUE(same_images(d, want)) << trial;
  }
}

TEST(LeftRight, KeepsOnlyConfirmedPixels) {
  const int width = 6, height = 1;
  std::vector<float> left = {NAN, 1.0f, 1.2f, 2.0f, 0.4f, 5.0f};
  // Right pixel 0 holds 1.0 (left 1 -> right 0 agrees); left 2: 1.2 -> right 1 (0.8: agrees);
  // left 3: 2.0 -> right 1 (0.8: |2.0 - 0.8| > 1 disagrees); left 4: 0.4 -> right 4 (NaN);
  // left 5: 5.0 -> right 0 (1.0: disagrees).
  std::vector<float> right = {1.0f, 0.8f, 3.0f, 3.0f, NAN, 3.0f};
  EXPECT_EQ(left_right_check(left, right, width, height, 1.0), 3u);
  EXPECT_TRUE(same_images(left, {NAN, 1.0f, 1.2f, NAN, NAN, NAN}));
}

// ---- the whole matcher on a rendered pair --------------------------------------------------------

// A random texture, bilinear between the values on a lattice of 1.3 px: continuous, so the right
// image can be sampled at any sub-pixel position.
struct Texture {
  int size;
  std::vector<float> lattice;
  explicit Texture(unsigned seed, int n = 400) : size(n), lattice(static_cast<std::size_t>(n) * n) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<float> value(20, 235);
    for (auto& v : lattice) v = value(random);
  }
  float at(double u, double v) const {
    u /= 1.3, v /= 1.3;
    const int i = std::clamp(static_cast<int>(std::floor(u)), 0, size - 2),
              j = std::clamp(static_cast<int>(std::floor(v)), 0, size - 2);
    const double fu = std::clamp(u - i, 0.0, 1.0), fv = std::clamp(v - j, 0.0, 1.0);
    const auto l = [&](int a, int b) { return lattice[static_cast<std::size_t>(b) * size + a]; };
    return static_cast<float>((1 - fv) * ((1 - fu) * l(i, j) + fu * l(i + 1, j)) +
                              fv * ((1 - fu) * l(i, j + 1) + fu * l(i + 1, j + 1)));
  }
};

struct RenderedPair {
  int width = 200, height = 150;
  std::vector<std::uint8_t> left, right;
  std::vector<float> truth;            // left disparity
  std::vector<std::uint8_t> occluded;  // left pixels the right image does not see
};

// A slanted background plane, d = 12 + 0.05 x + 0.03 y, and in front of it a box at d = 30 over
// columns [80, 130), rows [40, 110).
RenderedPair render_pair() {
  RenderedPair p;
  const Texture back(1), front(2);
  const auto background = [](double x, double y) { return 12 + 0.05 * x + 0.03 * y; };
  const double box_d = 30, box_x0 = 80, box_x1 = 130, box_y0 = 40, box_y1 = 110;
  const std::size_t n = static_cast<std::size_t>(p.width) * p.height;
  p.left.resize(n), p.right.resize(n), p.truth.resize(n), p.occluded.resize(n);
  for (int y = 0; y < p.height; ++y) {
    const bool box_row = y >= box_y0 && y < box_y1;
    for (int x = 0; x < p.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * p.width + x;
      const bool in_box = box_row && x >= box_x0 && x < box_x1;
      p.left[i] = static_cast<std::uint8_t>(std::lround(in_box ? front.at(x, y) : back.at(x, y)));
      p.truth[i] = static_cast<float>(in_box ? box_d : background(x, y));
      // A background point is hidden from the right camera where the box covers its right position.
      const double xr = x - background(x, y);
      p.occluded[i] = !in_box && box_row && xr >= box_x0 - box_d - 0.5 && xr < box_x1 - box_d + 0.5;
      // Right image: the box at x - 30; the background point of left column u lands at
      // u - d(u, y), so the right pixel xr shows u = (xr + 12 + 0.03 y) / 0.95.
      const bool right_box = box_row && x + box_d >= box_x0 && x + box_d < box_x1;
      const double u = (x + 12 + 0.03 * y) / 0.95;
      p.right[i] = static_cast<std::uint8_t>(std::lround(right_box ? front.at(x + box_d, y) : back.at(u, y)));
    }
  }
  return p;
}

TEST(Matcher, RenderedPlaneAndBoxSubPixelAndOcclusions) {
  const RenderedPair p = render_pair();
  SgmOptions options;
  options.num_disparities = 48, options.right_disparity = true;
  const Disparity d =
      sgm_match(ImageView(p.left.data(), p.width, p.height), ImageView(p.right.data(), p.width, p.height), options);
  ASSERT_EQ(d.left.size(), p.left.size());
  ASSERT_EQ(d.right.size(), p.left.size());
  std::vector<double> errors;
  std::size_t visible = 0, matched = 0, occluded = 0, occluded_invalid = 0;
  for (int y = 4; y < p.height - 4; ++y)
    for (int x = 50; x < p.width - 4; ++x) {  // columns < 50 see past the right image's edge
      const std::size_t i = static_cast<std::size_t>(y) * p.width + x;
      if (p.occluded[i]) {
        ++occluded, occluded_invalid += std::isnan(d.left[i]);
        continue;
      }
      ++visible;
      if (std::isnan(d.left[i])) continue;
      ++matched;
      errors.push_back(std::abs(d.left[i] - p.truth[i]));
    }
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  const double within1 = double(std::lower_bound(errors.begin(), errors.end(), 1.0) - errors.begin()) / errors.size();
  EXPECT_LT(median, 0.2);
  EXPECT_GT(within1, 0.97);
  EXPECT_GT(double(matched) / visible, 0.9);
  ASSERT_GT(occluded, 500u);
  EXPECT_GT(double(occluded_invalid) / occluded, 0.8) << occluded_invalid << " of " << occluded;
  // Without the check, the occluded pixels get (wrong) disparities: the check is what removes them.
  options.lr_max_difference = -1, options.speckle_min_pixels = 0;
  const Disparity unchecked =
      sgm_match(ImageView(p.left.data(), p.width, p.height), ImageView(p.right.data(), p.width, p.height), options);
  std::size_t unchecked_invalid = 0;
  for (std::size_t i = 0; i < p.occluded.size(); ++i)
    unchecked_invalid += p.occluded[i] && std::isnan(unchecked.left[i]);
  EXPECT_LT(unchecked_invalid, occluded_invalid / 4);
}

TEST(Matcher, SameResultOnOneOrTwoThreadsAnd16Bits) {
  const RenderedPair p = render_pair();
  SgmOptions options;
  options.num_disparities = 48, options.right_disparity = true;
  const ImageView left(p.left.data(), p.width, p.height), right(p.right.data(), p.width, p.height);
  options.threads = 1;
  const Disparity one = sgm_match(left, right, options);
  options.threads = 2;
  const Disparity two = sgm_match(left, right, options);
  EXPECT_TRUE(same_images(one.left, two.left));
  EXPECT_TRUE(same_images(one.right, two.right));
  // The same pair in 16 bits (x 16): the census and, with intensity_unit 16, the penalties agree.
  std::vector<std::uint16_t> left16(p.left.begin(), p.left.end()), right16(p.right.begin(), p.right.end());
  for (auto& v : left16) v = static_cast<std::uint16_t>(v * 16);
  for (auto& v : right16) v = static_cast<std::uint16_t>(v * 16);
  options.intensity_unit = 16;
  const Disparity wide =
      sgm_match(ImageView(left16.data(), p.width, p.height), ImageView(right16.data(), p.width, p.height), options);
  EXPECT_TRUE(same_images(one.left, wide.left));
}

TEST(Matcher, BandsAgreeWithTheWholeImageAwayFromTheSeams) {
  const RenderedPair p = render_pair();
  SgmOptions options;
  options.num_disparities = 48;
  const ImageView left(p.left.data(), p.width, p.height), right(p.right.data(), p.width, p.height);
  const Disparity whole = sgm_match(left, right, options);
  options.max_memory_bytes = sgm_memory_bytes(p.width, 60, options);  // bands of < 60 rows
  options.band_overlap = 16;
  const Disparity banded = sgm_match(left, right, options);
  std::size_t both = 0, agree = 0, differ_valid = 0;
  for (std::size_t i = 0; i < whole.left.size(); ++i) {
    if (std::isnan(whole.left[i]) != std::isnan(banded.left[i])) ++differ_valid;
    if (std::isnan(whole.left[i]) || std::isnan(banded.left[i])) continue;
    ++both, agree += std::abs(whole.left[i] - banded.left[i]) <= 0.5;
  }
  EXPECT_GT(double(agree) / both, 0.98);
  EXPECT_LT(double(differ_valid) / whole.left.size(), 0.03);
  EXPECT_FALSE(same_images(whole.left, banded.left)) << "the bound did not make bands";
}

// ---- Aloe ----------------------------------------------------------------------------------------

// OpenCV 4.6 StereoSGBM MODE_HH on the same pair, the same grey images and 224 disparities, tuned
// as bench/bench_sgm.cpp says, measured by `build/bench/bench_sgm 5` (bench/README.md, "SGM (issue
// 16)"): blockSize 3, P1 144, P2 576 were its best; bad > 1 px 6.87 %, bad > 2 px 2.84 % of its
// matched pixels, 71.4 % of the pixels with ground truth matched.
constexpr double opencv_hh_bad1 = 0.0687, opencv_hh_bad2 = 0.0284, opencv_hh_complete = 0.714;

TEST(Matcher, AloeAtLeastAsGoodAsOpenCvHH) {
  const aloe::Pair pair = aloe::read_pair(testkit::data_path("middlebury-aloe"));
  SgmOptions options;
  options.num_disparities = 224;
  const auto start = std::chrono::steady_clock::now();
  const Disparity d = sgm_match(ImageView(pair.left.pixels.data(), pair.left.width, pair.left.height),
                                ImageView(pair.right.pixels.data(), pair.right.width, pair.right.height), options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const aloe::Rates r = aloe::rates(d.left, pair.truth);
  std::printf("Aloe: bad > 1 px %.2f %%, bad > 2 px %.2f %%, complete %.1f %% (%.2f s)\n", 100 * r.bad1, 100 * r.bad2,
              100 * r.completeness, seconds);
  EXPECT_LE(r.bad1, opencv_hh_bad1);
  EXPECT_LE(r.bad2, opencv_hh_bad2);
  EXPECT_GE(r.completeness, opencv_hh_complete);
}

// ---- bad input -----------------------------------------------------------------------------------

void expect_argument_error(const std::function<void()>& call, const std::string& names) {
  try {
    call();
    ADD_FAILURE() << "no error; expected one naming " << names;
  } catch (const ArgumentError& e) {
    const std::string text = e.what();
    EXPECT_NE(text.find(names), std::string::npos) << text;
    EXPECT_EQ(text.find('\n'), std::string::npos) << text;
  }
}

TEST(Matcher, BadInputIsOneLineNamingTheArgument) {
  std::vector<std::uint8_t> a(40 * 30, 1), b(41 * 30, 1);
  std::vector<std::uint16_t> wide(40 * 30, 1);
  const ImageView left(a.data(), 40, 30);
  SgmOptions o;
  o.num_disparities = 16;
  expect_argument_error([&] { sgm_match(left, ImageView(b.data(), 41, 30), o); }, "right image: is 41 x 30");
  expect_argument_error([&] { sgm_match(left, ImageView(wide.data(), 40, 30), o); }, "right image: has 16 bits");
  expect_argument_error([&] { sgm_match(left, ImageView(), o); }, "right image: is empty");
  ImageView odd = left;
  odd.bits = 12;
  expect_argument_error([&] { sgm_match(odd, odd, o); }, "left image: has 12 bits");
  const auto with = [&](auto change, const std::string& names) {
    SgmOptions bad = o;
    change(bad);
    expect_argument_error([&] { sgm_match(left, left, bad); }, names);
  };
  with([](SgmOptions& x) { x.num_disparities = 0; }, "num_disparities: is 0");
  with([](SgmOptions& x) { x.num_disparities = 41; }, "num_disparities: the disparity range [0, 41) does not fit");
  with([](SgmOptions& x) { x.min_disparity = -40; }, "does not fit the image width 40");
  with([](SgmOptions& x) { x.p1 = 20, x.p2 = 10; }, "p2: P1 = 20, P2 = 10");
  with([](SgmOptions& x) { x.p2 = 5000; }, "P2 <= 1000");
  with([](SgmOptions& x) { x.census_width = 8; }, "census_width: is 8");
  with([](SgmOptions& x) { x.census_width = 15, x.census_height = 15; }, "more than 64 neighbours");
  with([](SgmOptions& x) { x.paths = 16; }, "paths: is 16");
  with([](SgmOptions& x) { x.lr_max_difference = NAN; }, "lr_max_difference");
  // A memory bound no band fits into: refused with the figure, as an InputError.
  o.max_memory_bytes = 1000;
  try {
    sgm_match(left, left, o);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("more than the memory bound"), std::string::npos) << e.what();
  }
}

}  // namespace
