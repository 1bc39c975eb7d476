// A world point from its pixels in two or more calibrated frame cameras (dsmplan/colmap_model.hpp,
// the ground control points of `dsmplan stereo --colmap --gcps`): the linear (DLT) triangulation
// of R. Hartley & A. Zisserman, "Multiple View Geometry in Computer Vision", 2nd ed., 2003,
// Section 12.2: each view's pixel is undistorted to normalised coordinates (x, y) (undistort(),
// frame_camera.cpp), P = [R | -R C], and the rows x P3ᵀ - P1ᵀ, y P3ᵀ - P2ᵀ of all views stacked
// into A; X is the right singular vector of A's least singular value. The world is first centred
// on the cameras' mean centre and scaled by their RMS distance from it (Hartley's normalisation,
// Section 4.4.4, applied to the 3D side), so the arbitrary scale and offset of a COLMAP model do
// not condition A. The result's reprojection errors (project()) and its rays' widest angle are
// returned for the caller to judge.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "dsmplan/colmap_model.hpp"

namespace dsmplan {

ViewTriangulation triangulate_views(const std::vector<FrameCamera>& cameras,
                                    const std::vector<std::array<double, 2>>& pixels) {
  if (cameras.size() != pixels.size() || cameras.size() < 2)
    throw ArgumentError("pixels", "a point is triangulated from two or more views, one pixel each");
  const auto n = static_cast<double>(cameras.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const FrameCamera& c : cameras) mean += Eigen::Vector3d(c.center[0], c.center[1], c.center[2]);
  mean /= n;
  double spread = 0;
  for (const FrameCamera& c : cameras)
    spread += (Eigen::Vector3d(c.center[0], c.center[1], c.center[2]) - mean).squaredNorm();
  spread = std::sqrt(spread / n);
  if (!(spread > 0)) spread = 1;  // one centre: no baseline; the angle below says so
  Eigen::MatrixXd a(2 * cameras.size(), 4);
  ViewTriangulation out;
  std::vector<Eigen::Vector3d> rays;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const FrameCamera& c = cameras[i];
    const auto [x, y] = undistort(c, (pixels[i][0] - c.cx) / c.fx, (pixels[i][1] - c.cy) / c.fy);
    Eigen::Matrix3d r;
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) r(j, k) = c.rotation[j][k];
    const Eigen::Vector3d centre = (Eigen::Vector3d(c.center[0], c.center[1], c.center[2]) - mean) / spread;
    Eigen::Matrix<double, 3, 4> p;
    p.leftCols<3>() = r;
    p.col(3) = -r * centre;
    a.row(2 * i) = x * p.row(2) - p.row(0);
    a.row(2 * i + 1) = y * p.row(2) - p.row(1);
    a.row(2 * i).normalize();
    a.row(2 * i + 1).normalize();
    rays.push_back((r.transpose() * Eigen::Vector3d(x, y, 1)).normalized());
  }
  for (std::size_t i = 0; i < rays.size(); ++i)
    for (std::size_t j = i + 1; j < rays.size(); ++j)
      out.ray_angle = std::max(out.ray_angle, std::acos(std::clamp(rays[i].dot(rays[j]), -1.0, 1.0)));
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  if (!(std::abs(h(3)) > 1e-12 * h.head<3>().norm())) {
    out.finite = false;  // a point at infinity: parallel rays
    return out;
  }
  const Eigen::Vector3d x = mean + spread * h.head<3>() / h(3);
  out.point = {x.x(), x.y(), x.z()};
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    double u = 0, v = 0;
    if (!project(cameras[i], out.point, u, v)) {
      out.behind = static_cast<int>(i);
      out.max_reprojection = INFINITY;
      out.worst = static_cast<int>(i);
      continue;
    }
    const double e = std::hypot(u - pixels[i][0], v - pixels[i][1]);
    if (out.behind < 0 && e > out.max_reprojection) out.max_reprojection = e, out.worst = static_cast<int>(i);
  }
  return out;
}

}  // namespace dsmplan
