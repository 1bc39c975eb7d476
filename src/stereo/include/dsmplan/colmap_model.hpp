// dsmplan/colmap_model.hpp: cameras from structure-from-motion (issue 34, point 4): COLMAP's
// text model read into the frame cameras of stereo_frames.hpp, and put into a CRS by a similarity
// transform, given or fitted to the cameras' known centres (Umeyama 1991). `dsmplan stereo
// --colmap MODEL_DIR` builds from it the same camera list a CAMERAS.json gives, and runs the
// pipeline unchanged (frame_dsm.hpp).
//
// The model (COLMAP's "Output Format", https://colmap.github.io/format.html; COLMAP's
// src/colmap/sensor/models.h for the cameras; `colmap model_converter --output_type TXT` writes
// it from a binary model):
//   cameras.txt  CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]       one line a camera;
//   images.txt   IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, then one line of 2D points (skipped,
//                even when empty, as COLMAP's own reader does); '#' lines and blank lines between
//                images are comments.
// Mapping, exact: (QW, QX, QY, QZ) is a Hamilton quaternion of R, world -> camera, and x_cam = R X
// + t (TX, TY, TZ), so C = -Rᵀ t; the camera axes are ours (x right, y down, z forward). COLMAP's
// pixel centres lie at half-integers (the top-left pixel's centre is (0.5, 0.5)), ours at
// integers: cx = cx_colmap - 0.5, cy likewise. The distortion models, with COLMAP's parameters:
//   SIMPLE_PINHOLE f, cx, cy              fx = fy = f, no distortion;
//   PINHOLE        fx, fy, cx, cy         no distortion;
//   SIMPLE_RADIAL  f, cx, cy, k           k1 = k;
//   RADIAL         f, cx, cy, k1, k2      k1, k2;
//   OPENCV         fx, fy, cx, cy, k1, k2, p1, p2   the same Brown–Conrady terms as ours;
//   FULL_OPENCV    ... k1, k2, p1, p2, k3, k4, k5, k6  only with k4 = k5 = k6 = 0 (no rational part).
// Any other model (the fisheye ones, FOV, THIN_PRISM_FISHEYE, ...) is refused in one line naming
// the line: it cannot be written as ours; `colmap image_undistorter` makes PINHOLE images of it.
// Camera i of the pipeline is the i-th image of images.txt, in the file's order.
//
// Into the CRS: X_crs = s Q X_model + T (s > 0, Q a rotation). A camera becomes R' = R Qᵀ, C' =
// s Q C + T; its focal lengths, principal point and distortion (pixels, normalised coordinates)
// do not change. s, Q, T come from a --transform file or are fitted to --centres (Umeyama,
// "Least-squares estimation of transformation parameters between two point patterns", IEEE
// PAMI 13(4), 1991: the closed form minimising Σ |y - (s Q x + T)|²). The fit is refused when
// fewer than 3 centres match the model's images, when the centres lie nearly on a line (the spread
// across it under 1 % of the spread along it: the rotation about the line is not determined), or
// when its RMS residual exceeds max(0.5 m, 1 % of the extent of the centres, the diagonal of their
// bounding box): a wrong centre or a model that is not the block. The centres may come from the
// images' EXIF GPS instead (--centres exif: src/geo reads and converts them, ExifCentres below),
// or ground control points may replace them (--gcps: each point triangulated in the model's frame
// from its pixels, Hartley & Zisserman Section 12.2, multiview_triangulate.cpp; the same fit and
// bound over the points). docs/stereo.md has the files' layouts.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {

/// One registered image of the model: its camera in the model's frame, as FrameCamera.
struct ColmapImage {
  long long id = 0;
  std::string name;  ///< NAME, relative to the images folder
  FrameCamera camera;
};

/// Reads MODEL_DIR/cameras.txt and MODEL_DIR/images.txt. InputError naming the file and "line N"
/// for a line with too few fields or a bad number, an unknown or unrepresentable model, a camera
/// the image refers to that cameras.txt lacks, a duplicate id, a quaternion far from unit length
/// (|q| off 1 by more than 1e-3; it is normalised), a camera check_camera() refuses; naming the
/// file for a missing one (with the model_converter hint when cameras.bin is there) or fewer than
/// two images. Memory: the cameras, not the 2D points.
std::vector<ColmapImage> read_colmap_model(const std::string& model_dir);

