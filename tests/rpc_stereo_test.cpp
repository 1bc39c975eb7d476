// Stereo of the real Pléiades pairs over Kahramanmaraş (data/pleiades-kahramanmaras) through
// dsmplan/rpc_stereo.hpp: affine epipolar rectification of a tile, the pointing
// correction from tie points, triangulation through the RPCs, and the SGM (stereo.hpp) on one
// rectified tile. No ground truth exists: the checks are the epipolar residual of tie points
// (held out from the correction's estimate), the round trip of synthetic ground points, and the
// SGM's valid share and height range, and the flatness of a street stretch picked from the
// image (robust plane fit residuals), printed.
#include "dsmplan/rpc_stereo.hpp"

#include <gdal_priv.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/rpc_io.hpp"
#include "dsmplan/stereo.hpp"

namespace {

using dsmplan::FloatImage;
using dsmplan::GeoPoint;
using dsmplan::PixelPoint;
using dsmplan::RpcCamera;
using dsmplan::RpcRectification;

const bool kGdalRegistered = [] {
  GDALAllRegister();
  return true;
}();

std::string data(const std::string& name) { return std::string(DSMPLAN_DATA_DIR) + "/pleiades-kahramanmaras/" + name; }

FloatImage read_image(const std::string& path) {
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(path.c_str(), GA_ReadOnly));
  EXPECT_NE(ds, nullptr) << path;
  FloatImage im;
  if (!ds) return im;
  im.width = ds->GetRasterXSize(), im.height = ds->GetRasterYSize();
  im.pixels.resize(static_cast<size_t>(im.width) * im.height);
  EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, im.width, im.height, im.pixels.data(), im.width, im.height,
                                           GDT_Float32, 0, 0, nullptr),
            CE_None);
  GDALClose(ds);
  return im;
}

double metres(const GeoPoint& a, const GeoPoint& b) {
  const double R = 6378137.0, rad = M_PI / 180;
  const double dx = (a.lon - b.lon) * rad * R * std::cos(a.lat * rad), dy = (a.lat - b.lat) * rad * R;
  return std::hypot(dx, dy, a.height - b.height);
}

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())))];
}

std::vector<double> absolute(std::vector<double> v) {
  for (double& x : v) x = std::abs(x);
  return v;
}

// The tile of the left image every test uses: 400 x 400 in the middle of the 1000 x 1000 crops,
// heights 450-900 m above the ellipsoid (the city lies at ~500-800 m, rpc_test).
dsmplan::RpcTile tile() { return {300, 300, 400, 400, 450, 900}; }

struct Pair {
  std::string a, b;
};
const Pair kPairs[] = {{"pre_event_img1", "pre_event_img2"}, {"post_event_img1", "post_event_img2"}};

// A pair rectified over tile(), its rectified images and its tie points.
struct Rectified {
  RpcCamera left, right;
  RpcRectification rect;
  FloatImage L, R;
  std::vector<dsmplan::TiePoint> ties;
  Rectified(const RpcCamera& a, const RpcCamera& b) : left(a), right(b) {}
};

Rectified rectify(const Pair& pair) {
  Rectified r(dsmplan::read_rpc_camera(data(pair.a + ".tif")), dsmplan::read_rpc_camera(data(pair.b + ".tif")));
  r.rect = dsmplan::rectify_rpc_pair(r.left, r.right, tile());
  const FloatImage A = read_image(data(pair.a + ".tif")), B = read_image(data(pair.b + ".tif"));
  r.L = dsmplan::resample_rectified(A, r.rect.left, r.rect.width, r.rect.height);
  r.R = dsmplan::resample_rectified(B, r.rect.right, r.rect.width, r.rect.height);
  r.ties = dsmplan::match_tie_points(r.L, r.R, r.rect);
  return r;
}

