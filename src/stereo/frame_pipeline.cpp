// The frame-camera pipeline of Adolf & Hirschmüller, Section 2 ("Meshing and Simplification of
// High Resolution Urban Surface Data for UAV Path Planning"): for every selected pair,
// epipolar rectification (rectify_pair.cpp: Fusiello, Trucco & Verri 2000), Semi-Global
// Matching (sgm_match.cpp: Hirschmüller 2008, with its left-right consistency check),
// triangulation (triangulate.cpp); then all pairs' points ortho-projected into the DSM grid
// with the median per cell (fuse_median.cpp). Pairs are processed one after the other (each
// match uses all threads); only the points of earlier pairs are kept between pairs.
#include <chrono>
#include <cmath>
#include <string>

#include "dsmplan/median_fusion.hpp"
#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {
namespace {
double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

FrameStereoStats stereo_dsm(const std::vector<FrameCamera>& cameras, const std::vector<GreyImage>& images,
                            const std::vector<std::pair<int, int>>& pairs, Grid& grid,
                            const FrameStereoOptions& options, const Progress& progress) {
  if (cameras.size() != images.size()) throw ArgumentError("images", "one image per camera is needed");
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const std::string name = "camera " + std::to_string(i);
    check_camera(cameras[i], name);
    if (images[i].width != cameras[i].width || images[i].height != cameras[i].height)
      throw InputError("", name,
                       "image is " + std::to_string(images[i].width) + " x " + std::to_string(images[i].height) +
                           ", the camera says " + std::to_string(cameras[i].width) + " x " +
                           std::to_string(cameras[i].height));
  }
  if (pairs.empty()) throw InputError("", "cameras", "no pair of cameras to match");
  FrameStereoStats stats;
  MedianFusion fusion(grid, options.fusion);
  SgmMatcher matcher;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto [a, b] = pairs[k];
    if (a < 0 || b < 0 || a >= static_cast<int>(cameras.size()) || b >= static_cast<int>(cameras.size()) || a == b)
      throw ArgumentError("pairs", "pair " + std::to_string(a) + "-" + std::to_string(b) + " is not two cameras");
    auto start = std::chrono::steady_clock::now();
    RectifiedPair pair;
    try {
      pair = rectify_pair(cameras[a], images[a], cameras[b], images[b], options.rectify);
    } catch (const InputError& error) {
      std::string problem = error.what();  // "cameras: ..." from rectify_pair
      if (problem.rfind("cameras: ", 0) == 0) problem = problem.substr(9);
      throw InputError("", "cameras " + std::to_string(a) + " and " + std::to_string(b), problem);
    }
    stats.seconds_rectify += seconds_since(start);

    start = std::chrono::steady_clock::now();
    const std::vector<std::uint16_t> left = to_uint16(pair.left_image), right = to_uint16(pair.right_image);
    SgmOptions sgm = options.sgm;
    sgm.min_disparity = 0;
    sgm.num_disparities = pair.num_disparities;
    const ImageView left_view(left.data(), pair.left.width, pair.left.height),
        right_view(right.data(), pair.right.width, pair.right.height);
    Disparity disparity;
    if (options.matcher) {
      disparity = options.matcher(left_view, right_view, sgm);
      if (disparity.width != pair.left.width || disparity.height != pair.left.height ||
          disparity.left.size() != static_cast<std::size_t>(pair.left.width) * pair.left.height)
        throw ArgumentError("matcher", "returned a disparity image of another size than the rectified pair's");
    } else {
      if (!(matcher.options().num_disparities == sgm.num_disparities)) matcher = SgmMatcher(sgm);
      disparity = matcher.match(left_view, right_view);
    }
    stats.seconds_match += seconds_since(start);
    for (float d : disparity.left) stats.matched_pixels += !std::isnan(d);

    // Triangulated and fused a band of rows at a time: a pair's points are never all held (24
    // bytes a pixel against the disparity's 4).
    constexpr int kBand = 256;
    for (int row = 0; row < disparity.height; row += kBand) {
      start = std::chrono::steady_clock::now();
      std::vector<Vec3> set = triangulate(pair, disparity, row, row + kBand);
      // The scene lies within the height range: a point more than 10 % of the range outside it
      // (the disparity search reaches about that far beyond, rectify_pair) is a mismatch. The
      // margin keeps the noise of points on the lowest (or highest) surface.
      const std::size_t before = set.size();
      const double margin = 0.1 * (options.rectify.max_height - options.rectify.min_height);
      std::erase_if(set, [&](const Vec3& p) {
        return !(p[2] >= options.rectify.min_height - margin && p[2] <= options.rectify.max_height + margin);
      });
      stats.points_outside_range += before - set.size();
      stats.points += set.size();
      stats.seconds_triangulate += seconds_since(start);
      start = std::chrono::steady_clock::now();
      fusion.add(set);
      stats.seconds_fuse += seconds_since(start);
    }
    ++stats.pairs;
    report(progress, 0.95 * (k + 1) / pairs.size());
  }
  const auto start = std::chrono::steady_clock::now();
  stats.points_in_grid = fusion.finish(grid);
  stats.fusion_runs_spilled = fusion.runs_spilled();
  for (float z : grid.z) stats.valid_cells += !std::isnan(z);
  stats.seconds_fuse += seconds_since(start);
  report(progress, 1.0);
  return stats;
}

}  // namespace dsmplan
