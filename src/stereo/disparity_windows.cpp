// A disparity search too wide for one SGM pass, split into windows and merged.
//
// Each window is an ordinary Semi-Global Matching search (H. Hirschmüller, "Stereo Processing by
// Semiglobal Matching and Mutual Information", IEEE PAMI 30(2):328-341, 2008; sgm_match.cpp)
// over a part of the pair's disparities, so memory and the per-pass cost stay those of one
// window. The split and the merge are dsmplan's own rule, not the paper's: the windows' cores
// tile the range; each window searches kWindowMargin disparities beyond its core on either side
// and answers only for disparities inside its core. A pixel whose true disparity lies outside a
// window's search tends to land on that search's edge, which lies in the margin and is dropped;
// a pixel two windows both answer for (inside both cores: one of them is wrong) is dropped too.
#include <algorithm>
#include <cmath>
#include <limits>

#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {

std::vector<DisparityWindow> disparity_windows(int num_disparities, int budget) {
  if (num_disparities < 1) throw ArgumentError("num_disparities", "must be at least 1");
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  if (num_disparities <= budget) return {{0, num_disparities, -kInfinity, kInfinity}};
  if (budget < 4 * kWindowMargin)
    throw ArgumentError("max_disparities",
                        "must be at least " + std::to_string(4 * kWindowMargin) + " to split a search into windows");
  const int count = (num_disparities + budget - 2 * kWindowMargin - 1) / (budget - 2 * kWindowMargin);
  const int core = (num_disparities + count - 1) / count;  // <= budget - 2 margins
  std::vector<DisparityWindow> windows;
  for (int k = 0; k < count; ++k) {
    const int begin = k * core, end = std::min(num_disparities, (k + 1) * core);
    if (begin >= end) break;
    DisparityWindow w;
    w.min_disparity = std::max(0, begin - kWindowMargin);
    w.num_disparities = std::min(num_disparities, end + kWindowMargin) - w.min_disparity;
    w.keep_begin = k == 0 ? -kInfinity : begin;  // the range's own ends are no window's edge
    w.keep_end = end == num_disparities ? kInfinity : end;
    windows.push_back(w);
  }
  return windows;
}

std::size_t merge_window(const std::vector<float>& window, const DisparityWindow& w, std::vector<float>& merged,
                         std::vector<unsigned char>& claimed) {
  if (merged.size() != window.size() || claimed.size() != window.size())
    throw ArgumentError("merged", "must have the window's size");
  std::size_t conflicts = 0;
  for (std::size_t i = 0; i < window.size(); ++i) {
    const float d = window[i];
    if (!(d >= w.keep_begin && d < w.keep_end)) continue;  // NaN, or outside the core
    if (claimed[i] == 0) {
      merged[i] = d;
      claimed[i] = 1;
    } else if (claimed[i] == 1) {
      merged[i] = std::numeric_limits<float>::quiet_NaN();
      claimed[i] = 2;
      ++conflicts;
    }
  }
  return conflicts;
}

}  // namespace dsmplan
