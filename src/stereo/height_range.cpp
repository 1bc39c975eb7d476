// The scene's height range from the images alone, for `dsmplan stereo` when CAMERAS.json gives
// none: a coarse-to-fine start as in hierarchical SGM (H. Hirschmüller, "Stereo Processing by
// Semiglobal Matching and Mutual Information", IEEE PAMI 30(2), 2008, sec. 3.1: a first match at
// a reduced resolution bounds the search at the full one). Each pair of nearest cameras is shrunk
// by a whole factor (box filter, so a coarse pixel is the mean of s x s pixels and the cameras'
// focal lengths and centres scale with it), rectified with a search over every depth from f·B/D
// to infinity (no height needed), matched by SGM with its left-right check, and triangulated;
// robust quantiles of the points' heights, widened by margins, give the range.
#include <algorithm>
#include <cmath>
#include <limits>

#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {
namespace {

// The camera of the image shrunk by `s`: coarse pixel i covers pixels s·i .. s·i + s - 1, its
// centre is at s·i + (s - 1)/2, so u_coarse = (u - (s - 1)/2) / s.
FrameCamera shrunk(const FrameCamera& c, int s) {
  FrameCamera out = c;
  out.width = c.width / s;
  out.height = c.height / s;
  out.fx = c.fx / s;
  out.fy = c.fy / s;
  out.cx = (c.cx - (s - 1) / 2.0) / s;
  out.cy = (c.cy - (s - 1) / 2.0) / s;
  return out;
}

GreyImage shrunk(const GreyImage& image, int s) {
  GreyImage out;
  out.width = image.width / s;
  out.height = image.height / s;
  out.pixels.assign(static_cast<std::size_t>(out.width) * out.height, 0.0f);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      double sum = 0;
      for (int dy = 0; dy < s; ++dy)
        for (int dx = 0; dx < s; ++dx) sum += image.at(s * x + dx, s * y + dy);
      out.pixels[static_cast<std::size_t>(y) * out.width + x] = static_cast<float>(sum / (s * s));
    }
  return out;
}

