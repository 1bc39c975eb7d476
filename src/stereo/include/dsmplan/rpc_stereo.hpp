// dsmplan/rpc_stereo.hpp: stereo of a push-broom (RPC) image pair over a tile: affine epipolar
// rectification, the pointing correction, triangulation through the RPCs.
//
// Method (C. de Franchis, E. Meinhardt-Llopis, J. Michel, J.-M. Morel, G. Facciolo, "An automatic
// and modular stereo pipeline for pushbroom images", ISPRS Annals II-3, 2014: s2p; and
// "On stereo-rectification of pushbroom images", ICIP 2014, by the same authors):
//   1. Over a small tile the RPC cameras are close to affine cameras (s2p's premise; measured
//      here: 0.03 px RMS over 400 x 400 Pléiades tiles, see Accuracy). fit_affine_camera() fits one per image by least
//      squares to RPC projections of ground points of the tile's volume (a grid of the left tile localized at heights
//      across [height_min, height_max]) in a local east-north-up frame in metres.
//   2. Two affine cameras have parallel epipolar lines (R. Hartley, A. Zisserman, "Multiple View
//      Geometry", 2nd ed., ch. 14: the affine fundamental matrix). rectify_rpc_pair() builds
//      a rectifying similarity per image (s2p's rectifying similarities): a rotation
//      that makes the epipolar direction horizontal, for the right image times the scale that
//      gives corresponding points the same rectified row, and translations (the rows aligned on
//      the RPC projections of the tile's volume; the columns so that the tile's middle height has
//      disparity about 0).
//   3. The pointing correction (s2p's "relative pointing error"): the RPCs of the two
//      images are off from each other by up to a few pixels; over a tile the error is a
//      translation of the right image. From tie points it is estimated as the median of their
//      errors across the epipolar lines (s2p's pointing_accuracy.local_translation), and composed
//      into the right image's rectifying map.
//   4. Triangulation: a match (left pixel, right pixel) is intersected through the RPCs by
//      Gauss-Newton least squares on (lon, lat, height), the 4 image coordinates as observations.
//
// Conventions. Pixel positions are those of rpc.hpp (GDAL's: the centre of pixel (i, j) at
// (i + 0.5, j + 0.5)), in rectified images the same. Disparity as in stereo.hpp: the left
// rectified pixel (x, y) with disparity d matches the right rectified (x - d, y). The "right"
// (secondary) image is the one the pointing correction moves. The rectified right position r of
// a right pixel x2 is right(x2); the RPC-consistent position of x2 is x2 + pointing (s2p's
// correction applied to the secondary image), so right(x2) = rpc_right(x2 + pointing).
//
// Accuracy, measured on the real Pléiades pairs (tests/rpc_stereo_test.cpp, 400 x 400 tile at
// (300, 300) of the 1000 x 1000 crops, heights 450-900 m): the affine cameras fit the RPCs to
// 0.032 px RMS (0.09 px at worst; AffineCamera::rms_px/max_px), the rectified RPC projections of
// the tile's volume share their row to 0.009 px (RpcRectification::rpc_row_error_px); tie points
// held out of the pointing correction's estimate lie 0.10 px (median) and 0.43 px (90th
// percentile) from their epipolar line on the pre-event pair, 0.09 and 0.36 px on the post-event
// pair (the pairs' pointing errors are small: 0.09 and 0.01 px). Triangulation returns a ground
// point projected into both images to 1e-11 m (the RPCs taken as exact). The SGM (stereo.hpp) on
// the pre-event tile gives 79 % valid disparities, and a street stretch picked from the image lies
// within 0.29 m (median) and 0.78 m (p90) of its robust plane.
//
// Errors: ArgumentError naming the argument for a tile smaller than 2 x 2, an empty height
// range, no tie points, images not of the rectification's size; InputError from
// RpcCamera::localize when a tile lies outside the RPC's domain (disparity_to_points skips a
// pixel whose triangulation fails so, rather than failing the tile).
//
// Complexity: rectification O(samples³) localizations; resampling O(W·H) over threads; tie points
// O(points · disparities · 7 · window²); disparity_to_points O(W·H) Gauss-Newton solves
// (about 5 RPC evaluations each) over threads.
#pragma once

#include <array>
#include <vector>

#include "dsmplan/rpc.hpp"
#include "dsmplan/stereo.hpp"

