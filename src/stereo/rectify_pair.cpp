// Epipolar rectification of a calibrated pair and bilinear resampling of both images.
//
// Method: A. Fusiello, E. Trucco and A. Verri, "A compact algorithm for rectification of stereo
// pairs", Machine Vision and Applications 12(1):16-22, 2000. Both rectified cameras keep their
// centres and get one orientation: x along the baseline C_right - C_left, y = z_left_old × x
// (so the left camera's old viewing direction stays in the rectified y-z plane), z = x × y;
// one focal length f (the mean of the four) and one row centre cy, so corresponding points lie
// in the same row. Unlike the paper's 3x4 matrices, the mapping here goes through rays, so the
// original cameras' lens distortion is removed in the same resampling step.
// The column centres differ by `shift` so that the depth range of the scene (from the height
// range) maps to disparities [0, D) (see dsmplan/stereo_frames.hpp).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {
namespace {

Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec3& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
Vec3 scaled(const Vec3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
Vec3 times(const Mat3& m, const Vec3& a) {
  return {m[0][0] * a[0] + m[0][1] * a[1] + m[0][2] * a[2], m[1][0] * a[0] + m[1][1] * a[1] + m[1][2] * a[2],
          m[2][0] * a[0] + m[2][1] * a[1] + m[2][2] * a[2]};
}

// The rectified camera's image of `original`, resampled bilinearly through the rays.
void resample(const FrameCamera& original, const GreyImage& image, const FrameCamera& rectified, GreyImage& out,
              std::vector<unsigned char>& mask) {
  out.width = rectified.width;
  out.height = rectified.height;
  out.pixels.assign(static_cast<std::size_t>(out.width) * out.height, 0.0f);
  mask.assign(out.pixels.size(), 0);
  // Camera-to-camera rotation: original R times rectified R^T.
  Mat3 M{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) M[i][j] += original.rotation[i][k] * rectified.rotation[j][k];
  const bool distorted = original.distorted();
  tbb::parallel_for(tbb::blocked_range<int>(0, out.height), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v)
      for (int u = 0; u < out.width; ++u) {
        const Vec3 ray{(u - rectified.cx) / rectified.fx, (v - rectified.cy) / rectified.fy, 1.0};
        const Vec3 p = times(M, ray);
        if (!(p[2] > 0)) continue;
        double x = p[0] / p[2], y = p[1] / p[2];
        if (distorted) {
          const auto xy = distort(original, x, y);
          x = xy[0];
          y = xy[1];
        }
        float value;
        const std::size_t i = static_cast<std::size_t>(v) * out.width + u;
        if (image.sample(original.fx * x + original.cx, original.fy * y + original.cy, value)) {
          out.pixels[i] = value;
          mask[i] = 1;
        }
      }
  });
}

}  // namespace

