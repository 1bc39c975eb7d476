// The dsmplan command line, tested through the real binary (testkit::run_cli).
//
// Expectations come from independent sources, never from an earlier run of dsmplan:
//   - raster facts from GDAL's own C API, called here in the test;
//   - LAS bounds from the LAS header bytes, decoded here;
//   - grid and mesh counts from arithmetic on the raster size (a full grid of nx x ny vertices
//     has 2 (nx-1)(ny-1) triangles);
//   - bad inputs are written by the test itself, so it knows what is wrong with them.
#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_minixml.h>
#include <cpl_vsi.h>
#include <fcntl.h>
#include <gdal.h>
#include <gtest/gtest.h>
#include <ogr_srs_api.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "dsmplan/clearance.hpp"
#include "dsmplan/columns.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/wgs84.hpp"
#include "testkit.hpp"

using nlohmann::json;
using testkit::run_cli;
using testkit::TempDir;

namespace {

const std::string kSample = "nrw-dom1/nrw_dom1_crop500m_1m.tif";
const std::string kProgress = "0...10...20...30...40...50...60...70...80...90...100 - done.";

// ---- rasters through GDAL (the oracle and the writer of test inputs) ----------------------

struct Raster {
  int width = 0, height = 0;
  double gt[6] = {0, 1, 0, 0, 0, -1};
  std::string wkt;       // empty: no CRS
  std::vector<float> z;  // row-major, as stored
  bool has_nodata = false;
  double nodata = 0;
};

Raster read_with_gdal(const std::string& path) {
  GDALDatasetH dataset = GDALOpen(path.c_str(), GA_ReadOnly);
  if (!dataset) throw std::runtime_error("GDAL cannot open " + path);
  Raster r;
  r.width = GDALGetRasterXSize(dataset);
  r.height = GDALGetRasterYSize(dataset);
  GDALGetGeoTransform(dataset, r.gt);
  if (const char* wkt = GDALGetProjectionRef(dataset)) r.wkt = wkt;
  GDALRasterBandH band = GDALGetRasterBand(dataset, 1);
  int has_nodata = 0;
  r.nodata = GDALGetRasterNoDataValue(band, &has_nodata);
  r.has_nodata = has_nodata != 0;
  r.z.resize(static_cast<size_t>(r.width) * r.height);
  if (GDALRasterIO(band, GF_Read, 0, 0, r.width, r.height, r.z.data(), r.width, r.height, GDT_Float32, 0, 0) !=
      CE_None) {
    GDALClose(dataset);
    throw std::runtime_error("GDAL cannot read " + path);
  }
  GDALClose(dataset);
  return r;
}

void write_with_gdal(const Raster& r, const std::string& path) {
  GDALDriverH driver = GDALGetDriverByName("GTiff");
  GDALDatasetH dataset = GDALCreate(driver, path.c_str(), r.width, r.height, 1, GDT_Float32, nullptr);
  if (!dataset) throw std::runtime_error("GDAL cannot create " + path);
  double gt[6];
  std::copy(std::begin(r.gt), std::end(r.gt), gt);
  GDALSetGeoTransform(dataset, gt);
  if (!r.wkt.empty()) GDALSetProjection(dataset, r.wkt.c_str());
  GDALRasterBandH band = GDALGetRasterBand(dataset, 1);
  if (r.has_nodata) GDALSetRasterNoDataValue(band, r.nodata);
  std::vector<float> z = r.z;
  const CPLErr status =
      GDALRasterIO(band, GF_Write, 0, 0, r.width, r.height, z.data(), r.width, r.height, GDT_Float32, 0, 0);
  GDALClose(dataset);
  if (status != CE_None) throw std::runtime_error("GDAL cannot write " + path);
}

std::string epsg_wkt(int code) {
  OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(srs, code);
  char* wkt = nullptr;
  OSRExportToWkt(srs, &wkt);
  std::string out = wkt;
  CPLFree(wkt);
  OSRDestroySpatialReference(srs);
  return out;
}

// A small geo-referenced raster (EPSG:25832 unless told otherwise) with distinct heights.
Raster small_raster(int width, int height, bool with_crs = true) {
  Raster r;
  r.width = width;
  r.height = height;
  const double gt[6] = {356300, 1, 0, 5699750, 0, -1};
  std::copy(std::begin(gt), std::end(gt), r.gt);
  if (with_crs) r.wkt = epsg_wkt(25832);
  for (int i = 0; i < width * height; ++i) r.z.push_back(100.0f + 0.5f * static_cast<float>(i));
  return r;
}

// Authority code of a WKT's (horizontal) CRS as GDAL/OSR sees it; 0 when there is none.
int epsg_of(const std::string& wkt) {
  OGRSpatialReferenceH srs = OSRNewSpatialReference(wkt.c_str());
  const char* code = OSRGetAuthorityCode(srs, nullptr);
  if (!code && OSRAutoIdentifyEPSG(srs) == OGRERR_NONE) code = OSRGetAuthorityCode(srs, nullptr);
  const int result = code ? std::atoi(code) : 0;
  OSRDestroySpatialReference(srs);
  return result;
}

// Number of 4-connected regions of cells for which `is_nodata` holds (plain flood fill).
size_t count_regions(int width, int height, const std::vector<bool>& is_nodata) {
  std::vector<bool> seen(is_nodata.size(), false);
  size_t regions = 0;
  std::vector<size_t> stack;
  for (size_t start = 0; start < is_nodata.size(); ++start) {
    if (!is_nodata[start] || seen[start]) continue;
    ++regions;
    seen[start] = true;
    stack.push_back(start);
    while (!stack.empty()) {
      const size_t i = stack.back();
      stack.pop_back();
      const int col = static_cast<int>(i % width), row = static_cast<int>(i / width);
      const int dc[4] = {1, -1, 0, 0}, dr[4] = {0, 0, 1, -1};
      for (int k = 0; k < 4; ++k) {
        const int c = col + dc[k], r = row + dr[k];
        if (c < 0 || r < 0 || c >= width || r >= height) continue;
        const size_t j = static_cast<size_t>(r) * width + c;
        if (is_nodata[j] && !seen[j]) {
          seen[j] = true;
          stack.push_back(j);
        }
      }
    }
  }
  return regions;
}

// ---- LAS header bytes (LAS 1.2 public header block) ---------------------------------------

struct LasBounds {
  double max_x, min_x, max_y, min_y, max_z, min_z;
};

LasBounds las_bounds(const std::string& path) {
  const std::string bytes = testkit::read_file(path);
  if (bytes.size() < 227) throw std::runtime_error("short LAS header in " + path);
  double v[6];
  std::memcpy(v, bytes.data() + 179, sizeof v);  // little-endian doubles; the test host is little-endian
  return {v[0], v[1], v[2], v[3], v[4], v[5]};
}

// ---- output checks -------------------------------------------------------------------------

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool contains_any(const std::string& text, const std::vector<std::string>& needles) {
  const std::string haystack = lower(text);
  return std::any_of(needles.begin(), needles.end(),
                     [&](const std::string& n) { return haystack.find(lower(n)) != std::string::npos; });
}

// The error contract: failure exit code, one line on stderr naming `subject`, saying `what`
// (any one of the given phrases), and nothing left in the output folder.
void expect_clean_failure(const testkit::CliResult& result, const TempDir& output, const std::string& subject,
                          const std::vector<std::string>& what) {
  EXPECT_NE(result.exit_code, 0);
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << "stderr: " << result.err;
  EXPECT_TRUE(!result.err.empty() && result.err.back() == '\n') << "stderr: " << result.err;
  EXPECT_NE(result.err.find(subject), std::string::npos) << "stderr should name '" << subject << "': " << result.err;
  EXPECT_TRUE(contains_any(result.err, what)) << "stderr should say what is wrong: " << result.err;
  EXPECT_TRUE(output.files().empty()) << "left behind: " << (output.files().empty() ? "" : output.files().front());
}

// A height from dsmplan's JSON as the float32 it stands for.
float as_float(const json& value) { return static_cast<float>(value.get<double>()); }

// The PLY header (up to "end_header"), as lines.
std::vector<std::string> ply_header(const std::string& bytes) {
  const size_t end = bytes.find("end_header\n");
  if (end == std::string::npos) throw std::runtime_error("no end_header in PLY");
  std::vector<std::string> lines;
  std::istringstream in(bytes.substr(0, end));
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

long long header_count(const std::vector<std::string>& lines, const std::string& prefix) {
  for (const auto& line : lines) {
    if (line.rfind(prefix, 0) == 0) return std::stoll(line.substr(prefix.size()));
  }
  return -1;
}

bool has_line_starting(const std::vector<std::string>& lines, const std::string& prefix) {
  return std::any_of(lines.begin(), lines.end(), [&](const std::string& l) { return l.rfind(prefix, 0) == 0; });
}

bool has_line(const std::vector<std::string>& lines, const std::string& line) {
  return std::find(lines.begin(), lines.end(), line) != lines.end();
}

size_t count_lines_starting(const std::string& text, const std::string& prefix) {
  std::istringstream in(text);
  size_t n = 0;
  for (std::string line; std::getline(in, line);) n += line.rfind(prefix, 0) == 0;
  return n;
}

}  // namespace

// ==== info ==================================================================================

TEST(CliInfo, JsonMatchesGdalOnRealSample) {
  const std::string path = testkit::data_path(kSample);
  GDALDatasetH dataset = GDALOpen(path.c_str(), GA_ReadOnly);
  ASSERT_NE(dataset, nullptr);
  const int width = GDALGetRasterXSize(dataset), height = GDALGetRasterYSize(dataset);
  double gt[6];
  ASSERT_EQ(GDALGetGeoTransform(dataset, gt), CE_None);
  GDALRasterBandH band = GDALGetRasterBand(dataset, 1);
  double minmax[2];
  ASSERT_EQ(GDALComputeRasterMinMax(band, FALSE, minmax), CE_None);  // exact, not approximate
  OGRSpatialReferenceH srs = OSRNewSpatialReference(GDALGetProjectionRef(dataset));
  const std::string crs_name = OSRGetName(srs);
  const char* code = OSRGetAuthorityCode(srs, nullptr);
  ASSERT_NE(code, nullptr);
  const int epsg = std::atoi(code);
  const bool compound = OSRIsCompound(srs);
  OSRDestroySpatialReference(srs);
  const char* unit_type = GDALGetRasterUnitType(band);
  const std::string unit = unit_type ? unit_type : "";
  GDALClose(dataset);
  // The sample has no declared nodata (so every cell counts as valid) and a 2D CRS; the
  // expectations below for nodata and vertical datum rely on that.
  const Raster cells = read_with_gdal(path);
  ASSERT_FALSE(cells.has_nodata);
  ASSERT_FALSE(compound);

  const auto result = run_cli({"info", path, "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  const json info = json::parse(result.out);

  EXPECT_EQ(info["width"].get<int>(), width);
  EXPECT_EQ(info["height"].get<int>(), height);
  EXPECT_DOUBLE_EQ(info["resolution"][0].get<double>(), gt[1]);
  EXPECT_DOUBLE_EQ(info["resolution"][1].get<double>(), -gt[5]);
  EXPECT_DOUBLE_EQ(info["extent"]["xmin"].get<double>(), gt[0]);
  EXPECT_DOUBLE_EQ(info["extent"]["ymax"].get<double>(), gt[3]);
  EXPECT_DOUBLE_EQ(info["extent"]["xmax"].get<double>(), gt[0] + width * gt[1]);
  EXPECT_DOUBLE_EQ(info["extent"]["ymin"].get<double>(), gt[3] + height * gt[5]);
  EXPECT_EQ(info["crs"]["name"].get<std::string>(), crs_name);
  EXPECT_EQ(info["crs"]["epsg"].get<int>(), epsg);
  ASSERT_TRUE(info["crs"]["wkt"].is_string());
  EXPECT_EQ(epsg_of(info["crs"]["wkt"].get<std::string>()), epsg) << "the WKT should describe the same CRS";
  EXPECT_TRUE(info["vertical"]["name"].is_null()) << "a 2D CRS names no vertical datum";
  if (unit.empty())
    EXPECT_TRUE(info["vertical"]["unit"].is_null());
  else
    EXPECT_EQ(info["vertical"]["unit"].get<std::string>(), unit);
  EXPECT_EQ(info["cells"].get<size_t>(), static_cast<size_t>(width) * height);
  EXPECT_EQ(info["valid_cells"].get<size_t>(), static_cast<size_t>(width) * height);
  EXPECT_EQ(info["nodata_cells"].get<size_t>(), 0u);
  EXPECT_EQ(info["holes"].get<size_t>(), 0u);
  // Heights are float32 cells; dsmplan may print them as the float's shortest decimal (109.18
  // rather than 109.18000030517578), so compare as the float both must denote.
  EXPECT_EQ(as_float(info["height_range"][0]), static_cast<float>(minmax[0]));
  EXPECT_EQ(as_float(info["height_range"][1]), static_cast<float>(minmax[1]));
}

TEST(CliInfo, TextNamesCrsAndEpsg) {
  const std::string path = testkit::data_path(kSample);
  const Raster r = read_with_gdal(path);
  OGRSpatialReferenceH srs = OSRNewSpatialReference(r.wkt.c_str());
  const std::string name = OSRGetName(srs);
  OSRDestroySpatialReference(srs);

  const auto result = run_cli({"info", path});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find(name), std::string::npos) << result.out;
  EXPECT_NE(result.out.find(std::to_string(epsg_of(r.wkt))), std::string::npos) << result.out;
}

TEST(CliInfo, CountsDeclaredNodataCellsAndHoles) {
  // The sample with every cell below 115 m replaced by a declared nodata value.
  Raster r = read_with_gdal(testkit::data_path(kSample));
  r.has_nodata = true;
  r.nodata = -9999;
  size_t nodata = 0;
  double z_min = INFINITY, z_max = -INFINITY;
  std::vector<bool> is_nodata(r.z.size(), false);
  for (size_t i = 0; i < r.z.size(); ++i) {
    if (r.z[i] < 115) {
      r.z[i] = -9999;
      is_nodata[i] = true;
      ++nodata;
    } else {
      z_min = std::min<double>(z_min, r.z[i]);
      z_max = std::max<double>(z_max, r.z[i]);
    }
  }
  ASSERT_GT(nodata, 0u) << "the threshold must cut something, or the test proves nothing";
  ASSERT_LT(nodata, r.z.size());
  TempDir dir;
  const std::string path = dir.path("with_nodata.tif");
  write_with_gdal(r, path);

  const auto result = run_cli({"info", path, "--json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const json info = json::parse(result.out);
  EXPECT_EQ(info["cells"].get<size_t>(), r.z.size());
  EXPECT_EQ(info["nodata_cells"].get<size_t>(), nodata);
  EXPECT_EQ(info["valid_cells"].get<size_t>(), r.z.size() - nodata);
  EXPECT_EQ(info["holes"].get<size_t>(), count_regions(r.width, r.height, is_nodata));
  // -9999 must not leak into the range: only valid cells count.
  EXPECT_EQ(as_float(info["height_range"][0]), static_cast<float>(z_min));
  EXPECT_EQ(as_float(info["height_range"][1]), static_cast<float>(z_max));
}

// ==== mesh ==================================================================================

TEST(CliMesh, RealSampleAtTwoMetresGivesFullGridCountsAndConsistentPly) {
  const std::string input = testkit::data_path(kSample);
  const Raster source = read_with_gdal(input);
  ASSERT_FALSE(source.has_nodata) << "full-grid counts assume a sample without nodata";
  // Resampling to 2 m covers the raster with ceil(extent / 2) cells per axis, one vertex each;
  // a full nx x ny grid of vertices has 2 (nx-1)(ny-1) triangles.
  const long long nx = static_cast<long long>(std::ceil(source.width * source.gt[1] / 2.0));
  const long long ny = static_cast<long long>(std::ceil(source.height * -source.gt[5] / 2.0));
  const int epsg = epsg_of(source.wkt);
  ASSERT_NE(epsg, 0);

  TempDir out;
  const auto result = run_cli({"mesh", input, "-o", out.path("mesh.ply"), "--res", "2", "--zstep", "0.1", "--stats",
                               out.path("stats.json"), "-q"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, "") << "-q must silence the progress output";
  EXPECT_EQ(result.err, "");

  const json stats = json::parse(testkit::read_file(out.path("stats.json")));
  for (const char* key : {"vertices", "faces", "cells", "holes", "seconds"}) EXPECT_TRUE(stats.contains(key)) << key;
  EXPECT_TRUE(stats["seconds"].is_object());
  EXPECT_EQ(stats["vertices"].get<long long>(), nx * ny);
  EXPECT_EQ(stats["faces"].get<long long>(), 2 * (nx - 1) * (ny - 1));
  EXPECT_EQ(stats["cells"].get<long long>(), nx * ny);
  EXPECT_EQ(stats["holes"].get<long long>(), 0);

  const std::string ply = testkit::read_file(out.path("mesh.ply"));
  const auto header = ply_header(ply);
  ASSERT_FALSE(header.empty());
  EXPECT_EQ(header[0], "ply");
  EXPECT_EQ(header_count(header, "element vertex "), stats["vertices"].get<long long>());
  EXPECT_EQ(header_count(header, "element face "), stats["faces"].get<long long>());
  EXPECT_TRUE(has_line(header, "comment crs_epsg " + std::to_string(epsg))) << "the PLY header must carry the CRS code";
  EXPECT_TRUE(has_line_starting(header, "comment crs_wkt ") || has_line_starting(header, "comment crs_wkt_part 1/"))
      << "the PLY header must carry the WKT";
  // The counts must also describe the body: 3 doubles per vertex, 1 + 3*4 bytes per triangle.
  const size_t body = ply.size() - (ply.find("end_header\n") + std::strlen("end_header\n"));
  EXPECT_EQ(body, static_cast<size_t>(nx * ny * 24 + 2 * (nx - 1) * (ny - 1) * 13));
}

TEST(CliMesh, ShowsGdalProgressUnlessQuiet) {
  const std::string input = testkit::data_path(kSample);
  TempDir out;
  const auto loud = run_cli({"mesh", input, "-o", out.path("loud.ply"), "--res", "10"});
  ASSERT_EQ(loud.exit_code, 0) << loud.err;
  EXPECT_NE(loud.out.find(kProgress), std::string::npos) << "stdout: " << loud.out;
  EXPECT_EQ(loud.err, "");

  const auto quiet = run_cli({"mesh", input, "-o", out.path("quiet.ply"), "--res", "10", "-q"});
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.out, "");
}

TEST(CliMesh, ObjAndOffByExtension) {
  const std::string input = testkit::data_path(kSample);
  const Raster source = read_with_gdal(input);
  ASSERT_FALSE(source.has_nodata);
  const size_t nx = static_cast<size_t>(std::ceil(source.width * source.gt[1] / 10.0));
  const size_t ny = static_cast<size_t>(std::ceil(source.height * -source.gt[5] / 10.0));
  const size_t vertices = nx * ny, faces = 2 * (nx - 1) * (ny - 1);
  TempDir out;

  ASSERT_EQ(run_cli({"mesh", input, "-o", out.path("m.obj"), "--res", "10", "-q"}).exit_code, 0);
  const std::string obj = testkit::read_file(out.path("m.obj"));
  EXPECT_EQ(count_lines_starting(obj, "v "), vertices);
  EXPECT_EQ(count_lines_starting(obj, "f "), faces);

  ASSERT_EQ(run_cli({"mesh", input, "-o", out.path("m.off"), "--res", "10", "-q"}).exit_code, 0);
  std::istringstream off(testkit::read_file(out.path("m.off")));
  std::string line;
  std::getline(off, line);
  EXPECT_EQ(line, "OFF");
  while (std::getline(off, line) && (line.empty() || line[0] == '#')) {
  }
  EXPECT_EQ(line, std::to_string(vertices) + " " + std::to_string(faces) + " 0");
}

// --3dtiles: the GLB and its tileset.json are one output, both or neither; the vertical reference
// is refused before the work (the sample's GeoTIFF does not state its DHHN2016).
TEST(CliMesh, ThreeDTilesWritesTheTilesetBesideTheGlbOrNothing) {
  const std::string input = testkit::data_path(kSample);
  TempDir out;
  const auto ply = run_cli({"mesh", input, "--res", "10", "-o", out.path("m.ply"), "--3dtiles", "-q"});
  EXPECT_EQ(ply.exit_code, 2) << ply.err;
  EXPECT_NE(ply.err.find("--3dtiles"), std::string::npos) << ply.err;
  EXPECT_NE(ply.err.find("m.glb"), std::string::npos) << ply.err;
  const auto unknown = run_cli({"mesh", input, "--res", "10", "-o", out.path("m.glb"), "--3dtiles", "-q"});
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_EQ(std::count(unknown.err.begin(), unknown.err.end(), '\n'), 1) << unknown.err;
  EXPECT_NE(unknown.err.find("--allow-approximate-vertical"), std::string::npos) << unknown.err;
  // A --stats that cannot be written takes both files with it.
  const auto stats = run_cli({"mesh", input, "--res", "10", "-o", out.path("m.glb"), "--3dtiles",
                              "--allow-approximate-vertical", "--stats", out.path("m.glb") + "/s.json", "-q"});
  EXPECT_NE(stats.exit_code, 0);
  EXPECT_TRUE(out.files().empty()) << "left behind: " << out.files().size() << " files";

  const auto simplified = run_cli({"simplify", input, "--res", "10", "--max-error", "0.5", "-o", out.path("s.glb"),
                                   "--3dtiles", "--allow-approximate-vertical", "--json", "-q"});
  ASSERT_EQ(simplified.exit_code, 0) << simplified.err;
  const auto report = nlohmann::json::parse(simplified.out);
  EXPECT_EQ(report["tileset"]["path"], out.path("tileset.json"));
  EXPECT_NE(report["tileset"]["heights"].get<std::string>().find("EGM96"), std::string::npos);
  const auto tileset = nlohmann::json::parse(testkit::read_file(out.path("tileset.json")));
  EXPECT_EQ(tileset["root"]["content"]["uri"], "s.glb");
  EXPECT_EQ(tileset["asset"]["version"], "1.1");
  // The tileset is an output like the others: -o may not be it.
  const auto clash = run_cli({"mesh", input, "--res", "10", "-o", out.path("s.glb"), "--3dtiles",
                              "--allow-approximate-vertical", "--stats", out.path("tileset.json"), "-q"});
  EXPECT_EQ(clash.exit_code, 2) << clash.err;
  EXPECT_NE(clash.err.find("--3dtiles"), std::string::npos) << clash.err;
  // One tileset.json a folder: a second GLB there does not replace the first one's tileset,
  // and nothing of it is written; the same GLB made again replaces its own.
  const std::string first = testkit::read_file(out.path("tileset.json"));
  const auto second = run_cli(
      {"mesh", input, "--res", "10", "-o", out.path("t.glb"), "--3dtiles", "--allow-approximate-vertical", "-q"});
  EXPECT_NE(second.exit_code, 0);
  EXPECT_EQ(std::count(second.err.begin(), second.err.end(), '\n'), 1) << second.err;
  EXPECT_NE(second.err.find("places s.glb on the globe, not t.glb"), std::string::npos) << second.err;
  EXPECT_FALSE(std::filesystem::exists(out.path("t.glb")));
  EXPECT_EQ(testkit::read_file(out.path("tileset.json")), first);
  const auto again = run_cli({"simplify", input, "--res", "10", "--max-error", "0.5", "-o", out.path("s.glb"),
                              "--3dtiles", "--allow-approximate-vertical", "-q"});
  EXPECT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(testkit::read_file(out.path("tileset.json")), first);
  // A tileset.json that is none of dsmplan's is not replaced either.
  testkit::write_file(out.path("tileset.json"), "{\"asset\": {\"version\": \"1.0\"}}");
  const auto foreign = run_cli({"simplify", input, "--res", "10", "--max-error", "0.5", "-o", out.path("s.glb"),
                                "--3dtiles", "--allow-approximate-vertical", "-q"});
  EXPECT_NE(foreign.exit_code, 0);
  EXPECT_NE(foreign.err.find("is not a tileset of dsmplan's"), std::string::npos) << foreign.err;
  EXPECT_EQ(testkit::read_file(out.path("tileset.json")), "{\"asset\": {\"version\": \"1.0\"}}");
}

// ==== grid ==================================================================================

// --fill-holes keeps GDAL's work rasters in memory: with its temporary folder unwritable (a
// read-only current folder) GDAL's default GeoTIFF work files failed the run, and an interrupted
// run left them behind (up to 34 MB). The filled DSM is the one filled with a writable folder.
TEST(CliGrid, FillingHolesWritesNoWorkFiles) {
  TempDir out;
  const std::string las = testkit::data_path("delft-ahn3/ahn3_cropped_1.las");
  const std::vector<std::string> args{"grid",      las, "--crs",        "EPSG:28992", "--res", "1",
                                      "--classes", "2", "--fill-holes", "30",         "-q",    "-o"};
  auto with_output = [&](const std::string& name) {
    std::vector<std::string> a = args;
    a.push_back(out.path(name));
    return a;
  };
  ASSERT_EQ(run_cli(with_output("writable.tif")).exit_code, 0);
  setenv("CPL_TMPDIR", "/proc/self", 1);  // no one may create a file there, root included
  const auto unwritable = run_cli(with_output("unwritable.tif"));
  unsetenv("CPL_TMPDIR");
  ASSERT_EQ(unwritable.exit_code, 0) << unwritable.err;
  const Raster a = read_with_gdal(out.path("writable.tif")), b = read_with_gdal(out.path("unwritable.tif"));
  EXPECT_EQ(a.z, b.z);
  EXPECT_EQ(out.files().size(), 2u);
}

TEST(CliGrid, DelftLasPairToGeoTiff) {
  const std::string las1 = testkit::data_path("delft-ahn3/ahn3_cropped_1.las");
  const std::string las2 = testkit::data_path("delft-ahn3/ahn3_cropped_2.las");
  const LasBounds a = las_bounds(las1), b = las_bounds(las2);
  const double min_x = std::min(a.min_x, b.min_x), max_x = std::max(a.max_x, b.max_x);
  const double min_y = std::min(a.min_y, b.min_y), max_y = std::max(a.max_y, b.max_y);
  const double res = 0.5;

  TempDir out;
  const std::string tif = out.path("dsm.tif");
  const auto result = run_cli({"grid", las1, las2, "-o", tif, "--res", "0.5", "--crs", "EPSG:28992", "-q"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, "");

  const Raster dsm = read_with_gdal(tif);
  EXPECT_EQ(epsg_of(dsm.wkt), 28992);
  EXPECT_DOUBLE_EQ(dsm.gt[1], res);
  EXPECT_DOUBLE_EQ(dsm.gt[5], -res);
  const double xmin = dsm.gt[0], xmax = dsm.gt[0] + dsm.width * dsm.gt[1];
  const double ymax = dsm.gt[3], ymin = dsm.gt[3] + dsm.height * dsm.gt[5];
  // Covers every point of both files ...
  EXPECT_LE(xmin, min_x);
  EXPECT_GE(xmax, max_x);
  EXPECT_LE(ymin, min_y);
  EXPECT_GE(ymax, max_y);
  // ... and "just covers" them: no more than one cell of margin on any side.
  EXPECT_GT(xmin, min_x - res);
  EXPECT_LT(xmax, max_x + res + 1e-9);
  EXPECT_GT(ymin, min_y - res - 1e-9);
  EXPECT_LT(ymax, max_y + res);

  // The canals have no LiDAR returns: they stay declared nodata, not invented heights.
  ASSERT_TRUE(dsm.has_nodata);
  const size_t holes = std::count(dsm.z.begin(), dsm.z.end(), static_cast<float>(dsm.nodata));
  EXPECT_GT(holes, 0u);
  EXPECT_LT(holes, dsm.z.size());
}

TEST(CliGrid, LasWithoutCrsNeedsCrsOption) {
  const std::string las1 = testkit::data_path("delft-ahn3/ahn3_cropped_1.las");
  const std::string las2 = testkit::data_path("delft-ahn3/ahn3_cropped_2.las");
  TempDir out;
  const auto result = run_cli({"grid", las1, las2, "-o", out.path("dsm.tif"), "--res", "0.5", "-q"});
  // Either file is a fair one to name: neither has a CRS.
  const std::string named = result.err.find("ahn3_cropped_1.las") != std::string::npos ? las1 : las2;
  expect_clean_failure(result, out, named, {"crs"});
}

// ==== bad input: one line on stderr, non-zero exit, nothing left behind =====================

TEST(CliBadInput, MissingFile) {
  TempDir in, out;
  const std::string missing = in.path("no-such-file.tif");  // a fresh folder: it cannot exist
  expect_clean_failure(run_cli({"mesh", missing, "-o", out.path("out.ply")}), out, missing,
                       {"no such file", "not found", "does not exist"});
}

TEST(CliBadInput, TextFileNamedTif) {
  TempDir in, out;
  const std::string path = in.path("notes.tif");
  testkit::write_file(path, "these are notes, not a raster\n");
  expect_clean_failure(run_cli({"mesh", path, "-o", out.path("out.ply")}), out, path,
                       {"not a raster", "cannot read", "not recognized"});
}

TEST(CliBadInput, EmptyTif) {
  TempDir in, out;
  const std::string path = in.path("empty.tif");
  testkit::write_file(path, "");
  expect_clean_failure(run_cli({"mesh", path, "-o", out.path("out.ply")}), out, path,
                       {"not a raster", "empty", "cannot read"});
}

TEST(CliBadInput, AllNodataRaster) {
  TempDir in, out;
  Raster r = small_raster(6, 5);
  r.has_nodata = true;
  r.nodata = -9999;
  std::fill(r.z.begin(), r.z.end(), -9999.0f);
  const std::string path = in.path("all_nodata.tif");
  write_with_gdal(r, path);
  expect_clean_failure(run_cli({"mesh", path, "-o", out.path("out.ply")}), out, path, {"nodata", "no valid"});
}

TEST(CliBadInput, UndeclaredNanHeightNamesTheCell) {
  TempDir in, out;
  Raster r = small_raster(6, 5);                             // no nodata declared
  r.z[2 * 6 + 3] = std::numeric_limits<float>::quiet_NaN();  // col 3, row 2
  const std::string path = in.path("nan.tif");
  write_with_gdal(r, path);
  const auto result = run_cli({"mesh", path, "-o", out.path("out.ply")});
  expect_clean_failure(result, out, path, {"nan"});
  EXPECT_NE(result.err.find("col 3"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("row 2"), std::string::npos) << result.err;
}

TEST(CliBadInput, InfiniteHeight) {
  TempDir in, out;
  Raster r = small_raster(6, 5);
  r.z[1 * 6 + 4] = std::numeric_limits<float>::infinity();  // col 4, row 1
  const std::string path = in.path("inf.tif");
  write_with_gdal(r, path);
  const auto result = run_cli({"mesh", path, "-o", out.path("out.ply")});
  expect_clean_failure(result, out, path, {"infinite", "inf"});
  EXPECT_NE(result.err.find("col 4"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("row 1"), std::string::npos) << result.err;
}

TEST(CliBadInput, RasterWithoutCrsUnlessAssigned) {
  TempDir in, out;
  const std::string path = in.path("no_crs.tif");
  write_with_gdal(small_raster(6, 5, /*with_crs=*/false), path);
  expect_clean_failure(run_cli({"mesh", path, "-o", out.path("out.ply")}), out, path, {"crs"});

  // Assigning the CRS makes the same file usable, and the mesh carries the assigned CRS.
  const auto fixed = run_cli({"mesh", path, "-o", out.path("out.ply"), "--crs", "EPSG:25832", "-q"});
  ASSERT_EQ(fixed.exit_code, 0) << fixed.err;
  const auto header = ply_header(testkit::read_file(out.path("out.ply")));
  EXPECT_TRUE(has_line(header, "comment crs_epsg 25832"));
  EXPECT_EQ(header_count(header, "element vertex "), 6 * 5);
}

TEST(CliBadInput, GeographicCrsIsRefusedForMeshing) {
  // Degrees in x,y and metres in z make no mesh a safety distance can be measured on.
  TempDir in, out;
  const std::string path = in.path("lonlat.tif");
  Raster r = small_raster(6, 5);
  r.wkt = epsg_wkt(4326);
  r.gt[0] = 6.9, r.gt[1] = 1e-5, r.gt[3] = 51.4, r.gt[5] = -1e-5;
  write_with_gdal(r, path);
  expect_clean_failure(run_cli({"mesh", path, "-o", out.path("out.ply")}), out, path, {"geographic"});
  // info still describes it.
  EXPECT_EQ(run_cli({"info", path}).exit_code, 0);
}

TEST(CliBadInput, TruncatedLas) {
  TempDir in, out;
  const std::string path = in.path("truncated.las");
  testkit::write_file(path, testkit::read_file(testkit::data_path("delft-ahn3/ahn3_cropped_2.las")).substr(0, 100));
  expect_clean_failure(run_cli({"grid", path, "-o", out.path("dsm.tif"), "--res", "0.5", "--crs", "EPSG:28992"}), out,
                       path, {"truncated", "too short", "ended early"});
}

TEST(CliBadInput, LasHeaderClaimsMorePointsThanTheFileHolds) {
  TempDir in, out;
  std::string bytes = testkit::read_file(testkit::data_path("delft-ahn3/ahn3_cropped_2.las"));
  uint32_t count = 0;
  std::memcpy(&count, bytes.data() + 107, 4);  // legacy point count, little-endian
  count += 1000;
  std::memcpy(bytes.data() + 107, &count, 4);
  const std::string path = in.path("lying.las");
  testkit::write_file(path, bytes);
  expect_clean_failure(run_cli({"grid", path, "-o", out.path("dsm.tif"), "--res", "0.5", "--crs", "EPSG:28992"}), out,
                       path, {"point count", "107"});
}

TEST(CliBadInput, XyzLineThatDoesNotParseNamesTheLine) {
  TempDir in, out;
  const std::string path = in.path("points.xyz");
  testkit::write_file(path, "85000.0 447500.0 1.5\n85000.5 447500.0 1.6\n85001.0 four 1.7\n85001.5 447500.0 1.8\n");
  const auto result = run_cli({"grid", path, "-o", out.path("dsm.tif"), "--res", "0.5", "--crs", "EPSG:28992"});
  expect_clean_failure(result, out, path, {"line 3"});
}

TEST(CliBadInput, MeshResolutionZero) {
  // BUG (apps/dsmplan.cpp, run_mesh): "--res 0" is taken as "keep the DSM's resolution" (the
  // option's default value is 0 and only < 0 is rejected), so this exits 0 and writes a mesh.
  // The contract requires --res 0 to be rejected like any non-positive resolution.
  TempDir out;
  expect_clean_failure(run_cli({"mesh", testkit::data_path(kSample), "-o", out.path("out.ply"), "--res", "0"}), out,
                       "--res", {"positive"});
}

TEST(CliBadInput, MeshResolutionNegative) {
  TempDir out;
  expect_clean_failure(run_cli({"mesh", testkit::data_path(kSample), "-o", out.path("out.ply"), "--res", "-1"}), out,
                       "--res", {"positive"});
}

TEST(CliBadInput, GridResolutionZeroAndNegative) {
  const std::string las = testkit::data_path("delft-ahn3/ahn3_cropped_2.las");
  for (const std::string res : {"0", "-1"}) {
    SCOPED_TRACE("--res " + res);
    TempDir out;
    expect_clean_failure(run_cli({"grid", las, "-o", out.path("dsm.tif"), "--res", res, "--crs", "EPSG:28992"}), out,
                         "--res", {"positive"});
  }
}

TEST(CliBadInput, UnknownMeshFormat) {
  TempDir out;
  expect_clean_failure(run_cli({"mesh", testkit::data_path(kSample), "-o", out.path("out.xyz")}), out, ".xyz",
                       {"format", "extension"});
}

TEST(CliBadInput, OutputInNonexistentFolder) {
  TempDir out;  // stays empty: the target is elsewhere
  const std::string target = "/nonexistent-dir/out.ply";
  ASSERT_FALSE(std::filesystem::exists("/nonexistent-dir"));
  expect_clean_failure(run_cli({"mesh", testkit::data_path(kSample), "-o", target, "--res", "10"}), out, target,
                       {"cannot write", "no such file", "cannot create"});
}

// DSMPLAN_MAX_MEMORY is a machine that small to every memory check (core.hpp); a value that is
// not a size is named.
TEST(CliBadInput, MaxMemoryFromTheEnvironmentIsTheMachinesMemory) {
  TempDir out;
  const auto with_limit = [&](const char* limit) {
    ::setenv("DSMPLAN_MAX_MEMORY", limit, 1);
    const auto result = run_cli({"mesh", testkit::data_path(kSample), "-o", out.path("dsm.ply"), "-q"});
    ::unsetenv("DSMPLAN_MAX_MEMORY");
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_TRUE(out.files().empty()) << "nothing written";
    return result;
  };
  const auto small = with_limit("1M");
  EXPECT_EQ(small.exit_code, 1);
  EXPECT_NE(small.err.find("this machine has 1.0 MB"), std::string::npos) << small.err;
  for (const char* bad : {"12x", "-1G", "0", "nan", "G"}) {
    const auto refused = with_limit(bad);
    EXPECT_EQ(refused.exit_code, 2) << bad;
    EXPECT_NE(refused.err.find("DSMPLAN_MAX_MEMORY: must be a positive number of bytes"), std::string::npos)
        << refused.err;
  }
  ::setenv("DSMPLAN_MAX_MEMORY", "24T", 1);  // more than the machine: the machine's own figure stays
  EXPECT_EQ(run_cli({"mesh", testkit::data_path(kSample), "-o", out.path("dsm.ply"), "-q"}).exit_code, 0);
  ::unsetenv("DSMPLAN_MAX_MEMORY");
}

TEST(CliBadInput, OutputInReadOnlyFolder) {
  TempDir out;
  const std::filesystem::path locked = out.dir() / "locked";
  std::filesystem::create_directory(locked);
  std::filesystem::permissions(locked, std::filesystem::perms(0555));
  const std::string target = (locked / "out.ply").string();
  const std::vector<std::string> args{"mesh", testkit::data_path(kSample), "-o", target, "--res", "10"};
  // Root passes directory permissions by its capability CAP_DAC_OVERRIDE (and reads by
  // CAP_DAC_READ_SEARCH): as root (how CI runs) the run goes without them (util-linux setpriv).
  std::vector<std::string> as_root{"--bounding-set=-dac_override,-dac_read_search", "--", DSMPLAN_CLI};
  as_root.insert(as_root.end(), args.begin(), args.end());
  const auto result = ::geteuid() == 0 ? testkit::run_program("setpriv", as_root) : run_cli(args);
  const bool locked_empty = std::filesystem::is_empty(locked);
  std::filesystem::permissions(locked, std::filesystem::perms(0755));  // so TempDir can clean up
  EXPECT_TRUE(locked_empty) << "nothing, not even a .partial file, may be left in the folder";
  EXPECT_NE(result.exit_code, 0);
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_NE(result.err.find(target), std::string::npos) << result.err;
  EXPECT_TRUE(contains_any(result.err, {"permission", "cannot write"})) << result.err;
}

// ==== usage errors (CLI11) ==================================================================

TEST(CliUsage, UnknownSubcommandOrMissingOptionFails) {
  TempDir out;
  EXPECT_NE(run_cli({"frobnicate"}).exit_code, 0);
  EXPECT_NE(run_cli({}).exit_code, 0);
  EXPECT_NE(run_cli({"mesh", testkit::data_path(kSample)}).exit_code, 0);  // no -o
  EXPECT_NE(run_cli({"grid", testkit::data_path("delft-ahn3/ahn3_cropped_2.las"), "-o", out.path("dsm.tif")}).exit_code,
            0);  // no --res
  EXPECT_TRUE(out.files().empty());
}

// ==== dsmplan simplify ======================================================================

// Table 2's columns from the real sample at 2 m: counts add up to the grid (250 x 250 cells, no
// nodata), the written PLY has the reported counts, the bounded mode keeps its promise.
TEST(CliSimplify, RealSampleVariantTwoAndBoundedReportTableTwoColumns) {
  TempDir out;
  const auto variant = run_cli({"simplify", testkit::data_path(kSample), "--res", "2", "--method", "variant2", "-o",
                                out.path("v2.ply"), "--stats", out.path("v2.json")});
  ASSERT_EQ(variant.exit_code, 0) << variant.err;
  const json v2 = json::parse(testkit::read_file(out.path("v2.json")));
  EXPECT_EQ(v2["vertices_in"], 250 * 250);
  EXPECT_EQ(v2["vertices_in"].get<int>() - v2["removed_coplanar"].get<int>() - v2["removed_colinear"].get<int>(),
            v2["vertices_out"].get<int>());
  EXPECT_GT(v2["removed_coplanar"].get<int>(), 0);
  EXPECT_EQ(v2["certified_cells"], 250 * 250);
  const auto header = ply_header(testkit::read_file(out.path("v2.ply")));
  EXPECT_NE(std::find(header.begin(), header.end(), "element vertex " + std::to_string(v2["vertices_out"].get<int>())),
            header.end());
  // The summary line says the same as the stats.
  EXPECT_NE(variant.out.find(std::to_string(v2["vertices_out"].get<int>()) + " vertices"), std::string::npos)
      << variant.out;

  const auto bounded = run_cli({"simplify", testkit::data_path(kSample), "--res", "2", "--max-error", "0.5",
                                "--conservative", "-o", out.path("b.ply"), "--json", "-q"});
  ASSERT_EQ(bounded.exit_code, 0) << bounded.err;
  const json b = json::parse(bounded.out);
  EXPECT_EQ(b["method"], "bounded");
  EXPECT_EQ(b["max_below_m"], 0.0);
  EXPECT_LE(b["max_above_m"].get<double>(), 0.5);
  EXPECT_TRUE(b["removed_coplanar"].is_null());
}

// The default is the safe one: without --method nor --max-error the written mesh is never below
// the DSM and at most 0.4 m above it, measured here at every cell centre on the mesh read back
// (ClearanceIndex::ground: the highest triangle over the point), not taken from the report.
TEST(CliSimplify, DefaultIsTheCertifiedConservativeMode) {
  TempDir out;
  const auto run =
      run_cli({"simplify", testkit::data_path(kSample), "--res", "2", "-o", out.path("d.ply"), "--json", "-q"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(json::parse(run.out)["method"], "bounded");
  const dsmplan::Grid dsm = dsmplan::resample(testkit::nrw_crop(), 2, dsmplan::Resampling::Median);
  const dsmplan::ClearanceIndex index(dsmplan::read_mesh(out.path("d.ply")));
  double below = 0, above = 0;
  size_t measured = 0;
  for (int row = 0; row < dsm.height; ++row)
    for (int col = 0; col < dsm.width; ++col) {
      const double z = dsm.at(col, row), m = index.ground(dsm.center_x(col), dsm.center_y(row));
      if (std::isnan(z) || std::isnan(m)) continue;
      ++measured;
      below = std::max(below, z - m), above = std::max(above, m - z);
    }
  EXPECT_EQ(measured, dsm.cells());
  EXPECT_LE(below, 1e-3);  // the float zstep of the heights written
  EXPECT_LE(above, 0.4 + 1e-3);
  EXPECT_GT(above, 0.1);  // a bound that is used, not a copy of the DSM
}

TEST(CliBadInput, SimplifyNegativeDzOrNonPositiveMaxError) {
  TempDir out;
  const std::string dsm = testkit::data_path(kSample);
  for (const char* v : {"-0.1", "inf", "nan", "1e300"}) {
    expect_clean_failure(run_cli({"simplify", dsm, "-o", out.path("o.ply"), "--method", "variant2", "--dz", v}), out,
                         "--dz", {"from 0 to 1000"});
    expect_clean_failure(run_cli({"simplify", dsm, "-o", out.path("o.ply"), "--method", "variant1", "--dco", v}), out,
                         "--dco", {"from 0 to 1000"});
  }
  // The paper's tolerances do not tune the bounded mode, the default: said, not ignored.
  for (const char* flag : {"--dz", "--dco"})
    expect_clean_failure(run_cli({"simplify", dsm, "-o", out.path("o.ply"), flag, "0.4"}), out, flag,
                         {"paper's variants", "--max-error"});
  for (const char* e : {"0", "-1", "inf", "nan", "1e-7", "1e5"}) {
    expect_clean_failure(run_cli({"simplify", dsm, "-o", out.path("o.ply"), "--max-error", e}), out, "--max-error",
                         {"from 0.001 to 10000"});
  }
  expect_clean_failure(run_cli({"simplify", dsm, "-o", out.path("o.ply"), "--method", "variant2", "--conservative"}),
                       out, "--conservative", {"bounded"});
}

// The rules between flags are the library's: the CLI prints, byte for byte, what the library
// throws for the same options (and a C++ or Python caller gets the same line).
TEST(CliBadInput, CrossFlagRulesSayWhatTheLibrarySays) {
  TempDir out;
  const std::string dsm = testkit::data_path(kSample);
  const auto library_says = [](const auto& job) {
    try {
      job();
    } catch (const dsmplan::ArgumentError& error) {
      return "dsmplan: " + std::string(error.what()) + "\n";
    }
    return std::string("(accepted)");
  };
  dsmplan::SimplifyJobOptions simplify;
  simplify.input = dsm;
  simplify.output = out.path("o.ply");
  simplify.method = dsmplan::SimplifyMethod::Variant1;
  simplify.max_error = 0.3;
  EXPECT_EQ(run_cli({"simplify", dsm, "-o", simplify.output, "--method", "variant1", "--max-error", "0.3"}).err,
            library_says([&] { simplify_job(simplify); }));
  simplify.method = dsmplan::SimplifyMethod::Bounded;
  simplify.dz = 0.3;
  EXPECT_EQ(run_cli({"simplify", dsm, "-o", simplify.output, "--max-error", "0.3", "--dz", "0.3"}).err,
            library_says([&] { simplify_job(simplify); }));

  dsmplan::GridOptions grid;
  grid.inputs = {out.path("points.las")};
  grid.output = out.path("dsm.tif");
  grid.classes = {2};
  grid.keep_all_classes = true;
  // The library names the field (keep_classes, as Python's keyword), the command line its flag.
  std::string problem;
  try {
    grid_to_geotiff(grid);
  } catch (const dsmplan::ArgumentError& error) {
    EXPECT_EQ(error.field(), "keep_classes");
    problem = error.problem();
  }
  EXPECT_EQ(
      run_cli({"grid", grid.inputs[0], "-o", grid.output, "--res", "1", "--classes", "2", "--keep-all-classes"}).err,
      "dsmplan: --classes: " + problem + "\n");
  EXPECT_EQ(run_cli({"info", dsm, "--of", "xml"}).err, library_says([] { dsmplan::parse_info_format("xml"); }));
  EXPECT_TRUE(out.files().empty());
}

// The plan's choices are the library's names (parse_planner(), ...), which Python takes too: the
// library names the field, the command line its flag, and the problem is the same words.
TEST(CliBadInput, PlanChoicesAreTheLibrarysNames) {
  const auto refusal = [](const auto& parse) -> std::pair<std::string, std::string> {
    try {
      parse();
    } catch (const dsmplan::ArgumentError& error) {
      return {error.field(), error.problem()};
    }
    return {"", "(accepted)"};
  };
  const std::vector<std::tuple<std::string, std::string, std::pair<std::string, std::string>>> cases{
      {"--planner", "rrt", refusal([] { dsmplan::parse_planner("rrt"); })},
      {"--end", "hover", refusal([] { dsmplan::parse_mission_end("hover"); })},
      {"--firmware", "dji", refusal([] { dsmplan::parse_firmware("dji"); })},
      {"--drone", "m3x", refusal([] { dsmplan::parse_drone("m3x"); })},
      {"--altitude-frame", "agl", refusal([] { dsmplan::parse_altitude_frame("agl"); })}};
  for (const auto& [flag, value, library] : cases) {
    SCOPED_TRACE(flag);
    EXPECT_EQ(library.first, flag.substr(2) == "altitude-frame" ? "altitude_frame" : flag.substr(2));
    const auto result = run_cli({"plan", "mesh.ply", "--waypoints", "w.csv", "-o", "p.plan", flag, value});
    EXPECT_EQ(result.exit_code, 2);
    EXPECT_EQ(result.err, "dsmplan: " + flag + ": " + library.second + "\n");
  }
  EXPECT_EQ(refusal([] { dsmplan::parse_planner("rrtconnect"); }).second, "(accepted)");
}

TEST(CliBadInput, SimplifyMeshWithoutItsDsm) {
  TempDir in, out;
  const std::string mesh = in.path("mesh.ply");
  ASSERT_EQ(run_cli({"mesh", testkit::data_path(kSample), "--res", "4", "-o", mesh, "-q"}).exit_code, 0);
  expect_clean_failure(run_cli({"simplify", mesh, "-o", out.path("o.ply")}), out, mesh, {"--dsm"});
}

TEST(CliBadInput, SimplifyMeshThatIsNot25D) {
  TempDir in, out;
  const std::string dsm = testkit::data_path(kSample);
  // Cell centres of the sample, so the mesh would be certifiable if it were 2.5D.
  const std::string square =
      "v 356300.5 5699749.5 120\nv 356301.5 5699749.5 120\nv 356301.5 5699748.5 120\nv 356300.5 5699748.5 120\n";
  struct Case {
    const char* name;
    std::string faces, what;
  };
  const std::vector<Case> cases = {
      {"clockwise.obj", "f 1 2 3\n", "clockwise"},                   // seen from above it turns clockwise
      {"folded.obj", "f 1 3 2\nf 1 3 2\n", "not 2.5D"},              // the same triangle twice: folds over
      {"flat.obj", "v 356301 5699749.5 120\nf 1 5 2\n", "no area"},  // three points on a line
  };
  for (const Case& c : cases) {
    const std::string path = in.path(c.name);
    testkit::write_file(path, square + c.faces);
    expect_clean_failure(run_cli({"simplify", path, "--dsm", dsm, "-o", out.path("o.ply"), "--method", "variant2"}),
                         out, path, {c.what, "2.5D"});
  }
  const std::string twin = in.path("twin.obj");
  testkit::write_file(twin, square + "v 356300.5 5699749.5 130\nf 1 3 2\nf 5 4 3\n");
  expect_clean_failure(run_cli({"simplify", twin, "--dsm", dsm, "-o", out.path("o.ply"), "--method", "variant2"}), out,
                       twin, {"share x,y"});
}

// ==== dsmplan render ========================================================================

namespace {

// Width and height from a PNG's IHDR chunk, read here byte by byte (PNG spec, section 11.2.2).
std::pair<uint32_t, uint32_t> png_size(const std::string& path) {
  const std::string bytes = testkit::read_file(path);
  if (bytes.size() < 24 || bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0 || bytes.compare(12, 4, "IHDR") != 0) {
    throw std::runtime_error(path + " is not a PNG");
  }
  auto be32 = [&](size_t at) {
    uint32_t v = 0;
    for (size_t k = 0; k < 4; ++k) v = v << 8 | static_cast<unsigned char>(bytes[at + k]);
    return v;
  };
  return {be32(16), be32(20)};
}

}  // namespace

TEST(CliRender, SampleWithItsMeshGivesAPictureOfTheWindowsSize) {
  const std::string input = testkit::data_path(kSample);
  const Raster source = read_with_gdal(input);
  // A 150 m square inside the sample, 4 pixels per cell.
  const double xmin = source.gt[0] + 150, ymax = source.gt[3] - 150;
  const double cell = source.gt[1];
  const auto side = static_cast<uint32_t>(std::lround(150 / cell * 4));
  std::ostringstream window;
  window.precision(12);
  window << xmin << "," << ymax - 150 << "," << xmin + 150 << "," << ymax;

  TempDir out;
  const std::string mesh = out.path("mesh.ply"), coarse = out.path("coarse.obj");
  ASSERT_EQ(run_cli({"mesh", input, "-o", mesh, "-q"}).exit_code, 0);
  ASSERT_EQ(run_cli({"mesh", input, "-o", coarse, "--res", "5", "-q"}).exit_code, 0);

  const auto one = run_cli({"render", input, "--mesh", mesh, "-o", out.path("one.png"), "--window", window.str(),
                            "--zoom", "4", "--title", "XY-3 1 m", "-q"});
  ASSERT_EQ(one.exit_code, 0) << one.err;
  EXPECT_EQ(one.out, "");
  EXPECT_EQ(one.err, "");
  EXPECT_EQ(png_size(out.path("one.png")), std::make_pair(side, side));

  // Two meshes side by side, 8 pixels apart; without edges the same size.
  const auto two = run_cli({"render", input, "--mesh", mesh, "--mesh", coarse, "-o", out.path("two.png"), "--window",
                            window.str(), "--no-edges", "-q"});
  ASSERT_EQ(two.exit_code, 0) << two.err;
  EXPECT_EQ(png_size(out.path("two.png")), std::make_pair(2 * side + 8, side));

  // The DSM alone, whole, one pixel per cell; progress unless -q.
  const auto dsm = run_cli({"render", input, "-o", out.path("dsm.png"), "--zoom", "1"});
  ASSERT_EQ(dsm.exit_code, 0) << dsm.err;
  EXPECT_NE(dsm.out.find(kProgress), std::string::npos) << dsm.out;
  EXPECT_EQ(png_size(out.path("dsm.png")),
            std::make_pair(static_cast<uint32_t>(source.width), static_cast<uint32_t>(source.height)));
}

TEST(CliRender, PathRoadmapAndWaypointsOverTheMesh) {
  const std::string input = testkit::data_path(kSample);
  TempDir in, out;
  const std::string mesh = in.path("mesh.ply"), roadmap = in.path("map.roadmap"), path = in.path("path.csv");
  ASSERT_EQ(run_cli({"mesh", input, "-o", mesh, "--res", "2", "-q"}).exit_code, 0);
  const auto planned = run_cli({"plan", mesh, "--waypoints", testkit::data_path("nrw-dom1/sample_waypoints.csv"), "-o",
                                path, "--roadmap", roadmap, "-q"});
  ASSERT_EQ(planned.exit_code, 0) << planned.err;
  const auto plain = run_cli({"render", input, "--mesh", mesh, "-o", out.path("plain.png"), "--zoom", "1", "-q"});
  const auto drawn =
      run_cli({"render", input, "--mesh", mesh, "--roadmap", roadmap, "--path", path, "--waypoints",
               testkit::data_path("nrw-dom1/sample_waypoints.csv"), "-o", out.path("drawn.png"), "--zoom", "1", "-q"});
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  ASSERT_EQ(drawn.exit_code, 0) << drawn.err;
  EXPECT_EQ(png_size(out.path("plain.png")), png_size(out.path("drawn.png")));
  EXPECT_NE(testkit::read_file(out.path("plain.png")), testkit::read_file(out.path("drawn.png")));

  TempDir none;
  testkit::write_file(in.path("bad.csv"), "x,y,z\n356320,5699270,130\nnot,a,point\n");
  expect_clean_failure(run_cli({"render", input, "--path", in.path("bad.csv"), "-o", none.path("p.png"), "-q"}), none,
                       in.path("bad.csv") + ": line 3", {"expected"});
  testkit::write_file(in.path("bad.roadmap"), "DSMPLAN-ROADMAP\n");
  expect_clean_failure(run_cli({"render", input, "--roadmap", in.path("bad.roadmap"), "-o", none.path("p.png"), "-q"}),
                       none, in.path("bad.roadmap"), {"truncated"});
}

TEST(CliBadInput, RenderWindowOutsideOrMalformed) {
  const std::string input = testkit::data_path(kSample);
  TempDir out;
  // Outside the sample (which lies near 356300, 5699250).
  expect_clean_failure(run_cli({"render", input, "-o", out.path("p.png"), "--window", "0,0,100,100"}), out, "--window",
                       {"outside"});
  expect_clean_failure(run_cli({"render", input, "-o", out.path("p.png"), "--window", "356300,5699300,356400"}), out,
                       "--window", {"four numbers"});
  expect_clean_failure(run_cli({"render", input, "-o", out.path("p.png"), "--window", "356400,5699300,356300,5699400"}),
                       out, "--window", {"xmin < xmax"});
  expect_clean_failure(run_cli({"render", input, "-o", out.path("p.png"), "--zoom", "0"}), out, "--zoom", {"positive"});
}

TEST(CliBadInput, RenderBrokenMeshNamesIt) {
  TempDir in, out;
  const std::string mesh = in.path("broken.obj");
  testkit::write_file(mesh, "v 356300.5 5699749.5 120\nv 356301.5 5699749.5 120\nf 1 2 3\n");
  expect_clean_failure(run_cli({"render", testkit::data_path(kSample), "--mesh", mesh, "-o", out.path("p.png")}), out,
                       mesh, {"does not exist"});
}

// ---- dsmplan profile ---------------------------------------------------------------------------

TEST(CliProfile, SamplePathGivesAPictureOfTheRequestedSizeAndASummary) {
  const std::string input = testkit::data_path(kSample);
  TempDir in, out;
  // Over the sample (x 356300-356800, y 5699250-5699750, roofs up to 168 m) at 170-180 m.
  const std::string path = in.path("path.csv");
  testkit::write_file(path, "x,y,z\n356320,5699270,170\n356560,5699500,180\n356780,5699730,175\n");
  const std::string png = out.path("profile.png");
  const auto result = run_cli({"profile", input, "--path", path, "--waypoints", path, "-o", png, "--width", "800",
                               "--height", "360", "--max-agl", "100", "--safety", "3"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  EXPECT_EQ(png_size(png), std::make_pair(800u, 360u));
  // The summary: the path's length (two straight legs: Pythagoras here), and the ceiling.
  const double length = std::hypot(240, 230) + std::hypot(220, 230);
  char expected[64];
  std::snprintf(expected, sizeof expected, "path %.1f m along the ground", length);
  EXPECT_NE(result.out.find(expected), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("ceiling DSM + 100 m kept"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find(kProgress), std::string::npos) << result.out;
  // Quiet: nothing printed; the default size.
  const auto quiet = run_cli({"profile", input, "--path", path, "-o", out.path("quiet.png"), "-q"});
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.out, "");
  EXPECT_EQ(png_size(out.path("quiet.png")), std::make_pair(1200u, 500u));
}

TEST(CliBadInput, ProfileRefusesAPathOutsideTheDsmAndForeignTerrain) {
  const std::string input = testkit::data_path(kSample);
  TempDir in, out;
  const std::string outside = in.path("outside.csv");
  testkit::write_file(outside, "x,y,z\n356320,5699270,170\n356900,5699500,180\n");
  expect_clean_failure(run_cli({"profile", input, "--path", outside, "-o", out.path("p.png"), "-q"}), out,
                       outside + ": point 2", {"outside the DSM"});
  const std::string path = in.path("path.csv");
  testkit::write_file(path, "x,y,z\n356320,5699270,170\n356560,5699500,180\n");
  expect_clean_failure(run_cli({"profile", input, "--path", path, "-o", out.path("p.jpg"), "-q"}), out,
                       out.path("p.jpg"), {"PNG"});
  // Terrain from points: the same place in another CRS (WGS 84 / UTM 32N), and far away.
  std::string points;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j)
      points += std::to_string(356300 + 25 * i + 12) + " " + std::to_string(5699250 + 25 * j + 12) + " 110\n";
  testkit::write_file(in.path("dtm.xyz"), points);
  ASSERT_EQ(run_cli({"grid", in.path("dtm.xyz"), "--crs", "EPSG:32632", "--res", "25", "-o", in.path("utm.tif"), "-q"})
                .exit_code,
            0);
  expect_clean_failure(
      run_cli({"profile", input, "--path", path, "--dtm", in.path("utm.tif"), "-o", out.path("p.png"), "-q"}), out,
      in.path("utm.tif"), {"EPSG:32632"});
  testkit::write_file(in.path("far.xyz"), "400000 5600000 50\n400010 5600010 50\n");
  ASSERT_EQ(run_cli({"grid", in.path("far.xyz"), "--crs", "EPSG:25832", "--res", "5", "-o", in.path("far.tif"), "-q"})
                .exit_code,
            0);
  expect_clean_failure(
      run_cli({"profile", input, "--path", path, "--dtm", in.path("far.tif"), "-o", out.path("p.png"), "-q"}), out,
      in.path("far.tif"), {"does not overlap"});
  // The same terrain in the DSM's CRS is taken.
  ASSERT_EQ(run_cli({"grid", in.path("dtm.xyz"), "--crs", "EPSG:25832", "--res", "25", "-o", in.path("dtm.tif"), "-q"})
                .exit_code,
            0);
  const auto taken = run_cli({"profile", input, "--path", path, "--dtm", in.path("dtm.tif"), "-o", out.path("t.png")});
  ASSERT_EQ(taken.exit_code, 0) << taken.err;
  EXPECT_NE(taken.out.find("above the DTM"), std::string::npos) << taken.out;
}

// ---- dsmplan plan ----------------------------------------------------------------------------
//
// Waypoints are put 35 m above the highest DSM cell within 15 m (read through GDAL here), so
// the test knows they are clear of any mesh of that DSM; the path's points are read back from
// the CSV and compared with the waypoints written.

namespace {

// GDAL's transformation between two CRSs, longitude first for geographic ones: a route through
// PROJ independent of dsmplan's Wgs84Transform.
class GdalTransform {
public:
  GdalTransform(const char* from, const char* to)
      : from_(OSRNewSpatialReference(nullptr)), to_(OSRNewSpatialReference(nullptr)) {
    OSRSetFromUserInput(from_, from);
    OSRSetFromUserInput(to_, to);
    OSRSetAxisMappingStrategy(from_, OAMS_TRADITIONAL_GIS_ORDER);
    OSRSetAxisMappingStrategy(to_, OAMS_TRADITIONAL_GIS_ORDER);
    transform_ = OCTNewCoordinateTransformation(from_, to_);
  }
  ~GdalTransform() {
    OCTDestroyCoordinateTransformation(transform_);
    OSRDestroySpatialReference(from_);
    OSRDestroySpatialReference(to_);
  }
  GdalTransform(const GdalTransform&) = delete;
  GdalTransform& operator=(const GdalTransform&) = delete;
  bool operator()(double& x, double& y, double* z = nullptr) const {
    return transform_ && OCTTransform(transform_, 1, &x, &y, z);
  }

private:
  OGRSpatialReferenceH from_, to_;
  OGRCoordinateTransformationH transform_ = nullptr;
};

struct PlanFixture {
  TempDir in;
  std::string mesh = in.path("mesh.ply"), waypoints = in.path("wp.csv");
  Raster dsm = read_with_gdal(testkit::data_path(kSample));

  PlanFixture() {
    const auto made = run_cli({"mesh", testkit::data_path(kSample), "-o", mesh, "--res", "2", "-q"});
    if (made.exit_code != 0) throw std::runtime_error("mesh failed: " + made.err);
  }
  // The DSM's cell under (x, y).
  double cell(double x, double y) const {
    const int col = int(std::floor((x - dsm.gt[0]) / dsm.gt[1])), row = int(std::floor((y - dsm.gt[3]) / dsm.gt[5]));
    if (col < 0 || row < 0 || col >= dsm.width || row >= dsm.height) return NAN;
    return dsm.z[size_t(row) * dsm.width + col];
  }
  // The ground dsmplan counts from at (x, y): the DSM's cell, the lowest of those whose closed
  // squares hold the point on a side or corner.
  double ground(double x, double y) const {
    double low = INFINITY;
    for (const double ex : {-1e-9, 1e-9})
      for (const double ey : {-1e-9, 1e-9}) low = std::min(low, cell(x + ex, y + ey));
    return low;
  }
  // Highest DSM cell within `r` of (x, y).
  double highest(double x, double y, double r) const {
    double top = -INFINITY;
    for (int row = 0; row < dsm.height; ++row)
      for (int col = 0; col < dsm.width; ++col) {
        const double cx = dsm.gt[0] + (col + 0.5) * dsm.gt[1], cy = dsm.gt[3] + (row + 0.5) * dsm.gt[5];
        if (std::abs(cx - x) <= r && std::abs(cy - y) <= r)
          top = std::max(top, double(dsm.z[size_t(row) * dsm.width + col]));
      }
    return top;
  }
  // Three waypoints: two opposite corners and one in between, 35 m above their surroundings.
  std::vector<std::array<double, 3>> corners() const {
    const double x0 = dsm.gt[0], y1 = dsm.gt[3], x1 = x0 + dsm.width * dsm.gt[1], y0 = y1 + dsm.height * dsm.gt[5];
    std::vector<std::array<double, 3>> points{
        {x0 + 20, y0 + 20, 0}, {0.5 * (x0 + x1) + 10, 0.5 * (y0 + y1) - 30, 0}, {x1 - 20, y1 - 20, 0}};
    for (auto& p : points) p[2] = std::round(highest(p[0], p[1], 15) + 35);
    return points;
  }
  void write_waypoints(const std::vector<std::array<double, 3>>& points, const std::string& header = "x,y,z\n") const {
    std::ostringstream text;
    text.precision(17);
    text << header;
    for (const auto& p : points) text << p[0] << "," << p[1] << "," << p[2] << "\n";
    testkit::write_file(waypoints, text.str());
  }
};

std::vector<std::array<double, 3>> read_path_csv(const std::string& path) {
  std::istringstream in(testkit::read_file(path));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "x,y,z");
  std::vector<std::array<double, 3>> points;
  while (std::getline(in, line)) {
    std::array<double, 3> p{};
    char c1 = 0, c2 = 0;
    std::istringstream fields(line);
    fields >> p[0] >> c1 >> p[1] >> c2 >> p[2];
    EXPECT_TRUE(fields && c1 == ',' && c2 == ',') << line;
    points.push_back(p);
  }
  return points;
}

}  // namespace

// A command loads only what it uses (issue 37): planning on a mesh file and --version never load
// GDAL (the binary's geo stage is stubs that load libdsmplan_gdal.so at the first call), and a
// command that reads a raster does, through the plugin. The oracle is the dynamic loader's own
// account of the libraries it loaded (glibc's LD_DEBUG=libs, printed to stderr).
TEST(CliPlan, APlanOnAMeshLoadsNoGdalAndARasterCommandDoes) {
  PlanFixture f;
  f.write_waypoints(f.corners(), "x,y,z\n");
  TempDir out;
  auto loaded_gdal = [](const std::vector<std::string>& args) {
    std::vector<std::string> command{"LD_DEBUG=libs", DSMPLAN_CLI};
    command.insert(command.end(), args.begin(), args.end());
    const auto result = testkit::run_program("env", command);
    EXPECT_EQ(result.exit_code, 0) << result.err;
    EXPECT_NE(result.err.find("libc.so"), std::string::npos) << "the loader said nothing: " << result.err;
    return result.err.find("libgdal.so") != std::string::npos;
  };
  EXPECT_FALSE(loaded_gdal({"--version"}));
  EXPECT_FALSE(loaded_gdal({"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path("path.csv"), "-q"}));
  EXPECT_TRUE(loaded_gdal({"info", testkit::data_path(kSample)}));
}

TEST(CliPlan, ThreeWaypointsGiveAPathCsvAndStats) {
  PlanFixture f;
  const auto waypoints = f.corners();
  f.write_waypoints(waypoints, "# three waypoints\nx,y,z\n");
  TempDir out;
  const std::string path = out.path("path.csv"), stats = out.path("stats.json");
  const auto result = run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", path, "--stats", stats, "-q"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  const auto points = read_path_csv(path);
  ASSERT_GE(points.size(), 3u);
  EXPECT_EQ(points.front(), waypoints.front());
  EXPECT_EQ(points.back(), waypoints.back());
  EXPECT_NE(std::find(points.begin(), points.end(), waypoints[1]), points.end());
  double length = 0, straight = 0;
  for (size_t k = 1; k < points.size(); ++k)
    length +=
        std::hypot(points[k][0] - points[k - 1][0], points[k][1] - points[k - 1][1], points[k][2] - points[k - 1][2]);
  for (size_t k = 1; k < waypoints.size(); ++k)
    straight += std::hypot(waypoints[k][0] - waypoints[k - 1][0], waypoints[k][1] - waypoints[k - 1][1],
                           waypoints[k][2] - waypoints[k - 1][2]);

  const json s = json::parse(testkit::read_file(stats));
  std::vector<std::string> keys;
  for (auto it = s.begin(); it != s.end(); ++it) keys.push_back(it.key());
  std::sort(keys.begin(), keys.end());
  std::vector<std::string> expected{"path_length_m", "min_clearance_m", "roadmap_nodes",   "roadmap_edges",
                                    "seconds_load",  "seconds_roadmap", "seconds_query",   "seconds_smooth",
                                    "planner",       "roadmap_reused",  "refined_samples", "max_agl_m",
                                    "ground",        "seconds_read",    "seconds_index",   "index_reused"};
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(keys, expected);
  EXPECT_EQ(s["ground"], "mesh floor");
  EXPECT_NEAR(s["seconds_read"].get<double>() + s["seconds_index"].get<double>(), s["seconds_load"].get<double>(),
              1e-9);
  EXPECT_LE(s["max_agl_m"].get<double>(), 120 + 0.05);
  EXPECT_NEAR(s["path_length_m"].get<double>(), length, 1e-6);
  EXPECT_GE(length, straight - 1e-6);
  EXPECT_GE(s["min_clearance_m"].get<double>(), 2.0);
  EXPECT_GT(s["roadmap_nodes"].get<long long>(), 0);
  EXPECT_GT(s["roadmap_edges"].get<long long>(), 0);
  for (const char* key :
       {"seconds_load", "seconds_read", "seconds_index", "seconds_roadmap", "seconds_query", "seconds_smooth"})
    EXPECT_GE(s[key].get<double>(), 0) << key;
}

TEST(CliBadInput, NumericOptionsAreFiniteAndInTheirStatedRange) {
  PlanFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  for (const char* v : {"-1", "inf", "nan", "1e300"}) {
    for (const char* flag : {"--safety", "--spacing", "--max-edge", "--max-agl"}) {
      if (std::string(v) == "-1" && std::string(flag) == "--safety") continue;  // checked elsewhere: >= 0
      expect_clean_failure(
          run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path("p.csv"), flag, v, "-q"}), out, flag,
          {"at most", "from 0 to"});
    }
    if (std::string(v) != "inf")  // inf: keep every triangle
      expect_clean_failure(
          run_cli({"mesh", testkit::data_path(kSample), "-o", out.path("m.ply"), "--max-edge", v, "-q"}), out,
          "--max-edge", {"to 1e6"});
  }
  // A resolution far beyond the raster's extent (it was a write out of bounds).
  expect_clean_failure(run_cli({"mesh", testkit::data_path(kSample), "-o", out.path("m.ply"), "--res", "1e300", "-q"}),
                       out, "--res", {"coarser than the whole raster"});
}

TEST(CliBadInput, PlanWaypointsOutsideUnderOrTooClose) {
  PlanFixture f;
  auto w = f.corners();
  TempDir out;
  const std::vector<std::string> outputs{"-o", out.path("path.csv"), "--stats", out.path("s.json"), "-q"};
  auto plan = [&](std::vector<std::string> extra) {
    std::vector<std::string> args{"plan", f.mesh, "--waypoints", f.waypoints};
    args.insert(args.end(), outputs.begin(), outputs.end());
    args.insert(args.end(), extra.begin(), extra.end());
    return run_cli(args);
  };
  auto outside = w;
  outside[0][0] -= 500;
  f.write_waypoints(outside);
  expect_clean_failure(plan({}), out, "waypoint 1", {"outside"});

  auto under = w;
  under[1][2] = 50;  // the sample's lowest cell is about 109 m
  f.write_waypoints(under);
  expect_clean_failure(plan({}), out, "waypoint 2", {"under the surface"});

  f.write_waypoints(w);
  expect_clean_failure(plan({"--safety", "50"}), out, "waypoint 1", {"safety distance"});

  f.write_waypoints({w[0]});
  expect_clean_failure(plan({}), out, f.waypoints, {"at least two"});

  // A roadmap too sparse to join anything, and no refinement: the leg is named.
  f.write_waypoints(w);
  expect_clean_failure(plan({"--spacing", "200", "--max-edge", "10", "--refine-rounds", "0"}), out, "waypoints 1 to 2",
                       {"no "});
}

TEST(CliBadInput, PlanMalformedWaypointFileNamesTheLine) {
  PlanFixture f;
  testkit::write_file(f.waypoints, "x,y,z\n356320,5699270,200\n356400,abc,200\n356700,5699700,200\n");
  TempDir out;
  expect_clean_failure(run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path("p.csv"), "-q"}), out,
                       f.waypoints + ": line 3", {"expected"});
  testkit::write_file(f.waypoints, "356320,5699270\n356700,5699700,200\n");
  expect_clean_failure(run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path("p.csv"), "-q"}), out,
                       "line 1", {"expected"});
  expect_clean_failure(
      run_cli({"plan", f.mesh, "--waypoints", f.in.path("missing.csv"), "-o", out.path("p.csv"), "-q"}), out,
      "missing.csv", {"cannot open"});
  f.write_waypoints(f.corners());
  expect_clean_failure(run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path("p.txt"), "-q"}), out, "-o",
                       {".csv"});
}

TEST(CliPlan, RoadmapFileIsReusedAndRefusedForAnotherMeshOrOptions) {
  PlanFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  const std::string roadmap = f.in.path("map.roadmap");
  auto plan = [&](const std::string& mesh, const std::string& path, std::vector<std::string> extra = {}) {
    std::vector<std::string> args{"plan", mesh, "--waypoints", f.waypoints, "-o", path, "--roadmap", roadmap, "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_cli(args);
  };
  const auto first = plan(f.mesh, out.path("a.csv"), {"--stats", out.path("a.json")});
  ASSERT_EQ(first.exit_code, 0) << first.err;
  ASSERT_TRUE(std::filesystem::exists(roadmap));
  const auto second = plan(f.mesh, out.path("b.csv"), {"--stats", out.path("b.json")});
  ASSERT_EQ(second.exit_code, 0) << second.err;
  const json a = json::parse(testkit::read_file(out.path("a.json"))),
             b = json::parse(testkit::read_file(out.path("b.json")));
  EXPECT_FALSE(a["roadmap_reused"].get<bool>());
  EXPECT_TRUE(b["roadmap_reused"].get<bool>());
  EXPECT_EQ(b["seconds_roadmap"].get<double>(), 0);
  EXPECT_EQ(a["roadmap_nodes"], b["roadmap_nodes"]);
  EXPECT_EQ(a["roadmap_edges"], b["roadmap_edges"]);
  EXPECT_EQ(testkit::read_file(out.path("a.csv")), testkit::read_file(out.path("b.csv")));  // same roadmap, same path

  TempDir none;
  expect_clean_failure(plan(f.mesh, none.path("c.csv"), {"--spacing", "15"}), none, roadmap, {"--spacing"});
  expect_clean_failure(plan(f.mesh, none.path("c.csv"), {"--safety", "3"}), none, roadmap, {"--safety"});
  const std::string other = f.in.path("other.ply");
  ASSERT_EQ(run_cli({"mesh", testkit::data_path(kSample), "-o", other, "--res", "3", "-q"}).exit_code, 0);
  expect_clean_failure(plan(other, none.path("c.csv")), none, roadmap, {"another mesh"});
  std::string bytes = testkit::read_file(roadmap);
  bytes[bytes.size() / 3] ^= 1;
  testkit::write_file(roadmap, bytes);
  expect_clean_failure(plan(f.mesh, none.path("c.csv")), none, roadmap, {"damaged"});
}

// --index: the kept index is opened only when it was built from this very mesh file (and DSM);
// a changed mesh, even by one vertex, is indexed anew, and the path is always the one planned
// without the file. A file that is no index, or is damaged, is refused and left as it was.
TEST(CliPlan, IndexFileIsReusedOnlyForItsOwnMeshAndNeverOverwrittenWhenItIsNoIndex) {
  PlanFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  const std::string index = f.in.path("mesh.index");
  auto plan = [&](const std::string& mesh, const std::string& name, std::vector<std::string> extra = {}) {
    std::vector<std::string> args{"plan",      mesh,      "--waypoints",
                                  f.waypoints, "-o",      out.path(name + ".csv"),
                                  "-q",        "--stats", out.path(name + ".json")};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto run = run_cli(args);
    EXPECT_EQ(run.exit_code, 0) << name << ": " << run.err;
    return json::parse(testkit::read_file(out.path(name + ".json")));
  };
  auto path = [&](const std::string& name) { return testkit::read_file(out.path(name + ".csv")); };
  const json fresh = plan(f.mesh, "fresh");
  EXPECT_FALSE(fresh["index_reused"].get<bool>());
  EXPECT_FALSE(plan(f.mesh, "built", {"--index", index})["index_reused"].get<bool>());
  ASSERT_TRUE(std::filesystem::exists(index));
  const json reused = plan(f.mesh, "reused", {"--index", index});
  EXPECT_TRUE(reused["index_reused"].get<bool>());
  EXPECT_EQ(reused["roadmap_nodes"], fresh["roadmap_nodes"]);
  EXPECT_EQ(reused["roadmap_edges"], fresh["roadmap_edges"]);
  EXPECT_EQ(path("built"), path("fresh"));
  EXPECT_EQ(path("reused"), path("fresh"));
  // With a terrain model (flat, at the DSM's lowest height: under everything) the mesh is not
  // read: the kept index's extent is what the terrain must cover.
  const std::string terrain = f.in.path("terrain.tif");
  {
    const double lowest = *std::min_element(f.dsm.z.begin(), f.dsm.z.end());
    std::string points;
    for (int i = 0; i < 20; ++i)
      for (int j = 0; j < 20; ++j)
        points += std::to_string(356300 + 25 * i + 12) + " " + std::to_string(5699250 + 25 * j + 12) + " " +
                  std::to_string(lowest) + "\n";
    testkit::write_file(f.in.path("terrain.xyz"), points);
    ASSERT_EQ(run_cli({"grid", f.in.path("terrain.xyz"), "--crs", "EPSG:25832", "--res", "25", "-o", terrain, "-q"})
                  .exit_code,
              0);
  }
  plan(f.mesh, "dtm_fresh", {"--dtm", terrain});
  EXPECT_TRUE(plan(f.mesh, "dtm_reused", {"--dtm", terrain, "--index", index})["index_reused"].get<bool>());
  EXPECT_EQ(path("dtm_reused"), path("dtm_fresh"));

  // With the DSM its holes' columns join the mesh (a conservative mesh of it, as
  // DsmClearanceIsReportedWithTheDsm plans on): its own index, then that one reused.
  const std::string dsm = testkit::data_path(kSample), safe = f.in.path("safe.ply");
  ASSERT_EQ(run_cli({"simplify", dsm, "--max-error", "0.4", "--conservative", "-o", safe, "-q"}).exit_code, 0);
  plan(safe, "dsm_fresh", {"--dsm", dsm});
  EXPECT_FALSE(plan(safe, "dsm_built", {"--dsm", dsm, "--index", index})["index_reused"].get<bool>());
  EXPECT_TRUE(plan(safe, "dsm_reused", {"--dsm", dsm, "--index", index})["index_reused"].get<bool>());
  EXPECT_FALSE(plan(safe, "no_dsm", {"--index", index})["index_reused"].get<bool>()) << "the DSM's columns are in it";
  EXPECT_EQ(path("dsm_reused"), path("dsm_fresh"));

  // The same mesh file with one vertex raised to the path where it passes over it (its z, a
  // double in the binary PLY, rewritten in place): a new index, and another path.
  const dsmplan::Mesh mesh = dsmplan::read_mesh(f.mesh);
  const auto fresh_path = read_path_csv(out.path("fresh.csv"));
  size_t longest = 1;  // the middle of the path's longest segment, far from any waypoint
  for (size_t k = 1; k < fresh_path.size(); ++k)
    if (std::hypot(fresh_path[k][0] - fresh_path[k - 1][0], fresh_path[k][1] - fresh_path[k - 1][1]) >
        std::hypot(fresh_path[longest][0] - fresh_path[longest - 1][0],
                   fresh_path[longest][1] - fresh_path[longest - 1][1]))
      longest = k;
  std::array<double, 3> over;
  for (int i = 0; i < 3; ++i) over[i] = (fresh_path[longest][i] + fresh_path[longest - 1][i]) / 2;
  size_t nearest = 0;
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    if (std::hypot(mesh.vertices[i].x - over[0], mesh.vertices[i].y - over[1]) <
        std::hypot(mesh.vertices[nearest].x - over[0], mesh.vertices[nearest].y - over[1]))
      nearest = i;
  std::string bytes = testkit::read_file(f.mesh);
  ASSERT_NE(bytes.find("property double z"), std::string::npos);
  const size_t body = bytes.find("end_header\n") + 11;
  const double raised = over[2];
  std::memcpy(&bytes[body + 24 * nearest + 16], &raised, 8);
  const std::string nudged = f.in.path("nudged.ply");
  testkit::write_file(nudged, bytes);
  plan(f.mesh, "again", {"--index", index});  // the index of the original mesh again
  const json other = plan(nudged, "nudged", {"--index", index});
  EXPECT_FALSE(other["index_reused"].get<bool>());
  plan(nudged, "nudged_fresh");
  EXPECT_EQ(path("nudged"), path("nudged_fresh"));
  EXPECT_NE(path("nudged"), path("fresh")) << "the nudged vertex was to change the plan";

  // Not an index, or damaged: refused, the file left alone.
  TempDir none;
  auto refused = [&](const std::string& file, const std::vector<std::string>& why) {
    const std::string before = testkit::read_file(file);
    expect_clean_failure(
        run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", none.path("p.csv"), "--index", file, "-q"}), none,
        file, why);
    EXPECT_TRUE(testkit::read_file(file) == before) << file << " was overwritten";
  };
  // An input named as the index is refused before anything is read (refuse_overwrites).
  refused(f.waypoints, {"is the same file as --waypoints"});
  refused(f.mesh, {"is the same file as MESH"});
  const std::string notes = f.in.path("notes.txt");
  testkit::write_file(notes, "not an index, and no input of the run either\n");
  refused(notes, {"not a dsmplan index"});
  // Damage is found once the file claims to fit (a stale one is replaced without reading further).
  EXPECT_TRUE(plan(f.mesh, "last", {"--index", index})["index_reused"].get<bool>() == false);
  std::string damaged = testkit::read_file(index);
  damaged[damaged.size() / 2] ^= 0x10;
  testkit::write_file(index, damaged);
  refused(index, {"damaged"});
  const auto corridor =
      run_cli({"plan", dsm, "--waypoints", f.waypoints, "-o", none.path("p.csv"), "--index", index, "-q"});
  expect_clean_failure(corridor, none, "--index", {"corridor"});
}

TEST(CliPlan, GeoJsonWaypointsAndPathAgreeWithTheCsvRun) {
  PlanFixture f;
  const auto waypoints = f.corners();
  f.write_waypoints(waypoints);
  TempDir out;
  ASSERT_EQ(run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path("p.csv"), "-q"}).exit_code, 0);
  const auto csv_path = read_path_csv(out.path("p.csv"));

  // The same waypoints in lon/lat by GDAL's transformation (an independent route through PROJ);
  // DHHN2016 heights have no grid here: allowed, they are taken as EGM96 heights, so the
  // GeoJSON's ellipsoidal heights are GDAL's from UTM + EGM96 to WGS 84 3D.
  const GdalTransform to_wgs("EPSG:25832+5773", "EPSG:4979");
  json features = json::array();
  std::vector<std::array<double, 2>> lonlat;
  for (const auto& w : waypoints) {
    double x = w[0], y = w[1], z = w[2];
    ASSERT_TRUE(to_wgs(x, y, &z));
    ASSERT_GT(z - w[2], 40);  // the geoid's height: GDAL found the EGM96 grid
    lonlat.push_back({x, y});
    features.push_back({{"type", "Feature"},
                        {"properties", json::object()},
                        {"geometry", {{"type", "Point"}, {"coordinates", {x, y, z}}}}});
  }
  const std::string geo_waypoints = f.in.path("wp.geojson");
  testkit::write_file(geo_waypoints, json{{"type", "FeatureCollection"}, {"features", features}}.dump());
  const std::vector<std::string> vertical{"--vertical-crs", "EPSG:7837", "--allow-approximate-vertical"};

  auto run = [&](const std::string& wp, const std::string& path, std::vector<std::string> extra) {
    std::vector<std::string> args{"plan", f.mesh, "--waypoints", wp, "-o", path};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_cli(args);
  };
  auto from_geo = vertical;
  from_geo.push_back("-q");
  ASSERT_EQ(run(geo_waypoints, out.path("g.csv"), from_geo).exit_code, 0);
  const auto geo_path = read_path_csv(out.path("g.csv"));
  for (size_t i : {size_t{0}, geo_path.size() - 1}) {
    const auto& w = i == 0 ? waypoints.front() : waypoints.back();
    EXPECT_LT(std::hypot(geo_path[i][0] - w[0], geo_path[i][1] - w[1], geo_path[i][2] - w[2]), 1e-3);
  }

  const auto written = run(f.waypoints, out.path("p.geojson"), vertical);  // not quiet: names the transformation
  ASSERT_EQ(written.exit_code, 0) << written.err;
  EXPECT_NE(written.out.find("DHHN2016"), std::string::npos) << written.out;
  const json line = json::parse(testkit::read_file(out.path("p.geojson")));
  EXPECT_EQ(line["type"], "Feature");
  EXPECT_EQ(line["geometry"]["type"], "LineString");
  const json& c = line["geometry"]["coordinates"];
  ASSERT_EQ(c.size(), csv_path.size());
  for (size_t i : {size_t{0}, c.size() - 1}) {
    const auto& ll = i == 0 ? lonlat.front() : lonlat.back();
    EXPECT_NEAR(c[i][0].get<double>(), ll[0], 2e-9);
    EXPECT_NEAR(c[i][1].get<double>(), ll[1], 2e-9);
    // Taken as EGM96 heights, then through the EGM96 grid: the geoid's ~47 m added, not copied.
    EXPECT_GT(c[i][2].get<double>() - csv_path[i][2], 40);
    EXPECT_LT(c[i][2].get<double>() - csv_path[i][2], 55);
  }
  EXPECT_NE(line["properties"]["transformation"].get<std::string>().find("taken as EGM96"), std::string::npos);

  TempDir none;
  expect_clean_failure(run(f.waypoints, none.path("p.geojson"), {"-q"}), none, "--vertical-crs", {"unknown"});
  expect_clean_failure(run(f.waypoints, none.path("p.geojson"), {"--vertical-crs", "EPSG:7837", "-q"}), none,
                       "--vertical-crs", {"approximate"});
}

TEST(CliPlan, OfOverridesTheExtensionAndJsonPrintsTheStatistics) {
  PlanFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  const auto result = run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path("path.txt"), "--of", "CSV",
                               "--json", "-q", "--stats", out.path("s.json")});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  const auto points = read_path_csv(out.path("path.txt"));  // a CSV, whatever the name says
  EXPECT_GE(points.size(), 2u);
  EXPECT_EQ(json::parse(result.out), json::parse(testkit::read_file(out.path("s.json"))));
  TempDir none;
  expect_clean_failure(
      run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", none.path("p.csv"), "--of", "shp", "-q"}), none,
      "--of", {"must be csv, geojson, plan, waypoints, kmz or kml, got 'shp'"});
}

TEST(CliPlan, DsmClearanceIsReportedWithTheDsm) {
  PlanFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  // The conservative mesh of the DSM itself: its columns lie within half a cell diagonal of it.
  const std::string safe = out.path("safe.ply");
  ASSERT_EQ(run_cli({"simplify", testkit::data_path(kSample), "--max-error", "0.4", "--conservative", "-o", safe, "-q"})
                .exit_code,
            0);
  const auto result = run_cli({"plan", safe, "--waypoints", f.waypoints, "-o", out.path("p.csv"), "--dsm",
                               testkit::data_path(kSample), "--stats", out.path("s.json"), "-q"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const json s = json::parse(testkit::read_file(out.path("s.json")));
  ASSERT_TRUE(s.contains("min_clearance_dsm_m"));
  EXPECT_EQ(s["mesh_max_below_dsm_m"].get<double>(), 0);
  EXPECT_NEAR(s["safety_margin_m"].get<double>(), std::sqrt(0.5), 1e-9);
  EXPECT_GE(s["min_clearance_m"].get<double>(), 2 + std::sqrt(0.5) - 1e-9);
  // The guarantee: the written path keeps --safety from the columns, with nothing subtracted
  // (1 cm for the rounding of what is written).
  EXPECT_EQ(s["dsm_tolerance_m"].get<double>(), 0.01);
  EXPECT_GE(s["min_clearance_dsm_m"].get<double>(), 2 - 0.01);
  const auto path = read_path_csv(out.path("p.csv"));
  const dsmplan::Grid dsm = dsmplan::read_raster(testkit::data_path(kSample));
  for (size_t k = 1; k < path.size(); ++k)
    EXPECT_GE(dsmplan::column_clearance(dsm, path[k - 1], path[k], 3), 2 - 0.01) << k;
  EXPECT_EQ(s["ground"], "dsm");
}

TEST(CliBadInput, PlanPathThroughATowerOfTheDsmIsNeverWritten) {
  PlanFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  const std::string safe = out.path("safe.ply"), path = out.path("p.csv");
  ASSERT_EQ(run_cli({"simplify", testkit::data_path(kSample), "--max-error", "0.4", "--conservative", "-o", safe, "-q"})
                .exit_code,
            0);
  ASSERT_EQ(run_cli({"plan", safe, "--waypoints", f.waypoints, "-o", path, "-q"}).exit_code, 0);

  // A 3 x 3 m tower in the DSM (not in the mesh) where the path's middle segment passes.
  const auto points = read_path_csv(path);
  const auto& a = points[points.size() / 2 - 1];
  const auto& b = points[points.size() / 2];
  dsmplan::Grid dsm = dsmplan::read_raster(testkit::data_path(kSample));
  const double mx = 0.5 * (a[0] + b[0]), my = 0.5 * (a[1] + b[1]), top = std::max(a[2], b[2]) + 20;
  const int col = static_cast<int>((mx - dsm.x0) / dsm.cell_x), row = static_cast<int>((dsm.y0 - my) / dsm.cell_y);
  for (int r = row - 1; r <= row + 1; ++r)
    for (int c = col - 1; c <= col + 1; ++c) dsm.z[dsm.index(c, r)] = static_cast<float>(top);
  const std::string towered = f.in.path("tower.tif");
  dsmplan::write_geotiff(dsm, towered);
  // The mesh does not hold the tower: the safety distance on it is widened by as much as the
  // tower rises above it. The run keeps 2 m from the tower's column, or stops with one line
  // that says why; it never writes the path through it.
  TempDir none;
  const auto run =
      run_cli({"plan", safe, "--waypoints", f.waypoints, "-o", none.path("p.csv"), "--dsm", towered, "-q"});
  if (run.exit_code == 0) {
    const auto around = read_path_csv(none.path("p.csv"));
    for (size_t k = 1; k < around.size(); ++k)
      EXPECT_GE(dsmplan::column_clearance(dsm, around[k - 1], around[k], 3), 2 - 0.01) << k;
  } else {
    expect_clean_failure(run, none, f.waypoints, {"widened by", "columns"});
  }
  EXPECT_EQ(dsmplan::column_clearance(dsm, a, b, 3), 0);  // the unguarded path went through it
}

TEST(CliBadInput, PlanMalformedGeoJsonWaypointsNameThePlace) {
  PlanFixture f;
  TempDir out;
  const std::string wp = f.in.path("wp.geojson");
  auto expect = [&](const std::string& text, const std::string& place, const std::string& why) {
    testkit::write_file(wp, text);
    expect_clean_failure(run_cli({"plan", f.mesh, "--waypoints", wp, "-o", out.path("p.csv"), "--vertical-crs",
                                  "EPSG:7837", "--allow-approximate-vertical", "-q"}),
                         out, wp + ": " + place, {why});
  };
  const std::string point = R"({"type":"Feature","geometry":{"type":"Point","coordinates":[6.93,51.43,150]}})";
  expect(R"({"type":"FeatureCollection","features":[)" + point +
             R"(,{"type":"Feature","geometry":{"type":"Point","coordinates":[6.93,51.43]}}]})",
         "feature 2", "height");
  expect(R"({"type":"FeatureCollection","features":[)" + point +
             R"(,{"type":"Feature","geometry":{"type":"Point","coordinates":[356320,5699270,150]}}]})",
         "feature 2", "longitude");
  expect(R"({"type":"FeatureCollection","features":[)" + point +
             R"(,{"type":"Feature","geometry":{"type":"Polygon","coordinates":[]}}]})",
         "feature 2", "Polygon");
  expect(R"({"type":"LineString","coordinates":[[6.93,51.43,150],[6.94,"x",150]]})", "geometry, position 2", "numbers");
  expect(R"({"type":"FeatureCollection","features":[)" + point + ",", "byte", "not JSON");
  expect(R"({"type":"FeatureCollection"})", "", "features");
}

// ---- dsmplan plan --planner rrtconnect ------------------------------------------------------

TEST(CliPlan, RrtConnectWritesAPathThroughTheWaypointsAndRepeatsItForTheSameSeed) {
  PlanFixture f;
  const auto waypoints = f.corners();
  f.write_waypoints(waypoints);
  TempDir out;
  auto plan = [&](const std::string& name, const std::string& seed) {
    return run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path(name), "--stats",
                    out.path(name + ".json"), "--planner", "rrtconnect", "--seed", seed, "-q"});
  };
  const auto result = plan("a.csv", "5");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  const auto points = read_path_csv(out.path("a.csv"));
  ASSERT_GE(points.size(), 3u);
  EXPECT_EQ(points.front(), waypoints.front());
  EXPECT_EQ(points.back(), waypoints.back());
  EXPECT_NE(std::find(points.begin(), points.end(), waypoints[1]), points.end());
  const json s = json::parse(testkit::read_file(out.path("a.csv.json")));
  EXPECT_GE(s["min_clearance_m"].get<double>(), 2.0);
  EXPECT_EQ(s["seconds_roadmap"].get<double>(), 0);  // no roadmap: trees
  EXPECT_GT(s["roadmap_nodes"].get<long long>(), 2);

  ASSERT_EQ(plan("b.csv", "5").exit_code, 0);
  EXPECT_EQ(testkit::read_file(out.path("b.csv")), testkit::read_file(out.path("a.csv")));
}

TEST(CliBadInput, PlanUnknownPlannerOrNegativeSeed) {
  PlanFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  auto plan = [&](std::vector<std::string> extra) {
    std::vector<std::string> args{"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path("p.csv"), "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_cli(args);
  };
  expect_clean_failure(plan({"--planner", "bogus"}), out, "--planner", {"rrtconnect or freespace"});
  expect_clean_failure(plan({"--planner", "freespace", "--objective", "lowest"}), out, "--objective",
                       {"low or shortest"});
  expect_clean_failure(plan({"--planner", "rrtconnect", "--seed", "-1"}), out, "--seed", {">= 0"});
}

// ---- dsmplan plan -o .plan / .waypoints / .kml ----------------------------------------------
//
// Oracle for the horizontal part: GDAL's own OGRCoordinateTransformation (traditional GIS order);
// heights given as EGM96 (--vertical-crs EPSG:5773) reach mean sea level unchanged, so the first
// and last items must carry the first and last waypoints' heights.

// ---- flyable missions --------------------------------------------------------------------------

// Least distance from p to the DSM's cells as solid columns (each a box over its square, from
// below up to its height), by brute force over the cells within r; r when none is nearer.
double distance_to_columns(const Raster& dsm, const std::array<double, 3>& p, double r) {
  double best = r;
  const int c0 = std::max(0, int(std::floor((p[0] - r - dsm.gt[0]) / dsm.gt[1])));
  const int c1 = std::min(dsm.width - 1, int(std::floor((p[0] + r - dsm.gt[0]) / dsm.gt[1])));
  const int r0 = std::max(0, int(std::floor((p[1] + r - dsm.gt[3]) / dsm.gt[5])));
  const int r1 = std::min(dsm.height - 1, int(std::floor((p[1] - r - dsm.gt[3]) / dsm.gt[5])));
  for (int row = r0; row <= r1; ++row)
    for (int col = c0; col <= c1; ++col) {
      const double x0 = dsm.gt[0] + col * dsm.gt[1], x1 = x0 + dsm.gt[1];
      const double y1 = dsm.gt[3] + row * dsm.gt[5], y0 = y1 + dsm.gt[5];
      const double dx = std::max({0.0, x0 - p[0], p[0] - x1}), dy = std::max({0.0, y0 - p[1], p[1] - y1});
      const double dz = std::max(0.0, p[2] - dsm.z[size_t(row) * dsm.width + col]);
      best = std::min(best, std::sqrt(dx * dx + dy * dy + dz * dz));
    }
  return best;
}

struct MissionLine {
  int command = 0, frame = 0;
  std::array<double, 3> xyz{};  // in EPSG:25832; z above mean sea level (the data's heights here)
};

// A .waypoints file read back: items (home first) with their positions in UTM, altitudes made
// absolute with home's.
std::vector<MissionLine> read_mission_utm(const std::string& path) {
  const GdalTransform to_utm("EPSG:4326", "EPSG:25832");
  std::vector<MissionLine> lines;
  std::istringstream wpl(testkit::read_file(path));
  std::string line;
  std::getline(wpl, line);
  while (std::getline(wpl, line)) {
    std::vector<std::string> f;
    std::istringstream split(line);
    for (std::string field; std::getline(split, field, '\t');) f.push_back(field);
    if (f.size() != 12) throw std::runtime_error("not 12 fields: " + line);
    MissionLine item;
    item.command = std::stoi(f[3]);
    item.frame = std::stoi(f[2]);
    double x = std::stod(f[9]), y = std::stod(f[8]);  // longitude, latitude
    if (!to_utm(x, y)) throw std::runtime_error("transform");
    item.xyz = {x, y, std::stod(f[10]) + (item.frame == 3 ? lines.front().xyz[2] : 0)};
    lines.push_back(item);
  }
  return lines;
}

// Every straight line a mission flies, sampled every 5 cm: its least distance to the DSM's
// columns and its greatest height above the DSM's cell below. The vertical climb at home and the
// descent of a landing are counted from 1 m plus `safety` above the ground, as documented.
struct MissionFlight {
  double least_clearance = INFINITY, most_above = -INFINITY;
  size_t positions = 0;
};
MissionFlight fly(const std::vector<MissionLine>& items, const PlanFixture& f, double safety) {
  MissionFlight flight;
  const auto& home = items.front().xyz;
  std::vector<std::array<double, 3>> route;
  std::vector<std::pair<std::array<double, 3>, std::array<double, 3>>> legs;
  for (size_t i = 1; i < items.size(); ++i) {
    const MissionLine& item = items[i];
    if (item.command == 22) {
      route.push_back({home[0], home[1], item.xyz[2]});
      legs.push_back({{home[0], home[1], std::min(item.xyz[2], home[2] + 1 + safety)}, route.back()});
    } else if (item.command == 16) {
      legs.push_back({route.back(), item.xyz});
      route.push_back(item.xyz);
    } else if (item.command == 21) {
      const auto& top = route.back();
      legs.push_back({{top[0], top[1], std::min(top[2], item.xyz[2] + 1 + safety)}, top});
    }
  }
  flight.positions = route.size();
  for (const auto& [a, b] : legs) {
    const double length = std::hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    const int steps = std::max(1, int(std::ceil(length / 0.05)));
    for (int k = 0; k <= steps; ++k) {
      const double t = double(k) / steps;
      const std::array<double, 3> p{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
      flight.least_clearance = std::min(flight.least_clearance, distance_to_columns(f.dsm, p, safety + 1));
      flight.most_above = std::max(flight.most_above, p[2] - f.cell(p[0], p[1]));
    }
  }
  return flight;
}

// A waypoint CSV with its comment lines.
std::vector<std::array<double, 3>> read_waypoints_csv_file(const std::string& path) {
  std::istringstream in(testkit::read_file(path));
  std::string kept;
  for (std::string line; std::getline(in, line);)
    if (line.rfind("#", 0) != 0) kept += line + "\n";
  TempDir dir;
  testkit::write_file(dir.path("w.csv"), kept);
  return read_path_csv(dir.path("w.csv"));
}

struct MissionFixture : PlanFixture {
  std::string bounded = in.path("bounded.ply");
  std::string low = testkit::data_path("nrw-dom1/low_waypoints.csv");
  MissionFixture() {
    const auto made =
        run_cli({"simplify", testkit::data_path(kSample), "--max-error", "0.4", "--conservative", "-o", bounded, "-q"});
    if (made.exit_code != 0) throw std::runtime_error("simplify failed: " + made.err);
  }
  testkit::CliResult plan(const std::string& output, std::vector<std::string> extra) const {
    std::vector<std::string> args{"plan",
                                  bounded,
                                  "--waypoints",
                                  low,
                                  "-o",
                                  output,
                                  "--dsm",
                                  testkit::data_path(kSample),
                                  "--max-agl",
                                  "30",
                                  "--spacing",
                                  "10",
                                  "--vertical-crs",
                                  "EPSG:5773",
                                  "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_cli(args);
  }
  // A home against a wall, whose climb passes nearer than the safety distance: the first cell
  // centre east of the first waypoint (on the half-metre line north of it) whose east neighbour
  // stands 8 m higher; NaN, NaN when there is none within 60 m.
  std::array<double, 2> home_against_wall() const {
    const auto user = read_waypoints_csv_file(low);
    for (double dx = 0.5; dx < 60; dx += 1) {
      const double x = user[0][0] + dx, y = user[0][1] + 0.5;
      if (cell(x + 1, y) - cell(x, y) > 8) return {x, y};
    }
    return {NAN, NAN};
  }
};

// The planner on the free airspace (issue 48), as a user runs it: held to the DSM's columns (not
// the mesh with the safety widened), measured here on the written path against the DSM itself;
// low (no higher above the ground than the PRM's path); and a leg between enclosed regions
// refused with both regions named, nothing written.
TEST(CliPlan, FreespaceKeepsTheColumnsFliesLowAndProvesARefusal) {
  MissionFixture f;
  TempDir out;
  const dsmplan::Grid dsm = dsmplan::read_raster(testkit::data_path(kSample));
  const dsmplan::GroundGrid ground(dsm);
  double highest[2] = {0, 0};
  for (const std::string planner : {"freespace", "prm"}) {
    const std::string path = out.path(planner + ".csv");
    const auto planned = f.plan(path, {"--planner", planner, "--stats", path + ".json"});
    ASSERT_EQ(planned.exit_code, 0) << planned.err;
    const auto points = read_path_csv(path);
    ASSERT_GE(points.size(), 4u);
    double& high = highest[planner == std::string("prm")];
    for (size_t k = 1; k < points.size(); ++k) {
      const dsmplan::Point3 p{points[k - 1][0], points[k - 1][1], points[k - 1][2]};
      const dsmplan::Point3 q{points[k][0], points[k][1], points[k][2]};
      EXPECT_GE(dsmplan::column_clearance(dsm, p, q, 3), 2 - 0.01) << planner << " segment " << k;
      high = std::max(high, ground.max_height_above(p, q));
    }
    EXPECT_LE(high, 30 + 0.01);
    const auto stats = nlohmann::json::parse(testkit::read_file(path + ".json"));
    EXPECT_EQ(stats["planner"], planner);
  }
  EXPECT_LT(highest[0], highest[1]) << "freespace flies lower than the PRM";
  testkit::write_file(out.path("apart.csv"), "x,y,z\n356681.5,5699302.5,127.44\n356570.5,5699579.5,127.15\n");
  const std::vector<std::string> refused{"plan",        f.bounded,
                                         "--waypoints", out.path("apart.csv"),
                                         "-o",          out.path("apart_path.csv"),
                                         "--dsm",       testkit::data_path(kSample),
                                         "--max-agl",   "10",
                                         "--planner",   "freespace",
                                         "-q"};
  const auto result = run_cli(refused);
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("lies in a region of"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("no path exists at the DSM's resolution"), std::string::npos) << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  EXPECT_FALSE(std::filesystem::exists(out.path("apart_path.csv")));
}

// Over a mesh alone (no --dsm), freespace plans on the columns that enclose the mesh
// (mesh_columns()) and holds the path to the mesh itself: every segment keeps --safety from every
// triangle (brute force over all of them, not the clearance index the report measures with), and
// the report says the same, under the ceiling over the mesh's floor.
TEST(CliPlan, FreespaceOverTheMeshAloneKeepsTheSafetyFromEveryTriangle) {
  MissionFixture f;
  TempDir out;
  const dsmplan::Mesh mesh = dsmplan::read_mesh(f.bounded);
  const std::string path = out.path("mesh_alone.csv"), stats = path + ".json";
  const auto planned = run_cli({"plan", f.bounded, "--waypoints", f.low, "-o", path, "--max-agl", "30", "--planner",
                                "freespace", "--stats", stats, "-q"});
  ASSERT_EQ(planned.exit_code, 0) << planned.err;
  const auto points = read_path_csv(path);
  ASSERT_GE(points.size(), 4u);
  double least = INFINITY;
  for (size_t k = 1; k < points.size(); ++k) {
    const dsmplan::Point3 p{points[k - 1][0], points[k - 1][1], points[k - 1][2]};
    const dsmplan::Point3 q{points[k][0], points[k][1], points[k][2]};
    for (const dsmplan::Triangle& t : mesh.triangles) {
      const auto corner = [&](int i) {
        const dsmplan::Vertex& v = mesh.vertices[t[i]];
        return dsmplan::Point3{v.x, v.y, v.z};
      };
      least = std::min(least, dsmplan::segment_triangle_distance(p, q, corner(0), corner(1), corner(2)));
    }
  }
  EXPECT_GE(least, 2 - 0.01);  // two decimals written
  const auto report = nlohmann::json::parse(testkit::read_file(stats));
  EXPECT_EQ(report["planner"], "freespace");
  EXPECT_NEAR(report["min_clearance_m"].get<double>(), least, 0.01);
  EXPECT_LE(report["max_agl_m"].get<double>(), 30 + 0.01);
  RecordProperty("least_clearance_m", std::to_string(least));
}

// `profile` draws the free airspace's floor under the path, the lowest height that keeps the
// safety from the DSM's columns (issue 48, point 7), and reports the path's least height above
// it: a path planned with --dsm at that safety never goes under it (its clearance to the columns,
// measured by column_clearance(), is at least the safety), and a straight line at street level
// between the same ends does.
TEST(CliProfile, DrawsTheLowestClearHeightThatAPlannedPathKeepsAboveAndAStraightOneDoesNot) {
  MissionFixture f;
  TempDir out;
  const std::string path = out.path("planned.csv");
  const auto planned = f.plan(path, {"--planner", "freespace"});
  ASSERT_EQ(planned.exit_code, 0) << planned.err;
  const auto points = read_path_csv(path);
  const auto profile = [&](const std::string& csv) {
    const auto run = run_cli({"profile", testkit::data_path(kSample), "--path", csv, "-o", csv + ".png", "--safety",
                              "2", "--max-agl", "30", "--json", "-q"});
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return json::parse(run.out);
  };
  const json kept = profile(path);
  EXPECT_GE(kept["min_above_lowest_clear_m"].get<double>(), -1e-6) << kept.dump();
  const dsmplan::Point3 a{points.front()[0], points.front()[1], points.front()[2]};
  const dsmplan::Point3 b{points.back()[0], points.back()[1], points.front()[2]};
  testkit::write_file(out.path("straight.csv"), "x,y,z\n" + std::to_string(a[0]) + "," + std::to_string(a[1]) + "," +
                                                    std::to_string(a[2]) + "\n" + std::to_string(b[0]) + "," +
                                                    std::to_string(b[1]) + "," + std::to_string(b[2]) + "\n");
  const json straight = profile(out.path("straight.csv"));
  const dsmplan::Grid dsm = dsmplan::read_raster(testkit::data_path(kSample));
  const double clearance = dsmplan::column_clearance(dsm, a, b, 3);
  ASSERT_LT(clearance, 2.0) << "the straight line should pass near a building";
  EXPECT_LT(straight["min_above_lowest_clear_m"].get<double>(), 0) << straight.dump();
}

// One definition of each measure (issue 32): the height above the ground `plan` verifies and
// reports is the one `profile` reports for the same path, to the last bit: over the DSM, over a
// DTM, and over a DTM with a hole where the path is highest above it (which the two counted apart
// before: plan 12.52 m, profile 12.07 m on a satellite DSM with holes).
TEST(CliPlan, PlanAndProfileGiveTheSameHeightAboveTheGround) {
  MissionFixture f;
  TempDir out;
  dsmplan::Grid terrain = dsmplan::read_raster(testkit::data_path(kSample));
  for (float& z : terrain.z) z -= 8;  // a ground 8 m under the DSM
  const auto plan_and_profile = [&](const std::string& name, const std::string& dtm) {
    const std::string path = out.path(name + ".csv"), stats = path + ".json";
    std::vector<std::string> extra{"--stats", stats};
    if (!dtm.empty()) extra.insert(extra.end(), {"--dtm", dtm});
    const auto planned = f.plan(path, extra);
    EXPECT_EQ(planned.exit_code, 0) << planned.err;
    std::vector<std::string> args{"profile", testkit::data_path(kSample), "--path", path, "-o", path + ".png", "--json",
                                  "-q"};
    if (!dtm.empty()) args.insert(args.end(), {"--dtm", dtm});
    const auto profiled = run_cli(args);
    EXPECT_EQ(profiled.exit_code, 0) << profiled.err;
    const json profile = json::parse(profiled.out);
    EXPECT_EQ(json::parse(testkit::read_file(stats))["max_agl_m"].get<double>(),
              profile["max_above_ground_m"].get<double>())
        << name;
    return std::make_pair(read_path_csv(path), profile["max_above_ground_at_m"].get<double>());
  };
  plan_and_profile("over_dsm", "");
  const std::string dtm = out.path("dtm.tif");
  dsmplan::write_geotiff(terrain, dtm);
  const auto [path, at] = plan_and_profile("over_dtm", dtm);
  // A hole of 7 x 7 cells in the DTM where the path is highest above it.
  double walked = 0, x = path[0][0], y = path[0][1];
  for (size_t k = 1; k < path.size(); ++k) {
    const double leg = std::hypot(path[k][0] - path[k - 1][0], path[k][1] - path[k - 1][1]);
    if (walked + leg >= at) {
      const double t = leg > 0 ? (at - walked) / leg : 0;
      x = path[k - 1][0] + t * (path[k][0] - path[k - 1][0]), y = path[k - 1][1] + t * (path[k][1] - path[k - 1][1]);
      break;
    }
    walked += leg;
  }
  int col = 0, row = 0;
  ASSERT_TRUE(terrain.cell_at(x, y, col, row));
  for (int r = row - 3; r <= row + 3; ++r)
    for (int c = col - 3; c <= col + 3; ++c) terrain.z[terrain.index(c, r)] = NAN;
  const std::string holed = out.path("holed.tif");
  dsmplan::write_geotiff(terrain, holed);
  plan_and_profile("over_holed_dtm", holed);
}

// Several outputs of one flight (issue 32, point 5): with a mission among them, the others show
// the mission as flown: from home on the ground up the vertical takeoff, along the planned items,
// and back down at home (--end rtl).
TEST(CliPlan, SeveralOutputsOfOneMissionShowItAsFlown) {
  MissionFixture f;
  TempDir out;
  const std::string csv = out.path("flown.csv"), mission = out.path("m.waypoints"), kml = out.path("flown.kml");
  const auto planned = f.plan(csv, {"-o", mission, "-o", kml, "--stats", out.path("s.json")});
  ASSERT_EQ(planned.exit_code, 0) << planned.err;
  const json stats = json::parse(testkit::read_file(out.path("s.json")));
  const auto flown = read_path_csv(csv);
  const auto home = stats["home"].get<std::vector<double>>();
  // --end rtl: the items are the takeoff, the speed, the planned points after the first and the
  // return, as many as the flown path's points (home, the planned points, home).
  ASSERT_EQ(flown.size(), stats["mission_items"].get<size_t>());
  for (const auto& end : {flown.front(), flown.back()}) {
    EXPECT_EQ(end[0], home[0]);
    EXPECT_EQ(end[1], home[1]);
    EXPECT_EQ(end[2], home[2]);
  }
  // The takeoff is vertical, to the height it was planned at above home.
  EXPECT_EQ(flown[1][0], home[0]);
  EXPECT_EQ(flown[1][1], home[1]);
  EXPECT_NEAR(flown[1][2] - home[2], stats["takeoff_height_m"].get<double>(), 1e-9);
  // The mission's own items (QGC WPL: the header, home, then a line per item).
  std::istringstream items(testkit::read_file(mission));
  size_t lines = 0;
  for (std::string line; std::getline(items, line);) lines += !line.empty();
  EXPECT_EQ(lines - 2, stats["mission_items"].get<size_t>());  // the header line, home, then the items
  // The KML draws the same flown path: as many coordinates in its LineString.
  const std::string text = testkit::read_file(kml);
  const size_t a = text.find("<coordinates>", text.find("<LineString>")), b = text.find("</coordinates>", a);
  std::istringstream coordinates(text.substr(a + 13, b - a - 13));
  size_t points = 0;
  for (std::string token; coordinates >> token;) ++points;
  EXPECT_EQ(points, flown.size());
}

TEST(CliPlan, MissionsAndKmlCarryTheWaypointsInLatLonAndMeanSeaLevelHeights) {
  MissionFixture f;
  const auto waypoints = f.corners();
  f.write_waypoints(waypoints);
  TempDir out;
  const std::vector<std::string> egm96{"--vertical-crs", "EPSG:5773"};
  auto run = [&](const std::string& name, bool quiet) {
    std::vector<std::string> args{"plan",        f.bounded,
                                  "--waypoints", f.waypoints,
                                  "-o",          out.path(name),
                                  "--stats",     out.path(name + ".json"),
                                  "--dsm",       testkit::data_path(kSample)};
    args.insert(args.end(), egm96.begin(), egm96.end());
    if (quiet) args.push_back("-q");
    return run_cli(args);
  };
  const auto written = run("m.plan", false);  // not quiet: names the transformation
  ASSERT_EQ(written.exit_code, 0) << written.err;
  EXPECT_NE(written.out.find("to WGS 84 by: "), std::string::npos) << written.out;
  EXPECT_NE(written.out.find("EGM96"), std::string::npos) << written.out;
  const json stats = json::parse(testkit::read_file(out.path("m.plan.json")));
  EXPECT_NE(stats["transformation"].get<std::string>().find("EGM96"), std::string::npos);
  EXPECT_EQ(stats["transformation"].get<std::string>().find("approximate"), std::string::npos);
  EXPECT_GE(stats["min_clearance_m"].get<double>(), 2.0 - 0.01);  // measured on the thinned path

  const GdalTransform to_wgs("EPSG:25832", "EPSG:4326");
  std::vector<std::array<double, 3>> lonlath;
  for (const auto& w : waypoints) {
    double x = w[0], y = w[1];
    ASSERT_TRUE(to_wgs(x, y));
    lonlath.push_back({x, y, w[2]});
  }

  const json plan = json::parse(testkit::read_file(out.path("m.plan")));
  EXPECT_EQ(plan["fileType"], "Plan");
  const json& items = plan["mission"]["items"];
  ASSERT_GE(items.size(), 5u);
  // The summary counts the mission's items.
  EXPECT_NE(written.out.find("mission: " + std::to_string(items.size()) + " items"), std::string::npos) << written.out;
  // Home on the ground under the first waypoint (the DSM's cell: EGM96 heights are the data's
  // here), the takeoff there to the first waypoint, the last waypoint, back above home, RTL.
  const double ground = f.ground(waypoints.front()[0], waypoints.front()[1]);
  const json& home = plan["mission"]["plannedHomePosition"];
  EXPECT_NEAR(home[0].get<double>(), lonlath.front()[1], 2e-9);
  EXPECT_NEAR(home[1].get<double>(), lonlath.front()[0], 2e-9);
  EXPECT_NEAR(home[2].get<double>(), ground, 1e-3);
  EXPECT_EQ(items[0]["command"], 22);
  EXPECT_EQ(items[1]["command"], 178);
  EXPECT_EQ(items.back()["command"], 20);
  size_t last_waypoint = 0;
  for (size_t i = 2; i + 1 < items.size(); ++i) {
    EXPECT_EQ(items[i]["command"], 16);
    EXPECT_EQ(items[i]["frame"], 3);  // relative to home
    const json& p = items[i]["params"];
    if (std::abs(p[4].get<double>() - lonlath.back()[1]) < 2e-9 &&
        std::abs(p[5].get<double>() - lonlath.back()[0]) < 2e-9)
      last_waypoint = i;
  }
  ASSERT_GT(last_waypoint, 0u) << "the last waypoint is not an item";
  EXPECT_NEAR(items[last_waypoint]["params"][6].get<double>() + ground, lonlath.back()[2], 1e-3);
  for (size_t i : {size_t{0}, items.size() - 2}) {  // the takeoff, and the return above home
    const json& p = items[i]["params"];
    EXPECT_NEAR(p[4].get<double>(), lonlath.front()[1], 2e-9);  // latitude first
    EXPECT_NEAR(p[5].get<double>(), lonlath.front()[0], 2e-9);
    EXPECT_NEAR(p[6].get<double>() + ground, lonlath.front()[2], 1e-3);
  }

  ASSERT_EQ(run("m.waypoints", true).exit_code, 0);
  std::istringstream wpl(testkit::read_file(out.path("m.waypoints")));
  std::string line;
  std::getline(wpl, line);
  EXPECT_EQ(line, "QGC WPL 110");
  size_t lines = 0;
  while (std::getline(wpl, line)) {
    std::vector<std::string> fields;
    std::istringstream split(line);
    for (std::string field; std::getline(split, field, '\t');) fields.push_back(field);
    ASSERT_EQ(fields.size(), 12u) << line;
    EXPECT_EQ(std::stoul(fields[0]), lines);
    if (lines <= 1) {  // home (absolute), then the takeoff above it (relative)
      EXPECT_NEAR(std::stod(fields[8]), lonlath.front()[1], 2e-9);
      EXPECT_NEAR(std::stod(fields[9]), lonlath.front()[0], 2e-9);
      EXPECT_NEAR(std::stod(fields[10]), lines == 0 ? ground : lonlath.front()[2] - ground, 1e-3);
    }
    ++lines;
  }
  EXPECT_EQ(lines, items.size() + 1);  // the same items, home first

  ASSERT_EQ(run("m.kml", true).exit_code, 0);
  const std::string kml = testkit::read_file(out.path("m.kml"));
  EXPECT_EQ(count_lines_starting(kml, "        <altitudeMode>absolute</altitudeMode>"), 1 + waypoints.size());
  for (size_t k = 0; k < waypoints.size(); ++k) {
    char expected[128];
    std::snprintf(expected, sizeof expected, "<coordinates>%.9f,%.9f,", lonlath[k][0], lonlath[k][1]);
    // Within a unit in the last place of PROJ's and GDAL's routes: compare to 1e-8 by prefix.
    const std::string prefix(expected, std::strlen(expected) - 3);
    EXPECT_NE(kml.find(prefix), std::string::npos) << expected;
  }
}

TEST(CliBadInput, MissionsNeedAKnownAndExactVerticalReference) {
  PlanFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  auto plan = [&](const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> args{"plan", f.mesh, "--waypoints", f.waypoints, "-o", out.path(name), "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_cli(args);
  };
  expect_clean_failure(plan("m.plan", {}), out, "--vertical-crs", {"unknown"});
  expect_clean_failure(plan("m.kml", {"--vertical-crs", "EPSG:7837"}), out, "--vertical-crs", {"approximate"});
  expect_clean_failure(plan("m.waypoints", {"--vertical-crs", "EPSG:7837"}), out, "--vertical-crs", {"approximate"});
  expect_clean_failure(plan("m.txt", {"--vertical-crs", "EPSG:5773"}), out, "-o", {".plan"});
}

TEST(CliPlan, MissionItemsAreFewAndTheirStraightLinesKeepSafetyAndCeilingOnTheDsm) {
  MissionFixture f;
  TempDir out;
  ASSERT_EQ(f.plan(out.path("p.csv"), {}).exit_code, 0);
  const auto path = read_path_csv(out.path("p.csv"));
  const auto user = read_waypoints_csv_file(f.low);
  for (const std::string end : {"rtl", "land", "none"}) {
    const auto run = f.plan(out.path(end + ".waypoints"), {"--end", end});
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto items = read_mission_utm(out.path(end + ".waypoints"));
    // Home on the DSM under the first waypoint; the takeoff first, the end last.
    EXPECT_NEAR(items[0].xyz[0], user.front()[0], 1e-3);
    EXPECT_NEAR(items[0].xyz[1], user.front()[1], 1e-3);
    EXPECT_NEAR(items[0].xyz[2], f.ground(user.front()[0], user.front()[1]), 1e-3);
    EXPECT_EQ(items[1].command, 22);
    EXPECT_EQ(items[2].command, 178);
    EXPECT_EQ(items.back().command, end == "rtl" ? 20 : end == "land" ? 21 : 16);
    // Every waypoint of the file is an item, in order.
    size_t found = 0;
    for (const MissionLine& item : items)
      if (found < user.size() && (item.command == 16 || item.command == 22) &&
          std::hypot(item.xyz[0] - user[found][0], item.xyz[1] - user[found][1], item.xyz[2] - user[found][2]) < 2e-3)
        ++found;
    EXPECT_EQ(found, user.size()) << end;
    // The limits hold on the straight lines between the items, measured on the DSM itself.
    const MissionFlight flight = fly(items, f, 2.0);
    EXPECT_GE(flight.least_clearance, 2.0 - 0.01) << end;
    EXPECT_LE(flight.most_above, 30 + 0.05) << end;
    // Few items: the path has a point every few metres, the mission one per turn it needs.
    EXPECT_LT(flight.positions * 4, path.size()) << end << ": " << flight.positions << " of " << path.size();
    if (end == "none") {  // the oracle sees a line through a building: an item moved into the DSM
      auto broken = items;
      broken[4].xyz[2] = f.cell(broken[4].xyz[0], broken[4].xyz[1]) - 1;
      EXPECT_LT(fly(broken, f, 2.0).least_clearance, 0.5);
    }
    if (end == "rtl") {  // the DJI mission holds the same points, read back by GDAL's zip and XML readers
      ASSERT_EQ(f.plan(out.path("m.kmz"), {}).exit_code, 0);
      const std::string wpml = "/vsizip/" + out.path("m.kmz") + "/wpmz/waylines.wpml";
      VSILFILE* file = VSIFOpenL(wpml.c_str(), "rb");
      ASSERT_TRUE(file) << wpml;
      std::string xml;
      char buffer[4096];
      for (size_t got; (got = VSIFReadL(buffer, 1, sizeof buffer, file)) > 0;) xml.append(buffer, got);
      VSIFCloseL(file);
      CPLXMLNode* root = CPLParseXMLString(xml.c_str());
      ASSERT_TRUE(root);
      const CPLXMLNode* folder = CPLSearchXMLNode(root, "=Folder");
      ASSERT_TRUE(folder);
      std::vector<std::array<double, 2>> placemarks;
      for (const CPLXMLNode* n = folder->psChild; n; n = n->psNext)
        if (n->eType == CXT_Element && std::string(n->pszValue) == "Placemark") {
          const char* coordinates = CPLGetXMLValue(n, "Point.coordinates", "");
          double lon = 0, lat = 0;
          ASSERT_EQ(std::sscanf(coordinates, "%lf,%lf", &lon, &lat), 2) << coordinates;
          placemarks.push_back({lon, lat});
        }
      CPLDestroyXMLNode(root);
      EXPECT_EQ(placemarks.size(), flight.positions);  // the takeoff's top, the waypoints, back above home
      EXPECT_NEAR(placemarks.back()[0], placemarks.front()[0], 1e-9);
      EXPECT_NEAR(placemarks.back()[1], placemarks.front()[1], 1e-9);
    }
    if (end == "rtl") {  // back above home before the return
      const auto& back = items[items.size() - 2].xyz;
      EXPECT_NEAR(back[0], items[0].xyz[0], 1e-3);
      EXPECT_NEAR(back[1], items[0].xyz[1], 1e-3);
    }
  }
}

TEST(CliPlan, MissionFromAHomeElsewhereLandsAtTheEndInAbsoluteAltitudes) {
  MissionFixture f;
  TempDir out;
  const auto user = read_waypoints_csv_file(f.low);
  // A flat open spot 30-60 m from the first waypoint: no cell within 3 m more than 0.3 m higher.
  std::array<double, 2> spot{NAN, NAN};
  for (double dy = -60; dy <= 60 && std::isnan(spot[0]); dy += 1)
    for (double dx = -60; dx <= 60 && std::isnan(spot[0]); dx += 1) {
      const double x = user[0][0] + dx + 0.5, y = user[0][1] + dy + 0.5, r = std::hypot(dx, dy);
      if (r < 30 || r > 60) continue;
      if (std::isnan(f.cell(x - 4, y - 4)) || std::isnan(f.cell(x + 4, y + 4))) continue;  // inside the DSM
      if (f.highest(x, y, 3.5) - f.cell(x, y) <= 0.3 && f.cell(x, y) < user[0][2] - 5) spot = {x, y};
    }
  ASSERT_FALSE(std::isnan(spot[0])) << "no open spot near the first waypoint";
  char home[64];
  std::snprintf(home, sizeof home, "%.3f,%.3f", spot[0], spot[1]);
  const auto run =
      f.plan(out.path("m.waypoints"), {"--home", home, "--end", "land", "--altitude-frame", "amsl", "--firmware",
                                       "ardupilot", "--speed", "4", "--stats", out.path("s.json")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto items = read_mission_utm(out.path("m.waypoints"));
  const double ground = f.ground(spot[0], spot[1]);
  EXPECT_NEAR(items[0].xyz[0], spot[0], 1e-3);
  EXPECT_NEAR(items[0].xyz[1], spot[1], 1e-3);
  EXPECT_NEAR(items[0].xyz[2], ground, 1e-3);
  // The takeoff climbs at home as high above its ground as the first waypoint is above its own.
  EXPECT_EQ(items[1].command, 22);
  EXPECT_EQ(items[1].frame, 0);  // absolute
  EXPECT_NEAR(items[1].xyz[0], spot[0], 1e-3);
  EXPECT_NEAR(items[1].xyz[2] - ground, user[0][2] - f.ground(user[0][0], user[0][1]), 1e-3);
  // Lands at the last waypoint, on the DSM's cell there.
  EXPECT_EQ(items.back().command, 21);
  EXPECT_NEAR(items.back().xyz[0], user.back()[0], 1e-3);
  EXPECT_NEAR(items.back().xyz[1], user.back()[1], 1e-3);
  EXPECT_NEAR(items.back().xyz[2], f.ground(user.back()[0], user.back()[1]), 1e-3);
  const MissionFlight flight = fly(items, f, 2.0);
  EXPECT_GE(flight.least_clearance, 2.0 - 0.01);
  EXPECT_LE(flight.most_above, 30 + 0.05);
  const json stats = json::parse(testkit::read_file(out.path("s.json")));
  EXPECT_EQ(stats["mission_items"], items.size() - 1);
  EXPECT_EQ(stats["mission_end"], "land");

  // The same home in degrees; the .plan says ArduPilot and its speed.
  double lon = spot[0], lat = spot[1];
  ASSERT_TRUE(GdalTransform("EPSG:25832", "EPSG:4326")(lon, lat));
  std::snprintf(home, sizeof home, "%.10f,%.10f", lon, lat);
  ASSERT_EQ(f.plan(out.path("m.plan"), {"--home", home, "--firmware", "ardupilot", "--speed", "4"}).exit_code, 0);
  const json plan = json::parse(testkit::read_file(out.path("m.plan")));
  EXPECT_EQ(plan["mission"]["firmwareType"], 3);
  EXPECT_EQ(plan["mission"]["cruiseSpeed"], 4);
  EXPECT_EQ(plan["mission"]["hoverSpeed"], 4);
  EXPECT_NEAR(plan["mission"]["plannedHomePosition"][0].get<double>(), lat, 1e-8);
  EXPECT_NEAR(plan["mission"]["plannedHomePosition"][1].get<double>(), lon, 1e-8);
  EXPECT_NEAR(plan["mission"]["plannedHomePosition"][2].get<double>(), ground, 1e-3);
}

TEST(CliBadInput, MissionHomeEndAndFirmwareRefusedInOneLine) {
  MissionFixture f;
  TempDir out;
  const auto user = read_waypoints_csv_file(f.low);
  expect_clean_failure(f.plan(out.path("m.plan"), {"--home", "356000,5699000"}), out, "--home", {"outside"});
  expect_clean_failure(f.plan(out.path("m.plan"), {"--home", "356400"}), out, "--home", {"x,y"});
  expect_clean_failure(f.plan(out.path("m.plan"), {"--firmware", "dji"}), out, "--firmware", {"px4, ardupilot"});
  expect_clean_failure(f.plan(out.path("m.plan"), {"--end", "hover"}), out, "--end", {"rtl, land"});
  expect_clean_failure(f.plan(out.path("m.plan"), {"--altitude-frame", "agl"}), out, "--altitude-frame", {"relative"});
  expect_clean_failure(f.plan(out.path("m.plan"), {"--speed", "0"}), out, "--speed", {"(0, 100]"});
  expect_clean_failure(f.plan(out.path("m.csv"), {"--home", "356400,5699400"}), out, "--home", {"missions"});
  expect_clean_failure(f.plan(out.path("m.csv"), {"--end", "land"}), out, "--end", {"missions"});
  // A home against a wall: the climb passes nearer than the safety distance.
  const std::array<double, 2> wall = f.home_against_wall();
  ASSERT_FALSE(std::isnan(wall[0])) << "no wall east of the first waypoint";
  char at[64];
  std::snprintf(at, sizeof at, "%.2f,%.2f", wall[0], wall[1]);
  const auto against_wall = f.plan(out.path("m.plan"), {"--home", at});
  expect_clean_failure(against_wall, out, "--home", {"climb", "obstacle", "the nearest clear spot: --home "});
  // The spot it names is one a run accepts, a few metres away.
  const std::string said = "the nearest clear spot: --home ";
  const size_t from = against_wall.err.find(said) + said.size();
  const std::string clear = against_wall.err.substr(from, against_wall.err.find(' ', from) - from);
  double cx = NAN, cy = NAN;
  ASSERT_EQ(std::sscanf(clear.c_str(), "%lf,%lf", &cx, &cy), 2) << against_wall.err;
  EXPECT_LE(std::hypot(cx - wall[0], cy - wall[1]), 10) << against_wall.err;
  const auto moved = f.plan(out.path("moved.plan"), {"--home", clear});
  EXPECT_EQ(moved.exit_code, 0) << moved.err;
  std::filesystem::remove(out.path("moved.plan"));
  // With a terrain model, a home and a landing under roofs are told apart from the ground.
  // A terrain model made as a crude ground filter would: the lowest DSM cell within 12 m.
  std::string points;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j) {
      const double x = 356302.5 + 5 * i, y = 5699252.5 + 5 * j;
      double low = INFINITY;
      for (double dx = -12; dx <= 12; dx += 1)
        for (double dy = -12; dy <= 12; dy += 1)
          if (std::abs(x + dx - 356550) < 250 && std::abs(y + dy - 5699500) < 250)
            low = std::min(low, f.cell(x + dx, y + dy));
      points += std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(low) + "\n";
    }
  testkit::write_file(f.in.path("dtm.xyz"), points);
  ASSERT_EQ(
      run_cli({"grid", f.in.path("dtm.xyz"), "--crs", "EPSG:25832", "--res", "5", "-o", f.in.path("dtm.tif"), "-q"})
          .exit_code,
      0);
  std::array<double, 2> roof{NAN, NAN};
  double top = -INFINITY;
  for (int row = 2; row < f.dsm.height - 2; ++row)
    for (int col = 2; col < f.dsm.width - 2; ++col)
      if (f.dsm.z[size_t(row) * f.dsm.width + col] > top)
        top = f.dsm.z[size_t(row) * f.dsm.width + col], roof = {f.dsm.gt[0] + col + 0.5, f.dsm.gt[3] - row - 0.5};
  std::snprintf(at, sizeof at, "%.2f,%.2f", roof[0], roof[1]);
  expect_clean_failure(f.plan(out.path("m.plan"), {"--home", at, "--dtm", f.in.path("dtm.tif")}), out, "--home",
                       {"under a roof"});
  // The last waypoint above that roof, landing there.
  std::vector<std::array<double, 3>> over_roof = user;
  over_roof.back() = {roof[0], roof[1], top + 5};
  f.write_waypoints(over_roof);
  const auto land = run_cli({"plan", f.bounded, "--waypoints", f.waypoints, "-o", out.path("m.plan"), "--dsm",
                             testkit::data_path(kSample), "--dtm", f.in.path("dtm.tif"), "--vertical-crs", "EPSG:5773",
                             "--end", "land", "-q"});
  expect_clean_failure(land, out, "--end", {"under a roof"});
}

// ---- one command line convention -------------------------------------------------------------

TEST(CliUsage, MistakesAreOneLineExitTwoWithTheNearestName) {
  TempDir out;
  const std::string dsm = testkit::data_path(kSample);
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::vector<Case> cases{
      {{"plan", "m.ply", "--saftey", "2"}, "unknown option --saftey for plan (did you mean --safety?)"},
      {{"pln", "m.ply"}, "unknown command 'pln' (did you mean 'plan'?)"},
      {{"simplfy", dsm}, "did you mean 'simplify'?"},
      {{"xyzzy"}, "the commands: info, grid, stereo, mesh, simplify, render, profile, plan, view"},
      {{}, "a command is needed"},
      {{"mesh", dsm, "-of", "glb", "-o", out.path("x.ply")}, "-of: long options take two dashes: --of"},
      {{"mesh", dsm, "-o", out.path("x.ply"), "--res", "abc"}, "--res"},
      {{"mesh", dsm}, "--output is required"},
      {{"info", dsm, "--bnd", "2"}, "did you mean --band?"},
      {{"plan", "m.ply", "--waypoints", "w.csv", "-o", out.path("p.csv"), "--planner", "astar"}, "--planner"},
      {{"render", dsm, "-o", out.path("x.png"), "--of", "jpeg"}, "png only"},
      {{"info", dsm, "--of", "xml"}, "text or json"},
  };
  for (const Case& c : cases) {
    const auto result = run_cli(c.args);
    EXPECT_EQ(result.exit_code, 2) << c.says << ": " << result.err;
    EXPECT_EQ(result.err.rfind("dsmplan: ", 0), 0u) << result.err;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_NE(result.err.find(c.says), std::string::npos) << result.err;
    EXPECT_TRUE(out.files().empty());
  }
  // --crs overrides what the input states, for rasters as for points (gdal_translate -a_srs).
  const auto info = run_cli({"info", dsm, "--crs", "EPSG:32632", "--json"});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_EQ(json::parse(info.out)["crs"]["epsg"], 32632) << info.out;
  // Help and version are not mistakes.
  EXPECT_EQ(run_cli({"--version"}).exit_code, 0);
  const auto help = run_cli({"plan", "--help"});
  EXPECT_EQ(help.exit_code, 0);
  for (const std::string unit : {"(m)", "m/s", "degrees"}) EXPECT_NE(help.out.find(unit), std::string::npos) << unit;
}

TEST(CliUsage, EveryCommandTakesJsonAndQuietSilencesItsSummary) {
  TempDir out;
  const std::string dsm = testkit::data_path(kSample);
  const auto info = run_cli({"info", dsm, "--of", "json", "-q"});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_EQ(json::parse(info.out)["width"], 500);
  const auto mesh = run_cli({"mesh", dsm, "--res", "5", "-o", out.path("m.ply"), "--json", "-q"});
  ASSERT_EQ(mesh.exit_code, 0) << mesh.err;
  EXPECT_EQ(json::parse(mesh.out)["faces"], dsmplan::read_mesh(out.path("m.ply")).triangles.size());
  // -q silences simplify's summary as it does plan's; --json still prints what was asked for.
  const auto quiet = run_cli({"simplify", dsm, "--res", "5", "-o", out.path("s.ply"), "-q"});
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.out, "");
  const auto simplify = run_cli({"simplify", dsm, "--res", "5", "-o", out.path("s2.ply"), "-q", "--json"});
  EXPECT_EQ(json::parse(simplify.out)["output"], out.path("s2.ply"));
  const auto render = run_cli({"render", dsm, "--res", "5", "-o", out.path("r.png"), "--of", "PNG", "--json", "-q"});
  ASSERT_EQ(render.exit_code, 0) << render.err;
  EXPECT_GT(json::parse(render.out)["width"].get<int>(), 0);
  testkit::write_file(out.path("p.csv"), "x,y,z\n356320,5699270,160\n356700,5699700,170\n");
  const auto profile = run_cli({"profile", dsm, "--path", out.path("p.csv"), "-o", out.path("p.png"), "--json", "-q"});
  ASSERT_EQ(profile.exit_code, 0) << profile.err;
  const json p = json::parse(profile.out);
  EXPECT_NEAR(p["length_m"].get<double>(), std::hypot(380.0, 430.0), 1e-6);
  EXPECT_EQ(p["ground"], "dsm");
}

// ---- GLB and --of -----------------------------------------------------------------------------

TEST(CliGlb, OfOverridesTheExtensionForMeshAndSimplify) {
  TempDir out;
  const std::string dsm = testkit::data_path(kSample);
  const auto mesh =
      run_cli({"mesh", dsm, "-o", out.path("x.dat"), "--of", "glb", "--res", "5", "--stats", out.path("x.json"), "-q"});
  ASSERT_EQ(mesh.exit_code, 0) << mesh.err;
  EXPECT_EQ(mesh.err, "");
  const std::string bytes = testkit::read_file(out.path("x.dat"));
  ASSERT_GE(bytes.size(), 12u);
  EXPECT_EQ(bytes.substr(0, 4), "glTF");
  const json stats = json::parse(testkit::read_file(out.path("x.json")));
  EXPECT_EQ(stats["file_bytes"], bytes.size());
  EXPECT_EQ(stats["dropped_triangles"], 0);

  // By extension, and --of ply over a .glb name.
  ASSERT_EQ(run_cli({"mesh", dsm, "-o", out.path("y.glb"), "--res", "5", "-q"}).exit_code, 0);
  EXPECT_EQ(testkit::read_file(out.path("y.glb")), bytes);
  ASSERT_EQ(run_cli({"mesh", dsm, "-o", out.path("z.glb"), "--of", "PLY", "--res", "5", "-q"}).exit_code, 0);
  EXPECT_EQ(testkit::read_file(out.path("z.glb")).substr(0, 4), "ply\n");

  const auto simplify = run_cli(
      {"simplify", dsm, "--max-error", "0.4", "-o", out.path("s.out"), "--of", "glb", "--res", "5", "--json", "-q"});
  ASSERT_EQ(simplify.exit_code, 0) << simplify.err;
  EXPECT_EQ(testkit::read_file(out.path("s.out")).substr(0, 4), "glTF");
  EXPECT_EQ(json::parse(simplify.out)["dropped_triangles"], 0);

  // A GLB is not read back: one line naming the file.
  expect_clean_failure(run_cli({"render", dsm, "--mesh", out.path("y.glb"), "-o", out.path("r.png")}), TempDir(),
                       out.path("y.glb"), {"not read"});
}

TEST(CliBadInput, UnknownOfFormat) {
  TempDir out;
  const std::string dsm = testkit::data_path(kSample);
  expect_clean_failure(run_cli({"mesh", dsm, "-o", out.path("x.glb"), "--of", "bogus"}), out, "--of",
                       {"unknown mesh format"});
  expect_clean_failure(run_cli({"simplify", dsm, "-o", out.path("x.glb"), "--of", "bogus"}), out, "--of",
                       {"unknown mesh format"});
}

// =================================================================================================
// Scale (issue 6): a VRT mosaic of pieces gives the very mesh of the whole raster, and so does an
// MPI task farm of two ranks.
// =================================================================================================

namespace {

std::string xml_escaped(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '"')
      out += "&quot;";
    else if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else
      out += c;
  }
  return out;
}

// The NRW crop cut into uneven pieces (GeoTIFFs) and a VRT mosaic that puts them together.
std::string write_mosaic(const TempDir& dir) {
  const dsmplan::Grid& whole = testkit::nrw_crop();
  const std::vector<int> cols{0, 171, 333, whole.width}, rows{0, 260, whole.height};
  char number[64];
  auto g = [&](double v) {
    std::snprintf(number, sizeof number, "%.17g", v);
    return std::string(number);
  };
  std::string vrt = "<VRTDataset rasterXSize=\"" + std::to_string(whole.width) + "\" rasterYSize=\"" +
                    std::to_string(whole.height) + "\">\n  <SRS>" + xml_escaped(whole.crs.wkt) + "</SRS>\n" +
                    "  <GeoTransform>" + g(whole.x0) + ", " + g(whole.cell_x) + ", 0, " + g(whole.y0) + ", 0, " +
                    g(-whole.cell_y) + "</GeoTransform>\n  <VRTRasterBand dataType=\"Float32\" band=\"1\">\n" +
                    "    <NoDataValue>-9999</NoDataValue>\n";
  for (size_t j = 0; j + 1 < rows.size(); ++j) {
    for (size_t i = 0; i + 1 < cols.size(); ++i) {
      const int w = cols[i + 1] - cols[i], h = rows[j + 1] - rows[j];
      dsmplan::Grid piece(w, h, whole.x0 + cols[i] * whole.cell_x, whole.y0 - rows[j] * whole.cell_y, whole.cell_x,
                          whole.cell_y);
      piece.crs = whole.crs;
      for (int r = 0; r < h; ++r)
        for (int c = 0; c < w; ++c) piece.z[piece.index(c, r)] = whole.at(cols[i] + c, rows[j] + r);
      const std::string name = "piece_" + std::to_string(j) + "_" + std::to_string(i) + ".tif";
      dsmplan::write_geotiff(piece, dir.path(name));
      const std::string size = "xSize=\"" + std::to_string(w) + "\" ySize=\"" + std::to_string(h) + "\"";
      vrt += "    <SimpleSource>\n      <SourceFilename relativeToVRT=\"1\">" + name +
             "</SourceFilename>\n      <SourceBand>1</SourceBand>\n      <SrcRect xOff=\"0\" yOff=\"0\" " + size +
             "/>\n      <DstRect xOff=\"" + std::to_string(cols[i]) + "\" yOff=\"" + std::to_string(rows[j]) + "\" " +
             size + "/>\n    </SimpleSource>\n";
    }
  }
  vrt += "  </VRTRasterBand>\n</VRTDataset>\n";
  testkit::write_file(dir.path("mosaic.vrt"), vrt);
  return dir.path("mosaic.vrt");
}

// Every edge in exactly two triangles, once each way, but on the outer rectangle: no crack, no
// T-junction (which would leave the long edge and the two short ones each with one triangle).
size_t edges_not_shared(const std::string& ply, const dsmplan::Grid& grid) {
  const dsmplan::Mesh mesh = dsmplan::read_mesh(ply);
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++uses[{t[k], t[(k + 1) % 3]}];
  size_t bad = 0;
  auto outer = [&](const dsmplan::Vertex& a, const dsmplan::Vertex& b) {
    const double left = grid.center_x(0), right = grid.center_x(grid.width - 1);
    const double top = grid.center_y(0), bottom = grid.center_y(grid.height - 1);
    return (a.x == b.x && (a.x == left || a.x == right)) || (a.y == b.y && (a.y == top || a.y == bottom));
  };
  for (const auto& [edge, count] : uses) {
    const bool twin = uses.count({edge.second, edge.first}) > 0;
    if (count != 1 || (!twin && !outer(mesh.vertices[edge.first], mesh.vertices[edge.second]))) ++bad;
  }
  return bad;
}

}  // namespace

TEST(CliScale, VrtMosaicOfPiecesGivesTheMeshOfTheWholeRaster) {
  TempDir dir;
  const std::string vrt = write_mosaic(dir);
  const std::vector<std::string> options{"--max-error", "0.4", "--conservative", "--tile-size", "37", "--block-tiles",
                                         "2",           "-q",  "--json"};
  auto args = [&](const std::string& input, const std::string& output) {
    std::vector<std::string> a{"simplify", input, "-o", output};
    a.insert(a.end(), options.begin(), options.end());
    return a;
  };
  const auto whole = run_cli(args(testkit::data_path(kSample), dir.path("whole.ply")));
  const auto mosaic = run_cli(args(vrt, dir.path("mosaic.ply")));
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  ASSERT_EQ(mosaic.exit_code, 0) << mosaic.err;
  const std::string a = testkit::read_file(dir.path("whole.ply")), b = testkit::read_file(dir.path("mosaic.ply"));
  // The header's CRS comes from different files (GeoTIFF keys, the VRT's WKT): compare the data.
  const size_t a_body = a.find("end_header\n"), b_body = b.find("end_header\n");
  ASSERT_NE(a_body, std::string::npos);
  ASSERT_NE(b_body, std::string::npos);
  EXPECT_TRUE(a.compare(a_body, std::string::npos, b, b_body, std::string::npos) == 0)
      << "the mosaic's mesh differs from the whole raster's";
  const json w = json::parse(whole.out), m = json::parse(mosaic.out);
  for (const char* key : {"vertices_in", "vertices_out", "faces_out", "max_above_m", "max_below_m", "certified_cells"})
    EXPECT_EQ(w[key], m[key]) << key;
  EXPECT_LE(m["max_above_m"].get<double>(), 0.4);
  EXPECT_EQ(m["max_below_m"].get<double>(), 0.0);
  EXPECT_EQ(m["certified_cells"], 250000);
  EXPECT_EQ(edges_not_shared(dir.path("mosaic.ply"), testkit::nrw_crop()), 0u);
}

// `mpirun -np 2 dsmplan simplify ...`: rank 1 makes the blocks, rank 0 writes them; the file is
// the one a single process writes, byte for byte. (As root OpenMPI wants --allow-run-as-root.)
TEST(CliScale, MpiTaskFarmOfTwoRanksWritesTheSameMesh) {
  TempDir dir;
  const std::string vrt = write_mosaic(dir);
  const std::vector<std::string> simplify{"simplify",    vrt,  "--max-error",   "0.4", "--conservative",
                                          "--tile-size", "37", "--block-tiles", "2",   "-q",
                                          "--json"};
  std::vector<std::string> single = simplify;
  single.insert(single.end(), {"-o", dir.path("single.ply")});
  std::vector<std::string> farm{"--allow-run-as-root", "--oversubscribe", "-np", "2", DSMPLAN_CLI};
  farm.insert(farm.end(), simplify.begin(), simplify.end());
  farm.insert(farm.end(), {"-o", dir.path("farm.ply")});
  // OpenMPI's own allocations outlive MPI_Finalize: under LeakSanitizer (the sanitizer CI run)
  // they would fail the farm's processes. dsmplan's leaks are caught by every other test.
  setenv("ASAN_OPTIONS", "detect_leaks=0", 1);
  const auto one = run_cli(single);
  const auto two = testkit::run_program("mpirun", farm);
  ASSERT_EQ(one.exit_code, 0) << one.err;
  ASSERT_EQ(two.exit_code, 0) << two.err << two.out;
  EXPECT_EQ(testkit::read_file(dir.path("single.ply")), testkit::read_file(dir.path("farm.ply")));
  const json a = json::parse(one.out), b = json::parse(two.out);  // only rank 0 prints
  for (const char* key : {"vertices_out", "faces_out", "max_above_m", "max_below_m", "rms_m", "certified_cells"})
    EXPECT_EQ(a[key], b[key]) << key;
  // --max-error alone, |mesh - DSM| <= E: the workers made conservative blocks of it once, while
  // rank 0 reported a two-sided bound.
  for (std::vector<std::string>* run : {&single, &farm}) {
    run->erase(std::find(run->begin(), run->end(), "--conservative"));
    run->back() += ".two_sided.ply";
  }
  const auto one_sided = run_cli(single);
  const auto farmed = testkit::run_program("mpirun", farm);
  ASSERT_EQ(one_sided.exit_code, 0) << one_sided.err;
  ASSERT_EQ(farmed.exit_code, 0) << farmed.err << farmed.out;
  EXPECT_GT(json::parse(one_sided.out)["max_below_m"].get<double>(), 0.1);
  EXPECT_EQ(testkit::read_file(single.back()), testkit::read_file(farm.back()));
  // A failure on a worker (a piece of the mosaic gone) reaches rank 0's one line, no hang.
  std::filesystem::remove(dir.path("piece_1_2.tif"));
  std::vector<std::string> broken{"--allow-run-as-root",
                                  "--oversubscribe",
                                  "-np",
                                  "2",
                                  DSMPLAN_CLI,
                                  "simplify",
                                  vrt,
                                  "--max-error",
                                  "0.4",
                                  "--block-tiles",
                                  "1",
                                  "-q",
                                  "-o",
                                  dir.path("broken.ply")};
  const auto failed = testkit::run_program("mpirun", broken);
  EXPECT_NE(failed.exit_code, 0);
  EXPECT_NE(failed.err.find("piece_1_2.tif"), std::string::npos) << failed.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path("broken.ply")));
}

// `dsmplan plan` on a DSM mosaic instead of a mesh: planned window by window along a corridor;
// the path passes through the waypoints and keeps clear of the DSM's columns (measured here).
TEST(CliScale, PlanOnAMosaicAlongACorridor) {
  TempDir dir;
  const std::string vrt = write_mosaic(dir);
  const std::string waypoints = testkit::data_path("nrw-dom1/sample_waypoints.csv");
  const auto run = run_cli({"plan", vrt, "--waypoints", waypoints, "-o", dir.path("path.csv"), "--corridor-chunk",
                            "150", "--corridor-margin", "40", "--json", "-q"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json stats = json::parse(run.out);
  EXPECT_GE(stats["corridor_windows"].get<int>(), 4);
  EXPECT_LT(stats["corridor_largest_window_cells"].get<int>(), 250000 / 2);
  EXPECT_GE(stats["min_clearance_m"].get<double>(), 2.0);
  EXPECT_GT(stats["min_clearance_dsm_m"].get<double>(), 2.0 - std::sqrt(0.5) - 1e-9);
  std::istringstream csv(testkit::read_file(dir.path("path.csv")));
  std::string line;
  std::getline(csv, line);  // header
  std::vector<std::array<double, 3>> path;
  while (std::getline(csv, line)) {
    std::array<double, 3> p{};
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf", &p[0], &p[1], &p[2]), 3) << line;
    path.push_back(p);
  }
  ASSERT_GE(path.size(), 3u);
  EXPECT_EQ(path.front(), (std::array<double, 3>{356320, 5699270, 130}));
  EXPECT_EQ(path.back(), (std::array<double, 3>{356780, 5699730, 135}));
  // Nothing else is accepted with a DSM input that only a mesh input has.
  const auto roadmap = run_cli(
      {"plan", vrt, "--waypoints", waypoints, "-o", dir.path("x.csv"), "--roadmap", dir.path("r.roadmap"), "-q"});
  EXPECT_EQ(roadmap.exit_code, 2);  // a usage error
  EXPECT_NE(roadmap.err.find("--roadmap"), std::string::npos) << roadmap.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path("x.csv")));
}

// `dsmplan mesh --stream` on the mosaic: band by band, the XY-3 mesh of the whole raster (the
// same vertices, the same triangles in another order).
TEST(CliScale, MeshStreamedFromAMosaicIsTheWholeMesh) {
  TempDir dir;
  const std::string vrt = write_mosaic(dir);
  const auto whole = run_cli({"mesh", testkit::data_path(kSample), "-o", dir.path("whole.ply"), "-q"});
  const auto streamed =
      run_cli({"mesh", vrt, "--stream", "-o", dir.path("streamed.ply"), "--stats", dir.path("streamed.json"), "-q"});
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  ASSERT_EQ(streamed.exit_code, 0) << streamed.err;
  const dsmplan::Mesh a = dsmplan::read_mesh(dir.path("whole.ply")), b = dsmplan::read_mesh(dir.path("streamed.ply"));
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  EXPECT_EQ(std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(dsmplan::Vertex)), 0);
  EXPECT_EQ(testkit::triangle_set(a.triangles), testkit::triangle_set(b.triangles));
  const json stats = json::parse(testkit::read_file(dir.path("streamed.json")));
  EXPECT_EQ(stats["streamed"], true);
  EXPECT_TRUE(stats["holes"].is_null());
  EXPECT_EQ(stats["faces"], b.triangles.size());
  EXPECT_EQ(edges_not_shared(dir.path("streamed.ply"), testkit::nrw_crop()), 0u);
  // A format that needs the whole mesh in memory is refused with --stream, before anything.
  const auto glb = run_cli({"mesh", vrt, "--stream", "-o", dir.path("x.glb"), "-q"});
  EXPECT_EQ(glb.exit_code, 2);  // a usage error
  EXPECT_NE(glb.err.find("--stream"), std::string::npos) << glb.err;
}