TEST(RpcStereo, EpipolarResidualBelowHalfPixelAfterPointingCorrection) {
  for (const Pair& pair : kPairs) {
    const Rectified r = rectify(pair);
    const RpcRectification& rect = r.rect;
    std::printf(
        "%s / %s: tile 400 x 400 at (300, 300), heights 450-900 m: rectified %d x %d, disparities %d..%d; "
        "affine fit RMS %.3f / %.3f px (max %.3f / %.3f), RPC rows after rectification within %.3f px\n",
        pair.a.c_str(), pair.b.c_str(), rect.width, rect.height, rect.min_disparity, rect.max_disparity,
        rect.camera_left.rms_px, rect.camera_right.rms_px, rect.camera_left.max_px, rect.camera_right.max_px,
        rect.rpc_row_error_px);
    EXPECT_LT(rect.camera_left.max_px, 0.1);
    EXPECT_LT(rect.rpc_row_error_px, 0.1);
    ASSERT_GE(r.ties.size(), 40u) << pair.a;
    // Estimate on the even tie points, measure on the odd ones (and on all, for the report).
    std::vector<dsmplan::TiePoint> even, odd;
    for (size_t i = 0; i < r.ties.size(); ++i) (i % 2 ? odd : even).push_back(r.ties[i]);
    const RpcRectification corrected = dsmplan::correct_pointing(rect, even);
    const auto before = absolute(dsmplan::epipolar_errors(rect, odd));
    const auto after = absolute(dsmplan::epipolar_errors(corrected, odd));
    const auto after_all = absolute(dsmplan::epipolar_errors(dsmplan::correct_pointing(rect, r.ties), r.ties));
    std::printf(
        "  %zu tie points (NCC > 0.9); pointing correction (%.3f, %.3f) px of the right image; "
        "|epipolar error| of the %zu held-out ones: before median %.3f p90 %.3f px, after median %.3f "
        "p90 %.3f px (all, estimated on all: median %.3f p90 %.3f)\n",
        r.ties.size(), corrected.pointing[0], corrected.pointing[1], odd.size(), quantile(before, 0.5),
        quantile(before, 0.9), quantile(after, 0.5), quantile(after, 0.9), quantile(after_all, 0.5),
        quantile(after_all, 0.9));
    EXPECT_LT(quantile(after, 0.5), 0.5) << pair.a;
    EXPECT_LT(quantile(after, 0.9), 0.5) << pair.a;
  }
}

TEST(RpcStereo, TriangulatesSyntheticPointsToACentimetre) {
  const RpcCamera left = dsmplan::read_rpc_camera(data("pre_event_img1.tif"));
  const RpcCamera right = dsmplan::read_rpc_camera(data("pre_event_img2.tif"));
  double worst = 0, worst_res = 0;
  for (double h : {300.0, 475.0, 650.0, 900.0})
    for (int j = 0; j <= 4; ++j)
      for (int i = 0; i <= 4; ++i) {
        const GeoPoint g = left.localize({100.0 + 200 * i, 100.0 + 200 * j}, h);
        const auto p = dsmplan::triangulate_rpc(left, right, left.project(g), right.project(g), 600);
        worst = std::max(worst, metres(g, p.ground)), worst_res = std::max(worst_res, p.residual_px);
      }
  std::printf("ground -> both images -> triangulated: largest error %.2e m, largest residual %.2e px\n", worst,
              worst_res);
  EXPECT_LT(worst, 0.01);
  // Through the rectification and a disparity map: a left rectified pixel localized at a known
  // height, its disparity from the right RPC; disparity_to_points must give that height back
  // (up to the affine model's row error, below 0.1 px: a few centimetres).
  const RpcRectification rect = dsmplan::rectify_rpc_pair(left, right, tile());
  const dsmplan::Affine2 back = rect.left.inverse();
  std::vector<GeoPoint> truth;
  for (int k = 0; k < 5; ++k)
    truth.push_back(left.localize(back({40 + 70 * k + 0.5, 50 + 60 * k + 0.5}), 500 + 80 * k));
  dsmplan::Disparity full;
  full.width = rect.width, full.height = rect.height;
  full.left.assign(static_cast<size_t>(full.width) * full.height, NAN);
  for (int k = 0; k < 5; ++k) {
    const int x = 40 + 70 * k, y = 50 + 60 * k;
    const PixelPoint r = rect.right(right.project(truth[k]));
    full.left[static_cast<size_t>(y) * full.width + x] = static_cast<float>(x + 0.5 - r.col);
  }
  const auto points = dsmplan::disparity_to_points(left, right, rect, full);
  ASSERT_EQ(points.size(), 5u);
  double worst_h = 0;
  for (int k = 0; k < 5; ++k) worst_h = std::max(worst_h, std::abs(points[k].ground.height - truth[k].height));
  std::printf("through a disparity map of the rectified tile: largest height error %.2e m\n", worst_h);
  EXPECT_LT(worst_h, 0.1);
}

