// Raster and CRS I/O through GDAL and PROJ: the only place in dsmplan that depends on them.
#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <gdal_alg.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>

#include "core/atomic_file.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

namespace {

void init_gdal() {
  static std::once_flag once;
  std::call_once(once, [] {
    GDALAllRegister();
    // Reading must not leave .aux.xml files next to the user's data.
    CPLSetConfigOption("GDAL_PAM_ENABLED", "NO");
    // Decode compressed GeoTIFF blocks on all cores, unless the user chose otherwise.
    if (!CPLGetConfigOption("GDAL_NUM_THREADS", nullptr)) CPLSetConfigOption("GDAL_NUM_THREADS", "ALL_CPUS");
    // GDAL's own messages would be a second, unlocated line; ours name the file and place.
    CPLSetErrorHandler(CPLQuietErrorHandler);
  });
}

std::string gdal_message() {
  std::string message = CPLGetLastErrorMsg();
  return message.empty() ? std::string() : ": " + message;
}

std::string format_number(double value) {
  std::ostringstream out;
  out.precision(12);
  out << value;
  return out.str();
}

// Bridges our Progress to GDAL's callback; remembers a cancel so we can throw after GDAL returns.
struct GdalProgress {
  Progress progress;
  bool cancelled = false;
  static int CPL_STDCALL call(double fraction, const char*, void* self) {
    auto* me = static_cast<GdalProgress*>(self);
    if (me->progress && !me->progress(fraction)) me->cancelled = true;
    return !me->cancelled;
  }
};

std::string cell_place(const Grid& grid, int col, int row) {
  return "cell (col " + std::to_string(col) + ", row " + std::to_string(row) +
         ") at x=" + format_number(grid.center_x(col)) + " y=" + format_number(grid.center_y(row));
}

// Fills the descriptive fields of `crs` (definition included) from a parsed reference system.
void describe(const OGRSpatialReference& srs, Crs& crs) {
  char* wkt = nullptr;
  const char* wkt_options[] = {"FORMAT=WKT2_2019", "MULTILINE=NO", nullptr};
  if (srs.exportToWkt(&wkt, wkt_options) == OGRERR_NONE && wkt) crs.wkt = wkt;
  CPLFree(wkt);
  if (crs.definition.empty()) crs.definition = crs.wkt;
  crs.name = srs.GetName() ? srs.GetName() : "";
  crs.geographic = srs.IsGeographic();

  OGRSpatialReference horizontal(srs);
  if (horizontal.IsCompound()) horizontal.StripVertical();
  const char* authority = horizontal.GetAuthorityName(nullptr);
  const char* code = horizontal.GetAuthorityCode(nullptr);
  if (!(authority && code) && horizontal.AutoIdentifyEPSG() == OGRERR_NONE) {
    authority = horizontal.GetAuthorityName(nullptr);
    code = horizontal.GetAuthorityCode(nullptr);
  }
  crs.epsg = authority && code && EQUAL(authority, "EPSG") ? std::atoi(code) : 0;
  if (!crs.epsg) {
    // ESRI .prj files (ASCII grids, shapefiles) carry names, not codes: ask PROJ's database.
    std::unique_ptr<OGRSpatialReference, decltype(&OSRRelease)> match(horizontal.FindBestMatch(90), &OSRRelease);
    if (match && match->GetAuthorityName(nullptr) && EQUAL(match->GetAuthorityName(nullptr), "EPSG")) {
      crs.epsg = std::atoi(match->GetAuthorityCode(nullptr));
    }
  }

  if (srs.IsCompound() || srs.IsVertical()) {
    const char* vertical = srs.GetAttrValue("VERT_CS");
    if (vertical) crs.vertical_name = vertical;
    const char* unit = nullptr;
    srs.GetTargetLinearUnits("VERT_CS", &unit);
    if (unit) crs.vertical_unit = unit;
  }
}

}  // namespace

void resolve_crs(Crs& crs) {
  init_gdal();
  if (crs.definition.empty()) return;
  OGRSpatialReference srs;
  if (srs.SetFromUserInput(crs.definition.c_str()) != OGRERR_NONE) {
    throw ArgumentError("--crs", "cannot interpret CRS '" + crs.definition.substr(0, 60) + "'" + gdal_message());
  }
  describe(srs, crs);
}