double quantile(std::vector<double>& values, double q) {
  const std::size_t k = std::min(values.size() - 1, static_cast<std::size_t>(q * (values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

std::vector<std::pair<int, int>> height_range_pairs(const std::vector<FrameCamera>& cameras, int max_pairs) {
  const int n = static_cast<int>(cameras.size());
  std::vector<std::pair<double, std::pair<int, int>>> nearest;
  for (int i = 0; i < n; ++i) {
    int best = -1;
    double best_distance = std::numeric_limits<double>::infinity();
    for (int j = 0; j < n; ++j) {
      if (j == i) continue;
      double d2 = 0;
      for (int k = 0; k < 3; ++k)
        d2 += (cameras[i].center[k] - cameras[j].center[k]) * (cameras[i].center[k] - cameras[j].center[k]);
      if (d2 > 0 && d2 < best_distance) best_distance = d2, best = j;
    }
    if (best >= 0) nearest.push_back({best_distance, {std::min(i, best), std::max(i, best)}});
  }
  std::sort(nearest.begin(), nearest.end());
  std::vector<std::pair<int, int>> pairs;
  for (const auto& [distance, pair] : nearest)
    if (std::find(pairs.begin(), pairs.end(), pair) == pairs.end() && static_cast<int>(pairs.size()) < max_pairs)
      pairs.push_back(pair);
  return pairs;
}

HeightRangeEstimate estimate_height_range(const std::vector<FrameCamera>& cameras, const std::vector<GreyImage>& images,
                                          const std::vector<std::pair<int, int>>& pairs,
                                          const HeightRangeOptions& options) {
  if (!(options.coarse_side >= 32 && options.max_disparities >= 16 && options.low_quantile >= 0 &&
        options.low_quantile < options.high_quantile && options.high_quantile <= 1 && options.margin_share >= 0 &&
        options.coarse_steps >= 0))
    throw ArgumentError("height range options", "out of range");
  HeightRangeEstimate out;
  std::vector<double> heights;
  for (const auto& [a, b] : pairs) {
    const FrameCamera &ca = cameras.at(a), &cb = cameras.at(b);
    if (images.at(a).width != ca.width || images.at(a).height != ca.height || images.at(b).width != cb.width ||
        images.at(b).height != cb.height)
      throw ArgumentError("images", "camera " + std::to_string(images.at(a).width != ca.width ? a : b) +
                                        ": image missing or of another size than the camera's");
    const int longest = std::max({ca.width, ca.height, cb.width, cb.height});
    const int s = std::max(1, (longest + options.coarse_side - 1) / options.coarse_side);
    const FrameCamera left = shrunk(ca, s), right = shrunk(cb, s);
    if (left.width < 32 || left.height < 32 || right.width < 32 || right.height < 32) continue;
    RectifyOptions rectify;
    rectify.unbounded_depth_disparities = options.max_disparities;
    RectifiedPair pair;
    try {
      pair = rectify_pair(left, s > 1 ? shrunk(images[a], s) : images[a], right,
                          s > 1 ? shrunk(images[b], s) : images[b], rectify);
    } catch (const InputError&) {
      continue;  // no baseline, or images too narrow: another pair may do
    }
    SgmOptions sgm;
    sgm.num_disparities = pair.num_disparities;
    const std::vector<std::uint16_t> l = to_uint16(pair.left_image), r = to_uint16(pair.right_image);
    const Disparity disparity = sgm_match(ImageView(l.data(), pair.left.width, pair.left.height),
                                          ImageView(r.data(), pair.right.width, pair.right.height), sgm);
    const std::vector<Vec3> points = triangulate(pair, disparity);
    if (points.empty()) continue;
    // The precision of this pass: the depth change of one disparity step at the median depth,
    // z² / (f·B) (d = f·B/z, shift 0).
    std::vector<double> d;
    for (float v : disparity.left)
      if (v > 0) d.push_back(v);
    if (!d.empty()) {
      const double z = pair.left.fx * pair.baseline / quantile(d, 0.5);
      out.coarse_step = std::max(out.coarse_step, z * z / (pair.left.fx * pair.baseline));
    }
    for (const Vec3& p : points) heights.push_back(p[2]);
    out.pairs.emplace_back(a, b);
    out.scale = std::max(out.scale, s);
  }
  if (heights.size() < 100)
    throw InputError("", "cameras",
                     "no pair of nearest cameras matched at a coarse scale (" + std::to_string(heights.size()) +
                         " points): the scene's height range cannot be estimated");
  // The scene: the heights connected to the median with no gap wider than `gap` (a quarter of
  // the cameras' height over the median, at least 10 coarse steps: a tower's roof seen without
  // its walls is kept, a clump of mismatches hundreds of metres off is not), then their quantiles.
  std::sort(heights.begin(), heights.end());
  const std::size_t middle = heights.size() / 2;
  double camera_height = 0;
  for (const auto& [a, b] : out.pairs) camera_height += (cameras[a].center[2] + cameras[b].center[2]) / 2;
  camera_height /= static_cast<double>(out.pairs.size());
  const double gap = std::max(10 * out.coarse_step, 0.25 * (camera_height - heights[middle]));
  std::size_t first = middle, last = middle;
  while (first > 0 && heights[first] - heights[first - 1] <= gap) --first;
  while (last + 1 < heights.size() && heights[last + 1] - heights[last] <= gap) ++last;
  std::vector<double> scene(heights.begin() + static_cast<std::ptrdiff_t>(first),
                            heights.begin() + static_cast<std::ptrdiff_t>(last) + 1);
  out.points = scene.size();
  out.low = quantile(scene, options.low_quantile);
  out.high = quantile(scene, options.high_quantile);
  const double margin = options.margin_share * (out.high - out.low) + options.coarse_steps * out.coarse_step;
  out.min_height = out.low - margin;
  out.max_height = out.high + margin;
  return out;
}

}  // namespace dsmplan
