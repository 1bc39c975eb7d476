// Stereo from frame cameras (include/dsmplan/stereo_frames.hpp), each part against an oracle
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
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "dsmplan/stereo_frames.hpp"
#include "testkit.hpp"

using namespace dsmplan;

namespace {

Mat3 rotation_xyz(double ax, double ay, double az) {  // R = Rz Ry Rx, radians
  const double cx = std::cos(ax), sx = std::sin(ax), cy = std::cos(ay), sy = std::sin(ay), cz = std::cos(az),
               sz = std::sin(az);
  const Mat3 Rx{{{1, 0, 0}, {0, cx, -sx}, {0, sx, cx}}}, Ry{{{cy, 0, sy}, {0, 1, 0}, {-sy, 0, cy}}},
      Rz{{{cz, -sz, 0}, {sz, cz, 0}, {0, 0, 1}}};
  const auto mul = [](const Mat3& a, const Mat3& b) {
    Mat3 c{};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
    return c;
  };
  return mul(Rz, mul(Ry, Rx));
}

// A nadir camera (x east, y south, z down) at `center`, turned by small angles.
FrameCamera nadir_camera(int size, double f, const Vec3& center, double tilt_x = 0, double tilt_y = 0,
                         double k1 = 0, double p1 = 0) {
  FrameCamera c;
  c.width = c.height = size;
  c.fx = c.fy = f;
  c.cx = c.cy = (size - 1) / 2.0;
  const Mat3 nadir{{{1, 0, 0}, {0, -1, 0}, {0, 0, -1}}};
  const Mat3 turn = rotation_xyz(tilt_x, tilt_y, 0);
  Mat3 R{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) R[i][j] += turn[i][k] * nadir[k][j];
  c.rotation = R;
  c.center = center;
  c.distortion = {k1, 0.3 * k1, p1, -0.5 * p1, 0};
  return c;
}

// Value noise in 3D: a hash per lattice point (spacing `cell` metres), trilinear in between, two
// octaves; 0..1.
double hash01(std::int64_t x, std::int64_t y, std::int64_t z) {
  std::uint64_t h = static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^ static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
                    static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return static_cast<double>(h & 0xFFFFFF) / 0xFFFFFF;
}
double value_noise(double x, double y, double z, double cell) {
  const double fx = x / cell, fy = y / cell, fz = z / cell;
  const double ix = std::floor(fx), iy = std::floor(fy), iz = std::floor(fz);
  const double tx = fx - ix, ty = fy - iy, tz = fz - iz;
  double sum = 0;
  for (int dx = 0; dx < 2; ++dx)
    for (int dy = 0; dy < 2; ++dy)
      for (int dz = 0; dz < 2; ++dz)
        sum += (dx ? tx : 1 - tx) * (dy ? ty : 1 - ty) * (dz ? tz : 1 - tz) *
               hash01(static_cast<std::int64_t>(ix) + dx, static_cast<std::int64_t>(iy) + dy,
                      static_cast<std::int64_t>(iz) + dz);
  return sum;
}
double texture(const Vec3& p) {
  return 30 + 140 * value_noise(p[0], p[1], p[2], 0.45) + 60 * value_noise(p[0], p[1], p[2], 2.1);
}

// The scene: the cells of `dsm` as solid columns on an endless floor at `floor` height.
struct ColumnScene {
  const Grid& dsm;
  double floor;
  double top;
  double height_at(int col, int row) const {
    if (col < 0 || row < 0 || col >= dsm.width || row >= dsm.height) return floor;
    return std::max<double>(floor, dsm.at(col, row));
  }
  // The first surface point along C + t·dir (dir pointing down), by a 2D DDA over the cells
  // (Amanatides & Woo 1987).
  Vec3 hit(const Vec3& C, const Vec3& dir) const {
    const double t_floor = (floor - C[2]) / dir[2];
    double t = std::max(0.0, (top - C[2]) / dir[2]);
    // Cell coordinates: gx = (x - x0)/cell_x, gy = (y0 - y)/cell_y.
    const double gx = (C[0] + t * dir[0] - dsm.x0) / dsm.cell_x, gy = (dsm.y0 - (C[1] + t * dir[1])) / dsm.cell_y;
    const double vx = dir[0] / dsm.cell_x, vy = -dir[1] / dsm.cell_y;
    int col = static_cast<int>(std::floor(gx)), row = static_cast<int>(std::floor(gy));
    const int step_x = vx > 0 ? 1 : -1, step_y = vy > 0 ? 1 : -1;
    double next_x = std::abs(vx) < 1e-15 ? INFINITY : ((vx > 0 ? col + 1 - gx : gx - col) / std::abs(vx)) + t;
    double next_y = std::abs(vy) < 1e-15 ? INFINITY : ((vy > 0 ? row + 1 - gy : gy - row) / std::abs(vy)) + t;
    const double dt_x = std::abs(vx) < 1e-15 ? INFINITY : 1 / std::abs(vx);
    const double dt_y = std::abs(vy) < 1e-15 ? INFINITY : 1 / std::abs(vy);
    for (int guard = 0; guard < 100000; ++guard) {
      const double h = height_at(col, row);
      const double t_out = std::min({next_x, next_y, t_floor});
      const double z_in = C[2] + t * dir[2];
      if (z_in <= h) return {C[0] + t * dir[0], C[1] + t * dir[1], z_in};  // a wall
      const double t_top = (h - C[2]) / dir[2];
      if (t_top <= t_out) return {C[0] + t_top * dir[0], C[1] + t_top * dir[1], h};
      t = t_out;
      if (next_x < next_y) {
        col += step_x;
        next_x += dt_x;
      } else {
        row += step_y;
        next_y += dt_y;
      }
    }
    return {C[0] + t_floor * dir[0], C[1] + t_floor * dir[1], floor};
  }
};

// The camera's image of the scene, 2 x 2 rays per pixel, plus a little noise.
GreyImage render(const ColumnScene& scene, const FrameCamera& camera, unsigned seed) {
  GreyImage image;
  image.width = camera.width;
  image.height = camera.height;
  image.pixels.resize(static_cast<size_t>(camera.width) * camera.height);
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0, 1.5);
  for (int v = 0; v < camera.height; ++v)
    for (int u = 0; u < camera.width; ++u) {
      double sum = 0;
      for (double du : {-0.25, 0.25})
        for (double dv : {-0.25, 0.25}) sum += texture(scene.hit(camera.center, pixel_ray(camera, u + du, v + dv)));
      image.pixels[static_cast<size_t>(v) * camera.width + u] =
          static_cast<float>(std::clamp(std::round(sum / 4 + noise(random)), 0.0, 255.0));
    }
  return image;
}

