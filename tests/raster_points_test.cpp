// Point clouds in: LAS and XYZ reading and the median/max gridding of Adolf & Hirschmueller,
// Section 2. The oracles are computed here, independently of the code under test: LAS headers
// and records are decoded with memcpy at the offsets of the ASPRS LAS 1.4 R15 specification,
// synthetic LAS files are written by a small writer below, and cell medians are brute-forced by
// sorting every cell's heights.
#include <gdal.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/tools.hpp"
#include "testkit.hpp"

using dsmplan::Fusion;
using dsmplan::Grid;
using dsmplan::GridPointsOptions;
using dsmplan::PointCloud;

namespace {

const std::string kDelft1 = testkit::data_path("delft-ahn3/ahn3_cropped_1.las");
const std::string kDelft2 = testkit::data_path("delft-ahn3/ahn3_cropped_2.las");

// ---- LAS bytes, decoded and written independently of the reader ---------------------------

template <typename T>
T get(const std::string& bytes, size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof value);  // LAS and the test hosts are little-endian
  return value;
}

template <typename T>
void put(std::string& bytes, size_t offset, T value) {
  std::memcpy(bytes.data() + offset, &value, sizeof value);
}

struct RawHeader {
  uint32_t point_offset;
  uint8_t format;
  uint16_t record_length;
  uint32_t count;
  double scale[3], offset[3];
  double min[3], max[3];
};

RawHeader raw_header(const std::string& bytes) {
  RawHeader h{};
  h.point_offset = get<uint32_t>(bytes, 96);
  h.format = get<uint8_t>(bytes, 104);
  h.record_length = get<uint16_t>(bytes, 105);
  h.count = get<uint32_t>(bytes, 107);
  for (int i = 0; i < 3; ++i) {
    h.scale[i] = get<double>(bytes, 131 + 8 * i);
    h.offset[i] = get<double>(bytes, 155 + 8 * i);
    h.max[i] = get<double>(bytes, 179 + 16 * i);  // max x, min x, max y, min y, max z, min z
    h.min[i] = get<double>(bytes, 187 + 16 * i);
  }
  return h;
}

double raw_coordinate(const std::string& bytes, const RawHeader& h, size_t point, int axis) {
  return get<int32_t>(bytes, h.point_offset + point * h.record_length + 4 * axis) * h.scale[axis] + h.offset[axis];
}

int raw_class(const std::string& bytes, const RawHeader& h, size_t point) {
  return get<uint8_t>(bytes, h.point_offset + point * h.record_length + 15) & 0x1F;  // formats 0-5
}

struct SynthPoint {
  double x, y, z;
  uint8_t cls;
};

constexpr int kRecordLength[11] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};

struct LasSpec {
  int minor = 2;
  int format = 1;
  int extra_bytes = 0;  // beyond the format's record length
  double scale[3] = {0.01, 0.01, 0.001};
  double offset[3] = {85000, 447000, -5};
  std::vector<SynthPoint> points;
  std::string wkt;                // a LASF_Projection 2112 record when not empty
  std::vector<uint16_t> geokeys;  // a LASF_Projection 34735 record when not empty
  bool wkt_as_evlr = false;       // LAS 1.4: the WKT record after the points
  bool legacy_count = true;       // LAS 1.4: fill the 32-bit count too (formats 0-5 only)
};

std::string vlr(const std::string& user, uint16_t record_id, const std::string& payload, bool extended) {
  std::string header(extended ? 60 : 54, '\0');
  std::memcpy(header.data() + 2, user.data(), std::min<size_t>(user.size(), 16));
  put<uint16_t>(header, 18, record_id);
  if (extended)
    put<uint64_t>(header, 20, payload.size());
  else
    put<uint16_t>(header, 20, static_cast<uint16_t>(payload.size()));
  return header + payload;
}

std::string las_bytes(const LasSpec& spec) {
  const int header_size = spec.minor >= 4 ? 375 : spec.minor == 3 ? 235 : 227;
  std::string vlrs = vlr("dsmplan_test", 7, "not a CRS", false);  // a record the reader must skip
  std::string evlrs;
  uint32_t vlr_count = 1;
  const std::string wkt_payload = spec.wkt + std::string(3, '\0');
  if (!spec.wkt.empty() && spec.wkt_as_evlr) evlrs += vlr("LASF_Projection", 2112, wkt_payload, true);
  if (!spec.wkt.empty() && !spec.wkt_as_evlr) {
    vlrs += vlr("LASF_Projection", 2112, wkt_payload, false);
    ++vlr_count;
  }
  if (!spec.geokeys.empty()) {
    std::string keys(spec.geokeys.size() * 2, '\0');
    std::memcpy(keys.data(), spec.geokeys.data(), keys.size());
    vlrs += vlr("LASF_Projection", 34735, keys, false);
    ++vlr_count;
  }
  const std::string pad = spec.minor == 0 ? std::string("\xDD\xCC", 2) : "";  // LAS 1.0 point data start signature
  const uint32_t point_offset = static_cast<uint32_t>(header_size + vlrs.size() + pad.size());
  const int length = kRecordLength[spec.format] + spec.extra_bytes;

  std::string header(header_size, '\0');
  std::memcpy(header.data(), "LASF", 4);
  put<uint8_t>(header, 24, 1);
  put<uint8_t>(header, 25, static_cast<uint8_t>(spec.minor));
  std::memcpy(header.data() + 58, "dsmplan test", 12);
  put<uint16_t>(header, 94, static_cast<uint16_t>(header_size));
  put<uint32_t>(header, 96, point_offset);
  put<uint32_t>(header, 100, vlr_count);
  put<uint8_t>(header, 104, static_cast<uint8_t>(spec.format));
  put<uint16_t>(header, 105, static_cast<uint16_t>(length));
  const uint64_t count = spec.points.size();
  if (spec.minor < 4 || (spec.legacy_count && spec.format < 6))
    put<uint32_t>(header, 107, static_cast<uint32_t>(count));
  double min[3] = {INFINITY, INFINITY, INFINITY}, max[3] = {-INFINITY, -INFINITY, -INFINITY};

  std::string records;
  for (const SynthPoint& p : spec.points) {
    std::string record(length, '\xA5');  // garbage wherever the reader must not look
    const double xyz[3] = {p.x, p.y, p.z};
    for (int i = 0; i < 3; ++i) {
      put<int32_t>(record, 4 * i, static_cast<int32_t>(std::llround((xyz[i] - spec.offset[i]) / spec.scale[i])));
      min[i] = std::min(min[i], xyz[i]);
      max[i] = std::max(max[i], xyz[i]);
    }
    if (spec.format < 6) {
      put<uint8_t>(record, 15, static_cast<uint8_t>(p.cls | 0xE0));  // synthetic/key-point/withheld flags set
    } else {
      put<uint8_t>(record, 15, 0xFF);  // classification flags, scanner channel
      put<uint8_t>(record, 16, p.cls);
    }
    records += record;
  }
  for (int i = 0; i < 3; ++i) {
    put<double>(header, 131 + 8 * i, spec.scale[i]);
    put<double>(header, 155 + 8 * i, spec.offset[i]);
    put<double>(header, 179 + 16 * i, count ? max[i] : 0);
    put<double>(header, 187 + 16 * i, count ? min[i] : 0);
  }
  if (spec.minor >= 4) {
    put<uint64_t>(header, 235, evlrs.empty() ? 0 : point_offset + records.size());
    put<uint32_t>(header, 243, evlrs.empty() ? 0 : 1);
    put<uint64_t>(header, 247, count);
  }
  return header + vlrs + pad + records + evlrs;
}

