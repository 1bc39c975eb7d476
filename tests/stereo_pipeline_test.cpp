// Stereo from frame cameras (dsmplan/stereo_frames.hpp), each part against an oracle
// that shares none of its code path:
//   - distortion: undistort(distort(p)) = p, and project() against the formula written out;
//   - rectification (Fusiello, Trucco & Verri 2000): known 3D points projected through both
//     rectified cameras land in the same row (epipolar residual < 0.01 px), the rectified images
//     hold, at those pixels, the original images' values at the original projections, and
//     triangulate() returns the point (< 1 mm);
//   - the median fusion against a hand count; pair parsing and `auto` selection;
//   - end to end: two views rendered by ray casting a 40 m x 40 m crop of the real NRW DSM
//     (cells as solid columns, a texture varying in x, y and z; one camera tilted and with lens
//     distortion), rectified, matched, triangulated and fused at 1 m, against the crop.
#include <gdal_priv.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "aerial_scene.hpp"
#include "dsmplan/frame_dsm.hpp"
#include "dsmplan/median_fusion.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/stereo_frames.hpp"
#include "dsmplan/stereo_io.hpp"
#include "dsmplan/stereo_job.hpp"
#include "dsmplan/tools.hpp"
#include "testkit.hpp"

using namespace dsmplan;

namespace {

using aerial::ColumnScene;
using aerial::nadir_camera;
using aerial::render;

// A smooth image whose value is known anywhere: for the resampling oracle.
GreyImage smooth_image(int w, int h) {
  GreyImage image;
  image.width = w;
  image.height = h;
  image.pixels.resize(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      image.pixels[static_cast<size_t>(y) * w + x] = static_cast<float>(100 + 0.3 * x + 0.2 * y);
  return image;
}

}  // namespace

TEST(StereoCamera, UndistortInvertsDistortAndProjectFollowsTheFormula) {
  FrameCamera c = nadir_camera(300, 400, {0, 0, 100}, 0.05, -0.03, -0.08, 0.002);
  c.distortion = {-0.08, 0.02, 0.002, -0.001, 0.004};
  for (double x = -0.4; x <= 0.4; x += 0.1)
    for (double y = -0.4; y <= 0.4; y += 0.1) {
      const auto d = distort(c, x, y);
      const auto u = undistort(c, d[0], d[1]);
      EXPECT_NEAR(u[0], x, 1e-10);
      EXPECT_NEAR(u[1], y, 1e-10);
    }
  // project() against the formula written out for one point.
  const Vec3 X{12.0, -7.0, 3.0};
  double p[3];
  for (int i = 0; i < 3; ++i)
    p[i] = c.rotation[i][0] * (X[0] - c.center[0]) + c.rotation[i][1] * (X[1] - c.center[1]) +
           c.rotation[i][2] * (X[2] - c.center[2]);
  const double x = p[0] / p[2], y = p[1] / p[2], r2 = x * x + y * y;
  const auto [k1, k2, p1, p2, k3] = c.distortion;
  const double radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  double u, v;
  ASSERT_TRUE(project(c, X, u, v));
  EXPECT_NEAR(u, c.fx * xd + c.cx, 1e-9);
  EXPECT_NEAR(v, c.fy * yd + c.cy, 1e-9);
  // The ray through that pixel passes through X.
  const Vec3 ray = pixel_ray(c, u, v);
  const Vec3 to{X[0] - c.center[0], X[1] - c.center[1], X[2] - c.center[2]};
  const double n = std::sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(ray[i], to[i] / n, 1e-9);
  EXPECT_FALSE(project(c, {0, 0, 200}, u, v));  // behind the camera
}

TEST(StereoCamera, CheckCameraRefusesANonOrthonormalRotation) {
  FrameCamera c = nadir_camera(100, 100, {0, 0, 100});
  EXPECT_NO_THROW(check_camera(c, "camera 0"));
  c.rotation[0][1] = 0.1;
  EXPECT_THROW(check_camera(c, "camera 0"), ArgumentError);
  c = nadir_camera(100, 100, {0, 0, 100});
  c.rotation[2] = {0, 0, 1};  // determinant -1
  EXPECT_THROW(check_camera(c, "camera 0"), ArgumentError);
}

TEST(StereoRectification, PointsShareARowAndTriangulateBack) {
  // Two tilted cameras with distortion, baseline mostly along x with some y and z.
  const FrameCamera a = nadir_camera(240, 380, {100, 200, 150}, 0.04, -0.06, -0.05, 0.001);
  const FrameCamera b = nadir_camera(220, 400, {130, 206, 152}, -0.03, 0.05, 0.03, -0.001);
  RectifyOptions options;
  options.min_height = 0;
  options.max_height = 40;
  const RectifiedPair pair =
      rectify_pair(a, smooth_image(a.width, a.height), b, smooth_image(b.width, b.height), options);
  EXPECT_NEAR(pair.baseline, std::sqrt(30.0 * 30 + 6 * 6 + 2 * 2), 1e-9);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> along(95, 135), across(185, 215), up(0, 40);
  int checked = 0;
  double worst_row = 0, worst_point = 0, worst_value = 0;
  for (int k = 0; k < 2000; ++k) {
    const Vec3 X{along(random), across(random), up(random)};
    double ua, va, ub, vb;
    if (!project(a, X, ua, va) || !project(b, X, ub, vb)) continue;
    if (ua < 1 || va < 1 || ub < 1 || vb < 1 || ua > a.width - 2 || va > a.height - 2 || ub > b.width - 2 ||
        vb > b.height - 2)
      continue;
    double ul, vl, ur, vr;
    ASSERT_TRUE(project(pair.left, X, ul, vl));
    ASSERT_TRUE(project(pair.right, X, ur, vr));
    if (ul < 0 || vl < 0 || ul > pair.left.width - 1 || vl > pair.left.height - 1) continue;
    ++checked;
    worst_row = std::max(worst_row, std::abs(vl - vr));
    const double d = ul - ur;
    EXPECT_GE(d, 0);
    EXPECT_LT(d, pair.num_disparities);
    Vec3 back;
    ASSERT_TRUE(triangulate(pair, ul, vl, d, back));
    worst_point = std::max({worst_point, std::abs(back[0] - X[0]), std::abs(back[1] - X[1]), std::abs(back[2] - X[2])});
    // The rectified image holds the original image's value there (the smooth image is linear,
    // so bilinear resampling reproduces it to float precision).
    float value;
    ASSERT_TRUE(pair.left_image.sample(ul, vl, value));
    const int x0 = static_cast<int>(ul), y0 = static_cast<int>(vl);
    const int x1 = std::min(x0 + 1, pair.left.width - 1), y1 = std::min(y0 + 1, pair.left.height - 1);
    const auto masked = [&](int x, int y) { return pair.left_mask[static_cast<size_t>(y) * pair.left.width + x] != 0; };
    if (masked(x0, y0) && masked(x1, y0) && masked(x0, y1) && masked(x1, y1))
      worst_value = std::max(worst_value, std::abs(value - (100 + 0.3 * ua + 0.2 * va)));
  }
  std::printf("%d points: epipolar residual %.2e px, triangulation %.2e m, resampled value %.2e; %d disparities\n",
              checked, worst_row, worst_point, worst_value, pair.num_disparities);
  EXPECT_GT(checked, 500);
  EXPECT_LT(worst_row, 0.01) << "epipolar residual, px";
  EXPECT_LT(worst_point, 0.001) << "triangulation error, m";
  // Bilinear of a linear function at the rectified pixel vs the original projection: the linear
  // function is not linear through the rectifying map, so allow the map's curvature over one pixel.
  EXPECT_LT(worst_value, 0.05) << "resampled value vs the original's";
}

TEST(StereoFusion, MedianPerCellNodataWhereNothingFell) {
  Grid grid = dsm_grid({0, 0, 3, 2}, 1.0);
  ASSERT_EQ(grid.width, 3);
  ASSERT_EQ(grid.height, 2);
  const std::vector<std::vector<Vec3>> sets{{{0.5, 1.5, 10}, {0.2, 1.9, 30}, {0.9, 1.1, 11}},  // cell (0,0): 10, 30, 11
                                            {{2.5, 0.5, 4}, {2.1, 0.2, 6}, {9, 9, 1}}};  // (2,1): 4, 6; one outside
  EXPECT_EQ(fuse_median(grid, sets), 5u);
  EXPECT_FLOAT_EQ(grid.at(0, 0), 11);
  EXPECT_FLOAT_EQ(grid.at(2, 1), 5);
  EXPECT_TRUE(std::isnan(grid.at(1, 0)));
  EXPECT_TRUE(std::isnan(grid.at(0, 1)));
}

// The oracle: every cell's heights gathered, sorted, the middle one (or the mean of the two).
std::vector<float> brute_force_medians(const Grid& grid, const std::vector<Vec3>& points) {
  std::vector<std::vector<float>> heights(grid.cells());
  for (const Vec3& p : points) {
    int col, row;
    if (std::isfinite(p[2]) && grid.cell_at(p[0], p[1], col, row))
      heights[grid.index(col, row)].push_back(static_cast<float>(p[2]));
  }
  std::vector<float> z(grid.cells(), Grid::nodata);
  for (size_t i = 0; i < heights.size(); ++i) {
    auto& h = heights[i];
    if (h.empty()) continue;
    std::sort(h.begin(), h.end());
    z[i] = h.size() % 2 ? h[h.size() / 2] : 0.5f * (h[h.size() / 2 - 1] + h[h.size() / 2]);
  }
  return z;
}

TEST(StereoFusion, SpilledRunsMergeToTheSameMediansAsInMemory) {
  Grid grid = dsm_grid({100, 200, 150, 240}, 1.0);  // 50 x 40 cells
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> x(95, 155), y(195, 245), z(-30, 60);
  std::vector<Vec3> points(300000);
  for (Vec3& p : points) p = {x(random), y(random), std::round(z(random) * 4) / 4};  // ties too
  points[10][2] = NAN, points[20][2] = INFINITY, points[30] = {1e300, 0, 1};
  const std::vector<float> expected = brute_force_medians(grid, points);
  size_t inside = 0;
  for (float v : expected) inside += !std::isnan(v);
  ASSERT_GT(inside, grid.cells() * 9 / 10);

  Grid in_memory = grid;
  const size_t fused = fuse_median(in_memory, {points});
  testkit::TempDir dir;
  MedianFusionOptions options;
  options.memory_bytes = 1 << 16;  // 8,192 points a run
  options.temp_dir = dir.dir().string();
  MedianFusion fusion(grid, options);
  for (size_t at = 0; at < points.size(); at += 7777)  // handed over in uneven parts, as tiles come
    fusion.add(std::span(points).subspan(at, std::min<size_t>(7777, points.size() - at)));
  EXPECT_GT(fusion.runs_spilled(), 20u);
  EXPECT_TRUE(dir.files().empty());  // the spill file is anonymous
  Grid spilled = grid;
  EXPECT_EQ(fusion.finish(spilled), fused);
  EXPECT_GT(fused, points.size() * 6 / 10);  // the grid is 2/3 of the points' area
  EXPECT_LT(fused, points.size() - 2);
  for (size_t i = 0; i < expected.size(); ++i) {
    ASSERT_EQ(std::isnan(expected[i]), std::isnan(in_memory.z[i])) << i;
    ASSERT_EQ(std::isnan(expected[i]), std::isnan(spilled.z[i])) << i;
    if (std::isnan(expected[i])) continue;
    ASSERT_EQ(expected[i], in_memory.z[i]) << i;
    ASSERT_EQ(expected[i], spilled.z[i]) << i;
  }
}

TEST(StereoFusion, UnwritableTemporaryDirectoryAndTooSmallABudgetAreNamed) {
  Grid grid = dsm_grid({0, 0, 10, 10}, 1.0);
  MedianFusionOptions options;
  options.memory_bytes = 1000;
  EXPECT_THROW(MedianFusion(grid, options), ArgumentError);
  options.memory_bytes = 1 << 16;
  options.temp_dir = "/nonexistent/dsmplan-spill";
  MedianFusion fusion(grid, options);
  const std::vector<Vec3> points(10000, Vec3{5.5, 5.5, 1});
  try {
    fusion.add(points);
    FAIL() << "no error";
  } catch (const OutputError& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/dsmplan-spill"), std::string::npos) << error.what();
  }
}

TEST(StereoPairs, ExplicitAndAuto) {
  const auto pairs = parse_pairs("0-1,2-1", 3);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[1], std::make_pair(2, 1));
  EXPECT_THROW(parse_pairs("0-3", 3), ArgumentError);
  EXPECT_THROW(parse_pairs("1-1", 3), ArgumentError);
  EXPECT_THROW(parse_pairs("0_1", 3), ArgumentError);
  EXPECT_THROW(parse_pairs("0-1x", 3), ArgumentError);
  // A strip of 4 nadir views 20 m apart at 100 m over the ground, footprint 60 m: neighbours and
  // second neighbours overlap (67 %, 33 %), the third do not; a fifth camera far away overlaps none.
  std::vector<FrameCamera> cameras;
  for (int i = 0; i < 4; ++i) cameras.push_back(nadir_camera(200, 200 * 100 / 60.0, {20.0 * i, 0, 100}));
  cameras.push_back(nadir_camera(200, 200 * 100 / 60.0, {5000, 0, 100}));
  PairSelectionOptions options;
  options.ground_height = 0;
  const auto chosen = select_pairs_auto(cameras, options);
  const std::vector<std::pair<int, int>> expected{{0, 1}, {0, 2}, {1, 2}, {1, 3}, {2, 3}};
  EXPECT_EQ(chosen, expected);
  EXPECT_NEAR(base_to_height(cameras[0], cameras[1], 0), 0.2, 1e-12);
  EXPECT_EQ(footprint_overlap(cameras[0], cameras[4], 0), 0.0);
}

