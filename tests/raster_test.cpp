// Raster stage: GDAL input (GeoTIFF, VRT mosaic, ESRI ASCII grid), nodata, CRS, resampling and
// quantization, each checked against GDAL's own tools (gdal_translate, gdalbuildvrt, gdalwarp)
// or brute force on the real NRW DSM.
#include "dsmplan/raster.hpp"

#include <cpl_conv.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "testkit.hpp"

using namespace dsmplan;

namespace {

const std::string sample = testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif");

const Grid& nrw() {
  static const Grid grid = read_raster(sample);
  return grid;
}

// Runs a GDAL utility with command-line style arguments; the result is closed immediately.
template <typename Options, typename NewOptions, typename FreeOptions, typename Run>
void gdal_tool(std::vector<std::string> args, NewOptions make, FreeOptions release, Run run) {
  CPLStringList list;
  for (const auto& arg : args) list.AddString(arg.c_str());
  Options* options = make(list.List(), nullptr);
  int usage_error = 0;
  GDALDatasetH out = run(options, &usage_error);
  release(options);
  ASSERT_NE(out, nullptr) << CPLGetLastErrorMsg();
  GDALClose(out);
}

void translate(const std::string& from, const std::string& to, std::vector<std::string> args) {
  GDALDatasetH source = GDALOpen(from.c_str(), GA_ReadOnly);
  ASSERT_NE(source, nullptr);
  gdal_tool<GDALTranslateOptions>(
      args, GDALTranslateOptionsNew, GDALTranslateOptionsFree,
      [&](GDALTranslateOptions* o, int* e) { return GDALTranslate(to.c_str(), source, o, e); });
  GDALClose(source);
}

void warp(const std::string& from, const std::string& to, std::vector<std::string> args) {
  GDALDatasetH source = GDALOpen(from.c_str(), GA_ReadOnly);
  ASSERT_NE(source, nullptr);
  gdal_tool<GDALWarpAppOptions>(
      args, GDALWarpAppOptionsNew, GDALWarpAppOptionsFree,
      [&](GDALWarpAppOptions* o, int* e) { return GDALWarp(to.c_str(), nullptr, 1, &source, o, e); });
  GDALClose(source);
}

void expect_same_cells(const Grid& a, const Grid& b, double tolerance = 0) {
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  EXPECT_DOUBLE_EQ(a.x0, b.x0);
  EXPECT_DOUBLE_EQ(a.y0, b.y0);
  EXPECT_DOUBLE_EQ(a.cell_x, b.cell_x);
  EXPECT_DOUBLE_EQ(a.cell_y, b.cell_y);
  size_t different = 0;
  for (size_t i = 0; i < a.cells(); ++i) {
    const bool both_nodata = std::isnan(a.z[i]) && std::isnan(b.z[i]);
    if (!both_nodata && !(std::abs(a.z[i] - b.z[i]) <= tolerance)) ++different;
  }
  EXPECT_EQ(different, 0u);
}

}  // namespace

TEST(ReadRaster, RealGeoTiffAsGdalSeesIt) {
  const Grid& grid = nrw();
  EXPECT_EQ(grid.width, 500);
  EXPECT_EQ(grid.height, 500);
  EXPECT_EQ(grid.crs.epsg, 25832);
  EXPECT_EQ(grid.crs.name, "ETRS89 / UTM zone 32N");
  // The file's own numbers, read through GDAL's C API.
  GDALDatasetH dataset = GDALOpen(sample.c_str(), GA_ReadOnly);
  ASSERT_NE(dataset, nullptr);
  double gt[6];
  GDALGetGeoTransform(dataset, gt);
  EXPECT_EQ(grid.x0, gt[0]);
  EXPECT_EQ(grid.y0, gt[3]);
  double min_max[2];
  GDALComputeRasterMinMax(GDALGetRasterBand(dataset, 1), FALSE, min_max);
  const GridSummary summary = summarize(grid);
  EXPECT_EQ(summary.z_min, min_max[0]);
  EXPECT_EQ(summary.z_max, min_max[1]);
  EXPECT_EQ(summary.nodata, 0u);
  // Spot check orientation: row 0 is the north edge.
  float corner[2];
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(dataset, 1), GF_Read, 499, 0, 1, 1, &corner[0], 1, 1, GDT_Float32, 0, 0),
            CE_None);
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(dataset, 1), GF_Read, 0, 499, 1, 1, &corner[1], 1, 1, GDT_Float32, 0, 0),
            CE_None);
  EXPECT_EQ(grid.at(499, 0), corner[0]);
  EXPECT_EQ(grid.at(0, 499), corner[1]);
  GDALClose(dataset);
}

