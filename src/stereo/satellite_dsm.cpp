// The satellite stereo stage (dsmplan/satellite_dsm.hpp is the manual): s2p's tile-wise chain
// (de Franchis et al., "An automatic and modular stereo pipeline for pushbroom images", ISPRS
// Annals II-3, 2014) over every overlapping pair, its points fused by the median per cell. The
// steps per tile are those of rpc_stereo.hpp; here the pairs, their height ranges, the tiles and
// the fusion. The images come through ImageReader (src/geo reads them with GDAL).
#include "dsmplan/satellite_dsm.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>

#include "core/text.hpp"
#include "dsmplan/median_fusion.hpp"
#include "dsmplan/rpc_stereo.hpp"

namespace dsmplan {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string metres_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f", v);
  return text;
}

const std::string& path_of(const SatelliteImage& image) { return image.pixels->path(); }
int width_of(const SatelliteImage& image) { return image.pixels->width(); }
int height_of(const SatelliteImage& image) { return image.pixels->height(); }

struct Box {  // pixels [c0, c1) x [r0, r1)
  int c0 = 0, r0 = 0, c1 = 0, r1 = 0;
  int width() const { return c1 - c0; }
  int height() const { return r1 - r0; }
  bool empty() const { return c1 <= c0 || r1 <= r0; }
};

Box clamp_box(double c0, double r0, double c1, double r1, int w, int h) {
  Box b;
  b.c0 = std::clamp(static_cast<int>(std::floor(c0)), 0, w);
  b.r0 = std::clamp(static_cast<int>(std::floor(r0)), 0, h);
  b.c1 = std::clamp(static_cast<int>(std::ceil(c1)), 0, w);
  b.r1 = std::clamp(static_cast<int>(std::ceil(r1)), 0, h);
  return b;
}

// The box of pixels a set of points spans, padded and clamped to a w x h image.
Box span_box(const std::vector<PixelPoint>& points, double pad_c, double pad_r, int w, int h) {
  double c0 = 1e300, r0 = 1e300, c1 = -1e300, r1 = -1e300;
  for (const PixelPoint& p : points)
    c0 = std::min(c0, p.col), r0 = std::min(r0, p.row), c1 = std::max(c1, p.col), r1 = std::max(r1, p.row);
  if (c0 > c1) return {};
  return clamp_box(c0 - pad_c, r0 - pad_r, c1 + pad_c, r1 + pad_r, w, h);
}

// A window of band 1 as floats, no data as NaN.
FloatImage read_window(const SatelliteImage& image, const Box& box) {
  FloatImage out;
  out.width = box.width(), out.height = box.height();
  require_memory(path_of(image), "", 4.0 * out.width * out.height);
  out.pixels.resize(static_cast<std::size_t>(out.width) * out.height);
  const std::string problem = image.pixels->read(1, box.c0, box.r0, out.width, out.height, out.pixels.data());
  if (!problem.empty())
    throw InputError(path_of(image), "window at (" + std::to_string(box.c0) + ", " + std::to_string(box.r0) + ")",
                     "cannot be read: " + problem);
  if (const std::optional<double> nodata = image.pixels->nodata(1))
    for (float& v : out.pixels)
      if (v == static_cast<float>(*nodata)) v = NAN;
  return out;
}

// The window of the right image that sees a window of the left one over a height range: the
// left window's corners and centre localized at both ends of the range, projected, padded.
Box right_window(const SatelliteImage& left, const Box& lw, const SatelliteImage& right, double lo, double hi,
                 double pad) {
  std::vector<PixelPoint> seen;
  const PixelPoint probes[5] = {{double(lw.c0), double(lw.r0)},
                                {double(lw.c1), double(lw.r0)},
                                {double(lw.c0), double(lw.r1)},
                                {double(lw.c1), double(lw.r1)},
                                {0.5 * (lw.c0 + lw.c1), 0.5 * (lw.r0 + lw.r1)}};
  for (const PixelPoint& p : probes)
    for (double h : {lo, hi}) {
      try {
        seen.push_back(right.camera.project(left.camera.localize(p, h)));
      } catch (const InputError&) {
      }
    }
  return span_box(seen, pad, pad, width_of(right), height_of(right));
}

// A pair at work: its report, the left image's lattice the right one sees, and the overlap.
struct PairWork {
  SatellitePairReport report;
  std::vector<PixelPoint> lattice;  // of the left image, seen by the right one
  Box region;                       // of the left image: the overlap
};