// A dense block of 200 views (10 strips of 20, 80 % forward and 75 % side overlap): the pairs grow
// with the views (each camera's best 4), every pair chosen is one brute force finds valid, and
// every camera with a valid partner keeps its best one. Explicitly named pairs with a baseline
// too short to measure depth are refused by the job (CliStereo / hostile catalogue).
TEST(StereoPairs, AutoGrowsWithTheViewsAndKeepsEachCamerasBest) {
  std::vector<FrameCamera> cameras;
  for (int strip = 0; strip < 10; ++strip)
    for (int i = 0; i < 20; ++i) cameras.push_back(nadir_camera(200, 200 * 100 / 60.0, {12.0 * i, 15.0 * strip, 100}));
  PairSelectionOptions options;
  const auto chosen = select_pairs_auto(cameras, options);
  const int n = static_cast<int>(cameras.size());
  EXPECT_LE(chosen.size(), static_cast<size_t>(options.max_partners * n));
  // Brute force: every valid pair and its score, as the selection's rule states them.
  std::vector<std::vector<std::pair<double, int>>> valid(n);
  size_t all_valid = 0;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const double ratio = base_to_height(cameras[i], cameras[j], 0);
      const double overlap =
          std::min(footprint_overlap(cameras[i], cameras[j], 0), footprint_overlap(cameras[j], cameras[i], 0));
      if (ratio < 0.1 || ratio > 1.2 || overlap < 0.3) continue;
      ++all_valid;
      const double score = overlap * std::min(1.0, ratio / 0.3);
      valid[i].emplace_back(score, j), valid[j].emplace_back(score, i);
    }
  EXPECT_GT(all_valid, chosen.size()) << "the block should offer more pairs than are kept";
  for (const auto& [a, b] : chosen) {
    const bool found = std::any_of(valid[a].begin(), valid[a].end(), [&](const auto& p) { return p.second == b; });
    EXPECT_TRUE(found) << a << "-" << b << " is not a valid pair";
  }
  for (int i = 0; i < n; ++i) {
    if (valid[i].empty()) continue;
    const auto best = *std::max_element(valid[i].begin(), valid[i].end(), [](const auto& x, const auto& y) {
      return x.first < y.first || (x.first == y.first && x.second > y.second);
    });
    const std::pair<int, int> pair{std::min(i, best.second), std::max(i, best.second)};
    EXPECT_TRUE(std::find(chosen.begin(), chosen.end(), pair) != chosen.end()) << "camera " << i << "'s best";
  }
  std::printf("200 views: %zu pairs chosen of %zu valid\n", chosen.size(), all_valid);
}

