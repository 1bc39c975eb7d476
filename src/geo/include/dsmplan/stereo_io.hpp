// dsmplan/stereo_io.hpp: the files of the stereo stage (dsmplan/frame_dsm.hpp,
// dsmplan/satellite_dsm.hpp) through GDAL and PROJ: images opened for reading by windows, the
// satellite images with their RPC cameras, the satellite DSM's output CRS and its GeoTIFF. In
// the library dsmplan_geo.
#pragma once

#include <memory>
#include <string>

#include "dsmplan/image_reader.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/satellite_dsm.hpp"

namespace dsmplan {

/// An image file read through GDAL (any raster GDAL reads), for ImageOpener. InputError naming
/// `path` and `place`: not a regular file (require_input_file()), "is not a raster image GDAL can
/// read", "image is <type>: give 8- or 16-bit images" (8- and 16-bit integers pass).
std::unique_ptr<ImageReader> open_image_file(const std::string& path, const std::string& place = "");

/// A satellite image: its camera (read_rpc_camera(), rpc_io.hpp) and its pixels
/// (open_image_file()), in that order, with their errors.
SatelliteImage open_satellite_image(const std::string& path);

/// The output of the satellite stage: where its points go and what the GeoTIFF says of its heights.
struct SatelliteOutput {
  GroundFrame frame;
  /// The metadata value (kEllipsoidalHeightsKey, raster_io.hpp) by which a 2D CRS's DSM says its
  /// heights are above its datum's ellipsoid; empty for a compound CRS (its GeoKeys say).
  std::string ellipsoidal_heights;
};

/// The output CRS of a satellite DSM: `crs` (any projected CRS in metres, EPSG:n, WKT or PROJ) or,
/// empty, WGS 84 / UTM of the zone holding `centre` (EPSG:326zz north, 327zz south). A 2D CRS is
/// made 3D (easting, northing, height above its datum's ellipsoid: GDAL 3.6 cannot write a 3D
/// projected CRS into GeoTIFF keys, so the file states the 2D CRS and its metadata the heights);
/// a compound one (e.g. EPSG:32637+3855) gets its heights through its geoid grid, and where PROJ
/// lacks that grid it is refused (naming the grid) unless `allow_approximate_vertical` (then
/// through EGM96: Wgs84Transform, wgs84.hpp). ArgumentError("--crs") for a CRS PROJ cannot read,
/// not projected, not in metres, or a vertical transformation refused.
SatelliteOutput satellite_output(const std::string& crs, const GeoPoint& centre, bool allow_approximate_vertical);

/// Writes the satellite DSM as a Float32 GeoTIFF (write_geotiff(): DEFLATE, tiled, nodata -9999)
/// with `ellipsoidal_heights` in its metadata when not empty. Atomic: the file and its metadata,
/// or nothing. OutputError naming `path`.
void write_satellite_dsm(const Grid& dsm, const std::string& path, const std::string& ellipsoidal_heights,
                         const Progress& progress = {});

}  // namespace dsmplan