// The pixels of a 17 x 17 lattice of the left image whose ground at height h the right one sees.
std::vector<PixelPoint> seen_at(const SatelliteImage& L, const SatelliteImage& R, double h) {
  std::vector<PixelPoint> seen;
  for (int v = 0; v < 17; ++v)
    for (int u = 0; u < 17; ++u) {
      const PixelPoint p{(u + 0.5) * width_of(L) / 17.0, (v + 0.5) * height_of(L) / 17.0};
      try {
        const PixelPoint q = R.camera.project(L.camera.localize(p, h));
        if (q.col >= 0 && q.row >= 0 && q.col <= width_of(R) && q.row <= height_of(R)) seen.push_back(p);
      } catch (const InputError&) {
      }
    }
  return seen;
}

// Why a pair without overlap has none: the scene outside the RPCs' range, or no common ground.
[[noreturn]] void refuse_no_overlap(const SatelliteImage& L, const SatelliteImage& R, const SatellitePairReport& pr) {
  const std::string range = metres_text(pr.rpc_height_min) + ".." + metres_text(pr.rpc_height_max);
  for (double h = -500; h <= 9000; h += 100)
    if ((h < pr.rpc_height_min || h > pr.rpc_height_max) && !seen_at(L, R, h).empty())
      throw InputError(path_of(R), "",
                       "overlaps " + path_of(L) + " only at heights outside the RPCs' height range " + range +
                           " m above the WGS 84 ellipsoid (at about " + metres_text(h) +
                           " m): the scene lies outside the range the RPCs were made for");
  throw InputError(path_of(R), "",
                   "does not overlap " + path_of(L) + " on the ground (no pixel of the latter, localized at " + range +
                       " m above the WGS 84 ellipsoid, falls in it)");
}

// Step 1 for one pair: the RPCs' common height range, the lattice both see, the overlap's region.
void find_overlap(const SatelliteImage& L, const SatelliteImage& R, PairWork& work) {
  SatellitePairReport& pr = work.report;
  const RpcModel &a = L.camera.model(), &b = R.camera.model();
  pr.rpc_height_min = std::max(a.height_off - std::abs(a.height_scale), b.height_off - std::abs(b.height_scale));
  pr.rpc_height_max = std::min(a.height_off + std::abs(a.height_scale), b.height_off + std::abs(b.height_scale));
  if (!(pr.rpc_height_max > pr.rpc_height_min))
    throw InputError(path_of(R), "", "its RPC's height range and " + path_of(L) + "'s do not intersect");
  work.lattice = seen_at(L, R, 0.5 * (pr.rpc_height_min + pr.rpc_height_max));
  for (double h : {pr.rpc_height_min, pr.rpc_height_max})
    for (const PixelPoint& p : seen_at(L, R, h))
      if (std::none_of(work.lattice.begin(), work.lattice.end(),
                       [&](const PixelPoint& q) { return q.col == p.col && q.row == p.row; }))
        work.lattice.push_back(p);
  pr.overlap = static_cast<double>(work.lattice.size()) / 289.0;
  if (work.lattice.empty()) refuse_no_overlap(L, R, pr);
  work.region = span_box(work.lattice, width_of(L) / 17.0, height_of(L) / 17.0, width_of(L), height_of(L));
}

