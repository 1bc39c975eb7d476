// The scene's height range from the images alone, for `dsmplan stereo` when CAMERAS.json gives
// none: coarse to fine as in hierarchical SGM (H. Hirschmüller, "Stereo Processing by
// Semiglobal Matching and Mutual Information", IEEE PAMI 30(2), 2008, sec. 3.1: a first match at
// a reduced resolution bounds the search at a finer one), pair by pair over every camera's
// nearest partner (every part of a block is seen, not only its first few pairs: on the 100-view
// block the old 8 nearest pairs missed the 167.7 m top).
//
// Pass 1 shrinks both images by a whole factor (box filter, so a coarse pixel is the mean of
// s x s pixels and the cameras' focal lengths and centres scale with it) to about 320 px,
// rectifies with a search over every depth from f·B/D to infinity (no height needed), matches by
// SGM with its left-right check and triangulates. Its heights connected to their median (no gap
// wider than a quarter of the flying height) bound pass 2, which matches the pair again at about
// 640 px, both ways (each camera left once), searching only that bound (widened by 2 coarse
// steps and 10 %): few disparities, so it costs about what pass 1 does, for half its step.
//
// Mismatches are the whole difficulty: one clump 100 m off makes the range useless (the issue's
// 100-246 m for a 122-149 m strip). Three rules, each measured on the rendered blocks of
// tests/stereo_height_range_test.cpp:
//  - a disparity within a pixel of the search's ends is dropped: where matching fails, SGM's
//    paths pile up there (the far end: heights at the bound's bottom, 10-40 m under the ground);
//  - in pass 2, a pixel is kept only when its whole search, census window included, lies inside
//    both images: a pixel whose true match is out of frame gets another inside, and the
//    left-right check passes it as often as not (a band of too-low heights along the image's
//    edge, the largest source of error before this rule: -47 m on the Delft 2-view B/H 0.8 block);
//    running pass 2 both ways gives back each way's lost band;
//  - the points binned in cells of 3 x 3 pass-2 pixels, each cell with 4 points or more counted
//    by its median (robust to fewer than half its points wrong: the breakdown point of the
//    median, P. J. Rousseeuw and A. M. Leroy, "Robust Regression and Outlier Detection", Wiley
//    1987, ch. 1). The cells' heights connected to the median cell (steps up to 3 pass-2
//    disparity steps + 1 m) are the scene; a cluster of heights apart from them counts only if
//    both ways matched it (a tower's roof is found both ways; the clumps that survive are, on
//    those blocks, found one way only); the lowest (highest) height 3 cells share to within a
//    step ends the pair's range.
// Each pair's ends, then the lowest and highest over all pairs, widened by 10 % of their
// difference: what matching misses (a 2-cell chimney 5 m over its roof, a shaded pit).
// Not quantiles: a quantile drops the one tower whose roof is the scene's top.
//
// Why one margin share, not a margin per pair from its own disparity step (measured on the 14
// rendered blocks): where the estimate misses, it is not by a step's imprecision but by what no
// matched pair sees. NrwPairBh02Nadir's one pair, the coarsest step there (3.3 m), finds its
// heights to 0.1 m and leaves 1 m of the allowed width, so any term of more than 0.15 steps a side
// breaks it; the blocks that miss (tests/stereo_height_range_test.cpp, `shortfall`) miss cells only
// views that are no camera's nearest partner see together (views 4 and 7, 2 and 7 of two strips
// of 4 with 15 degree tilts), or that their pair cannot match (a steep roof at an image's edge).
// Matching every pair does not reach them (the far pairs' mismatches lie kilometres off), and the
// share of the seen area the pairs measure does not tell those blocks from ones that hold (0.59
// where the bottom is missed by 7 m, 0.60 where 7 m of margin would break the width).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>

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