std::vector<SynthPoint> synthetic_points(const std::vector<uint8_t>& classes) {
  std::vector<SynthPoint> points;
  for (int i = 0; i < 40; ++i) {
    points.push_back({84950.0 + i * 1.37 - (i % 3) * 0.004, 447500.0 - i * 0.53 + (i % 5) * 0.0123, -12.345 + i * 0.777,
                      classes[static_cast<size_t>(i) % classes.size()]});
  }
  return points;
}

// ---- helpers ----------------------------------------------------------------------------

// Calls `read` and expects an InputError whose one-line message names `path` and contains `fragment`.
void expect_input_error(const std::function<void()>& read, const std::string& path, const std::string& fragment) {
  try {
    read();
    ADD_FAILURE() << "no error; expected one containing '" << fragment << "'";
  } catch (const dsmplan::InputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(fragment), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

size_t valid_cells(const Grid& grid) {
  return static_cast<size_t>(std::count_if(grid.z.begin(), grid.z.end(), [](float z) { return !std::isnan(z); }));
}

std::vector<PointCloud> delft_clouds() { return {dsmplan::read_las(kDelft1), dsmplan::read_las(kDelft2)}; }

// Brute force: every kept point goes to the cell floor((x-x0)/res), floor((y0-y)/res) of the
// grid's lattice; a cell's height is the sorted middle (or the maximum) of its points.
void expect_brute_force_grid(const std::vector<PointCloud>& clouds, const GridPointsOptions& options,
                             const Grid& grid) {
  const double res = options.resolution;
  const std::set<int> dropped(options.drop_classes.begin(), options.drop_classes.end());
  std::vector<std::vector<double>> cells(grid.cells());
  size_t kept = 0, assigned = 0;
  double min_x = INFINITY, max_x = -INFINITY, min_y = INFINITY, max_y = -INFINITY;
  for (const PointCloud& cloud : clouds) {
    for (size_t i = 0; i < cloud.size(); ++i) {
      if (dropped.count(cloud.classification[i])) continue;
      ++kept;
      min_x = std::min(min_x, cloud.x[i]), max_x = std::max(max_x, cloud.x[i]);
      min_y = std::min(min_y, cloud.y[i]), max_y = std::max(max_y, cloud.y[i]);
      const double col = std::floor((cloud.x[i] - grid.x0) / res), row = std::floor((grid.y0 - cloud.y[i]) / res);
      if (col < 0 || row < 0 || col >= grid.width || row >= grid.height) continue;
      cells[grid.index(static_cast<int>(col), static_cast<int>(row))].push_back(cloud.z[i]);
      ++assigned;
    }
  }
  EXPECT_EQ(assigned, kept) << "points outside the grid";

  // Aligned to multiples of the resolution and just covering the kept points.
  EXPECT_EQ(grid.cell_x, res);
  EXPECT_EQ(grid.cell_y, res);
  EXPECT_EQ(grid.x0, std::floor(min_x / res) * res);
  EXPECT_EQ(grid.y0, std::ceil(max_y / res) * res);
  EXPECT_LT(max_x, grid.x1());
  EXPECT_GE(max_x, grid.x1() - res);
  EXPECT_GT(min_y, grid.y1());
  EXPECT_LE(min_y, grid.y1() + res);

  size_t mismatches = 0, holes = 0;
  std::string first;
  for (size_t c = 0; c < cells.size(); ++c) {
    std::vector<double>& z = cells[c];
    float expected = Grid::nodata;
    if (!z.empty()) {
      std::sort(z.begin(), z.end());
      const size_t n = z.size();
      if (options.fusion == Fusion::Max)
        expected = static_cast<float>(z.back());
      else
        expected = static_cast<float>(n % 2 ? z[n / 2] : (z[n / 2 - 1] + z[n / 2]) / 2);
    }
    holes += z.empty();
    const bool same = std::isnan(expected) ? std::isnan(grid.z[c]) : grid.z[c] == expected;
    if (!same && mismatches++ == 0)
      first = "cell " + std::to_string(c % grid.width) + "," + std::to_string(c / grid.width) + ": got " +
              std::to_string(grid.z[c]) + ", expected " + std::to_string(expected) + " from " +
              std::to_string(z.size()) + " points";
  }
  EXPECT_EQ(mismatches, 0u) << "first: " << first;
  EXPECT_GT(holes, 0u) << "the Delft tiles have canals without returns";
}

}  // namespace

// ---- the real Delft AHN3 tiles ------------------------------------------------------------

TEST(DelftLas, ReadsEveryPointAsTheHeaderAndRecordsSay) {
  const std::map<std::string, uint32_t> expected_counts = {{kDelft1, 640510}, {kDelft2, 208432}};
  for (const auto& [path, expected_count] : expected_counts) {
    SCOPED_TRACE(path);
    const std::string bytes = testkit::read_file(path);
    const RawHeader h = raw_header(bytes);
    ASSERT_EQ(h.count, expected_count);
    ASSERT_EQ(h.format, 1);
    ASSERT_EQ(h.record_length, 28);

    const PointCloud cloud = dsmplan::read_las(path);
    ASSERT_EQ(cloud.size(), h.count);
    ASSERT_EQ(cloud.classification.size(), h.count);
    EXPECT_FALSE(cloud.crs.known()) << "the AHN3 crops carry no CRS record";

    // The header's bounds, written by LAStools, are the extremes of the scaled records.
    const auto [min_x, max_x] = std::minmax_element(cloud.x.begin(), cloud.x.end());
    const auto [min_y, max_y] = std::minmax_element(cloud.y.begin(), cloud.y.end());
    const auto [min_z, max_z] = std::minmax_element(cloud.z.begin(), cloud.z.end());
    EXPECT_DOUBLE_EQ(*min_x, h.min[0]);
    EXPECT_DOUBLE_EQ(*max_x, h.max[0]);
    EXPECT_DOUBLE_EQ(*min_y, h.min[1]);
    EXPECT_DOUBLE_EQ(*max_y, h.max[1]);
    EXPECT_DOUBLE_EQ(*min_z, h.min[2]);
    EXPECT_DOUBLE_EQ(*max_z, h.max[2]);
    EXPECT_EQ(cloud.min_x, *min_x);
    EXPECT_EQ(cloud.max_x, *max_x);
    EXPECT_EQ(cloud.min_y, *min_y);
    EXPECT_EQ(cloud.max_y, *max_y);
    EXPECT_EQ(cloud.min_z, *min_z);
    EXPECT_EQ(cloud.max_z, *max_z);

    std::map<int, size_t> raw_classes, read_classes;
    size_t coordinate_mismatches = 0;
    for (size_t i = 0; i < h.count; ++i) {
      ++raw_classes[raw_class(bytes, h, i)];
      ++read_classes[cloud.classification[i]];
      if (i % 97 == 0) {
        coordinate_mismatches += std::abs(cloud.x[i] - raw_coordinate(bytes, h, i, 0)) > 1e-9;
        coordinate_mismatches += std::abs(cloud.y[i] - raw_coordinate(bytes, h, i, 1)) > 1e-9;
        coordinate_mismatches += std::abs(cloud.z[i] - raw_coordinate(bytes, h, i, 2)) > 1e-9;
      }
    }
    EXPECT_EQ(coordinate_mismatches, 0u);
    EXPECT_EQ(read_classes, raw_classes);
    for (const auto& [cls, count] : read_classes) EXPECT_TRUE(std::set<int>({1, 2, 6, 9, 26}).count(cls)) << cls;
  }
}

TEST(DelftLas, ProgressIsMonotonicEndsAtOneAndCanCancel) {
  std::vector<double> seen;
  dsmplan::read_las(kDelft1, [&](double f) {
    seen.push_back(f);
    return true;
  });
  ASSERT_FALSE(seen.empty());
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(seen.back(), 1.0);
  EXPECT_THROW(dsmplan::read_las(kDelft1, [](double) { return false; }), dsmplan::Cancelled);
}

TEST(DelftGrid, MedianAtHalfMetreMatchesBruteForceAndKeepsCanalHoles) {
  const std::vector<PointCloud> clouds = delft_clouds();
  GridPointsOptions options;
  options.resolution = 0.5;
  std::vector<double> seen;
  const Grid grid = dsmplan::grid_points(clouds, options, [&](double f) {
    seen.push_back(f);
    return true;
  });
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.back(), 1.0);

  // The lattice computed by hand from the header bounds (x 84808.3-85072.299, y 447412.8-447641.299).
  EXPECT_EQ(grid.x0, 84808.0);
  EXPECT_EQ(grid.y0, 447641.5);
  EXPECT_EQ(grid.width, 529);
  EXPECT_EQ(grid.height, 458);
  expect_brute_force_grid(clouds, options, grid);

  // A 40 x 40 window across the canal in the north of tile 1: water returns nothing, and the
  // gridding must leave those cells empty rather than invent heights.
  size_t holes = 0, valid = 0;
  for (int row = 0; row < 40; ++row)
    for (int col = 240; col < 280; ++col) (grid.valid(col, row) ? valid : holes)++;
  EXPECT_GT(holes, 400u);   // 499 when written
  EXPECT_GT(valid, 1000u);  // 1101
}