RectifiedPair rectify_cameras(const FrameCamera& left, const FrameCamera& right, const RectifyOptions& options) {
  check_camera(left, "left camera");
  check_camera(right, "right camera");
  const bool unbounded = options.unbounded_depth_disparities > 0;
  if (!unbounded && !(std::isfinite(options.min_height) && std::isfinite(options.max_height) &&
                      options.min_height <= options.max_height))
    throw ArgumentError("height range", "must be finite, min <= max");
  if (!(options.max_size_factor >= 1)) throw ArgumentError("max_size_factor", "must be >= 1");

  RectifiedPair pair;
  const Vec3 base{right.center[0] - left.center[0], right.center[1] - left.center[1], right.center[2] - left.center[2]};
  pair.baseline = norm(base);
  if (!(pair.baseline > 1e-9)) throw InputError("", "cameras", "the two cameras have the same centre: no baseline");
  const Vec3 x_axis = scaled(base, 1 / pair.baseline);
  const Vec3 old_z = left.rotation[2];
  Vec3 y_axis = cross(old_z, x_axis);
  const double ny = norm(y_axis);
  if (!(ny > 1e-6)) throw InputError("", "cameras", "the baseline is along the left camera's viewing direction");
  y_axis = scaled(y_axis, 1 / ny);
  const Vec3 z_axis = cross(x_axis, y_axis);
  const Mat3 R{x_axis, y_axis, z_axis};
  const double f = (left.fx + left.fy + right.fx + right.fy) / 4;

  // The rectified frame's view of both images' borders: 16 points per side.
  const auto border = [&](const FrameCamera& c, double& x0, double& x1, double& y0, double& y1) {
    x0 = y0 = std::numeric_limits<double>::infinity();
    x1 = y1 = -x0;
    for (int side = 0; side < 4; ++side)
      for (int k = 0; k <= 16; ++k) {
        const double t = k / 16.0;
        const double u = side < 2 ? t * (c.width - 1) : (side == 2 ? 0 : c.width - 1);
        const double v = side < 2 ? (side == 0 ? 0 : c.height - 1) : t * (c.height - 1);
        const Vec3 p = times(R, pixel_ray(c, u, v));
        if (!(p[2] > 1e-6)) continue;
        x0 = std::min(x0, f * p[0] / p[2]);
        x1 = std::max(x1, f * p[0] / p[2]);
        y0 = std::min(y0, f * p[1] / p[2]);
        y1 = std::max(y1, f * p[1] / p[2]);
      }
  };
  double lx0, lx1, ly0, ly1, rx0, rx1, ry0, ry1;
  border(left, lx0, lx1, ly0, ly1);
  border(right, rx0, rx1, ry0, ry1);
  if (!(lx0 < lx1 && rx0 < rx1)) throw InputError("", "cameras", "the rectified views hold no part of the images");
  const double cap = options.max_size_factor * std::max({left.width, left.height, right.width, right.height});
  // Rows: the union of both images' rows (points outside one of them cannot be matched anyway,
  // but the union keeps the rows the same for both); columns: the left image's.
  double top = std::min(ly0, ry0), bottom = std::max(ly1, ry1);
  const auto clamp_span = [cap](double& a, double& b, double centre) {
    if (b - a + 1 > cap) {
      a = std::max(a, centre - cap / 2);
      b = std::min(b, a + cap - 1);
      a = std::max(a, b - cap + 1);
    }
  };
  const Vec3 left_axis = times(R, left.rotation[2]);
  clamp_span(lx0, lx1, f * left_axis[0] / left_axis[2]);
  clamp_span(top, bottom, f * left_axis[1] / left_axis[2]);

  // Depths of the scene in the rectified frame: rays through a 9 x 9 lattice of left pixels cut
  // with the planes of the lowest and highest heights (unless the search is unbounded in depth).
  double depth_min = std::numeric_limits<double>::infinity(), depth_max = 0;
  for (int i = 0; i <= 8; ++i)
    for (int j = 0; j <= 8; ++j) {
      const Vec3 ray = pixel_ray(left, i / 8.0 * (left.width - 1), j / 8.0 * (left.height - 1));
      for (double Z : {options.min_height, options.max_height}) {
        if (unbounded) break;
        if (std::abs(ray[2]) < 1e-12) continue;
        const double t = (Z - left.center[2]) / ray[2];
        if (!(t > 0)) continue;
        const double depth = t * (z_axis[0] * ray[0] + z_axis[1] * ray[1] + z_axis[2] * ray[2]);
        if (!(depth > 0)) continue;
        depth_min = std::min(depth_min, depth);
        depth_max = std::max(depth_max, depth);
      }
    }
  if (!unbounded && !(depth_max > 0 && std::isfinite(depth_min)))
    throw InputError("", "cameras", "the left camera does not look at the height range");
  if (!unbounded) {
    depth_min *= 0.9;
    depth_max *= 1.1;
    pair.shift = f * pair.baseline / depth_max;
    const double span = f * pair.baseline / depth_min - pair.shift;
    pair.num_disparities = (static_cast<int>(std::ceil(span)) + 1 + 15) / 16 * 16;
  }

  FrameCamera rect;
  rect.fx = rect.fy = f;
  rect.rotation = R;
  rect.width = static_cast<int>(std::ceil(lx1 - lx0)) + 1;
  rect.height = static_cast<int>(std::ceil(bottom - top)) + 1;
  rect.cx = -lx0;
  rect.cy = -top;
  pair.left = rect;
  pair.left.center = left.center;
  pair.right = rect;
  pair.right.center = right.center;
  if (unbounded) {  // every depth from f·B/D on: shift 0 (infinity), D as wide as the image allows
    pair.shift = 0;
    pair.num_disparities = std::min(options.unbounded_depth_disparities, rect.width - 1) / 16 * 16;
    if (pair.num_disparities < 16)
      throw InputError(
          "", "cameras",
          "the rectified images are too narrow (" + std::to_string(rect.width) + " px) for a search of 16 disparities");
  }
  pair.right.cx = rect.cx + pair.shift;
  // The search may be split into max_windows windows of max_disparities (disparity_windows()),
  // but never wider than the image: no column could then be matched over the whole range.
  const long budget = static_cast<long>(options.max_disparities) * std::max(1, options.max_windows);
  if (pair.num_disparities > budget || pair.num_disparities >= rect.width) {
    std::string limit = std::to_string(std::min<long>(budget, rect.width - 1));
    if (options.max_windows > 1 && budget < rect.width)
      limit +=
          " (" + std::to_string(options.max_windows) + " windows of " + std::to_string(options.max_disparities) + ")";
    throw InputError("", "cameras",
                     "the height range needs " + std::to_string(pair.num_disparities) + " disparities, more than " +
                         limit + ": narrow the height range");
  }
  return pair;
}

