// Photo blocks rendered from a real DSM (issue 34, points 2 and 5): the set-ups a drone or an
// aircraft flies over a city, each rendered by aerial_scene.hpp, and what two views of them see.
// Shared by the height-range test (tests/stereo_height_range_test.cpp: the estimate must hold
// the seen heights, and cost the DSM nothing the true range would give) and bench_stereo's block
// and range tables (bench/bench_stereo_frames.cpp: dsmplan's SGM against OpenCV's on the same
// renders; the DSM with the estimate against the DSM given the truth), so all speak of the same
// blocks.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <tuple>
#include <utility>
#include <vector>

#include "aerial_scene.hpp"

namespace aerial {

using dsmplan::FrameCamera;
using dsmplan::GreyImage;
using dsmplan::Grid;
using dsmplan::Vec3;

/// One block. The views fly `strips` strips of `per_strip` along x, neighbours in a strip
/// `base_to_height` apart over the area's median height with 60 % forward overlap (so the focal
/// length follows: f = 0.4 size / (B/H)), strips 30 % side overlap apart; each view tilted by up
/// to `tilt_deg` in its own direction; radial distortion k1; a sun `sun_elevation` degrees high
/// (0: evenly lit, no shadows); gains 1 +- gain_spread and offsets +- 40 gain_spread grey levels;
/// noise in grey levels. `footprint`: the side of a view's footprint on the median height, metres.
struct BlockSetup {
  const char* name;
  bool delft;          ///< rendered from the Delft AHN3 DSM (1 m), else the NRW DOM1 tile
  double east, north;  ///< the block's centre, metres from the DSM's centre
  int strips, per_strip;
  double base_to_height;
  double tilt_deg;
  double k1;
  double sun_elevation;
  double gain_spread;
  double noise;
  int size;  ///< pixels a side
  double footprint;
  /// 0: the height-range estimate meets issue 34's bound here. Else how far short of it the
  /// estimate was measured to fall (metres, on any of its three sides), so that the test still
  /// fails if that gets worse; the table's comments say where and why.
  double shortfall = 0;
};

/// Every condition issue 34 point 2 names, on both cities.
inline const std::vector<BlockSetup>& block_setups() {
  // clang-format off
  static const std::vector<BlockSetup> setups{
    // name                       delft  east  north  strips per B/H  tilt  k1     sun  gain  noise size footprint shortfall
    {"NrwPairBh02Nadir",          false,    0,     0,  1, 2, 0.2,  0,    0,      0,   0,    1.5, 240, 160},
    {"NrwPairBh08Tilt15",         false, -150,   100,  1, 2, 0.8, 15,    0,      0,   0,    1.5, 240, 160},
    {"NrwStripOf3Bh03Tilt8",      false,   50,   -50,  1, 3, 0.3,  8,   -0.05,   0,   0,    1.5, 480, 200},
    // Short: the highest seen cells, a steep roof up to 162.4 m (49 cells over 140 m), are seen by
    // both views of one pair only, 0-1, and in view 1 only in its first 32 of 200 columns; that
    // pair matches nothing over 136 m (pass 1 and pass 2, either camera left). The top comes
    // from pair 2-3's 6 cells at 154.6-155.3 m, found both ways: 2.8 m missed.
    {"NrwTwoStripsOf4",           false,  100,   150,  2, 4, 0.5,  5,    0,      0,   0,    1.5, 200, 150, 3.5},
    {"NrwLowSunLongShadows",      false, -100,  -150,  2, 2, 0.4,  3,    0,     15,   0,    1.5, 240, 160},
    {"NrwGainAndNoise",           false,  200,     0,  1, 5, 0.6,  4,    0,      0,   0.3,  4,   240, 160},
    // Short: the lowest seen cell (109.7 m), a street the low sun shades, is seen by views 4 and
    // 7 only (223 cells in common; 0 and 7 see 110.9 m), no camera's nearest partner; matching
    // all 28 pairs gives those far pairs' mismatches (km off), not the street. The nearest pairs'
    // lowest cells are 117.0 m: 2.8 m missed. The top: 167.7 m, matched 162.6 m: 0.6 m missed.
    {"NrwEverything",             false,    0,     0,  2, 4, 0.3, 15,   -0.03,  15,   0.25, 3,   240, 180, 3.5},
    {"DelftPairBh02Nadir",        true,     0,     0,  1, 2, 0.2,  0,    0,      0,   0,    1.5, 240, 90},
    {"DelftPairBh08Tilt15",       true,    20,   -20,  1, 2, 0.8, 15,    0,      0,   0,    1.5, 240, 90},
    {"DelftStripOf3Bh03Tilt8",    true,     0,    10,  1, 3, 0.3,  8,   -0.05,   0,   0,    1.5, 240, 80},
    {"DelftTwoStripsOf4",         true,     0,     0,  2, 4, 0.5,  5,    0,      0,   0,    1.5, 200, 70},
    {"DelftLowSunLongShadows",    true,   -20,     0,  2, 2, 0.4,  3,    0,     15,   0,    1.5, 240, 80},
    // Short: a clump of 4 cells at 15.8-15.9 m, 3.8 m over the highest seen cell, that both ways
    // of pair 0-1 matched cell by cell (noise 4, gains 0.7-1.3) and no other pair sees: alike in
    // every measure tried to NrwPairBh02Nadir's true tower top (4 cells, 159.5-160.7 m, both
    // ways, also over pass 2's search bound): 2.4 m too wide.
    {"DelftGainAndNoise",         true,     0,   -10,  1, 5, 0.6,  4,    0,      0,   0.3,  4,   240, 60,  3},
    // Short: the highest seen cells (15.9 m) are seen by views 2 and 7 only (1 and 6: 15.1 m),
    // no camera's nearest partner; the nearest pairs' highest cell is 13.8 m (their truth, 14.0 m):
    // 0.6 m missed.
    {"DelftEverything",           true,     0,     0,  2, 4, 0.3, 15,   -0.03,  15,   0.25, 3,   240, 70,  1},
  };
  // clang-format on
  return setups;
}

/// A rendered block: the scene, its cameras and their images.
struct Block {
  Grid truth;  ///< the scene: the DSM's cells (holes and beyond the DSM at `floor`)
  double floor = 0, top = 0, ground = 0;
  std::vector<FrameCamera> cameras;
  std::vector<GreyImage> images;
};

inline double median_of(std::vector<float> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

/// Renders `s` from `dsm` (the NRW tile or the Delft DSM, as s.delft says).
inline Block render_block(const BlockSetup& s, const Grid& dsm) {
  Block b;
  const double W = s.footprint, B = (1 - 0.6) * W, across = (1 - 0.3) * W;
  const double f = 0.4 * s.size / s.base_to_height, H = W * f / s.size;
  const double shift = H * std::tan(s.tilt_deg * std::numbers::pi / 180);
  const double cx = (dsm.x0 + dsm.x1()) / 2 + s.east, cy = (dsm.y0 + dsm.y1()) / 2 + s.north;
  // The scene: a square of cells holding every footprint, 1.6 W + the tilt's shift around the
  // block (a footprint is W on the median, wider on lower ground).
  const double half = 0.5 * std::max((s.per_strip - 1) * B, (s.strips - 1) * across) + 0.8 * W + shift + 10;
  const int col0 = static_cast<int>(std::floor((cx - half - dsm.x0) / dsm.cell_x));
  const int row0 = static_cast<int>(std::floor((dsm.y0 - (cy + half)) / dsm.cell_y));
  const int n = static_cast<int>(std::ceil(2 * half / dsm.cell_x));
  b.truth = Grid(n, n, dsm.x0 + col0 * dsm.cell_x, dsm.y0 - row0 * dsm.cell_y, dsm.cell_x, dsm.cell_y);
  b.truth.crs = dsm.crs;
  float lowest = INFINITY;
  for (float z : dsm.z)
    if (!std::isnan(z)) lowest = std::min(lowest, z);
  b.floor = lowest;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const int dc = col0 + c, dr = row0 + r;
      const bool inside = dc >= 0 && dr >= 0 && dc < dsm.width && dr < dsm.height;
      const float z = inside ? dsm.at(dc, dr) : NAN;
      b.truth.z[b.truth.index(c, r)] = std::isnan(z) ? lowest : z;
    }
  b.top = *std::max_element(b.truth.z.begin(), b.truth.z.end());
  b.ground = median_of(b.truth.z);
  // The cameras: strips along x, tilted each in its own direction (golden angle apart).
  const double magnitudes[] = {1, 0.6, 0.85, 0.4, 0.95, 0.7, 0.5, 0.8};
  const double gains[] = {1, -1, 0.4, -0.6, 0.8, -0.2, -0.9, 0.1}, offsets[] = {-0.5, 1, -1, 0.3, 0.6, -0.8, 0.2, -0.3};
  const Sun sun = Sun::at(s.sun_elevation, 135);
  const ColumnScene scene{b.truth, b.floor, b.top};
  int k = 0;
  for (int j = 0; j < s.strips; ++j)
    for (int i = 0; i < s.per_strip; ++i, ++k) {
      const double tilt = s.tilt_deg * std::numbers::pi / 180 * magnitudes[k % 8];
      const double direction = k * 2.399963;
      const Vec3 center{cx + (i - (s.per_strip - 1) / 2.0) * B, cy + (j - (s.strips - 1) / 2.0) * across, b.ground + H};
      b.cameras.push_back(
          nadir_camera(s.size, f, center, tilt * std::cos(direction), tilt * std::sin(direction), s.k1, s.k1 / 50));
      ViewLook look;
      look.gain = 1 + s.gain_spread * gains[k % 8];
      look.offset = 40 * s.gain_spread * offsets[k % 8];
      look.noise = s.noise;
      if (s.sun_elevation > 0) look.sun = &sun;
      b.images.push_back(render(scene, b.cameras.back(), 100 + k, look));
    }
  return b;
}

/// What stereo can measure at all: the block's cells whose top at least two views see, at least
/// in part (the top's centre or one of four points 0.1 cell in from its corners projects into the
/// image and the ray from the camera to it meets no other column first: the renderer's own ray
/// cast); NaN elsewhere. From the DSM and the cameras only, so it is an oracle independent of any
/// matcher or estimator. A cell one view sees, or none, no pair can triangulate.
inline Grid seen_by_two(const Block& b) {
  const ColumnScene scene{b.truth, b.floor, b.top};
  Grid seen = b.truth;
  for (int r = 0; r < b.truth.height; ++r)
    for (int c = 0; c < b.truth.width; ++c) {
      const double z = b.truth.at(c, r);
      int views = 0;
      for (const FrameCamera& camera : b.cameras) {
        for (const auto& [dx, dy] : {std::pair{0.0, 0.0}, {-0.4, -0.4}, {0.4, -0.4}, {-0.4, 0.4}, {0.4, 0.4}}) {
          const Vec3 X{b.truth.center_x(c) + dx * b.truth.cell_x, b.truth.center_y(r) + dy * b.truth.cell_y, z};
          double u, v;
          if (!project(camera, X, u, v) || u < 0 || v < 0 || u > camera.width - 1 || v > camera.height - 1) continue;
          const Vec3 to{X[0] - camera.center[0], X[1] - camera.center[1], X[2] - camera.center[2]};
          const double length = std::sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
          const Vec3 hit = scene.hit(camera.center, {to[0] / length, to[1] / length, to[2] / length});
          if (std::abs(hit[0] - X[0]) + std::abs(hit[1] - X[1]) + std::abs(hit[2] - X[2]) < 0.01) {
            ++views;
            break;
          }
        }
      }
      if (views < 2) seen.z[seen.index(c, r)] = NAN;
    }
  return seen;
}

/// The box (x0, y0, x1, y1) of the cells `seen` (seen_by_two()) holds: the DSM a bench or test makes.
inline std::array<double, 4> seen_bounds(const Grid& seen) {
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (int r = 0; r < seen.height; ++r)
    for (int c = 0; c < seen.width; ++c)
      if (seen.valid(c, r)) {
        x0 = std::min(x0, seen.center_x(c) - 0.5 * seen.cell_x),
        x1 = std::max(x1, seen.center_x(c) + 0.5 * seen.cell_x);
        y0 = std::min(y0, seen.center_y(r) - 0.5 * seen.cell_y),
        y1 = std::max(y1, seen.center_y(r) + 0.5 * seen.cell_y);
      }
  return {x0, y0, x1, y1};
}

/// The job `dsmplan stereo` runs on block `b` given the height range [min_height, max_height]
/// (estimated, or as CAMERAS.json would give it): the pairs select_pairs_auto() chooses on the
/// range's lowest plane, dsmplan's SGM, a 1 m DSM over the cells `seen` (seen_by_two()) holds,
/// scored against them.
struct RangedDsm {
  Grid dsm;
  std::size_t pairs = 0;
  DsmErrors errors;
};
inline RangedDsm dsm_given_range(const Block& b, const Grid& seen, double min_height, double max_height) {
  dsmplan::PairSelectionOptions selection;
  selection.ground_height = min_height;
  const auto pairs = dsmplan::select_pairs_auto(b.cameras, selection);
  dsmplan::FrameStereoOptions options;
  options.rectify.min_height = min_height;
  options.rectify.max_height = max_height;
  RangedDsm out;
  out.dsm = dsmplan::dsm_grid(seen_bounds(seen), 1.0);
  out.pairs = dsmplan::stereo_dsm(b.cameras, b.images, pairs, out.dsm, options).pairs;
  out.errors = dsm_errors(out.dsm, seen);
  return out;
}

/// The heights of the cells `seen` (seen_by_two()) holds: the oracle of issue 34's point 2.
struct SeenHeights {
  double lowest = INFINITY, highest = -INFINITY;
  std::size_t cells = 0;
};
inline SeenHeights seen_heights(const Grid& seen) {
  SeenHeights h;
  for (float z : seen.z)
    if (!std::isnan(z)) {
      ++h.cells;
      h.lowest = std::min(h.lowest, double(z));
      h.highest = std::max(h.highest, double(z));
    }
  return h;
}

/// The widest range issue 34's bound allows, centred on the truth: the lowest and highest cell
/// `seen` holds, widened by 7.5 % of their difference and 1.5 m a side. What a user who knows the
/// scene would give; the yardstick for what an estimate costs the DSM.
inline std::pair<double, double> true_range_given(const Grid& seen) {
  const SeenHeights h = seen_heights(seen);
  const double widen = 0.075 * (h.highest - h.lowest) + 1.5;
  return {h.lowest - widen, h.highest + widen};
}

/// The cells of `seen` whose height lies outside [min_height, max_height], how many of them `dsm`
/// has a height for, within 1 m of the truth, and more than 1 m below it (an obstacle shown lower).
struct Outside {
  std::size_t cells = 0, filled = 0, within_1m = 0, low_by_1m = 0;
};
inline Outside outside_range(const Grid& seen, double min_height, double max_height, const Grid& dsm) {
  Outside out;
  for (int r = 0; r < seen.height; ++r)
    for (int c = 0; c < seen.width; ++c) {
      if (!seen.valid(c, r)) continue;
      const double truth = seen.at(c, r);
      if (truth >= min_height && truth <= max_height) continue;
      ++out.cells;
      int cd, rd;
      if (!dsm.cell_at(seen.center_x(c), seen.center_y(r), cd, rd) || !dsm.valid(cd, rd)) continue;
      ++out.filled;
      out.within_1m += std::abs(dsm.at(cd, rd) - truth) <= 1;
      out.low_by_1m += dsm.at(cd, rd) < truth - 1;
    }
  return out;
}

/// What the height range [min_height, max_height] (an estimate) costs block `b`'s DSM: the DSM
/// made with it and the DSM given the true range (true_range_given()), and the cells of `seen`
/// outside it as each of the two DSMs has them.
struct RangeCost {
  double given_low = 0, given_high = 0;
  RangedDsm estimated, given;
  Outside missed, recovered;
};
inline RangeCost range_cost(const Block& b, const Grid& seen, double min_height, double max_height) {
  RangeCost out;
  std::tie(out.given_low, out.given_high) = true_range_given(seen);
  out.estimated = dsm_given_range(b, seen, min_height, max_height);
  out.given = dsm_given_range(b, seen, out.given_low, out.given_high);
  out.missed = outside_range(seen, min_height, max_height, out.estimated.dsm);
  out.recovered = outside_range(seen, min_height, max_height, out.given.dsm);
  return out;
}

}  // namespace aerial
