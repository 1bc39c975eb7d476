// dsmplan/stereo_job.hpp: `dsmplan stereo` as a library function: frame cameras' images in (CAMERAS.json), a
// GeoTIFF DSM out (tools.hpp's conventions: an options struct in, a report out, to_json() keys a
// contract).
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dsmplan/raster.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan {

// ---- dsmplan stereo -------------------------------------------------------------------------

/// `dsmplan stereo`: a DSM from frame-camera images with known poses (stereo_frames.hpp).
///
/// CAMERAS.json (a contract; README, "Stereo from frame cameras"):
///   {"crs": "EPSG:25832", "height_range": [100, 180] (optional),
///    "cameras": [{"image": "img_0.png", "width": 1200, "height": 900, "fx": 2400.0, "fy": 2400.0,
///                 "cx": 599.5, "cy": 449.5, "distortion": [k1, k2, p1, p2, k3],
///                 "rotation": [[1,0,0],[0,-1,0],[0,0,-1]], "center": [x, y, z]}, ...]}
/// crs, cameras and every camera key are required but "distortion" (default none) and
/// "height_range" (the scene's lowest and highest heights, world units: it bounds the disparity
/// search and sets the plane footprints are cut with). Without height_range it is estimated
/// (estimate_height_range(), stereo_frames.hpp): the nearest cameras' images shrunk to about
/// 320 px, matched over every depth, triangulated; of the heights connected to their median
/// without a wide gap, the 0.2 % and 99.8 % quantiles widened by 10 % of their difference and two
/// coarse disparity steps. InputError (key height_range) when no such pair matches. `image` is any GDAL raster,
/// relative to the JSON's folder: one band (grey) or three or more (RGB taken as luminance 0.299 R + 0.587 G + 0.114
/// B), 8 or 16 bit.
struct StereoJobOptions {
  std::string cameras;  ///< CAMERAS.json
  std::string output;   ///< GeoTIFF (.tif, .tiff)
  double resolution = 0;
  std::string pairs = "auto";                   ///< "auto" or "0-1,1-2,..."
  std::optional<std::array<double, 4>> bounds;  ///< x0, y0, x1, y1; none: the pairs' overlap on the ground
  /// The fusion's memory for points, bytes (8 a point; beyond it sorted runs go to a temporary
  /// file in $TMPDIR or /tmp: MedianFusion, median_fusion.hpp); at least 64 KiB.
  std::size_t fusion_memory_bytes = std::size_t{1} << 30;
  /// Memory for one band of a pair's rectified images and matching, bytes (FrameStereoOptions::band_bytes).
  std::size_t band_memory_bytes = std::size_t{1} << 30;
};

struct StereoReport {
  std::string cameras, output;
  size_t camera_count = 0;
  std::vector<std::pair<int, int>> pairs;
  double min_height = 0, max_height = 0;  ///< the height range used
  bool height_range_estimated = false;    ///< not in CAMERAS.json: estimated (seconds_height_range)
  std::array<double, 4> bounds{};
  int width = 0, height = 0;
  size_t matched_pixels = 0, points = 0, points_in_grid = 0;
  size_t points_outside_range = 0;  ///< triangulated outside height_range, dropped as mismatches
  size_t fusion_runs_spilled = 0;   ///< 0: the points fitted in fusion_memory_bytes
  size_t bands = 0;                 ///< bands of rectified rows matched (one a pair when it fits band_memory_bytes)
  GridSummary summary;
  double seconds_read = 0, seconds_height_range = 0, seconds_rectify = 0, seconds_match = 0, seconds_triangulate = 0,
         seconds_fuse = 0, seconds_write = 0;
};

/// The files a run of `options` reads: CAMERAS.json ("--cameras") and every image it names
/// ("camera i's image", relative to its folder), for refuse_overwrites() before the work: a
/// --stats or -o that is one of them would replace it. InputError as stereo_job() for a
/// CAMERAS.json it cannot read.
std::vector<NamedFile> stereo_job_inputs(const StereoJobOptions& options);

/// Reads CAMERAS.json and the images, checks everything (one InputError naming the file and the
/// camera/key), selects the pairs, runs stereo_dsm() and writes the Float32 GeoTIFF atomically.
/// InputError when no pair overlaps, when --bounds lies outside every pair's footprint, or when
/// nothing was matched (no output is written then).
StereoReport stereo_job(const StereoJobOptions& options, const Progress& progress = {});
/// Keys: cameras, output, camera_count, pairs [[i,j],...], height_range, height_range_estimated, bounds, width, height,
/// matched_pixels, points, points_outside_height_range, points_in_grid, fusion_runs_spilled, bands, dsm {cells, valid,
/// nodata, holes, z_min, z_max}, seconds {read, height_range, rectify, match, triangulate, fuse, write, total}.
Json to_json(const StereoReport& report);

}  // namespace dsmplan