Grid read_raster(const std::string& path, const ReadRasterOptions& options, const Progress& progress) {
  init_gdal();
  VSIStatBufL stat;
  if (VSIStatL(path.c_str(), &stat) != 0) throw InputError(path, "", "no such file");
  if (VSI_ISDIR(stat.st_mode)) throw InputError(path, "", "is a directory, not a raster");
  CPLErrorReset();
  GDALDatasetUniquePtr dataset(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  if (!dataset) throw InputError(path, "", "not a raster GDAL can read" + gdal_message());
  const int width = dataset->GetRasterXSize(), height = dataset->GetRasterYSize();
  if (width <= 0 || height <= 0) throw InputError(path, "", "raster has no cells");
  if (dataset->GetRasterCount() < 1) throw InputError(path, "", "raster has no band");
  if (options.band < 1 || options.band > dataset->GetRasterCount()) {
    throw ArgumentError("--band", "band " + std::to_string(options.band) + " does not exist in " + path + " (it has " +
                                      std::to_string(dataset->GetRasterCount()) + ")");
  }
  double gt[6];
  if (dataset->GetGeoTransform(gt) != CE_None) throw InputError(path, "", "not geo-referenced (no geotransform)");
  if (gt[2] != 0 || gt[4] != 0) throw InputError(path, "geotransform", "rotated or sheared rasters are not supported");
  if (!(gt[1] > 0) || gt[5] == 0) throw InputError(path, "geotransform", "cell size must be positive");
  const bool south_up = gt[5] > 0;
  // A float per cell, a byte more when a mask band has to be read alongside.
  GDALRasterBand* band = dataset->GetRasterBand(options.band);
  const int mask_flags = band->GetMaskFlags();
  const bool read_mask = !(mask_flags & (GMF_ALL_VALID | GMF_NODATA));
  require_memory(path, std::to_string(width) + " x " + std::to_string(height) + " cells",
                 double(width) * double(height) * (sizeof(float) + (read_mask ? 1 : 0) + options.extra_bytes_per_cell));

  Grid grid(width, height, gt[0], south_up ? gt[3] + height * gt[5] : gt[3], gt[1], std::abs(gt[5]));
  const OGRSpatialReference* srs = dataset->GetSpatialRef();
  if (srs && !srs->IsEmpty()) {
    describe(*srs, grid.crs);
  } else if (!options.assign_crs.empty()) {
    grid.crs.definition = options.assign_crs;
    resolve_crs(grid.crs);
  } else if (!options.allow_no_crs) {
    throw InputError(path, "", "raster has no CRS; assign one with --crs (e.g. --crs EPSG:25832)");
  }

  GdalProgress bridge{progress};
  GDALRasterIOExtraArg extra;
  INIT_RASTERIO_EXTRA_ARG(extra);
  extra.pfnProgress = GdalProgress::call;
  extra.pProgressData = &bridge;
  CPLErrorReset();
  if (band->RasterIO(GF_Read, 0, 0, width, height, grid.z.data(), width, height, GDT_Float32, 0, 0, &extra) !=
      CE_None) {
    if (bridge.cancelled) throw Cancelled();
    throw InputError(path, "band " + std::to_string(options.band), "cannot read heights" + gdal_message());
  }
  if (south_up) {
    for (int row = 0; row < height / 2; ++row) {
      std::swap_ranges(grid.z.begin() + grid.index(0, row), grid.z.begin() + grid.index(0, row) + width,
                       grid.z.begin() + grid.index(0, height - 1 - row));
    }
  }

  int has_nodata = 0;
  const double nodata = band->GetNoDataValue(&has_nodata);
  const bool nan_is_nodata = has_nodata && std::isnan(nodata);
  const float nodata_value = static_cast<float>(nodata);
  // An explicit mask (internal mask, alpha) marks nodata too.
  std::vector<GByte> mask;
  if (read_mask) {
    mask.resize(grid.cells());
    if (band->GetMaskBand()->RasterIO(GF_Read, 0, 0, width, height, mask.data(), width, height, GDT_Byte, 0, 0) !=
        CE_None) {
      throw InputError(path, "mask band", "cannot read" + gdal_message());
    }
  }
  int has_scale = 0, has_offset = 0;
  const double scale = band->GetScale(&has_scale), offset = band->GetOffset(&has_offset);
  const bool rescale = (has_scale && scale != 1) || (has_offset && offset != 0);
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      float& z = grid.z[grid.index(col, row)];
      const int source_row = south_up ? height - 1 - row : row;
      if ((has_nodata && !nan_is_nodata && z == nodata_value) ||
          (!mask.empty() && mask[static_cast<size_t>(source_row) * width + col] == 0)) {
        z = Grid::nodata;
        continue;
      }
      if (std::isnan(z)) {
        if (nan_is_nodata) continue;
        throw InputError(path, cell_place(grid, col, row), "height is NaN but the raster declares no NaN nodata");
      }
      if (std::isinf(z)) throw InputError(path, cell_place(grid, col, row), "height is infinite");
      if (rescale) z = static_cast<float>(z * (has_scale ? scale : 1) + (has_offset ? offset : 0));
    }
  }
  if (std::all_of(grid.z.begin(), grid.z.end(), [](float z) { return std::isnan(z); })) {
    throw InputError(path, "", "no valid cell: every cell is nodata");
  }
  if (grid.crs.vertical_unit.empty() && band->GetUnitType() && *band->GetUnitType()) {
    grid.crs.vertical_unit = band->GetUnitType();
  }
  return grid;
}