// ---- interrupted runs --------------------------------------------------------------------

namespace {

// Starts `dsmplan mesh --stream` of the 1 km tile into `folder`, waits until its temporary
// output exists, sends `signal`, and returns the exit code (or -1 when no temporary file showed).
int interrupt_streamed_mesh(const std::filesystem::path& folder, int signal) {
  const std::string out = (folder / "tile.ply").string();
  const std::string tile = testkit::data_path("nrw-dom1/dom1_32_356_5699_1_nw_2020.tif");
  const pid_t pid = fork();
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1), ::dup2(null, 2);
    ::execl(DSMPLAN_CLI, DSMPLAN_CLI, "mesh", tile.c_str(), "-o", out.c_str(), "--stream", "-q", nullptr);
    ::_exit(127);
  }
  bool seen = false;
  for (int i = 0; i < 5000 && !seen; ++i) {  // up to 10 s
    for (const auto& e : std::filesystem::directory_iterator(folder))
      seen = seen || e.path().filename().string().find(".partial-") != std::string::npos;
    if (!seen) ::usleep(2000);
  }
  ::kill(pid, signal);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!seen) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace

TEST(CliInterrupted, SigintAndSigtermLeaveNothingBehindAndExit130And143) {
  for (const auto& [signal, code] : {std::pair{SIGINT, 130}, std::pair{SIGTERM, 143}}) {
    testkit::TempDir out;
    const int exit_code = interrupt_streamed_mesh(out.dir(), signal);
    ASSERT_NE(exit_code, -1) << "no temporary output appeared";
    // Finished before the signal came (a fast machine): then the whole output is there.
    if (exit_code == 0) {
      EXPECT_TRUE(std::filesystem::exists(out.dir() / "tile.ply"));
      continue;
    }
    EXPECT_EQ(exit_code, code) << "signal " << signal;
    // Nothing half-written: no temporary file, and an output only if it was renamed into place
    // whole before the signal came (then it reads back).
    for (const std::string& file : out.files()) {
      EXPECT_EQ(file.find(".partial-"), std::string::npos) << "left behind: " << file;
      if (file == "tile.ply") EXPECT_GT(dsmplan::read_mesh((out.dir() / file).string()).triangles.size(), 1000000u);
    }
  }
}

