// The frame-camera stereo stage (dsmplan/frame_dsm.hpp is the manual): the request of `dsmplan
// stereo --cameras` around stereo_dsm() (frame_pipeline.cpp: Adolf & Hirschmüller, Section 2):
// the scene's heights, the pairs, the DSM's extent, and the images read through ImageReader.
#include "dsmplan/frame_dsm.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>

#include "core/text.hpp"

namespace dsmplan {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string camera_name(int i) { return "camera " + std::to_string(i); }
std::string pair_name(const FramePairStats& p) {
  return "cameras " + std::to_string(p.left) + " and " + std::to_string(p.right);
}

InputError missing_image(const CameraFile& file, int i) {
  return InputError(file.images[i], camera_name(i), "missing (an image of " + file.path + ")");
}

// Camera i's image opened and checked (a raster, 8 or 16 bit, the camera's size), not read.
std::unique_ptr<ImageReader> open_checked(const CameraFile& file, int i, const ImageOpener& open) {
  const std::string& path = file.images[i];
  const FrameCamera& camera = file.cameras[i];
  if (!std::filesystem::exists(path)) throw missing_image(file, i);
  std::unique_ptr<ImageReader> image = open(path, camera_name(i));
  const int w = image->width(), h = image->height();
  if (w != camera.width || h != camera.height)
    throw InputError(path, camera_name(i),
                     "image is " + std::to_string(w) + " x " + std::to_string(h) + ", the camera says " +
                         std::to_string(camera.width) + " x " + std::to_string(camera.height));
  return image;
}

// Camera i's image as grey floats: band 1, or the luminance of bands 1-3.
GreyImage read_grey(const CameraFile& file, int i, const ImageOpener& open) {
  const std::unique_ptr<ImageReader> reader = open_checked(file, i, open);
  const int w = reader->width(), h = reader->height();
  require_memory(file.images[i], camera_name(i), 8.0 * w * h);
  GreyImage image;
  image.width = w;
  image.height = h;
  image.pixels.assign(static_cast<size_t>(w) * h, 0.0f);
  const bool rgb = reader->bands() >= 3;
  const double weights[3] = {0.299, 0.587, 0.114};
  std::vector<float> band(image.pixels.size());
  for (int b = 0; b < (rgb ? 3 : 1); ++b) {
    if (const std::string problem = reader->read(b + 1, 0, 0, w, h, band.data()); !problem.empty())
      throw InputError(file.images[i], camera_name(i), "image could not be read: " + problem);
    const double weight = rgb ? weights[b] : 1.0;
    for (size_t k = 0; k < band.size(); ++k) image.pixels[k] += static_cast<float>(weight * band[k]);
  }
  return image;
}

// The scene's heights: given, or from a coarse pass over the nearest cameras' images.
void find_height_range(const CameraFile& file, const ImageOpener& open, StereoReport& out) {
  out.min_height = file.min_height;
  out.max_height = file.max_height;
  out.height_range_estimated = !file.has_height_range;
  if (file.has_height_range) return;
  const auto coarse_pairs = height_range_pairs(file.cameras);
  // Each pair's images read when its turn comes, the last one kept (pairs share cameras): the
  // pass holds two images at a time, whatever the block's size. Their reading counts as read.
  std::shared_ptr<const GreyImage> last;
  int last_camera = -1;
  double reading = 0;
  const auto image = [&](int i) {
    if (i != last_camera) {
      const auto read_start = Clock::now();
      last = std::make_shared<const GreyImage>(read_grey(file, i, open));
      last_camera = i;
      reading += seconds_since(read_start);
    }
    return last;
  };
  const auto start = Clock::now();
  try {
    const HeightRangeEstimate estimate = estimate_height_range(file.cameras, image, coarse_pairs);
    out.min_height = estimate.min_height;
    out.max_height = estimate.max_height;
  } catch (const InputError& error) {
    std::string problem = error.what();  // "cameras: ...", or an image's own error, passed on
    if (problem.rfind("cameras: ", 0) != 0) throw;
    problem = problem.substr(9);
    throw InputError(file.path, "height_range", "not given, and " + problem + "; give [lowest, highest]");
  }
  out.seconds_height_range = seconds_since(start) - reading;
}

// The pairs to match, before the other images are read: cameras that see nothing in common fail fast.
std::vector<std::pair<int, int>> choose_pairs(const CameraFile& file, const std::string& pairs, double ground) {
  if (pairs != "auto") {
    auto named = parse_pairs(pairs, static_cast<int>(file.cameras.size()), "--pairs");
    check_pair_baselines(file.cameras, named, ground);
    return named;
  }
  PairSelectionOptions selection;
  selection.ground_height = ground;
  auto chosen = select_pairs_auto(file.cameras, selection);
  if (chosen.empty())
    throw InputError(file.path, "cameras",
                     "no two cameras overlap by 30 % on the ground with a base-to-height ratio of 0.1..1.2");
  return chosen;
}

// What stereo_dsm() is asked: the scene's heights, the memory bounds.
FrameStereoOptions stereo_options(const FrameDsmOptions& options, const StereoReport& out) {
  FrameStereoOptions stereo;
  stereo.rectify.min_height = out.min_height;
  stereo.rectify.max_height = out.max_height;
  stereo.fusion.memory_bytes = options.fusion_memory_bytes;
  stereo.band_bytes = options.band_memory_bytes;
  return stereo;
}

// The pairs chosen, screened before any image is read: a pair whose cameras see nothing in common
// on the scene's lowest nor on its highest plane, or that cannot be rectified over its heights
// (pair_problem()), is left out (out.pair_stats: its problem); out.pairs gets the others. Returns
// their common footprint on those planes. InputError when no pair is left.
std::array<double, 4> screen_pairs(const CameraFile& file, const std::vector<std::pair<int, int>>& chosen,
                                   const RectifyOptions& rectify, StereoReport& out) {
  std::array<double, 4> footprint{};
  std::string problems;
  for (const auto& [a, b] : chosen) {
    FramePairStats& pair = out.pair_stats.emplace_back();
    pair.left = a, pair.right = b;
    // The pair's common footprint on the lowest and on the highest plane of the scene; one may be
    // empty (strips with little side overlap share nothing high above the ground), not both.
    std::array<double, 4> box, high;
    const bool low_seen = footprint_box(file.cameras[a], file.cameras[b], out.min_height, box);
    const bool high_seen = footprint_box(file.cameras[a], file.cameras[b], out.max_height, high);
    if (!low_seen && !high_seen)
      pair.problem = "see nothing in common";
    else
      pair.problem = pair_problem(file.cameras[a], file.cameras[b], rectify);
    if (!pair.problem.empty()) {
      problems += (problems.empty() ? "" : "; ") + pair_name(pair) + ": " + pair.problem;
      continue;
    }
    if (!low_seen) box = high;
    if (low_seen && high_seen)
      box = {std::min(box[0], high[0]), std::min(box[1], high[1]), std::max(box[2], high[2]),
             std::max(box[3], high[3])};
    footprint = out.pairs.empty()
                    ? box
                    : std::array<double, 4>{std::min(footprint[0], box[0]), std::min(footprint[1], box[1]),
                                            std::max(footprint[2], box[2]), std::max(footprint[3], box[3])};
    out.pairs.emplace_back(a, b);
  }
  if (out.pairs.empty()) throw InputError(file.path, "cameras", "no pair left to match (" + problems + ")");
  return footprint;
}

// Every pair rectified, matched, triangulated and fused into `dsm`, the images read when their
// pair comes (stereo_dsm's ImageSource), so only two are held.
void match_pairs(const CameraFile& file, const ImageOpener& open, const FrameDsmOptions& options, Grid& dsm,
                 StereoReport& out, const Progress& progress) {
  const ImageSource source = [&](int i) {
    const auto read_start = Clock::now();
    auto image = std::make_shared<const GreyImage>(read_grey(file, i, open));
    out.seconds_read += seconds_since(read_start);
    return image;
  };
  const FrameStereoOptions stereo = stereo_options(options, out);
  const FrameStereoStats stats = [&] {
    try {
      return stereo_dsm(file.cameras, source, out.pairs, dsm, stereo, progress);
    } catch (const InputError& error) {
      throw InputError(file.path, "", error.what());
    }
  }();
  out.matched_pixels = stats.matched_pixels;
  out.points = stats.points;
  out.points_outside_range = stats.points_outside_range;
  out.points_in_grid = stats.points_in_grid;
  out.fusion_runs_spilled = stats.fusion_runs_spilled;
  out.bands = stats.bands;
  out.seconds_rectify = stats.seconds_rectify;
  out.seconds_match = stats.seconds_match;
  out.seconds_triangulate = stats.seconds_triangulate;
  out.seconds_fuse = stats.seconds_fuse;
  // The screened pairs' entries, the matched ones' replaced by their figures (in order).
  size_t next = 0;
  for (FramePairStats& pair : out.pair_stats)
    if (pair.problem.empty() && next < stats.pair_stats.size()) pair = stats.pair_stats[next++];
  out.pairs.clear();
  for (const FramePairStats& pair : out.pair_stats) {
    if (pair.used)
      out.pairs.emplace_back(pair.left, pair.right);
    else
      out.warnings.push_back(file.path + ": " + pair_name(pair) + ": left out, " + pair.problem);
  }
}

}  // namespace