std::string pair_problem(const FrameCamera& left, const FrameCamera& right, const RectifyOptions& options) {
  try {
    rectify_cameras(left, right, options);
    return {};
  } catch (const InputError& error) {
    std::string problem = error.what();  // "cameras: ..."
    if (problem.rfind("cameras: ", 0) == 0) problem = problem.substr(9);
    return problem;
  }
}

RectifiedPair rectify_rows(const RectifiedPair& cameras, const FrameCamera& left, const GreyImage& left_image,
                           const FrameCamera& right, const GreyImage& right_image, int row0, int rows) {
  if (left_image.width != left.width || left_image.height != left.height)
    throw ArgumentError("left image", "size differs from the camera's");
  if (right_image.width != right.width || right_image.height != right.height)
    throw ArgumentError("right image", "size differs from the camera's");
  if (!(row0 >= 0 && rows > 0 && row0 + rows <= cameras.left.height))
    throw ArgumentError("rows", "must lie within the rectified images' " + std::to_string(cameras.left.height));
  RectifiedPair band = cameras;
  // The band is the rectified camera moved up by row0 rows: same rays, fewer of them.
  for (FrameCamera* c : {&band.left, &band.right}) {
    c->cy -= row0;
    c->height = rows;
  }
  resample(left, left_image, band.left, band.left_image, band.left_mask);
  resample(right, right_image, band.right, band.right_image, band.right_mask);
  return band;
}

RectifiedPair rectify_pair(const FrameCamera& left, const GreyImage& left_image, const FrameCamera& right,
                           const GreyImage& right_image, const RectifyOptions& options) {
  const RectifiedPair cameras = rectify_cameras(left, right, options);
  return rectify_rows(cameras, left, left_image, right, right_image, 0, cameras.left.height);
}

std::vector<std::uint16_t> to_uint16(const GreyImage& image) {
  std::vector<std::uint16_t> out(image.pixels.size());
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = static_cast<std::uint16_t>(std::clamp(std::lround(image.pixels[i]), 0L, 65535L));
  return out;
}

}  // namespace dsmplan
