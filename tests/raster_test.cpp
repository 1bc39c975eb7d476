// Raster stage: GDAL input (GeoTIFF, VRT mosaic, ESRI ASCII grid), nodata, CRS, resampling and
// quantization, each checked against GDAL's own tools (gdal_translate, gdalbuildvrt, gdalwarp)
// or brute force on the real NRW DSM.
#include "dsmplan/raster.hpp"

#include <cpl_conv.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <proj.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <numeric>

#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/tools.hpp"
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

// Found by fuzz/fuzz_pipeline. Grids made in memory get the readers' checks: cells of 5e-324
// made resample() index past its last block (ASan), and a corner at 1e308 with cells of -1 kept
// simplify_bounded() on a GridView flipping edges forever; a --zstep of 5e-324 overflowed z / step
// into infinite heights.
TEST(Resample, GridsMadeInMemoryGetTheReadersChecks) {
  Grid denormal(46, 19, 0, 0, 5e-324, 5e-324);
  for (float& z : denormal.z) z = 100;
  EXPECT_THROW(resample(denormal, 1e-323, Resampling::Median), ArgumentError);
  Grid far(49, 19, 1.7e308, -6.3e307, 4e307, -1);
  for (float& z : far.z) z = 100;
  EXPECT_THROW(GridView view(far), ArgumentError);
  Grid sentinel(4, 4, 0, 4, 1, 1);
  for (float& z : sentinel.z) z = -3.4e38f;
  EXPECT_THROW(GridView view(sentinel), ArgumentError);
  EXPECT_THROW(resample(sentinel, 2, Resampling::Max), ArgumentError);
  try {
    HeightQuantizer quantize(5e-324);
    FAIL() << "a 5e-324 step was accepted";
  } catch (const ArgumentError& e) {
    EXPECT_EQ(e.field(), "zstep");  // the CLI shows it as --zstep
    EXPECT_NE(std::string(e.what()).find("zstep: must be at least 1e-6 and at most 100"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(quantize_height(123.456789, 1e-6), std::round(123.456789 * 1e6) / 1e6);
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

// ---- units: dsmplan measures in metres ------------------------------------------------------
//
// Each raster is placed around a longitude/latitude chosen here, by transforming that point
// into the raster's CRS (OGR, the inverse of what dsmplan does); the UTM zone dsmplan must
// suggest is worked out by hand from the chosen longitude: floor((lon + 180) / 6) + 1.

namespace {

// (x, y) in `crs` of WGS 84 (lon, lat).
std::pair<double, double> from_lonlat(const std::string& crs, double lon, double lat) {
  OGRSpatialReference wgs84, target;
  wgs84.SetWellKnownGeogCS("WGS84");
  EXPECT_EQ(target.SetFromUserInput(crs.c_str()), OGRERR_NONE) << crs;
  if (target.IsCompound()) target.StripVertical();
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  target.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> transform(OGRCreateCoordinateTransformation(&wgs84, &target));
  double x = lon, y = lat;
  EXPECT_TRUE(transform && transform->Transform(1, &x, &y)) << crs;
  return {x, y};
}

// A 20 x 20 Float32 GeoTIFF of `cell`-sized cells centred on (lon, lat), in `crs` (written as
// WKT; compound CRSs too), heights 100 + col, with `unit_type` as the band's unit when given.
std::string unit_raster(const testkit::TempDir& dir, const std::string& name, const std::string& crs, double lon,
                        double lat, double cell, const char* unit_type = nullptr) {
  const auto [cx, cy] = from_lonlat(crs, lon, lat);
  const std::string path = dir.path(name);
  GDALDatasetH dataset = GDALCreate(GDALGetDriverByName("GTiff"), path.c_str(), 20, 20, 1, GDT_Float32, nullptr);
  double gt[6] = {cx - 10 * cell, cell, 0, cy + 10 * cell, 0, -cell};
  GDALSetGeoTransform(dataset, gt);
  OGRSpatialReference srs;
  srs.SetFromUserInput(crs.c_str());
  GDALSetSpatialRef(dataset, OGRSpatialReference::ToHandle(&srs));
  GDALRasterBandH band = GDALGetRasterBand(dataset, 1);
  if (unit_type) GDALSetRasterUnitType(band, unit_type);
  std::vector<float> heights(400);
  for (size_t i = 0; i < heights.size(); ++i) heights[i] = 100.0f + static_cast<float>(i % 20);
  EXPECT_EQ(GDALRasterIO(band, GF_Write, 0, 0, 20, 20, heights.data(), 20, 20, GDT_Float32, 0, 0), CE_None);
  GDALClose(dataset);
  return path;
}

// PROJ's own scale factors of the projected CRS `code` at longitude, latitude (degrees): the
// larger departure of the meridional and parallel scales from 1 (proj_factors, analytical).
double proj_scale_departure(const char* code, double lon, double lat) {
  PJ_CONTEXT* ctx = proj_context_create();
  PJ* crs = proj_create(ctx, code);
  const PJ_FACTORS f = proj_factors(crs, proj_coord(proj_torad(lon), proj_torad(lat), 0, 0));
  EXPECT_EQ(proj_errno(crs), 0) << code;
  proj_destroy(crs);
  proj_context_destroy(ctx);
  return std::max(std::abs(f.meridional_scale - 1), std::abs(f.parallel_scale - 1));
}

// A projected CRS whose metres are not the ground's is refused with the UTM suggestion (a
// safety distance in its units must be one on the ground); PROJ's proj_factors is the oracle
// of the scale, at the data's centre. UTM inside its zone (0.9996 to 1.001) passes; so do the
// national grids; Web Mercator at 51 N (1.59) and UTM 15 degrees outside its zone do not.
TEST(Units, AProjectedCrsThatStretchesLengthsIsRefused) {
  testkit::TempDir dir;
  struct Case {
    const char* crs;
    double lon, lat;
    const char* utm;  // the suggestion
  };
  const Case cases[] = {
      {"EPSG:25832", 7.0, 51.4, "EPSG:32632"},   // NRW, UTM 32N: 0.9996 + a little
      {"EPSG:32632", 9.0, 51.4, "EPSG:32632"},   // on the central meridian: 0.9996
      {"EPSG:32632", 11.9, 48.0, "EPSG:32632"},  // at the zone's edge: about 1.0004
      {"EPSG:28992", 4.37, 52.0, "EPSG:32631"},  // RD New (Delft): 0.99991
      {"EPSG:2154", 2.3, 48.9, "EPSG:32631"},    // Lambert 93 (Paris): about 0.9994
      {"EPSG:3857", 7.0, 51.0, "EPSG:32632"},    // Web Mercator at 51 N: 1.59
      {"EPSG:3857", 7.0, 4.0, "EPSG:32632"},     // ... near the equator: 1.0024, passes
      {"EPSG:32632", 24.0, 60.0, "EPSG:32635"},  // UTM 32N 15 degrees east of its meridian: 1.017
      {"EPSG:32631", 9.0, 30.0, "EPSG:32632"},   // UTM 31N 6 degrees east: about 1.0051
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(c.crs) + " at " + std::to_string(c.lon) + ", " + std::to_string(c.lat));
    const double truth = proj_scale_departure(c.crs, c.lon, c.lat);
    const auto [x, y] = from_lonlat(c.crs, c.lon, c.lat);
    Crs crs;
    crs.definition = c.crs;
    resolve_crs(crs);
    const std::string problem = metric_problem(crs, "dsm.tif", x, y);
    EXPECT_EQ(!problem.empty(), truth > kMaxScaleDeparture) << "PROJ: " << truth << "; " << problem;
    if (!problem.empty()) {
      char factor[32];
      std::snprintf(factor, sizeof factor, "scale factor of %.4g", 1 + truth);
      for (const std::string& phrase :
           {std::string(factor), std::string("UTM zone"), "gdalwarp -t_srs " + std::string(c.utm)})
        EXPECT_NE(problem.find(phrase), std::string::npos) << phrase << " not in: " << problem;
    }
    // Units only (as every raster is read): not refused for its scale.
    EXPECT_EQ(metric_problem(crs, "dsm.tif", x, y, /*units_only=*/true), "");
  }
}

// The one-line InputError of `run`, or "" when it did not throw one.
std::string input_error(const std::function<void()>& run) {
  try {
    run();
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

void expect_phrases(const std::string& message, std::initializer_list<const char*> phrases) {
  EXPECT_FALSE(message.empty()) << "accepted";
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  for (const char* phrase : phrases) EXPECT_NE(message.find(phrase), std::string::npos) << phrase << " in: " << message;
}

MeshJobOptions mesh_job(const std::string& input, const testkit::TempDir& dir) {
  MeshJobOptions job;
  job.input = input;
  job.output = dir.path("out.ply");
  return job;
}

}  // namespace

TEST(Units, CrsInUsSurveyFeetIsRefusedNamingTheUnitAndTheUtmZoneOfItsCentre) {
  testkit::TempDir dir;
  // Northern Virginia, lon -77.5: zone floor(102.5 / 6) + 1 = 18.
  const std::string feet = unit_raster(dir, "dsm_ft.tif", "EPSG:2283", -77.5, 38.9, 3.0);
  const std::initializer_list<const char*> phrases = {"dsm_ft.tif", "NAD83 / Virginia North (ftUS)", "horizontal unit",
                                                      "US survey foot (0.3048006 m)", "gdalwarp -t_srs EPSG:32618"};
  expect_phrases(input_error([&] { read_raster(feet); }), phrases);
  expect_phrases(input_error([&] { open_raster(feet); }), phrases);
  expect_phrases(input_error([&] { mesh_dsm(mesh_job(feet, dir)); }), phrases);
  EXPECT_FALSE(std::filesystem::exists(dir.path("out.ply")));

  // A raster without CRS given EPSG:2283 by --crs: the same refusal.
  ReadRasterOptions assign;
  assign.assign_crs = "EPSG:2283";
  {
    GDALDatasetH dataset =
        GDALCreate(GDALGetDriverByName("GTiff"), dir.path("nocrs.tif").c_str(), 4, 4, 1, GDT_Float32, nullptr);
    const auto [cx, cy] = from_lonlat("EPSG:2283", -77.5, 38.9);
    double gt[6] = {cx, 3, 0, cy, 0, -3};
    GDALSetGeoTransform(dataset, gt);
    GDALClose(dataset);
  }
  expect_phrases(input_error([&] { read_raster(dir.path("nocrs.tif"), assign); }), {"US survey foot", "EPSG:32618"});

  // info describes it, units and all.
  InfoOptions info;
  info.input = feet;
  const RasterReport report = describe_raster(info);
  EXPECT_EQ(report.crs.epsg, 2283);
  EXPECT_EQ(report.crs.linear_unit, "US survey foot");
  EXPECT_NEAR(report.crs.linear_unit_m, 1200.0 / 3937.0, 1e-12);
  EXPECT_NE(to_text(report).find("US survey foot (0.3048006 m)"), std::string::npos) << to_text(report);
  EXPECT_NEAR(to_json(report)["units"]["horizontal_m"].get<double>(), 1200.0 / 3937.0, 1e-12);

  // The same place in metres (UTM 18N) is read, and says metres.
  const Grid metres = read_raster(unit_raster(dir, "dsm_m.tif", "EPSG:32618", -77.5, 38.9, 1.0));
  EXPECT_EQ(metres.crs.linear_unit_m, 1.0);
  EXPECT_EQ(metres.crs.linear_unit, "metre");
  // International feet: NAD83(2011) / Oregon GIC Lambert (ft), lon -121: zone 10.
  const std::string intl = unit_raster(dir, "oregon_ft.tif", "EPSG:6557", -121.0, 44.0, 3.0);
  expect_phrases(input_error([&] { read_raster(intl); }), {"oregon_ft.tif", "(0.3048 m)", "EPSG:32610"});
}

TEST(Units, HeightsInFeetAreRefusedByTheBandUnitTypeOrTheCompoundCrs) {
  testkit::TempDir dir;
  // Essen, lon 7.0: zone floor(187 / 6) + 1 = 32.
  for (auto [unit, metres] : {std::pair{"ft", "(0.3048 m)"},
                              {"foot", "(0.3048 m)"},
                              {"US survey foot", "(0.3048006 m)"},
                              {"ftUS", "(0.3048006 m)"},
                              {"us-ft", "(0.3048006 m)"},
                              {"Feet", "(0.3048 m)"}}) {
    SCOPED_TRACE(unit);
    const std::string path = unit_raster(dir, "dsm_vft.tif", "EPSG:25832", 7.0, 51.4, 1.0, unit);
    expect_phrases(input_error([&] { read_raster(path); }),
                   {"dsm_vft.tif", "heights are in", unit, metres, "gdal_calc.py"});
    SimplifyJobOptions simplify;
    simplify.input = path;
    simplify.output = dir.path("out.ply");
    simplify.method = SimplifyMethod::Bounded;
    simplify.max_error = 0.5;
    expect_phrases(input_error([&] { simplify_job(simplify); }), {"dsm_vft.tif", unit});
  }
  // Metres, however spelt, are read; so is a band without unit.
  for (const char* unit : {"m", "metre", "Meters", "metres", ""}) {
    const Grid grid = read_raster(unit_raster(dir, "dsm.tif", "EPSG:25832", 7.0, 51.4, 1.0, unit));
    EXPECT_EQ(grid.crs.vertical_unit_m, *unit ? 1.0 : 0.0) << unit;
  }
  // A unit that is no length is not taken as metres either.
  expect_phrases(input_error([&] { read_raster(unit_raster(dir, "odd.tif", "EPSG:25832", 7.0, 51.4, 1.0, "banana")); }),
                 {"odd.tif", "'banana'", "not a length unit"});

  // NAD83 / UTM zone 18N + NAVD88 height (ftUS), lon -77.5: refused, with the metre version of
  // the same vertical CRS (NAVD88 height, EPSG:5703) in the example; + NAVD88 height is read.
  const std::string compound = unit_raster(dir, "navd88_ft.tif", "EPSG:26918+6360", -77.5, 38.9, 1.0);
  expect_phrases(input_error([&] { read_raster(compound); }),
                 {"navd88_ft.tif", "US survey foot (0.3048006 m)", "NAVD88 height (ftUS)", "EPSG:32618+5703"});
  const Grid navd88 = read_raster(unit_raster(dir, "navd88_m.tif", "EPSG:26918+5703", -77.5, 38.9, 1.0));
  EXPECT_EQ(navd88.crs.vertical_unit_m, 1.0);
  EXPECT_EQ(navd88.crs.linear_unit_m, 1.0);
  // The band cannot make feet metres under a CRS in feet, nor feet metres the other way round.
  expect_phrases(
      input_error([&] { read_raster(unit_raster(dir, "both.tif", "EPSG:26918+5703", -77.5, 38.9, 1.0, "ft")); }),
      {"both.tif", "ft (0.3048 m)"});
}

TEST(Units, GeographicRasterIsRefusedSuggestingTheUtmZoneOfItsCentre) {
  testkit::TempDir dir;
  struct Place {
    const char* name;
    double lon, lat;
    const char* epsg;  // by hand: floor((lon + 180) / 6) + 1, 326zz north, 327zz south
  };
  for (const Place& place : {Place{"virginia", -77.5, 38.9, "EPSG:32618"}, Place{"essen", 6.9, 51.4, "EPSG:32632"},
                             Place{"sydney", 151.2, -33.9, "EPSG:32756"}, Place{"quito", -78.5, -0.2, "EPSG:32717"}}) {
    SCOPED_TRACE(place.name);
    const std::string path =
        unit_raster(dir, std::string(place.name) + ".tif", "EPSG:4326", place.lon, place.lat, 1e-5);
    // Reading describes degrees (info, render take them); the tools refuse them.
    EXPECT_TRUE(read_raster(path).crs.geographic);
    expect_phrases(input_error([&] { mesh_dsm(mesh_job(path, dir)); }),
                   {place.name, "geographic", (std::string("gdalwarp -t_srs ") + place.epsg).c_str()});
  }
  // The zone boundary at 78 degrees West: zone 17 west of it, 18 from it on.
  Crs wgs84;
  wgs84.definition = "EPSG:4326";
  resolve_crs(wgs84);
  EXPECT_EQ(utm_epsg_at(wgs84, -78.0001, 38), "EPSG:32617");
  EXPECT_EQ(utm_epsg_at(wgs84, -78.0, 38), "EPSG:32618");
  EXPECT_EQ(utm_epsg_at(wgs84, 179.99, -10), "EPSG:32760");
}