// A smooth image whose value is known anywhere: for the resampling oracle.
GreyImage smooth_image(int w, int h) {
  GreyImage image;
  image.width = w;
  image.height = h;
  image.pixels.resize(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) image.pixels[static_cast<size_t>(y) * w + x] = static_cast<float>(100 + 0.3 * x + 0.2 * y);
  return image;
}

}  // namespace

TEST(FrameCamera, UndistortInvertsDistortAndProjectFollowsTheFormula) {
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

TEST(FrameCamera, CheckCameraRefusesANonOrthonormalRotation) {
  FrameCamera c = nadir_camera(100, 100, {0, 0, 100});
  EXPECT_NO_THROW(check_camera(c, "camera 0"));
  c.rotation[0][1] = 0.1;
  EXPECT_THROW(check_camera(c, "camera 0"), ArgumentError);
  c = nadir_camera(100, 100, {0, 0, 100});
  c.rotation[2] = {0, 0, 1};  // determinant -1
  EXPECT_THROW(check_camera(c, "camera 0"), ArgumentError);
}

TEST(Rectification, PointsShareARowAndTriangulateBack) {
  // Two tilted cameras with distortion, baseline mostly along x with some y and z.
  const FrameCamera a = nadir_camera(240, 380, {100, 200, 150}, 0.04, -0.06, -0.05, 0.001);
  const FrameCamera b = nadir_camera(220, 400, {130, 206, 152}, -0.03, 0.05, 0.03, -0.001);
  RectifyOptions options;
  options.min_height = 0;
  options.max_height = 40;
  const RectifiedPair pair = rectify_pair(a, smooth_image(a.width, a.height), b, smooth_image(b.width, b.height), options);
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

TEST(Fusion, MedianPerCellNodataWhereNothingFell) {
  Grid grid = dsm_grid({0, 0, 3, 2}, 1.0);
  ASSERT_EQ(grid.width, 3);
  ASSERT_EQ(grid.height, 2);
  const std::vector<std::vector<Vec3>> sets{{{0.5, 1.5, 10}, {0.2, 1.9, 30}, {0.9, 1.1, 11}},  // cell (0,0): 10, 30, 11
                                            {{2.5, 0.5, 4}, {2.1, 0.2, 6}, {9, 9, 1}}};          // (2,1): 4, 6; one outside
  EXPECT_EQ(fuse_median(grid, sets), 5u);
  EXPECT_FLOAT_EQ(grid.at(0, 0), 11);
  EXPECT_FLOAT_EQ(grid.at(2, 1), 5);
  EXPECT_TRUE(std::isnan(grid.at(1, 0)));
  EXPECT_TRUE(std::isnan(grid.at(0, 1)));
}

TEST(PairSelection, ExplicitAndAuto) {
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

TEST(FramePipeline, RenderedNrwCropBackToItsDsm) {
  // 40 m x 40 m of the real DSM (1 m cells) in the middle of the 500 m crop.
  const Grid& nrw = testkit::nrw_crop();
  const int c0 = nrw.width / 2 - 20, r0 = nrw.height / 2 - 20, n = 40;
  Grid truth(n, n, nrw.x0 + c0 * nrw.cell_x, nrw.y0 - r0 * nrw.cell_y, nrw.cell_x, nrw.cell_y);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) truth.z[truth.index(c, r)] = nrw.at(c0 + c, r0 + r);
  const auto [lo, hi] = std::minmax_element(truth.z.begin(), truth.z.end());
  const ColumnScene scene{truth, *lo, *hi};
  const double xc = truth.x0 + n / 2.0, yc = truth.y0 - n / 2.0, zc = *lo + 110;
  // Base 24 m at 110 m (B/H 0.22); 240 x 240 pixels, 0.3 m on the ground; the right camera tilted
  // and with lens distortion.
  const std::vector<FrameCamera> cameras{nadir_camera(240, 380, {xc - 12, yc, zc}),
                                         nadir_camera(240, 380, {xc + 12, yc + 1, zc + 2}, 0.02, -0.03, -0.04, 0.0005)};
  const auto start = std::chrono::steady_clock::now();
  const std::vector<GreyImage> images{render(scene, cameras[0], 1), render(scene, cameras[1], 2)};
  const double render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  FrameStereoOptions options;
  options.rectify.min_height = *lo;
  options.rectify.max_height = *hi;
  Grid dsm = dsm_grid({truth.x0, truth.y1(), truth.x1(), truth.y0}, 1.0);
  PairSelectionOptions selection;
  selection.ground_height = *lo;
  const auto pairs = select_pairs_auto(cameras, selection);
  ASSERT_EQ(pairs.size(), 1u);
  const FrameStereoStats stats = stereo_dsm(cameras, images, pairs, dsm, options);
  ASSERT_EQ(dsm.width, n);
  ASSERT_EQ(dsm.height, n);

  std::vector<double> errors;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c)
      if (dsm.valid(c, r)) errors.push_back(std::abs(dsm.at(c, r) - truth.at(c, r)));
  ASSERT_FALSE(errors.empty());
  std::sort(errors.begin(), errors.end());
  const double completeness = static_cast<double>(errors.size()) / (n * n);
  const double median = errors[errors.size() / 2];
  const double over1 = static_cast<double>(errors.end() - std::upper_bound(errors.begin(), errors.end(), 1.0)) / errors.size();
  const double over3 = static_cast<double>(errors.end() - std::upper_bound(errors.begin(), errors.end(), 3.0)) / errors.size();
  std::printf("NRW crop 40 m x 40 m (heights %.1f..%.1f m): completeness %.1f %%, median |error| %.3f m, "
              "> 1 m %.1f %%, > 3 m %.1f %%; %zu points, render %.2f s, rectify %.3f s, match %.3f s, "
              "triangulate %.3f s, fuse %.3f s\n",
              *lo, *hi, 100 * completeness, median, 100 * over1, 100 * over3, stats.points, render_seconds,
              stats.seconds_rectify, stats.seconds_match, stats.seconds_triangulate, stats.seconds_fuse);
  EXPECT_GT(completeness, 0.85);
  EXPECT_LT(median, 0.3);
  EXPECT_LT(over1, 0.15);
  EXPECT_LT(over3, 0.05);
}

TEST(FramePipeline, RefusesWrongImageSizeAndCamerasWithoutOverlap) {
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
