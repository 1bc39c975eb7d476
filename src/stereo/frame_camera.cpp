// Frame cameras: pinhole projection with Brown–Conrady lens distortion in OpenCV's convention
// (D. C. Brown, "Decentering distortion of lenses", Photogrammetric Engineering 32(3), 1966;
// A. E. Conrady, "Decentred lens-systems", MNRAS 79, 1919; the formula and coefficient order of
// OpenCV's calib3d, "Camera Calibration and 3D Reconstruction"). See dsmplan/stereo_frames.hpp.
#include <cmath>
#include <string>

#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {

void check_camera(const FrameCamera& c, const std::string& name) {
  if (c.width < 1 || c.height < 1) throw ArgumentError(name, "width and height must be >= 1 pixels");
  if (!(std::isfinite(c.fx) && std::isfinite(c.fy) && c.fx > 0 && c.fy > 0))
    throw ArgumentError(name, "fx and fy must be positive numbers of pixels");
  if (!(std::isfinite(c.cx) && std::isfinite(c.cy))) throw ArgumentError(name, "cx and cy must be finite");
  for (double k : c.distortion)
    if (!std::isfinite(k)) throw ArgumentError(name, "distortion coefficients must be finite");
  for (double x : c.center)
    if (!(std::abs(x) <= kMaxCoordinate))
      throw ArgumentError(name,
                          "center must be finite and within 1e9 CRS units of the origin (a projected CRS's reach)");
  const Mat3& R = c.rotation;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      if (!std::isfinite(R[i][j])) throw ArgumentError(name, "rotation must be finite");
      double dot = 0;
      for (int k = 0; k < 3; ++k) dot += R[i][k] * R[j][k];
      if (std::abs(dot - (i == j ? 1.0 : 0.0)) > 1e-6)
        throw ArgumentError(name, "rotation is not orthonormal (R R^T differs from I by " +
                                      std::to_string(std::abs(dot - (i == j ? 1.0 : 0.0))) + ")");
    }
  const double det = R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1]) -
                     R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0]) +
                     R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]);
  if (det < 0) throw ArgumentError(name, "rotation is a reflection (determinant -1), not a rotation");
}

std::array<double, 2> distort(const FrameCamera& c, double x, double y) {
  const auto& [k1, k2, p1, p2, k3] = c.distortion;
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
}

std::array<double, 2> undistort(const FrameCamera& c, double xd, double yd) {
  if (!c.distorted()) return {xd, yd};
  const auto& [k1, k2, p1, p2, k3] = c.distortion;
  double x = xd, y = yd;
  for (int step = 0; step < 20; ++step) {
    const double r2 = x * x + y * y;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dradial = k1 + r2 * (2 * k2 + 3 * k3 * r2);  // d radial / d r2
    const auto [fx, fy] = distort(c, x, y);
    const double ex = fx - xd, ey = fy - yd;
    // Jacobian of distort() at (x, y).
    const double a = radial + x * dradial * 2 * x + 2 * p1 * y + p2 * 6 * x;
    const double b = x * dradial * 2 * y + 2 * p1 * x + p2 * 2 * y;
    const double cc = y * dradial * 2 * x + p1 * 2 * x + 2 * p2 * y;
    const double d = radial + y * dradial * 2 * y + p1 * 6 * y + 2 * p2 * x;
    const double det = a * d - b * cc;
    if (!(std::abs(det) > 1e-300)) break;
    const double dx = (d * ex - b * ey) / det, dy = (a * ey - cc * ex) / det;
    x -= dx;
    y -= dy;
    if (std::abs(dx) + std::abs(dy) < 1e-12) break;
  }
  return {x, y};
}

bool project(const FrameCamera& c, const Vec3& X, double& u, double& v) {
  const Vec3 d{X[0] - c.center[0], X[1] - c.center[1], X[2] - c.center[2]};
  double p[3];
  for (int i = 0; i < 3; ++i) p[i] = c.rotation[i][0] * d[0] + c.rotation[i][1] * d[1] + c.rotation[i][2] * d[2];
  if (!(p[2] > 0)) return false;
  double x = p[0] / p[2], y = p[1] / p[2];
  if (c.distorted()) {
    const auto xy = distort(c, x, y);
    x = xy[0];
    y = xy[1];
  }
  u = c.fx * x + c.cx;
  v = c.fy * y + c.cy;
  return true;
}

Vec3 pixel_ray(const FrameCamera& c, double u, double v) {
  const auto [x, y] = undistort(c, (u - c.cx) / c.fx, (v - c.cy) / c.fy);
  Vec3 w{};
  for (int i = 0; i < 3; ++i) w[i] = c.rotation[0][i] * x + c.rotation[1][i] * y + c.rotation[2][i];  // R^T (x, y, 1)
  const double n = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  return {w[0] / n, w[1] / n, w[2] / n};
}

bool GreyImage::sample(double x, double y, float& value) const {
  if (!(x >= 0 && y >= 0 && x <= width - 1 && y <= height - 1)) return false;
  const int x0 = std::min(static_cast<int>(x), width - 2 < 0 ? 0 : width - 2);
  const int y0 = std::min(static_cast<int>(y), height - 2 < 0 ? 0 : height - 2);
  const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
  const double fx = x - x0, fy = y - y0;
  const double top = at(x0, y0) * (1 - fx) + at(x1, y0) * fx;
  const double bottom = at(x0, y1) * (1 - fx) + at(x1, y1) * fx;
  value = static_cast<float>(top * (1 - fy) + bottom * fy);
  return true;
}

}  // namespace dsmplan
