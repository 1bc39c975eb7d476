// OpenCV's StereoSGBM (Debian's libopencv-dev, 4.6) as a dsmplan::DenseMatcher, so that it runs
// inside dsmplan's pipelines (same rectification, triangulation and fusion; only the matcher
// differs): bench_stereo's tables. Settings as tuned on Aloe in bench_sgm (bench/README.md, "SGM"):
// uniquenessRatio 10, disp12MaxDiff 1, preFilterCap 63, speckleWindowSize 100, speckleRange 1.
#pragma once
#ifdef DSMPLAN_HAVE_OPENCV

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "dsmplan/stereo_frames.hpp"

namespace bench {

struct SgbmSetting {
  int mode, block_size, p1, p2;
};
/// bench_sgm's choices on Aloe (the fewest pixels off by more than 1 px for each mode).
inline constexpr SgbmSetting sgbm_hh{cv::StereoSGBM::MODE_HH, 3, 144, 576};
inline constexpr SgbmSetting sgbm_3way{cv::StereoSGBM::MODE_SGBM_3WAY, 5, 200, 800};

/// The matcher: images as 8-bit (16-bit ones scaled by 255 / their largest value), the pair's
/// disparity range, OpenCV's fixed-point result as float pixels, NaN where it found none. One
/// StereoSGBM object, kept between calls (as dsmplan's SgmMatcher keeps its buffer).
inline dsmplan::DenseMatcher sgbm_matcher(const SgbmSetting& s) {
  auto sgbm = std::shared_ptr<cv::StereoSGBM>(
      cv::StereoSGBM::create(0, 16, s.block_size, s.p1, s.p2, 1, 63, 10, 100, 1, s.mode));
  return [sgbm](const dsmplan::ImageView& left, const dsmplan::ImageView& right, const dsmplan::SgmOptions& options) {
    const auto to8 = [](const dsmplan::ImageView& view) {
      unsigned top = 0;
      for (int y = 0; y < view.height; ++y)
        for (int x = 0; x < view.width; ++x) top = std::max(top, view.at(x, y));
      const double scale = top > 255 ? 255.0 / top : 1.0;
      cv::Mat out(view.height, view.width, CV_8UC1);
      for (int y = 0; y < view.height; ++y)
        for (int x = 0; x < view.width; ++x)
          out.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(std::lround(scale * view.at(x, y)));
      return out;
    };
    sgbm->setMinDisparity(options.min_disparity);
    sgbm->setNumDisparities(options.num_disparities);
    cv::Mat fixed;
    sgbm->compute(to8(left), to8(right), fixed);  // CV_16S, 16 x disparity, (minDisparity - 1) * 16 where invalid
    dsmplan::Disparity d;
    d.width = fixed.cols;
    d.height = fixed.rows;
    d.left.resize(static_cast<std::size_t>(d.width) * d.height);
    const int invalid = (options.min_disparity - 1) * 16;
    for (int y = 0; y < fixed.rows; ++y)
      for (int x = 0; x < fixed.cols; ++x) {
        const short v = fixed.at<short>(y, x);
        d.left[static_cast<std::size_t>(y) * d.width + x] = v <= invalid ? NAN : v / 16.0f;
      }
    return d;
  };
}

}  // namespace bench

#endif
