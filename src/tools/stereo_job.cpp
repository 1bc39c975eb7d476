// dsmplan stereo: frame-camera images with known poses to a GeoTIFF DSM (issue 16), the
// pipeline of Adolf & Hirschmüller, Section 2, run by stereo_dsm() (src/stereo, no GDAL); here
// only what needs files: CAMERAS.json, the images through GDAL, the GeoTIFF out.
#include "dsmplan/stereo_job.hpp"

#include <gdal_priv.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/text.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/stereo_frames.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan {
namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The image's file opened and checked (a raster, 8 or 16 bit, the camera's size), its pixels not read.
std::unique_ptr<GDALDataset> open_image(const std::string& path, const FrameCamera& camera,
                                        const std::string& camera_name) {
  if (!std::filesystem::exists(path)) throw InputError(path, camera_name, "image does not exist");
  require_input_file(path);
  GDALAllRegister();
  CPLPushErrorHandler(CPLQuietErrorHandler);
  std::unique_ptr<GDALDataset> dataset(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  CPLPopErrorHandler();
  if (!dataset || dataset->GetRasterCount() < 1)
    throw InputError(path, camera_name, "is not a raster image GDAL can read");
  const GDALDataType type = dataset->GetRasterBand(1)->GetRasterDataType();
  if (type != GDT_Byte && type != GDT_UInt16 && type != GDT_Int16)
    throw InputError(path, camera_name,
                     std::string("image is ") + GDALGetDataTypeName(type) + ": give 8- or 16-bit images");
  const int w = dataset->GetRasterXSize(), h = dataset->GetRasterYSize();
  if (w != camera.width || h != camera.height)
    throw InputError(path, camera_name,
                     "image is " + std::to_string(w) + " x " + std::to_string(h) + ", the camera says " +
                         std::to_string(camera.width) + " x " + std::to_string(camera.height));
  return dataset;
}

// One image as grey floats: band 1, or the luminance of bands 1-3.
GreyImage read_image(const std::string& path, const FrameCamera& camera, const std::string& camera_name) {
  const std::unique_ptr<GDALDataset> dataset = open_image(path, camera, camera_name);
  const int w = dataset->GetRasterXSize(), h = dataset->GetRasterYSize();
  require_memory(path, camera_name, 8.0 * w * h);
  GreyImage image;
  image.width = w;
  image.height = h;
  image.pixels.assign(static_cast<size_t>(w) * h, 0.0f);
  const bool rgb = dataset->GetRasterCount() >= 3;
  const double weights[3] = {0.299, 0.587, 0.114};
  std::vector<float> band(image.pixels.size());
  for (int b = 0; b < (rgb ? 3 : 1); ++b) {
    if (dataset->GetRasterBand(b + 1)->RasterIO(GF_Read, 0, 0, w, h, band.data(), w, h, GDT_Float32, 0, 0) != CE_None)
      throw InputError(path, camera_name, "image could not be read: " + std::string(CPLGetLastErrorMsg()));
    const double weight = rgb ? weights[b] : 1.0;
    for (size_t i = 0; i < band.size(); ++i) image.pixels[i] += static_cast<float>(weight * band[i]);
  }
  return image;
}

// The bounding box of the pairs' common footprint on the plane Z = ground: left pixels of a
// 65 x 65 lattice whose ground point the right camera sees.
bool overlap_box(const FrameCamera& left, const FrameCamera& right, double ground, std::array<double, 4>& box) {
  bool any = false;
  for (int i = 0; i <= 64; ++i)
    for (int j = 0; j <= 64; ++j) {
      const Vec3 ray = pixel_ray(left, i / 64.0 * (left.width - 1), j / 64.0 * (left.height - 1));
      if (std::abs(ray[2]) < 1e-12) continue;
      const double t = (ground - left.center[2]) / ray[2];
      if (!(t > 0)) continue;
      const Vec3 X{left.center[0] + t * ray[0], left.center[1] + t * ray[1], ground};
      double u, v;
      if (!project(right, X, u, v) || u < 0 || v < 0 || u > right.width - 1 || v > right.height - 1) continue;
      if (!any) box = {X[0], X[1], X[0], X[1]};
      any = true;
      box = {std::min(box[0], X[0]), std::min(box[1], X[1]), std::max(box[2], X[0]), std::max(box[3], X[1])};
    }
  return any;
}

}  // namespace

