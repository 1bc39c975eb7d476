// dsmplan/stereo_frames.hpp: a DSM from frame-camera images with known poses (issue 16), the
// pipeline of Adolf & Hirschmüller, Section 2: pair selection, epipolar rectification, dense
// matching by Semi-Global Matching (stereo.hpp), triangulation, ortho-projection of every pair's
// points into the DSM grid and the median per cell.
//
// Camera model (OpenCV's convention, the CAMERAS.json contract of `dsmplan stereo`):
//   x_cam = R (X - C)           R: world -> camera (rows: the camera's x, y, z axes in world
//                               coordinates), C: the projection centre, world units (metres);
//   x = x_cam/z_cam, y = y_cam/z_cam   (a point is seen only when z_cam > 0)
//   Brown–Conrady distortion of the normalised coordinates, r² = x² + y²:
//     x' = x (1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2 x²)
//     y' = y (1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2 y²) + 2 p2 x y
//   u = fx x' + cx,  v = fy y' + cy  (pixels; the centre of the top-left pixel is (0, 0)).
//   Camera x right, y down, z forward (the viewing direction).
//
// Images are grey, float intensities (any scale; 8- and 16-bit images keep their values),
// row-major, pixel (x, y) = column x, row y.
//
// Parts (each its own source file in src/stereo, pure C++ and TBB; no GDAL):
//   frame_camera.cpp   project(), undistort(), pixel rays;
//   rectify_pair.cpp   epipolar rectification (Fusiello, Trucco & Verri 2000) and resampling;
//   disparity_windows.cpp a search wider than one SGM pass, split into windows and merged;
//   triangulate.cpp    disparities to world points through the rectified cameras;
//   fuse_median.cpp    ortho-projection and the median per cell (MedianFusion, median_fusion.hpp);
//   select_pairs.cpp   `auto` and explicit pairs, overlap and base-to-height ratio;
//   height_range.cpp   the scene's height range from a coarse pass, when it is not given;
//   frame_pipeline.cpp the whole chain for a set of cameras and images (stereo_dsm()).
//
// Guarantees. Rectification is exact up to rounding: a world point projects into the same row of
// both rectified cameras (tested < 0.01 px; about 1e-13 px in double) and triangulate() returns it
// (< 1 mm; about 1e-13 m). The result does not depend on the number of threads (SGM's guarantee;
// triangulation keeps row order; the fusion sorts). Accuracy on rendered views of the real NRW DSM:
// docs/stereo.md, "Stereo from frame cameras".
//
// Memory. Per pair: the two rectified images (5 bytes a pixel each, float + mask) and SGM's
// (stereo.hpp, in bands under its memory bound); for all pairs: 24 bytes per triangulated point,
// kept until the fusion, plus 12 bytes per point during it.
//
// Errors: ArgumentError / InputError (core.hpp), naming the camera ("camera 3") and the problem.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/median_fusion.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/stereo.hpp"