void check(const FrameDsmOptions& options) {
  if (!(options.resolution > 0 && options.resolution <= kMaxDsmResolution))
    throw ArgumentError("--res", "must lie in (0, " + short_number(kMaxDsmResolution) + "] CRS units, got " +
                                     short_number(options.resolution));
  if (options.bounds) dsm_grid(*options.bounds, options.resolution);  // checks the bounds
}

StereoReport frame_dsm(const CameraFile& file, const Crs& crs, const ImageOpener& open, const FrameDsmOptions& options,
                       Grid& dsm, const GridCheck& grid_check, const Progress& progress) {
  check(options);
  const auto start = Clock::now();
  StereoReport out;
  out.cameras = file.path;
  out.camera_count = file.cameras.size();
  const int n = static_cast<int>(file.cameras.size());
  if (options.pairs != "auto") parse_pairs(options.pairs, n, "--pairs");  // a bad --pairs fails fast
  // Every image there before any is read: a missing one is named, not met halfway.
  for (int i = 0; i < static_cast<int>(file.images.size()); ++i)
    if (!std::filesystem::exists(file.images[i])) throw missing_image(file, i);
  find_height_range(file, open, out);
  report(progress, 0.03 / 0.9);
  const auto chosen = choose_pairs(file, options.pairs, out.min_height);
  const std::array<double, 4> footprint = screen_pairs(file, chosen, stereo_options(options, out).rectify, out);
  const DsmExtent extent = dsm_extent(footprint, options.bounds, options.resolution, file.path, "common footprint");
  out.bounds = extent.bounds;
  dsm = extent.grid;
  dsm.crs = crs;
  if (grid_check) grid_check(dsm);
  // Every image a pair needs is checked now: a bad one is refused before the long work.
  std::vector<bool> needed(file.cameras.size(), false);
  for (const auto& [a, b] : out.pairs) needed[a] = needed[b] = true;
  for (int i = 0; i < n; ++i)
    if (needed[i]) open_checked(file, i, open);
  out.seconds_read = seconds_since(start) - out.seconds_height_range;
  report(progress, 0.05 / 0.9);
  match_pairs(file, open, options, dsm, out, sub_progress(progress, 0.05 / 0.9, 1.0));
  out.width = dsm.width;
  out.height = dsm.height;
  out.summary = summarize(dsm);
  if (out.summary.valid == 0)
    throw InputError(file.path, "", "no point of any pair fell into the DSM's bounds: nothing to write");
  return out;
}

}  // namespace dsmplan
