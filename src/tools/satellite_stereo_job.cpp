// dsmplan stereo IMG1 IMG2 [IMG3 ...]: satellite images with RPC cameras to a GeoTIFF DSM (issue
// 17). The algorithms are those of dsmplan/rpc_stereo.hpp (src/stereo, no GDAL: s2p's
// tile-wise chain, de Franchis et al., ISPRS Annals II-3, 2014) and the median fusion of
// stereo_frames.hpp; here only what needs files and PROJ: the RPCs and image windows through
// GDAL, the footprints and tiles, the points into the output CRS, the GeoTIFF out.
// dsmplan/satellite_stereo_job.hpp is the manual.
#include "dsmplan/satellite_stereo_job.hpp"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <limits>
#include <memory>
#include <mutex>

#include "core/atomic_file.hpp"
#include "core/text.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/median_fusion.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/rpc.hpp"
#include "dsmplan/rpc_io.hpp"
#include "dsmplan/rpc_stereo.hpp"
#include "dsmplan/stereo_frames.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

const char* const kHeightsValue = "EPSG:4979 (heights above the WGS 84 ellipsoid)";

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string metres_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f", v);
  return text;
}

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};

// A satellite image: its camera and its raster, open for windows.
struct SatImage {
  std::string path;
  RpcCamera camera;
  std::unique_ptr<GDALDataset, DatasetCloser> dataset;
  int width = 0, height = 0;
  bool has_nodata = false;
  double nodata = 0;
  SatImage(std::string p, RpcCamera c) : path(std::move(p)), camera(std::move(c)) {}
};

SatImage open_image(const std::string& path) {
  require_input_file(path);
  SatImage image(path, read_rpc_camera(path));  // InputError: no RPC, a bad .geom, not a raster
  GDALAllRegister();
  CPLPushErrorHandler(CPLQuietErrorHandler);
  image.dataset.reset(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  CPLPopErrorHandler();
  if (!image.dataset || image.dataset->GetRasterCount() < 1)
    throw InputError(path, "", "is not a raster image GDAL can read");
  GDALRasterBand* band = image.dataset->GetRasterBand(1);
  const GDALDataType type = band->GetRasterDataType();
  if (type != GDT_Byte && type != GDT_UInt16 && type != GDT_Int16)
    throw InputError(path, "", std::string("image is ") + GDALGetDataTypeName(type) + ": give 8- or 16-bit images");
  image.width = image.dataset->GetRasterXSize();
  image.height = image.dataset->GetRasterYSize();
  int has = 0;
  image.nodata = band->GetNoDataValue(&has);
  image.has_nodata = has != 0;
  return image;
}

// A window of pixels [c0, c0 + w) x [r0, r0 + h) of band 1 as floats, no data as NaN.
FloatImage read_window(SatImage& image, int c0, int r0, int w, int h) {
  FloatImage out;
  out.width = w, out.height = h;
  require_memory(image.path, "", 4.0 * w * h);
  out.pixels.resize(static_cast<std::size_t>(w) * h);
  CPLErrorReset();
  if (image.dataset->GetRasterBand(1)->RasterIO(GF_Read, c0, r0, w, h, out.pixels.data(), w, h, GDT_Float32, 0, 0,
                                                nullptr) != CE_None)
    throw InputError(image.path, "window at (" + std::to_string(c0) + ", " + std::to_string(r0) + ")",
                     std::string("cannot be read: ") + CPLGetLastErrorMsg());
  if (image.has_nodata)
    for (float& v : out.pixels)
      if (v == static_cast<float>(image.nodata)) v = NAN;
  return out;
}

struct Box {  // pixels [c0, c1) x [r0, r1)
  int c0 = 0, r0 = 0, c1 = 0, r1 = 0;
  int width() const { return c1 - c0; }
  int height() const { return r1 - r0; }
  bool empty() const { return c1 <= c0 || r1 <= r0; }
};

Box clamp_box(double c0, double r0, double c1, double r1, int w, int h) {
  Box b;
  b.c0 = std::clamp(static_cast<int>(std::floor(c0)), 0, w);
  b.r0 = std::clamp(static_cast<int>(std::floor(r0)), 0, h);
  b.c1 = std::clamp(static_cast<int>(std::ceil(c1)), 0, w);
  b.r1 = std::clamp(static_cast<int>(std::ceil(r1)), 0, h);
  return b;
}

// The window of the right image that sees a window of the left one over a height range: the
// left window's corners and centre localized at both ends of the range, projected, padded.
Box right_window(const SatImage& left, const Box& lw, const SatImage& right, double lo, double hi, double pad) {
  double c0 = 1e300, r0 = 1e300, c1 = -1e300, r1 = -1e300;
  const PixelPoint probes[5] = {{double(lw.c0), double(lw.r0)},
                                {double(lw.c1), double(lw.r0)},
                                {double(lw.c0), double(lw.r1)},
                                {double(lw.c1), double(lw.r1)},
                                {0.5 * (lw.c0 + lw.c1), 0.5 * (lw.r0 + lw.r1)}};
  for (const PixelPoint& p : probes)
    for (double h : {lo, hi}) {
      try {
        const PixelPoint q = right.camera.project(left.camera.localize(p, h));
        c0 = std::min(c0, q.col), r0 = std::min(r0, q.row), c1 = std::max(c1, q.col), r1 = std::max(r1, q.row);
      } catch (const InputError&) {
      }
    }
  if (c0 > c1) return {};
  return clamp_box(c0 - pad, r0 - pad, c1 + pad, r1 + pad, right.width, right.height);
}

// The output CRS: --crs or WGS 84 / UTM of the point, made 3D when it is 2D.
OGRSpatialReference output_srs(const std::string& text, const GeoPoint& centre, std::string& definition) {
  definition = text;
  if (definition.empty()) {
    const int zone = std::clamp(static_cast<int>(std::floor((centre.lon + 180) / 6)) + 1, 1, 60);
    definition = "EPSG:" + std::to_string((centre.lat >= 0 ? 32600 : 32700) + zone);
  }
  OGRSpatialReference srs;
  CPLPushErrorHandler(CPLQuietErrorHandler);
  const OGRErr parsed = srs.SetFromUserInput(definition.c_str());
  CPLPopErrorHandler();
  if (parsed != OGRERR_NONE) throw ArgumentError("--crs", "'" + definition + "' is not a CRS GDAL/PROJ can read");
  if (!srs.IsProjected())
    throw ArgumentError("--crs", "'" + definition + "' is not a projected CRS: give one in metres, e.g. EPSG:32637");
  if (std::abs(srs.GetLinearUnits() - 1) > 1e-9)
    throw ArgumentError("--crs", "'" + definition + "' is not in metres: dsmplan measures in metres");
  if (!srs.IsCompound() && srs.GetAxesCount() == 2) srs.PromoteTo3D(nullptr);
  return srs;
}

struct PairWork {
  SatellitePairReport report;
  std::vector<PixelPoint> lattice;  // of the left image, seen by the right one
  Box region;                       // of the left image: the overlap
};

}  // namespace