namespace {

// One pair matched at shrink factor s: its points and the height of one disparity step at the
// pair's median depth, z² / (f·B) (d = f·B/z - shift), the pass's precision.
struct PairMatch {
  std::vector<Vec3> points;
  double step = 0;
  double pixel = 0;  // the ground size of one pixel at the median depth, z / f
  bool matched = false;
};

PairMatch match_pair(const FrameCamera& ca, const GreyImage& ia, const FrameCamera& cb, const GreyImage& ib, int s,
                     const RectifyOptions& rectify, int speckle_min_pixels, bool whole_search_inside) {
  PairMatch out;
  const FrameCamera left = shrunk(ca, s), right = shrunk(cb, s);
  if (left.width < 32 || left.height < 32 || right.width < 32 || right.height < 32) return out;
  RectifiedPair pair;
  try {
    pair = rectify_pair(left, s > 1 ? shrunk(ia, s) : ia, right, s > 1 ? shrunk(ib, s) : ib, rectify);
  } catch (const InputError&) {
    return out;  // no baseline, images too narrow, or too many disparities: the caller decides
  }
  SgmOptions sgm;
  sgm.num_disparities = pair.num_disparities;
  sgm.speckle_min_pixels = speckle_min_pixels;
  const std::vector<std::uint16_t> l = to_uint16(pair.left_image), r = to_uint16(pair.right_image);
  Disparity disparity = sgm_match(ImageView(l.data(), pair.left.width, pair.left.height),
                                  ImageView(r.data(), pair.right.width, pair.right.height), sgm);
  // A disparity within a pixel of the search's ends was stopped by the search, not measured:
  // where matching fails (shadow, occlusion) SGM's paths pile up there, and the pile is a
  // height at the bound's far or near end that no surface has.
  for (float& v : disparity.left)
    if (!(v >= 1 && v <= pair.num_disparities - 2)) v = NAN;
  // A left pixel whose search runs out of the right image (or whose census window leaves
  // either image) cannot tell its match from a wrong one when the true match is the part out of
  // frame: SGM then picks some disparity inside, and the left-right check passes it as often as
  // not. Along the images' borders that is a band of wrong, mostly too low, heights; only pixels
  // whose whole search (and window) lies inside both images are kept.
  if (whole_search_inside) {
    const int m = sgm.census_width / 2, w = pair.left.width, wr = pair.right.width;
    for (int v = 0; v < disparity.height; ++v)
      for (int u = 0; u < disparity.width; ++u) {
        float& d = disparity.left[static_cast<std::size_t>(v) * disparity.width + u];
        if (std::isnan(d)) continue;
        const auto inside = [&](const std::vector<unsigned char>& mask, int width, int x) {
          return x >= 0 && x < width && mask[static_cast<std::size_t>(v) * width + x] != 0;
        };
        if (!inside(pair.left_mask, w, u - m) || !inside(pair.left_mask, w, u + m) ||
            !inside(pair.right_mask, wr, u + m) || !inside(pair.right_mask, wr, u - (pair.num_disparities - 1) - m))
          d = NAN;
      }
  }
  out.points = triangulate(pair, disparity);
  out.matched = true;
  std::vector<double> d;
  for (float v : disparity.left)
    if (v > 0) d.push_back(v + pair.shift);
  if (!d.empty()) {
    const double z = pair.left.fx * pair.baseline / quantile(d, 0.5);
    out.step = z * z / (pair.left.fx * pair.baseline);
    out.pixel = z / pair.left.fx;
  }
  return out;
}

int shrink_factor(const FrameCamera& a, const FrameCamera& b, int side) {
  const int longest = std::max({a.width, a.height, b.width, b.height});
  return std::max(1, (longest + side - 1) / side);
}

// One pair's heights: the first pass bounds the second's search; the second's points binned in
// cells, the medians of the cells holding enough points. Empty when the pair gives too few.
struct PairHeights {
  std::vector<double> medians;  // sorted
  double coarse_step = 0, fine_step = 0, search_low = 0, search_high = 0;
  std::size_t points = 0;
  int scale = 1;
};

PairHeights pair_heights(const FrameCamera& ca, const GreyImage& ia, const FrameCamera& cb, const GreyImage& ib,
                         const HeightRangeOptions& options) {
  PairHeights out;
  // Pass 1, the search's bound: every depth, coarse.
  RectifyOptions unbounded;
  unbounded.unbounded_depth_disparities = options.max_disparities;
  const int coarse = shrink_factor(ca, cb, options.coarse_side);
  const PairMatch first = match_pair(ca, ia, cb, ib, coarse, unbounded, options.speckle_pixels, false);
  if (first.points.size() < 100) return out;
  // The scene: the heights connected to the median with no gap wider than `gap` (a quarter of
  // the cameras' height over the median, at least 10 coarse steps: a tower's roof seen without
  // its walls is kept, a clump of mismatches hundreds of metres off is not). Its ends, widened
  // by 2 coarse steps, bound the second pass's search.
  std::vector<double> heights;
  for (const Vec3& p : first.points) heights.push_back(p[2]);
  std::sort(heights.begin(), heights.end());
  const std::size_t middle = heights.size() / 2;
  const double camera_height = (ca.center[2] + cb.center[2]) / 2;
  const double gap = std::max(10 * first.step, 0.25 * (camera_height - heights[middle]));
  std::size_t lowest = middle, highest = middle;
  while (lowest > 0 && heights[lowest] - heights[lowest - 1] <= gap) --lowest;
  while (highest + 1 < heights.size() && heights[highest + 1] - heights[highest] <= gap) ++highest;
  out.coarse_step = first.step;
  const double widen = 2 * first.step + 0.1 * (heights[highest] - heights[lowest]);
  out.search_low = heights[lowest] - widen;
  out.search_high = heights[highest] + widen;
  // Pass 2, the measure: finer, searching only the bound (coarser while that needs too many
  // disparities).
  RectifyOptions bounded;
  bounded.min_height = out.search_low;
  bounded.max_height = out.search_high;
  bounded.max_disparities = options.max_disparities;
  // Both ways, each camera left once: a pixel is only kept when its whole search lies inside the
  // other image (match_pair), which drops a band along the other image's edge; the band is
  // another part of the scene each way.
  PairMatch second;
  int s = shrink_factor(ca, cb, options.fine_side);
  for (; s <= coarse; ++s) {
    second = match_pair(ca, ia, cb, ib, s, bounded, options.speckle_pixels, true);
    if (second.matched) break;
  }
  // A bound too deep for max_disparities even at pass 1's scale (a clump of mismatches connected
  // to the scene), or a pass 2 whose pixels nearly all search beyond the other image (a small
  // overlap between tilted views): pass 1's own points, one way, so only the cells connected to
  // the median count (on the 8-view blocks with 15 degree tilts, 2 pairs of 6 come back so).
  const bool one_way = !second.matched;
  if (one_way) second = first, s = coarse;
  PairMatch back = one_way ? PairMatch{} : match_pair(cb, ib, ca, ia, s, bounded, options.speckle_pixels, true);
  if (second.points.size() + back.points.size() < 100) second = first, back = PairMatch{}, s = coarse;
  out.scale = s;
  out.fine_step = std::max(second.step, back.step);
  out.points = second.points.size() + back.points.size();
  // The heights' ends, robustly: both ways' points binned in square cells of cell_pixels pixels
  // of the second pass, the median of each cell holding at least cell_points of them (a lone
  // mismatch is outvoted).
  const double cell = options.cell_pixels * std::max(second.pixel, back.pixel);
  double x0 = INFINITY, y0 = INFINITY;
  for (const Vec3& p : second.points) x0 = std::min(x0, p[0]), y0 = std::min(y0, p[1]);
  for (const Vec3& p : back.points) x0 = std::min(x0, p[0]), y0 = std::min(y0, p[1]);
  struct Binned {
    std::uint64_t cell;
    double z;
    int way;  // 1: a left, 2: b left
    bool operator<(const Binned& o) const { return cell < o.cell || (cell == o.cell && z < o.z); }
  };
  std::vector<Binned> binned;
  binned.reserve(second.points.size() + back.points.size());
  const auto bin = [&](const std::vector<Vec3>& points, int way) {
    for (const Vec3& p : points) {
      const auto col = static_cast<std::uint64_t>((p[0] - x0) / cell);
      const auto row = static_cast<std::uint64_t>((p[1] - y0) / cell);
      binned.push_back(Binned{row << 32 | col, p[2], way});
    }
  };
  bin(second.points, 1);
  bin(back.points, 2);
  std::sort(binned.begin(), binned.end());
  std::vector<std::pair<double, int>> cells;  // median, ways that saw the cell (bits)
  for (std::size_t i = 0; i < binned.size();) {
    std::size_t j = i;
    int ways = 0;
    for (; j < binned.size() && binned[j].cell == binned[i].cell; ++j) ways |= binned[j].way;
    if (static_cast<int>(j - i) >= options.cell_points) cells.emplace_back(binned[i + (j - i) / 2].z, ways);
    i = j;
  }
  std::sort(cells.begin(), cells.end());
  // The scene's cells: the heights connected to the median cell's through steps of at most
  // `cell_gap` fine steps (plus 1 m), and each cluster of heights apart from them that both ways
  // saw (some of its cells matched with a left and with b left): a tower's roof above every other
  // roof is found both ways, a clump of mismatches (an occlusion, a shadow) mostly one way only.
  const double cell_gap = options.cell_gap * out.fine_step + 1.0;
  const std::size_t middle_cell = cells.size() / 2;
  for (std::size_t i = 0; i < cells.size();) {
    std::size_t j = i + 1;
    while (j < cells.size() && cells[j].first - cells[j - 1].first <= cell_gap) ++j;
    int ways = 0;
    for (std::size_t k = i; k < j; ++k) ways |= cells[k].second;
    const bool kept = (i <= middle_cell && middle_cell < j) || ways == 3;
    if (kept)
      for (std::size_t k = i; k < j; ++k) out.medians.push_back(cells[k].first);
    i = j;
  }
  return out;
}

}  // namespace