// ---- dsmplan plan --no-fly ---------------------------------------------------------------------
//
// A square zone (from the ground up, no top) put where the path without it runs: the path with
// it keeps --safety from the square, measured every 5 cm on the written path; a waypoint in a
// zone, and a floor under every waypoint, are refused in one line naming the zone and its file.

namespace {

// Distance of (x, y) to the axis-aligned square of half side `h` around `c` (0 inside).
double square_distance(double x, double y, const std::array<double, 2>& c, double h) {
  const double dx = std::max(0.0, std::abs(x - c[0]) - h), dy = std::max(0.0, std::abs(y - c[1]) - h);
  return std::hypot(dx, dy);
}

// A GeoJSON zone file: the square of half side `h` around `c` (EPSG:25832), in WGS 84.
void write_square_zone(const std::string& file, const std::string& name, const std::array<double, 2>& c, double h,
                       const std::string& limits = "") {
  const GdalTransform to_wgs84("EPSG:25832", "EPSG:4326");
  std::ostringstream ring;
  ring.precision(12);
  const double corners[5][2] = {{-h, -h}, {h, -h}, {h, h}, {-h, h}, {-h, -h}};
  for (int k = 0; k < 5; ++k) {
    double x = c[0] + corners[k][0], y = c[1] + corners[k][1];
    EXPECT_TRUE(to_wgs84(x, y));
    ring << (k ? "," : "") << "[" << x << "," << y << "]";
  }
  testkit::write_file(file, R"({"type":"FeatureCollection","features":[{"type":"Feature","properties":{"name":")" +
                                name + "\"" + limits + R"(},"geometry":{"type":"Polygon","coordinates":[[)" +
                                ring.str() + "]]}}]}");
}

