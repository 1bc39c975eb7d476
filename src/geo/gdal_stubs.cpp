// The dsmplan binary's geo stage: every function of the module's headers, each forwarding to
// libdsmplan_gdal.so, which the first call loads (gdal_entry_points.hpp says why). The plugin
// is looked for beside the binary (the build tree) and then where `cmake --install` puts it
// relative to the binary (DSMPLAN_PLUGIN_FROM_BIN), so an installed tree can move. The binary
// links PROJ (8 ms of a start, against GDAL's 41) for the one check every plan over a mesh makes.
#include <dlfcn.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include "geo/gdal_entry_points.hpp"
#include "geo/metric_crs.hpp"

namespace dsmplan {

namespace {

constexpr const char* kPlugin = "libdsmplan_gdal.so";

// Lazy, as the binary's own libraries are bound. Deep: GDAL's 100 libraries find their own
// symbols in their own scope first, not after the binary's 26 libraries: 13 ms less of a
// raster command's start, which otherwise paid more than when it linked GDAL itself. Not
// under the sanitizers, whose runtimes must interpose on every library (and refuse deep binding).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr int kOpenFlags = RTLD_LAZY | RTLD_LOCAL;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
constexpr int kOpenFlags = RTLD_LAZY | RTLD_LOCAL;
#else
constexpr int kOpenFlags = RTLD_LAZY | RTLD_LOCAL | RTLD_DEEPBIND;
#endif
#else
constexpr int kOpenFlags = RTLD_LAZY | RTLD_LOCAL | RTLD_DEEPBIND;
#endif

std::filesystem::path binary_directory() {
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  return error ? std::filesystem::path(".") : self.parent_path();
}

const detail::GdalEntryPoints* load_plugin() {
  const std::filesystem::path dir = binary_directory();
  std::string problem;
  for (const std::filesystem::path& candidate :
       {dir / kPlugin, (dir / DSMPLAN_PLUGIN_FROM_BIN / kPlugin).lexically_normal()}) {
    void* handle = ::dlopen(candidate.c_str(), kOpenFlags);
    if (!handle) {
      if (problem.empty()) problem = ::dlerror();
      continue;
    }
    using Table = const detail::GdalEntryPoints* (*)();
    const auto table_of = reinterpret_cast<Table>(::dlsym(handle, "dsmplan_gdal_entry_points"));
    const detail::GdalEntryPoints* table = table_of ? table_of() : nullptr;
    if (!table || table->size != sizeof(detail::GdalEntryPoints))
      throw Error(candidate.string() + ": not the GDAL plugin of this dsmplan build: reinstall dsmplan");
    return table;  // never unloaded: what it made (rasters, transforms) lives in its code
  }
  throw Error(std::string(kPlugin) + ": cannot load GDAL and PROJ for this command (looked beside " + dir.string() +
              " and in " + (dir / DSMPLAN_PLUGIN_FROM_BIN).lexically_normal().string() + "): " + problem);
}

const detail::GdalEntryPoints& gdal() {
  static const detail::GdalEntryPoints* const table = load_plugin();  // retried after a failure
  return *table;
}

}  // namespace

std::vector<AirspaceZone> read_airspace(const std::string& path, const Crs& crs, const VerticalOptions& vertical) {
  return gdal().read_airspace(path, crs, vertical);
}
Grid read_raster(const std::string& path, const ReadRasterOptions& options, const Progress& progress) {
  return gdal().read_raster(path, options, progress);
}
std::unique_ptr<GridSource> open_raster(const std::string& path, const ReadRasterOptions& options) {
  return gdal().open_raster(path, options);
}
std::vector<std::string> raster_file_list(const std::string& path) { return gdal().raster_file_list(path); }
void resolve_crs(Crs& crs) { gdal().resolve_crs(crs); }
bool print_terminal_progress(double fraction) { return gdal().print_terminal_progress(fraction); }
double unit_metres(const std::string& unit) { return gdal().unit_metres(unit); }
void resolve_units(Crs& crs) { gdal().resolve_units(crs); }
std::string utm_epsg_at(const Crs& crs, double x, double y) { return gdal().utm_epsg_at(crs, x, y); }
std::string metric_problem(const Crs& crs, const std::string& path, double centre_x, double centre_y, bool units_only) {
  // The common case, a projected CRS in metres, is proven with PROJ alone: GDAL stays unloaded.
  if (proven_metric(crs, centre_x, centre_y, units_only)) return "";
  return gdal().metric_problem(crs, path, centre_x, centre_y, units_only);
}
void write_geotiff(const Grid& grid, const std::string& path, const Progress& progress) {
  gdal().write_geotiff(grid, path, progress);
}
double geotiff_buffer_bytes() { return gdal().geotiff_buffer_bytes(); }
void fill_holes(Grid& grid, double max_distance, const Progress& progress) {
  gdal().fill_holes(grid, max_distance, progress);
}
RpcModel read_ossim_geom(const std::string& path) { return gdal().read_ossim_geom(path); }
RpcModel read_gdal_rpc(const std::string& raster_path) { return gdal().read_gdal_rpc(raster_path); }
std::array<double, 2> read_sensor_offset(const std::string& raster_path) {
  return gdal().read_sensor_offset(raster_path);
}
bool has_rpc(const std::string& raster_path) { return gdal().has_rpc(raster_path); }
RpcCamera read_rpc_camera(const std::string& raster_path) { return gdal().read_rpc_camera(raster_path); }
std::unique_ptr<ImageReader> open_image_file(const std::string& path, const std::string& place) {
  return gdal().open_image_file(path, place);
}
SatelliteImage open_satellite_image(const std::string& path) { return gdal().open_satellite_image(path); }
SatelliteOutput satellite_output(const std::string& crs, const GeoPoint& centre, bool allow_approximate_vertical) {
  return gdal().satellite_output(crs, centre, allow_approximate_vertical);
}
void write_satellite_dsm(const Grid& dsm, const std::string& path, const std::string& ellipsoidal_heights,
                         const Progress& progress) {
  gdal().write_satellite_dsm(dsm, path, ellipsoidal_heights, progress);
}
TilesetPlacement place_on_globe(const Mesh& mesh, const Wgs84Transform& to_ellipsoid) {
  return gdal().place_on_globe(mesh, to_ellipsoid);
}
std::string tileset_json(const TilesetPlacement& placement, const std::string& content_uri, const Crs& crs) {
  return gdal().tileset_json(placement, content_uri, crs);
}
void write_wpml_kmz(const Mission& mission, const MissionOptions& options, const std::string& path) {
  gdal().write_wpml_kmz(mission, options, path);
}

std::optional<ExifGps> read_exif_gps(const std::string& path) { return gdal().read_exif_gps(path); }
ImageCentres exif_centres(const std::vector<std::string>& image_paths, const std::string& crs) {
  return gdal().exif_centres(image_paths, crs);
}

Wgs84Transform::Wgs84Transform(const Crs& crs, HeightReference target, const VerticalOptions& options,
                               const std::array<double, 4>& area)
    : Wgs84Transform(gdal().make_wgs84(crs, target, options, area)) {}
Wgs84Transform::~Wgs84Transform() = default;
Wgs84Transform::Wgs84Transform(Wgs84Transform&&) noexcept = default;
Point3 Wgs84Transform::apply(const Point3& p, bool forward) const { return gdal().wgs84_apply(*this, p, forward); }
void Wgs84Transform::from_wgs84(std::vector<Point3>& points) const { gdal().wgs84_from_many(*this, points); }

}  // namespace dsmplan
