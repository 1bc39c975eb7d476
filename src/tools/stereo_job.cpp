// dsmplan stereo --cameras: frame-camera images with known poses to a GeoTIFF DSM (issue 16).
// The wiring of the stage frame_dsm() (src/stereo: the pipeline of Adolf & Hirschmüller, Section
// 2) to its files: CAMERAS.json, the CRS and the images through src/geo, the GeoTIFF out. And the
// rules of `dsmplan stereo`'s flags taken together (stereo_job_for()).
#include "dsmplan/stereo_job.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <tuple>

#include "dsmplan/export.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/stereo_io.hpp"

namespace dsmplan {
namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// What is wrong with the options, before any file is read.
void check_job(const StereoJobOptions& options) {
  const std::string extension = std::filesystem::path(options.output).extension().string();
  if (extension != ".tif" && extension != ".tiff")
    throw ArgumentError(options.output, "output must be a GeoTIFF (.tif)");
  check(static_cast<const FrameDsmOptions&>(options));
  if (!options.colmap.model.empty()) check(options.colmap);
  check_writable(options.output);  // a missing folder is known now, not after the matching
}

// CAMERAS.json's CRS, or --colmap's --crs: one dsmplan can make a DSM in (degrees, a geocentric
// frame or stretched metres refused as for rasters).
Crs cameras_crs(const CameraFile& file, bool from_flag) {
  Crs crs;
  crs.definition = file.crs;
  const auto refuse = [&](const std::string& problem) {
    if (from_flag) throw ArgumentError("--crs", problem);
    throw InputError(file.path, "crs", problem);
  };
  try {
    resolve_crs(crs);
  } catch (const ArgumentError& error) {
    refuse(error.problem());
  }
  const std::string problem = metric_problem(crs, file.path, file.cameras[0].center[0], file.cameras[0].center[1]);
  if (!problem.empty()) refuse(problem);
  return crs;
}

// The cameras of the job: CAMERAS.json, or the COLMAP model put in the CRS.
CameraFile job_cameras(const StereoJobOptions& options, std::optional<Georeference>* georeference = nullptr) {
  if (options.colmap.model.empty()) return read_camera_file(options.cameras);
  const std::string crs = options.colmap.crs;
  ColmapCameras colmap = colmap_cameras(
      options.colmap, [&crs](const std::vector<std::string>& images) { return exif_centres(images, crs); });
  if (georeference) *georeference = colmap.georeference;
  return std::move(colmap.file);
}

std::vector<NamedFile> camera_images(const CameraFile& file) {
  std::vector<NamedFile> images;
  for (size_t i = 0; i < file.images.size(); ++i)
    images.push_back({"camera " + std::to_string(i) + "'s image", file.images[i]});
  return images;
}

// --bounds "x0,y0,x1,y1".
std::array<double, 4> parse_bounds(const std::string& text) {
  try {
    const Window w = parse_window(text);
    return {w.xmin, w.ymin, w.xmax, w.ymax};
  } catch (const ArgumentError&) {
    throw ArgumentError("--bounds", "expected four numbers x0,y0,x1,y1, got '" + text.substr(0, 80) + "'");
  }
}

// The rules that hold whichever pipeline runs.
void check_common(const StereoRequest& request) {
  if (request.cameras.empty() + request.images.empty() + request.colmap.empty() != 2)
    throw ArgumentError("--cameras",
                        "give one of: satellite images with RPCs (dsmplan stereo IMG1 IMG2 ...), --cameras "
                        "CAMERAS.json for frame cameras, or --colmap MODEL_DIR for a COLMAP text model");
  if (request.colmap.empty())
    for (const auto& [flag, value] :
         {std::pair{"--centres", &request.centres}, std::pair{"--transform", &request.transform},
          std::pair{"--gcps", &request.gcps}, std::pair{"--images", &request.colmap_images}})
      if (!value->empty()) throw ArgumentError(flag, "belongs to --colmap");
  for (const auto& [flag, megabytes, least] : {std::tuple{"--fusion-memory", request.fusion_memory_mb, 0.0625},
                                               std::tuple{"--band-memory", request.band_memory_mb, 1.0}})
    if (!(megabytes >= least && megabytes < 1e9)) {
      char range[96];  // %g: 1e300 as typed, not as 301 digits
      std::snprintf(range, sizeof range, "must lie in [%g, 1e9) MB, got %g", least, megabytes);
      throw ArgumentError(flag, range);
    }
}

// The frame cameras' job: --cameras, or --colmap with its CRS and georeference.
StereoJobOptions frame_job(const StereoRequest& request, const std::optional<std::array<double, 4>>& bounds) {
  StereoJobOptions frame;
  if (request.colmap.empty() && !request.crs.empty())
    throw ArgumentError("--crs", "belongs to satellite images or --colmap; CAMERAS.json states its CRS");
  if (request.allow_approximate_vertical)
    throw ArgumentError("--allow-approximate-vertical", "belongs to satellite images with a compound --crs");
  frame.cameras = request.cameras, frame.output = request.output;
  if (!request.colmap.empty()) {
    frame.colmap = {.model = request.colmap,
                    .centres = request.centres,
                    .transform = request.transform,
                    .gcps = request.gcps,
                    .crs = request.crs,
                    .images = request.colmap_images};
    check(frame.colmap);
  }
  frame.resolution = request.resolution, frame.pairs = request.pairs, frame.bounds = bounds;
  frame.fusion_memory_bytes = static_cast<std::size_t>(request.fusion_memory_mb * 1048576.0);
  frame.band_memory_bytes = static_cast<std::size_t>(request.band_memory_mb * 1048576.0);
  return frame;
}

// --stats' entry of one pair chosen: matched or left out, its search and its share of matched pixels.
Json pair_json(const FramePairStats& p, const StereoReport& r) {
  return {{"cameras", {p.left, p.right}},
          {"used", p.used},
          {"problem", p.problem},
          {"height_range", {r.min_height, r.max_height}},
          {"disparity_offset", p.shift},
          {"disparities", p.num_disparities},
          {"windows", p.windows},
          {"pixels", p.pixels},
          {"matched_pixels", p.matched_pixels},
          {"matched_share", p.pixels ? double(p.matched_pixels) / double(p.pixels) : 0.0},
          {"share_of_all_matched", r.matched_pixels ? double(p.matched_pixels) / double(r.matched_pixels) : 0.0},
          {"window_conflicts", p.window_conflicts},
          {"points", p.points}};
}

}  // namespace