TEST(DelftGrid, MaxMatchesBruteForce) {
  const std::vector<PointCloud> clouds = delft_clouds();
  GridPointsOptions options;
  options.resolution = 0.5;
  options.fusion = Fusion::Max;
  expect_brute_force_grid(clouds, options, dsmplan::grid_points(clouds, options));
}

TEST(DelftGrid, DroppingBuildingsAndWaterMatchesBruteForce) {
  const std::vector<PointCloud> clouds = delft_clouds();
  GridPointsOptions options;
  options.resolution = 1.0;
  options.drop_classes = {6, 9};
  const Grid grid = dsmplan::grid_points(clouds, options);
  expect_brute_force_grid(clouds, options, grid);
  options.drop_classes = {};
  const Grid all = dsmplan::grid_points(clouds, options);
  EXPECT_GT(valid_cells(all), valid_cells(grid));
}

// ---- a DTM: --classes 2, the ground ---------------------------------------------------------

namespace {

// A single-band GeoTIFF as GDAL reads it (the oracle's reader, not dsmplan's): geotransform and
// heights, its nodata value as NaN.
struct TiffGrid {
  int width = 0, height = 0;
  double gt[6] = {};
  std::vector<float> z;
  float at(int col, int row) const { return z[static_cast<size_t>(row) * width + col]; }
};

TiffGrid read_tiff(const std::string& path) {
  TiffGrid grid;
  GDALDatasetH dataset = GDALOpen(path.c_str(), GA_ReadOnly);
  EXPECT_NE(dataset, nullptr) << path;
  if (!dataset) return grid;
  grid.width = GDALGetRasterXSize(dataset);
  grid.height = GDALGetRasterYSize(dataset);
  GDALGetGeoTransform(dataset, grid.gt);
  GDALRasterBandH band = GDALGetRasterBand(dataset, 1);
  int has_nodata = 0;
  const double nodata = GDALGetRasterNoDataValue(band, &has_nodata);
  grid.z.resize(static_cast<size_t>(grid.width) * grid.height);
  EXPECT_EQ(GDALRasterIO(band, GF_Read, 0, 0, grid.width, grid.height, grid.z.data(), grid.width, grid.height,
                         GDT_Float32, 0, 0),
            CE_None);
  GDALClose(dataset);
  if (has_nodata)
    for (float& v : grid.z)
      if (v == static_cast<float>(nodata)) v = NAN;
  return grid;
}

}  // namespace

TEST(DelftGrid, ClassesTwoIsTheGroundMedianAndNeverAboveTheMaxDsm) {
  testkit::TempDir dir;
  const std::string dtm_path = dir.path("dtm.tif"), dsm_path = dir.path("dsm.tif");
  const auto dtm_run = testkit::run_cli(
      {"grid", kDelft1, kDelft2, "--crs", "EPSG:28992", "--res", "0.5", "--classes", "2", "-o", dtm_path, "-q"});
  ASSERT_EQ(dtm_run.exit_code, 0) << dtm_run.err;
  const auto dsm_run = testkit::run_cli({"grid", kDelft1, kDelft2, "--crs", "EPSG:28992", "--res", "0.5", "--fusion",
                                         "max", "--keep-all-classes", "-o", dsm_path, "-q"});
  ASSERT_EQ(dsm_run.exit_code, 0) << dsm_run.err;
  const TiffGrid dtm = read_tiff(dtm_path), dsm = read_tiff(dsm_path);
  ASSERT_GT(dtm.width, 0);
  ASSERT_GT(dsm.width, 0);

  // Brute force: the class-2 points (read by dsmplan's LAS reader, whose records the tests above
  // check byte by byte), cells and medians computed here.
  const double res = 0.5;
  std::vector<std::array<double, 3>> ground;
  for (const PointCloud& cloud : delft_clouds())
    for (size_t i = 0; i < cloud.size(); ++i)
      if (cloud.classification[i] == 2) ground.push_back({cloud.x[i], cloud.y[i], cloud.z[i]});
  ASSERT_GT(ground.size(), 250000u);  // 195,988 + 87,130 ground returns
  double min_x = INFINITY, max_y = -INFINITY;
  for (const auto& p : ground) min_x = std::min(min_x, p[0]), max_y = std::max(max_y, p[1]);
  const double x0 = std::floor(min_x / res) * res, y0 = std::ceil(max_y / res) * res;
  EXPECT_EQ(dtm.gt[0], x0);
  EXPECT_EQ(dtm.gt[3], y0);
  EXPECT_EQ(dtm.gt[1], res);
  EXPECT_EQ(dtm.gt[5], -res);
  std::map<std::pair<long, long>, std::vector<double>> cells;
  for (const auto& p : ground)
    cells[{static_cast<long>(std::floor((p[0] - x0) / res)), static_cast<long>(std::floor((y0 - p[1]) / res))}]
        .push_back(p[2]);
  size_t mismatches = 0, outside = 0, valid = 0;
  std::string first;
  for (auto& [cell, z] : cells) {
    const auto [col, row] = cell;
    if (col < 0 || row < 0 || col >= dtm.width || row >= dtm.height) {
      ++outside;
      continue;
    }
    std::sort(z.begin(), z.end());
    const size_t n = z.size();
    const float median = static_cast<float>(n % 2 ? z[n / 2] : (z[n / 2 - 1] + z[n / 2]) / 2);
    if (dtm.at(int(col), int(row)) != median && mismatches++ == 0)
      first = "cell " + std::to_string(col) + "," + std::to_string(row) + ": " +
              std::to_string(dtm.at(int(col), int(row))) + " vs " + std::to_string(median);
  }
  for (float z : dtm.z) valid += !std::isnan(z);
  EXPECT_EQ(outside, 0u);
  EXPECT_EQ(mismatches, 0u) << first;
  EXPECT_EQ(valid, cells.size()) << "a DTM cell is valid exactly where ground points fall";

  // The ground under the highest return of every class: never above it, well below on roofs.
  const double dc = (dtm.gt[0] - dsm.gt[0]) / res, dr = (dsm.gt[3] - dtm.gt[3]) / res;
  ASSERT_EQ(dc, std::round(dc));
  ASSERT_EQ(dr, std::round(dr));
  size_t compared = 0, above = 0, far_below = 0;
  for (int row = 0; row < dtm.height; ++row)
    for (int col = 0; col < dtm.width; ++col) {
      const int c = col + int(dc), r = row + int(dr);
      ASSERT_TRUE(c >= 0 && r >= 0 && c < dsm.width && r < dsm.height) << "the DSM covers every ground point";
      const float g = dtm.at(col, row), top = dsm.at(c, r);
      if (std::isnan(g) || std::isnan(top)) continue;
      ++compared;
      above += g > top;
      far_below += g < top - 3;
    }
  EXPECT_EQ(above, 0u);
  EXPECT_GT(compared, 100000u);
  EXPECT_GT(far_below, 100u) << "trees and buildings stand above the ground";
}