namespace dsmplan {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<std::array<double, 3>, 3>;  ///< row-major: m[row][col]

/// A calibrated frame camera: pinhole with optional Brown–Conrady distortion (see above).
struct FrameCamera {
  int width = 0, height = 0;                         ///< image size, pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;             ///< focal lengths and principal point, pixels
  std::array<double, 5> distortion{0, 0, 0, 0, 0};   ///< k1, k2, p1, p2, k3 (OpenCV's order)
  Mat3 rotation{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};  ///< R, world -> camera
  Vec3 center{0, 0, 0};                              ///< C, world coordinates
  bool distorted() const {
    for (double k : distortion)
      if (k != 0) return true;
    return false;
  }
};

/// ArgumentError naming `name` ("camera 2") when the camera cannot be used: size < 1, focal
/// lengths not positive and finite, a rotation that is not orthonormal with determinant +1
/// (tolerance 1e-6), anything non-finite.
void check_camera(const FrameCamera& camera, const std::string& name);

/// Normalised distorted coordinates (x', y') of the undistorted (x, y) (the formula above).
std::array<double, 2> distort(const FrameCamera& camera, double x, double y);
/// The inverse of distort(): Newton's method from (x', y'), at most 20 steps, to 1e-12. For the
/// distortion of real lenses within the image (|r| < 1.5) it converges; returns the last iterate.
std::array<double, 2> undistort(const FrameCamera& camera, double xd, double yd);

/// The pixel (u, v) of world point X; false (u, v untouched) when X is not in front (z_cam <= 0).
/// Pixels outside the image are returned too: the caller checks the bounds.
bool project(const FrameCamera& camera, const Vec3& X, double& u, double& v);
/// The unit direction, world coordinates, of the ray through pixel (u, v) (undistorted).
Vec3 pixel_ray(const FrameCamera& camera, double u, double v);

/// A grey image in memory, owned.
struct GreyImage {
  int width = 0, height = 0;
  std::vector<float> pixels;  ///< row-major
  float at(int x, int y) const { return pixels[static_cast<std::size_t>(y) * width + x]; }
  /// Bilinear value at (x, y) (pixel centres at integers); false outside [0, width-1] x [0, height-1].
  bool sample(double x, double y, float& value) const;
};

/// Options of the rectification.
struct RectifyOptions {
  /// World heights (Z) the scene lies between: they bound the disparity search. Required finite.
  double min_height = 0, max_height = 0;
  /// > 0: the heights are not used; the search is disparities [0, D) with shift 0, i.e. every
  /// depth from f·B/D to infinity, D = this rounded down to a multiple of 16 and below the
  /// rectified width (the coarse pass of estimate_height_range(), which knows no heights yet).
  int unbounded_depth_disparities = 0;
  /// Bound on the rectified images' sides, as a multiple of the larger original side.
  double max_size_factor = 2.0;
  int max_disparities = 512;  ///< one SGM search's disparities at most (a window's)
  /// The search may be split into at most this many windows of max_disparities each
  /// (disparity_windows()); InputError when the height range needs more than their product
  /// (stereo_dsm() then leaves the pair out), or more than the rectified width.
  int max_windows = 1;
};

/// A rectified pair (Fusiello, Trucco & Verri 2000): two cameras with the same orientation
/// (x axis along the baseline C_right - C_left), no distortion, the same focal length f and row
/// centre cy, so a world point is seen in the same row of both images. The column centres
/// differ (cx_right - cx_left = shift) so that the scene's heights fall into disparities
/// [0, num_disparities): a left pixel (u, v) with disparity d (right pixel (u - d, v)) lies at
/// depth z = f·B / (d + shift) in the rectified frame, B = |C_right - C_left|.
struct RectifiedPair {
  FrameCamera left, right;  ///< the rectified cameras (size = the rectified images')
  GreyImage left_image, right_image;
  std::vector<unsigned char> left_mask, right_mask;  ///< 1 where the pixel comes from the original image
  double baseline = 0;                               ///< B, world units
  double shift = 0;                                  ///< cx_right - cx_left, pixels
  int num_disparities = 0;  ///< the search range for sgm_match (min_disparity 0), multiple of 16
};

/// Rectifies the pair (left, right) and resamples both images (bilinear) into it. The depth
/// range is taken from rays through a 9 x 9 lattice of left pixels cut with the planes Z =
/// min_height and Z = max_height (10 % margin). The rectified images have the left image's
/// columns and both images' rows as the rectified cameras see them, each side at most
/// max_size_factor times the larger original side. Throws ArgumentError for a bad camera or
/// options, InputError ("cameras: ...") when the centres coincide, the baseline is along the
/// left viewing direction, or the range needs more than max_disparities (stereo_dsm() names the
/// two cameras). Time and memory O(rectified pixels), 5 bytes each per image.
RectifiedPair rectify_pair(const FrameCamera& left, const GreyImage& left_image, const FrameCamera& right,
                           const GreyImage& right_image, const RectifyOptions& options);
/// rectify_pair() in two steps, for images too large to rectify whole: rectify_cameras() is the
/// geometry alone (the same errors, no images: O(1)); rectify_rows() resamples rows
/// [row0, row0 + rows) of its rectified images, as a pair whose cameras are moved up by row0
/// (cy - row0), so triangulate() and sgm_match work on the band as on a whole pair. Rows agree
/// between both images, so a band of the left image needs only the same band of the right.
/// rectify_rows() throws ArgumentError for rows outside the images. Memory O(band pixels).
RectifiedPair rectify_cameras(const FrameCamera& left, const FrameCamera& right, const RectifyOptions& options);
RectifiedPair rectify_rows(const RectifiedPair& cameras, const FrameCamera& left, const GreyImage& left_image,
                           const FrameCamera& right, const GreyImage& right_image, int row0, int rows);

/// Why the pair (left, right) cannot be rectified with `options` (rectify_cameras()'s InputError,
/// without its "cameras: "), or empty when it can: stereo_dsm() leaves such a pair out. O(1).
std::string pair_problem(const FrameCamera& left, const FrameCamera& right, const RectifyOptions& options);

/// One window of a disparity search split by disparity_windows(): SGM searches
/// [min_disparity, min_disparity + num_disparities) and answers for disparities in [keep_begin,
/// keep_end) only (its core; infinite at the range's own ends).
struct DisparityWindow {
  int min_disparity = 0, num_disparities = 0;
  double keep_begin = 0, keep_end = 0;
};
/// Disparities a window searches beyond its core on either side.
constexpr int kWindowMargin = 16;
/// The search [0, num_disparities): one window when it fits `budget`, else the fewest windows of
/// at most `budget` disparities whose cores tile the range, each searching kWindowMargin more on
/// either side (within the range). ArgumentError for num_disparities < 1, or a split asked of a
/// budget under 4 kWindowMargin.
std::vector<DisparityWindow> disparity_windows(int num_disparities, int budget);
/// Folds one window's left disparities into `merged` (NaN where nothing yet; same size): a valid
/// disparity inside the window's core is taken where no other window answered (claimed 0 -> 1),
/// and a pixel two windows answer for is made NaN (claimed 2: one of them is wrong). Returns the
/// pixels newly made NaN so.
std::size_t merge_window(const std::vector<float>& window, const DisparityWindow& w, std::vector<float>& merged,
                         std::vector<unsigned char>& claimed);

/// An image as an SGM input: 16-bit, values rounded and clamped to 0..65535 (8-bit images keep
/// their 0..255, which sgm_match's automatic intensity_unit treats as 8-bit).
std::vector<std::uint16_t> to_uint16(const GreyImage& image);

/// The world point of left rectified pixel (u, v) with disparity d; false when d + shift <= 0.
bool triangulate(const RectifiedPair& pair, double u, double v, double d, Vec3& X);
/// Every valid left pixel's world point (NaN disparities, pixels outside either original image,
/// and points behind either camera skipped), row by row, of the rows [row_begin, row_end) (clamped
/// to the image; all by default). O(pixels of those rows).
std::vector<Vec3> triangulate(const RectifiedPair& pair, const Disparity& disparity, int row_begin = 0,
                              int row_end = std::numeric_limits<int>::max());

// ---- CAMERAS.json: the cameras of `dsmplan stereo --cameras` (docs/stereo.md, "Stereo from frame cameras")

struct CameraFile {
  std::string path;  ///< the file read (the one the pipeline's errors name)
  std::string crs;   ///< as written ("EPSG:25832", WKT): the job resolves and checks it
  bool has_height_range = false;
  double min_height = 0, max_height = 0;
  std::vector<FrameCamera> cameras;
  std::vector<std::string> images;  ///< paths as resolved against the JSON's folder
};
/// Reads CAMERAS.json whole: crs, the optional height_range, and at least two cameras each with
/// image, width, height, fx, fy, cx, cy, optional distortion, rotation and center, every camera
/// checked (check_camera()). InputError naming the file and the key (e.g. "cameras[2].fx") for
/// anything missing, malformed or out of range, for a file that is not JSON, or is no file or
/// over 64 MB (require_input_file()). Opens no image.
CameraFile read_camera_file(const std::string& path);

/// The coarsest DSM cell stereo makes, CRS units (metres): 10 km.
constexpr double kMaxDsmResolution = 1e4;

/// The DSM grid of `bounds` (xmin, ymin, xmax, ymax, world units) at cell size `resolution`:
/// cell (0, 0) touches (xmin, ymax); width = ceil((xmax - xmin)/res), height likewise.
/// ArgumentError("resolution") outside (0, kMaxDsmResolution]; ArgumentError("bounds") for
/// bounds not increasing, more than 4e9 cells, or a grid dsmplan's readers would refuse
/// (frame_problem(): beyond 1e9 CRS units, cells too fine for their coordinates), so that
/// nothing is matched into a raster that cannot be read back.
Grid dsm_grid(const std::array<double, 4>& bounds, double resolution);
/// dsm_grid() over bounds a job found itself, the pairs' common footprint (not bounds the user
/// gave): its refusals are InputError(cameras) naming the footprint, since the cameras in the
/// file `cameras` (a CAMERAS.json, a satellite image) put it there, not a flag.
Grid footprint_grid(const std::array<double, 4>& bounds, double resolution, const std::string& cameras);
/// The grid a stereo job makes and the bounds it stands for: `bounds` when given (InputError
/// naming `file` and "--bounds" when they miss `footprint`: "lies outside every pair's " +
/// `footprint_name`), else `footprint` widened to whole multiples of `resolution`
/// (footprint_grid()). Errors of dsm_grid() and footprint_grid().
struct DsmExtent {
  std::array<double, 4> bounds{};
  Grid grid;
};
DsmExtent dsm_extent(const std::array<double, 4>& footprint, const std::optional<std::array<double, 4>>& bounds,
                     double resolution, const std::string& file, const std::string& footprint_name);
/// Called by the stereo entry points with the DSM's grid (geometry only) as soon as it is known,
/// before any matching: where the job checks that it can hold and write it (require_memory()).
using GridCheck = std::function<void(const Grid& grid)>;
/// Ortho-projection and fusion (the paper's Section 2): each point falls into the cell holding
/// its (x, y); each cell gets the median of its heights (the mean of the two middle ones for an
/// even count), nodata where none fell. `grid` gives the geometry; its heights are replaced.
/// Returns the number of points that fell into the grid. O(n log n). MedianFusion (median_fusion.hpp)
/// does the same with the points handed over as they come, in bounded memory.
std::size_t fuse_median(Grid& grid, const std::vector<std::vector<Vec3>>& point_sets);

/// What pair selection needs of the scene.
struct PairSelectionOptions {
  double ground_height = 0;  ///< the plane footprints are cut with (e.g. mid of the height range)
  double min_overlap = 0.3;  ///< share of the left footprint seen by the right camera, (0, 1]
  double min_base_to_height = 0.1, max_base_to_height = 1.2;
  /// Each camera's best partners kept (by overlap, a B/H under 0.3 counting less): at most
  /// max_partners x cameras pairs, so the matching grows with the views, not their square.
  int max_partners = 4;
};
/// The least base-to-height ratio a pair given by name (--pairs) may have: below it (a 5 cm base
/// 300 m up) the two rays of a point are parallel to rounding, and the heights come out at the
/// cameras' own height; such a pair is refused, not matched.
constexpr double kMinPairBaseToHeight = 0.02;
/// The share (0..1) of a 16 x 16 lattice of left pixels whose rays, cut with Z = ground_height,
/// the right camera sees inside its image.
double footprint_overlap(const FrameCamera& left, const FrameCamera& right, double ground_height);
/// The bounding box (xmin, ymin, xmax, ymax) on the plane Z = ground_height of the ground points
/// of a 65 x 65 lattice of left pixels, from the first pixel centre to the last, that the right
/// camera sees within its pixel centres; false when it sees none. A DSM's extent (the common
/// footprint of a pair), where footprint_overlap() is a share for pair selection.
bool footprint_box(const FrameCamera& left, const FrameCamera& right, double ground_height, std::array<double, 4>& box);
/// Base-to-height ratio: |C_l - C_r| / (mean camera height above ground_height).
double base_to_height(const FrameCamera& left, const FrameCamera& right, double ground_height);
/// The box (xmin, ymin, xmax, ymax) on the plane Z = ground_height holding what the camera sees
/// within its image's area: the rays of 16 points a side of the area's border, widened by 5 %
/// a side (a distorted edge bows between them); infinite when a border ray misses the plane.
std::array<double, 4> ground_box(const FrameCamera& camera, double ground_height);
/// Each camera's candidates, ranked by how much their ground boxes share, whose footprints
/// select_pairs_auto() cuts exactly: kCutPerPartner x max_partners.
constexpr int kCutPerPartner = 3;
/// What select_pairs_auto() did: pairs whose ground boxes met, pairs whose footprints it cut.
struct PairSelectionStats {
  std::size_t boxes_met = 0, footprints_cut = 0;
};
/// `auto`: the pairs (i < j) with overlap >= min_overlap both ways and a ratio within the
/// bounds, each camera keeping its max_partners best (a pair kept by either camera is kept): at
/// most max_partners x cameras pairs, each camera choosing at most max_partners.
/// Cost, n cameras: the ground boxes (O(n)) met by a sweep along x (O(n log n + m) for the m
/// pairs whose boxes meet: a few comparisons each, and the B/H test), then the footprints cut
/// (footprint_overlap(), both ways) of each camera's kCutPerPartner x max_partners candidates
/// sharing the most of their boxes: at most 12 n pairs cut by default, whatever n. Pairs whose
/// boxes do not meet cannot overlap, so the choice is the one of comparing every pair whenever no
/// camera has more than 12 candidates within the B/H bounds (checked against brute force in
/// tests/stereo_pipeline_test.cpp); beyond, a partner ranked below them by its box is not cut.
/// ArgumentError for max_partners < 1 or min_overlap outside (0, 1].
std::vector<std::pair<int, int>> select_pairs_auto(const std::vector<FrameCamera>& cameras,
                                                   const PairSelectionOptions& options,
                                                   PairSelectionStats* stats = nullptr);
/// ArgumentError("pairs") naming the first of `pairs` whose base-to-height ratio over
/// `ground_height` is under kMinPairBaseToHeight (its base and height in the message).
void check_pair_baselines(const std::vector<FrameCamera>& cameras, const std::vector<std::pair<int, int>>& pairs,
                          double ground_height);
/// "0-1,1-2": explicit pairs. ArgumentError (`flag`) for a bad token, an index out of range or i == j.
std::vector<std::pair<int, int>> parse_pairs(const std::string& text, int cameras, const std::string& flag = "--pairs");

// ---- the scene's heights, when nobody gave them ---------------------------------------------

/// Options of estimate_height_range().
struct HeightRangeOptions {
  /// The first pass's images: both images of a pair shrunk by one whole factor s (box filter)
  /// until their longer side is at most this; the search covers every depth from f·B/D on.
  int coarse_side = 320;
  /// The second pass's images, searching only the first pass's heights: at most this side (or
  /// coarser, down to coarse_side, while that search needs more than max_disparities).
  int fine_side = 640;
  int max_disparities = 256;  ///< D, one pass's search at most
  int speckle_pixels = 25;    ///< both passes' SGM speckle filter, pixels (small roofs count)
  /// The second pass's points are binned in cells of this many of its pixels a side; a cell with
  /// at least cell_points points counts with its median height.
  double cell_pixels = 3;
  int cell_points = 4;
  /// A pair's lowest (highest) height: the lowest (highest) median this many cells share to
  /// within one disparity step of the second pass (a lone cell is not the scene's end).
  int cluster_cells = 3;
  /// The second pass runs both ways (each camera left once). A pair's cells connected to its
  /// median cell through heights at most this many disparity steps of the second pass (plus 1 m)
  /// apart are the scene, and so is a cluster of heights apart from them that both ways matched;
  /// a cluster only one way matched is a clump of mismatches.
  double cell_gap = 3;
  /// The lowest and highest heights, widened on each side by this share of their difference
  /// (what matching misses: a chimney above its roof, a pit below its street) plus `fine_steps`
  /// times the height of one disparity step of the second pass (0: within the share on the
  /// rendered blocks of tests/stereo_height_range_test.cpp).
  double margin_share = 0.10;
  double fine_steps = 0.0;
};

/// What estimate_height_range() found.
struct HeightRangeEstimate {
  double min_height = 0, max_height = 0;   ///< the range to use (margins included)
  double low = 0, high = 0;                ///< the cells' lowest and highest medians (no margin)
  double search_low = 0, search_high = 0;  ///< the first pass's bound on the second's search
  double coarse_step = 0, fine_step = 0;   ///< largest height of one disparity step of each pass
  std::vector<std::pair<int, int>> pairs;  ///< the pairs that gave points in the second pass
  std::size_t points = 0;                  ///< the second pass's points
  std::size_t cells = 0;                   ///< cells with a median
  int scale = 1;                           ///< largest shrink factor of the second pass
};

/// The pairs estimate_height_range() matches: for every camera its nearest other camera (centre
/// distance: the most overlap), each pair once, nearest first, at most `max_pairs` of them. Every
/// camera is in one by default, so every part of a block is seen (at most n pairs for n views).
std::vector<std::pair<int, int>> height_range_pairs(const std::vector<FrameCamera>& cameras,
                                                    int max_pairs = std::numeric_limits<int>::max());

/// The scene's height range from the images alone (no height known beforehand), pair by pair:
/// a first pass over the shrunk images (HeightRangeOptions::coarse_side) searches every depth
/// from f·B/D to infinity (RectifyOptions::unbounded_depth_disparities) and bounds a second,
/// finer pass (fine_side) that searches only that bound; both are SGM with its left-right check.
/// The second pass's heights, binned in cells, give each cell's median; the lowest and highest
/// medians of all pairs, widened by the margins, are the range. `image(i)` gives camera i's
/// image (read when its pair's turn comes: one pair's images are held at a time).
/// A pair that cannot be rectified or gives too few points is skipped; InputError ("cameras: ...")
/// when none is left. Time: two SGMs of shrunk images per pair.
using CameraImages = std::function<std::shared_ptr<const GreyImage>(int camera)>;
HeightRangeEstimate estimate_height_range(const std::vector<FrameCamera>& cameras, const CameraImages& image,
                                          const std::vector<std::pair<int, int>>& pairs,
                                          const HeightRangeOptions& options = {});
/// The same with every image in memory: images[i] must be set for the cameras of `pairs`.
HeightRangeEstimate estimate_height_range(const std::vector<FrameCamera>& cameras, const std::vector<GreyImage>& images,
                                          const std::vector<std::pair<int, int>>& pairs,
                                          const HeightRangeOptions& options = {});

// ---- the whole chain ------------------------------------------------------------------------

/// A dense matcher in place of dsmplan's SGM (for comparisons, e.g. OpenCV's StereoSGBM in
/// bench_stereo): the rectified pair (16-bit, from to_uint16()) and the options with the pair's
/// disparity range in, disparities in stereo.hpp's convention out (left image's, NaN = invalid).
using DenseMatcher = std::function<Disparity(const ImageView& left, const ImageView& right, const SgmOptions& options)>;

struct FrameStereoOptions {
  /// min_height, max_height: the scene's heights. Each pair is searched from its own smallest
  /// disparity (RectifiedPair::shift); a search wider than max_disparities (512) is split into at
  /// most max_windows (here 4) windows (disparity_windows(): time grows with the windows, memory
  /// stays one window's); a pair that needs more, or cannot be rectified, is left out.
  RectifyOptions rectify{.max_windows = 4};
  SgmOptions sgm;              ///< num_disparities and min_disparity are set per pair
  DenseMatcher matcher;        ///< empty: dsmplan's SGM (SgmMatcher, its buffer kept between pairs)
  MedianFusionOptions fusion;  ///< the points' memory budget (median_fusion.hpp)
  /// Memory for one band of a pair, bytes: a pair whose rectified images need more (SGM's 2 bytes
  /// a pixel and disparity, about 24 bytes a pixel for the images and disparities) is rectified,
  /// matched, triangulated and fused in bands of rows that fit, each with band_margin more rows
  /// above and below for SGM's paths to enter the band (their disparities are dropped). Memory
  /// is then O(band_bytes) instead of O(rectified pixels x disparities); the disparities near a
  /// band's border can differ from a whole-image match (paths cut at the margin).
  std::size_t band_bytes = std::size_t{1} << 30;
  int band_rows = 0;  ///< > 0: bands of this many rows, whatever band_bytes says (at least 16)
  int band_margin = 64;
};

/// One pair of a stereo_dsm() run: matched, or left out and why.
struct FramePairStats {
  int left = 0, right = 0;  ///< the cameras
  bool used = false;        ///< matched; false: left out (`problem`)
  std::string problem;      ///< why it was left out, e.g. "the height range needs 2400 disparities, ..."
  double shift = 0;         ///< the pair's disparity offset, px: disparities shift + [0, num_disparities)
  int num_disparities = 0;  ///< its whole search
  int windows = 0;          ///< SGM passes the search was split into (1: not split)
  std::size_t pixels = 0;   ///< left rectified pixels taken from the original image: what could match
  std::size_t matched_pixels = 0, points = 0;
  std::size_t window_conflicts = 0;  ///< pixels two windows answered for, dropped (disparity_windows.cpp)
};

struct FrameStereoStats {
  std::size_t pairs = 0, matched_pixels = 0, points = 0, points_in_grid = 0, valid_cells = 0;
  std::size_t points_outside_range = 0;  ///< more than 10 % of the height range outside it: dropped
  std::size_t bands = 0;  ///< rectified bands matched, all pairs (one a pair when none is taller than band_rows)
  std::size_t fusion_runs_spilled = 0;  ///< runs the fusion wrote to disk (0: all points fitted in memory)
  double seconds_rectify = 0, seconds_match = 0, seconds_triangulate = 0, seconds_fuse = 0;
  std::vector<FramePairStats> pair_stats;  ///< one per pair given, in order; `pairs` counts the used
};

/// Every pair rectified, matched (sgm_match; in disparity windows when its search is wider than
/// options.rectify.max_disparities), triangulated, its points more than 10 % of the
/// height range outside that range dropped (options.rectify: the scene is stated to lie within
/// it), each pair's points handed to a MedianFusion as they are made, then fused into `grid`
/// (its geometry as given). A pair whose rectified images are taller than options.band_rows is
/// rectified and matched in bands of rows (FrameStereoOptions). images[i] belongs to cameras[i]
/// and must have its size (InputError "camera i: image is W x H, the camera says ..."). Progress
/// per pair. Memory: the images given, one band (rectified images, SGM, disparities) and the
/// fusion's budget. A pair that cannot be rectified (pair_problem()) is left out and listed in
/// pair_stats with its problem; InputError ("cameras: no pair left to match (...)", each pair's
/// problem) when every pair is.
FrameStereoStats stereo_dsm(const std::vector<FrameCamera>& cameras, const std::vector<GreyImage>& images,
                            const std::vector<std::pair<int, int>>& pairs, Grid& grid,
                            const FrameStereoOptions& options, const Progress& progress = {});

/// The image of camera i, read when a pair first needs it (e.g. from a file); null is an
/// ArgumentError.
using ImageSource = std::function<std::shared_ptr<const GreyImage>(int camera)>;
/// stereo_dsm() with the images read on demand: only the current pair's two are held (one kept
/// for the next pair when it shares it), so memory is two images, one band and the fusion's
/// budget, whatever the number of cameras. The size check happens when an image is read.
FrameStereoStats stereo_dsm(const std::vector<FrameCamera>& cameras, const ImageSource& images,
                            const std::vector<std::pair<int, int>>& pairs, Grid& grid,
                            const FrameStereoOptions& options, const Progress& progress = {});

}  // namespace dsmplan
