// Triangulation of a rectified pair's disparities into world points. In the rectified frame
// (Fusiello, Trucco & Verri 2000) both cameras share orientation R, focal length f and row
// centre; the right centre lies at (B, 0, 0). A left pixel (u, v) with disparity d (right pixel
// u - d) is at depth z = f·B / (d + shift), x = (u - cx)·z/f, y = (v - cy)·z/f, and in the world
// at C_left + R^T (x, y, z): the two rays' intersection, exact because rectified rays of one
// row are coplanar (Hartley & Zisserman, "Multiple View Geometry", 2nd ed., Sec. 11.12 on
// rectified geometry).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {

bool triangulate(const RectifiedPair& pair, double u, double v, double d, Vec3& X) {
  const FrameCamera& c = pair.left;
  const double denominator = d + pair.shift;
  if (!(denominator > 0)) return false;
  const double z = c.fx * pair.baseline / denominator;
  const double x = (u - c.cx) * z / c.fx, y = (v - c.cy) * z / c.fy;
  for (int i = 0; i < 3; ++i) X[i] = c.center[i] + c.rotation[0][i] * x + c.rotation[1][i] * y + c.rotation[2][i] * z;
  return true;
}

std::vector<Vec3> triangulate(const RectifiedPair& pair, const Disparity& disparity, int row_begin, int row_end) {
  const int W = disparity.width, H = disparity.height;
  if (W != pair.left.width || H != pair.left.height)
    throw ArgumentError("disparity", "size differs from the rectified pair's");
  row_begin = std::clamp(row_begin, 0, H), row_end = std::clamp(row_end, row_begin, H);
  std::vector<std::vector<Vec3>> rows(static_cast<std::size_t>(row_end - row_begin));
  tbb::parallel_for(tbb::blocked_range<int>(row_begin, row_end), [&](const tbb::blocked_range<int>& range) {
    for (int v = range.begin(); v < range.end(); ++v)
      for (int u = 0; u < W; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * W + u;
        const float d = disparity.left[i];
        if (std::isnan(d) || !pair.left_mask[i]) continue;
        // The right pixel must come from the right image too (both neighbours of a sub-pixel position).
        const double ur = u - d;
        const int r0 = static_cast<int>(std::floor(ur)), r1 = r0 + 1;
        if (r0 < 0 || r1 >= W) continue;
        const std::size_t row = static_cast<std::size_t>(v) * W;
        if (!pair.right_mask[row + r0] || !pair.right_mask[row + r1]) continue;
        Vec3 X;
        if (triangulate(pair, u, v, d, X)) rows[v - row_begin].push_back(X);
      }
  });
  std::vector<Vec3> points;
  for (auto& r : rows) points.insert(points.end(), r.begin(), r.end());
  return points;
}

}  // namespace dsmplan
