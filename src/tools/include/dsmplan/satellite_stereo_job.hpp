// dsmplan/satellite_stereo_job.hpp: `dsmplan stereo IMG1 IMG2 [IMG3 ...]` as a library function:
// satellite images with RPC cameras in, a GeoTIFF DSM out (tools.hpp's conventions: an options
// struct in, a report out, to_json() keys a contract).
//
// The chain (each step a function of dsmplan/rpc_stereo.hpp, src/stereo, no GDAL; here
// only what needs files and PROJ):
//   1. cameras: every image's RPC (read_rpc_camera(): TIFF tags, _RPC.TXT, .RPB through GDAL, or
//      an OSSIM .geom beside it with the crop's sensor offset from its transform);
//   2. pairs: every pair (i < j) of the images whose footprints overlap: a 17 x 17 lattice of the
//      first image's pixels, localized at the middle of the two RPCs' common height range, seen
//      inside the second image;
//   3. the scene's heights per pair: tie points searched across the RPCs' whole common height
//      range on up to 2 x 2 survey tiles of 384 px (tie_point_heights()); the scene is taken as
//      their 1st to 99th percentile widened by 20 m and 10 % each side, within the RPCs' range;
//   4. tiles of the first image's overlap (tile_size pixels a side; with bounds, only where the
//      ground of its pixels falls in them), each read as a window of both images (bounded
//      memory: windows, not images) and run through rpc_tile_stereo(): affine rectification,
//      pointing correction, SGM with the left-right check, triangulation through the RPCs;
//   5. the points (longitude, latitude, height above the WGS 84 ellipsoid) to the output CRS by
//      PROJ (through GDAL's OGRCoordinateTransformation), handed tile by tile to the fusion, which
//      takes the median per cell over every pair's points (MedianFusion, median_fusion.hpp); no
//      data where none fell.
//
// Output: a Float32 GeoTIFF (nodata -9999) in the output CRS, written atomically. The default
// CRS is WGS 84 / UTM of the zone holding the first image's centre (EPSG:326zz north, 327zz
// south). Heights are above the WGS 84 ellipsoid (the RPCs' own heights): the points go through
// PROJ to the CRS made three-dimensional (promote_to_3D: easting, northing, ellipsoidal height),
// and the file says so in its metadata, VERTICAL_CRS=EPSG:4979 (heights above the WGS 84
// ellipsoid), beside the 2D CRS in its GeoKeys: GDAL 3.6 cannot write a 3D projected CRS into
// GeoTIFF keys (it would go to a side-car .aux.xml). `dsmplan plan --vertical-crs EPSG:4979`
// (and `simplify --3dtiles --vertical-crs EPSG:4979`) then converts them (wgs84.hpp).
// --crs: any projected CRS in metres; a 2D one gets heights above its datum's ellipsoid (the
// metadata names that datum), a compound one (e.g. EPSG:32637+3855, EGM2008 heights) gets its
// heights converted by PROJ and states them in its GeoKeys: where PROJ lacks the geoid grid,
// refused (naming the grid) unless allow_approximate_vertical, never ellipsoidal heights labelled
// as the datum's.
//
// Memory, bounded whatever the scene's size: per tile two windows, the rectified images, SGM's
// buffer (stereo.hpp) and the tile's points; the fusion's fusion_memory_bytes (beyond it, 8 bytes
// a point on disk in the temporary directory); the grid (4 bytes a cell, checked with
// require_memory() before it is made).
//
// Errors (one line each, nothing written): InputError naming the image for an image without RPCs,
// a bad .geom (a missing, repeated or non-numeric coefficient: the .geom and the key), an image
// that is not 8- or 16-bit; two images that do not overlap on the ground (or, with three or
// more, no two that do); images that match nowhere within the RPCs' height range (the scene
// lies outside the range the RPCs were made for, or the images do not show the same ground);
// --bounds outside every pair's footprint; nothing matched. ArgumentError for options: fewer than
// two images, an output that is not .tif, --res, --crs not a projected CRS in metres, tile_size.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/raster.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan {

struct SatelliteStereoOptions {
  std::vector<std::string> images;              ///< two or more, with RPCs
  std::string output;                           ///< GeoTIFF (.tif, .tiff)
  double resolution = 0;                        ///< cell size, metres
  std::string crs;                              ///< output CRS; empty: WGS 84 / UTM of the scene (see above)
  std::optional<std::array<double, 4>> bounds;  ///< x0, y0, x1, y1 in the output CRS; none: the pairs' footprints
  int tile_size = 512;                          ///< left-image pixels per tile side, 64..4096
  /// The fusion's memory for points, bytes (8 a point; beyond it sorted runs go to a temporary
  /// file in $TMPDIR or /tmp: MedianFusion, median_fusion.hpp); at least 64 KiB.
  std::size_t fusion_memory_bytes = std::size_t{1} << 30;
  /// A compound --crs whose geoid grid PROJ lacks: heights through EGM96 instead (about a metre
  /// off; the report's transformation says so) rather than refused.
  bool allow_approximate_vertical = false;
};

struct SatellitePairReport {
  int left = 0, right = 0;                        ///< indices into images
  double overlap = 0;                             ///< share of the left image's lattice seen by the right image
  double rpc_height_min = 0, rpc_height_max = 0;  ///< the RPCs' common height range, metres
  double height_min = 0, height_max = 0;          ///< the scene's heights searched (step 3)
  std::size_t survey_tie_points = 0;              ///< tie points whose heights gave step 3
  std::size_t tiles = 0, tiles_pointing_corrected = 0, tie_points = 0;
  std::size_t tile_pixels = 0, matched_pixels = 0, points = 0;
  double seconds_read = 0, seconds_survey = 0, seconds_rectify = 0, seconds_pointing = 0, seconds_match = 0,
         seconds_triangulate = 0;
};

struct SatelliteStereoReport {
  std::vector<std::string> images;
  std::string output;
  Crs crs;                     ///< the output's, resolved
  std::string transformation;  ///< PROJ's operation from the RPCs' ground to it (Wgs84Transform::description())
  std::vector<SatellitePairReport> pairs;
  std::array<double, 4> bounds{};
  int width = 0, height = 0;
  std::size_t points = 0, points_in_grid = 0;
  std::size_t fusion_runs_spilled = 0;  ///< 0: the points fitted in fusion_memory_bytes
  GridSummary summary;
  double completeness = 0;  ///< valid cells / cells of the grid
  double seconds_read = 0, seconds_survey = 0, seconds_rectify = 0, seconds_pointing = 0, seconds_match = 0,
         seconds_triangulate = 0, seconds_transform = 0, seconds_fuse = 0, seconds_write = 0;
};

/// The chain above. Progress: the surveys, then per tile, then the fusion and the writing.
SatelliteStereoReport satellite_stereo_job(const SatelliteStereoOptions& options, const Progress& progress = {});
/// Keys: images, output, crs {name, epsg, wkt}, transformation, pairs [{images [i, j], overlap, rpc_height_range,
/// height_range, survey_tie_points, tiles, tiles_pointing_corrected, tie_points, tile_pixels,
/// matched_pixels, points, seconds {read, survey, rectify, pointing, match, triangulate}}], bounds,
/// width, height, points, points_in_grid, fusion_runs_spilled, completeness, dsm {cells, valid, nodata, holes, z_min,
/// z_max}, seconds {read, survey, rectify, pointing, match, triangulate, transform, fuse, write, total}.
Json to_json(const SatelliteStereoReport& report);

}  // namespace dsmplan