namespace {

// The oracle of `auto`, the rule written out over every pair: B/H within the bounds, both
// footprints' overlap at least min_overlap, score overlap x min(1, B/H / 0.3), each camera's
// max_partners best (ties to the lower index), a pair kept by either camera.
std::vector<std::pair<int, int>> brute_force_pairs(const std::vector<FrameCamera>& cameras,
                                                   const PairSelectionOptions& options) {
  const int n = static_cast<int>(cameras.size());
  std::vector<std::vector<std::pair<double, int>>> valid(n);
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const double ratio = base_to_height(cameras[i], cameras[j], options.ground_height);
      const double overlap = std::min(footprint_overlap(cameras[i], cameras[j], options.ground_height),
                                      footprint_overlap(cameras[j], cameras[i], options.ground_height));
      if (ratio < options.min_base_to_height || ratio > options.max_base_to_height || overlap < options.min_overlap)
        continue;
      const double score = overlap * std::min(1.0, ratio / 0.3);
      valid[i].emplace_back(score, j), valid[j].emplace_back(score, i);
    }
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < n; ++i) {
    std::sort(valid[i].begin(), valid[i].end(), [](const auto& a, const auto& b) {
      return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
    for (int k = 0; k < std::min<int>(options.max_partners, valid[i].size()); ++k)
      pairs.emplace_back(std::min(i, valid[i][k].second), std::max(i, valid[i][k].second));
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

// A block of strips x views nadir cameras, 200 px, footprint 60 m from 100 m, with `forward` and
// `side` overlap, jittered (seeded) by up to 2 m, 3 degrees and a little lens distortion.
std::vector<FrameCamera> camera_block(int strips, int views, double forward, double side, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::vector<FrameCamera> cameras;
  for (int s = 0; s < strips; ++s)
    for (int i = 0; i < views; ++i)
      cameras.push_back(nadir_camera(
          200, 200 * 100 / 60.0,
          {60 * (1 - forward) * i + 2 * unit(random), 60 * (1 - side) * s + 2 * unit(random), 100 + 2 * unit(random)},
          0.05 * unit(random), 0.05 * unit(random), 0.02 * unit(random)));
  return cameras;
}

}  // namespace

// Where no camera has more than 12 candidates (kCutPerPartner x max_partners), the boxes'
// prefilter must change nothing: small random blocks (2-13 views scattered over 150 m, 70-130 m
// up, tilted up to 15 degrees, with lens distortion; in every fifth one a view tilted 80 degrees,
// seeing the horizon), the choice equals brute force's exactly.
TEST(StereoPairs, PrefilteredSelectionEqualsBruteForceOnSmallBlocks) {
  std::mt19937 random(34);
  std::uniform_real_distribution<double> unit(-1, 1);
  size_t compared = 0, chosen_total = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 2 + trial % 12;
    std::vector<FrameCamera> cameras;
    for (int i = 0; i < n; ++i)
      cameras.push_back(
          nadir_camera(160 + 8 * (i % 3), 220, {75 * unit(random), 75 * unit(random), 100 + 30 * unit(random)},
                       0.26 * unit(random), 0.26 * unit(random), 0.05 * unit(random), 0.001 * unit(random)));
    if (trial % 5 == 4)  // an oblique view whose upper rays miss the ground: an unbounded box
      cameras.back() = nadir_camera(160, 220, cameras.back().center, 1.4, 0.1);
    PairSelectionOptions options;
    options.ground_height = 5 * unit(random);
    PairSelectionStats stats;
    if (trial % 5 == 4) EXPECT_TRUE(std::isinf(ground_box(cameras.back(), options.ground_height)[2]));
    const auto chosen = select_pairs_auto(cameras, options, &stats);
    EXPECT_EQ(chosen, brute_force_pairs(cameras, options)) << "trial " << trial << ", " << n << " views";
    EXPECT_LE(stats.footprints_cut, stats.boxes_met);
    compared += n * (n - 1) / 2, chosen_total += chosen.size();
  }
  std::printf("40 small blocks: %zu pairs compared, %zu chosen, the same as brute force\n", compared, chosen_total);
}

// A block of 100 views (10 strips of 10, 60 % forward and 30 % side overlap) and of 400 (20 x 20):
// the pairs and the footprints cut grow with the views (at most 4 n pairs, each camera choosing at
// most 4; at most 12 n footprints cut), and every camera keeps the best partner brute force finds.
TEST(StereoPairs, BlocksOf100And400ViewsMakeLinearlyManyPairs) {
  for (const int side : {10, 20}) {
    const std::vector<FrameCamera> cameras = camera_block(side, side, 0.6, 0.3, side);
    const int n = static_cast<int>(cameras.size());
    PairSelectionOptions options;
    PairSelectionStats stats;
    const auto start = std::chrono::steady_clock::now();
    const auto chosen = select_pairs_auto(cameras, options, &stats);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LE(chosen.size(), static_cast<size_t>(options.max_partners * n));
    EXPECT_LE(stats.footprints_cut, static_cast<size_t>(kCutPerPartner * options.max_partners * n));
    EXPECT_GE(chosen.size(), static_cast<size_t>(n));  // a block of overlapping views: every camera paired
    std::vector<int> degree(n, 0);
    for (const auto& [a, b] : chosen) ++degree[a], ++degree[b];
    EXPECT_GT(*std::min_element(degree.begin(), degree.end()), 0);
    std::printf(
        "%d views: %zu pairs (%.2f a view, most partners of one camera %d), %zu boxes met, %zu footprints "
        "cut, %.3f s\n",
        n, chosen.size(), double(chosen.size()) / n, *std::max_element(degree.begin(), degree.end()), stats.boxes_met,
        stats.footprints_cut, seconds);
    if (n > 100) continue;  // brute force: n^2 / 2 footprint pairs
    const auto oracle = brute_force_pairs(cameras, options);
    for (int i = 0; i < n; ++i) {  // the oracle's pairs of camera i include its best; it must be chosen too
      std::pair<int, int> best{-1, -1};
      double best_score = -1;
      for (const auto& [a, b] : oracle) {
        if (a != i && b != i) continue;
        const int j = a == i ? b : a;
        const double score =
            std::min(footprint_overlap(cameras[i], cameras[j], 0), footprint_overlap(cameras[j], cameras[i], 0)) *
            std::min(1.0, base_to_height(cameras[i], cameras[j], 0) / 0.3);
        if (score > best_score) best_score = score, best = {a, b};
      }
      if (best.first < 0) continue;
      EXPECT_TRUE(std::find(chosen.begin(), chosen.end(), best) != chosen.end()) << "camera " << i << "'s best";
    }
    size_t same = 0;
    for (const auto& p : chosen) same += std::find(oracle.begin(), oracle.end(), p) != oracle.end();
    std::printf("%d views: %zu of the %zu pairs chosen are brute force's (%zu)\n", n, same, chosen.size(),
                oracle.size());
    EXPECT_GE(same, chosen.size() * 9 / 10);
  }
}

namespace {

// 40 m x 40 m of the real DSM (1 m cells) in the middle of the 500 m crop, seen by two cameras:
// base 24 m at 110 m over the lowest cell (B/H 0.22), 240 x 240 pixels, 0.3 m on the ground; the
// right camera tilted and with lens distortion; a third camera 14 m across. Each view is
// rendered once per test binary, when first asked for.
struct RenderedScene {
  Grid truth;
  double lo = 0, hi = 0;
  std::vector<FrameCamera> cameras;
  double render_seconds = 0;
  std::vector<std::vector<GreyImage>> cache = std::vector<std::vector<GreyImage>>(3);
  const GreyImage& view(int i) {
    if (cache[i].empty()) {
      const auto start = std::chrono::steady_clock::now();
      cache[i].push_back(render(ColumnScene{truth, lo, hi}, cameras[i], 1 + i));
      render_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    return cache[i][0];
  }
  std::vector<GreyImage> views(int count) {
    std::vector<GreyImage> images;
    for (int i = 0; i < count; ++i) images.push_back(view(i));
    return images;
  }
};

RenderedScene& rendered_scene() {
  static RenderedScene scene = [] {
    RenderedScene p;
    const Grid& nrw = testkit::nrw_crop();
    const int n = 40;
    p.truth = aerial::crop(nrw, nrw.width / 2 - 20, nrw.height / 2 - 20, n);
    const auto [lo, hi] = std::minmax_element(p.truth.z.begin(), p.truth.z.end());
    p.lo = *lo;
    p.hi = *hi;
    const double xc = p.truth.x0 + n / 2.0, yc = p.truth.y0 - n / 2.0, zc = p.lo + 110;
    p.cameras = {nadir_camera(240, 380, {xc - 12, yc, zc}),
                 nadir_camera(240, 380, {xc + 12, yc + 1, zc + 2}, 0.02, -0.03, -0.04, 0.0005),
                 nadir_camera(240, 380, {xc, yc + 14, zc - 1}, -0.02, 0.01)};  // across the strip
    return p;
  }();
  return scene;
}

using aerial::dsm_errors;
using aerial::DsmErrors;

}  // namespace

TEST(StereoPipeline, RenderedNrwCropBackToItsDsm) {
  RenderedScene& scene = rendered_scene();
  const Grid& truth = scene.truth;
  const std::vector<FrameCamera> cameras(scene.cameras.begin(), scene.cameras.begin() + 2);
  const std::vector<GreyImage> images = scene.views(2);
  const int n = truth.width;
  const double lo = scene.lo, hi = scene.hi, render_seconds = scene.render_seconds;

  FrameStereoOptions options;
  options.rectify.min_height = lo;
  options.rectify.max_height = hi;
  Grid dsm = dsm_grid({truth.x0, truth.y1(), truth.x1(), truth.y0}, 1.0);
  const std::vector<std::pair<int, int>> pairs{{0, 1}};
  const FrameStereoStats stats = stereo_dsm(cameras, images, pairs, dsm, options);
  ASSERT_EQ(dsm.width, n);
  ASSERT_EQ(dsm.height, n);

  const DsmErrors e = dsm_errors(dsm, truth);
  const double completeness = e.completeness, median = e.median, over1 = e.over1, over3 = e.over3;
  std::printf(
      "NRW crop 40 m x 40 m (heights %.1f..%.1f m): completeness %.1f %%, median |error| %.3f m, "
      "> 1 m %.1f %%, > 3 m %.1f %%; %zu points, render %.2f s, rectify %.3f s, match %.3f s, "
      "triangulate %.3f s, fuse %.3f s\n",
      lo, hi, 100 * completeness, median, 100 * over1, 100 * over3, stats.points, render_seconds, stats.seconds_rectify,
      stats.seconds_match, stats.seconds_triangulate, stats.seconds_fuse);
  EXPECT_GT(completeness, 0.85);
  EXPECT_LT(median, 0.3);
  EXPECT_LT(over1, 0.15);
  EXPECT_LT(over3, 0.05);
}

// Large images are matched in bands of rectified rows: forced here with bands of 96 rows (the
// views are 480 px), the DSM must be as good against the truth as the whole pair's and agree with
// it in nearly every cell; and images read on demand hold at most the pair's two at a time.
TEST(StereoPipeline, BandsOfRowsAndImagesReadOnDemand) {
  RenderedScene& scene = rendered_scene();
  const Grid& truth = scene.truth;
  const std::vector<FrameCamera> cameras(scene.cameras.begin(), scene.cameras.begin() + 3);
  const std::vector<GreyImage> images = scene.views(3);
  FrameStereoOptions options;
  options.rectify.min_height = scene.lo;
  options.rectify.max_height = scene.hi;
  const std::vector<std::pair<int, int>> pairs{{0, 1}, {1, 2}, {0, 2}};
  Grid whole = dsm_grid({truth.x0, truth.y1(), truth.x1(), truth.y0}, 1.0);
  const FrameStereoStats whole_stats = stereo_dsm(cameras, images, pairs, whole, options);
  EXPECT_EQ(whole_stats.bands, pairs.size());

  options.band_rows = 96;
  options.band_margin = 48;
  Grid banded = whole;
  int live = 0, most = 0, reads = 0;
  const ImageSource source = [&](int i) {
    ++reads;
    most = std::max(most, ++live);
    return std::shared_ptr<const GreyImage>(new GreyImage(images[i]), [&live](const GreyImage* image) {
      --live;
      delete image;
    });
  };
  const FrameStereoStats banded_stats = stereo_dsm(cameras, source, pairs, banded, options);
  EXPECT_GT(banded_stats.bands, 3 * pairs.size());
  EXPECT_LE(most, 2);
  EXPECT_EQ(live, 0);
  EXPECT_EQ(reads, 4);  // 0 and 1; 2 (1 kept); 0 again (2 kept)

  const DsmErrors w = dsm_errors(whole, truth), b = dsm_errors(banded, truth);
  size_t both = 0, close = 0;
  for (size_t i = 0; i < whole.z.size(); ++i)
    if (!std::isnan(whole.z[i]) && !std::isnan(banded.z[i])) ++both, close += std::abs(whole.z[i] - banded.z[i]) <= 0.5;
  std::printf(
      "whole pairs (%zu bands) vs bands of 96 rows (%zu bands): completeness %.1f / %.1f %%, median |error| %.3f / "
      "%.3f m, > 1 m %.1f / %.1f %%; %.1f %% of the cells valid in both within 0.5 m\n",
      whole_stats.bands, banded_stats.bands, 100 * w.completeness, 100 * b.completeness, w.median, b.median,
      100 * w.over1, 100 * b.over1, 100.0 * close / both);
  EXPECT_GT(b.completeness, w.completeness - 0.02);
  EXPECT_LT(b.median, w.median + 0.05);
  EXPECT_LT(b.over1, w.over1 + 0.02);
  EXPECT_GT(double(close) / double(both), 0.97);

  // The same bands from images in memory: the same DSM, cell for cell.
  Grid lent = whole;
  stereo_dsm(cameras, images, pairs, lent, options);
  for (size_t i = 0; i < lent.z.size(); ++i)
    ASSERT_TRUE(std::isnan(lent.z[i]) ? std::isnan(banded.z[i]) : lent.z[i] == banded.z[i]) << i;
}

TEST(StereoPipeline, ReversedPairAndThreeViewsFusedByTheMedian) {
  RenderedScene& scene = rendered_scene();
  const std::vector<GreyImage> images = scene.views(3);
  FrameStereoOptions options;
  options.rectify.min_height = scene.lo;
  options.rectify.max_height = scene.hi;
  const std::array<double, 4> bounds{scene.truth.x0, scene.truth.y1(), scene.truth.x1(), scene.truth.y0};
  // The pair the other way round: the rectified images turn by 180 degrees, the DSM stays.
  Grid reversed = dsm_grid(bounds, 1.0);
  stereo_dsm(scene.cameras, images, {{1, 0}}, reversed, options);
  const DsmErrors r = dsm_errors(reversed, scene.truth);
  // All three views: `auto` takes the three pairs, the median fuses them.
  PairSelectionOptions selection;
  selection.ground_height = scene.lo;
  const auto pairs = select_pairs_auto(scene.cameras, selection);
  const std::vector<std::pair<int, int>> expected{{0, 1}, {0, 2}, {1, 2}};
  EXPECT_EQ(pairs, expected);
  Grid fused = dsm_grid(bounds, 1.0);
  const FrameStereoStats stats = stereo_dsm(scene.cameras, images, pairs, fused, options);
  const DsmErrors e = dsm_errors(fused, scene.truth);
  std::printf(
      "pair 1-0: completeness %.1f %%, median |error| %.3f m, > 1 m %.1f %%, > 3 m %.1f %%\n"
      "3 views, %zu pairs: completeness %.1f %%, median |error| %.3f m, > 1 m %.1f %%, > 3 m %.1f %%\n",
      100 * r.completeness, r.median, 100 * r.over1, 100 * r.over3, stats.pairs, 100 * e.completeness, e.median,
      100 * e.over1, 100 * e.over3);
  EXPECT_GT(r.completeness, 0.85);
  EXPECT_LT(r.median, 0.3);
  EXPECT_LT(r.over3, 0.05);
  EXPECT_GT(e.completeness, 0.9);
  EXPECT_LT(e.median, 0.3);
  EXPECT_LT(e.over1, 0.15);
  EXPECT_LT(e.over3, 0.05);
}

// No pair sinks the job (issue 34, point 1). A pair whose search is wider than one SGM pass is
// matched in disparity windows: forced here with a height range 50 m too low and 25 m too high
// (an estimate gone wide) and windows of 64 disparities, the DSM must be as good against the
// truth as with the true range (the thresholds above) and agree with the whole search's in nearly
// every cell. With no windows allowed, the pair that needs more is left out with its problem, the
// other matched; when every pair is over, one error names them all.
TEST(StereoPipeline, PairOverTheBudgetSearchedInWindowsOrLeftOut) {
  RenderedScene& scene = rendered_scene();
  const std::vector<GreyImage> images = scene.views(3);
  const std::array<double, 4> bounds{scene.truth.x0, scene.truth.y1(), scene.truth.x1(), scene.truth.y0};
  FrameStereoOptions options;
  options.rectify.min_height = scene.lo - 50;
  options.rectify.max_height = scene.hi + 25;
  const int wide = rectify_cameras(scene.cameras[0], scene.cameras[1], options.rectify).num_disparities;
  const int narrow = rectify_cameras(scene.cameras[0], scene.cameras[2], options.rectify).num_disparities;
  ASSERT_GT(wide, 96) << "the pair must need three windows of 64 or more";
  ASSERT_LT(narrow, wide);

  Grid whole = dsm_grid(bounds, 1.0);
  const FrameStereoStats whole_stats = stereo_dsm(scene.cameras, images, {{0, 1}}, whole, options);
  ASSERT_EQ(whole_stats.pair_stats.size(), 1u);
  EXPECT_EQ(whole_stats.pair_stats[0].windows, 1);
  options.rectify.max_disparities = 64;
  Grid split = dsm_grid(bounds, 1.0);
  const FrameStereoStats split_stats = stereo_dsm(scene.cameras, images, {{0, 1}}, split, options);
  const FramePairStats& pair = split_stats.pair_stats.at(0);
  EXPECT_TRUE(pair.used);
  EXPECT_EQ(pair.windows, static_cast<int>(disparity_windows(wide, 64).size()));
  EXPECT_GE(pair.windows, 3);
  EXPECT_EQ(pair.num_disparities, wide);
  EXPECT_GT(pair.pixels, pair.matched_pixels);
  const DsmErrors w = dsm_errors(whole, scene.truth), e = dsm_errors(split, scene.truth);
  size_t both = 0, close = 0;
  for (size_t i = 0; i < whole.z.size(); ++i)
    if (!std::isnan(whole.z[i]) && !std::isnan(split.z[i])) ++both, close += std::abs(whole.z[i] - split.z[i]) <= 0.5;
  std::printf(
      "pair 0-1, %d disparities: whole search vs %d windows of 64: completeness %.1f / %.1f %%, median |error| "
      "%.3f / %.3f m, > 1 m %.1f / %.1f %%, > 3 m %.1f / %.1f %%; matched %.1f / %.1f %% of the pixels, %zu "
      "conflicts; %.1f %% of the cells valid in both within 0.5 m\n",
      wide, pair.windows, 100 * w.completeness, 100 * e.completeness, w.median, e.median, 100 * w.over1, 100 * e.over1,
      100 * w.over3, 100 * e.over3, 100.0 * whole_stats.pair_stats[0].matched_pixels / whole_stats.pair_stats[0].pixels,
      100.0 * pair.matched_pixels / pair.pixels, pair.window_conflicts, 100.0 * close / both);
  EXPECT_GT(e.completeness, 0.85);
  EXPECT_LT(e.median, 0.3);
  EXPECT_LT(e.over1, 0.15);
  EXPECT_LT(e.over3, 0.05);
  EXPECT_GT(double(close) / double(both), 0.95);

  // No windows, a budget between the two pairs' needs: 0-1 left out, 0-2 matched.
  options.rectify.max_windows = 1;
  options.rectify.max_disparities = (narrow + 15) / 16 * 16;
  ASSERT_LT(options.rectify.max_disparities, wide);
  Grid one = dsm_grid(bounds, 1.0);
  const FrameStereoStats one_stats = stereo_dsm(scene.cameras, images, {{0, 1}, {0, 2}}, one, options);
  ASSERT_EQ(one_stats.pair_stats.size(), 2u);
  EXPECT_EQ(one_stats.pairs, 1u);
  EXPECT_FALSE(one_stats.pair_stats[0].used);
  EXPECT_NE(one_stats.pair_stats[0].problem.find("needs " + std::to_string(wide) + " disparities"), std::string::npos)
      << one_stats.pair_stats[0].problem;
  EXPECT_TRUE(one_stats.pair_stats[1].used);
  EXPECT_EQ(one_stats.matched_pixels, one_stats.pair_stats[1].matched_pixels);
  EXPECT_GT(dsm_errors(one, scene.truth).completeness, 0.8);
  options.rectify.max_disparities = 32;
  try {
    stereo_dsm(scene.cameras, images, {{0, 1}, {0, 2}}, one, options);
    ADD_FAILURE() << "no error";
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("no pair left to match (cameras 0 and 1: the height range needs"), std::string::npos)
        << message;
    EXPECT_NE(message.find("; cameras 0 and 2: "), std::string::npos) << message;
  }
}

// The windows' split and merge, against their definitions counted by hand.
TEST(StereoPipeline, DisparityWindowsTileTheRangeAndDropConflicts) {
  EXPECT_EQ(disparity_windows(100, 512).size(), 1u);
  for (const int total : {513, 912, 2048, 1000}) {
    const auto windows = disparity_windows(total, 512);
    EXPECT_EQ(windows.size(), static_cast<size_t>((total + 479) / 480)) << total;
    // Every whole disparity of the range is in exactly one core, and searched by its window with
    // at least kWindowMargin on either side (but at the range's ends).
    for (int d = 0; d < total; ++d) {
      int cores = 0;
      for (const DisparityWindow& w : windows) {
        EXPECT_LE(w.num_disparities, 512);
        if (d >= w.keep_begin && d < w.keep_end) {
          ++cores;
          EXPECT_GE(d - w.min_disparity, std::min(d, kWindowMargin)) << d;
          EXPECT_GE(w.min_disparity + w.num_disparities - 1 - d, std::min(total - 1 - d, kWindowMargin)) << d;
        }
      }
      EXPECT_EQ(cores, 1) << "disparity " << d << " of " << total;
    }
  }
  EXPECT_THROW(disparity_windows(200, 60), ArgumentError);
  // Merge: window 1 answers for [.., 10), window 2 for [10, ..): a pixel both answer for is dropped.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const DisparityWindow low{0, 26, -INFINITY, 10}, high{0, 40, 10, INFINITY};
  std::vector<float> merged(4, nan);
  std::vector<unsigned char> claimed(4, 0);
  EXPECT_EQ(merge_window({3, 12, nan, 4}, low, merged, claimed), 0u);     // 12: outside its core
  EXPECT_EQ(merge_window({20, 11, 15, nan}, high, merged, claimed), 1u);  // pixel 0: both
  EXPECT_TRUE(std::isnan(merged[0]));
  EXPECT_EQ(merged[1], 11);
  EXPECT_EQ(merged[2], 15);
  EXPECT_EQ(merged[3], 4);
}

// Without a height range: estimate_height_range() finds it from the views alone (a coarse pass
// over every depth), against the oracle of the truth's own heights, and the DSM made with the
// estimate is as good as with the true range (the thresholds of the test above).
TEST(StereoPipeline, HeightRangeEstimatedFromTheImagesAlone) {
  RenderedScene& scene = rendered_scene();
  const std::vector<GreyImage> images = scene.views(3);
  const auto coarse = height_range_pairs(scene.cameras);
  // Camera 2 lies 17.9 m from camera 1 and 18.5 m from camera 0, which are 24.1 m apart.
  const std::vector<std::pair<int, int>> nearest{{1, 2}, {0, 2}};
  EXPECT_EQ(coarse, nearest);
  const HeightRangeEstimate estimate = estimate_height_range(scene.cameras, images, coarse);
  std::vector<float> z = scene.truth.z;
  std::sort(z.begin(), z.end());
  const double p01 = z[z.size() / 100], p99 = z[z.size() * 99 / 100];
  std::printf(
      "estimated height range %.1f..%.1f m (ends %.1f..%.1f, fine step %.2f m, %zu points, %zu pairs, "
      "scale %d); truth %.1f..%.1f m, 1st-99th percentile %.1f..%.1f m\n",
      estimate.min_height, estimate.max_height, estimate.low, estimate.high, estimate.fine_step, estimate.points,
      estimate.pairs.size(), estimate.scale, scene.lo, scene.hi, p01, p99);
  EXPECT_LE(estimate.min_height, p01);
  EXPECT_GE(estimate.max_height, p99);
  EXPECT_GE(estimate.min_height, scene.lo - 15);
  EXPECT_LE(estimate.max_height, scene.hi + 15);

  FrameStereoOptions options;
  options.rectify.min_height = estimate.min_height;
  options.rectify.max_height = estimate.max_height;
  Grid dsm = dsm_grid({scene.truth.x0, scene.truth.y1(), scene.truth.x1(), scene.truth.y0}, 1.0);
  stereo_dsm(scene.cameras, images, {{0, 1}}, dsm, options);
  const DsmErrors e = dsm_errors(dsm, scene.truth);
  std::printf("pair 0-1, estimated range: completeness %.1f %%, median |error| %.3f m, > 1 m %.1f %%, > 3 m %.1f %%\n",
              100 * e.completeness, e.median, 100 * e.over1, 100 * e.over3);
  EXPECT_GT(e.completeness, 0.85);
  EXPECT_LT(e.median, 0.3);
  EXPECT_LT(e.over1, 0.15);
  EXPECT_LT(e.over3, 0.05);
}

TEST(StereoPipeline, RefusesWrongImageSizeAndCamerasWithoutOverlap) {
  const std::vector<FrameCamera> cameras{nadir_camera(64, 100, {0, 0, 100}), nadir_camera(64, 100, {20, 0, 100})};
  std::vector<GreyImage> images{smooth_image(64, 64), smooth_image(63, 64)};
  FrameStereoOptions options;
  options.rectify.max_height = 10;
  Grid dsm = dsm_grid({0, 0, 10, 10}, 1.0);
  try {
    stereo_dsm(cameras, images, {{0, 1}}, dsm, options);
    FAIL() << "no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("camera 1: image is 63 x 64"), std::string::npos) << error.what();
  }
  PairSelectionOptions selection;
  const std::vector<FrameCamera> apart{nadir_camera(64, 100, {0, 0, 100}), nadir_camera(64, 100, {900, 0, 100})};
  EXPECT_TRUE(select_pairs_auto(apart, selection).empty());
}

// ---- dsmplan stereo: the command line ------------------------------------------------------

namespace {

// `image` as an 8-bit PNG (grey, or three equal RGB bands) through GDAL.
void write_png(const GreyImage& image, const std::string& path, int bands = 1) {
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDriver* png = GetGDALDriverManager()->GetDriverByName("PNG");
  ASSERT_TRUE(mem && png);
  std::unique_ptr<GDALDataset> data(mem->Create("", image.width, image.height, bands, GDT_Byte, nullptr));
  std::vector<std::uint8_t> bytes(image.pixels.size());
  for (size_t i = 0; i < bytes.size(); ++i)
    bytes[i] = static_cast<std::uint8_t>(std::clamp(image.pixels[i], 0.0f, 255.0f));
  for (int b = 1; b <= bands; ++b)
    ASSERT_EQ(data->GetRasterBand(b)->RasterIO(GF_Write, 0, 0, image.width, image.height, bytes.data(), image.width,
                                               image.height, GDT_Byte, 0, 0),
              CE_None);
  std::unique_ptr<GDALDataset> out(png->CreateCopy(path.c_str(), data.get(), FALSE, nullptr, nullptr, nullptr));
  ASSERT_TRUE(out);
}

using aerial::camera_json;

// The first two views as files: img_0.png (grey), img_1.png (RGB), and the cameras.json to
// return; `rendered` false: smooth stand-ins of the right size (for errors found before matching).
nlohmann::json write_pair_files(const testkit::TempDir& dir, bool rendered = true) {
  RenderedScene& scene = rendered_scene();
  write_png(rendered ? scene.view(0) : smooth_image(240, 240), dir.path("img_0.png"), 1);
  write_png(rendered ? scene.view(1) : smooth_image(240, 240), dir.path("img_1.png"), 3);
  return {{"crs", "EPSG:25832"},
          {"height_range", {scene.lo, scene.hi}},
          {"cameras", {camera_json(scene.cameras[0], "img_0.png"), camera_json(scene.cameras[1], "img_1.png")}}};
}

void write_json(const nlohmann::json& json, const std::string& path) { testkit::write_file(path, json.dump(1)); }

std::string bounds_of(const Grid& g) {
  return std::to_string(g.x0) + "," + std::to_string(g.y1()) + "," + std::to_string(g.x1()) + "," +
         std::to_string(g.y0);
}

}  // namespace

TEST(StereoCli, WritesTheDsmAndItsStats) {
  testkit::TempDir dir;
  write_json(write_pair_files(dir), dir.path("cameras.json"));
  const RenderedScene& scene = rendered_scene();
  const auto result =
      testkit::run_cli({"stereo", "--cameras", dir.path("cameras.json"), "-o", dir.path("dsm.tif"), "--res", "1",
                        "--bounds", bounds_of(scene.truth), "--stats", dir.path("stats.json"), "-q"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const Grid dsm = read_raster(dir.path("dsm.tif"));
  ASSERT_EQ(dsm.width, scene.truth.width);
  ASSERT_EQ(dsm.height, scene.truth.height);
  EXPECT_NEAR(dsm.x0, scene.truth.x0, 1e-6);
  EXPECT_NEAR(dsm.y0, scene.truth.y0, 1e-6);
  EXPECT_EQ(dsm.crs.epsg, 25832);
  const DsmErrors e = dsm_errors(dsm, scene.truth);
  std::printf("CLI: completeness %.1f %%, median |error| %.3f m, > 1 m %.1f %%, > 3 m %.1f %%\n", 100 * e.completeness,
              e.median, 100 * e.over1, 100 * e.over3);
  EXPECT_GT(e.completeness, 0.85);
  EXPECT_LT(e.median, 0.3);
  const auto stats = nlohmann::json::parse(testkit::read_file(dir.path("stats.json")));
  EXPECT_EQ(stats["pairs"], nlohmann::json::parse("[[0,1]]"));
  EXPECT_GT(stats["points"].get<double>(), 10000);
  for (const char* stage : {"read", "rectify", "match", "triangulate", "fuse", "write", "total"})
    EXPECT_TRUE(stats["seconds"].contains(stage)) << stage;
  EXPECT_EQ(stats["dsm"]["valid"].get<double>(), e.completeness * dsm.cells());

  // Without --bounds: the DSM covers the pairs' common footprint (beyond the 40 m crop, over
  // the rendered floor), on whole multiples of the cell size; where both have cells, the same DSM.
  // (In process: stereo_job() is what the binary calls.)
  StereoJobOptions whole;
  whole.cameras = dir.path("cameras.json");
  whole.output = dir.path("whole.tif");
  whole.resolution = 1;
  stereo_job(whole);
  const Grid wide = read_raster(dir.path("whole.tif"));
  EXPECT_GT(wide.cells(), dsm.cells());
  EXPECT_EQ(wide.x0, std::floor(wide.x0));
  EXPECT_EQ(wide.y0, std::floor(wide.y0));
  int same = 0, compared = 0;
  for (int r = 0; r < dsm.height; ++r)
    for (int c = 0; c < dsm.width; ++c) {
      int cw, rw;
      if (!dsm.valid(c, r) || !wide.cell_at(dsm.center_x(c), dsm.center_y(r), cw, rw) || !wide.valid(cw, rw)) continue;
      ++compared;
      same += std::abs(wide.at(cw, rw) - dsm.at(c, r)) < 1e-4;
    }
  EXPECT_GT(compared, 0.9 * e.completeness * dsm.cells());
  EXPECT_EQ(same, compared);
  // Without height_range (the contract: it is optional): estimated, and the DSM as good.
  nlohmann::json no_range = nlohmann::json::parse(testkit::read_file(dir.path("cameras.json")));
  no_range.erase("height_range");
  write_json(no_range, dir.path("no_range.json"));
  StereoJobOptions estimated;
  estimated.cameras = dir.path("no_range.json");
  estimated.output = dir.path("estimated.tif");
  estimated.resolution = 1;
  estimated.bounds = std::array<double, 4>{scene.truth.x0, scene.truth.y1(), scene.truth.x1(), scene.truth.y0};
  const StereoReport report = stereo_job(estimated);
  EXPECT_TRUE(report.height_range_estimated);
  EXPECT_LE(report.min_height, scene.lo + 1);
  EXPECT_GE(report.max_height, scene.hi - 3);
  const DsmErrors en = dsm_errors(read_raster(dir.path("estimated.tif")), scene.truth);
  std::printf(
      "CLI, no height_range (estimated %.1f..%.1f m): completeness %.1f %%, median |error| %.3f m, > 1 m %.1f %%\n",
      report.min_height, report.max_height, 100 * en.completeness, en.median, 100 * en.over1);
  EXPECT_GT(en.completeness, 0.85);
  EXPECT_LT(en.median, 0.3);
  EXPECT_LT(en.over1, 0.15);
  EXPECT_EQ(to_json(report)["height_range_estimated"], true);
  if (const char* keep = std::getenv("DSMPLAN_STEREO_KEEP"))  // the files, to look at by hand
    for (const char* name : {"img_0.png", "img_1.png", "cameras.json", "dsm.tif", "whole.tif", "stats.json"})
      std::filesystem::copy_file(dir.path(name), std::filesystem::path(keep) / name,
                                 std::filesystem::copy_options::overwrite_existing);
}

// A pair that cannot be matched (camera 2 straight above camera 0: the baseline along the
// viewing direction) is left out with one warning line naming it and why; --stats lists every
// pair, used or not, with its search and share of matched pixels; the job fails, in one line,
// only when no pair is left.
TEST(StereoCli, PairLeftOutWarnsOnceAndStatsListEveryPair) {
  testkit::TempDir dir;
  nlohmann::json json = write_pair_files(dir);
  RenderedScene& scene = rendered_scene();
  FrameCamera above = scene.cameras[0];
  above.center[2] += 30;
  write_png(scene.view(0), dir.path("img_2.png"), 1);
  json["cameras"].push_back(camera_json(above, "img_2.png"));
  write_json(json, dir.path("cameras.json"));
  const std::vector<std::string> args{
      "stereo", "--cameras", dir.path("cameras.json"), "-o",      dir.path("dsm.tif"),    "--res",
      "1",      "--bounds",  bounds_of(scene.truth),   "--stats", dir.path("stats.json"), "-q",
      "--pairs"};
  std::vector<std::string> both = args;
  both.push_back("0-1,0-2");
  const auto result = testkit::run_cli(both);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_EQ(result.err.rfind("dsmplan: warning: " + dir.path("cameras.json") + ": cameras 0 and 2: left out, ", 0), 0u)
      << result.err;
  EXPECT_NE(result.err.find("viewing direction"), std::string::npos) << result.err;
  const auto stats = nlohmann::json::parse(testkit::read_file(dir.path("stats.json")));
  EXPECT_EQ(stats["pairs"], nlohmann::json::parse("[[0,1]]"));
  EXPECT_EQ(stats["pairs_left_out"], 1);
  const auto& details = stats["pair_details"];
  ASSERT_EQ(details.size(), 2u) << details.dump();
  EXPECT_EQ(details[0]["cameras"], nlohmann::json::parse("[0,1]"));
  EXPECT_EQ(details[0]["used"], true);
  EXPECT_EQ(details[0]["problem"], "");
  EXPECT_EQ(details[0]["windows"], 1);
  EXPECT_EQ(details[0]["matched_pixels"], stats["matched_pixels"]);
  EXPECT_EQ(details[0]["share_of_all_matched"], 1.0);
  const double share = details[0]["matched_share"];
  EXPECT_NEAR(share, details[0]["matched_pixels"].get<double>() / details[0]["pixels"].get<double>(), 1e-12);
  EXPECT_GT(share, 0.5);
  EXPECT_LE(share, 1.0);
  EXPECT_GT(details[0]["disparity_offset"].get<double>(), 0);
  EXPECT_EQ(details[0]["height_range"], stats["height_range"]);
  EXPECT_EQ(details[1]["cameras"], nlohmann::json::parse("[0,2]"));
  EXPECT_EQ(details[1]["used"], false);
  EXPECT_NE(details[1]["problem"].get<std::string>().find("viewing direction"), std::string::npos);
  EXPECT_EQ(details[1]["matched_pixels"], 0);
  const DsmErrors e = dsm_errors(read_raster(dir.path("dsm.tif")), scene.truth);
  EXPECT_GT(e.completeness, 0.85);
  EXPECT_LT(e.median, 0.3);

  std::filesystem::remove(dir.path("dsm.tif"));
  std::filesystem::remove(dir.path("stats.json"));
  std::vector<std::string> none = args;
  none.push_back("0-2");
  const auto failed = testkit::run_cli(none);
  EXPECT_EQ(failed.exit_code, 1);
  EXPECT_EQ(std::count(failed.err.begin(), failed.err.end(), '\n'), 1) << failed.err;
  EXPECT_NE(failed.err.find("cameras: no pair left to match (cameras 0 and 2: "), std::string::npos) << failed.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif")));
  EXPECT_FALSE(std::filesystem::exists(dir.path("stats.json")));
}

// Two views with 30 % side overlap on the ground share nothing on a plane high above it (the
// footprints shrink with the distance to the cameras): such a pair is matched over the ground
// they share, not refused as seeing nothing in common; its heights match the truth.
TEST(StereoCli, PairSharingOnlyLowGroundIsMatched) {
  testkit::TempDir dir;
  RenderedScene& scene = rendered_scene();
  FrameCamera side = scene.cameras[0];
  side.center[0] += 48;  // the footprint is 69 m wide on the lowest cell, 38 m on the top plane
  write_png(scene.view(0), dir.path("img_0.png"), 1);
  write_png(render(ColumnScene{scene.truth, scene.lo, scene.hi}, side, 9), dir.path("img_1.png"), 1);
  const double top = scene.lo + 50;
  const nlohmann::json json{{"crs", "EPSG:25832"},
                            {"height_range", {scene.lo, top}},
                            {"cameras", {camera_json(scene.cameras[0], "img_0.png"), camera_json(side, "img_1.png")}}};
  write_json(json, dir.path("cameras.json"));
  std::array<double, 4> box;
  ASSERT_TRUE(footprint_box(scene.cameras[0], side, scene.lo, box));
  ASSERT_FALSE(footprint_box(scene.cameras[0], side, top, box)) << "the pair must share nothing on the top plane";
  StereoJobOptions options;
  options.cameras = dir.path("cameras.json");
  options.output = dir.path("dsm.tif");
  options.resolution = 1;
  options.bounds = std::array<double, 4>{scene.truth.x0, scene.truth.y1(), scene.truth.x1(), scene.truth.y0};
  const StereoReport report = stereo_job(options);
  ASSERT_EQ(report.pair_stats.size(), 1u);
  EXPECT_TRUE(report.pair_stats[0].used) << report.pair_stats[0].problem;
  EXPECT_TRUE(report.warnings.empty());
  const Grid dsm = read_raster(dir.path("dsm.tif"));
  const DsmErrors e = dsm_errors(dsm, scene.truth);
  std::printf(
      "pair with 30 %% side overlap, nothing shared at %.1f m: %.1f %% of the crop filled, median |error| "
      "%.3f m, > 1 m %.1f %%\n",
      top, 100 * e.completeness, e.median, 100 * e.over1);
  EXPECT_GT(e.completeness, 0.2);  // the overlap covers part of the crop only
  EXPECT_LT(e.median, 0.3);
  EXPECT_LT(e.over1, 0.15);
}

TEST(StereoCli, BadInputOneLineNoOutput) {
  testkit::TempDir dir;
  const nlohmann::json good = write_pair_files(dir, /*rendered=*/false);  // every error comes before matching
  const RenderedScene& scene = rendered_scene();
  struct Case {
    std::string name;
    nlohmann::json json;
    std::vector<std::string> extra;
    std::string expected;  // in the message
  };
  std::vector<Case> cases;
  {
    nlohmann::json j = good;
    j["cameras"][1]["image"] = "missing.png";
    cases.push_back({"missing image", j, {}, "missing.png: camera 1: missing (an image of "});
  }
  {
    nlohmann::json j = good;
    j["cameras"][0]["fx"] = "wide";
    cases.push_back({"bad field", j, {}, "cameras[0].fx: must be a finite number"});
  }
  {
    nlohmann::json j = good;
    j["cameras"][0].erase("center");
    cases.push_back({"missing key", j, {}, "cameras[0].center: missing"});
  }
  {
    nlohmann::json j = good;
    j["cameras"][1]["width"] = 241;
    cases.push_back({"size", j, {}, "camera 1: image is 240 x 240, the camera says 241 x 240"});
  }
  {
    nlohmann::json j = good;
    j["cameras"][1]["rotation"][0][1] = 0.2;
    cases.push_back({"rotation", j, {}, "cameras[1]: rotation is not orthonormal"});
  }
  {
    nlohmann::json j = good;
    j["cameras"][1]["center"][0] = scene.cameras[1].center[0] + 5000;
    cases.push_back({"apart, auto", j, {}, "no two cameras overlap"});
    cases.push_back({"apart, explicit", j, {"--pairs", "0-1"}, "cameras 0 and 1: see nothing in common"});
  }
  cases.push_back({"bounds outside", good, {"--bounds", "0,0,10,10"}, "--bounds: lies outside"});
  cases.push_back({"bad pairs", good, {"--pairs", "0-2"}, "--pairs"});
  testkit::write_file(dir.path("broken.json"), "{\"crs\": ");
  // In process (stereo_job, what the binary calls) for every case; through the binary for two,
  // for the exit code and the one line on stderr.
  for (const Case& c : cases) {
    write_json(c.json, dir.path("cameras.json"));
    StereoJobOptions options;
    options.cameras = dir.path("cameras.json");
    options.output = dir.path("dsm.tif");
    options.resolution = 1;
    for (size_t k = 0; k + 1 < c.extra.size(); k += 2) {
      if (c.extra[k] == "--pairs") options.pairs = c.extra[k + 1];
      if (c.extra[k] == "--bounds") options.bounds = std::array<double, 4>{0, 0, 10, 10};
    }
    try {
      stereo_job(options);
      ADD_FAILURE() << c.name << ": no error";
    } catch (const Error& error) {
      EXPECT_NE(std::string(error.what()).find(c.expected), std::string::npos) << c.name << ": " << error.what();
    }
    EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif"))) << c.name;
  }
  for (const size_t k : {size_t{0}, cases.size() - 3}) {  // the missing image, cameras apart
    const Case& c = cases[k];
    write_json(c.json, dir.path("cameras.json"));
    std::vector<std::string> args{"stereo", "--cameras", dir.path("cameras.json"), "-o", dir.path("dsm.tif"), "--res",
                                  "1",      "--stats",   dir.path("stats.json"),   "-q"};
    args.insert(args.end(), c.extra.begin(), c.extra.end());
    const auto result = testkit::run_cli(args);
    EXPECT_EQ(result.exit_code, 1) << c.name;
    EXPECT_NE(result.err.find(c.expected), std::string::npos) << c.name << ": " << result.err;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << c.name << ": " << result.err;
    EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif"))) << c.name;
    EXPECT_FALSE(std::filesystem::exists(dir.path("stats.json"))) << c.name;
  }
  StereoJobOptions options;
  options.cameras = dir.path("broken.json");
  options.output = dir.path("dsm.tif");
  options.resolution = 1;
  try {
    stereo_job(options);
    ADD_FAILURE() << "broken JSON: no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("broken.json: is not JSON"), std::string::npos) << error.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif")));
}

// The rules of `dsmplan stereo`'s flags taken together are the library's (stereo_job_for()): a
// C++ or Python caller gets the command line's one line, flag included.
TEST(StereoRequest, FlagRulesAreTheLibrarysOwn) {
  StereoRequest frame;
  frame.cameras = "cameras.json", frame.output = "dsm.tif", frame.resolution = 1;
  StereoRequest satellite;
  satellite.images = {"a.tif", "b.tif"}, satellite.output = "dsm.tif", satellite.resolution = 1;
  const auto refused = [](StereoRequest request, auto change, const std::string& expected) {
    change(request);
    try {
      stereo_job_for(request);
      ADD_FAILURE() << expected << ": no error";
    } catch (const ArgumentError& error) {
      EXPECT_EQ(error.what(), expected);
    }
  };
  refused(
      frame, [](StereoRequest& r) { r.bounds = "1,2,3"; }, "--bounds: expected four numbers x0,y0,x1,y1, got '1,2,3'");
  refused(
      frame, [](StereoRequest& r) { r.images = {"a.tif"}; },
      "--cameras: give one of: satellite images with RPCs (dsmplan stereo IMG1 IMG2 ...), --cameras "
      "CAMERAS.json for frame cameras, or --colmap MODEL_DIR for a COLMAP text model");
  refused(
      StereoRequest{}, [](StereoRequest&) {},
      "--cameras: give one of: satellite images with RPCs (dsmplan stereo IMG1 IMG2 ...), --cameras "
      "CAMERAS.json for frame cameras, or --colmap MODEL_DIR for a COLMAP text model");
  refused(
      frame, [](StereoRequest& r) { r.fusion_memory_mb = 0.01; },
      "--fusion-memory: must lie in [0.0625, 1e9) MB, got 0.01");
  refused(
      satellite, [](StereoRequest& r) { r.band_memory_mb = 1e300; },
      "--band-memory: must lie in [1, 1e9) MB, got 1e+300");
  refused(
      frame, [](StereoRequest& r) { r.crs = "EPSG:32632"; },
      "--crs: belongs to satellite images or --colmap; CAMERAS.json states its CRS");
  refused(
      frame, [](StereoRequest& r) { r.allow_approximate_vertical = true; },
      "--allow-approximate-vertical: belongs to satellite images with a compound --crs");
  refused(
      satellite, [](StereoRequest& r) { r.pairs = "0-1"; },
      "--pairs: belongs to --cameras and --colmap; satellite images are paired by overlap");

  frame.bounds = "0,0,10,20", frame.pairs = "0-1", frame.fusion_memory_mb = 2, frame.band_memory_mb = 3;
  const StereoJob job = stereo_job_for(frame);
  ASSERT_TRUE(job.frame);
  EXPECT_FALSE(job.satellite);
  EXPECT_EQ(job.frame->cameras, "cameras.json");
  EXPECT_EQ(job.frame->pairs, "0-1");
  EXPECT_EQ(*job.frame->bounds, (std::array<double, 4>{0, 0, 10, 20}));
  EXPECT_EQ(job.frame->fusion_memory_bytes, 2u << 20);
  EXPECT_EQ(job.frame->band_memory_bytes, 3u << 20);
  satellite.crs = "EPSG:32637", satellite.allow_approximate_vertical = true;
  const StereoJob sat = stereo_job_for(satellite);
  ASSERT_TRUE(sat.satellite);
  EXPECT_FALSE(sat.frame);
  EXPECT_EQ(sat.satellite->images, satellite.images);
  EXPECT_EQ(sat.satellite->crs, "EPSG:32637");
  EXPECT_TRUE(sat.satellite->allow_approximate_vertical);
  EXPECT_EQ(sat.satellite->resolution, 1);
}

namespace {
// An ImageReader around another that counts the windows read: what the stage reads, and how.
class CountingReader final : public ImageReader {
public:
  CountingReader(std::unique_ptr<ImageReader> inner, int& reads) : inner_(std::move(inner)), reads_(reads) {}
  const std::string& path() const override { return inner_->path(); }
  int width() const override { return inner_->width(); }
  int height() const override { return inner_->height(); }
  int bands() const override { return inner_->bands(); }
  std::optional<double> nodata(int band) const override { return inner_->nodata(band); }
  std::string read(int band, int col0, int row0, int cols, int rows, float* out) const override {
    ++reads_;
    return inner_->read(band, col0, row0, cols, rows, out);
  }

private:
  std::unique_ptr<ImageReader> inner_;
  int& reads_;
};
}  // namespace

// The stage reads its images through any ImageReader, and gives the DSM the job writes.
TEST(StereoPipeline, FrameDsmReadsThroughTheImageReaderGiven) {
  testkit::TempDir dir;
  write_json(write_pair_files(dir), dir.path("cameras.json"));
  const RenderedScene& scene = rendered_scene();
  StereoJobOptions options;
  options.cameras = dir.path("cameras.json");
  options.output = dir.path("dsm.tif");
  options.resolution = 1;
  options.bounds = std::array<double, 4>{scene.truth.x0, scene.truth.y1(), scene.truth.x1(), scene.truth.y0};
  const StereoReport written = stereo_job(options);

  int reads = 0, opened = 0;
  const ImageOpener counting = [&](const std::string& path, const std::string& place) {
    ++opened;
    return std::make_unique<CountingReader>(open_image_file(path, place), reads);
  };
  const CameraFile cameras = read_camera_file(options.cameras);
  Crs crs;
  crs.definition = cameras.crs;
  Grid dsm;
  int checked = 0;
  const StereoReport report =
      frame_dsm(cameras, crs, counting, options, dsm, [&](const Grid& grid) { checked += grid.cells() > 0; });
  EXPECT_EQ(checked, 1);
  EXPECT_EQ(opened, 4);     // each image checked before the matching, then read for its pair
  EXPECT_EQ(reads, 1 + 3);  // img_0.png grey: one band; img_1.png RGB: three
  EXPECT_EQ(report.points, written.points);
  const Grid file = read_raster(options.output);
  ASSERT_EQ(file.cells(), dsm.cells());
  for (std::size_t i = 0; i < dsm.cells(); ++i)
    ASSERT_TRUE(std::isnan(dsm.z[i]) ? std::isnan(file.z[i]) : dsm.z[i] == file.z[i]) << i;
}