// Least distance of the path, sampled every 5 cm, to the square (the zone has no floor or top).
double sampled_square_distance(const std::vector<std::array<double, 3>>& path, const std::array<double, 2>& c,
                               double h) {
  double least = INFINITY;
  for (size_t k = 1; k < path.size(); ++k) {
    const auto &a = path[k - 1], &b = path[k];
    const int n = std::max(1, int(std::ceil(std::hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]) / 0.05)));
    for (int i = 0; i <= n; ++i) {
      const double t = double(i) / n;
      least = std::min(least, square_distance(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), c, h));
    }
  }
  return least;
}

// The fixture with its mesh replaced by a conservative one (the DSM's columns fit it).
struct NoFlyFixture : PlanFixture {
  NoFlyFixture() {
    mesh = in.path("safe.ply");
    const auto made =
        run_cli({"simplify", testkit::data_path(kSample), "--max-error", "0.4", "--conservative", "-o", mesh, "-q"});
    if (made.exit_code != 0) throw std::runtime_error("simplify failed: " + made.err);
  }
  // The path through the corners without zones, over the mesh with the DSM (written to `out`).
  std::vector<std::array<double, 3>> free_path(const TempDir& out) const {
    write_waypoints(corners());
    const auto run = run_cli({"plan", mesh, "--waypoints", waypoints, "--dsm", testkit::data_path(kSample), "-o",
                              out.path("free.csv"), "-q"});
    if (run.exit_code != 0) throw std::runtime_error("the free path failed: " + run.err);
    return read_path_csv(out.path("free.csv"));
  }
};

}  // namespace

