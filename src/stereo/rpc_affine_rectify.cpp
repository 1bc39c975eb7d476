// Affine epipolar rectification of a push-broom (RPC) pair over a tile (dsmplan/rpc_stereo.hpp).
//
// Follows C. de Franchis, E. Meinhardt-Llopis, J. Michel, J.-M. Morel, G. Facciolo, "An automatic
// and modular stereo pipeline for pushbroom images", ISPRS Annals II-3, 2014 (s2p),
// and "On stereo-rectification of pushbroom images", ICIP 2014: over a small tile each RPC camera
// is replaced by its best affine camera, two affine cameras have parallel epipolar lines
// (Hartley & Zisserman, "Multiple View Geometry", 2nd ed., ch. 14), and a similarity per image
// makes them horizontal and aligned. The similarities are built here directly from the two
// affine cameras (s2p builds them from the affine fundamental matrix; the same lines): the
// viewing direction of camera i is the null vector v_i of its 2x3 linear part M_i, the epipolar
// direction of image 1 is M_1 v_2 (a point sliding along camera 2's ray), and n_1ᵀ M_1, n_2ᵀ M_2
// (n_i the normals of the epipolar directions) both vanish on v_1 and v_2, so they are multiples
// of one row: the ratio of the multiples is the right image's scale.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "dsmplan/core.hpp"
#include "dsmplan/rpc_stereo.hpp"

namespace dsmplan {

Affine2 Affine2::inverse() const {
  const double det = m[0] * m[4] - m[1] * m[3];
  if (!(std::abs(det) > 1e-300)) throw ArgumentError("affine map", "is singular");
  const double a = m[4] / det, b = -m[1] / det, c = -m[3] / det, d = m[0] / det;
  return {{a, b, -(a * m[2] + b * m[5]), c, d, -(c * m[2] + d * m[5])}};
}

Affine2 Affine2::after(const Affine2& o) const {
  const auto& n = o.m;
  return {{m[0] * n[0] + m[1] * n[3], m[0] * n[1] + m[1] * n[4], m[0] * n[2] + m[1] * n[5] + m[2],
           m[3] * n[0] + m[4] * n[3], m[3] * n[1] + m[4] * n[4], m[3] * n[2] + m[4] * n[5] + m[5]}};
}

float FloatImage::sample(double col, double row) const {
  const double x = col - 0.5, y = row - 0.5;
  if (!(x >= 0 && y >= 0 && x <= width - 1 && y <= height - 1)) return std::numeric_limits<float>::quiet_NaN();
  // Clamped so that the last row and column (x == width - 1) read inside.
  const int x0 = std::min(static_cast<int>(x), width - 2 < 0 ? 0 : width - 2);
  const int y0 = std::min(static_cast<int>(y), height - 2 < 0 ? 0 : height - 2);
  const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
  const double fx = x - x0, fy = y - y0;
  const double top = (1 - fx) * at(x0, y0) + fx * at(x1, y0), bottom = (1 - fx) * at(x0, y1) + fx * at(x1, y1);
  return static_cast<float>((1 - fy) * top + fy * bottom);
}

namespace {
constexpr double kRadius = 6378137.0, kRad = M_PI / 180;
}

std::array<double, 3> AffineCamera::local(const GeoPoint& g) const {
  return {(g.lon - origin.lon) * kRad * kRadius * std::cos(origin.lat * kRad), (g.lat - origin.lat) * kRad * kRadius,
          g.height - origin.height};
}

PixelPoint AffineCamera::project(const GeoPoint& g) const {
  const auto x = local(g);
  return {p[0] * x[0] + p[1] * x[1] + p[2] * x[2] + p[3], p[4] * x[0] + p[5] * x[1] + p[6] * x[2] + p[7]};
}

AffineCamera fit_affine_camera(const RpcCamera& camera, const GeoPoint& origin, const std::vector<GeoPoint>& points) {
  if (points.size() < 4) throw ArgumentError("points", "an affine camera needs at least 4 ground points");
  AffineCamera cam;
  cam.origin = origin;
  const Eigen::Index n = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixXd A(n, 4);
  Eigen::MatrixXd b(n, 2);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto x = cam.local(points[i]);
    A.row(i) << x[0], x[1], x[2], 1.0;
    const PixelPoint q = camera.project(points[i]);
    b.row(i) << q.col, q.row;
  }
  // QR, not normal equations: metres and pixels of very different spreads (heights vs extent).
  const Eigen::MatrixXd P = A.colPivHouseholderQr().solve(b);
  for (int k = 0; k < 4; ++k) cam.p[k] = P(k, 0), cam.p[4 + k] = P(k, 1);
  double sum = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const PixelPoint q = camera.project(points[i]), a = cam.project(points[i]);
    const double e = std::hypot(q.col - a.col, q.row - a.row);
    sum += e * e, cam.max_px = std::max(cam.max_px, e);
  }
  cam.rms_px = std::sqrt(sum / static_cast<double>(n));
  return cam;
}