TEST(RpcStereo, SgmOnAPreEventTile) {
  const Rectified r = rectify(kPairs[0]);
  const RpcRectification rect = dsmplan::correct_pointing(r.rect, r.ties);
  const FloatImage R =
      dsmplan::resample_rectified(read_image(data(kPairs[0].b + ".tif")), rect.right, rect.width, rect.height);
  // The disparity range from the tie points (s2p's "sift" range), widened by 8 px.
  double dmin = 1e9, dmax = -1e9;
  for (const auto& t : r.ties) {
    const double d = rect.left(t.left).col - rect.right(t.right).col;
    dmin = std::min(dmin, d), dmax = std::max(dmax, d);
  }
  dsmplan::SgmOptions options;
  options.min_disparity = static_cast<int>(std::floor(dmin)) - 8;
  options.num_disparities = static_cast<int>(std::ceil(dmax)) + 8 - options.min_disparity + 1;
  // 12-bit grey levels as uint16; no data as 0.
  auto quantize = [](const FloatImage& im) {
    std::vector<std::uint16_t> q(im.pixels.size());
    for (size_t i = 0; i < q.size(); ++i)
      q[i] = std::isnan(im.pixels[i]) ? 0
                                      : static_cast<std::uint16_t>(std::lround(std::clamp(im.pixels[i], 0.f, 65535.f)));
    return q;
  };
  const auto ql = quantize(r.L), qr = quantize(R);
  const auto t0 = std::chrono::steady_clock::now();
  dsmplan::Disparity disp =
      dsmplan::sgm_match({ql.data(), rect.width, rect.height}, {qr.data(), rect.width, rect.height}, options);
  const auto t1 = std::chrono::steady_clock::now();
  // Pixels outside either image carry no disparity.
  size_t inside = 0, valid = 0;
  for (int y = 0; y < rect.height; ++y)
    for (int x = 0; x < rect.width; ++x) {
      float& d = disp.left[static_cast<size_t>(y) * rect.width + x];
      const bool in = !std::isnan(r.L.at(x, y));
      inside += in;
      if (!in) d = NAN;
      valid += !std::isnan(d);
    }
  const auto points = dsmplan::disparity_to_points(r.left, r.right, rect, disp);
  const auto t2 = std::chrono::steady_clock::now();
  std::vector<double> heights;
  for (const auto& p : points) heights.push_back(p.ground.height);
  ASSERT_GT(heights.size(), 1000u);
  const double share = static_cast<double>(valid) / static_cast<double>(inside);
  std::printf(
      "pre-event tile: SGM over disparities %d..%d: %.1f %% of the tile's pixels valid, %zu points (residual "
      "< 1 px); heights p2 %.1f, p50 %.1f, p98 %.1f m; SGM %.2f s, triangulation %.2f s\n",
      options.min_disparity, options.min_disparity + options.num_disparities - 1, 100 * share, points.size(),
      quantile(heights, 0.02), quantile(heights, 0.5), quantile(heights, 0.98),
      std::chrono::duration<double>(t1 - t0).count(), std::chrono::duration<double>(t2 - t1).count());
  EXPECT_GT(share, 0.5);
  EXPECT_GT(quantile(heights, 0.02), 400);
  EXPECT_LT(quantile(heights, 0.98), 950);

  // Street flatness: a straight stretch of a street, picked from the image (pre_event_img1,
  // columns 320-580, rows 399-405: the asphalt of the east-west street below the curb in the
  // tile's upper quarter, clear of trees; it falls ~5 m to the east). A plane fitted to its points (least squares, then
  // again without those beyond 3 MADs: cars and overhanging crowns) leaves residuals that are the matching's noise.
  const dsmplan::Affine2 back = rect.left.inverse();
  std::vector<std::array<double, 3>> street;
  for (int y = 0; y < rect.height; ++y)
    for (int x = 0; x < rect.width; ++x) {
      const float d = disp.at(x, y);
      const PixelPoint a = back({x + 0.5, y + 0.5});
      if (std::isnan(d) || a.col < 320 || a.col > 580 || a.row < 399 || a.row > 405) continue;
      const PixelPoint b = rect.right_rpc({x + 0.5 - d, y + 0.5});
      const auto p = dsmplan::triangulate_rpc(r.left, r.right, a, b, 700);
      if (p.residual_px < 1) street.push_back(rect.camera_left.local(p.ground));
    }
  ASSERT_GT(street.size(), 500u);
  auto fit = [](const std::vector<std::array<double, 3>>& pts, std::vector<double>& residuals) {
    Eigen::MatrixXd A(static_cast<Eigen::Index>(pts.size()), 3);
    Eigen::VectorXd z(A.rows());
    for (Eigen::Index i = 0; i < A.rows(); ++i) A.row(i) << 1, pts[i][0], pts[i][1], z[i] = pts[i][2];
    const Eigen::VectorXd c = A.colPivHouseholderQr().solve(z);
    residuals.clear();
    for (Eigen::Index i = 0; i < A.rows(); ++i) residuals.push_back(z[i] - A.row(i).dot(c));
    return c;
  };
  std::vector<double> res;
  fit(street, res);
  const double mad = quantile(absolute(res), 0.5);
  std::vector<std::array<double, 3>> kept;
  for (size_t i = 0; i < street.size(); ++i)
    if (std::abs(res[i]) <= 3 * 1.4826 * mad) kept.push_back(street[i]);
  const Eigen::VectorXd plane = fit(kept, res);
  const auto abs_res = absolute(res);
  size_t over = 0;
  for (double e : abs_res) over += e > 0.5;
  // The slope along the street (its points' principal direction); across it, over a strip a few
  // metres wide, the plane's slope is mostly noise and not reported.
  double me = 0, mn = 0, see = 0, snn = 0, sen = 0;
  for (const auto& q : kept) me += q[0], mn += q[1];
  me /= static_cast<double>(kept.size()), mn /= static_cast<double>(kept.size());
  for (const auto& q : kept)
    see += (q[0] - me) * (q[0] - me), snn += (q[1] - mn) * (q[1] - mn), sen += (q[0] - me) * (q[1] - mn);
  const double theta = 0.5 * std::atan2(2 * sen, see - snn);
  const double along = plane[1] * std::cos(theta) + plane[2] * std::sin(theta);
  std::printf(
      "street stretch (%zu points, %zu kept within 3 MADs): slope along it %.2f %%, |residual| median %.3f m, "
      "p90 %.3f m, %.1f %% over 0.5 m\n",
      street.size(), kept.size(), 100 * std::abs(along), quantile(abs_res, 0.5), quantile(abs_res, 0.9),
      100.0 * static_cast<double>(over) / static_cast<double>(abs_res.size()));
  EXPECT_LT(quantile(abs_res, 0.5), 0.5);
}

