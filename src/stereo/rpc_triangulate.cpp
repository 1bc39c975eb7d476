// Triangulation of a push-broom (RPC) pair (dsmplan/rpc_stereo.hpp).
//
// The least-squares intersection of two RPC viewing rays: the ground point (lon, lat, height)
// whose projections are nearest, in pixels, to the two observed positions, by Gauss-Newton on the
// 4 residuals (as s2p's triangulation by "RPC least squares", de Franchis et al., ISPRS Annals
// II-3, 2014, and rpcm's/ASP's RPC intersection). The derivatives by longitude and
// latitude are RpcCamera::jacobian's (analytic); by height a central difference over ±1 m (the
// RPC is a cubic in height: its second-order error is below 1e-6 relative, and only the speed of
// convergence depends on it, not the point it converges to). Started from the left ray at the
// initial height, the problem is near linear over a tile: 2 to 4 steps.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/rpc_stereo.hpp"

namespace dsmplan {

RpcStereoPoint triangulate_rpc(const RpcCamera& left, const RpcCamera& right, const PixelPoint& a, const PixelPoint& b,
                               double initial_height) {
  GeoPoint g = left.localize(a, initial_height);
  auto residuals = [&](const GeoPoint& x) {
    const PixelPoint pa = left.project(x), pb = right.project(x);
    return Eigen::Vector4d(pa.col - a.col, pa.row - a.row, pb.col - b.col, pb.row - b.row);
  };
  Eigen::Vector4d f = residuals(g);
  const double m_per_deg = M_PI / 180 * 6378137.0;
  for (int step = 0; step < 10; ++step) {
    const auto ja = left.jacobian(g), jb = right.jacobian(g);
    const Eigen::Vector4d up = residuals({g.lon, g.lat, g.height + 1}), down = residuals({g.lon, g.lat, g.height - 1});
    Eigen::Matrix<double, 4, 3> J;
    // Columns in pixels per metre (degrees scaled), so that the three unknowns weigh alike.
    J << ja[0] / m_per_deg, ja[1] / m_per_deg, 0, ja[2] / m_per_deg, ja[3] / m_per_deg, 0, jb[0] / m_per_deg,
        jb[1] / m_per_deg, 0, jb[2] / m_per_deg, jb[3] / m_per_deg, 0;
    J.col(2) = 0.5 * (up - down);
    const Eigen::Vector3d dx = J.colPivHouseholderQr().solve(-f);
    g.lon += dx[0] / m_per_deg, g.lat += dx[1] / m_per_deg, g.height += dx[2];
    f = residuals(g);
    if (dx.norm() < 1e-6) break;
  }
  return {g, std::sqrt(f.squaredNorm() / 4)};
}

std::vector<RpcStereoPoint> disparity_to_points(const RpcCamera& left, const RpcCamera& right,
                                                const RpcRectification& rect, const Disparity& disparity,
                                                double max_residual_px) {
  const Affine2 left_back = rect.left.inverse(), right_back = rect.right.inverse();
  std::vector<std::vector<RpcStereoPoint>> rows(static_cast<std::size_t>(disparity.height));
  tbb::parallel_for(tbb::blocked_range<int>(0, disparity.height), [&](const tbb::blocked_range<int>& range) {
    for (int y = range.begin(); y < range.end(); ++y) {
      double h0 = rect.camera_left.origin.height;  // the tile's middle height, then the last point's
      for (int x = 0; x < disparity.width; ++x) {
        const float d = disparity.at(x, y);
        if (std::isnan(d)) continue;
        const PixelPoint a = left_back({x + 0.5, y + 0.5});
        const PixelPoint r = right_back({x + 0.5 - d, y + 0.5});
        RpcStereoPoint p;
        try {
          p = triangulate_rpc(left, right, a, {r.col + rect.pointing[0], r.row + rect.pointing[1]}, h0);
        } catch (const InputError&) {
          continue;  // a wild disparity far outside the RPC's domain: that pixel only
        }
        if (p.residual_px <= max_residual_px) rows[static_cast<std::size_t>(y)].push_back(p), h0 = p.ground.height;
      }
    }
  });
  std::vector<RpcStereoPoint> out;
  for (auto& row : rows) out.insert(out.end(), row.begin(), row.end());
  return out;
}

}  // namespace dsmplan
