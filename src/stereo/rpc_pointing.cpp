// Tie points of a rectified RPC pair and the pointing correction (dsmplan/rpc_stereo.hpp).
//
// Pointing correction after C. de Franchis, E. Meinhardt-Llopis, J. Michel, J.-M. Morel,
// G. Facciolo, "An automatic and modular stereo pipeline for pushbroom images", ISPRS Annals II-3,
// 2014 (s2p), and "Automatic sensor orientation refinement of Pléiades stereo images",
// IGARSS 2014, by the same authors: the relative pointing error of two push-broom images is, over a
// tile, a translation of the secondary image; s2p (pointing_accuracy.local_translation) estimates
// it as the median of the tie points' error vectors to their epipolar lines (collinear for affine
// cameras, so the median of each component is the median vector). In the rectified frame the
// error vector of a tie point is its row difference, and the translation is the one that moves
// the right image's rows by minus the median.
//
// Tie points: s2p matches SIFT features; here, as tests/rpc_test.cpp, normalised cross-correlation
// of 13 x 13 patches on a grid, searched in the rectified pair along the row over the disparity
// range and a few rows across it (the pointing error is at most a few pixels), with a parabola
// through the correlation's neighbours for the sub-pixel position. Correlation on a grid of
// textured patches gives tie points where SIFT would, in a fraction of the code.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/rpc_stereo.hpp"

