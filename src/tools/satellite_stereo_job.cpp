// dsmplan stereo IMG1 IMG2 [IMG3 ...]: satellite images with RPC cameras to a GeoTIFF DSM (issue
// 17). The wiring of the stage satellite_dsm() (src/stereo: s2p's tile-wise chain, de Franchis
// et al., ISPRS Annals II-3, 2014) to its files, which src/geo reads and writes (stereo_io.hpp).
// dsmplan/satellite_stereo_job.hpp is the manual.
#include "dsmplan/satellite_stereo_job.hpp"

#include <chrono>
#include <filesystem>

#include "dsmplan/export.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/stereo_io.hpp"

namespace dsmplan {
namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// What is wrong with the options, before any file is opened.
void check_job(const SatelliteStereoOptions& options) {
  const std::string extension = std::filesystem::path(options.output).extension().string();
  if (extension != ".tif" && extension != ".tiff") throw ArgumentError("-o", "output must be a GeoTIFF (.tif)");
  if (options.images.size() < 2) throw ArgumentError("IMAGES", "give two or more satellite images with RPCs");
  check(static_cast<const SatelliteDsmOptions&>(options));
  check_writable(options.output);  // a missing folder is known now, not after the matching
}

}  // namespace

std::vector<NamedFile> satellite_stereo_inputs(const SatelliteStereoOptions& options) {
  std::vector<NamedFile> inputs;
  for (const std::string& image : options.images) {
    inputs.push_back({"IMAGES", image});
    const std::string geom = std::filesystem::path(image).replace_extension(".geom").string();
    if (std::filesystem::exists(geom)) inputs.push_back({"IMAGES", geom});
  }
  return inputs;
}

SatelliteStereoReport satellite_stereo_job(const SatelliteStereoOptions& options, const Progress& progress) {
  check_job(options);
  auto start = std::chrono::steady_clock::now();
  std::vector<SatelliteImage> images;
  for (const std::string& path : options.images) images.push_back(open_satellite_image(path));
  const double seconds_open = seconds_since(start);
  // The output CRS, checked before any long work.
  const SatelliteOutput output =
      satellite_output(options.crs, scene_centre(images[0]), options.allow_approximate_vertical);
  const GridCheck fits = [&](const Grid& grid) {
    require_memory(options.output, "", 12.0 * grid.cells() + geotiff_buffer_bytes());
  };
  Grid dsm;
  SatelliteStereoReport out = satellite_dsm(images, output.frame, options, dsm, fits, sub_progress(progress, 0, 0.9));
  out.output = options.output;
  out.seconds_read += seconds_open;
  start = std::chrono::steady_clock::now();
  write_satellite_dsm(dsm, options.output, output.ellipsoidal_heights, sub_progress(progress, 0.9, 1.0));
  out.seconds_write = seconds_since(start);
  return out;
}

Json to_json(const SatelliteStereoReport& r) {
  Json pairs = Json::array();
  for (const SatellitePairReport& p : r.pairs)
    pairs.push_back({{"images", {p.left, p.right}},
                     {"overlap", p.overlap},
                     {"rpc_height_range", {p.rpc_height_min, p.rpc_height_max}},
                     {"height_range", {p.height_min, p.height_max}},
                     {"survey_tie_points", p.survey_tie_points},
                     {"tiles", p.tiles},
                     {"tiles_pointing_corrected", p.tiles_pointing_corrected},
                     {"tie_points", p.tie_points},
                     {"tile_pixels", p.tile_pixels},
                     {"matched_pixels", p.matched_pixels},
                     {"points", p.points},
                     {"seconds",
                      {{"read", p.seconds_read},
                       {"survey", p.seconds_survey},
                       {"rectify", p.seconds_rectify},
                       {"pointing", p.seconds_pointing},
                       {"match", p.seconds_match},
                       {"triangulate", p.seconds_triangulate}}}});
  const double total = r.seconds_read + r.seconds_survey + r.seconds_rectify + r.seconds_pointing + r.seconds_match +
                       r.seconds_triangulate + r.seconds_transform + r.seconds_fuse + r.seconds_write;
  Json crs = {{"name", r.crs.name}, {"epsg", r.crs.epsg}, {"wkt", r.crs.wkt}};
  return {{"images", r.images},
          {"output", r.output},
          {"crs", crs},
          {"transformation", r.transformation},
          {"pairs", pairs},
          {"bounds", {r.bounds[0], r.bounds[1], r.bounds[2], r.bounds[3]}},
          {"width", r.width},
          {"height", r.height},
          {"points", r.points},
          {"points_in_grid", r.points_in_grid},
          {"fusion_runs_spilled", r.fusion_runs_spilled},
          {"completeness", r.completeness},
          {"dsm", to_json(r.summary)},
          {"seconds",
           {{"read", r.seconds_read},
            {"survey", r.seconds_survey},
            {"rectify", r.seconds_rectify},
            {"pointing", r.seconds_pointing},
            {"match", r.seconds_match},
            {"triangulate", r.seconds_triangulate},
            {"transform", r.seconds_transform},
            {"fuse", r.seconds_fuse},
            {"write", r.seconds_write},
            {"total", total}}}};
}

}  // namespace dsmplan