// ---- synthetic LAS: every version and point format ----------------------------------------

TEST(SyntheticLas, EveryVersionAndPointFormatReadsBack) {
  const int last_format[5] = {1, 1, 3, 5, 10};  // the formats each LAS 1.x defines
  testkit::TempDir dir;
  for (int minor = 0; minor <= 4; ++minor) {
    for (int format = 0; format <= last_format[minor]; ++format) {
      for (int extra : {0, 5}) {
        SCOPED_TRACE("LAS 1." + std::to_string(minor) + " format " + std::to_string(format) + " extra bytes " +
                     std::to_string(extra));
        LasSpec spec;
        spec.minor = minor;
        spec.format = format;
        spec.extra_bytes = extra;
        // Formats 6-10 give the class a whole byte; before, it has 5 bits next to 3 flags.
        spec.points = synthetic_points(format < 6 ? std::vector<uint8_t>{0, 1, 2, 6, 7, 18, 31}
                                                  : std::vector<uint8_t>{0, 1, 2, 7, 18, 64, 200, 255});
        const std::string path = dir.path("synthetic.las");
        const std::string bytes = las_bytes(spec);
        testkit::write_file(path, bytes);
        ASSERT_EQ(get<uint16_t>(bytes, 105), kRecordLength[format] + extra);

        const PointCloud cloud = dsmplan::read_las(path);
        ASSERT_EQ(cloud.size(), spec.points.size());
        EXPECT_FALSE(cloud.crs.known());
        for (size_t i = 0; i < spec.points.size(); ++i) {
          const SynthPoint& p = spec.points[i];
          EXPECT_NEAR(cloud.x[i], p.x, spec.scale[0] / 2 + 1e-9) << i;
          EXPECT_NEAR(cloud.y[i], p.y, spec.scale[1] / 2 + 1e-9) << i;
          EXPECT_NEAR(cloud.z[i], p.z, spec.scale[2] / 2 + 1e-9) << i;
          EXPECT_EQ(cloud.classification[i], p.cls) << i;
        }
        EXPECT_NEAR(cloud.min_x, get<double>(bytes, 187), spec.scale[0] / 2 + 1e-9);
        EXPECT_NEAR(cloud.max_y, get<double>(bytes, 195), spec.scale[1] / 2 + 1e-9);
        EXPECT_NEAR(cloud.min_z, get<double>(bytes, 219), spec.scale[2] / 2 + 1e-9);
      }
    }
  }
}

TEST(SyntheticLas, Las14UsesThe64BitCountWhenTheLegacyOneIsZero) {
  testkit::TempDir dir;
  LasSpec spec;
  spec.minor = 4;
  spec.format = 1;
  spec.legacy_count = false;
  spec.points = synthetic_points({2});
  std::string bytes = las_bytes(spec);
  ASSERT_EQ(get<uint32_t>(bytes, 107), 0u);
  testkit::write_file(dir.path("a.las"), bytes);
  EXPECT_EQ(dsmplan::read_las(dir.path("a.las")).size(), spec.points.size());

  put<uint32_t>(bytes, 107, 7);  // a legacy count that contradicts the 64-bit one
  testkit::write_file(dir.path("b.las"), bytes);
  expect_input_error([&] { dsmplan::read_las(dir.path("b.las")); }, dir.path("b.las"), "byte 247 (point count)");
}

TEST(SyntheticLas, CrsFromWktVlrEvlrAndGeoKeys) {
  const std::string wkt =
      "PROJCS[\"Amersfoort / RD New\",GEOGCS[\"Amersfoort\",DATUM[\"Amersfoort\",SPHEROID[\"Bessel 1841\","
      "6377397.155,299.1528128]],PRIMEM[\"Greenwich\",0],UNIT[\"degree\",0.0174532925199433]],"
      "PROJECTION[\"Oblique_Stereographic\"],UNIT[\"metre\",1],AUTHORITY[\"EPSG\",\"28992\"]]";
  // GeoKeyDirectory: version 1.1.0, then (key, location, count, value) entries.
  auto keys = [](std::vector<std::array<uint16_t, 2>> entries) {
    std::vector<uint16_t> directory = {1, 1, 0, static_cast<uint16_t>(entries.size() + 1), 1024, 0, 1, 1};
    for (auto [key, value] : entries) directory.insert(directory.end(), {key, 0, 1, value});
    return directory;
  };
  struct Case {
    std::string name;
    int minor;
    std::string wkt;
    bool wkt_as_evlr;
    std::vector<uint16_t> geokeys;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"WKT VLR", 2, wkt, false, {}, wkt},
      {"WKT VLR in 1.4", 4, wkt, false, {}, wkt},
      {"WKT EVLR", 4, wkt, true, {}, wkt},
      {"WKT wins over GeoKeys", 4, wkt, false, keys({{3072, 32632}}), wkt},
      {"projected + vertical", 2, "", false, keys({{3072, 28992}, {4096, 5709}}), "EPSG:28992+5709"},
      {"projected only", 3, "", false, keys({{3072, 25832}}), "EPSG:25832"},
      {"geographic only", 1, "", false, keys({{2048, 4326}}), "EPSG:4326"},
      {"user-defined projected, known geographic", 2, "", false, keys({{3072, 32767}, {2048, 4258}}), "EPSG:4258"},
      {"user-defined vertical", 2, "", false, keys({{3072, 28992}, {4096, 32767}}), "EPSG:28992"},
      {"everything user-defined", 2, "", false, keys({{3072, 32767}, {2048, 32767}}), ""},
  };
  testkit::TempDir dir;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    LasSpec spec;
    spec.minor = c.minor;
    spec.wkt = c.wkt;
    spec.wkt_as_evlr = c.wkt_as_evlr;
    spec.geokeys = c.geokeys;
    spec.points = synthetic_points({2});
    testkit::write_file(dir.path("crs.las"), las_bytes(spec));
    const PointCloud cloud = dsmplan::read_las(dir.path("crs.las"));
    EXPECT_EQ(cloud.crs.definition, c.expected);
    EXPECT_EQ(cloud.size(), spec.points.size());
  }
}