namespace dsmplan {

namespace {

// A mean-free patch of unit norm centred on pixel (x, y); false when it leaves the image, holds
// NaN, or is flatter than min_std.
bool patch(const FloatImage& im, int x, int y, int half, double min_std, std::vector<double>& out) {
  if (x - half < 0 || y - half < 0 || x + half >= im.width || y + half >= im.height) return false;
  out.clear();
  double mean = 0;
  for (int dy = -half; dy <= half; ++dy)
    for (int dx = -half; dx <= half; ++dx) {
      const float v = im.at(x + dx, y + dy);
      if (std::isnan(v)) return false;
      out.push_back(v), mean += v;
    }
  mean /= static_cast<double>(out.size());
  double norm = 0;
  for (double& v : out) v -= mean, norm += v * v;
  if (norm < min_std * min_std * static_cast<double>(out.size())) return false;
  for (double& v : out) v /= std::sqrt(norm);
  return true;
}

// Whether the patch of pixel (x, y) has texture in every direction: the smaller eigenvalue of its
// gradient structure tensor at least `ratio` times the larger (J. Shi, C. Tomasi, "Good features
// to track", CVPR 1994). A patch whose texture is one straight edge matches anywhere along the
// edge: across the epipolar lines that is an error of the row found, the very quantity measured.
bool textured_every_way(const FloatImage& im, int x, int y, int half, double ratio) {
  double xx = 0, xy = 0, yy = 0;
  for (int dy = -half + 1; dy <= half - 1; ++dy)
    for (int dx = -half + 1; dx <= half - 1; ++dx) {
      const double gx = 0.5 * (im.at(x + dx + 1, y + dy) - im.at(x + dx - 1, y + dy));
      const double gy = 0.5 * (im.at(x + dx, y + dy + 1) - im.at(x + dx, y + dy - 1));
      xx += gx * gx, xy += gx * gy, yy += gy * gy;
    }
  const double mean = 0.5 * (xx + yy), root = std::sqrt(0.25 * (xx - yy) * (xx - yy) + xy * xy);
  return mean + root > 0 && (mean - root) >= ratio * (mean + root);
}

// The vertex offset of the parabola through (-1, a), (0, b), (1, c), in (-0.5, 0.5).
double parabola(double a, double b, double c) {
  const double den = a - 2 * b + c;
  return den < 0 ? std::clamp(0.5 * (a - c) / den, -0.5, 0.5) : 0.0;
}

}  // namespace

std::vector<TiePoint> match_tie_points(const FloatImage& L, const FloatImage& R, const RpcRectification& rect,
                                       const TiePointOptions& o) {
  if (L.width != rect.width || L.height != rect.height || R.width != rect.width || R.height != rect.height)
    throw ArgumentError("rectified images", "are not of the rectification's size");
  if (o.step < 1 || o.half_window < 1 || o.row_search < 1) throw ArgumentError("tie point options", "out of range");
  const int h = o.half_window, d0 = rect.min_disparity - o.disparity_margin,
            d1 = rect.max_disparity + o.disparity_margin;
  const int nd = d1 - d0 + 1, nv = 2 * o.row_search + 1;
  std::vector<PixelPoint> grid;
  for (int y = h + o.row_search; y + h + o.row_search < L.height; y += o.step)
    for (int x = h; x + h < L.width; x += o.step) grid.push_back({double(x), double(y)});
  std::vector<TiePoint> found(grid.size());
  std::vector<char> ok(grid.size(), 0);
  const Affine2 left_back = rect.left.inverse(), right_back = rect.right.inverse();
  // The right patches' sums, sums of squares and NaN counts by integral images: the NCC of a
  // mean-free unit left patch a with a right patch b is sum(a b) / |b - mean(b)|, one product per
  // pixel and candidate.
  const int W = R.width, H = R.height;
  std::vector<double> s1(static_cast<std::size_t>(W + 1) * (H + 1), 0), s2(s1.size(), 0), sn(s1.size(), 0);
  auto idx = [&](int x, int y) { return static_cast<std::size_t>(y) * (W + 1) + x; };
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const float v = R.at(x, y);
      const double f = std::isnan(v) ? 0.0 : v, n = std::isnan(v) ? 1.0 : 0.0;
      s1[idx(x + 1, y + 1)] = f + s1[idx(x, y + 1)] + s1[idx(x + 1, y)] - s1[idx(x, y)];
      s2[idx(x + 1, y + 1)] = f * f + s2[idx(x, y + 1)] + s2[idx(x + 1, y)] - s2[idx(x, y)];
      sn[idx(x + 1, y + 1)] = n + sn[idx(x, y + 1)] + sn[idx(x + 1, y)] - sn[idx(x, y)];
    }
  auto box = [&](const std::vector<double>& s, int x, int y) {  // the window centred on (x, y)
    return s[idx(x + h + 1, y + h + 1)] - s[idx(x - h, y + h + 1)] - s[idx(x + h + 1, y - h)] + s[idx(x - h, y - h)];
  };
  const double count = (2.0 * h + 1) * (2.0 * h + 1);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, grid.size()), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<double> a, score(static_cast<std::size_t>(nd) * nv);
    for (std::size_t g = range.begin(); g < range.end(); ++g) {
      const int x = static_cast<int>(grid[g].col), y = static_cast<int>(grid[g].row);
      if (!patch(L, x, y, h, o.min_std, a) || !textured_every_way(L, x, y, h, o.min_corner_ratio)) continue;
      double best = -2;
      int bd = 0, bv = 0;
      for (int iv = 0; iv < nv; ++iv)
        for (int id = 0; id < nd; ++id) {
          double c = -2;
          const int xr = x - (d0 + id), yr = y + iv - o.row_search;
          if (xr - h >= 0 && yr - h >= 0 && xr + h < W && yr + h < H && box(sn, xr, yr) == 0) {
            const double sum = box(s1, xr, yr), var = box(s2, xr, yr) - sum * sum / count;
            if (var > 1e-9) {
              double dotp = 0;
              std::size_t k = 0;
              for (int dy = -h; dy <= h; ++dy) {
                const float* row = &R.pixels[static_cast<std::size_t>(yr + dy) * W + xr - h];
                for (int dx = 0; dx <= 2 * h; ++dx) dotp += a[k++] * row[dx];
              }
              c = dotp / std::sqrt(var);
            }
          }
          score[static_cast<std::size_t>(iv) * nd + id] = c;
          if (c > best) best = c, bd = id, bv = iv;
        }
      // Distinct, and not on the edge of the search (the true match may lie beyond).
      if (best < o.min_ncc || bd == 0 || bd == nd - 1 || bv == 0 || bv == nv - 1) continue;
      auto s = [&](int iv, int id) { return score[static_cast<std::size_t>(iv) * nd + id]; };
      const double sd = parabola(s(bv, bd - 1), best, s(bv, bd + 1)), sv = parabola(s(bv - 1, bd), best, s(bv + 1, bd));
      const double d = d0 + bd + sd, dv = bv - o.row_search + sv;
      found[g] = {left_back({x + 0.5, y + 0.5}), right_back({x + 0.5 - d, y + 0.5 + dv}), best};
      ok[g] = 1;
    }
  });
  std::vector<TiePoint> out;
  for (std::size_t g = 0; g < grid.size(); ++g)
    if (ok[g]) out.push_back(found[g]);
  return out;
}

std::vector<double> epipolar_errors(const RpcRectification& rect, const std::vector<TiePoint>& ties) {
  std::vector<double> e;
  e.reserve(ties.size());
  for (const TiePoint& t : ties) e.push_back(rect.right(t.right).row - rect.left(t.left).row);
  return e;
}

RpcRectification correct_pointing(const RpcRectification& rect, const std::vector<TiePoint>& ties) {
  if (ties.empty()) throw ArgumentError("tie points", "none to estimate the pointing correction from");
  std::vector<double> e = epipolar_errors(rect, ties);
  std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
  const double median = e[e.size() / 2];
  // The right-image translation t with right(x + t) = right(x) + (0, -median): t = L⁻¹ (0, -median)
  // for the linear part L of the right map (rows move, columns do not, so disparities keep).
  const auto& m = rect.right.m;
  const double det = m[0] * m[4] - m[1] * m[3];
  const double tc = (-m[1] * -median) / det, tr = (m[0] * -median) / det;
  RpcRectification out = rect;
  out.right = rect.right.after(Affine2{{1, 0, tc, 0, 1, tr}});
  out.pointing = {rect.pointing[0] + tc, rect.pointing[1] + tr};
  return out;
}

}  // namespace dsmplan
