// The frame-camera pipeline of Adolf & Hirschmüller, Section 2 ("Meshing and Simplification of
// High Resolution Urban Surface Data for UAV Path Planning"): for every selected pair,
// epipolar rectification (rectify_pair.cpp: Fusiello, Trucco & Verri 2000), Semi-Global
// Matching (sgm_match.cpp: Hirschmüller 2008, with its left-right consistency check),
// triangulation (triangulate.cpp); then all pairs' points ortho-projected into the DSM grid
// with the median per cell (fuse_median.cpp). Pairs are processed one after the other (each
// match uses all threads), a pair in bands of rectified rows; only the pair's two images, one
// band and the fusion's budget are held.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "dsmplan/median_fusion.hpp"
#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {
namespace {
double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string size_problem(const GreyImage& image, const FrameCamera& camera) {
  if (image.width == camera.width && image.height == camera.height) return {};
  return "image is " + std::to_string(image.width) + " x " + std::to_string(image.height) + ", the camera says " +
         std::to_string(camera.width) + " x " + std::to_string(camera.height);
}
}  // namespace

FrameStereoStats stereo_dsm(const std::vector<FrameCamera>& cameras, const std::vector<GreyImage>& images,
                            const std::vector<std::pair<int, int>>& pairs, Grid& grid,
                            const FrameStereoOptions& options, const Progress& progress) {
  if (cameras.size() != images.size()) throw ArgumentError("images", "one image per camera is needed");
  for (std::size_t i = 0; i < cameras.size(); ++i)
    if (const std::string problem = size_problem(images[i], cameras[i]); !problem.empty())
      throw InputError("", "camera " + std::to_string(i), problem);
  // The caller's images, lent (the deleter does nothing).
  const ImageSource lent = [&](int i) { return std::shared_ptr<const GreyImage>(&images[i], [](const GreyImage*) {}); };
  return stereo_dsm(cameras, lent, pairs, grid, options, progress);
}