TEST(SyntheticLas, DefaultGriddingDropsNoiseClassesSevenAndEighteen) {
  LasSpec spec;
  spec.minor = 4;
  spec.format = 6;
  spec.offset[0] = spec.offset[1] = 0;
  // res 1: ground/other points in cells (0,0) and (2,0); only noise in (1,0) and far away.
  spec.points = {{0.5, 0.5, 1, 2},    {0.5, 0.5, 2, 2},   {0.5, 0.5, 3, 2}, {0.5, 0.5, 2.5, 200}, {0.5, 0.5, 100, 7},
                 {0.5, 0.5, -50, 18}, {1.5, 0.5, 99, 18}, {2.5, 0.5, 4, 1}, {50, 50, 500, 7}};
  testkit::TempDir dir;
  testkit::write_file(dir.path("noise.las"), las_bytes(spec));
  const PointCloud cloud = dsmplan::read_las(dir.path("noise.las"));
  ASSERT_EQ(cloud.size(), spec.points.size());
  EXPECT_EQ(cloud.classification[5], 18);

  GridPointsOptions options;
  const Grid grid = dsmplan::grid_points({cloud}, options);
  ASSERT_EQ(grid.width, 3);
  ASSERT_EQ(grid.height, 1);
  EXPECT_EQ(grid.x0, 0);
  EXPECT_EQ(grid.y0, 1);
  EXPECT_FLOAT_EQ(grid.at(0, 0), 2.25f);  // median of 1, 2, 2.5, 3
  EXPECT_TRUE(std::isnan(grid.at(1, 0)));
  EXPECT_FLOAT_EQ(grid.at(2, 0), 4.0f);

  options.drop_classes = {};
  const Grid everything = dsmplan::grid_points({cloud}, options);
  EXPECT_EQ(everything.width, 51);
  EXPECT_EQ(everything.height, 50);
  EXPECT_FLOAT_EQ(everything.at(0, 49), 2.25f);  // median of -50, 1, 2, 2.5, 3, 100
  EXPECT_FLOAT_EQ(everything.at(1, 49), 99.0f);
  EXPECT_FLOAT_EQ(everything.at(50, 0), 500.0f);
}

// ---- gridding rules on hand-made clouds ---------------------------------------------------

namespace {
PointCloud cloud_of(const std::vector<SynthPoint>& points, const std::string& crs = "") {
  PointCloud cloud;
  for (const SynthPoint& p : points) cloud.add(p.x, p.y, p.z, p.cls);
  cloud.crs.definition = crs;
  return cloud;
}
}  // namespace

TEST(PointGrid, PointsOnWestAndNorthEdgesBelongToThatCell) {
  GridPointsOptions options;
  // max_y = 2 is a multiple of the resolution: that point lies on row 0's north edge.
  Grid grid = dsmplan::grid_points({cloud_of({{0, 0, 1, 2}, {1, 1, 2, 2}, {2, 2, 3, 2}})}, options);
  ASSERT_EQ(grid.width, 3);
  ASSERT_EQ(grid.height, 3);
  EXPECT_EQ(grid.x0, 0);
  EXPECT_EQ(grid.y0, 2);
  EXPECT_EQ(grid.at(2, 0), 3.0f);
  EXPECT_EQ(grid.at(1, 1), 2.0f);
  EXPECT_EQ(grid.at(0, 2), 1.0f);
  EXPECT_EQ(valid_cells(grid), 3u);

  // Negative coordinates and a fractional resolution follow the same rule.
  options.resolution = 0.25;
  grid = dsmplan::grid_points({cloud_of({{-1.0, -0.5, 7, 2}, {-0.9, -0.6, 8, 2}, {-0.76, -0.74, 9, 2}})}, options);
  EXPECT_EQ(grid.x0, -1.0);
  EXPECT_EQ(grid.y0, -0.5);
  ASSERT_EQ(grid.width, 1);
  ASSERT_EQ(grid.height, 1);
  EXPECT_EQ(grid.at(0, 0), 8.0f);
  grid = dsmplan::grid_points({cloud_of({{-1.0, -0.5, 7, 2}, {-0.75, -0.75, 9, 2}})}, options);
  ASSERT_EQ(grid.width, 2);
  ASSERT_EQ(grid.height, 2);
  EXPECT_EQ(grid.at(0, 0), 7.0f);
  EXPECT_EQ(grid.at(1, 1), 9.0f);
  EXPECT_TRUE(std::isnan(grid.at(1, 0)));
}

TEST(PointGrid, MedianOfEvenCountIsTheMeanOfTheMiddlePairAndMaxIsTheMaximum) {
  const std::vector<PointCloud> clouds = {
      cloud_of({{0.1, 0.9, 4, 2}, {0.2, 0.8, 1, 2}, {0.3, 0.7, 3, 2}}),
      cloud_of({{0.4, 0.6, 2, 2}, {1.5, 0.5, 5, 2}, {1.5, 0.5, 1, 2}, {1.5, 0.5, 3, 2}})};
  GridPointsOptions options;
  Grid grid = dsmplan::grid_points(clouds, options);
  ASSERT_EQ(grid.width, 2);
  EXPECT_EQ(grid.at(0, 0), 2.5f);
  EXPECT_EQ(grid.at(1, 0), 3.0f);
  options.fusion = Fusion::Max;
  grid = dsmplan::grid_points(clouds, options);
  EXPECT_EQ(grid.at(0, 0), 4.0f);
  EXPECT_EQ(grid.at(1, 0), 5.0f);
}

// The up-front memory refusal counts what the caller holds beside the grid (the GeoTIFF writer's
// GDAL cache, for dsmplan grid): a grid that fits alone is refused when the two together do not.
TEST(PointGrid, MemoryRefusalCountsTheWritersBuffersToo) {
  const PointCloud cloud = cloud_of({{0.5, 0.5, 1, 2}, {3.5, 0.5, 1, 2}});
  GridPointsOptions options;
  EXPECT_NO_THROW(dsmplan::grid_points({cloud}, options));
  options.other_bytes = dsmplan::machine_memory_bytes();  // with the grid's few bytes: more than the machine
  try {
    dsmplan::grid_points({cloud}, options);
    ADD_FAILURE() << "the writer's buffers were not counted";
  } catch (const dsmplan::ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("needs about"), std::string::npos) << e.what();
  }
  // GDAL's cache, as the writer will use it, is capped at an eighth of the machine's memory.
  EXPECT_GT(dsmplan::geotiff_buffer_bytes(), 0);
  EXPECT_LE(dsmplan::geotiff_buffer_bytes(), dsmplan::machine_memory_bytes() / 8 + 1);
}