TEST(ReadRaster, VrtMosaicOfTwoTilesEqualsTheTile) {
  testkit::TempDir dir;
  translate(sample, dir.path("west.tif"), {"-srcwin", "0", "0", "230", "500"});
  translate(sample, dir.path("east.tif"), {"-srcwin", "230", "0", "270", "500"});
  const char* tiles[] = {nullptr, nullptr};
  std::string west = dir.path("west.tif"), east = dir.path("east.tif");
  tiles[0] = west.c_str();
  tiles[1] = east.c_str();
  int usage_error = 0;
  GDALDatasetH vrt = GDALBuildVRT(dir.path("mosaic.vrt").c_str(), 2, nullptr, tiles, nullptr, &usage_error);
  ASSERT_NE(vrt, nullptr);
  GDALClose(vrt);
  const Grid mosaic = read_raster(dir.path("mosaic.vrt"));
  expect_same_cells(mosaic, nrw());
  EXPECT_EQ(mosaic.crs.epsg, 25832);
}

TEST(ReadWindow, IsTheWindowGdalCutsOut) {
  // A window read from the file (GDAL) and from the grid in memory (GridView) is what
  // gdal_translate -srcwin writes: the same cells, corner, cell size and CRS.
  testkit::TempDir dir;
  translate(sample, dir.path("window.tif"), {"-srcwin", "230", "17", "100", "60"});
  const Grid cut = read_raster(dir.path("window.tif"));
  const std::unique_ptr<GridSource> file = open_raster(sample);
  GridView memory(nrw());
  for (GridSource* source : {file.get(), static_cast<GridSource*>(&memory)}) {
    const Grid window = read_window(*source, 230, 17, 100, 60);
    expect_same_cells(window, cut);
    EXPECT_EQ(window.crs.epsg, 25832);
  }
}

TEST(ReadRaster, EsriAsciiGridWithPrj) {
  testkit::TempDir dir;
  translate(sample, dir.path("dsm.asc"), {"-of", "AAIGrid", "-co", "DECIMAL_PRECISION=3"});
  const Grid ascii = read_raster(dir.path("dsm.asc"));
  expect_same_cells(ascii, nrw(), 0.0005);
  EXPECT_EQ(ascii.crs.epsg, 25832);
}

