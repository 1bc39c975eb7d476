// dsmplan/frame_dsm.hpp: the frame-camera stereo stage: the cameras of a CAMERAS.json and their
// images in, a DSM grid out (issue 16; the pipeline of stereo_frames.hpp: Adolf & Hirschmüller,
// Section 2). `dsmplan stereo --cameras` is this stage with its files around it (stereo_job(),
// dsmplan/stereo_job.hpp: the CRS resolved and the images opened by src/geo, the GeoTIFF written).
//
// The chain: the scene's height range (CAMERAS.json's height_range, else estimate_height_range()
// on the nearest cameras' images); the pairs (`auto`: select_pairs_auto(), or named, each with a
// base-to-height ratio of at least kMinPairBaseToHeight); the DSM's extent (the bounds given, or
// every pair's common footprint on the lowest and highest plane of the scene, footprint_box());
// every pair rectified, matched, triangulated and fused by the median per cell (stereo_dsm()).
// No pair sinks the job: each is searched from its own smallest disparity, in up to 4 windows of
// 512 disparities when wider (FrameStereoOptions); a pair that needs more, cannot be rectified or
// whose cameras see nothing in common is left out before any image is read, with one line in
// StereoReport::warnings; the job fails only when no pair is left.
// Images are opened when first needed: a bad image of a pair is refused before the long work,
// and only a pair's two images are held while it is matched.
//
// Images: `image` of each camera, through the ImageOpener given: one band (grey) or three or more
// (RGB taken as luminance 0.299 R + 0.587 G + 0.114 B), 8 or 16 bit, of the camera's size.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dsmplan/colmap_model.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/image_reader.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {

/// What the stage needs to know of its request; the job's options (stereo_job.hpp) add the files.
struct FrameDsmOptions {
  double resolution = 0;                        ///< cell size, CRS units (metres), (0, kMaxDsmResolution]
  std::string pairs = "auto";                   ///< "auto" or "0-1,1-2,..."
  std::optional<std::array<double, 4>> bounds;  ///< x0, y0, x1, y1; none: the pairs' overlap on the ground
  /// The fusion's memory for points, bytes (8 a point; beyond it sorted runs go to a temporary
  /// file in $TMPDIR or /tmp: MedianFusion, median_fusion.hpp); at least 64 KiB.
  std::size_t fusion_memory_bytes = std::size_t{1} << 30;
  /// Memory for one band of a pair's rectified images and matching, bytes (FrameStereoOptions::band_bytes).
  std::size_t band_memory_bytes = std::size_t{1} << 30;
};

/// ArgumentError for options the stage cannot run: "--res" outside (0, kMaxDsmResolution],
/// bounds dsm_grid() refuses ("bounds"). frame_dsm() checks them first; a job calls this before
/// it reads any file.
void check(const FrameDsmOptions& options);

struct StereoReport {
  std::string cameras;  ///< CAMERAS.json (CameraFile::path)
  std::string output;   ///< the file the job wrote (set by the job)
  size_t camera_count = 0;
  std::vector<std::pair<int, int>> pairs;  ///< the pairs matched
  /// Every pair chosen (--pairs or `auto`), in order: matched (its disparity offset, windows and
  /// matched pixels) or left out with its problem; pairs = the matched ones.
  std::vector<FramePairStats> pair_stats;
  /// One line a pair left out, "CAMERAS.json: cameras 0 and 2: left out, <problem>": for the
  /// caller to show (the CLI prints each as "dsmplan: warning: ...").
  std::vector<std::string> warnings;
  double min_height = 0, max_height = 0;  ///< the height range used
  bool height_range_estimated = false;    ///< not in CAMERAS.json: estimated (seconds_height_range)
  std::array<double, 4> bounds{};
  int width = 0, height = 0;
  size_t matched_pixels = 0, points = 0, points_in_grid = 0;
  size_t points_outside_range = 0;  ///< triangulated outside height_range, dropped as mismatches
  size_t fusion_runs_spilled = 0;   ///< 0: the points fitted in fusion_memory_bytes
  size_t bands = 0;                 ///< bands of rectified rows matched (one a pair when it fits band_memory_bytes)
  GridSummary summary;
  /// Set by the job for cameras from a COLMAP model (--colmap): how they were put in the CRS.
  std::optional<Georeference> georeference;
  /// seconds_read includes the job's reading of CAMERAS.json; seconds_write is the job's.
  double seconds_read = 0, seconds_height_range = 0, seconds_rectify = 0, seconds_match = 0, seconds_triangulate = 0,
         seconds_fuse = 0, seconds_write = 0;
};

/// The chain above over `cameras` (read_camera_file()), whose CRS the caller resolved and
/// checked (`crs`: the DSM's). `dsm` gets the grid with the median heights, nodata where nothing
/// fell; `grid_check` is called with it before any image is matched. Progress: the height range,
/// then per pair.
///
/// Errors (one line each, naming cameras.path and the camera or key): ArgumentError as check(),
/// and "--pairs" for a bad list or a pair too short for depth; InputError "height_range" when it
/// is not given and cannot be estimated, "cameras" when no two cameras overlap enough ("auto"),
/// "cameras" when no pair is left to match (each pair's problem named: "cameras i and j: see
/// nothing in common", "...: the height range needs N disparities, more than M ..."), "--bounds" outside every pair's
/// common footprint, an image missing, unreadable, not 8- or 16-bit or not of its camera's size, nothing matched into
/// the grid.
StereoReport frame_dsm(const CameraFile& cameras, const Crs& crs, const ImageOpener& open_image,
                       const FrameDsmOptions& options, Grid& dsm, const GridCheck& grid_check = {},
                       const Progress& progress = {});

}  // namespace dsmplan