namespace dsmplan {

/// A plane affine map: (x', y') = (m0 x + m1 y + m2, m3 x + m4 y + m5).
struct Affine2 {
  std::array<double, 6> m{1, 0, 0, 0, 1, 0};
  PixelPoint operator()(const PixelPoint& p) const {
    return {m[0] * p.col + m[1] * p.row + m[2], m[3] * p.col + m[4] * p.row + m[5]};
  }
  Affine2 inverse() const;  ///< ArgumentError when singular
  /// this ∘ other: apply `other` first.
  Affine2 after(const Affine2& other) const;
};

/// A grey image of floats, row-major; NaN = no data.
struct FloatImage {
  int width = 0, height = 0;
  std::vector<float> pixels;
  float at(int x, int y) const { return pixels[static_cast<std::size_t>(y) * width + x]; }
  /// Bilinear value at a position (pixel centres at i + 0.5); NaN outside the pixel centres' hull.
  float sample(double col, double row) const;
};

/// An affine camera (col, row) = M (e, n, u) + b in a local east-north-up frame in metres
/// (origin at `origin`, on the WGS 84 sphere of radius 6378137 m: only its linearity matters).
struct AffineCamera {
  GeoPoint origin;
  std::array<double, 8> p{};                             ///< rows (m00 m01 m02 b0), (m10 m11 m12 b1)
  double rms_px = 0, max_px = 0;                         ///< of the fit to the RPC
  std::array<double, 3> local(const GeoPoint& g) const;  ///< the frame's (e, n, u) in metres
  PixelPoint project(const GeoPoint& g) const;
};

/// Least-squares affine camera of `camera` over the ground points (at least 4, not coplanar).
AffineCamera fit_affine_camera(const RpcCamera& camera, const GeoPoint& origin, const std::vector<GeoPoint>& points);

/// A tile of the left image (pixels) and the range of ellipsoidal heights it contains (metres).
struct RpcTile {
  int col0 = 0, row0 = 0, width = 0, height = 0;
  double height_min = 0, height_max = 0;
};

/// The rectification of a pair over a tile.
struct RpcRectification {
  Affine2 left, right;                       ///< original image positions -> rectified positions
  std::array<double, 2> pointing{0, 0};      ///< the correction in right-image pixels (see Conventions)
  int width = 0, height = 0;                 ///< of the two rectified images (the left tile's bounding box)
  int min_disparity = 0, max_disparity = 0;  ///< over the tile's height range (RPC projections)
  AffineCamera camera_left, camera_right;
  double rpc_row_error_px = 0;  ///< largest |row_left - row_right| of the RPC projections (rectified)
  /// The RPC-consistent right position of a right rectified position.
  PixelPoint right_rpc(const PixelPoint& r) const {
    const PixelPoint x = right.inverse()(r);
    return {x.col + pointing[0], x.row + pointing[1]};
  }
};

/// Steps 1-2. `samples` x `samples` tile positions at `samples` heights (>= 2).
RpcRectification rectify_rpc_pair(const RpcCamera& left, const RpcCamera& right, const RpcTile& tile, int samples = 7);

/// The rectified image `width` x `height`: each pixel's centre mapped back by the inverse of
/// `to_rectified`, sampled bilinearly (NaN outside the image). Threads over rows.
FloatImage resample_rectified(const FloatImage& image, const Affine2& to_rectified, int width, int height);

/// A tie point: positions in the left and the right original images (the right as seen, without
/// the pointing correction), and its normalised cross-correlation.
struct TiePoint {
  PixelPoint left, right;
  double ncc = 0;
};

struct TiePointOptions {
  int step = 20;         ///< grid of left rectified pixels searched, px
  int half_window = 6;   ///< 13 x 13 patches
  int row_search = 3;    ///< rows searched across the epipolar line each side, px
  double min_ncc = 0.9;  ///< kept when the best NCC exceeds this
  double min_std = 10;   ///< patches flatter than this (grey levels, std) are skipped
  /// Patches whose gradient structure tensor has eigenvalues in a smaller ratio (one straight
  /// edge: ambiguous along it) are skipped (Shi & Tomasi's corner measure).
  double min_corner_ratio = 0.3;
  int disparity_margin = 2;  ///< searched beyond [min_disparity, max_disparity], px
};

/// Tie points by correlation in the rectified pair (as tests/rpc_test.cpp's, in rectified
/// geometry): for a grid of left pixels textured in every direction, the best NCC over the disparity range and
/// ±row_search rows, refined to sub-pixel by a parabola in each direction; returned in original positions.
std::vector<TiePoint> match_tie_points(const FloatImage& left_rectified, const FloatImage& right_rectified,
                                       const RpcRectification& rect, const TiePointOptions& options = {});

/// Signed epipolar errors of tie points: rectified row of the right minus of the left, px.
std::vector<double> epipolar_errors(const RpcRectification& rect, const std::vector<TiePoint>& ties);

/// Step 3: the rectification with the pointing correction estimated from `ties` (the median of
/// their epipolar errors, s2p) composed into its right map and stored in `pointing`.
RpcRectification correct_pointing(const RpcRectification& rect, const std::vector<TiePoint>& ties);

/// A triangulated point and its reprojection error (RMS of the 4 image residuals, px).
struct RpcStereoPoint {
  GeoPoint ground;
  double residual_px = 0;
};

/// Step 4: the least-squares intersection of the left pixel `a` and the right RPC-consistent
/// pixel `b` (at most 10 Gauss-Newton steps from `initial_height`; stops below 1e-6 m).
RpcStereoPoint triangulate_rpc(const RpcCamera& left, const RpcCamera& right, const PixelPoint& a, const PixelPoint& b,
                               double initial_height);

/// The points of a disparity map of the rectified tile (NaN skipped), row by row, those whose
/// residual is below max_residual_px. Threads over rows; the order does not depend on them.
std::vector<RpcStereoPoint> disparity_to_points(const RpcCamera& left, const RpcCamera& right,
                                                const RpcRectification& rect, const Disparity& disparity,
                                                double max_residual_px = 1.0);

// ---- a tile through the whole chain (src/stereo/rpc_tile_stereo.cpp) ------------------------
//
// What the satellite stage (satellite_dsm(), satellite_dsm.hpp) runs per tile of a pair, on
// image windows: the cameras passed are those of the windows (RpcCamera::crop), the tile is in
// the left window's pixels, and its height range is the heights searched (metres above the
// WGS 84 ellipsoid). Pure C++ and TBB (no GDAL).

/// The heights of the scene over a tile, from tie points searched across the tile's whole height
/// range (s2p's "sift" range, de Franchis et al. 2014: the disparity range of a tile is taken
/// from matched features rather than from a DEM): the tile rectified (steps 1-2), tie points
/// matched (match_tie_points), each triangulated through the RPCs (residual below 1 px kept).
/// Empty when nothing matched: the scene lies outside the height range, or the windows do not
/// show the same ground. Errors as rectify_rpc_pair().
std::vector<double> tie_point_heights(const RpcCamera& left, const FloatImage& left_image, const RpcCamera& right,
                                      const FloatImage& right_image, const RpcTile& tile,
                                      const TiePointOptions& options = {});

struct RpcTileStereoOptions {
  TiePointOptions ties;
  /// min_disparity and num_disparities are set per tile from the height range (the rectified
  /// RPC projections of the tile's volume, widened by 2 px each side).
  SgmOptions sgm;
  /// Left pixels matched beyond the tile on each side (clamped to the window), for SGM's paths;
  /// their points are dropped, so neighbouring tiles do not overlap in their output.
  int margin = 32;
  /// With fewer tie points the tile keeps the RPCs as given (no pointing correction).
  int min_tie_points = 10;
  int max_disparities = 512;     ///< ArgumentError("height range") when the range needs more
  double max_residual_px = 1.0;  ///< disparity_to_points' bound
};

struct RpcTileStereo {
  std::vector<RpcStereoPoint> points;  ///< of the tile's own left pixels, row by row of the rectified tile
  RpcRectification rect;               ///< with the pointing correction when there was one
  std::size_t tie_points = 0;
  bool pointing_corrected = false;
  std::size_t tile_pixels = 0;     ///< rectified pixels of the tile (margin excluded) inside the left image
  std::size_t matched_pixels = 0;  ///< of those, with a disparity after SGM's left-right check
  int min_disparity = 0, num_disparities = 0;
  double seconds_rectify = 0, seconds_pointing = 0, seconds_match = 0, seconds_triangulate = 0;
};

/// Steps 1-4 and SGM over one tile: rectification over tile ± margin, tie points and the
/// pointing correction (re-resampling the right image), SGM (stereo.hpp, left-right check
/// included) over the disparities of the height range, the disparities of the tile's own pixels
/// (pixels of no data in the left image masked) triangulated through the RPCs. A tile narrower
/// than its largest |disparity| gives no points (SGM's limit) rather than an error.
/// ArgumentError as rectify_rpc_pair(), and for images of no pixels. Threads: each stage over
/// rows (TBB); SGM's two sweeps. Memory: the two windows, four rectified images (4 bytes a
/// pixel) and SGM's (stereo.hpp).
RpcTileStereo rpc_tile_stereo(const RpcCamera& left, const FloatImage& left_image, const RpcCamera& right,
                              const FloatImage& right_image, const RpcTile& tile,
                              const RpcTileStereoOptions& options = {});

}  // namespace dsmplan