/// X' = scale · rotation · X + translation.
struct Similarity {
  double scale = 1;
  Mat3 rotation{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  Vec3 translation{0, 0, 0};
  Vec3 apply(const Vec3& x) const;
};

/// The camera seen from the transformed world: R' = R Qᵀ, C' = s Q C + T; intrinsics kept.
FrameCamera transformed(const FrameCamera& camera, const Similarity& transform);

/// A --transform file, model -> CRS: whitespace- or comma-separated numbers, '#' to the end of a
/// line a comment; 16 (a 4 x 4 matrix by rows, [sQ | T; 0 0 0 1]), 12 (its first three rows) or 13
/// (s, then Q by rows, then T). InputError naming the file for another count, a bad number, a last
/// row other than 0 0 0 1, or a 3 x 3 part that is not a positive scale times a rotation (1e-6).
Similarity read_similarity(const std::string& path);

/// One row of a --centres CSV: `image,x,y,z`, the camera centre in the CRS.
struct CentreRow {
  std::string image;
  Vec3 position{};
  int line = 0;
};
/// Reads a centres CSV: one `image,x,y,z` a line, an optional header line first (its x not a
/// number), '#' lines and blank lines skipped. InputError naming the file and "line N" for a line
/// with another number of fields, a bad number or an image given twice.
std::vector<CentreRow> read_centres(const std::string& path);

/// One point of a --gcps CSV: its position in the CRS and its pixels in the images.
struct GcpObservation {
  std::string image;
  double u = 0, v = 0;  ///< pixel; the centre of the top-left pixel is (0, 0), as in CAMERAS.json
  int line = 0;
};
struct GcpPoint {
  std::string name;  ///< the `point` column, else "x,y,z" as written
  Vec3 position{};
  std::vector<GcpObservation> observations;  ///< in the file's order
  int line = 0;                              ///< its first row
};
/// Reads a ground control points CSV: a header line naming the columns, then one row per
/// observation (a point in one image). Columns, in any order, case-insensitive: x, y, z (the point
/// in the CRS), image (a NAME of images.txt, or its file name), u, v (the pixel, dsmplan's
/// convention: the centre of the top-left pixel is (0, 0), COLMAP's (0.5, 0.5) less half a pixel),
/// and optionally point (its name); other columns are ignored. Rows of one point share its name, or
/// without a point column the same x, y, z. '#' lines and blank lines skipped. InputError naming
/// the file and "line N" for a header without x, y, z, image, u or v, a row with another number of
/// fields, a bad number, a named point given other x, y, z than its first row, a point seen twice in
/// one image; the file for no rows.
std::vector<GcpPoint> read_gcps(const std::string& path);

/// A point triangulated from its pixels in several views (multiview_triangulate.cpp).
struct ViewTriangulation {
  Vec3 point{};
  bool finite = true;           ///< false: the rays are parallel (a point at infinity); point unset
  double ray_angle = 0;         ///< the widest angle between two of its rays, radians
  double max_reprojection = 0;  ///< pixels, the largest distance from a view's pixel to the point's projection
  int worst = -1;               ///< the view of max_reprojection
  int behind = -1;              ///< a view the point lies behind (max_reprojection infinite), else -1
};
/// The linear (DLT) triangulation of Hartley & Zisserman, Section 12.2, from the pixels (u, v) of
/// one point in `cameras` (their distortion undone first), the world normalised to the cameras'
/// centres. ArgumentError for fewer than two views or sizes that differ. O(views).
ViewTriangulation triangulate_views(const std::vector<FrameCamera>& cameras,
                                    const std::vector<std::array<double, 2>>& pixels);
/// A ground control point is refused when its rays meet at less than this angle (radians, 0.2°)...
constexpr double kMinGcpRayAngle = 0.2 * 3.14159265358979323846 / 180;
/// ... or when a view's pixel lies further than this from the triangulated point's projection.
constexpr double kMaxGcpReprojection = 10;

/// Umeyama's closed form: the s, Q, T minimising Σ |to_i - (s Q from_i + T)|², Q a proper
/// rotation. ArgumentError for fewer than 3 points or sizes that differ.
Similarity fit_similarity(const std::vector<Vec3>& from, const std::vector<Vec3>& to);

/// The least bound on the fit's RMS residual, metres, and the share of the centres' extent that
/// raises it.
constexpr double kMinFitBound = 0.5;
constexpr double kFitBoundShare = 0.01;

/// How the model was put in the CRS: --stats' "georeference".
struct Georeference {
  std::string method;               ///< "centres", "exif" or "gcps" (fitted), "transform" (given)
  std::size_t centres = 0;          ///< centres matched to the model's images (0: none given)
  std::size_t gcps = 0;             ///< ground control points triangulated (0: none given)
  double gcp_reprojection_max = 0;  ///< pixels, the largest of the GCPs' triangulations
  std::string residuals_at;         ///< "centres", "gcps" or "" (none): where rms and max were measured
  std::string heights;              ///< --centres exif: what the centres' heights are and how they were converted
  double scale = 1;                 ///< s
  double rms = 0, max = 0;          ///< residuals at the centres, CRS units (0 without centres)
  std::string worst;                ///< the image (centres) or point (GCPs) of the largest residual
  double bound = 0;                 ///< the RMS bound applied
};

/// What `--colmap` needs: the model, where its images are, the CRS and how to get there.
struct ColmapOptions {
  std::string model;      ///< MODEL_DIR (cameras.txt, images.txt)
  std::string centres;    ///< CSV of image,x,y,z in `crs`, or kExifCentres: the images' EXIF GPS
  std::string transform;  ///< model -> CRS (read_similarity()); with centres or GCPs, checked, not fitted
  std::string gcps;       ///< CSV of ground control points (read_gcps()) in `crs`, instead of centres
  std::string crs;        ///< the centres' and the DSM's CRS ("EPSG:25832")
  /// The images' folder; empty: the `image_path=` of MODEL_DIR/project.ini (written by COLMAP's
  /// mapper) when that folder exists (relative: to the current directory, as COLMAP ran), else
  /// MODEL_DIR/../images when a folder, else MODEL_DIR.
  std::string images;
};
/// ArgumentError naming the flag: --colmap empty, --crs empty, none of --centres, --gcps and
/// --transform, both --centres and --gcps.
void check(const ColmapOptions& options);

/// The model as the pipeline's camera list: `file.path` is MODEL_DIR/images.txt (the name the
/// pipeline's errors give), `crs` the options', no height range (estimated), images resolved in
/// the images folder; and how it was georeferenced. InputError naming the centres file for fewer
/// than 3 matched centres (names compared with NAME, else its file name when unique), centres on a
/// line, or residuals over the bound (the worst centre's line named); errors of the readers above.
/// With --gcps: each point triangulated in the model's frame from its observations in the model's
/// images (triangulate_views()), the similarity fitted from those to the points' CRS positions by
/// the same rules (3 points, not on a line, the same bound on the RMS residual over the points'
/// extent). InputError naming the GCP file and the point's row for a point seen in fewer than two
/// of the model's images, rays meeting at under kMinGcpRayAngle, a point behind a camera, or a
/// reprojection error over kMaxGcpReprojection pixels (naming the row of the worst observation).
/// --centres exif: the camera centres are the images' EXIF GPS positions.
constexpr const char* kExifCentres = "exif";
/// The centres an image's metadata records, in the CRS, one per image path given (nullopt where an
/// image records none), and what their heights are: made by src/geo (exif_centres(), stereo_io.hpp),
/// which alone reads image metadata and converts coordinates.
struct ImageCentres {
  std::vector<std::optional<Vec3>> centres;
  std::string heights;
};
using ExifCentres = std::function<ImageCentres(const std::vector<std::string>& image_paths)>;

struct ColmapCameras {
  CameraFile file;
  Georeference georeference;
  Similarity transform;  ///< model -> CRS, as applied
};
/// With --centres exif, `exif` reads the images' centres (ArgumentError when it is empty); the
/// images without a position are left out, and fewer than 3 left is an InputError naming the
/// images' folder; a residual over the bound names the worst image's file and "EXIF GPS".
ColmapCameras colmap_cameras(const ColmapOptions& options, const ExifCentres& exif = {});

/// The model's image files as colmap_cameras() resolves them (file.images), without putting the
/// model in the CRS: check(options), the model read, no centres, GCPs, EXIF or transform read.
/// For listing a run's inputs before the work; the same errors as colmap_cameras() for the model.
std::vector<std::string> colmap_image_paths(const ColmapOptions& options);

}  // namespace dsmplan