// Step 2 for one pair: tie points across the RPCs' whole height range on up to 2 x 2 tiles of
// the overlap; the scene's heights are their 1st to 99th percentile, widened.
void survey_heights(const SatelliteImage& L, const SatelliteImage& R, PairWork& work) {
  SatellitePairReport& pr = work.report;
  const auto t0 = Clock::now();
  std::vector<double> heights;
  const Box& g = work.region;
  const int kx = g.width() > 768 ? 2 : 1, ky = g.height() > 768 ? 2 : 1;
  for (int sy = 0; sy < ky; ++sy)
    for (int sx = 0; sx < kx; ++sx) {
      const int sw = std::min(384, g.width() / kx), sh = std::min(384, g.height() / ky);
      if (sw < 32 || sh < 32) continue;
      const int cx = g.c0 + static_cast<int>((sx + 0.5) * g.width() / kx);
      const int cy = g.r0 + static_cast<int>((sy + 0.5) * g.height() / ky);
      const Box lw =
          clamp_box(cx - sw / 2, cy - sh / 2, cx + (sw + 1) / 2, cy + (sh + 1) / 2, width_of(L), height_of(L));
      const Box rw = right_window(L, lw, R, pr.rpc_height_min, pr.rpc_height_max, 32);
      if (lw.width() < 32 || lw.height() < 32 || rw.width() < 16 || rw.height() < 16) continue;
      const auto tr = Clock::now();
      const FloatImage li = read_window(L, lw);
      const FloatImage ri = read_window(R, rw);
      pr.seconds_read += seconds_since(tr);
      const RpcTile tile{0, 0, lw.width(), lw.height(), pr.rpc_height_min, pr.rpc_height_max};
      const auto found = tie_point_heights(L.camera.crop(lw.c0, lw.r0), li, R.camera.crop(rw.c0, rw.r0), ri, tile);
      heights.insert(heights.end(), found.begin(), found.end());
    }
  pr.survey_tie_points = heights.size();
  pr.seconds_survey = seconds_since(t0) - pr.seconds_read;
  if (heights.size() < 10)
    throw InputError(path_of(R), "",
                     "matches " + path_of(L) + " nowhere within the RPCs' height range " +
                         metres_text(pr.rpc_height_min) + ".." + metres_text(pr.rpc_height_max) +
                         " m above the WGS 84 ellipsoid (" + std::to_string(heights.size()) +
                         " tie points): the scene lies outside the range the RPCs were made for, or the "
                         "images do not show the same ground");
  std::sort(heights.begin(), heights.end());
  const double p1 = heights[heights.size() / 100], p99 = heights[heights.size() - 1 - heights.size() / 100];
  const double widen = 20 + 0.1 * (p99 - p1);
  pr.height_min = std::max(pr.rpc_height_min, p1 - widen);
  pr.height_max = std::min(pr.rpc_height_max, p99 + widen);
}

// Steps 1 and 2 over every pair (i < j): the pairs that overlap and match, or the first
// pair's refusal when none does.
std::vector<PairWork> overlapping_pairs(const std::vector<SatelliteImage>& images) {
  std::vector<PairWork> pairs;
  std::exception_ptr first_failure;
  const int n = static_cast<int>(images.size());
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      PairWork work;
      work.report.left = i, work.report.right = j;
      try {
        find_overlap(images[i], images[j], work);
        survey_heights(images[i], images[j], work);
        pairs.push_back(std::move(work));
      } catch (const InputError&) {
        if (!first_failure) first_failure = std::current_exception();
      }
    }
  if (pairs.empty()) std::rethrow_exception(first_failure);
  return pairs;
}

// One point to the output CRS; NaN where it cannot go.
Vec3 to_ground(const GroundFrame& frame, const GeoPoint& g) {
  std::vector<Point3> one{{g.lon, g.lat, g.height}};
  frame.from_wgs84(one);
  return one[0];
}

// The footprints on the ground: the overlap lattices at the scene's heights, in the output CRS.
std::array<double, 4> pairs_footprint(const std::vector<SatelliteImage>& images, const std::vector<PairWork>& pairs,
                                      const GroundFrame& frame) {
  std::array<double, 4> footprint{1e300, 1e300, -1e300, -1e300};
  for (const PairWork& w : pairs) {
    const SatelliteImage& L = images[w.report.left];
    for (const PixelPoint& p : w.lattice)
      for (double h : {w.report.height_min, w.report.height_max}) {
        try {
          const Vec3 X = to_ground(frame, L.camera.localize(p, h));
          if (!std::isfinite(X[0])) continue;
          footprint = {std::min(footprint[0], X[0]), std::min(footprint[1], X[1]), std::max(footprint[2], X[0]),
                       std::max(footprint[3], X[1])};
        } catch (const InputError&) {
        }
      }
  }
  if (!(footprint[2] > footprint[0] && footprint[3] > footprint[1]))
    throw InputError(path_of(images[0]), "", "the pairs' footprints do not transform into the output CRS");
  return footprint;
}

struct Tile {
  int pair;
  Box box;  // of the pair's left image
};