TEST(PointGrid, CrsMustAgreeAndTheKnownOneIsKept) {
  GridPointsOptions options;
  const PointCloud unknown = cloud_of({{0.5, 0.5, 1, 2}});
  const PointCloud rd = cloud_of({{1.5, 0.5, 2, 2}}, "EPSG:28992");
  EXPECT_EQ(dsmplan::grid_points({unknown, rd, rd}, options).crs.definition, "EPSG:28992");
  EXPECT_FALSE(dsmplan::grid_points({unknown}, options).crs.known());
  EXPECT_THROW(dsmplan::grid_points({rd, cloud_of({{0, 0, 0, 2}}, "EPSG:25832")}, options), dsmplan::ArgumentError);
}

TEST(PointGrid, RejectsBadResolutionsAndEmptyInput) {
  const PointCloud cloud = cloud_of({{0.5, 0.5, 1, 2}, {3.5, 0.5, 1, 7}});
  GridPointsOptions options;
  for (double res : std::vector<double>{0.0, -1.0, NAN, INFINITY}) {
    options.resolution = res;
    try {
      dsmplan::grid_points({cloud}, options);
      ADD_FAILURE() << res;
    } catch (const dsmplan::ArgumentError& error) {
      EXPECT_EQ(error.field(), "resolution") << error.what();
    }
  }
  options.resolution = 1e-6;  // 3 million x 1 cells are fine, a million million are not
  EXPECT_NEAR(dsmplan::grid_points({cloud}, {1e-6, Fusion::Median, {}}).width, 3000001, 1);
  EXPECT_THROW(dsmplan::grid_points({cloud_of({{0, 0, 1, 2}, {1000, 1000, 1, 2}})}, options), dsmplan::ArgumentError);
  options.resolution = 1e-310;  // 85000 / res overflows to infinity
  EXPECT_THROW(dsmplan::grid_points({cloud_of({{85000, 447000, 1, 2}})}, options), dsmplan::ArgumentError);

  options.resolution = 1;
  options.drop_classes = {2, 7};
  try {
    dsmplan::grid_points({cloud}, options);
    ADD_FAILURE();
  } catch (const dsmplan::InputError& error) {
    EXPECT_NE(std::string(error.what()).find("no points left"), std::string::npos) << error.what();
  }
  EXPECT_THROW(dsmplan::grid_points({PointCloud{}}, options), dsmplan::InputError);
  EXPECT_THROW(dsmplan::grid_points({}, options), dsmplan::InputError);
  options.drop_classes = {300};
  EXPECT_THROW(dsmplan::grid_points({cloud}, options), dsmplan::ArgumentError);
}

TEST(PointGrid, CancelStopsTheGridding) {
  const PointCloud cloud = cloud_of({{0.5, 0.5, 1, 2}});
  EXPECT_THROW(dsmplan::grid_points({cloud}, {}, [](double) { return false; }), dsmplan::Cancelled);
}