RpcRectification rectify_rpc_pair(const RpcCamera& left, const RpcCamera& right, const RpcTile& tile, int samples) {
  if (tile.width < 2 || tile.height < 2) throw ArgumentError("tile", "is smaller than 2 x 2 pixels");
  if (!(tile.height_max > tile.height_min)) throw ArgumentError("tile", "height range is empty");
  if (samples < 2) throw ArgumentError("samples", "must be at least 2");
  // The tile's volume: a grid of its positions localized at heights across the range.
  std::vector<GeoPoint> ground;
  std::vector<int> level;  // the height index of each point
  for (int k = 0; k < samples; ++k) {
    const double h = tile.height_min + (tile.height_max - tile.height_min) * k / (samples - 1);
    for (int j = 0; j < samples; ++j)
      for (int i = 0; i < samples; ++i) {
        const PixelPoint p{tile.col0 + tile.width * static_cast<double>(i) / (samples - 1),
                           tile.row0 + tile.height * static_cast<double>(j) / (samples - 1)};
        ground.push_back(left.localize(p, h));
        level.push_back(k);
      }
  }
  const double h_mid = 0.5 * (tile.height_min + tile.height_max);
  const GeoPoint origin = left.localize({tile.col0 + 0.5 * tile.width, tile.row0 + 0.5 * tile.height}, h_mid);
  RpcRectification r;
  r.camera_left = fit_affine_camera(left, origin, ground);
  r.camera_right = fit_affine_camera(right, origin, ground);
  const auto& p1 = r.camera_left.p;
  const auto& p2 = r.camera_right.p;
  const Eigen::Vector3d a1(p1[0], p1[1], p1[2]), b1(p1[4], p1[5], p1[6]);
  const Eigen::Vector3d a2(p2[0], p2[1], p2[2]), b2(p2[4], p2[5], p2[6]);
  const Eigen::Vector3d v1 = a1.cross(b1), v2 = a2.cross(b2);  // viewing directions
  // Epipolar directions: where a point sliding along the other camera's ray moves.
  Eigen::Vector2d e1(a1.dot(v2), b1.dot(v2)), e2(a2.dot(v1), b2.dot(v1));
  if (e1.norm() < 1e-12 || e2.norm() < 1e-12) throw ArgumentError("cameras", "have parallel rays: no stereo");
  e1.normalize(), e2.normalize();
  // The same sense of the rectified columns in both images: their ground gradients agree.
  auto ground_row = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector2d& d) {
    return Eigen::Vector3d(d[0] * a + d[1] * b);
  };
  if (ground_row(a1, b1, e1).dot(ground_row(a2, b2, e2)) < 0) e2 = -e2;
  const Eigen::Vector2d n1(-e1[1], e1[0]), n2(-e2[1], e2[0]);
  const Eigen::Vector3d g1 = ground_row(a1, b1, n1), g2 = ground_row(a2, b2, n2);
  const double s = g1.dot(g2) / g2.squaredNorm();  // right's rows times s = left's rows
  const double su = std::abs(s);                   // columns scaled alike (a similarity)
  r.left = Affine2{{e1[0], e1[1], 0, n1[0], n1[1], 0}};
  r.right = Affine2{{su * e2[0], su * e2[1], 0, s * n2[0], s * n2[1], 0}};
  // Translations: the left tile's bounding box starts at (0, 0).
  double umin = 1e300, umax = -1e300, vmin = 1e300, vmax = -1e300;
  for (const PixelPoint c :
       {PixelPoint{double(tile.col0), double(tile.row0)}, PixelPoint{double(tile.col0 + tile.width), double(tile.row0)},
        PixelPoint{double(tile.col0), double(tile.row0 + tile.height)},
        PixelPoint{double(tile.col0 + tile.width), double(tile.row0 + tile.height)}}) {
    const PixelPoint q = r.left(c);
    umin = std::min(umin, q.col), umax = std::max(umax, q.col), vmin = std::min(vmin, q.row),
    vmax = std::max(vmax, q.row);
  }
  r.left.m[2] = -umin, r.left.m[5] = -vmin;
  r.width = static_cast<int>(std::ceil(umax - umin)), r.height = static_cast<int>(std::ceil(vmax - vmin));
  // The right rows aligned on the RPC projections (mean), the columns so that the middle height
  // level has disparity ~0 (mean), from the RPCs themselves rather than the affine fits.
  double dv = 0, du = 0;
  int n_mid = 0;
  const int k_mid = (samples - 1) / 2;
  std::vector<PixelPoint> q1(ground.size()), q2(ground.size());
  for (std::size_t i = 0; i < ground.size(); ++i) {
    q1[i] = r.left(left.project(ground[i])), q2[i] = r.right(right.project(ground[i]));
    dv += q1[i].row - q2[i].row;
    if (level[i] == k_mid) du += q1[i].col - q2[i].col, ++n_mid;
  }
  dv /= static_cast<double>(ground.size()), du /= n_mid;
  r.right.m[2] = du, r.right.m[5] = dv;
  double dmin = 1e300, dmax = -1e300;
  for (std::size_t i = 0; i < ground.size(); ++i) {
    const double d = q1[i].col - (q2[i].col + du);
    dmin = std::min(dmin, d), dmax = std::max(dmax, d);
    r.rpc_row_error_px = std::max(r.rpc_row_error_px, std::abs(q1[i].row - (q2[i].row + dv)));
  }
  r.min_disparity = static_cast<int>(std::floor(dmin)), r.max_disparity = static_cast<int>(std::ceil(dmax));
  return r;
}

FloatImage resample_rectified(const FloatImage& image, const Affine2& to_rectified, int width, int height) {
  if (width < 1 || height < 1) throw ArgumentError("rectified size", "is empty");
  if (image.pixels.size() != static_cast<std::size_t>(image.width) * image.height || image.width < 1 ||
      image.height < 1)
    throw ArgumentError("image", "size does not match its pixels");
  const Affine2 back = to_rectified.inverse();
  FloatImage out;
  out.width = width, out.height = height;
  out.pixels.resize(static_cast<std::size_t>(width) * height);
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < width; ++x) {
        const PixelPoint p = back({x + 0.5, y + 0.5});
        out.pixels[static_cast<std::size_t>(y) * width + x] = image.sample(p.col, p.row);
      }
  });
  return out;
}

}  // namespace dsmplan
