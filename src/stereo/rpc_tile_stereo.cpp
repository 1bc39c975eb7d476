// A tile of a push-broom (RPC) pair through the whole chain (dsmplan/rpc_stereo.hpp):
// the tile-wise pipeline of C. de Franchis, E. Meinhardt-Llopis, J. Michel, J.-M. Morel,
// G. Facciolo, "An automatic and modular stereo pipeline for pushbroom images", ISPRS Annals
// II-3, 2014 (s2p): each tile is rectified with its own affine cameras, its pointing error
// corrected from its own tie points, matched, and triangulated through the RPCs; the disparity
// range of a tile comes from matched features (tie_point_heights), not from an external DEM.
// The matcher is this project's SGM (stereo.hpp, Hirschmüller 2008) where s2p offers several.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/rpc_stereo.hpp"

namespace dsmplan {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// An image's grey levels as SGM input: rounded, clamped to 0..65535, no data as 0.
std::vector<std::uint16_t> quantize(const FloatImage& im) {
  std::vector<std::uint16_t> q(im.pixels.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, q.size(), 1 << 14),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i < r.end(); ++i) {
                        const float v = im.pixels[i];
                        q[i] = std::isnan(v) ? 0 : static_cast<std::uint16_t>(std::lround(std::clamp(v, 0.f, 65535.f)));
                      }
                    });
  return q;
}

void check_image(const FloatImage& im, const char* name) {
  if (im.width < 1 || im.height < 1 || im.pixels.size() != static_cast<std::size_t>(im.width) * im.height)
    throw ArgumentError(name, "has no pixels or a size that does not match them");
}

// The tile widened by `margin` each side, clamped to the image.
RpcTile widened(const RpcTile& t, int margin, const FloatImage& im) {
  RpcTile w = t;
  w.col0 = std::max(0, t.col0 - margin), w.row0 = std::max(0, t.row0 - margin);
  w.width = std::min(im.width, t.col0 + t.width + margin) - w.col0;
  w.height = std::min(im.height, t.row0 + t.height + margin) - w.row0;
  return w;
}

}  // namespace

std::vector<double> tie_point_heights(const RpcCamera& left, const FloatImage& left_image, const RpcCamera& right,
                                      const FloatImage& right_image, const RpcTile& tile,
                                      const TiePointOptions& options) {
  check_image(left_image, "left image");
  check_image(right_image, "right image");
  const RpcRectification rect = rectify_rpc_pair(left, right, tile);
  const FloatImage L = resample_rectified(left_image, rect.left, rect.width, rect.height);
  const FloatImage R = resample_rectified(right_image, rect.right, rect.width, rect.height);
  const std::vector<TiePoint> ties = match_tie_points(L, R, rect, options);
  const double mid = 0.5 * (tile.height_min + tile.height_max);
  std::vector<double> heights;
  for (const TiePoint& t : ties) {
    try {
      const RpcStereoPoint p = triangulate_rpc(left, right, t.left, t.right, mid);
      if (p.residual_px < 1.0 && std::isfinite(p.ground.height)) heights.push_back(p.ground.height);
    } catch (const InputError&) {
      // a tie point far outside the RPC's domain: not the scene
    }
  }
  return heights;
}

RpcTileStereo rpc_tile_stereo(const RpcCamera& left, const FloatImage& left_image, const RpcCamera& right,
                              const FloatImage& right_image, const RpcTile& tile, const RpcTileStereoOptions& options) {
  check_image(left_image, "left image");
  check_image(right_image, "right image");
  if (options.margin < 0) throw ArgumentError("margin", "must be >= 0");
  RpcTileStereo out;
  auto start = std::chrono::steady_clock::now();
  const RpcTile wide = widened(tile, options.margin, left_image);
  out.rect = rectify_rpc_pair(left, right, wide);
  const int W = out.rect.width, H = out.rect.height;
  const FloatImage L = resample_rectified(left_image, out.rect.left, W, H);
  FloatImage R = resample_rectified(right_image, out.rect.right, W, H);
  out.seconds_rectify = seconds_since(start);

  start = std::chrono::steady_clock::now();
  const std::vector<TiePoint> ties = match_tie_points(L, R, out.rect, options.ties);
  out.tie_points = ties.size();
  if (static_cast<int>(ties.size()) >= options.min_tie_points && !ties.empty()) {
    out.rect = correct_pointing(out.rect, ties);
    R = resample_rectified(right_image, out.rect.right, W, H);
    out.pointing_corrected = true;
  }
  out.seconds_pointing = seconds_since(start);

  start = std::chrono::steady_clock::now();
  out.min_disparity = out.rect.min_disparity - 2;
  out.num_disparities = out.rect.max_disparity + 2 - out.min_disparity + 1;
  if (out.num_disparities > options.max_disparities)
    throw ArgumentError("height range", "needs " + std::to_string(out.num_disparities) +
                                            " disparities over this tile, more than " +
                                            std::to_string(options.max_disparities));
  // The tile's own pixels: rectified pixels whose left position lies in the tile (not the margin).
  const Affine2 back = out.rect.left.inverse();
  std::vector<unsigned char> own(static_cast<std::size_t>(W) * H, 0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const PixelPoint a = back({x + 0.5, y + 0.5});
      const bool in = a.col >= tile.col0 && a.col < tile.col0 + tile.width && a.row >= tile.row0 &&
                      a.row < tile.row0 + tile.height && !std::isnan(L.at(x, y));
      own[static_cast<std::size_t>(y) * W + x] = in;
      out.tile_pixels += in;
    }
  const int reach = std::max(std::abs(out.min_disparity), std::abs(out.min_disparity + out.num_disparities - 1));
  if (reach >= W || out.tile_pixels == 0) return out;  // too narrow for the disparities: no points
  SgmOptions sgm = options.sgm;
  sgm.min_disparity = out.min_disparity;
  sgm.num_disparities = out.num_disparities;
  const std::vector<std::uint16_t> ql = quantize(L), qr = quantize(R);
  Disparity disparity = sgm_match({ql.data(), W, H}, {qr.data(), W, H}, sgm);
  for (std::size_t i = 0; i < own.size(); ++i) {
    if (!own[i]) disparity.left[i] = NAN;
    out.matched_pixels += !std::isnan(disparity.left[i]);
  }
  out.seconds_match = seconds_since(start);

  start = std::chrono::steady_clock::now();
  out.points = disparity_to_points(left, right, out.rect, disparity, options.max_residual_px);
  out.seconds_triangulate = seconds_since(start);
  return out;
}

}  // namespace dsmplan