TEST(CliNoFly, ZoneOnThePathIsFlownAroundOnAMeshAndAlongACorridor) {
  NoFlyFixture f;
  TempDir out;
  const std::string dsm = testkit::data_path(kSample);
  const auto free = f.free_path(out);
  // The square on the free path's point a quarter along, away from the waypoints: the path
  // without the zone runs through it.
  double length = 0;
  for (size_t k = 1; k < free.size(); ++k)
    length += std::hypot(free[k][0] - free[k - 1][0], free[k][1] - free[k - 1][1]);
  std::array<double, 2> centre{};
  double walked = 0;
  for (size_t k = 1; k < free.size(); ++k) {
    const double step = std::hypot(free[k][0] - free[k - 1][0], free[k][1] - free[k - 1][1]);
    if (walked + step >= length / 4) {
      const double t = (length / 4 - walked) / step;
      centre = {free[k - 1][0] + t * (free[k][0] - free[k - 1][0]), free[k - 1][1] + t * (free[k][1] - free[k - 1][1])};
      break;
    }
    walked += step;
  }
  const double half = 15;
  for (const auto& w : f.corners()) ASSERT_GT(square_distance(w[0], w[1], centre, half), 20);
  ASSERT_EQ(sampled_square_distance(free, centre, half), 0);
  const std::string zones = f.in.path("zones.geojson");
  write_square_zone(zones, "test block", centre, half);
  for (const std::string& input : {f.mesh, dsm}) {  // a mesh, and a DSM planned along a corridor
    std::vector<std::string> args{"plan", input, "--waypoints",          f.waypoints, "--no-fly",
                                  zones,  "-o",  out.path("around.csv"), "--stats",   out.path("around.json"),
                                  "-q"};
    if (input == f.mesh) args.insert(args.end(), {"--dsm", dsm});
    const auto run = run_cli(args);
    ASSERT_EQ(run.exit_code, 0) << input << ": " << run.err;
    const double sampled = sampled_square_distance(read_path_csv(out.path("around.csv")), centre, half);
    EXPECT_GE(sampled, 2 - 0.01) << input;
    const json stats = json::parse(testkit::read_file(out.path("around.json")));
    ASSERT_EQ(stats["no_fly_zones"].size(), 1u) << input;
    const double reported = stats["no_fly_zones"][0]["min_distance_m"];
    EXPECT_TRUE(stats["no_fly_zones"][0]["blocks"]);
    EXPECT_GE(reported, 2 - 0.01) << input;
    EXPECT_LE(reported, sampled + 0.05) << input;  // a lower bound of the true distance
  }
}

