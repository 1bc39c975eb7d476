// dsmplan/satellite_stereo_job.hpp: `dsmplan stereo IMG1 IMG2 [IMG3 ...]` as a library function:
// satellite images with RPC cameras in, a GeoTIFF DSM out (tools.hpp's conventions: an options
// struct in, a report out, to_json() keys a contract). The job reads the files, runs the stage
// satellite_dsm() (dsmplan/satellite_dsm.hpp: the chain, its memory and its errors) and writes
// the file:
//   - the images' RPCs and pixels (open_satellite_image(), stereo_io.hpp: TIFF tags, _RPC.TXT,
//     .RPB through GDAL, or an OSSIM .geom beside the image with the crop's sensor offset);
//   - the output CRS (satellite_output(), stereo_io.hpp). The default is WGS 84 / UTM of the zone
//     holding the first image's centre (EPSG:326zz north, 327zz south). Heights are above the
//     WGS 84 ellipsoid (the RPCs' own heights): the points go through PROJ to the CRS made
//     three-dimensional (easting, northing, ellipsoidal height), and the file says so in its
//     metadata, VERTICAL_CRS=EPSG:4979 (heights above the WGS 84 ellipsoid), beside the 2D CRS
//     in its GeoKeys: GDAL 3.6 cannot write a 3D projected CRS into GeoTIFF keys.
//     `dsmplan plan --vertical-crs EPSG:4979` (and `simplify --3dtiles --vertical-crs
//     EPSG:4979`) then converts them (wgs84.hpp). --crs: any projected CRS in metres; a 2D one
//     gets heights above its datum's ellipsoid (the metadata names that datum), a compound one
//     (e.g. EPSG:32637+3855, EGM2008 heights) gets its heights converted by PROJ and states them
//     in its GeoKeys: where PROJ lacks the geoid grid, refused (naming the grid) unless
//     allow_approximate_vertical, never ellipsoidal heights labelled as the datum's.
//
// Output: a Float32 GeoTIFF (nodata -9999) in the output CRS, written atomically; the grid (4
// bytes a cell and GDAL's writing buffer) is checked with require_memory() before any matching.
//
// Errors (one line each, nothing written): those of satellite_dsm(); InputError naming the image
// for an image without RPCs, a bad .geom (a missing, repeated or non-numeric coefficient: the
// .geom and the key), an image that is not 8- or 16-bit. ArgumentError for options: fewer than
// two images ("IMAGES"), an output that is not .tif ("-o"), --res, tile_size, --bounds, --crs
// not a projected CRS in metres.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/satellite_dsm.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan {

/// The stage's options (resolution, bounds, tile_size, fusion_memory_bytes) and the files.
struct SatelliteStereoOptions : SatelliteDsmOptions {
  std::vector<std::string> images;  ///< two or more, with RPCs
  std::string output;               ///< GeoTIFF (.tif, .tiff)
  std::string crs;                  ///< output CRS; empty: WGS 84 / UTM of the scene (see above)
  /// A compound --crs whose geoid grid PROJ lacks: heights through EGM96 instead (about a metre
  /// off; the report's transformation says so) rather than refused.
  bool allow_approximate_vertical = false;
};

/// The files a run of `options` reads: every image ("IMAGES") and the OSSIM .geom beside it when
/// there is one, for refuse_overwrites() before the work.
std::vector<NamedFile> satellite_stereo_inputs(const SatelliteStereoOptions& options);

/// Reads, runs satellite_dsm(), writes. Progress: the stage to 0.9, then the writing.
SatelliteStereoReport satellite_stereo_job(const SatelliteStereoOptions& options, const Progress& progress = {});
/// Keys: images, output, crs {name, epsg, wkt}, transformation, pairs [{images [i, j], overlap, rpc_height_range,
/// height_range, survey_tie_points, tiles, tiles_pointing_corrected, tie_points, tile_pixels,
/// matched_pixels, points, seconds {read, survey, rectify, pointing, match, triangulate}}], bounds,
/// width, height, points, points_in_grid, fusion_runs_spilled, completeness, dsm {cells, valid, nodata, holes, z_min,
/// z_max}, seconds {read, survey, rectify, pointing, match, triangulate, transform, fuse, write, total}.
Json to_json(const SatelliteStereoReport& report);

}  // namespace dsmplan