FrameStereoStats stereo_dsm(const std::vector<FrameCamera>& cameras, const ImageSource& source,
                            const std::vector<std::pair<int, int>>& pairs, Grid& grid,
                            const FrameStereoOptions& options, const Progress& progress) {
  for (std::size_t i = 0; i < cameras.size(); ++i) check_camera(cameras[i], "camera " + std::to_string(i));
  if (pairs.empty()) throw InputError("", "cameras", "no pair of cameras to match");
  if (!(options.band_rows == 0 || options.band_rows >= 16))
    throw ArgumentError("band_rows", "must be 0 or at least 16");
  if (!(options.band_bytes >= (std::size_t{1} << 20))) throw ArgumentError("band_bytes", "must be at least 1 MiB");
  if (!(options.band_margin >= 0)) throw ArgumentError("band_margin", "must be >= 0");
  FrameStereoStats stats;
  MedianFusion fusion(grid, options.fusion);
  SgmMatcher matcher;
  bool matcher_made = false;
  std::vector<std::pair<int, std::shared_ptr<const GreyImage>>> held;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const int a = pairs[k].first, b = pairs[k].second;  // not a structured binding: lambdas take these (clang 14)
    if (a < 0 || b < 0 || a >= static_cast<int>(cameras.size()) || b >= static_cast<int>(cameras.size()) || a == b)
      throw ArgumentError("pairs", "pair " + std::to_string(a) + "-" + std::to_string(b) + " is not two cameras");
    FramePairStats& pair_stats = stats.pair_stats.emplace_back();
    pair_stats.left = a, pair_stats.right = b;
    // The geometry first (O(1)): a pair that cannot be rectified is left out before its images are read.
    auto start = std::chrono::steady_clock::now();
    pair_stats.problem = pair_problem(cameras[a], cameras[b], options.rectify);
    if (!pair_stats.problem.empty()) {
      report(progress, 0.95 * (k + 1) / pairs.size());
      continue;
    }
    const RectifiedPair geometry = rectify_cameras(cameras[a], cameras[b], options.rectify);
    stats.seconds_rectify += seconds_since(start);
    // The pair's two images: kept from the previous pair when it shares them, read otherwise.
    std::erase_if(held, [&](const auto& entry) { return entry.first != a && entry.first != b; });
    const auto image = [&](int i) -> const GreyImage& {
      for (const auto& [camera, held_image] : held)
        if (camera == i) return *held_image;
      std::shared_ptr<const GreyImage> loaded = source(i);
      if (!loaded) throw ArgumentError("images", "no image for camera " + std::to_string(i));
      if (const std::string problem = size_problem(*loaded, cameras[i]); !problem.empty())
        throw InputError("", "camera " + std::to_string(i), problem);
      held.emplace_back(i, std::move(loaded));
      return *held.back().second;
    };
    const GreyImage &image_a = image(a), &image_b = image(b);
    const std::vector<DisparityWindow> windows =
        disparity_windows(geometry.num_disparities, options.rectify.max_disparities);
    int widest = 0;
    for (const DisparityWindow& w : windows) widest = std::max(widest, w.num_disparities);
    pair_stats.used = true;
    pair_stats.shift = geometry.shift;
    pair_stats.num_disparities = geometry.num_disparities;
    pair_stats.windows = static_cast<int>(windows.size());
    const double margin_m = 0.1 * (options.rectify.max_height - options.rectify.min_height);

    // Band by band: rows [row, row + band_rows) of the rectified pair, matched with band_margin
    // rows more on each side (cut at the images' edges) and their disparities dropped.
    const int H = geometry.left.height;
    const double row_bytes = double(geometry.left.width) * (2.0 * widest + 24);
    const double fits = double(options.band_bytes) / row_bytes;  // rows, margins included
    const int wanted = options.band_rows > 0 ? options.band_rows
                       : fits >= H           ? H
                                             : std::max(64, static_cast<int>(fits) - 2 * options.band_margin);
    const int band = std::min(H, wanted);
    const int margin = band == H ? 0 : options.band_margin;
    for (int row = 0; row < H; row += band) {
      const int top = std::max(0, row - margin), bottom = std::min(H, row + band + margin);
      start = std::chrono::steady_clock::now();
      const RectifiedPair pair = rectify_rows(geometry, cameras[a], image_a, cameras[b], image_b, top, bottom - top);
      stats.seconds_rectify += seconds_since(start);

      start = std::chrono::steady_clock::now();
      const std::vector<std::uint16_t> left = to_uint16(pair.left_image), right = to_uint16(pair.right_image);
      const ImageView left_view(left.data(), pair.left.width, pair.left.height),
          right_view(right.data(), pair.right.width, pair.right.height);
      Disparity disparity;
      std::vector<unsigned char> claimed;
      for (const DisparityWindow& w : windows) {
        SgmOptions sgm = options.sgm;
        sgm.min_disparity = w.min_disparity;
        sgm.num_disparities = w.num_disparities;
        Disparity found;
        if (options.matcher) {
          found = options.matcher(left_view, right_view, sgm);
          if (found.width != pair.left.width || found.height != pair.left.height ||
              found.left.size() != static_cast<std::size_t>(pair.left.width) * pair.left.height)
            throw ArgumentError("matcher", "returned a disparity image of another size than the rectified pair's");
        } else {
          // Made anew for another range (and once at first: options.sgm's other fields are the caller's).
          if (!matcher_made || !(matcher.options().num_disparities == sgm.num_disparities &&
                                 matcher.options().min_disparity == sgm.min_disparity))
            matcher = SgmMatcher(sgm), matcher_made = true;
          found = matcher.match(left_view, right_view);
        }
        if (windows.size() == 1) {
          disparity = std::move(found);
          break;
        }
        if (disparity.left.empty()) {
          disparity.width = found.width, disparity.height = found.height;
          disparity.left.assign(found.left.size(), std::numeric_limits<float>::quiet_NaN());
          claimed.assign(found.left.size(), 0);
        }
        pair_stats.window_conflicts += merge_window(found.left, w, disparity.left, claimed);
      }
      stats.seconds_match += seconds_since(start);
      const int core0 = row - top, core1 = std::min(row + band, H) - top;  // the band's own rows
      for (std::size_t i = static_cast<std::size_t>(core0) * disparity.width;
           i < static_cast<std::size_t>(core1) * disparity.width; ++i) {
        pair_stats.matched_pixels += !std::isnan(disparity.left[i]);
        pair_stats.pixels += pair.left_mask[i] != 0;
      }

      // Triangulated and fused 256 rows at a time: a pair's points are never all held (24
      // bytes a pixel against the disparity's 4).
      constexpr int kRows = 256;
      for (int r = core0; r < core1; r += kRows) {
        start = std::chrono::steady_clock::now();
        std::vector<Vec3> set = triangulate(pair, disparity, r, std::min(r + kRows, core1));
        // The scene lies within the height range: a point more than 10 % of the range outside it
        // (the disparity search reaches about that far beyond, rectify_pair) is a mismatch. The
        // margin keeps the noise of points on the lowest (or highest) surface.
        const std::size_t before = set.size();
        std::erase_if(set, [&](const Vec3& p) {
          return !(p[2] >= options.rectify.min_height - margin_m && p[2] <= options.rectify.max_height + margin_m);
        });
        stats.points_outside_range += before - set.size();
        pair_stats.points += set.size();
        stats.seconds_triangulate += seconds_since(start);
        start = std::chrono::steady_clock::now();
        fusion.add(set);
        stats.seconds_fuse += seconds_since(start);
      }
      ++stats.bands;
    }
    stats.matched_pixels += pair_stats.matched_pixels;
    stats.points += pair_stats.points;
    ++stats.pairs;
    report(progress, 0.95 * (k + 1) / pairs.size());
  }
  if (stats.pairs == 0) {
    std::string problems;
    for (const FramePairStats& p : stats.pair_stats)
      problems += (problems.empty() ? "" : "; ") +
                  ("cameras " + std::to_string(p.left) + " and " + std::to_string(p.right) + ": " + p.problem);
    throw InputError("", "cameras", "no pair left to match (" + problems + ")");
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