std::vector<NamedFile> stereo_job_inputs(const StereoJobOptions& options) {
  std::vector<NamedFile> files;
  if (options.colmap.model.empty()) {
    files.push_back({"--cameras", options.cameras});
  } else {
    for (const char* name : {"cameras.txt", "images.txt"})
      files.push_back({"--colmap", (std::filesystem::path(options.colmap.model) / name).string()});
    if (!options.colmap.centres.empty() && options.colmap.centres != kExifCentres)
      files.push_back({"--centres", options.colmap.centres});
    if (!options.colmap.transform.empty()) files.push_back({"--transform", options.colmap.transform});
    if (!options.colmap.gcps.empty()) files.push_back({"--gcps", options.colmap.gcps});
  }
  // The images' names only: for --colmap, the model read without the fit (EXIF, PROJ, GCPs), which
  // stereo_job() does once.
  CameraFile cameras;
  if (options.colmap.model.empty())
    cameras = read_camera_file(options.cameras);
  else
    cameras.images = colmap_image_paths(options.colmap);
  for (const NamedFile& image : camera_images(cameras)) files.push_back(image);
  return files;
}

StereoReport stereo_job(const StereoJobOptions& options, const Progress& progress) {
  check_job(options);
  auto start = std::chrono::steady_clock::now();
  std::optional<Georeference> georeference;
  const CameraFile file = job_cameras(options, &georeference);
  const Crs crs = cameras_crs(file, !options.colmap.model.empty());
  refuse_overwrites(camera_images(file), {{"-o", options.output}});
  const double seconds_read = seconds_since(start);
  const GridCheck fits = [&](const Grid& grid) {
    require_memory(options.output, "", 12.0 * grid.cells() + geotiff_buffer_bytes());
  };
  Grid dsm;
  StereoReport out = frame_dsm(file, crs, open_image_file, options, dsm, fits, sub_progress(progress, 0, 0.9));
  out.cameras = file.path;
  out.georeference = georeference;
  out.output = options.output;
  out.seconds_read += seconds_read;
  start = std::chrono::steady_clock::now();
  write_geotiff(dsm, options.output, sub_progress(progress, 0.9, 1.0));
  out.seconds_write = seconds_since(start);
  return out;
}