TEST(ReadRaster, DeclaredNodataBecomesHolesAndScaleApplies) {
  testkit::TempDir dir;
  // Int16 centimetres with scale 0.01 and nodata for everything below 115 m, as some DSMs ship.
  translate(sample, dir.path("cm.tif"),
            {"-ot", "Int16", "-scale", "100", "200", "0", "10000", "-a_scale", "0.01", "-a_offset", "100", "-a_nodata",
             "-1"});
  GDALDatasetH dataset = GDALOpen(dir.path("cm.tif").c_str(), GA_Update);
  ASSERT_NE(dataset, nullptr);
  GDALRasterBandH band = GDALGetRasterBand(dataset, 1);
  std::vector<int16_t> raw(500 * 500);
  ASSERT_EQ(GDALRasterIO(band, GF_Read, 0, 0, 500, 500, raw.data(), 500, 500, GDT_Int16, 0, 0), CE_None);
  size_t holes = 0;
  for (auto& v : raw)
    if (v < 1500) v = -1, ++holes;
  ASSERT_EQ(GDALRasterIO(band, GF_Write, 0, 0, 500, 500, raw.data(), 500, 500, GDT_Int16, 0, 0), CE_None);
  GDALClose(dataset);

  const Grid grid = read_raster(dir.path("cm.tif"));
  const GridSummary summary = summarize(grid);
  EXPECT_GT(holes, 1000u);
  EXPECT_EQ(summary.nodata, holes);
  size_t different = 0;
  for (size_t i = 0; i < grid.cells(); ++i) {
    if (std::isnan(grid.z[i])) continue;
    if (std::abs(grid.z[i] - nrw().z[i]) > 0.006) ++different;  // centimetre storage
  }
  EXPECT_EQ(different, 0u);
}

TEST(ReadRaster, RefusesWhatCannotBeUsed) {
  testkit::TempDir dir;
  EXPECT_THROW(read_raster(dir.path("missing.tif")), InputError);
  testkit::write_file(dir.path("text.tif"), "this is not a raster\n");
  EXPECT_THROW(read_raster(dir.path("text.tif")), InputError);
  {
    // A geo-referenced raster without a spatial reference.
    GDALDatasetH dataset =
        GDALCreate(GDALGetDriverByName("GTiff"), dir.path("nocrs.tif").c_str(), 10, 10, 1, GDT_Float32, nullptr);
    double gt[6] = {356300, 1, 0, 5699750, 0, -1};
    GDALSetGeoTransform(dataset, gt);
    std::vector<float> heights(100, 120.0f);
    ASSERT_EQ(
        GDALRasterIO(GDALGetRasterBand(dataset, 1), GF_Write, 0, 0, 10, 10, heights.data(), 10, 10, GDT_Float32, 0, 0),
        CE_None);
    GDALClose(dataset);
  }
  try {
    read_raster(dir.path("nocrs.tif"));
    ADD_FAILURE() << "a raster without CRS was accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("nocrs.tif"), std::string::npos);
    EXPECT_NE(std::string(error.what()).find("--crs"), std::string::npos);
  }
  ReadRasterOptions assign;
  assign.assign_crs = "EPSG:25832";
  EXPECT_EQ(read_raster(dir.path("nocrs.tif"), assign).crs.epsg, 25832);
}

TEST(Resample, MaxMinMeanAgreeWithGdalwarp) {
  testkit::TempDir dir;
  // gdalwarp aggregates the same 1 m cells into 2 m blocks; 500 m divides evenly.
  for (auto [ours, theirs] :
       {std::pair{Resampling::Max, "max"}, {Resampling::Min, "min"}, {Resampling::Mean, "average"}}) {
    const std::string out = dir.path(std::string(theirs) + ".tif");
    warp(sample, out, {"-tr", "2", "2", "-r", theirs, "-ot", "Float32"});
    const Grid expected = read_raster(out);
    SCOPED_TRACE(theirs);
    expect_same_cells(resample(nrw(), 2, ours), expected, ours == Resampling::Mean ? 1e-4 : 0);
  }
}

TEST(Resample, MedianIsTheBlockMedianByBruteForce) {
  for (double resolution : {2.0, 3.0, 4.0}) {
    const Grid out = resample(nrw(), resolution, Resampling::Median);
    const int factor = static_cast<int>(resolution);
    // Table 1 sizing: ceil(extent / resolution) cells.
    ASSERT_EQ(out.width, (500 + factor - 1) / factor);
    for (int row = 0; row < out.height; ++row) {
      for (int col = 0; col < out.width; ++col) {
        std::vector<double> values;
        for (int r = row * factor; r < std::min(500, (row + 1) * factor); ++r)
          for (int c = col * factor; c < std::min(500, (col + 1) * factor); ++c) values.push_back(nrw().at(c, r));
        std::sort(values.begin(), values.end());
        const size_t n = values.size();
        const double median = n % 2 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
        ASSERT_FLOAT_EQ(out.at(col, row), median) << resolution << " m, block " << col << "," << row;
      }
    }
  }
  EXPECT_THROW(resample(nrw(), 0, Resampling::Median), ArgumentError);
  EXPECT_THROW(resample(nrw(), -1, Resampling::Median), ArgumentError);
  EXPECT_THROW(resample(nrw(), 0.5, Resampling::Median), ArgumentError);
}