// The region of a pair's left image (every 16th pixel) whose ground lies in the grid.
Box region_in_grid(const SatelliteImage& L, const SatelliteImage& R, const PairWork& w, const Grid& grid,
                   const GroundFrame& frame) {
  const double reach_m = 16 * 1.0 + 2 * grid.cell_x;  // how far outside the grid a lattice pixel may lie
  const double mid = 0.5 * (w.report.height_min + w.report.height_max);
  std::vector<PixelPoint> inside;
  for (int v = w.region.r0; v <= w.region.r1; v += 16)
    for (int u = w.region.c0; u <= w.region.c1; u += 16) {
      const PixelPoint p{double(u), double(v)};
      bool in = false;
      try {
        const PixelPoint q = R.camera.project(L.camera.localize(p, mid));
        if (q.col < 0 || q.row < 0 || q.col > width_of(R) || q.row > height_of(R)) continue;
        for (double h : {w.report.height_min, w.report.height_max}) {
          const Vec3 X = to_ground(frame, L.camera.localize(p, h));
          in = in || (X[0] > grid.x0 - reach_m && X[0] < grid.x1() + reach_m && X[1] > grid.y1() - reach_m &&
                      X[1] < grid.y0 + reach_m);
        }
      } catch (const InputError&) {
        continue;
      }
      if (in) inside.push_back(p);
    }
  return span_box(inside, 16, 16, width_of(L), height_of(L));
}

// Step 3's tiles: each pair's region in the grid cut into tiles of about tile_size pixels.
std::vector<Tile> tiles_in_grid(const std::vector<SatelliteImage>& images, const std::vector<PairWork>& pairs,
                                const Grid& grid, const GroundFrame& frame, int tile_size) {
  std::vector<Tile> tiles;
  for (int k = 0; k < static_cast<int>(pairs.size()); ++k) {
    const PairWork& w = pairs[k];
    const Box region = region_in_grid(images[w.report.left], images[w.report.right], w, grid, frame);
    if (region.empty()) continue;
    const int T = tile_size;
    const int nx = (region.width() + T - 1) / T, ny = (region.height() + T - 1) / T;
    for (int ty = 0; ty < ny; ++ty)
      for (int tx = 0; tx < nx; ++tx) {
        Box b;
        b.c0 = region.c0 + static_cast<int>(static_cast<long>(region.width()) * tx / nx);
        b.c1 = region.c0 + static_cast<int>(static_cast<long>(region.width()) * (tx + 1) / nx);
        b.r0 = region.r0 + static_cast<int>(static_cast<long>(region.height()) * ty / ny);
        b.r1 = region.r0 + static_cast<int>(static_cast<long>(region.height()) * (ty + 1) / ny);
        if (!b.empty()) tiles.push_back({k, b});
      }
  }
  if (tiles.empty()) throw InputError(path_of(images[0]), "--bounds", "lies outside every pair's footprint");
  return tiles;
}

void add_tile(SatellitePairReport& pr, const RpcTileStereo& result) {
  ++pr.tiles;
  pr.tiles_pointing_corrected += result.pointing_corrected;
  pr.tie_points += result.tie_points;
  pr.tile_pixels += result.tile_pixels;
  pr.matched_pixels += result.matched_pixels;
  pr.points += result.points.size();
  pr.seconds_rectify += result.seconds_rectify;
  pr.seconds_pointing += result.seconds_pointing;
  pr.seconds_match += result.seconds_match;
  pr.seconds_triangulate += result.seconds_triangulate;
}

// Steps 3 and 4 for one tile: its windows matched, its points to the output CRS and the fusion.
void match_tile(const std::vector<SatelliteImage>& images, const Tile& tile, PairWork& w, const GroundFrame& frame,
                MedianFusion& fusion, SatelliteStereoReport& out) {
  SatellitePairReport& pr = w.report;
  const SatelliteImage& L = images[pr.left];
  const SatelliteImage& R = images[pr.right];
  const RpcTileStereoOptions tile_options;
  const Box& b = tile.box;
  const int m = tile_options.margin;
  const Box lw = clamp_box(b.c0 - m, b.r0 - m, b.c1 + m, b.r1 + m, width_of(L), height_of(L));
  const Box rw = right_window(L, lw, R, pr.height_min, pr.height_max, 32);
  if (rw.width() < 16 || rw.height() < 16) return;
  auto t0 = Clock::now();
  const FloatImage li = read_window(L, lw);
  const FloatImage ri = read_window(R, rw);
  pr.seconds_read += seconds_since(t0);
  const RpcTile rpc_tile{b.c0 - lw.c0, b.r0 - lw.r0, b.width(), b.height(), pr.height_min, pr.height_max};
  RpcTileStereo result;
  try {
    result = rpc_tile_stereo(L.camera.crop(lw.c0, lw.r0), li, R.camera.crop(rw.c0, rw.r0), ri, rpc_tile, tile_options);
  } catch (const ArgumentError& error) {
    throw InputError(path_of(L), "tile at (" + std::to_string(b.c0) + ", " + std::to_string(b.r0) + ")", error.what());
  }
  add_tile(pr, result);
  t0 = Clock::now();
  std::vector<Vec3> points;
  points.reserve(result.points.size());
  for (const RpcStereoPoint& p : result.points) points.push_back({p.ground.lon, p.ground.lat, p.ground.height});
  frame.from_wgs84(points);
  points.erase(std::remove_if(points.begin(), points.end(), [](const Vec3& q) { return std::isnan(q[0]); }),
               points.end());
  out.points += points.size();
  out.seconds_transform += seconds_since(t0);
  t0 = Clock::now();
  fusion.add(points);
  out.seconds_fuse += seconds_since(t0);
}