StereoJob stereo_job_for(const StereoRequest& request) {
  std::optional<std::array<double, 4>> bounds;
  if (!request.bounds.empty()) bounds = parse_bounds(request.bounds);
  check_common(request);
  const auto fusion_bytes = static_cast<std::size_t>(request.fusion_memory_mb * 1048576.0);
  StereoJob job;
  if (request.images.empty()) {
    job.frame = frame_job(request, bounds);
    return job;
  }
  if (request.pairs != "auto")
    throw ArgumentError("--pairs", "belongs to --cameras and --colmap; satellite images are paired by overlap");
  SatelliteStereoOptions& satellite = job.satellite.emplace();
  satellite.images = request.images, satellite.output = request.output, satellite.crs = request.crs;
  satellite.allow_approximate_vertical = request.allow_approximate_vertical;
  satellite.resolution = request.resolution, satellite.bounds = bounds;
  satellite.fusion_memory_bytes = fusion_bytes;
  return job;
}

Json to_json(const StereoReport& r) {
  Json pairs = Json::array();
  for (const auto& [a, b] : r.pairs) pairs.push_back({a, b});
  Json details = Json::array();
  for (const FramePairStats& p : r.pair_stats) details.push_back(pair_json(p, r));
  const double total = r.seconds_read + r.seconds_height_range + r.seconds_rectify + r.seconds_match +
                       r.seconds_triangulate + r.seconds_fuse + r.seconds_write;
  Json out = {{"cameras", r.cameras},
              {"output", r.output},
              {"camera_count", r.camera_count},
              {"pairs", pairs},
              {"pair_details", details},
              {"pairs_left_out", r.pair_stats.size() - r.pairs.size()},
              {"height_range", {r.min_height, r.max_height}},
              {"height_range_estimated", r.height_range_estimated},
              {"bounds", {r.bounds[0], r.bounds[1], r.bounds[2], r.bounds[3]}},
              {"width", r.width},
              {"height", r.height},
              {"matched_pixels", r.matched_pixels},
              {"points", r.points},
              {"points_outside_height_range", r.points_outside_range},
              {"points_in_grid", r.points_in_grid},
              {"fusion_runs_spilled", r.fusion_runs_spilled},
              {"bands", r.bands},
              {"dsm", to_json(r.summary)},
              {"seconds",
               {{"read", r.seconds_read},
                {"height_range", r.seconds_height_range},
                {"rectify", r.seconds_rectify},
                {"match", r.seconds_match},
                {"triangulate", r.seconds_triangulate},
                {"fuse", r.seconds_fuse},
                {"write", r.seconds_write},
                {"total", total}}}};
  if (r.georeference) {
    const Georeference& g = *r.georeference;
    out["georeference"] = {{"method", g.method},
                           {"centres", g.centres},
                           {"scale", g.scale},
                           {"residual_rms", g.rms},
                           {"residual_max", g.max},
                           {"worst_image", g.worst},
                           {"residual_bound", g.bound},
                           {"gcps", g.gcps},
                           {"residuals_at", g.residuals_at},
                           {"gcp_reprojection_max_px", g.gcp_reprojection_max},
                           {"heights", g.heights}};
  }
  return out;
}

}  // namespace dsmplan