TEST(PointGrid, ClassesKeepOnlyTheListedAndContradictionsAreRefused) {
  const PointCloud cloud = cloud_of(
      {{0.5, 0.5, 1, 2}, {0.5, 0.5, 9, 6}, {1.5, 0.5, 30, 6}, {2.5, 0.5, 2, 2}, {2.5, 0.5, 4, 9}, {3.5, 0.5, -7, 7}});
  GridPointsOptions options;
  options.keep_classes = {2};
  Grid grid = dsmplan::grid_points({cloud}, options);
  ASSERT_EQ(grid.width, 3);  // x 0.5 .. 2.5: the building and noise cells east of it are gone
  EXPECT_EQ(grid.at(0, 0), 1.0f);
  EXPECT_TRUE(std::isnan(grid.at(1, 0)));
  EXPECT_EQ(grid.at(2, 0), 2.0f);
  options.keep_classes = {2, 9};
  grid = dsmplan::grid_points({cloud}, options);
  EXPECT_EQ(grid.at(2, 0), 3.0f);  // median of 2 and 4
  // A noise class asked for by name: the default drop list has to go first.
  options.keep_classes = {7};
  EXPECT_THROW(dsmplan::grid_points({cloud}, options), dsmplan::ArgumentError);
  options.drop_classes = {};
  grid = dsmplan::grid_points({cloud}, options);
  ASSERT_EQ(grid.width, 1);
  EXPECT_EQ(grid.at(0, 0), -7.0f);
  options.keep_classes = {2};
  options.drop_classes = {2};
  try {
    dsmplan::grid_points({cloud}, options);
    ADD_FAILURE() << "class 2 both kept and dropped";
  } catch (const dsmplan::ArgumentError& error) {
    EXPECT_NE(std::string(error.what()).find("both kept"), std::string::npos) << error.what();
  }
  options.drop_classes = {};
  options.keep_classes = {300};
  EXPECT_THROW(dsmplan::grid_points({cloud}, options), dsmplan::ArgumentError);
  options.keep_classes = {3};
  try {
    dsmplan::grid_points({cloud}, options);
    ADD_FAILURE() << "no class-3 point";
  } catch (const dsmplan::InputError& error) {
    EXPECT_NE(std::string(error.what()).find("no point of classes 3"), std::string::npos) << error.what();
  }

  // The command line: one line for each contradiction, no output left.
  testkit::TempDir dir;
  const std::string xyz = dir.path("points.xyz");
  testkit::write_file(xyz, "0.5 0.5 1 2\n0.5 0.5 9 6\n2.5 0.5 2 2\n");
  for (const std::vector<std::string>& extra :
       {std::vector<std::string>{"--keep-all-classes"}, std::vector<std::string>{"--drop-classes", "6,2"}}) {
    std::vector<std::string> args{"grid",      xyz, "--crs", "EPSG:28992",        "--res", "1",
                                  "--classes", "2", "-o",    dir.path("out.tif"), "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto result = testkit::run_cli(args);
    EXPECT_NE(result.exit_code, 0) << extra[0];
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_NE(result.err.find("--classes"), std::string::npos) << result.err;
    EXPECT_FALSE(std::filesystem::exists(dir.path("out.tif")));
  }
  // No contradiction: --drop-classes of another class is redundant, not refused.
  const auto fine = testkit::run_cli({"grid", xyz, "--crs", "EPSG:28992", "--res", "1", "--classes", "2",
                                      "--drop-classes", "7", "-o", dir.path("out.tif"), "-q"});
  EXPECT_EQ(fine.exit_code, 0) << fine.err;
  const TiffGrid written = read_tiff(dir.path("out.tif"));
  ASSERT_EQ(written.width, 3);
  EXPECT_EQ(written.at(0, 0), 1.0f);
  EXPECT_EQ(written.at(2, 0), 2.0f);
}

TEST(PointGrid, PointsInFeetAreRefusedNamingTheUnit) {
  // The same XYZ taken as NAD83 / Virginia North (ftUS) by --crs, and by a LAS's GeoTIFF keys.
  testkit::TempDir dir;
  const std::string xyz = dir.path("points_ft.xyz");
  testkit::write_file(xyz, "11800000 7000000 300 2\n11800003 7000003 301 2\n");
  const auto result =
      testkit::run_cli({"grid", xyz, "--crs", "EPSG:2283", "--res", "3", "-o", dir.path("dsm.tif"), "-q"});
  EXPECT_NE(result.exit_code, 0);
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
  for (const char* phrase : {"points_ft.xyz", "US survey foot", "0.3048006 m", "metres"})
    EXPECT_NE(result.err.find(phrase), std::string::npos) << phrase << " in " << result.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif")));
  // In metres (UTM 18N) the same file grids.
  EXPECT_EQ(
      testkit::run_cli({"grid", xyz, "--crs", "EPSG:32618", "--res", "3", "-o", dir.path("dsm.tif"), "-q"}).exit_code,
      0);

  LasSpec spec;
  spec.offset[0] = 11800000, spec.offset[1] = 7000000;
  spec.points = {{11800000, 7000000, 300, 2}, {11800003, 7000003, 301, 2}};
  spec.geokeys = {1, 1, 0, 2, 1024, 0, 1, 1, 3072, 0, 1, 2283};  // projected: EPSG:2283
  testkit::write_file(dir.path("points_ft.las"), las_bytes(spec));
  dsmplan::GridOptions options;
  options.inputs = {dir.path("points_ft.las")};
  options.output = dir.path("dsm_las.tif");
  options.grid.resolution = 3;
  try {
    dsmplan::grid_to_geotiff(options);
    ADD_FAILURE() << "a LAS in feet was gridded";
  } catch (const dsmplan::InputError& error) {
    EXPECT_NE(std::string(error.what()).find("US survey foot"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("pdal translate"), std::string::npos) << error.what();
  }
}

// ---- bad input ----------------------------------------------------------------------------

TEST(BadInput, DamagedDelftCopiesGiveOneLineInputErrorsNamingTheFileAndField) {
  testkit::TempDir dir;
  const std::string original = testkit::read_file(kDelft2);
  const RawHeader h = raw_header(original);
  auto damaged = [&](const std::string& name, const std::string& bytes) {
    const std::string path = dir.path(name);
    testkit::write_file(path, bytes);
    return path;
  };
  auto expect_las_error = [&](const std::string& path, const std::string& fragment) {
    SCOPED_TRACE(path);
    expect_input_error([&] { dsmplan::read_las(path); }, path, fragment);
  };

  expect_las_error(damaged("a-100-bytes.las", original.substr(0, 100)), "truncated");
  expect_las_error(
      damaged("b-half-points.las", original.substr(0, h.point_offset + h.count / 2 * h.record_length + 13)),
      "byte 107 (point count)");
  std::string bytes = original;
  put<uint32_t>(bytes, 107, h.count + 1);
  expect_las_error(damaged("c-count.las", bytes), "byte 107 (point count)");
  bytes = original;
  bytes[3] = 'X';
  expect_las_error(damaged("d-signature.las", bytes), "byte 0 (signature)");
  bytes = original;
  bytes[104] = static_cast<char>(h.format | 0x80);
  // The LASzip bit without the VLR that says how the points were compressed (issue 20: LAZ is
  // read now; laz_test covers real and damaged LAZ files).
  expect_las_error(damaged("e-laz.las", bytes), "LAZ-compressed, but the file has no 'laszip encoded' VLR");
  bytes[104] = static_cast<char>(h.format | 0x40);
  expect_las_error(damaged("e-laz-bit6.laz", bytes), "no 'laszip encoded' VLR");

  const std::string xyz = damaged("f-bad-line.xyz", "85000.1 447500.2 1.5\n85000.2 447500.3 1.6\nabc 1 2\n");
  expect_input_error([&] { dsmplan::read_xyz(xyz); }, xyz, "line 3: expected 'x y z [class]', got 'abc 1 2'");
  const std::string nan = damaged("g-nan.xyz", "85000.1 447500.2 1.5\n85000.2 nan 1.6\n");
  expect_input_error([&] { dsmplan::read_xyz(nan); }, nan, "line 2");
  expect_input_error([&] { dsmplan::read_points(nan); }, nan, "'nan' is not a finite number");
}

TEST(BadInput, LyingHeaderFieldsAreNamed) {
  testkit::TempDir dir;
  LasSpec spec;
  spec.points = synthetic_points({2, 6});
  const std::string good = las_bytes(spec);
  struct Case {
    std::string field;
    std::function<void(std::string&)> damage;
  };
  const std::vector<Case> cases = {
      {"byte 24 (version)", [](std::string& b) { b[24] = 2; }},
      {"byte 94 (header size)", [](std::string& b) { put<uint16_t>(b, 94, 200); }},
      {"byte 96 (offset to point data)", [](std::string& b) { put<uint32_t>(b, 96, 100); }},
      {"byte 96 (offset to point data)",
       [&](std::string& b) { put<uint32_t>(b, 96, static_cast<uint32_t>(b.size() + 1)); }},
      {"byte 104 (point data format)", [](std::string& b) { b[104] = 11; }},
      {"byte 105 (point record length)", [](std::string& b) { put<uint16_t>(b, 105, 27); }},
      {"byte 131 (x scale factor)", [](std::string& b) { put<double>(b, 131, 0.0); }},
      {"byte 139 (y scale factor)", [](std::string& b) { put<double>(b, 139, NAN); }},
      {"byte 171 (z offset)", [](std::string& b) { put<double>(b, 171, INFINITY); }},
      {"VLR 2 at byte 290", [](std::string& b) { put<uint32_t>(b, 100, 2); }},
      {"VLR 1 at byte 227", [](std::string& b) { put<uint16_t>(b, 227 + 20, 1000); }},
      {"header", [](std::string& b) { b.resize(200); }},
      {"the file is empty", [](std::string& b) { b.clear(); }},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.field);
    std::string bytes = good;
    c.damage(bytes);
    const std::string path = dir.path("lying.las");
    testkit::write_file(path, bytes);
    expect_input_error([&] { dsmplan::read_las(path); }, path, c.field);
  }

  spec.minor = 4;
  spec.wkt = "GEOGCS[\"WGS 84\"]";
  spec.wkt_as_evlr = true;
  std::string bytes = las_bytes(spec);
  put<uint64_t>(bytes, bytes.size() - spec.wkt.size() - 3 - 40, 1000);  // the EVLR's payload length
  testkit::write_file(dir.path("evlr.las"), bytes);
  expect_input_error([&] { dsmplan::read_las(dir.path("evlr.las")); }, dir.path("evlr.las"), "EVLR 1");
  bytes = las_bytes(spec);
  put<uint64_t>(bytes, 235, 300);  // inside the point data
  testkit::write_file(dir.path("evlr-start.las"), bytes);
  expect_input_error([&] { dsmplan::read_las(dir.path("evlr-start.las")); }, dir.path("evlr-start.las"),
                     "byte 235 (start of first EVLR)");

  spec = LasSpec{};
  spec.geokeys = {1, 1, 0, 5, 3072, 0, 1, 28992};  // says 5 keys, holds 1
  spec.points = synthetic_points({2});
  testkit::write_file(dir.path("keys.las"), las_bytes(spec));
  expect_input_error([&] { dsmplan::read_las(dir.path("keys.las")); }, dir.path("keys.las"), "GeoKeyDirectory");

  const std::string missing = dir.path("missing.las");
  expect_input_error([&] { dsmplan::read_las(missing); }, missing, "cannot open");
  expect_input_error([&] { dsmplan::read_xyz(missing); }, missing, "cannot open");
  expect_input_error([&] { dsmplan::read_las(dir.path("")); }, dir.path(""), "directory");
}

TEST(BadInput, RandomlyDamagedHeadersNeverEscapeAsAnythingButInputError) {
  testkit::TempDir dir;
  LasSpec spec;
  spec.minor = 4;
  spec.format = 6;
  spec.wkt = "GEOGCS[\"WGS 84\"]";
  spec.geokeys = {1, 1, 0, 1, 3072, 0, 1, 28992};
  spec.points = synthetic_points({2, 6});
  const std::string good = las_bytes(spec);
  std::mt19937 random(20240611);
  const std::string path = dir.path("fuzz.las");
  size_t rejected = 0;
  for (int trial = 0; trial < 1500; ++trial) {
    std::string bytes = good;
    for (int k = 0; k < 3; ++k) {
      const size_t at = random() % 500;  // the header and the VLRs
      bytes[at] = static_cast<char>(random() % 4 == 0 ? 0xFF : random());
    }
    if (trial % 5 == 0) bytes.resize(random() % bytes.size());
    testkit::write_file(path, bytes);
    try {
      const PointCloud cloud = dsmplan::read_las(path);
      EXPECT_EQ(cloud.size(), cloud.classification.size());
    } catch (const dsmplan::InputError& error) {
      ++rejected;
      EXPECT_EQ(std::string(error.what()).find('\n'), std::string::npos);
    }
  }
  EXPECT_GT(rejected, 100u);
}

// ---- XYZ ----------------------------------------------------------------------------------

TEST(Xyz, RealPointsPrintedWithMillimetresReadBack) {
  const PointCloud las = dsmplan::read_las(kDelft1);
  testkit::TempDir dir;
  std::string text = "X Y Z Classification\n";
  char line[128];
  for (size_t i = 0; i < 1000; ++i) {
    if (i % 2)
      std::snprintf(line, sizeof line, "%.3f %.3f %.3f %d\n", las.x[i], las.y[i], las.z[i], las.classification[i]);
    else
      std::snprintf(line, sizeof line, "%.3f,%.3f,%.3f\n", las.x[i], las.y[i], las.z[i]);
    text += line;
  }
  testkit::write_file(dir.path("delft.xyz"), text);
  const PointCloud xyz = dsmplan::read_points(dir.path("delft.xyz"));
  ASSERT_EQ(xyz.size(), 1000u);
  EXPECT_FALSE(xyz.crs.known());
  for (size_t i = 0; i < 1000; ++i) {
    EXPECT_NEAR(xyz.x[i], las.x[i], 1e-6) << i;
    EXPECT_NEAR(xyz.y[i], las.y[i], 1e-6) << i;
    EXPECT_NEAR(xyz.z[i], las.z[i], 1e-6) << i;
    EXPECT_EQ(xyz.classification[i], i % 2 ? las.classification[i] : 0) << i;
  }
  EXPECT_EQ(xyz.min_x, *std::min_element(xyz.x.begin(), xyz.x.end()));
  EXPECT_EQ(xyz.max_z, *std::max_element(xyz.z.begin(), xyz.z.end()));
}

TEST(Xyz, HeaderCommentsBlankLinesSeparatorsAndLineEndings) {
  testkit::TempDir dir;
  testkit::write_file(dir.path("mixed.csv"),
                      "\xEF\xBB\xBF# exported by hand\r\nX;Y;Z;Class\r\n\r\n1.5,2.5,3.5,2\r\n4;5;6\n \t7\t8  9 18\n"
                      "# a comment\n+1e2 -2E-1 .5 255");
  const PointCloud cloud = dsmplan::read_points(dir.path("mixed.csv"));
  ASSERT_EQ(cloud.size(), 4u);
  EXPECT_EQ(cloud.x, (std::vector<double>{1.5, 4, 7, 100}));
  EXPECT_EQ(cloud.y, (std::vector<double>{2.5, 5, 8, -0.2}));
  EXPECT_EQ(cloud.z, (std::vector<double>{3.5, 6, 9, 0.5}));
  EXPECT_EQ(cloud.classification, (std::vector<uint8_t>{2, 0, 18, 255}));
  testkit::write_file(dir.path("empty.txt"), "");
  EXPECT_EQ(dsmplan::read_points(dir.path("empty.txt")).size(), 0u);
}

TEST(Xyz, BadLinesAreNamedByNumber) {
  testkit::TempDir dir;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"1 2\n", "line 1: expected"},
      {"1 2 3 4 5\n", "line 1: expected"},
      {"x1 y1 z1\n", "line 1: expected"},  // has digits, so not a column header
      {"1 2 3\nX Y Z\n", "line 2: expected"},
      {"1 2 3 256\n", "line 1: the class"},
      {"1 2 3 2.5\n", "line 1: the class"},
      {"1 2 3 -1\n", "line 1: the class"},
      {"\n\n# c\n1 2 inf\n", "line 4: 'inf' is not a finite number"},
      {"1 2 3\n1 2 1e999\n", "line 2: expected"},
      {"1 2 3\n1 2 0x10\n", "line 2: expected"},
      {"1 2 3\n" + std::string(200, '7') + " x\n", "..."},
      {"1 2 3\n" + std::string(100000, '\x01'), "line 2: longer than"},
  };
  for (const auto& [content, fragment] : cases) {
    SCOPED_TRACE(fragment);
    const std::string path = dir.path("bad.xyz");
    testkit::write_file(path, content);
    expect_input_error([&] { dsmplan::read_xyz(path); }, path, fragment);
  }
}

