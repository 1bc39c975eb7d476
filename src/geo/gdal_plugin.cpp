// libdsmplan_gdal.so: the geo stage's functions behind one exported table (gdal_entry_points.hpp),
// for the dsmplan binary to load when a command first needs GDAL or PROJ. Every other symbol is
// local (gdal_plugin.map): the plugin's copies of the stages below it never interpose on the
// binary's, nor the binary's stubs on the plugin's own calls.
#include "geo/gdal_entry_points.hpp"

using namespace dsmplan;

extern "C" __attribute__((visibility("default"))) const detail::GdalEntryPoints* dsmplan_gdal_entry_points() {
  static const detail::GdalEntryPoints table{
      sizeof(detail::GdalEntryPoints),
      &read_airspace,
      &read_raster,
      &open_raster,
      &raster_file_list,
      &resolve_crs,
      &print_terminal_progress,
      &unit_metres,
      &resolve_units,
      &utm_epsg_at,
      &metric_problem,
      &write_geotiff,
      &geotiff_buffer_bytes,
      &fill_holes,
      &read_ossim_geom,
      &read_gdal_rpc,
      &read_sensor_offset,
      &has_rpc,
      &read_rpc_camera,
      &open_image_file,
      &open_satellite_image,
      &satellite_output,
      &write_satellite_dsm,
      &place_on_globe,
      &tileset_json,
      &write_wpml_kmz,
      &read_exif_gps,
      &exif_centres,
      [](const Crs& crs, HeightReference target, const VerticalOptions& options, const std::array<double, 4>& area) {
        return Wgs84Transform(crs, target, options, area);
      },
      [](const Wgs84Transform& t, const Point3& p, bool forward) { return forward ? t.to_wgs84(p) : t.from_wgs84(p); },
      [](const Wgs84Transform& t, std::vector<Point3>& points) { t.from_wgs84(points); },
  };
  return &table;
}