HeightRangeEstimate estimate_height_range(const std::vector<FrameCamera>& cameras, const CameraImages& image,
                                          const std::vector<std::pair<int, int>>& pairs,
                                          const HeightRangeOptions& options) {
  if (!(options.coarse_side >= 32 && options.fine_side >= options.coarse_side && options.max_disparities >= 16 &&
        options.margin_share >= 0 && options.fine_steps >= 0 && options.cell_pixels >= 1 && options.cell_points >= 1 &&
        options.cluster_cells >= 1 && options.cell_gap >= 0))
    throw ArgumentError("height range options", "out of range");
  HeightRangeEstimate out;
  out.low = INFINITY;
  out.high = -INFINITY;
  std::size_t matched_points = 0;
  for (const auto& [a, b] : pairs) {
    const FrameCamera &ca = cameras.at(a), &cb = cameras.at(b);
    const std::shared_ptr<const GreyImage> ia = image(a), ib = image(b);
    if (!ia || ia->width != ca.width || ia->height != ca.height || !ib || ib->width != cb.width ||
        ib->height != cb.height)
      throw ArgumentError("images", "camera " + std::to_string(!ia || ia->width != ca.width ? a : b) +
                                        ": image missing or of another size than the camera's");
    const PairHeights h = pair_heights(ca, *ia, cb, *ib, options);
    matched_points += h.points;
    if (h.medians.empty()) continue;
    // The lowest and highest heights `cluster_cells` cells share to within a fine step: a roof
    // or a street of a few cells counts, a lone cell (a mismatch the median did not outvote,
    // one cell at a height no other has) does not.
    const std::size_t k = static_cast<std::size_t>(options.cluster_cells) - 1;
    const double tolerance = std::max(h.fine_step, 0.1);
    double low = h.medians.front(), high = h.medians.back();
    for (std::size_t i = 0; i + k < h.medians.size(); ++i)
      if (h.medians[i + k] - h.medians[i] <= tolerance) {
        low = h.medians[i];
        break;
      }
    for (std::size_t i = h.medians.size() - 1; i >= k; --i)
      if (h.medians[i] - h.medians[i - k] <= tolerance) {
        high = h.medians[i];
        break;
      }
    out.low = std::min(out.low, low);
    out.high = std::max(out.high, high);
    out.coarse_step = std::max(out.coarse_step, h.coarse_step);
    out.fine_step = std::max(out.fine_step, h.fine_step);
    out.search_low = out.pairs.empty() ? h.search_low : std::min(out.search_low, h.search_low);
    out.search_high = out.pairs.empty() ? h.search_high : std::max(out.search_high, h.search_high);
    out.points += h.points;
    out.cells += h.medians.size();
    out.scale = std::max(out.scale, h.scale);
    out.pairs.emplace_back(a, b);
  }
  if (out.pairs.empty())
    throw InputError("", "cameras",
                     "no pair of nearest cameras gave enough matched points (" + std::to_string(matched_points) +
                         " in all): the scene's height range cannot be estimated");
  const double margin = options.margin_share * (out.high - out.low) + options.fine_steps * out.fine_step;
  out.min_height = out.low - margin;
  out.max_height = out.high + margin;
  return out;
}

HeightRangeEstimate estimate_height_range(const std::vector<FrameCamera>& cameras, const std::vector<GreyImage>& images,
                                          const std::vector<std::pair<int, int>>& pairs,
                                          const HeightRangeOptions& options) {
  return estimate_height_range(
      cameras,
      [&](int i) {
        return i < static_cast<int>(images.size())
                   ? std::shared_ptr<const GreyImage>(std::shared_ptr<const GreyImage>{}, &images[i])
                   : nullptr;
      },
      pairs, options);
}

}  // namespace dsmplan