TEST(Xyz, ReadPointsPicksTheReaderByExtension) {
  testkit::TempDir dir;
  const std::string las = testkit::read_file(kDelft2);
  testkit::write_file(dir.path("tile.LAS"), las);
  EXPECT_EQ(dsmplan::read_points(dir.path("tile.LAS")).size(), 208432u);
  testkit::write_file(dir.path("points.txt"), "1 2 3\n");
  EXPECT_EQ(dsmplan::read_points(dir.path("points.txt")).size(), 1u);
  testkit::write_file(dir.path("points.ply"), "1 2 3\n");
  expect_input_error([&] { dsmplan::read_points(dir.path("points.ply")); }, dir.path("points.ply"), ".ply");
  testkit::write_file(dir.path("points"), "1 2 3\n");
  expect_input_error([&] { dsmplan::read_points(dir.path("points")); }, dir.path("points"), "extension");
}

TEST(PointGrid, FusionNamesRoundTripAndUnknownOnesAreRefused) {
  for (dsmplan::Fusion fusion : {dsmplan::Fusion::Median, dsmplan::Fusion::Max})
    EXPECT_EQ(dsmplan::parse_fusion(dsmplan::to_string(fusion)), fusion);
  EXPECT_THROW(dsmplan::parse_fusion("mean"), dsmplan::ArgumentError);
}
