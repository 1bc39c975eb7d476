// The geo stage's entry points as one table of functions. libdsmplan_gdal.so (gdal_plugin.cpp)
// fills it with this module's functions, which use GDAL and PROJ; the dsmplan binary links
// stubs of the same functions instead (gdal_stubs.cpp), which load the plugin at their first
// call. A command that reads no raster and transforms no coordinate (`dsmplan plan MESH.ply`,
// `dsmplan --version`) then never loads GDAL, PROJ and the 110 libraries they bring: binding
// them took 50 ms of every start (bench/README.md, "A first plan"). The library, the tests and
// the Python module link dsmplan_geo itself and call the functions directly.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/airspace_io.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/rpc_io.hpp"
#include "dsmplan/stereo_io.hpp"
#include "dsmplan/wgs84.hpp"
#include "dsmplan/wpml.hpp"

namespace dsmplan::detail {

struct GdalEntryPoints {
  uint32_t size;  ///< sizeof(GdalEntryPoints) where it was filled: a plugin of another build is refused
  decltype(&dsmplan::read_airspace) read_airspace;
  decltype(&dsmplan::read_raster) read_raster;
  decltype(&dsmplan::open_raster) open_raster;
  decltype(&dsmplan::raster_file_list) raster_file_list;
  decltype(&dsmplan::resolve_crs) resolve_crs;
  decltype(&dsmplan::print_terminal_progress) print_terminal_progress;
  decltype(&dsmplan::unit_metres) unit_metres;
  decltype(&dsmplan::resolve_units) resolve_units;
  decltype(&dsmplan::utm_epsg_at) utm_epsg_at;
  decltype(&dsmplan::metric_problem) metric_problem;
  decltype(&dsmplan::write_geotiff) write_geotiff;
  decltype(&dsmplan::geotiff_buffer_bytes) geotiff_buffer_bytes;
  decltype(&dsmplan::fill_holes) fill_holes;
  decltype(&dsmplan::read_ossim_geom) read_ossim_geom;
  decltype(&dsmplan::read_gdal_rpc) read_gdal_rpc;
  decltype(&dsmplan::read_sensor_offset) read_sensor_offset;
  decltype(&dsmplan::has_rpc) has_rpc;
  decltype(&dsmplan::read_rpc_camera) read_rpc_camera;
  decltype(&dsmplan::open_image_file) open_image_file;
  decltype(&dsmplan::open_satellite_image) open_satellite_image;
  decltype(&dsmplan::satellite_output) satellite_output;
  decltype(&dsmplan::write_satellite_dsm) write_satellite_dsm;
  decltype(&dsmplan::place_on_globe) place_on_globe;
  decltype(&dsmplan::tileset_json) tileset_json;
  decltype(&dsmplan::write_wpml_kmz) write_wpml_kmz;
  decltype(&dsmplan::read_exif_gps) read_exif_gps;
  decltype(&dsmplan::exif_centres) exif_centres;
  // Wgs84Transform: made in the plugin and moved out (its State is shared, so the stubs can
  // move and destroy it); its transformations run there.
  Wgs84Transform (*make_wgs84)(const Crs&, HeightReference, const VerticalOptions&, const std::array<double, 4>&);
  Point3 (*wgs84_apply)(const Wgs84Transform&, const Point3&, bool forward);
  void (*wgs84_from_many)(const Wgs84Transform&, std::vector<Point3>&);
};

}  // namespace dsmplan::detail

/// The plugin's one exported symbol.
extern "C" const dsmplan::detail::GdalEntryPoints* dsmplan_gdal_entry_points();
