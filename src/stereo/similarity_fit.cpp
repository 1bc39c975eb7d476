// The similarity transform between two point sets by least squares (dsmplan/colmap_model.hpp):
// S. Umeyama, "Least-squares estimation of transformation parameters between two point
// patterns", IEEE PAMI 13(4):376-380, 1991, eqs. (34)-(42): the means, the covariance Σxy of the
// centred sets, its SVD U D Vᵀ, S = diag(1, 1, -1) when det(U) det(V) < 0 (a reflection would fit
// better: the rotation closest to it is taken), Q = U S Vᵀ, s = tr(D S) / σx², T = μy - s Q μx.
// And the camera carried through it.
#include <Eigen/Dense>
#include <cmath>

#include "dsmplan/colmap_model.hpp"

namespace dsmplan {

Vec3 Similarity::apply(const Vec3& x) const {
  Vec3 out{};
  for (int i = 0; i < 3; ++i)
    out[i] = scale * (rotation[i][0] * x[0] + rotation[i][1] * x[1] + rotation[i][2] * x[2]) + translation[i];
  return out;
}

FrameCamera transformed(const FrameCamera& camera, const Similarity& transform) {
  // x_cam ∝ R (X - C) with X = Qᵀ (X' - T) / s: x_cam ∝ R Qᵀ (X' - (s Q C + T)).
  FrameCamera out = camera;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double sum = 0;
      for (int k = 0; k < 3; ++k) sum += camera.rotation[i][k] * transform.rotation[j][k];
      out.rotation[i][j] = sum;
    }
  out.center = transform.apply(camera.center);
  return out;
}

Similarity fit_similarity(const std::vector<Vec3>& from, const std::vector<Vec3>& to) {
  if (from.size() != to.size() || from.size() < 3)
    throw ArgumentError("centres", "a similarity needs at least 3 pairs of points, the same number on both sides");
  const auto n = static_cast<double>(from.size());
  Eigen::Vector3d mean_from = Eigen::Vector3d::Zero(), mean_to = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    mean_from += Eigen::Vector3d(from[i][0], from[i][1], from[i][2]);
    mean_to += Eigen::Vector3d(to[i][0], to[i][1], to[i][2]);
  }
  mean_from /= n;
  mean_to /= n;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  double variance_from = 0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector3d x = Eigen::Vector3d(from[i][0], from[i][1], from[i][2]) - mean_from;
    const Eigen::Vector3d y = Eigen::Vector3d(to[i][0], to[i][1], to[i][2]) - mean_to;
    covariance += y * x.transpose();
    variance_from += x.squaredNorm();
  }
  covariance /= n;
  variance_from /= n;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d s(1, 1, 1);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) s(2) = -1;
  const Eigen::Matrix3d q = svd.matrixU() * s.asDiagonal() * svd.matrixV().transpose();
  Similarity out;
  out.scale = variance_from > 0 ? svd.singularValues().dot(s) / variance_from : 1.0;
  const Eigen::Vector3d t = mean_to - out.scale * q * mean_from;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.rotation[i][j] = q(i, j);
    out.translation[i] = t(i);
  }
  return out;
}

}  // namespace dsmplan