TEST(CliNoFly, WaypointInAZoneAndAFloorUnderEveryWaypointAreRefused) {
  NoFlyFixture f;
  const auto waypoints = f.corners();
  f.write_waypoints(waypoints);
  const std::string dsm = testkit::data_path(kSample), zones = f.in.path("zones.geojson");
  write_square_zone(zones, "around waypoint 2", {waypoints[1][0], waypoints[1][1]}, 5);
  TempDir out;
  auto run = run_cli(
      {"plan", f.mesh, "--waypoints", f.waypoints, "--dsm", dsm, "--no-fly", zones, "-o", out.path("p.csv"), "-q"});
  expect_clean_failure(run, out, f.waypoints, {"waypoint 2: inside no-fly zone 'around waypoint 2' of " + zones});
  // A zone over the whole crop from 5 m above the ground up: every waypoint stands in it.
  write_square_zone(zones, "everywhere", {356550, 5699500}, 400, R"(,"lower":5,"lower_ref":"AGL")");
  run = run_cli(
      {"plan", f.mesh, "--waypoints", f.waypoints, "--dsm", dsm, "--no-fly", zones, "-o", out.path("p.csv"), "-q"});
  expect_clean_failure(run, out, f.waypoints, {"waypoint 1: inside no-fly zone 'everywhere'"});
  // Not blocking when its restriction is not one of --no-fly-blocking: planned through.
  run = run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "--dsm", dsm, "--no-fly", zones, "--no-fly-blocking",
                 "NONE", "-o", out.path("p.csv"), "-q"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  // A restriction no zone can have would unblock them all: a typo, a case, an empty value, or a
  // list that is empty is refused, naming the nearest restriction, before anything is read.
  for (const auto& [value, said] : std::vector<std::pair<std::string, std::string>>{
           {"PROHIBTED", "(did you mean PROHIBITED?)"},
           {"prohibited", "(did you mean PROHIBITED?)"},
           {"", "got ''"},
           {"NONE,PROHIBITED", "NONE stands alone"},
           {"REQ_AUTHORISATION,CONDITINAL", "(did you mean CONDITIONAL?)"}}) {
    run = run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "--dsm", dsm, "--no-fly", zones, "--no-fly-blocking",
                   value, "-o", out.path("typo.csv"), "-q"});
    EXPECT_EQ(run.exit_code, 2) << value << ": " << run.err;
    EXPECT_NE(run.err.find("--no-fly-blocking: "), std::string::npos) << run.err;
    EXPECT_NE(run.err.find(said), std::string::npos) << value << ": " << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_FALSE(std::filesystem::exists(out.path("typo.csv")));
  }
}

// ---- dsmplan plan --routes ---------------------------------------------------------------------
//
// Many routes over one roadmap: each route's path is, byte for byte, the path `dsmplan plan`
// writes for that route alone with the same roadmap kept (--roadmap), and a route without a path
// gets the one-line reason the single run gives, without stopping the others (exit 4).

TEST(CliRoutes, EachRouteIsTheSingleRunsPathAndAFailedRouteStopsNoOther) {
  NoFlyFixture f;
  const auto corners = f.corners();
  std::ostringstream routes;
  routes.precision(17);
  routes << "route,x,y,z\n";
  const std::vector<std::pair<std::string, std::vector<size_t>>> legs{{"a", {0, 1}}, {"b", {1, 2}}, {"c", {2, 0, 1}}};
  for (const auto& [id, which] : legs)
    for (const size_t k : which)
      routes << id << "," << corners[k][0] << "," << corners[k][1] << "," << corners[k][2] << "\n";
  routes << "under," << corners[0][0] << "," << corners[0][1] << ",0\n"
         << "under," << corners[1][0] << "," << corners[1][1] << "," << corners[1][2] << "\n";
  const std::string routes_file = f.in.path("routes.csv"), dsm = testkit::data_path(kSample);
  testkit::write_file(routes_file, routes.str());
  TempDir out;
  const std::string folder = out.path("paths") + "/", roadmap = f.in.path("kept.roadmap");
  const auto run =
      run_cli({"plan", f.mesh, "--routes", routes_file, "--dsm", dsm, "--roadmap", roadmap, "-o", folder, "-q"});
  EXPECT_EQ(run.exit_code, 4) << run.err;
  EXPECT_NE(run.out.find("no path: under: waypoint 1: "), std::string::npos) << run.out;
  for (const auto& [id, which] : legs) {
    std::vector<std::array<double, 3>> waypoints;
    for (const size_t k : which) waypoints.push_back(corners[k]);
    f.write_waypoints(waypoints);
    const std::string alone = out.path(id + "_alone.csv");
    const auto single =
        run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "--dsm", dsm, "--roadmap", roadmap, "-o", alone, "-q"});
    ASSERT_EQ(single.exit_code, 0) << single.err;
    EXPECT_EQ(testkit::read_file(folder + id + ".csv"), testkit::read_file(alone)) << id;
  }
  f.write_waypoints({{corners[0][0], corners[0][1], 0}, corners[1]});
  const auto refused =
      run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "--dsm", dsm, "-o", out.path("under.csv"), "-q"});
  ASSERT_EQ(refused.exit_code, 1);
  const json listed = json::parse(testkit::read_file(folder + "routes.json"));
  ASSERT_EQ(listed.size(), 4u);
  EXPECT_FALSE(listed[3]["solved"]);
  const std::string reason = listed[3]["reason"];
  EXPECT_NE(refused.err.find(reason), std::string::npos) << refused.err << " vs " << reason;
  EXPECT_FALSE(std::filesystem::exists(folder + "under.csv"));

  // Missions too, in a folder: each route's the single run's mission, byte for byte.
  // One depot for every route, clear of the walls.
  const std::vector<std::string> vertical{"--vertical-crs", "EPSG:7837",      "--allow-approximate-vertical",
                                          "--home",         "356781,5699730", "-q"};
  std::vector<std::string> args{"plan",      f.mesh,  "--routes", routes_file, "--dsm", dsm,
                                "--roadmap", roadmap, "--of",     "waypoints", "-o",    out.path("missions") + "/"};
  args.insert(args.end(), vertical.begin(), vertical.end());
  EXPECT_EQ(run_cli(args).exit_code, 4);
  for (const auto& [id, which] : legs) {
    std::vector<std::array<double, 3>> waypoints;
    for (const size_t k : which) waypoints.push_back(corners[k]);
    f.write_waypoints(waypoints);
    const std::string mission = out.path(id + ".waypoints");
    args = {"plan", f.mesh, "--waypoints", f.waypoints, "--dsm", dsm, "--roadmap", roadmap, "-o", mission};
    args.insert(args.end(), vertical.begin(), vertical.end());
    const auto alone = run_cli(args);
    ASSERT_EQ(alone.exit_code, 0) << alone.err;
    EXPECT_EQ(testkit::read_file(out.path("missions/" + id + ".waypoints")), testkit::read_file(mission)) << id;
  }

  // As one GeoJSON FeatureCollection: a feature a route, the failed one with a null geometry.
  const auto collected =
      run_cli({"plan", f.mesh, "--routes", routes_file, "--dsm", dsm, "-o", out.path("routes.geojson"),
               "--vertical-crs", "EPSG:7837", "--allow-approximate-vertical", "-q"});
  EXPECT_EQ(collected.exit_code, 4) << collected.err;
  const json doc = json::parse(testkit::read_file(out.path("routes.geojson")));
  ASSERT_EQ(doc["features"].size(), 4u);
  EXPECT_EQ(doc["features"][0]["properties"]["id"], "a");
  EXPECT_EQ(doc["features"][0]["geometry"]["type"], "LineString");
  EXPECT_TRUE(doc["features"][3]["geometry"].is_null());
  // --routes with --waypoints, or over a raster, is refused before anything is read.
  const auto both = run_cli({"plan", f.mesh, "--routes", routes_file, "--waypoints", f.waypoints, "-o", folder, "-q"});
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("--routes"), std::string::npos) << both.err;
}

namespace {

// Every file under `folder`, hidden ones too, by its path inside it, with its bytes (routes.json
// without its timings, which differ from run to run).
std::map<std::string, std::string> folder_contents(const std::filesystem::path& folder) {
  std::map<std::string, std::string> files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(folder)) {
    const std::string name = std::filesystem::relative(e.path(), folder).string();
    if (e.is_directory()) {
      files[name + "/"] = "";
      continue;
    }
    files[name] = testkit::read_file(e.path());
    if (name != "routes.json") continue;
    json listed = json::parse(files[name]);
    for (json& route : listed) route.erase("seconds_query"), route.erase("seconds_smooth");
    files[name] = listed.dump();
  }
  return files;
}

}  // namespace

// A --routes run into a folder that holds an earlier run's outputs, stopped by SIGINT at times
// spread over its whole run, leaves the earlier outputs or its own, never a mix of the two (nor a
// file of a route now without a path, nor a temporary file).
TEST(CliRoutes, AnInterruptedRunLeavesTheOldOutputsOrTheNewNeverAMix) {
  NoFlyFixture f;
  const auto c = f.corners();
  const auto routes_of = [&](size_t from, size_t to, bool gone_solved) {
    std::ostringstream rows;
    rows.precision(17);
    rows << "route,x,y,z\n";
    for (int r = 0; r < 300; ++r)
      for (const size_t k : {from, to}) rows << "r" << r << "," << c[k][0] << "," << c[k][1] << "," << c[k][2] << "\n";
    rows << "gone," << c[0][0] << "," << c[0][1] << "," << (gone_solved ? c[0][2] : 0.0) << "\n"
         << "gone," << c[1][0] << "," << c[1][1] << "," << c[1][2] << "\n";
    return rows.str();
  };
  const std::string old_routes = f.in.path("old.csv"), new_routes = f.in.path("new.csv");
  testkit::write_file(old_routes, routes_of(0, 1, true));
  testkit::write_file(new_routes, routes_of(1, 2, false));
  const std::string dsm = testkit::data_path(kSample), roadmap = f.in.path("kept.roadmap");
  const auto args_of = [&](const std::string& routes, const std::filesystem::path& folder) {
    return std::vector<std::string>{
        "plan", f.mesh, "--routes", routes, "--dsm", dsm, "--roadmap", roadmap, "-o", folder.string() + "/", "-q"};
  };
  TempDir out;
  ASSERT_EQ(run_cli(args_of(old_routes, out.dir() / "old")).exit_code, 0);
  const auto started = std::chrono::steady_clock::now();
  std::vector<std::string> timed = args_of(new_routes, out.dir() / "new");
  timed.insert(timed.end(), {"--stats", out.path("new.json")});
  ASSERT_EQ(run_cli(timed).exit_code, 4);  // "gone" has no path
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const double writing = json::parse(testkit::read_file(out.path("new.json")))["seconds_write"];
  const auto old_files = folder_contents(out.dir() / "old"), new_files = folder_contents(out.dir() / "new");
  ASSERT_TRUE(old_files.count("gone.csv"));
  ASSERT_FALSE(new_files.count("gone.csv"));
  ASSERT_NE(old_files.at("r0.csv"), new_files.at("r0.csv"));
  int olds = 0, news = 0;
  // Most stops where the outputs are written: from a little before to a little after.
  for (int k = 1; k <= 12; ++k) {
    const std::filesystem::path folder = out.dir() / ("run" + std::to_string(k));
    std::filesystem::copy(out.dir() / "old", folder);
    std::vector<std::string> args = args_of(new_routes, folder);
    std::vector<char*> argv{const_cast<char*>(DSMPLAN_CLI)};
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const pid_t pid = fork();
    if (pid == 0) {
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, 1), ::dup2(null, 2);
      ::execv(DSMPLAN_CLI, argv.data());
      ::_exit(127);
    }
    const double from = std::max(0.0, seconds - 2 * writing), to = seconds * 1.1;
    ::usleep(static_cast<useconds_t>((from + (to - from) * k / 12) * 1e6));
    ::kill(pid, SIGINT);
    int status = 0;
    ::waitpid(pid, &status, 0);
    const auto left = folder_contents(folder);
    EXPECT_TRUE(left == old_files || left == new_files) << "a mix after " << k << "/12 of the run";
    olds += left == old_files, news += left == new_files;
  }
  std::cout << "interrupted runs of " << seconds << " s (" << writing << " s writing): " << olds
            << " left the old outputs, " << news << " the new\n";
}