TEST(Quantize, MatchesDecimalRoundingOnRealHeights) {
  size_t checked = 0;
  for (size_t i = 0; i < nrw().cells(); i += 37) {
    const double z = nrw().z[i];
    char text[32];
    std::snprintf(text, sizeof text, "%.1f", std::round(z * 10) / 10);
    ASSERT_EQ(quantize_height(z, 0.1), std::strtod(text, nullptr)) << z;
    ASSERT_LE(std::abs(quantize_height(z, 0.25) - z), 0.125 + 1e-12);
    ++checked;
  }
  EXPECT_GT(checked, 6000u);
  EXPECT_EQ(quantize_height(123.456, 0), 123.456);
}

TEST(Summary, HolesAreFourConnectedNodataRegions) {
  Grid grid = nrw();
  for (float& z : grid.z)
    if (z < 113.0f) z = Grid::nodata;
  // Union-find over the nodata cells as the independent count.
  std::vector<size_t> parent(grid.cells());
  std::iota(parent.begin(), parent.end(), 0);
  std::function<size_t(size_t)> find = [&](size_t i) { return parent[i] == i ? i : parent[i] = find(parent[i]); };
  for (int r = 0; r < grid.height; ++r)
    for (int c = 0; c < grid.width; ++c) {
      if (grid.valid(c, r)) continue;
      if (c + 1 < grid.width && !grid.valid(c + 1, r)) parent[find(grid.index(c, r))] = find(grid.index(c + 1, r));
      if (r + 1 < grid.height && !grid.valid(c, r + 1)) parent[find(grid.index(c, r))] = find(grid.index(c, r + 1));
    }
  size_t roots = 0;
  for (size_t i = 0; i < grid.cells(); ++i) roots += std::isnan(grid.z[i]) && find(i) == i;
  EXPECT_GT(roots, 3u);
  EXPECT_EQ(summarize(grid).holes, roots);
}

TEST(FillHoles, FillsNearDataWithNeighbourHeightsAndLeavesCanals) {
  std::vector<PointCloud> clouds{read_las(testkit::data_path("delft-ahn3/ahn3_cropped_1.las")),
                                 read_las(testkit::data_path("delft-ahn3/ahn3_cropped_2.las"))};
  GridPointsOptions options;
  options.resolution = 0.5;
  const Grid original = grid_points(clouds, options);
  Grid filled = original;
  const int reach = 4;  // cells
  fill_holes(filled, reach);

  size_t kept_valid = 0, filled_next_to_data = 0, next_to_data = 0, still_empty = 0, outside_neighbourhood = 0;
  for (int r = 0; r < original.height; ++r) {
    for (int c = 0; c < original.width; ++c) {
      if (original.valid(c, r)) {
        kept_valid += filled.at(c, r) == original.at(c, r);
        continue;
      }
      // Inverse-distance weights average heights found within `reach`: the result must lie
      // within the range of the valid heights in that window.
      float low = INFINITY, high = -INFINITY;
      bool touches_data = false;
      for (int dr = -reach; dr <= reach; ++dr)
        for (int dc = -reach; dc <= reach; ++dc) {
          const int cc = c + dc, rr = r + dr;
          if (cc < 0 || rr < 0 || cc >= original.width || rr >= original.height || !original.valid(cc, rr)) continue;
          low = std::min(low, original.at(cc, rr)), high = std::max(high, original.at(cc, rr));
          touches_data |= std::abs(dr) <= 1 && std::abs(dc) <= 1;
        }
      next_to_data += touches_data;
      if (!filled.valid(c, r)) {
        ++still_empty;
        continue;
      }
      filled_next_to_data += touches_data;
      if (filled.at(c, r) < low - 1e-3f || filled.at(c, r) > high + 1e-3f) ++outside_neighbourhood;
    }
  }
  const GridSummary before = summarize(original);
  EXPECT_EQ(kept_valid, before.valid);
  EXPECT_EQ(filled_next_to_data, next_to_data);
  EXPECT_EQ(outside_neighbourhood, 0u);
  EXPECT_GT(still_empty, 100u);                   // the canals are far wider than 2 m
  EXPECT_GT(before.nodata - still_empty, 1000u);  // single-cell dropouts and canal banks
  EXPECT_THROW(fill_holes(filled, 0), ArgumentError);
}

