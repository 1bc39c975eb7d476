// dsmplan/stereo_io.hpp: the files of the stereo stage (dsmplan/frame_dsm.hpp,
// dsmplan/satellite_dsm.hpp) through GDAL and PROJ: images opened for reading by windows, the
// satellite images with their RPC cameras, the satellite DSM's output CRS and its GeoTIFF. In
// the library dsmplan_geo.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/colmap_model.hpp"
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

/// The position an image's EXIF GPS tags record (exif_gps.cpp): WGS 84 degrees, and metres above
/// sea level (GPSAltitude, negative when GPSAltitudeRef says below).
struct ExifGps {
  double latitude = 0, longitude = 0, altitude = 0;
};
/// nullopt when the image lacks GPSLatitude, GPSLongitude or GPSAltitude; the references default
/// to N, E and above sea level when absent. InputError naming `path` and the tag ("EXIF
/// GPSLatitude") for a value that is not degrees, minutes, seconds in range, a reference other than
/// N/S, E/W, 0/1; naming `path` when it is not an image GDAL reads.
std::optional<ExifGps> read_exif_gps(const std::string& path);

/// --centres exif (colmap_model.hpp's ExifCentres): each image's EXIF GPS position in `crs`
/// (read_exif_gps(); nullopt where none), the altitude taken as an EGM96 height (above mean sea
/// level, as EXIF defines it) and the position on WGS 84, carried by PROJ (Wgs84Transform,
/// wgs84.hpp): a 2D `crs` keeps the EGM96 heights, a compound one converts them through its geoid
/// grid. `heights` says so and names PROJ's operation. ArgumentError("--crs") when PROJ cannot
/// read `crs` or has only a ballpark height transformation to it; read_exif_gps()'s errors.
ImageCentres exif_centres(const std::vector<std::string>& image_paths, const std::string& crs);

}  // namespace dsmplan
