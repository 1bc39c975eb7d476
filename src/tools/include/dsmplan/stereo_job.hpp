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

#include "dsmplan/frame_dsm.hpp"
#include "dsmplan/satellite_stereo_job.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan {

// ---- dsmplan stereo -------------------------------------------------------------------------

/// `dsmplan stereo`: a DSM from frame-camera images with known poses (stereo_frames.hpp).
///
/// CAMERAS.json (a contract; docs/stereo.md, "Stereo from frame cameras"):
///   {"crs": "EPSG:25832", "height_range": [100, 180] (optional),
///    "cameras": [{"image": "img_0.png", "width": 1200, "height": 900, "fx": 2400.0, "fy": 2400.0,
///                 "cx": 599.5, "cy": 449.5, "distortion": [k1, k2, p1, p2, k3],
///                 "rotation": [[1,0,0],[0,-1,0],[0,0,-1]], "center": [x, y, z]}, ...]}
/// crs, cameras and every camera key are required but "distortion" (default none) and
/// "height_range" (the scene's lowest and highest heights, world units: it bounds the disparity
/// search and sets the plane footprints are cut with). Without height_range it is estimated
/// (estimate_height_range(), stereo_frames.hpp): every camera with its nearest, the pair's images
/// shrunk to about 320 px and matched over every depth, which bounds a second match at about
/// 640 px both ways; the lowest and highest of its cells' median heights (a lone cell or a clump
/// only one way matched left out), widened by 10 % of their difference. InputError (key
/// height_range) when no such pair matches. `image` is any GDAL raster,
/// relative to the JSON's folder: one band (grey) or three or more (RGB taken as luminance 0.299 R + 0.587 G + 0.114
/// B), 8 or 16 bit.
///
/// Or, instead of CAMERAS.json, a COLMAP text model (`colmap`, dsmplan/colmap_model.hpp): its
/// cameras put in `colmap.crs` by a similarity given or fitted to known centres, the same camera
/// list CAMERAS.json would give, the height range estimated; StereoReport::georeference says how.
struct StereoJobOptions : FrameDsmOptions {
  std::string cameras;   ///< CAMERAS.json; empty when colmap.model is set
  ColmapOptions colmap;  ///< --colmap MODEL_DIR, --centres, --gcps, --transform, --crs, --images
  std::string output;    ///< GeoTIFF (.tif, .tiff)
};

/// The files a run of `options` reads: CAMERAS.json ("--cameras"), or the COLMAP model's two files,
/// --centres and --transform, and every image named ("camera i's image"), for refuse_overwrites() before the work: a
/// --stats or -o that is one of them would replace it. InputError as stereo_job() for a
/// CAMERAS.json it cannot read.
std::vector<NamedFile> stereo_job_inputs(const StereoJobOptions& options);

/// Reads CAMERAS.json and resolves its CRS (InputError "crs" for one dsmplan cannot measure in:
/// metric_problem()), runs frame_dsm() (dsmplan/frame_dsm.hpp: its checks and errors, the images
/// read through GDAL) and writes the Float32 GeoTIFF atomically. ArgumentError naming the output
/// when it is not .tif. Nothing is written when it fails. Progress: the stage to 0.9, then the writing.
StereoReport stereo_job(const StereoJobOptions& options, const Progress& progress = {});
/// Keys: cameras (CAMERAS.json, or the COLMAP model's images.txt), output, georeference (--colmap only:
/// method "centres", "exif", "gcps" or "transform", centres, gcps (counts), residuals_at ("centres", "gcps" or ""),
/// scale, residual_rms, residual_max (CRS units), worst_image (the image, or the point of a GCP), residual_bound,
/// gcp_reprojection_max_px, heights (--centres exif: how the centres' heights were read and converted)), camera_count,
/// pairs [[i,j],...] (the pairs matched), pair_details (every pair chosen: cameras [i,j], used, problem (why left out,
/// "" when used), height_range, disparity_offset (px), disparities, windows, pixels, matched_pixels, matched_share (of
/// pixels), share_of_all_matched, window_conflicts, points), pairs_left_out, height_range, height_range_estimated,
/// bounds, width, height, matched_pixels, points, points_outside_height_range, points_in_grid, fusion_runs_spilled,
/// bands, dsm {cells, valid, nodata, holes, z_min, z_max}, seconds {read, height_range, rectify, match, triangulate,
/// fuse, write, total}.
Json to_json(const StereoReport& report);

// ---- the request of `dsmplan stereo`, either pipeline ----------------------------------------

/// `dsmplan stereo`'s flags as given, before it is known which pipeline runs: satellite images
/// (`images`) or frame cameras (`cameras`). What the command line, Python and C++ callers fill.
struct StereoRequest {
  std::vector<std::string> images;          ///< satellite images with RPCs (IMAGES)
  std::string cameras;                      ///< CAMERAS.json (--cameras)
  std::string colmap;                       ///< --colmap MODEL_DIR: a COLMAP text model instead of --cameras
  std::string centres;                      ///< --centres CSV (image,x,y,z in --crs) or "exif", with --colmap
  std::string transform;                    ///< --transform FILE (model -> --crs), with --colmap
  std::string gcps;                         ///< --gcps CSV (x,y,z,image,u,v in --crs), with --colmap
  std::string colmap_images;                ///< --images DIR, with --colmap
  std::string output;                       ///< -o
  double resolution = 0;                    ///< --res
  std::string pairs = "auto";               ///< --pairs, frame cameras only
  std::string bounds;                       ///< --bounds "x0,y0,x1,y1"; empty: the pairs' footprint
  std::string crs;                          ///< --crs: satellite images' output CRS, or --colmap's CRS
  bool allow_approximate_vertical = false;  ///< --allow-approximate-vertical, satellite images only
  double fusion_memory_mb = 1024;           ///< --fusion-memory, MB, [0.0625, 1e9)
  double band_memory_mb = 1024;             ///< --band-memory, MB, [1, 1e9)
};

/// The options of the pipeline a request runs: exactly one of frame and satellite is set.
struct StereoJob {
  std::optional<StereoJobOptions> frame;
  std::optional<SatelliteStereoOptions> satellite;
};

/// The rules of `dsmplan stereo`'s flags taken together, one ArgumentError naming the flag for
/// the first broken: --bounds not four numbers; not exactly one of IMAGES, --cameras and --colmap
/// (reported as "--cameras"); --centres, --gcps, --transform or --images without --colmap; with --colmap,
/// check(ColmapOptions) (--crs and --centres, --gcps or --transform needed); --fusion-memory outside [0.0625, 1e9) MB,
/// --band-memory outside [1, 1e9) MB; with --cameras, --crs or --allow-approximate-vertical (satellite images only);
/// with IMAGES, --pairs other than auto (frame cameras only). The options' own ranges are checked
/// by the jobs (check(FrameDsmOptions), check(SatelliteDsmOptions)).
StereoJob stereo_job_for(const StereoRequest& request);

}  // namespace dsmplan
