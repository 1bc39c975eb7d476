// dsmplan/satellite_dsm.hpp: the satellite stereo stage: images with RPC cameras in, a DSM grid
// out (issue 17). `dsmplan stereo IMG1 IMG2 ...` is this stage with its files around it
// (satellite_stereo_job(), dsmplan/satellite_stereo_job.hpp: the images opened and the output
// CRS made by src/geo, stereo_io.hpp; the GeoTIFF written).
//
// The chain (s2p's tile-wise chain, de Franchis et al., ISPRS Annals II-3, 2014; each step a
// function of dsmplan/rpc_stereo.hpp):
//   1. pairs: every pair (i < j) of the images whose footprints overlap: a 17 x 17 lattice of the
//      first image's pixels, localized at the middle of the two RPCs' common height range, seen
//      inside the second image;
//   2. the scene's heights per pair: tie points searched across the RPCs' whole common height
//      range on up to 2 x 2 survey tiles of 384 px (tie_point_heights()); the scene is taken as
//      their 1st to 99th percentile widened by 20 m and 10 % each side, within the RPCs' range;
//   3. tiles of the first image's overlap (tile_size pixels a side; with bounds, only where the
//      ground of its pixels falls in them), each read as a window of both images (bounded
//      memory: windows, not images) and run through rpc_tile_stereo(): affine rectification,
//      pointing correction, SGM with the left-right check, triangulation through the RPCs;
//   4. the points (longitude, latitude, height above the WGS 84 ellipsoid) to the output CRS by
//      the GroundFrame given, handed tile by tile to the fusion, which takes the median per cell
//      over every pair's points (MedianFusion, median_fusion.hpp); no data where none fell.
//
// Memory, bounded whatever the scene's size: per tile two windows, the rectified images, SGM's
// buffer (stereo.hpp) and the tile's points; the fusion's fusion_memory_bytes (beyond it, 8 bytes
// a point on disk in the temporary directory); the grid (4 bytes a cell; the job checks it in its
// GridCheck before any matching).
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/image_reader.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/rpc.hpp"
#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {

/// What the stage needs to know of its request; the job's options (satellite_stereo_job.hpp)
/// add the files and the output CRS.
struct SatelliteDsmOptions {
  double resolution = 0;                        ///< cell size, metres, (0, kMaxDsmResolution]
  std::optional<std::array<double, 4>> bounds;  ///< x0, y0, x1, y1 in the output CRS; none: the pairs' footprints
  int tile_size = 512;                          ///< left-image pixels per tile side, 64..4096
  /// The fusion's memory for points, bytes (8 a point; beyond it sorted runs go to a temporary
  /// file in $TMPDIR or /tmp: MedianFusion, median_fusion.hpp); at least 64 KiB.
  std::size_t fusion_memory_bytes = std::size_t{1} << 30;
};

/// ArgumentError for options the stage cannot run: "--res" outside (0, kMaxDsmResolution],
/// "tile_size" outside 64..4096, bounds dsm_grid() refuses ("bounds"). satellite_dsm() checks
/// them first; a job calls this before it opens any file.
void check(const SatelliteDsmOptions& options);

/// A satellite image: its camera and its pixels (band 1 is matched; 8- or 16-bit).
struct SatelliteImage {
  RpcCamera camera;
  std::shared_ptr<const ImageReader> pixels;
};

/// The ground of the image's centre pixel at its RPC's height offset (where the default output
/// CRS, WGS 84 / UTM, is chosen). InputError naming the image when it does not localize.
GeoPoint scene_centre(const SatelliteImage& image);

/// Where the points go: the DSM's CRS (projected, metres) and the transform of the RPCs' ground
/// to it (src/geo makes one from --crs, satellite_output() in stereo_io.hpp).
struct GroundFrame {
  Crs crs;                     ///< the DSM's, resolved
  std::string transformation;  ///< the operation's name, for the report
  /// Longitude, latitude (degrees), height above the WGS 84 ellipsoid (metres) to x, y, z of crs,
  /// in place; a point it cannot transform becomes NaN.
  std::function<void(std::vector<Point3>& points)> from_wgs84;
};

struct SatellitePairReport {
  int left = 0, right = 0;                        ///< indices into images
  double overlap = 0;                             ///< share of the left image's lattice seen by the right image
  double rpc_height_min = 0, rpc_height_max = 0;  ///< the RPCs' common height range, metres
  double height_min = 0, height_max = 0;          ///< the scene's heights searched (step 2)
  std::size_t survey_tie_points = 0;              ///< tie points whose heights gave step 2
  std::size_t tiles = 0, tiles_pointing_corrected = 0, tie_points = 0;
  std::size_t tile_pixels = 0, matched_pixels = 0, points = 0;
  double seconds_read = 0, seconds_survey = 0, seconds_rectify = 0, seconds_pointing = 0, seconds_match = 0,
         seconds_triangulate = 0;
};

struct SatelliteStereoReport {
  std::vector<std::string> images;  ///< the images' paths
  std::string output;               ///< the file the job wrote (set by the job)
  Crs crs;                          ///< the output's, resolved (GroundFrame::crs)
  std::string transformation;       ///< GroundFrame::transformation
  std::vector<SatellitePairReport> pairs;
  std::array<double, 4> bounds{};
  int width = 0, height = 0;
  std::size_t points = 0, points_in_grid = 0;
  std::size_t fusion_runs_spilled = 0;  ///< 0: the points fitted in fusion_memory_bytes
  GridSummary summary;
  double completeness = 0;  ///< valid cells / cells of the grid
  /// seconds_read includes the job's opening of the images; seconds_write is the job's.
  double seconds_read = 0, seconds_survey = 0, seconds_rectify = 0, seconds_pointing = 0, seconds_match = 0,
         seconds_triangulate = 0, seconds_transform = 0, seconds_fuse = 0, seconds_write = 0;
};

/// The chain above: `dsm` gets the grid (in frame.crs) with the median heights, nodata where
/// nothing fell. `grid_check` is called with the grid before any matching. Progress: the pairs'
/// surveys (to 0.11), then per tile, then the fusion.
///
/// Errors (one line each): ArgumentError as check(), and "images" for fewer than two images;
/// InputError naming the image for two images whose RPCs' height ranges do not intersect, that
/// do not overlap on the ground (or, with three or more, no two that do), that overlap only at
/// heights outside the RPCs' range, that match nowhere within that range (the scene lies outside
/// the range the RPCs were made for, or the images do not show the same ground), a window that
/// cannot be read; "--bounds" outside every pair's footprint; nothing matched into the grid.
SatelliteStereoReport satellite_dsm(const std::vector<SatelliteImage>& images, const GroundFrame& frame,
                                    const SatelliteDsmOptions& options, Grid& dsm, const GridCheck& grid_check = {},
                                    const Progress& progress = {});

}  // namespace dsmplan