TEST(ReadRaster, SouthUpAndMaskedRastersReadAsTheTile) {
  testkit::TempDir dir;
  const Grid& tile = nrw();
  GDALDriverH gtiff = GDALGetDriverByName("GTiff");
  std::vector<float> rows(tile.z.size());

  // South-up: row 0 is the southern edge and the y pixel size is positive.
  for (int r = 0; r < tile.height; ++r)
    std::copy_n(&tile.z[tile.index(0, tile.height - 1 - r)], tile.width, &rows[tile.index(0, r)]);
  GDALDatasetH south_up =
      GDALCreate(gtiff, dir.path("south_up.tif").c_str(), tile.width, tile.height, 1, GDT_Float32, nullptr);
  double gt[6] = {tile.x0, tile.cell_x, 0, tile.y1(), 0, tile.cell_y};
  GDALSetGeoTransform(south_up, gt);
  GDALSetProjection(south_up, tile.crs.wkt.c_str());
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(south_up, 1), GF_Write, 0, 0, tile.width, tile.height, rows.data(),
                         tile.width, tile.height, GDT_Float32, 0, 0),
            CE_None);
  GDALClose(south_up);
  expect_same_cells(read_raster(dir.path("south_up.tif")), tile);

  // An internal mask (no nodata value) hides the cells below 115 m.
  GDALDatasetH masked =
      GDALCreate(gtiff, dir.path("masked.tif").c_str(), tile.width, tile.height, 1, GDT_Float32, nullptr);
  double north_up[6] = {tile.x0, tile.cell_x, 0, tile.y0, 0, -tile.cell_y};
  GDALSetGeoTransform(masked, north_up);
  GDALSetProjection(masked, tile.crs.wkt.c_str());
  GDALRasterBandH band = GDALGetRasterBand(masked, 1);
  std::vector<float> heights = tile.z;
  ASSERT_EQ(GDALRasterIO(band, GF_Write, 0, 0, tile.width, tile.height, heights.data(), tile.width, tile.height,
                         GDT_Float32, 0, 0),
            CE_None);
  ASSERT_EQ(GDALCreateMaskBand(band, GMF_PER_DATASET), CE_None);
  std::vector<GByte> mask(tile.cells());
  Grid expected = tile;
  for (size_t i = 0; i < tile.cells(); ++i) {
    mask[i] = tile.z[i] < 115.0f ? 0 : 255;
    if (!mask[i]) expected.z[i] = Grid::nodata;
  }
  ASSERT_EQ(GDALRasterIO(GDALGetMaskBand(band), GF_Write, 0, 0, tile.width, tile.height, mask.data(), tile.width,
                         tile.height, GDT_Byte, 0, 0),
            CE_None);
  GDALClose(masked);
  const Grid read = read_raster(dir.path("masked.tif"));
  EXPECT_GT(summarize(read).nodata, 1000u);
  expect_same_cells(read, expected);
}