// The pairs' reports and their seconds summed into the whole run's.
void add_pairs(const std::vector<PairWork>& pairs, SatelliteStereoReport& out) {
  for (const PairWork& w : pairs) {
    const SatellitePairReport& pr = w.report;
    out.seconds_read += pr.seconds_read;
    out.seconds_survey += pr.seconds_survey;
    out.seconds_rectify += pr.seconds_rectify;
    out.seconds_pointing += pr.seconds_pointing;
    out.seconds_match += pr.seconds_match;
    out.seconds_triangulate += pr.seconds_triangulate;
    out.pairs.push_back(pr);
  }
}

}  // namespace

void check(const SatelliteDsmOptions& options) {
  if (!(options.resolution > 0 && options.resolution <= kMaxDsmResolution))
    throw ArgumentError("--res", "must lie in (0, " + short_number(kMaxDsmResolution) + "] metres, got " +
                                     short_number(options.resolution));
  if (options.tile_size < 64 || options.tile_size > 4096) throw ArgumentError("tile_size", "must be 64..4096 pixels");
  if (options.bounds) dsm_grid(*options.bounds, options.resolution);  // checks the bounds
}

GeoPoint scene_centre(const SatelliteImage& image) {
  try {
    return image.camera.localize({0.5 * width_of(image), 0.5 * height_of(image)}, image.camera.model().height_off);
  } catch (const InputError& error) {
    throw InputError(path_of(image), "", std::string("the image's centre does not localize: ") + error.what());
  }
}

SatelliteStereoReport satellite_dsm(const std::vector<SatelliteImage>& images, const GroundFrame& frame,
                                    const SatelliteDsmOptions& options, Grid& dsm, const GridCheck& grid_check,
                                    const Progress& progress) {
  check(options);
  if (images.size() < 2) throw ArgumentError("images", "give two or more satellite images with RPCs");
  SatelliteStereoReport out;
  for (const SatelliteImage& image : images) out.images.push_back(path_of(image));
  out.crs = frame.crs;
  out.transformation = frame.transformation;
  report(progress, 0.01 / 0.9);
  std::vector<PairWork> pairs = overlapping_pairs(images);
  report(progress, 0.1 / 0.9);

  const DsmExtent extent = dsm_extent(pairs_footprint(images, pairs, frame), options.bounds, options.resolution,
                                      path_of(images[0]), "footprint");
  out.bounds = extent.bounds;
  dsm = extent.grid;
  dsm.crs = out.crs;
  out.width = dsm.width, out.height = dsm.height;
  if (grid_check) grid_check(dsm);

  const std::vector<Tile> tiles = tiles_in_grid(images, pairs, dsm, frame, options.tile_size);
  MedianFusionOptions fusion_options;
  fusion_options.memory_bytes = options.fusion_memory_bytes;
  MedianFusion fusion(dsm, fusion_options);
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    match_tile(images, tiles[t], pairs[tiles[t].pair], frame, fusion, out);
    report(progress, (0.1 + 0.8 * static_cast<double>(t + 1) / static_cast<double>(tiles.size())) / 0.9);
  }

  const auto start = Clock::now();
  out.points_in_grid = fusion.finish(dsm);
  out.fusion_runs_spilled = fusion.runs_spilled();
  out.summary = summarize(dsm);
  out.completeness = dsm.cells() ? static_cast<double>(out.summary.valid) / static_cast<double>(dsm.cells()) : 0;
  out.seconds_fuse += seconds_since(start);
  add_pairs(pairs, out);
  if (out.summary.valid == 0)
    throw InputError(path_of(images[0]), "", "no matched point fell into the DSM's bounds: nothing to write");
  return out;
}

}  // namespace dsmplan