void write_geotiff(const Grid& grid, const std::string& path, const Progress& progress) {
  init_gdal();
  constexpr double nodata = -9999.0;
  AtomicFile file(path);
  file.close_stream();  // GDAL writes the temporary file by name
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  CPLStringList create_options;
  create_options.SetNameValue("COMPRESS", "DEFLATE");
  create_options.SetNameValue("PREDICTOR", "3");
  create_options.SetNameValue("TILED", "YES");
  create_options.SetNameValue("BIGTIFF", "IF_SAFER");
  CPLErrorReset();
  GDALDataset* dataset =
      driver->Create(file.temp_path().c_str(), grid.width, grid.height, 1, GDT_Float32, create_options.List());
  if (!dataset) throw OutputError(path, "cannot create GeoTIFF" + gdal_message());
  double gt[6] = {grid.x0, grid.cell_x, 0, grid.y0, 0, -grid.cell_y};
  dataset->SetGeoTransform(gt);
  if (grid.crs.known()) {
    OGRSpatialReference srs;
    if (srs.SetFromUserInput(grid.crs.wkt.empty() ? grid.crs.definition.c_str() : grid.crs.wkt.c_str()) ==
        OGRERR_NONE) {
      dataset->SetSpatialRef(&srs);
    }
  }
  GDALRasterBand* band = dataset->GetRasterBand(1);
  band->SetNoDataValue(nodata);
  if (!grid.crs.vertical_unit.empty()) band->SetUnitType(grid.crs.vertical_unit.c_str());
  std::vector<float> row_values(grid.width);
  CPLErr status = CE_None;
  for (int row = 0; row < grid.height && status == CE_None; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      const float z = grid.at(col, row);
      row_values[col] = std::isnan(z) ? static_cast<float>(nodata) : z;
    }
    status = band->RasterIO(GF_Write, 0, row, grid.width, 1, row_values.data(), grid.width, 1, GDT_Float32, 0, 0);
    if (row % 256 == 0) report(progress, 0.9 * row / grid.height);
  }
  CPLErrorReset();
  GDALClose(dataset);  // flushes: compressed blocks are written here, and can fail here
  if (status == CE_None && CPLGetLastErrorType() >= CE_Failure) status = CE_Failure;
  if (status != CE_None) throw OutputError(path, "cannot write GeoTIFF" + gdal_message());
  file.commit();
  report(progress, 1);
}

void fill_holes(Grid& grid, double max_distance, const Progress& progress) {
  init_gdal();
  if (!(max_distance > 0)) throw ArgumentError("--fill-holes", "must be a positive distance in cells");
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDatasetUniquePtr dataset(driver->Create("", grid.width, grid.height, 1, GDT_Float32, nullptr));
  GDALRasterBand* band = dataset->GetRasterBand(1);
  band->SetNoDataValue(NAN);
  if (band->RasterIO(GF_Write, 0, 0, grid.width, grid.height, grid.z.data(), grid.width, grid.height, GDT_Float32, 0,
                     0) != CE_None) {
    throw Error("fill holes: cannot stage grid" + gdal_message());
  }
  GdalProgress bridge{progress};
  if (GDALFillNodata(band, nullptr, max_distance, 0, 0, nullptr, GdalProgress::call, &bridge) != CE_None) {
    if (bridge.cancelled) throw Cancelled();
    throw Error("fill holes: GDALFillNodata failed" + gdal_message());
  }
  if (band->RasterIO(GF_Read, 0, 0, grid.width, grid.height, grid.z.data(), grid.width, grid.height, GDT_Float32, 0,
                     0) != CE_None) {
    throw Error("fill holes: cannot read back" + gdal_message());
  }
}

}  // namespace dsmplan
