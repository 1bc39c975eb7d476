// How a GeoTIFF of dsmplan states that its heights are above its datum's ellipsoid: GDAL 3.6
// writes no GeoTIFF keys for a projected CRS made 3D, so the file states the 2D CRS and its
// metadata (kEllipsoidalHeightsKey, raster_io.hpp) the heights; read_raster() promotes it back.
// Internal to src/geo (gdal_io.cpp writes it, satellite_output.cpp names it).
#pragma once

#include <ogr_spatialref.h>

#include <string>

namespace dsmplan {

/// "EPSG:4979 (heights above the WGS 84 ellipsoid)" for a CRS on WGS 84, else "heights above the
/// <datum> ellipsoid": the metadata value read_raster() recognises.
std::string ellipsoid_statement(const OGRSpatialReference& srs);

}  // namespace dsmplan