// A route without a path says why for a program too (issue 52, point 5): a code, the waypoint or
// the leg as the route numbers them, and the nearest valid point, which a single run accepts in
// the refused waypoint's place (the oracle); a route past --route-budget fails on its own.
TEST(CliRoutes, AFailedRouteSaysItsCodeLegWaypointAndNearestValidPoint) {
  MissionFixture f;
  TempDir out;
  const auto low = read_waypoints_csv_file(f.low);
  ASSERT_GE(low.size(), 2u);
  const std::string dsm = testkit::data_path(kSample);
  std::ostringstream rows;
  rows.precision(17);
  const auto row = [&](const std::string& id, double x, double y, double z) {
    rows << id << "," << x << "," << y << "," << z << "\n";
  };
  rows << "route,x,y,z\n";
  row("ok", low[0][0], low[0][1], low[0][2]);
  row("ok", low[1][0], low[1][1], low[1][2]);
  row("under", low[0][0], low[0][1], low[0][2]);
  const double below = f.cell(low[1][0], low[1][1]) - 1;  // a metre under the DSM's surface
  row("under", low[1][0], low[1][1], below);
  // Two street-level regions no path joins under a 10 m ceiling (CliPlan.FreespaceKeeps...).
  row("apart", 356681.5, 5699302.5, 127.44);
  row("apart", 356570.5, 5699579.5, 127.15);
  const std::string routes = f.in.path("failing.csv");
  testkit::write_file(routes, rows.str());
  const std::vector<std::string> common{"plan",      f.bounded, "--routes",  routes,      "--dsm", dsm,
                                        "--max-agl", "10",      "--planner", "freespace", "-q"};
  const auto with = [&](std::vector<std::string> more) {
    std::vector<std::string> args = common;
    args.insert(args.end(), more.begin(), more.end());
    return run_cli(args);
  };
  const std::string folder = out.path("paths") + "/";
  const auto run = with({"-o", folder, "--stats", out.path("stats.json")});
  ASSERT_EQ(run.exit_code, 4) << run.err;
  const json listed = json::parse(testkit::read_file(folder + "routes.json"));
  ASSERT_EQ(listed.size(), 3u);
  EXPECT_TRUE(listed[0]["solved"]);
  EXPECT_FALSE(listed[0].contains("failure"));
  const json& under = listed[1]["failure"];
  EXPECT_EQ(under["code"], "waypoint_refused") << under.dump();
  EXPECT_EQ(under["waypoint"], 2) << under.dump();
  EXPECT_TRUE(under["leg"].is_null());
  EXPECT_EQ(under["message"], listed[1]["reason"]);
  ASSERT_EQ(under["nearest_valid_point"].size(), 3u) << under.dump();
  const std::array<double, 3> nearest{under["nearest_valid_point"][0], under["nearest_valid_point"][1],
                                      under["nearest_valid_point"][2]};
  EXPECT_LE(std::hypot(nearest[0] - low[1][0], nearest[1] - low[1][1], nearest[2] - below), 50);
  // The nearest valid point in the refused one's place: the single run refuses no waypoint (a
  // leg without a path under this ceiling may still be refused, but not the point).
  f.write_waypoints({low[0], nearest});
  std::vector<std::string> single{
      "plan",      f.bounded, "--waypoints", f.waypoints, "--dsm", dsm, "-o", out.path("single.csv"),
      "--max-agl", "10",      "--planner",   "freespace", "-q"};
  const auto alone = run_cli(single);
  EXPECT_EQ(alone.err.find("waypoint 2:"), std::string::npos) << alone.err;
  const json& apart = listed[2]["failure"];
  EXPECT_EQ(apart["code"], "no_path") << apart.dump();
  EXPECT_EQ(apart["leg"], json::array({1, 2})) << apart.dump();
  EXPECT_TRUE(apart["waypoint"].is_null());
  EXPECT_TRUE(apart["nearest_valid_point"].is_null());
  // --stats lists the same failures with their ids.
  const json stats = json::parse(testkit::read_file(out.path("stats.json")));
  ASSERT_EQ(stats["failures"].size(), 2u) << stats.dump();
  EXPECT_EQ(stats["failures"][0]["id"], "under");
  EXPECT_EQ(stats["failures"][0]["code"], "waypoint_refused");
  EXPECT_EQ(stats["failures"][1]["id"], "apart");
  EXPECT_EQ(stats["failures"][1]["leg"], apart["leg"]);

  // In the FeatureCollection the nearest valid point is in WGS 84, as its paths are.
  const auto collected = with({"-o", out.path("routes.geojson"), "--vertical-crs", "EPSG:5773"});
  ASSERT_EQ(collected.exit_code, 4) << collected.err;
  const json doc = json::parse(testkit::read_file(out.path("routes.geojson")));
  const json& lonlat = doc["features"][1]["properties"]["failure"]["nearest_valid_point"];
  ASSERT_EQ(lonlat.size(), 3u) << doc["features"][1].dump();
  double lon = nearest[0], lat = nearest[1];
  ASSERT_TRUE(GdalTransform("EPSG:25832", "EPSG:4326")(lon, lat));
  EXPECT_NEAR(lonlat[0].get<double>(), lon, 1e-7);
  EXPECT_NEAR(lonlat[1].get<double>(), lat, 1e-7);

  // A budget no route can keep: each fails with its own code, none stops the run.
  const auto hurried = with({"-o", out.path("hurried") + "/", "--route-budget", "0.000001"});
  ASSERT_EQ(hurried.exit_code, 4) << hurried.err;
  const json late = json::parse(testkit::read_file(out.path("hurried/routes.json")));
  ASSERT_EQ(late.size(), 3u);
  for (const json& route : late) {
    EXPECT_EQ(route["failure"]["code"], "route_budget") << route.dump();
    EXPECT_NE(route["reason"].get<std::string>().find("--route-budget"), std::string::npos) << route.dump();
  }
  for (const std::string bad : {"-1", "nan", "4000"}) {
    const auto refused = with({"-o", out.path("bad") + "/", "--route-budget", bad});
    EXPECT_EQ(refused.exit_code, 2) << bad << ": " << refused.err;
    EXPECT_NE(refused.err.find("--route-budget"), std::string::npos) << refused.err;
  }
  single.insert(single.end(), {"--route-budget", "5"});
  EXPECT_EQ(run_cli(single).exit_code, 2);

  // A home against a wall: every route's mission refused with home_refused and the nearest clear
  // spot on the ground, where a single run takes off.
  const std::array<double, 2> wall = f.home_against_wall();
  ASSERT_FALSE(std::isnan(wall[0]));
  char at[64];
  std::snprintf(at, sizeof at, "%.2f,%.2f", wall[0], wall[1]);
  const auto missions = run_cli({"plan", f.bounded, "--routes", routes, "--dsm", dsm, "--max-agl", "30", "--spacing",
                                 "10", "--vertical-crs", "EPSG:5773", "--of", "waypoints", "--home", at, "-o",
                                 out.path("missions") + "/", "-q"});
  ASSERT_EQ(missions.exit_code, 4) << missions.err;
  const json homes = json::parse(testkit::read_file(out.path("missions/routes.json")));
  const json& home = homes[0]["failure"];
  EXPECT_EQ(home["code"], "home_refused") << home.dump();
  ASSERT_EQ(home["nearest_valid_point"].size(), 3u) << home.dump();
  const double hx = home["nearest_valid_point"][0], hy = home["nearest_valid_point"][1];
  EXPECT_LE(std::hypot(hx - wall[0], hy - wall[1]), 10) << home.dump();
  char moved[64];
  std::snprintf(moved, sizeof moved, "%.2f,%.2f", hx, hy);
  EXPECT_EQ(f.plan(out.path("moved.waypoints"), {"--home", moved}).exit_code, 0);
}

// ---- zones seen: KML, render and profile -----------------------------------------------------

namespace {

const std::string kNrwZones = std::string(DSMPLAN_TESTS_DIR) + "/data/airspace/nrw_zones_ed269.json";

// The text of every <altitudeMode> in one Placemark's XML, by CPL's own XML parser.
std::vector<std::string> altitude_modes(const CPLXMLNode* node) {
  std::vector<std::string> modes;
  for (const CPLXMLNode* child = node ? node->psChild : nullptr; child; child = child->psNext) {
    if (child->eType != CXT_Element) continue;
    if (std::string(child->pszValue) == "altitudeMode") modes.push_back(CPLGetXMLValue(child, "", ""));
    for (const std::string& m : altitude_modes(child)) modes.push_back(m);
  }
  return modes;
}

}  // namespace

// Zone names and ids from a corpus of hostile strings (terminal escapes, BEL, markup, a NUL, a
// right-to-left override, line breaks, 5,000 bytes, CDATA's end): every output stays well-formed
// for the program that reads it (libkml for the KML, a JSON parser for --stats, the PNGs), and no
// control character reaches the terminal raw (shown as "\x1b").
TEST(CliNoFly, HostileZoneNamesLeaveEveryOutputWellFormed) {
  NoFlyFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  const std::vector<std::string> corpus = {"\x1b[31mred\x1b[0m",
                                           "bell\a",
                                           "<zone & \"name\" 'x'>",
                                           "]]></name><x>",
                                           std::string("nul\0byte", 8),
                                           "\u202eright to left",
                                           "tab\tand\nnewline\r",
                                           std::string(5000, 'a'),
                                           "ünïcödé 日本",
                                           "\\x1b as text"};
  const GdalTransform to_wgs84("EPSG:25832", "EPSG:4326");
  json features = json::array();
  for (size_t i = 0; i < corpus.size(); ++i) {
    const double cx = 356420 + 25.0 * double(i), cy = 5699420, h = 5;
    json ring = json::array();
    for (const auto& [dx, dy] : std::vector<std::pair<double, double>>{{-h, -h}, {h, -h}, {h, h}, {-h, h}, {-h, -h}}) {
      double x = cx + dx, y = cy + dy;
      EXPECT_TRUE(to_wgs84(x, y));
      ring.push_back({x, y});
    }
    features.push_back({{"type", "Feature"},
                        {"id", corpus[i]},
                        {"properties", {{"name", corpus[i]}, {"restriction", "CONDITIONAL"}}},
                        {"geometry", {{"type", "Polygon"}, {"coordinates", {ring}}}}});
  }
  const std::string zones = f.in.path("hostile_zones.geojson");
  testkit::write_file(zones, json{{"type", "FeatureCollection"}, {"features", features}}.dump());
  const std::string kml = out.path("p.kml"), stats = out.path("s.json");
  const auto run = run_cli({"plan",
                            f.mesh,
                            "--waypoints",
                            f.waypoints,
                            "--no-fly",
                            zones,
                            "--vertical-crs",
                            "EPSG:7837",
                            "--allow-approximate-vertical",
                            "-o",
                            kml,
                            "-o",
                            out.path("p.csv"),
                            "--stats",
                            stats,
                            "--dsm",
                            testkit::data_path(kSample),
                            "--render",
                            out.path("r.png"),
                            "--profile",
                            out.path("s.png")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const std::string* text : {&run.out, &run.err})
    for (const char c : *text)
      EXPECT_FALSE((static_cast<unsigned char>(c) < 0x20 && c != '\n' && c != '\r') || c == 0x7f)
          << "a control character " << int(c) << " on the terminal: " << *text;
  EXPECT_NE(run.out.find("nearest no-fly zone: zone '"), std::string::npos) << run.out;
  // --stats: JSON that parses, each zone's name as the file gave it (JSON escapes what it must).
  const json report = json::parse(testkit::read_file(stats));
  std::set<std::string> named;
  for (const auto& zone : report["no_fly_zones"]) named.insert(zone["name"].get<std::string>());
  for (const std::string& name : corpus) EXPECT_TRUE(named.count(name)) << name;
  // The KML: libkml reads it, every zone a placemark named visibly.
  GDALAllRegister();
  const char* libkml[] = {"LIBKML", nullptr};
  GDALDatasetH ds = GDALOpenEx(kml.c_str(), GDAL_OF_VECTOR, libkml, nullptr, nullptr);
  ASSERT_TRUE(ds) << "libkml cannot read the KML";
  std::set<std::string> placemarks;
  for (int l = 0; l < GDALDatasetGetLayerCount(ds); ++l) {
    OGRLayerH layer = GDALDatasetGetLayer(ds, l);
    while (OGRFeatureH feature = OGR_L_GetNextFeature(layer)) {
      placemarks.insert(OGR_F_GetFieldAsString(feature, OGR_F_GetFieldIndex(feature, "Name")));
      OGR_F_Destroy(feature);
    }
  }
  GDALClose(ds);
  EXPECT_TRUE(placemarks.count("\\x1b[31mred\\x1b[0m"));
  EXPECT_TRUE(placemarks.count("<zone & \"name\" 'x'>"));
  EXPECT_TRUE(placemarks.count("]]></name><x>"));
  EXPECT_TRUE(placemarks.count("nul\\x00byte"));
  EXPECT_TRUE(placemarks.count(corpus[8]));                              // UTF-8 kept as it is
  EXPECT_EQ(placemarks.size(), corpus.size() + 1 + f.corners().size());  // the zones, the path, the waypoints
}

TEST(CliNoFly, KmlCarriesEveryZoneWhereTheFileDrawsIt) {
  NoFlyFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  const std::string kml = out.path("p.kml");
  // No zone blocks (no restriction is named so): the plan runs whatever the zones, and the KML
  // carries the six hand-made shapes: a hole, a circle, an AGL floor, an AMSL band, feet.
  const auto run = run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "--no-fly", kNrwZones, "--no-fly-blocking",
                            "NONE", "--vertical-crs", "EPSG:7837", "--allow-approximate-vertical", "-o", kml, "-q"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json file = json::parse(testkit::read_file(kNrwZones));
  // libkml's own parser reads the KML: every zone a feature with its polygons.
  GDALAllRegister();
  const char* libkml[] = {"LIBKML", nullptr};
  GDALDatasetH ds = GDALOpenEx(kml.c_str(), GDAL_OF_VECTOR, libkml, nullptr, nullptr);
  ASSERT_TRUE(ds) << "libkml cannot read the KML";
  std::map<std::string, OGRGeometryH> zones;
  for (int l = 0; l < GDALDatasetGetLayerCount(ds); ++l) {
    OGRLayerH layer = GDALDatasetGetLayer(ds, l);
    while (OGRFeatureH feature = OGR_L_GetNextFeature(layer)) {
      const std::string name = OGR_F_GetFieldAsString(feature, OGR_F_GetFieldIndex(feature, "Name"));
      if (OGRGeometryH g = OGR_F_GetGeometryRef(feature); g && name != "path" && name.rfind("waypoint", 0) != 0)
        zones[name] = OGR_G_Clone(g);
      OGR_F_Destroy(feature);
    }
  }
  GDALClose(ds);
  ASSERT_EQ(zones.size(), file["features"].size());
  const GdalTransform to_utm("EPSG:4326", "EPSG:25832");
  for (const auto& feature : file["features"]) {
    const std::string name = feature["name"];
    ASSERT_TRUE(zones.count(name)) << name;
    OGRGeometryH all = zones[name];
    ASSERT_GT(OGR_G_GetGeometryCount(all), 0) << name;
    // The ceiling, or the floor without one (a MultiGeometry of one face may come back a Polygon).
    OGRGeometryH top = wkbFlatten(OGR_G_GetGeometryType(all)) == wkbPolygon ? all : OGR_G_GetGeometryRef(all, 0);
    ASSERT_EQ(wkbFlatten(OGR_G_GetGeometryType(top)), wkbPolygon) << name;
    const auto& g = feature["geometry"][0];
    const auto& shape = g["horizontalProjection"];
    const double unit = g["uomDimensions"] == "FT" ? 0.3048 : 1.0;
    OGRGeometryH outer = OGR_G_GetGeometryRef(top, 0);
    if (shape["type"] == "Circle") {  // every corner R to R + 5 cm from the centre, in UTM metres
      double cx = shape["center"][0], cy = shape["center"][1];
      ASSERT_TRUE(to_utm(cx, cy));
      for (int k = 0; k < OGR_G_GetPointCount(outer); ++k) {
        double x = OGR_G_GetX(outer, k), y = OGR_G_GetY(outer, k);
        ASSERT_TRUE(to_utm(x, y));
        const double r = shape["radius"].get<double>() * unit;
        EXPECT_NEAR(std::hypot(x - cx, y - cy), r + 0.025, 0.05 + r * 5e-4) << name << " corner " << k;
      }
    } else {  // the file's own corners, and as many holes
      const auto& rings = shape["coordinates"];
      ASSERT_EQ(OGR_G_GetGeometryCount(top), static_cast<int>(rings.size())) << name;
      for (size_t r = 0; r < rings.size(); ++r) {
        OGRGeometryH ring = OGR_G_GetGeometryRef(top, static_cast<int>(r));
        ASSERT_EQ(OGR_G_GetPointCount(ring), static_cast<int>(rings[r].size())) << name;
        for (size_t k = 0; k < rings[r].size(); ++k) {
          EXPECT_NEAR(OGR_G_GetX(ring, static_cast<int>(k)), rings[r][k][0].get<double>(), 2e-9) << name;
          EXPECT_NEAR(OGR_G_GetY(ring, static_cast<int>(k)), rings[r][k][1].get<double>(), 2e-9) << name;
        }
      }
    }
    // The top face's height: the ceiling in its unit, AGL relative to the ground, AMSL absolute.
    const bool ceiling = g.contains("upperLimit");
    const double expected = (ceiling ? g["upperLimit"] : g["lowerLimit"]).get<double>() * unit;
    EXPECT_NEAR(OGR_G_GetZ(outer, 0), expected, 0.01) << name;
    for (auto& [n, geometry] : zones)
      if (n == name) OGR_G_DestroyGeometry(geometry), geometry = nullptr;
  }
  // Altitude modes, as the limits' references say (CPL's XML parser).
  std::unique_ptr<CPLXMLNode, decltype(&CPLDestroyXMLNode)> tree(CPLParseXMLString(testkit::read_file(kml).c_str()),
                                                                 &CPLDestroyXMLNode);
  ASSERT_TRUE(tree);
  const CPLXMLNode* document = CPLGetXMLNode(tree.get(), "=kml.Document");
  ASSERT_TRUE(document);
  std::map<std::string, std::vector<std::string>> modes;
  for (const CPLXMLNode* p = document->psChild; p; p = p->psNext)
    if (p->eType == CXT_Element && std::string(p->pszValue) == "Placemark")
      modes[CPLGetXMLValue(p, "name", "")] = altitude_modes(CPLGetXMLNode(p, "MultiGeometry"));
  EXPECT_EQ(modes["East band"].front(), "absolute");
  EXPECT_EQ(modes["Centre circle"], std::vector<std::string>{"relativeToGround"});  // one face, extruded
  EXPECT_EQ(modes["Courtyard ring"], std::vector<std::string>{"relativeToGround"});
  // The AGL floor above the roofs: ceiling, floor and a wall per edge, all relative to the ground.
  EXPECT_GT(modes["High corridor above the roofs"].size(), 4u);
  for (const std::string& m : modes["High corridor above the roofs"]) EXPECT_EQ(m, "relativeToGround");
}

TEST(CliNoFly, RenderAndProfileDrawTheZonesAndRefuseABadFile) {
  NoFlyFixture f;
  f.write_waypoints(f.corners());
  TempDir out;
  const std::string dsm = testkit::data_path(kSample), path = out.path("p.csv");
  ASSERT_EQ(run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "-o", path, "-q"}).exit_code, 0);
  const std::vector<std::string> zones{"--no-fly", kNrwZones, "--vertical-crs", "EPSG:7837",
                                       "--allow-approximate-vertical"};
  for (const std::string command : {"render", "profile"}) {
    std::vector<std::string> args{command, dsm, "--path", path, "-q"};
    if (command == "render") args.insert(args.end(), {"--zoom", "1"});
    auto plain = args, zoned = args;
    plain.insert(plain.end(), {"-o", out.path(command + "_plain.png")});
    zoned.insert(zoned.end(), {"-o", out.path(command + "_zones.png")});
    zoned.insert(zoned.end(), zones.begin(), zones.end());
    ASSERT_EQ(run_cli(plain).exit_code, 0) << command;
    const auto run = run_cli(zoned);
    ASSERT_EQ(run.exit_code, 0) << command << ": " << run.err;
    EXPECT_NE(testkit::read_file(out.path(command + "_plain.png")),
              testkit::read_file(out.path(command + "_zones.png")))
        << command << " drew no zone";
  }
  // A bad zones file: one line naming it, nothing written.
  const std::string bad = out.path("bad.json");
  testkit::write_file(bad, "{\"features\": 3}");
  const auto run = run_cli({"render", dsm, "--no-fly", bad, "-o", out.path("bad.png"), "-q"});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find(bad), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(out.path("bad.png")));
}

// One plan run draws its own pictures (issue 32, point 5): the mission as flown, home legs
// included, over the DSM and the DTM with the waypoints and the zones, the same bytes as `render`
// and `profile` draw of the written CSV with the window, zoom and title the run reports. A picture
// needs a DSM, and a refused one leaves nothing behind.
TEST(CliPlan, OneRunDrawsTheMissionAsFlownAsRenderAndProfileDrawItsCsv) {
  MissionFixture f;
  TempDir out;
  const std::string dsm = testkit::data_path(kSample), dtm = out.path("dtm.tif");
  dsmplan::Grid terrain = dsmplan::read_raster(dsm);
  for (float& z : terrain.z) z -= 0.3f;  // lower, yet home's ground stays clear of "roofs"
  dsmplan::write_geotiff(terrain, dtm);
  const std::string csv = out.path("flown.csv"), mission = out.path("m.plan"), stats = out.path("s.json");
  const std::string above = out.path("above.png"), side = out.path("side.png");
  const std::vector<std::string> zones{"--no-fly",       kNrwZones,   "--no-fly-blocking",           "NONE",
                                       "--vertical-crs", "EPSG:7837", "--allow-approximate-vertical"};
  std::vector<std::string> args{"plan",     f.bounded, "--waypoints", f.low, "-o",        mission, "-o",        csv,
                                "--dsm",    dsm,       "--dtm",       dtm,   "--max-agl", "30",    "--spacing", "10",
                                "--render", above,     "--profile",   side,  "--stats",   stats,   "-q"};
  args.insert(args.end(), zones.begin(), zones.end());
  const auto planned = run_cli(args);
  ASSERT_EQ(planned.exit_code, 0) << planned.err;
  const json report = json::parse(testkit::read_file(stats));
  const auto flown = read_path_csv(csv);
  const auto home = report["home"].get<std::vector<double>>();
  ASSERT_EQ(flown.front()[0], home[0]);  // as flown: from home on the ground
  const json& render = report["render"];
  const auto window = render["window"].get<std::vector<double>>();
  for (const auto& p : flown) {  // the picture frames the whole flight
    EXPECT_GT(p[0], window[0]);
    EXPECT_GT(p[1], window[1]);
    EXPECT_LT(p[0], window[2]);
    EXPECT_LT(p[1], window[3]);
  }
  char box[160];
  std::snprintf(box, sizeof box, "%.17g,%.17g,%.17g,%.17g", window[0], window[1], window[2], window[3]);
  std::vector<std::string> again{"render",      dsm,
                                 "--path",      csv,
                                 "--waypoints", f.low,
                                 "--window",    box,
                                 "--zoom",      render["zoom"].dump(),
                                 "--title",     "flown.csv over " + std::filesystem::path(dsm).filename().string(),
                                 "-o",          out.path("above_again.png"),
                                 "-q"};
  again.insert(again.end(), zones.begin(), zones.end());
  ASSERT_EQ(run_cli(again).exit_code, 0);
  EXPECT_EQ(testkit::read_file(above), testkit::read_file(out.path("above_again.png")));
  again = {"profile", dsm,        "--path", csv,         "--dtm", dtm,  "--waypoints",
           f.low,     "--safety", "2",      "--max-agl", "30",    "-o", out.path("side_again.png"),
           "-q"};
  again.insert(again.end(), zones.begin(), zones.end());
  ASSERT_EQ(run_cli(again).exit_code, 0);
  EXPECT_EQ(testkit::read_file(side), testkit::read_file(out.path("side_again.png")));
  EXPECT_EQ(report["profile"]["max_above_ground_m"].get<double>(), report["max_agl_m"].get<double>());

  // Refused before the planning, nothing written: no DSM to draw over, a picture not named .png.
  for (const auto& [flag, picture, dsm_given] :
       {std::tuple{"--render", out.path("r.png"), false}, std::tuple{"--profile", out.path("p.jpg"), true}}) {
    std::vector<std::string> refused{"plan", f.bounded, "--waypoints", f.low, "-o", out.path("never.csv"),
                                     flag,   picture,   "-q"};
    if (dsm_given) refused.insert(refused.end(), {"--dsm", dsm});
    const auto run = run_cli(refused);
    EXPECT_EQ(run.exit_code, 2) << flag;
    EXPECT_EQ(run.err.rfind(std::string("dsmplan: ") + flag, 0), 0u) << run.err;
    EXPECT_FALSE(std::filesystem::exists(out.path("never.csv")));
    EXPECT_FALSE(std::filesystem::exists(picture));
  }
}

namespace {

// Issue 35, point 4: waypoints near walls snapped, and heights above the ground.
struct SnapFixture : MissionFixture {
  // Brute force over every cell of the DSM read by GDAL: the distance of p to the cells as solid
  // columns (each cell's square from below up to its height). A hole counts as infinitely tall,
  // which only a point beside it could notice: the wall point below has none within 6 m.
  double column_distance(const std::array<double, 3>& p) const {
    double best = INFINITY;
    const double cx = dsm.gt[1], cy = -dsm.gt[5];
    for (int row = 0; row < dsm.height; ++row)
      for (int col = 0; col < dsm.width; ++col) {
        const double x0 = dsm.gt[0] + col * cx, y1 = dsm.gt[3] - row * cy;
        const double dx = std::max({0.0, x0 - p[0], p[0] - (x0 + cx)});
        const double dy = std::max({0.0, (y1 - cy) - p[1], p[1] - y1});
        if (dx > best || dy > best) continue;
        const float top = dsm.z[size_t(row) * dsm.width + col];
        const double dz = std::isnan(top) ? 0.0 : std::max(0.0, p[2] - top);
        best = std::min(best, std::sqrt(dx * dx + dy * dy + dz * dz));
      }
    return best;
  }
  bool hole_within(double x, double y, double r) const {
    for (int row = 0; row < dsm.height; ++row)
      for (int col = 0; col < dsm.width; ++col) {
        const double cx = dsm.gt[0] + (col + 0.5) * dsm.gt[1], cy = dsm.gt[3] + (row + 0.5) * dsm.gt[5];
        if (std::abs(cx - x) <= r && std::abs(cy - y) <= r && std::isnan(dsm.z[size_t(row) * dsm.width + col]))
          return true;
      }
    return false;
  }
  // A waypoint 8 m above a street cell, on its side 1 m from a building's column: of the cells
  // within 60 m of the mission's first waypoint, in row order, the first street cell (its top
  // within 1 m of that waypoint's street) whose east neighbour stands 10 m above it, moved to its
  // west edge; kept only when the columns (brute force) lie 0.9 to 1.1 m away and no hole is near.
  std::array<double, 3> wall_point() const {
    const double x = 356359, y = 5699307, street = cell(x, y);
    for (int row = 0; row < dsm.height; ++row)
      for (int col = 0; col + 1 < dsm.width; ++col) {
        const double cx = dsm.gt[0] + (col + 0.5) * dsm.gt[1], cy = dsm.gt[3] + (row + 0.5) * dsm.gt[5];
        if (std::hypot(cx - x, cy - y) > 60) continue;
        const float here = dsm.z[size_t(row) * dsm.width + col], east = dsm.z[size_t(row) * dsm.width + col + 1];
        if (!(std::abs(here - street) <= 1 && east > here + 10)) continue;
        const std::array<double, 3> p{cx - 0.5 * dsm.gt[1], cy, here + 8.0};
        const double d = column_distance(p);
        if (d >= 0.9 && d <= 1.1 && !hole_within(p[0], p[1], 6)) return p;
      }
    throw std::runtime_error("no street cell beside a wall near the first waypoint");
  }
  testkit::CliResult plan_points(const std::vector<std::array<double, 3>>& points, const std::string& output,
                                 std::vector<std::string> extra, const std::string& header = "x,y,z\n") const {
    write_waypoints(points, header);
    std::vector<std::string> args{"plan",      bounded, "--waypoints", waypoints,
                                  "-o",        output,  "--dsm",       testkit::data_path(kSample),
                                  "--max-agl", "30",    "--spacing",   "10"};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_cli(args);
  }
};

std::array<double, 3> point_of(const json& xyz) {
  return {xyz[0].get<double>(), xyz[1].get<double>(), xyz[2].get<double>()};
}

}  // namespace

// A refusal's search for the nearest valid point costs its tries times the area within the safety
// distance that each examines: past 10 m the tries are cut in proportion (at --safety 100 over the
// crop's DSM three refusals took 19 s before, at 300 117 s), and the message says how many were tried.
TEST(CliPlan, ARefusalAtALargeSafetyTriesAsFewPointsAsItsCostAllows) {
  SnapFixture f;
  TempDir out;
  const std::array<double, 3> wall = f.wall_point(), second{356469, 5699429, 129};
  const auto near = f.plan_points({wall, second}, out.path("never.csv"), {"--safety", "2", "-q"});
  EXPECT_EQ(near.exit_code, 1) << near.err;
  EXPECT_NE(near.err.find("the nearest valid point: x "), std::string::npos) << near.err;
  const auto far = f.plan_points({wall, second}, out.path("never.csv"), {"--safety", "100", "-q"});
  EXPECT_EQ(far.exit_code, 1) << far.err;
  const size_t named = far.err.find("no valid point among the ");
  ASSERT_NE(named, std::string::npos) << far.err;
  const long tried = std::strtol(far.err.c_str() + named + std::strlen("no valid point among the "), nullptr, 10);
  EXPECT_GE(tried, 16);                           // the least a search tries
  EXPECT_LE(tried * 100 * 100, 4000L * 10 * 10);  // the cost of the 4,000 tried at 10 m
  EXPECT_FALSE(std::filesystem::exists(out.path("never.csv")));
}