std::vector<NamedFile> stereo_job_inputs(const StereoJobOptions& options) {
  std::vector<NamedFile> files{{"--cameras", options.cameras}};
  const CameraFile file = read_camera_file(options.cameras);
  for (size_t i = 0; i < file.images.size(); ++i)
    files.push_back({"camera " + std::to_string(i) + "'s image", file.images[i]});
  return files;
}

StereoReport stereo_job(const StereoJobOptions& options, const Progress& progress) {
  const std::string extension = std::filesystem::path(options.output).extension().string();
  if (extension != ".tif" && extension != ".tiff")
    throw ArgumentError(options.output, "output must be a GeoTIFF (.tif)");
  if (!(options.resolution > 0 && options.resolution <= kMaxDsmResolution))
    throw ArgumentError("--res", "must lie in (0, " + short_number(kMaxDsmResolution) + "] CRS units, got " +
                                     short_number(options.resolution));
  if (options.bounds) dsm_grid(*options.bounds, options.resolution);  // checks the bounds
  check_writable(options.output);  // a missing folder is known now, not after the matching

  StereoReport out;
  out.cameras = options.cameras;
  out.output = options.output;
  auto start = std::chrono::steady_clock::now();
  const CameraFile file = read_camera_file(options.cameras);
  const int n = static_cast<int>(file.cameras.size());
  out.camera_count = file.cameras.size();
  Crs crs;
  crs.definition = file.crs;
  try {
    resolve_crs(crs);
  } catch (const ArgumentError& error) {
    throw InputError(options.cameras, "crs", error.problem());
  }
  // The DSM is made on a grid in this CRS: degrees, a geocentric frame or stretched metres refused as for rasters.
  const std::string problem =
      metric_problem(crs, options.cameras, file.cameras[0].center[0], file.cameras[0].center[1]);
  if (!problem.empty()) throw InputError(options.cameras, "crs", problem);

  std::vector<NamedFile> images_in;
  for (int i = 0; i < n; ++i) images_in.push_back({"camera " + std::to_string(i) + "'s image", file.images[i]});
  refuse_overwrites(images_in, {{"-o", options.output}});

  // The images, each read once when first needed.
  std::vector<GreyImage> images(file.cameras.size());
  std::vector<bool> loaded(file.cameras.size(), false);
  const auto need_image = [&](int i) {
    if (!loaded[i]) images[i] = read_image(file.images[i], file.cameras[i], "camera " + std::to_string(i));
    loaded[i] = true;
  };
  if (options.pairs != "auto") parse_pairs(options.pairs, n, "--pairs");  // a bad --pairs fails fast

  // The scene's heights: given, or from a coarse pass over the nearest cameras' images.
  out.min_height = file.min_height;
  out.max_height = file.max_height;
  out.height_range_estimated = !file.has_height_range;
  if (!file.has_height_range) {
    const auto coarse_pairs = height_range_pairs(file.cameras);
    for (const auto& [a, b] : coarse_pairs) need_image(a), need_image(b);
    const auto estimate_start = std::chrono::steady_clock::now();
    try {
      const HeightRangeEstimate estimate = estimate_height_range(file.cameras, images, coarse_pairs);
      out.min_height = estimate.min_height;
      out.max_height = estimate.max_height;
    } catch (const InputError& error) {
      std::string problem = error.what();  // "cameras: ..."
      if (problem.rfind("cameras: ", 0) == 0) problem = problem.substr(9);
      throw InputError(options.cameras, "height_range", "not given, and " + problem + "; give [lowest, highest]");
    }
    out.seconds_height_range = seconds_since(estimate_start);
  }
  report(progress, 0.03);

  // Pairs, before the other images are read: cameras that see nothing in common fail fast.
  const double ground = out.min_height;
  if (options.pairs == "auto") {
    PairSelectionOptions selection;
    selection.ground_height = ground;
    out.pairs = select_pairs_auto(file.cameras, selection);
    if (out.pairs.empty())
      throw InputError(options.cameras, "cameras",
                       "no two cameras overlap by 30 % on the ground with a base-to-height ratio of 0.1..1.2");
  } else {
    out.pairs = parse_pairs(options.pairs, n, "--pairs");
    check_pair_baselines(file.cameras, out.pairs, ground);
  }
  std::array<double, 4> footprint{};
  bool any_footprint = false;
  for (const auto& [a, b] : out.pairs) {
    // The common footprint on the lowest and the highest plane of the scene.
    std::array<double, 4> box, high;
    if (!overlap_box(file.cameras[a], file.cameras[b], ground, box) ||
        !overlap_box(file.cameras[a], file.cameras[b], out.max_height, high))
      throw InputError(options.cameras, "cameras " + std::to_string(a) + " and " + std::to_string(b),
                       "see nothing in common");
    box = {std::min(box[0], high[0]), std::min(box[1], high[1]), std::max(box[2], high[2]), std::max(box[3], high[3])};
    footprint = any_footprint ? std::array<double, 4>{std::min(footprint[0], box[0]), std::min(footprint[1], box[1]),
                                                      std::max(footprint[2], box[2]), std::max(footprint[3], box[3])}
                              : box;
    any_footprint = true;
  }
  if (options.bounds) {
    const auto& b = *options.bounds;
    if (b[2] <= footprint[0] || b[0] >= footprint[2] || b[3] <= footprint[1] || b[1] >= footprint[3])
      throw InputError(options.cameras, "--bounds", "lies outside every pair's common footprint");
    out.bounds = b;
  } else {
    const double r = options.resolution;
    out.bounds = {std::floor(footprint[0] / r) * r, std::floor(footprint[1] / r) * r, std::ceil(footprint[2] / r) * r,
                  std::ceil(footprint[3] / r) * r};
  }
  Grid grid = options.bounds ? dsm_grid(out.bounds, options.resolution)
                             : footprint_grid(out.bounds, options.resolution, options.cameras);
  grid.crs = crs;
  require_memory(options.output, "", 12.0 * grid.cells() + geotiff_buffer_bytes());

  // Every image a pair needs is checked now (a bad one is refused before the long work); its
  // pixels are read when its pair comes (stereo_dsm's ImageSource), so only two are held.
  std::vector<bool> needed(file.cameras.size(), false);
  for (const auto& [a, b] : out.pairs) needed[a] = needed[b] = true;
  for (int i = 0; i < n; ++i)
    if (needed[i] && !loaded[i]) open_image(file.images[i], file.cameras[i], "camera " + std::to_string(i));
  images.clear();  // the height range's images: read again when their pair comes
  const ImageSource source = [&](int i) {
    const auto read_start = std::chrono::steady_clock::now();
    auto image =
        std::make_shared<const GreyImage>(read_image(file.images[i], file.cameras[i], "camera " + std::to_string(i)));
    out.seconds_read += seconds_since(read_start);
    return image;
  };
  out.seconds_read = seconds_since(start) - out.seconds_height_range;
  report(progress, 0.05);

  FrameStereoOptions stereo;
  stereo.rectify.min_height = out.min_height;
  stereo.rectify.max_height = out.max_height;
  stereo.fusion.memory_bytes = options.fusion_memory_bytes;
  stereo.band_bytes = options.band_memory_bytes;
  const FrameStereoStats stats = [&] {
    try {
      return stereo_dsm(file.cameras, source, out.pairs, grid, stereo, sub_progress(progress, 0.05, 0.9));
    } catch (const InputError& error) {
      throw InputError(options.cameras, "", error.what());
    }
  }();
  out.matched_pixels = stats.matched_pixels;
  out.points = stats.points;
  out.points_outside_range = stats.points_outside_range;
  out.points_in_grid = stats.points_in_grid;
  out.fusion_runs_spilled = stats.fusion_runs_spilled;
  out.bands = stats.bands;
  out.seconds_rectify = stats.seconds_rectify;
  out.seconds_match = stats.seconds_match;
  out.seconds_triangulate = stats.seconds_triangulate;
  out.seconds_fuse = stats.seconds_fuse;
  out.width = grid.width;
  out.height = grid.height;
  out.summary = summarize(grid);
  if (out.summary.valid == 0)
    throw InputError(options.cameras, "", "no point of any pair fell into the DSM's bounds: nothing to write");

  start = std::chrono::steady_clock::now();
  write_geotiff(grid, options.output, sub_progress(progress, 0.9, 1.0));
  out.seconds_write = seconds_since(start);
  return out;
}

Json to_json(const StereoReport& r) {
  Json pairs = Json::array();
  for (const auto& [a, b] : r.pairs) pairs.push_back({a, b});
  const double total = r.seconds_read + r.seconds_height_range + r.seconds_rectify + r.seconds_match +
                       r.seconds_triangulate + r.seconds_fuse + r.seconds_write;
  return {{"cameras", r.cameras},
          {"output", r.output},
          {"camera_count", r.camera_count},
          {"pairs", pairs},
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
}

}  // namespace dsmplan