SatelliteStereoReport satellite_stereo_job(const SatelliteStereoOptions& options, const Progress& progress) {
  const std::string extension = std::filesystem::path(options.output).extension().string();
  if (extension != ".tif" && extension != ".tiff") throw ArgumentError("-o", "output must be a GeoTIFF (.tif)");
  if (options.images.size() < 2) throw ArgumentError("IMAGES", "give two or more satellite images with RPCs");
  if (!(options.resolution > 0 && options.resolution <= kMaxDsmResolution))
    throw ArgumentError("--res", "must lie in (0, " + short_number(kMaxDsmResolution) + "] metres, got " +
                                     short_number(options.resolution));
  if (options.tile_size < 64 || options.tile_size > 4096) throw ArgumentError("tile_size", "must be 64..4096 pixels");
  if (options.bounds) dsm_grid(*options.bounds, options.resolution);  // checks the bounds
  check_writable(options.output);  // a missing folder is known now, not after the matching

  SatelliteStereoReport out;
  out.images = options.images;
  out.output = options.output;
  auto start = std::chrono::steady_clock::now();
  std::vector<SatImage> images;
  for (const std::string& path : options.images) images.push_back(open_image(path));
  out.seconds_read = seconds_since(start);

  // The output CRS (checked before any long work).
  const RpcModel& m0 = images[0].camera.model();
  GeoPoint centre;
  try {
    centre = images[0].camera.localize({0.5 * images[0].width, 0.5 * images[0].height}, m0.height_off);
  } catch (const InputError& error) {
    throw InputError(images[0].path, "", std::string("the image's centre does not localize: ") + error.what());
  }
  std::string definition;
  const OGRSpatialReference srs = output_srs(options.crs, centre, definition);
  // The file states the CRS as given (GDAL's GeoTIFF writer keeps no 3D projected CRS in the
  // GeoKeys: it would go to a side-car .aux.xml); the ellipsoidal heights are stated in the
  // file's metadata (kEllipsoidalHeightsKey) for a 2D CRS.
  out.crs.definition = definition;
  resolve_crs(out.crs);
  const bool ellipsoidal = !srs.IsCompound();
  // The points (longitude, latitude, height on the WGS 84 ellipsoid) go to the CRS as made 3D
  // (ellipsoidal heights of its datum), or to the compound CRS's heights through its geoid grid:
  // where PROJ lacks that grid, refused unless --allow-approximate-vertical (then through EGM96,
  // and the report says so), never ellipsoidal heights labelled as the datum's.
  Crs heights_crs;
  {
    char* wkt = nullptr;
    const char* wkt_options[] = {"FORMAT=WKT2_2019", "MULTILINE=NO", nullptr};
    if (srs.exportToWkt(&wkt, wkt_options) == OGRERR_NONE && wkt) heights_crs.definition = wkt;
    CPLFree(wkt);
  }
  const std::array<double, 4> area{centre.lon - 0.5, centre.lat - 0.5, centre.lon + 0.5, centre.lat + 0.5};
  const Wgs84Transform to_output = [&] {
    try {
      return Wgs84Transform(heights_crs, HeightReference::Ellipsoid, {"", options.allow_approximate_vertical}, area);
    } catch (const ArgumentError& error) {
      throw ArgumentError("--crs", "'" + definition + "': " + error.problem());
    }
  }();
  out.transformation = to_output.description();
  // One point to the output CRS; NaN where PROJ cannot take it.
  const auto to_ground = [&](const GeoPoint& g) {
    std::vector<Point3> one{{g.lon, g.lat, g.height}};
    to_output.from_wgs84(one);
    return Vec3{one[0][0], one[0][1], one[0][2]};
  };

  // Pairs whose footprints overlap, and the scene's heights in each (steps 2 and 3).
  std::vector<PairWork> pairs;
  std::exception_ptr first_failure;
  const int n = static_cast<int>(images.size());
  report(progress, 0.01);
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      SatImage& L = images[i];
      SatImage& R = images[j];
      PairWork work;
      SatellitePairReport& pr = work.report;
      pr.left = i, pr.right = j;
      try {
        const RpcModel &a = L.camera.model(), &b = R.camera.model();
        pr.rpc_height_min = std::max(a.height_off - std::abs(a.height_scale), b.height_off - std::abs(b.height_scale));
        pr.rpc_height_max = std::min(a.height_off + std::abs(a.height_scale), b.height_off + std::abs(b.height_scale));
        if (!(pr.rpc_height_max > pr.rpc_height_min))
          throw InputError(R.path, "", "its RPC's height range and " + L.path + "'s do not intersect");
        const double mid = 0.5 * (pr.rpc_height_min + pr.rpc_height_max);
        // The lattice pixels of the left image whose ground at height h the right image sees.
        auto seen_at = [&](double h) {
          std::vector<PixelPoint> seen;
          for (int v = 0; v < 17; ++v)
            for (int u = 0; u < 17; ++u) {
              const PixelPoint p{(u + 0.5) * L.width / 17.0, (v + 0.5) * L.height / 17.0};
              try {
                const PixelPoint q = R.camera.project(L.camera.localize(p, h));
                if (q.col >= 0 && q.row >= 0 && q.col <= R.width && q.row <= R.height) seen.push_back(p);
              } catch (const InputError&) {
              }
            }
          return seen;
        };
        work.lattice = seen_at(mid);
        for (double h : {pr.rpc_height_min, pr.rpc_height_max})
          for (const PixelPoint& p : seen_at(h))
            if (std::none_of(work.lattice.begin(), work.lattice.end(),
                             [&](const PixelPoint& q) { return q.col == p.col && q.row == p.row; }))
              work.lattice.push_back(p);
        pr.overlap = static_cast<double>(work.lattice.size()) / 289.0;
        if (work.lattice.empty()) {
          // Would they overlap at heights the RPCs were not made for (the scene outside their range)?
          for (double h = -500; h <= 9000; h += 100)
            if ((h < pr.rpc_height_min || h > pr.rpc_height_max) && !seen_at(h).empty())
              throw InputError(R.path, "",
                               "overlaps " + L.path + " only at heights outside the RPCs' height range " +
                                   metres_text(pr.rpc_height_min) + ".." + metres_text(pr.rpc_height_max) +
                                   " m above the WGS 84 ellipsoid (at about " + metres_text(h) +
                                   " m): the scene lies outside the range the RPCs were made for");
          throw InputError(R.path, "",
                           "does not overlap " + L.path + " on the ground (no pixel of the latter, localized at " +
                               metres_text(pr.rpc_height_min) + ".." + metres_text(pr.rpc_height_max) +
                               " m above the WGS 84 ellipsoid, falls in it)");
        }
        double c0 = 1e300, r0 = 1e300, c1 = -1e300, r1 = -1e300;
        for (const PixelPoint& p : work.lattice)
          c0 = std::min(c0, p.col), r0 = std::min(r0, p.row), c1 = std::max(c1, p.col), r1 = std::max(r1, p.row);
        const double du = L.width / 17.0, dv = L.height / 17.0;
        work.region = clamp_box(c0 - du, r0 - dv, c1 + du, r1 + dv, L.width, L.height);

        // Survey: tie points across the RPCs' whole height range on up to 2 x 2 tiles.
        auto t0 = std::chrono::steady_clock::now();
        std::vector<double> heights;
        const Box& g = work.region;
        const int kx = g.width() > 768 ? 2 : 1, ky = g.height() > 768 ? 2 : 1;
        for (int sy = 0; sy < ky; ++sy)
          for (int sx = 0; sx < kx; ++sx) {
            const int sw = std::min(384, g.width() / kx), sh = std::min(384, g.height() / ky);
            if (sw < 32 || sh < 32) continue;
            const int cx = g.c0 + static_cast<int>((sx + 0.5) * g.width() / kx);
            const int cy = g.r0 + static_cast<int>((sy + 0.5) * g.height() / ky);
            const Box lw = clamp_box(cx - sw / 2, cy - sh / 2, cx + (sw + 1) / 2, cy + (sh + 1) / 2, L.width, L.height);
            const Box rw = right_window(L, lw, R, pr.rpc_height_min, pr.rpc_height_max, 32);
            if (lw.width() < 32 || lw.height() < 32 || rw.width() < 16 || rw.height() < 16) continue;
            auto tr = std::chrono::steady_clock::now();
            const FloatImage li = read_window(L, lw.c0, lw.r0, lw.width(), lw.height());
            const FloatImage ri = read_window(R, rw.c0, rw.r0, rw.width(), rw.height());
            pr.seconds_read += seconds_since(tr);
            const RpcTile tile{0, 0, lw.width(), lw.height(), pr.rpc_height_min, pr.rpc_height_max};
            const auto found =
                tie_point_heights(L.camera.crop(lw.c0, lw.r0), li, R.camera.crop(rw.c0, rw.r0), ri, tile);
            heights.insert(heights.end(), found.begin(), found.end());
          }
        pr.survey_tie_points = heights.size();
        pr.seconds_survey = seconds_since(t0) - pr.seconds_read;
        if (heights.size() < 10)
          throw InputError(R.path, "",
                           "matches " + L.path + " nowhere within the RPCs' height range " +
                               metres_text(pr.rpc_height_min) + ".." + metres_text(pr.rpc_height_max) +
                               " m above the WGS 84 ellipsoid (" + std::to_string(heights.size()) +
                               " tie points): the scene lies outside the range the RPCs were made for, or the "
                               "images do not show the same ground");
        std::sort(heights.begin(), heights.end());
        const double p1 = heights[heights.size() / 100], p99 = heights[heights.size() - 1 - heights.size() / 100];
        const double widen = 20 + 0.1 * (p99 - p1);
        pr.height_min = std::max(pr.rpc_height_min, p1 - widen);
        pr.height_max = std::min(pr.rpc_height_max, p99 + widen);
        pairs.push_back(std::move(work));
      } catch (const InputError&) {
        if (!first_failure) first_failure = std::current_exception();
      }
    }
  if (pairs.empty()) std::rethrow_exception(first_failure);
  report(progress, 0.1);

  // The footprints on the ground: the overlap lattice at the scene's heights.
  std::array<double, 4> footprint{1e300, 1e300, -1e300, -1e300};
  for (const PairWork& w : pairs) {
    const SatImage& L = images[w.report.left];
    for (const PixelPoint& p : w.lattice)
      for (double h : {w.report.height_min, w.report.height_max}) {
        try {
          const Vec3 X = to_ground(L.camera.localize(p, h));
          if (!std::isfinite(X[0])) continue;
          footprint = {std::min(footprint[0], X[0]), std::min(footprint[1], X[1]), std::max(footprint[2], X[0]),
                       std::max(footprint[3], X[1])};
        } catch (const InputError&) {
        }
      }
  }
  if (!(footprint[2] > footprint[0] && footprint[3] > footprint[1]))
    throw InputError(images[0].path, "", "the pairs' footprints do not transform into the output CRS");
  const double res = options.resolution;
  if (options.bounds) {
    const auto& b = *options.bounds;
    if (b[2] <= footprint[0] || b[0] >= footprint[2] || b[3] <= footprint[1] || b[1] >= footprint[3])
      throw InputError(images[0].path, "--bounds", "lies outside every pair's footprint");
    out.bounds = b;
  } else {
    out.bounds = {std::floor(footprint[0] / res) * res, std::floor(footprint[1] / res) * res,
                  std::ceil(footprint[2] / res) * res, std::ceil(footprint[3] / res) * res};
  }
  Grid grid = options.bounds ? dsm_grid(out.bounds, res) : footprint_grid(out.bounds, res, images[0].path);
  grid.crs = out.crs;
  out.width = grid.width, out.height = grid.height;
  require_memory(options.output, "", 12.0 * grid.cells() + geotiff_buffer_bytes());

  // The tiles of each pair: the left image's pixels (every 16th) whose ground lies in the grid.
  struct Tile {
    int pair;
    Box box;
  };
  std::vector<Tile> tiles;
  const double reach_m = 16 * 1.0 + 2 * res;  // how far outside the grid a lattice pixel may lie
  for (int k = 0; k < static_cast<int>(pairs.size()); ++k) {
    const PairWork& w = pairs[k];
    const SatImage& L = images[w.report.left];
    const SatImage& R = images[w.report.right];
    const double mid = 0.5 * (w.report.height_min + w.report.height_max);
    double c0 = 1e300, r0 = 1e300, c1 = -1e300, r1 = -1e300;
    for (int v = w.region.r0; v <= w.region.r1; v += 16)
      for (int u = w.region.c0; u <= w.region.c1; u += 16) {
        const PixelPoint p{double(u), double(v)};
        bool inside = false;
        try {
          const PixelPoint q = R.camera.project(L.camera.localize(p, mid));
          if (q.col < 0 || q.row < 0 || q.col > R.width || q.row > R.height) continue;
          for (double h : {w.report.height_min, w.report.height_max}) {
            const Vec3 X = to_ground(L.camera.localize(p, h));
            inside = inside || (X[0] > grid.x0 - reach_m && X[0] < grid.x1() + reach_m && X[1] > grid.y1() - reach_m &&
                                X[1] < grid.y0 + reach_m);
          }
        } catch (const InputError&) {
          continue;
        }
        if (inside)
          c0 = std::min(c0, p.col), r0 = std::min(r0, p.row), c1 = std::max(c1, p.col), r1 = std::max(r1, p.row);
      }
    if (c0 > c1) continue;
    const Box region = clamp_box(c0 - 16, r0 - 16, c1 + 16, r1 + 16, L.width, L.height);
    const int T = options.tile_size;
    const int nx = (region.width() + T - 1) / T, ny = (region.height() + T - 1) / T;
    for (int ty = 0; ty < ny; ++ty)
      for (int tx = 0; tx < nx; ++tx) {
        Box b;
        b.c0 = region.c0 + static_cast<int>(static_cast<long>(region.width()) * tx / nx);
        b.c1 = region.c0 + static_cast<int>(static_cast<long>(region.width()) * (tx + 1) / nx);
        b.r0 = region.r0 + static_cast<int>(static_cast<long>(region.height()) * ty / ny);
        b.r1 = region.r0 + static_cast<int>(static_cast<long>(region.height()) * (ty + 1) / ny);
        if (!b.empty()) tiles.push_back({k, b});
      }
  }
  if (tiles.empty()) throw InputError(images[0].path, "--bounds", "lies outside every pair's footprint");

  // Step 4 and 5 per tile.
  MedianFusionOptions fusion_options;
  fusion_options.memory_bytes = options.fusion_memory_bytes;
  MedianFusion fusion(grid, fusion_options);
  std::vector<Vec3> points;
  RpcTileStereoOptions tile_options;
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    PairWork& w = pairs[tiles[t].pair];
    SatellitePairReport& pr = w.report;
    SatImage& L = images[pr.left];
    SatImage& R = images[pr.right];
    const Box& b = tiles[t].box;
    const Box lw = clamp_box(b.c0 - tile_options.margin, b.r0 - tile_options.margin, b.c1 + tile_options.margin,
                             b.r1 + tile_options.margin, L.width, L.height);
    const Box rw = right_window(L, lw, R, pr.height_min, pr.height_max, 32);
    if (rw.width() < 16 || rw.height() < 16) continue;
    auto t0 = std::chrono::steady_clock::now();
    const FloatImage li = read_window(L, lw.c0, lw.r0, lw.width(), lw.height());
    const FloatImage ri = read_window(R, rw.c0, rw.r0, rw.width(), rw.height());
    pr.seconds_read += seconds_since(t0);
    const RpcTile tile{b.c0 - lw.c0, b.r0 - lw.r0, b.width(), b.height(), pr.height_min, pr.height_max};
    RpcTileStereo result;
    try {
      result = rpc_tile_stereo(L.camera.crop(lw.c0, lw.r0), li, R.camera.crop(rw.c0, rw.r0), ri, tile, tile_options);
    } catch (const ArgumentError& error) {
      throw InputError(L.path, "tile at (" + std::to_string(b.c0) + ", " + std::to_string(b.r0) + ")", error.what());
    }
    ++pr.tiles;
    pr.tiles_pointing_corrected += result.pointing_corrected;
    pr.tie_points += result.tie_points;
    pr.tile_pixels += result.tile_pixels;
    pr.matched_pixels += result.matched_pixels;
    pr.points += result.points.size();
    pr.seconds_rectify += result.seconds_rectify;
    pr.seconds_pointing += result.seconds_pointing;
    pr.seconds_match += result.seconds_match;
    pr.seconds_triangulate += result.seconds_triangulate;
    t0 = std::chrono::steady_clock::now();
    points.clear();
    points.reserve(result.points.size());
    for (const RpcStereoPoint& p : result.points) points.push_back({p.ground.lon, p.ground.lat, p.ground.height});
    to_output.from_wgs84(points);
    points.erase(std::remove_if(points.begin(), points.end(), [](const Vec3& q) { return std::isnan(q[0]); }),
                 points.end());
    out.points += points.size();
    out.seconds_transform += seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    fusion.add(points);
    out.seconds_fuse += seconds_since(t0);
    report(progress, 0.1 + 0.8 * static_cast<double>(t + 1) / static_cast<double>(tiles.size()));
  }

  start = std::chrono::steady_clock::now();
  out.points_in_grid = fusion.finish(grid);
  out.fusion_runs_spilled = fusion.runs_spilled();
  out.summary = summarize(grid);
  out.completeness = grid.cells() ? static_cast<double>(out.summary.valid) / static_cast<double>(grid.cells()) : 0;
  out.seconds_fuse += seconds_since(start);
  for (PairWork& w : pairs) {
    const SatellitePairReport& pr = w.report;
    out.seconds_read += pr.seconds_read;
    out.seconds_survey += pr.seconds_survey;
    out.seconds_rectify += pr.seconds_rectify;
    out.seconds_pointing += pr.seconds_pointing;
    out.seconds_match += pr.seconds_match;
    out.seconds_triangulate += pr.seconds_triangulate;
    out.pairs.push_back(pr);
  }
  if (out.summary.valid == 0)
    throw InputError(images[0].path, "", "no matched point fell into the DSM's bounds: nothing to write");
  start = std::chrono::steady_clock::now();
  {
    AtomicFile file(options.output);  // the GeoTIFF and its metadata, or nothing
    file.close_stream();
    write_geotiff(grid, file.temp_path(), sub_progress(progress, 0.9, 1.0));
    if (ellipsoidal) {
      CPLErrorReset();
      std::unique_ptr<GDALDataset, DatasetCloser> written(
          GDALDataset::Open(file.temp_path().c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
      if (!written)
        throw OutputError(options.output, std::string("cannot reopen to state the heights: ") + CPLGetLastErrorMsg());
      OGRSpatialReference geographic;
      geographic.CopyGeogCSFrom(&srs);
      const std::string datum = geographic.GetName() ? geographic.GetName() : "";
      written->SetMetadataItem(kEllipsoidalHeightsKey, datum == "WGS 84"
                                                           ? kHeightsValue
                                                           : ("heights above the " + datum + " ellipsoid").c_str());
      written.reset();
      if (CPLGetLastErrorType() >= CE_Failure)
        throw OutputError(options.output, std::string("cannot state the heights: ") + CPLGetLastErrorMsg());
    }
    file.commit();
  }
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