TEST(CliPlan, SnapMovesAWaypointBesideAWallToTheNearestValidPoint) {
  SnapFixture f;
  TempDir out;
  const std::array<double, 3> wall = f.wall_point();
  const std::array<double, 3> second{356469, 5699429, 129};  // the mission's second street point
  ASSERT_LT(f.column_distance(wall), 2.0);
  ASSERT_GE(f.column_distance(second), 2.0);

  // Without --snap: refused, naming the waypoint and a nearest valid point, which holds.
  const auto refused = f.plan_points({wall, second}, out.path("never.csv"), {"-q"});
  EXPECT_EQ(refused.exit_code, 1) << refused.err;
  EXPECT_NE(refused.err.find("waypoint 1"), std::string::npos) << refused.err;
  const size_t named = refused.err.find("the nearest valid point: x ");
  ASSERT_NE(named, std::string::npos) << refused.err;
  std::array<double, 3> nearest{};
  ASSERT_EQ(std::sscanf(refused.err.c_str() + named, "the nearest valid point: x %lf, y %lf, z %lf", &nearest[0],
                        &nearest[1], &nearest[2]),
            3)
      << refused.err;
  EXPECT_GE(f.column_distance(nearest), 2.0 - 0.01);  // two decimals written
  EXPECT_FALSE(std::filesystem::exists(out.path("never.csv")));

  // With --snap 5: moved, reported in the summary, --stats and the GeoJSON, and the moved point
  // keeps every rule by the oracle: the columns, the ceiling over the DSM's ground, within 5 m.
  const std::string csv = out.path("snapped.csv"), geo = out.path("snapped.geojson"), stats = out.path("s.json");
  const auto snapped =
      f.plan_points({wall, second}, csv, {"-o", geo, "--snap", "5", "--stats", stats, "--vertical-crs", "EPSG:5773"});
  ASSERT_EQ(snapped.exit_code, 0) << snapped.err;
  EXPECT_NE(snapped.out.find("waypoint 1 snapped "), std::string::npos) << snapped.out;
  const json report = json::parse(testkit::read_file(stats));
  ASSERT_EQ(report["snapped"].size(), 1u) << report.dump();
  const json& move = report["snapped"][0];
  EXPECT_EQ(move["waypoint"], 1);
  const std::array<double, 3> from = point_of(move["from"]), to = point_of(move["to"]);
  EXPECT_EQ(from, wall);
  const double moved = std::hypot(to[0] - from[0], to[1] - from[1], to[2] - from[2]);
  EXPECT_NEAR(move["distance_m"].get<double>(), moved, 1e-9);
  EXPECT_LE(moved, 5.0);
  EXPECT_GT(moved, 0.0);
  EXPECT_NE(move["reason"].get<std::string>().find("safety distance"), std::string::npos) << move.dump();
  EXPECT_GE(f.column_distance(to), 2.0);
  EXPECT_LE(to[2] - f.ground(to[0], to[1]), 30.0);
  const std::vector<std::array<double, 3>> path = read_path_csv(csv);
  ASSERT_GE(path.size(), 2u);
  EXPECT_EQ(path.front(), to);  // the path starts at the moved point
  EXPECT_EQ(path.back(), second);
  const json feature = json::parse(testkit::read_file(geo));
  EXPECT_EQ(feature["properties"]["snapped"], report["snapped"]);

  // The wall needs about 1 m: --snap 0.5 refuses it, saying so and naming the nearest point.
  const auto too_far = f.plan_points({wall, second}, out.path("never.csv"), {"--snap", "0.5", "-q"});
  EXPECT_EQ(too_far.exit_code, 1);
  EXPECT_NE(too_far.err.find("no valid point within --snap 0.50 m"), std::string::npos) << too_far.err;
  EXPECT_NE(too_far.err.find("the nearest valid point"), std::string::npos) << too_far.err;
  EXPECT_FALSE(std::filesystem::exists(out.path("never.csv")));

  const auto bad = f.plan_points({wall, second}, out.path("never.csv"), {"--snap", "60", "-q"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.err.rfind("dsmplan: --snap: must lie in [0, 50] m (0: off), got 60", 0), 0u) << bad.err;
}

// --snap moves a mission's home too: a home against a wall (its climb passes nearer than the
// safety distance) goes to the nearest clear spot, the very one the refusal without --snap names,
// and the climb there keeps the safety distance from the DSM's columns by brute force.
TEST(CliPlan, SnapMovesAHomeAgainstAWallToTheNearestClearSpot) {
  SnapFixture f;
  TempDir out;
  const std::array<double, 2> wall = f.home_against_wall();
  ASSERT_FALSE(std::isnan(wall[0])) << "no wall east of the first waypoint";
  char at[64];
  std::snprintf(at, sizeof at, "%.2f,%.2f", wall[0], wall[1]);
  const auto refused = f.plan(out.path("never.plan"), {"--home", at});
  ASSERT_EQ(refused.exit_code, 1) << refused.err;  // a well-formed home the data refuse: the data's fault
  const std::string said = "the nearest clear spot: --home ";
  const size_t named = refused.err.find(said);
  ASSERT_NE(named, std::string::npos) << refused.err;
  double cx = NAN, cy = NAN, away = NAN;
  ASSERT_EQ(std::sscanf(refused.err.c_str() + named + said.size(), "%lf,%lf (%lf m away)", &cx, &cy, &away), 3)
      << refused.err;

  const std::string plan = out.path("m.plan"), stats = out.path("s.json");
  const auto snapped = f.plan(plan, {"--home", at, "--snap", "10", "--stats", stats});
  ASSERT_EQ(snapped.exit_code, 0) << snapped.err;
  const json report = json::parse(testkit::read_file(stats));
  ASSERT_EQ(report["snapped"].size(), 1u) << report.dump();
  const json& move = report["snapped"][0];
  EXPECT_EQ(move["place"], "home");
  EXPECT_EQ(move["waypoint"], 0);
  EXPECT_NE(move["reason"].get<std::string>().find("climb"), std::string::npos) << move.dump();
  const std::array<double, 3> from = point_of(move["from"]), to = point_of(move["to"]);
  EXPECT_NEAR(from[0], std::stod(at), 1e-9);
  EXPECT_NEAR(to[0], cx, 0.005);  // the spot the refusal named, to its two decimals
  EXPECT_NEAR(to[1], cy, 0.005);
  EXPECT_NEAR(move["distance_m"].get<double>(), away, 0.005);
  EXPECT_EQ(to[2], f.ground(to[0], to[1]));  // on the ground (the DSM's cell, no DTM)
  EXPECT_EQ(point_of(report["home"]), to);   // the mission's home is the moved one
  // The climb at the new home, every 5 cm from 1 m plus --safety above the ground to the takeoff's
  // top (as high above the ground as waypoint 1), keeps 2 m from the columns.
  const double top = to[2] + report["takeoff_height_m"].get<double>();
  for (double z = to[2] + 1 + 2; z <= top; z += 0.05)
    ASSERT_GE(f.column_distance({to[0], to[1], z}), 2.0 - 0.01) << "z " << z;
  // A radius short of the spot refuses home as without --snap, nothing written.
  if (away > 1) {
    const auto short_of = f.plan(out.path("never.plan"), {"--home", at, "--snap", "1"});
    EXPECT_EQ(short_of.exit_code, 2) << short_of.err;
    EXPECT_NE(short_of.err.find(said), std::string::npos) << short_of.err;
    EXPECT_FALSE(std::filesystem::exists(out.path("never.plan")));
  }
}

TEST(CliPlan, WaypointHeightsAboveTheGroundCountFromTheDtmElseTheDsm) {
  SnapFixture f;
  TempDir out;
  const std::vector<std::array<double, 3>> agl{{356359, 5699307, 9.5}, {356469, 5699429, 11.25}};
  // The DSM's cells, read by GDAL, are the ground without a DTM: z = cell + agl exactly.
  const std::string over_dsm = out.path("dsm.csv");
  const auto by_header = f.plan_points(agl, over_dsm, {"-q"}, "x,y,agl\n");
  ASSERT_EQ(by_header.exit_code, 0) << by_header.err;
  std::vector<std::array<double, 3>> path = read_path_csv(over_dsm);
  EXPECT_EQ(path.front()[2], f.ground(agl[0][0], agl[0][1]) + 9.5);
  EXPECT_EQ(path.back()[2], f.ground(agl[1][0], agl[1][1]) + 11.25);
  // The flag says the same of a header-less file; crs over an agl header is refused.
  const auto by_flag = f.plan_points(agl, out.path("flag.csv"), {"--waypoint-heights", "agl", "-q"}, "");
  ASSERT_EQ(by_flag.exit_code, 0) << by_flag.err;
  EXPECT_EQ(testkit::read_file(out.path("flag.csv")), testkit::read_file(over_dsm));
  const auto clash = f.plan_points(agl, out.path("never.csv"), {"--waypoint-heights", "crs", "-q"}, "x,y,agl\n");
  EXPECT_EQ(clash.exit_code, 2);
  EXPECT_EQ(clash.err.rfind("dsmplan: --waypoint-heights: is crs, but the header of", 0), 0u) << clash.err;
  // --routes reads a "route,x,y,agl" header the same way: the route's path is the single run's.
  const std::string routes = f.in.path("routes.csv"), folder = out.path("routes") + "/";
  std::ostringstream rows;
  rows.precision(17);
  rows << "route,x,y,agl\n";
  for (const auto& p : agl) rows << "r," << p[0] << "," << p[1] << "," << p[2] << "\n";
  testkit::write_file(routes, rows.str());
  const std::vector<std::string> route_args{
      "plan",      f.bounded, "--routes",  routes, "--dsm", testkit::data_path(kSample),
      "--max-agl", "30",      "--spacing", "10",   "-q"};
  auto args = route_args;
  args.insert(args.end(), {"-o", folder});
  const auto by_routes = run_cli(args);
  ASSERT_EQ(by_routes.exit_code, 0) << by_routes.err;
  EXPECT_EQ(testkit::read_file(folder + "r.csv"), testkit::read_file(over_dsm));
  args = route_args;
  args.insert(args.end(), {"-o", out.path("never") + "/", "--waypoint-heights", "crs"});
  const auto routes_clash = run_cli(args);
  EXPECT_EQ(routes_clash.exit_code, 2);
  EXPECT_EQ(routes_clash.err.rfind("dsmplan: --waypoint-heights: is crs, but the header of " + routes, 0), 0u)
      << routes_clash.err;

  // With a DTM 3 m under the DSM, read back by GDAL: z = DTM cell + agl.
  dsmplan::Grid terrain = dsmplan::read_raster(testkit::data_path(kSample));
  for (float& z : terrain.z) z -= 3;
  const std::string dtm = out.path("dtm.tif"), over_dtm = out.path("dtm.csv");
  dsmplan::write_geotiff(terrain, dtm);
  const Raster ground = read_with_gdal(dtm);
  // The lowest of the DTM's cells whose closed squares hold (x, y), as the ground is counted.
  const auto dtm_cell = [&](double x, double y) {
    double low = INFINITY;
    for (const double ex : {-1e-9, 1e-9})
      for (const double ey : {-1e-9, 1e-9}) {
        const int col = int(std::floor((x + ex - ground.gt[0]) / ground.gt[1]));
        const int row = int(std::floor((y + ey - ground.gt[3]) / ground.gt[5]));
        low = std::min(low, double(ground.z[size_t(row) * ground.width + col]));
      }
    return low;
  };
  const auto planned = f.plan_points(agl, over_dtm, {"--dtm", dtm, "-q"}, "x,y,agl\n");
  ASSERT_EQ(planned.exit_code, 0) << planned.err;
  path = read_path_csv(over_dtm);
  EXPECT_EQ(path.front()[2], dtm_cell(agl[0][0], agl[0][1]) + 9.5);
  EXPECT_EQ(path.back()[2], dtm_cell(agl[1][0], agl[1][1]) + 11.25);
  EXPECT_NE(path.front()[2], f.ground(agl[0][0], agl[0][1]) + 9.5);  // the DTM, not the DSM

  // A DSM input, planned along a corridor window by window, counts from the same ground: the DSM's
  // cells, or the DTM's.
  f.write_waypoints(agl, "x,y,agl\n");
  for (const std::string& with : {std::string(), dtm}) {
    std::vector<std::string> args{"plan", testkit::data_path(kSample), "--waypoints", f.waypoints,
                                  "-o",   out.path("corridor.csv"),    "--max-agl",   "30",
                                  "-q"};
    if (!with.empty()) args.insert(args.end(), {"--dtm", with});
    const auto along = run_cli(args);
    ASSERT_EQ(along.exit_code, 0) << along.err;
    path = read_path_csv(out.path("corridor.csv"));
    const auto under = [&](double x, double y) { return with.empty() ? f.ground(x, y) : dtm_cell(x, y); };
    EXPECT_EQ(path.front()[2], under(agl[0][0], agl[0][1]) + 9.5) << with;
    EXPECT_EQ(path.back()[2], under(agl[1][0], agl[1][1]) + 11.25) << with;
  }
  // --snap is not done along a corridor: refused in one line, nothing written.
  const auto snap = run_cli({"plan", testkit::data_path(kSample), "--waypoints", f.waypoints, "-o",
                             out.path("never.csv"), "--snap", "2", "-q"});
  EXPECT_EQ(snap.exit_code, 2);
  EXPECT_EQ(snap.err.rfind("dsmplan: --snap: applies to a mesh input", 0), 0u) << snap.err;
  EXPECT_FALSE(std::filesystem::exists(out.path("never.csv")));
}

TEST(CliNoFly, SnapMovesAWaypointOutOfAZoneAndItsSafetyDistance) {
  NoFlyFixture f;
  std::vector<std::array<double, 3>> points = f.corners();
  f.write_waypoints(points);
  TempDir out;
  const std::string dsm = testkit::data_path(kSample), zones = f.in.path("zones.geojson");
  // A 30 m square from the ground up whose west edge runs 1 m west of waypoint 1: it must move
  // 3 m west (1 m out, then --safety 2) or more; up does not leave a zone without a ceiling.
  const std::array<double, 2> centre{points[0][0] + 14, points[0][1]};
  write_square_zone(zones, "snap block", centre, 15);
  for (size_t k = 1; k < points.size(); ++k) ASSERT_GT(square_distance(points[k][0], points[k][1], centre, 15), 20);
  const auto plan = [&](std::vector<std::string> extra) {
    std::vector<std::string> args{"plan", f.mesh, "--waypoints", f.waypoints, "--dsm", dsm, "--no-fly", zones, "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return run_cli(args);
  };
  const auto refused = plan({"-o", out.path("never.csv")});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("waypoint 1: inside no-fly zone 'snap block'"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("; the nearest valid point: x "), std::string::npos) << refused.err;
  const auto too_far = plan({"-o", out.path("never.csv"), "--snap", "2"});
  EXPECT_EQ(too_far.exit_code, 1);
  EXPECT_NE(too_far.err.find("no valid point within --snap 2.00 m"), std::string::npos) << too_far.err;
  EXPECT_FALSE(std::filesystem::exists(out.path("never.csv")));

  const std::string csv = out.path("snapped.csv"), stats = out.path("snapped.json");
  const auto snapped = plan({"-o", csv, "--snap", "5", "--stats", stats});
  ASSERT_EQ(snapped.exit_code, 0) << snapped.err;
  const json report = json::parse(testkit::read_file(stats));
  ASSERT_EQ(report["snapped"].size(), 1u) << report.dump();
  const json& move = report["snapped"][0];
  EXPECT_EQ(move["waypoint"], 1);
  EXPECT_NE(move["reason"].get<std::string>().find("inside no-fly zone 'snap block'"), std::string::npos);
  const std::array<double, 3> to = point_of(move["to"]);
  // Out of the zone by the safety distance (the square's edges drawn through WGS 84: 1 cm),
  // no farther than 5 m, and kept from the DSM's columns and under the ceiling as before.
  EXPECT_GE(square_distance(to[0], to[1], centre, 15), 2 - 0.01);
  const double moved = std::hypot(to[0] - points[0][0], to[1] - points[0][1], to[2] - points[0][2]);
  EXPECT_LE(moved, 5.0);
  EXPECT_GE(moved, 3.0 - 0.01);
  EXPECT_EQ(read_path_csv(csv).front(), to);
  EXPECT_GE(sampled_square_distance(read_path_csv(csv), centre, 15), 2 - 0.01);
}

// Issue 52: `render` and `profile` read an x,y,agl waypoint file as `plan` does, its heights above
// the DSM cell under each waypoint (the DTM's with --dtm): the picture is byte for byte the one of
// the x,y,z file of those heights (each height from the raster's own cells, the oracle). An agl
// waypoint over no ground is refused in one line naming the file and the waypoint.
TEST(CliProfile, AnAglWaypointFileIsDrawnWhereThePlanFliesIt) {
  TempDir out;
  const std::string dsm_path = testkit::data_path(kSample);
  dsmplan::Grid terrain = dsmplan::read_raster(dsm_path);
  const dsmplan::Grid dsm = terrain;
  for (float& z : terrain.z) z -= 8;
  const std::string dtm = out.path("dtm.tif");
  dsmplan::write_geotiff(terrain, dtm);
  const auto cell = [](const dsmplan::Grid& g, double x, double y) {
    return double(g.z[size_t(std::floor((g.y0 - y) / g.cell_y)) * g.width + size_t(std::floor((x - g.x0) / g.cell_x))]);
  };
  const std::vector<std::array<double, 2>> places{{356320.5, 5699270.5}, {356561.2, 5699499.7}, {356780.0, 5699730.9}};
  const std::vector<double> above{25, 31.5, 40};
  const auto write = [&](const std::string& name, const std::string& header, auto&& height) {
    std::string text = header + "\n";
    char line[96];
    for (size_t i = 0; i < places.size(); ++i) {
      std::snprintf(line, sizeof line, "%.3f,%.3f,%.17g\n", places[i][0], places[i][1], height(i));
      text += line;
    }
    testkit::write_file(out.path(name), text);
    return out.path(name);
  };
  const std::string agl = write("agl.csv", "x,y,agl", [&](size_t i) { return above[i]; });
  const std::string over_dsm =
      write("over_dsm.csv", "x,y,z", [&](size_t i) { return cell(dsm, places[i][0], places[i][1]) + above[i]; });
  const std::string over_dtm =
      write("over_dtm.csv", "x,y,z", [&](size_t i) { return cell(terrain, places[i][0], places[i][1]) + above[i]; });
  const std::string path = write("path.csv", "x,y,z", [&](size_t i) { return 180.0 + i; });
  const auto profile = [&](const std::string& waypoints, const std::string& png, bool with_dtm) {
    std::vector<std::string> args{"profile", dsm_path, "--path",      path, "--waypoints",
                                  waypoints, "-o",     out.path(png), "-q"};
    if (with_dtm) args.insert(args.end(), {"--dtm", dtm});
    const auto run = run_cli(args);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return testkit::read_file(out.path(png));
  };
  const std::string drawn = profile(agl, "agl.png", false);
  EXPECT_FALSE(drawn.empty());
  EXPECT_TRUE(drawn == profile(over_dsm, "over_dsm.png", false)) << "the agl waypoints are not where the z ones are";
  EXPECT_FALSE(drawn == profile(over_dtm, "over_dtm_no_dtm.png", false)) << "the waypoints do not change the picture";
  EXPECT_TRUE(profile(agl, "agl_dtm.png", true) == profile(over_dtm, "over_dtm.png", true));

  for (const auto& [waypoints, png] : {std::pair{agl, "r_agl.png"}, std::pair{over_dsm, "r_z.png"}}) {
    const auto run = run_cli({"render", dsm_path, "--waypoints", waypoints, "-o", out.path(png), "-q"});
    EXPECT_EQ(run.exit_code, 0) << run.err;
  }
  EXPECT_TRUE(testkit::read_file(out.path("r_agl.png")) == testkit::read_file(out.path("r_z.png")));

  testkit::write_file(out.path("beyond.csv"), "x,y,agl\n356320.5,5699270.5,25\n357900,5699270.5,25\n");
  for (const char* command : {"render", "profile"}) {
    std::vector<std::string> args{command, dsm_path,           "--waypoints", out.path("beyond.csv"),
                                  "-o",    out.path("no.png"), "-q"};
    if (std::string(command) == "profile") args.insert(args.end(), {"--path", path});
    const auto run = run_cli(args);
    EXPECT_EQ(run.exit_code, 1) << command;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_NE(run.err.find("beyond.csv: waypoint 2: x 357900.00"), std::string::npos) << run.err;
    EXPECT_FALSE(std::filesystem::exists(out.path("no.png"))) << command;
  }
}

// Issue 52: a .plan carries the zones it was planned around as QGC geofence exclusion polygons,
// as far as a flat fence can: every ring of each blocking zone the mission keeps out of seen from
// above, its corners those of the zones file (WGS 84, the oracle) through the CRS and back; the
// zones the path passes under or over (a floor 90 m up, an AMSL band) left out and named, since
// the autopilot would call the planned flight a breach. The mission's own legs, home to home,
// enter no polygon (QGC's even-odd test of a coordinate, and no leg crossing an edge).
TEST(CliNoFly, PlanGeofenceKeepsOutTheZonesTheMissionKeepsOutOf) {
  NoFlyFixture f;
  TempDir out;
  const std::string plan = out.path("m.plan"), stats = out.path("s.json");
  const auto run = run_cli({"plan",
                            f.mesh,
                            "--dsm",
                            testkit::data_path(kSample),
                            "--waypoints",
                            testkit::data_path("nrw-dom1/low_waypoints.csv"),
                            "--max-agl",
                            "30",
                            "--no-fly",
                            kNrwZones,
                            "--no-fly-blocking",
                            "PROHIBITED,REQ_AUTHORISATION",
                            "--vertical-crs",
                            "EPSG:7837",
                            "--allow-approximate-vertical",
                            "-o",
                            plan,
                            "--stats",
                            stats,
                            "-q"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json report = json::parse(testkit::read_file(stats));
  const json mission = json::parse(testkit::read_file(plan));
  const json file = json::parse(testkit::read_file(kNrwZones));
  std::set<std::string> left_out;
  for (const auto& zone : report["geofence_left_out"]) {
    left_out.insert(zone["zone"].get<std::string>());
    EXPECT_NE(zone["why"].get<std::string>().find("passes over or under"), std::string::npos) << zone.dump();
  }
  EXPECT_EQ(left_out, (std::set<std::string>{"High corridor above the roofs", "East band"}));
  using LatLon = std::array<double, 2>;
  std::vector<std::vector<LatLon>> fences;
  for (const auto& fence : mission["geoFence"]["polygons"]) {
    EXPECT_EQ(fence["inclusion"], false);
    EXPECT_EQ(fence["version"], 1);
    auto& ring = fences.emplace_back();
    for (const auto& c : fence["polygon"]) ring.push_back({c[0].get<double>(), c[1].get<double>()});
    EXPECT_GE(ring.size(), 3u);
    EXPECT_NE(ring.front(), ring.back()) << "QGC keeps its polygons open";
  }
  // Every ring of every blocking zone not left out, its corners where the file has them.
  size_t rings = 0, zones = 0;
  for (const auto& zone : file["features"]) {
    const std::string restriction = zone["restriction"];
    if ((restriction != "PROHIBITED" && restriction != "REQ_AUTHORISATION") || left_out.count(zone["name"])) continue;
    ++zones;
    const auto& shape = zone["geometry"][0]["horizontalProjection"];
    if (shape["type"] != "Polygon") {
      ++rings;  // a circle: drawn as a ring of its own
      continue;
    }
    for (const auto& ring : shape["coordinates"]) {
      ++rings;
      for (const auto& corner : ring) {
        const double lon = corner[0], lat = corner[1];
        const bool found = std::any_of(fences.begin(), fences.end(), [&](const auto& fence) {
          return std::any_of(fence.begin(), fence.end(), [&](const LatLon& c) {
            return std::abs(c[0] - lat) < 1e-7 && std::abs(c[1] - lon) < 1e-7;
          });
        });
        EXPECT_TRUE(found) << zone["name"] << ": " << lon << ", " << lat;
      }
    }
  }
  EXPECT_EQ(report["geofence_zones"].get<size_t>(), zones);
  EXPECT_EQ(fences.size(), rings);
  // The mission as flown: home, the items with a position, back home (RTL).
  std::vector<LatLon> legs{
      {mission["mission"]["plannedHomePosition"][0], mission["mission"]["plannedHomePosition"][1]}};
  for (const auto& item : mission["mission"]["items"])
    if (item["frame"] != 2) legs.push_back({item["params"][4].get<double>(), item["params"][5].get<double>()});
  legs.push_back(legs.front());
  const auto inside = [](const std::vector<LatLon>& ring, const LatLon& p) {  // winding number
    int winding = 0;
    for (size_t i = 0; i < ring.size(); ++i) {
      const LatLon &a = ring[i], &b = ring[(i + 1) % ring.size()];
      const double side = (b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1]);
      if (a[1] <= p[1] && b[1] > p[1] && side > 0) ++winding;
      if (a[1] > p[1] && b[1] <= p[1] && side < 0) --winding;
    }
    return winding != 0;
  };
  const auto cross = [](const LatLon& p, const LatLon& q, const LatLon& a, const LatLon& b) {  // proper or touching
    const auto orient = [](const LatLon& o, const LatLon& u, const LatLon& v) {
      const double d = (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0]);
      return (d > 0) - (d < 0);
    };
    return orient(p, q, a) * orient(p, q, b) <= 0 && orient(a, b, p) * orient(a, b, q) <= 0;
  };
  for (size_t z = 0; z < fences.size(); ++z)
    for (size_t k = 0; k + 1 < legs.size(); ++k) {
      EXPECT_FALSE(inside(fences[z], legs[k])) << "point " << k << " inside fence " << z;
      for (size_t i = 0; i < fences[z].size(); ++i)
        EXPECT_FALSE(cross(legs[k], legs[k + 1], fences[z][i], fences[z][(i + 1) % fences[z].size()]))
            << "leg " << k << " crosses fence " << z;
    }
}

// Issue 52: --no-fly-buffer keeps the blocking zones farther than --safety keeps the obstacles:
// the path's distance to a square zone on the free path, sampled from the written path (the
// oracle) and as reported, is at least the buffer, on a mesh and along a corridor; a waypoint
// within the buffer is refused naming the zone, and a negative buffer is a usage error.
TEST(CliNoFly, ABufferKeepsTheZonesFartherThanTheSafety) {
  NoFlyFixture f;
  TempDir out;
  const std::string dsm = testkit::data_path(kSample);
  const auto free = f.free_path(out);
  const std::array<double, 2> centre{(free[free.size() / 2][0] + free[free.size() / 2 - 1][0]) / 2,
                                     (free[free.size() / 2][1] + free[free.size() / 2 - 1][1]) / 2};
  const double half = 10, buffer = 12;
  for (const auto& w : f.corners()) ASSERT_GT(square_distance(w[0], w[1], centre, half), buffer + 1);
  ASSERT_LT(sampled_square_distance(free, centre, half), buffer);
  const std::string zones = f.in.path("zones.geojson");
  write_square_zone(zones, "buffered block", centre, half);
  for (const std::string& input : {f.mesh, dsm}) {
    std::vector<std::string> args{"plan",
                                  input,
                                  "--waypoints",
                                  f.waypoints,
                                  "--no-fly",
                                  zones,
                                  "--no-fly-buffer",
                                  "12",
                                  "-o",
                                  out.path("around.csv"),
                                  "--stats",
                                  out.path("around.json"),
                                  "-q"};
    if (input == f.mesh) args.insert(args.end(), {"--dsm", dsm});
    const auto run = run_cli(args);
    ASSERT_EQ(run.exit_code, 0) << input << ": " << run.err;
    EXPECT_GE(sampled_square_distance(read_path_csv(out.path("around.csv")), centre, half), buffer - 0.01) << input;
    const json stats = json::parse(testkit::read_file(out.path("around.json")));
    EXPECT_GE(stats["no_fly_zones"][0]["min_distance_m"].get<double>(), buffer - 0.01) << input;
  }
  double nearest = INFINITY;
  for (const auto& w : f.corners()) nearest = std::min(nearest, square_distance(w[0], w[1], centre, half));
  TempDir none;
  const auto refused = run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "--dsm", dsm, "--no-fly", zones,
                                "--no-fly-buffer", std::to_string(nearest + 3), "-o", none.path("no.csv"), "-q"});
  expect_clean_failure(refused, none, f.waypoints, {"no-fly zone 'buffered block'"});
  const auto negative = run_cli({"plan", f.mesh, "--waypoints", f.waypoints, "--no-fly", zones, "--no-fly-buffer", "-1",
                                 "-o", out.path("no.csv"), "-q"});
  EXPECT_EQ(negative.exit_code, 2) << negative.err;
  EXPECT_NE(negative.err.find("--no-fly-buffer: must be from 0 to 1000, got -1"), std::string::npos) << negative.err;
}