TEST(RpcStereo, BadArgumentsThrowArgumentError) {
  const RpcCamera left = dsmplan::read_rpc_camera(data("pre_event_img1.tif"));
  const RpcCamera right = dsmplan::read_rpc_camera(data("pre_event_img2.tif"));
  dsmplan::RpcTile flat = tile();
  flat.height_max = flat.height_min;
  EXPECT_THROW(dsmplan::rectify_rpc_pair(left, right, flat), dsmplan::ArgumentError);
  dsmplan::RpcTile thin = tile();
  thin.width = 1;
  EXPECT_THROW(dsmplan::rectify_rpc_pair(left, right, thin), dsmplan::ArgumentError);
  const RpcRectification rect = dsmplan::rectify_rpc_pair(left, right, tile());
  EXPECT_THROW(dsmplan::correct_pointing(rect, {}), dsmplan::ArgumentError);
  FloatImage small;
  small.width = small.height = 8;
  small.pixels.assign(64, 100.f);
  EXPECT_THROW(dsmplan::match_tie_points(small, small, rect), dsmplan::ArgumentError);
  // The same camera twice: parallel rays, no stereo.
  EXPECT_THROW(dsmplan::rectify_rpc_pair(left, left, tile()), dsmplan::ArgumentError);
}

}  // namespace
