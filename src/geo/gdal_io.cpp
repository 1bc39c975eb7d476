// Raster and CRS I/O through GDAL and PROJ: the only place in dsmplan that depends on them.
#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <gdal_alg.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <proj.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "core/atomic_file.hpp"
#include "core/text.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "heights_statement.hpp"
#include "metric_crs.hpp"
#include "raster_inputs.hpp"

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
    // GDAL's block cache is 5 % of the physical memory by default, whatever ulimit -v or a
    // cgroup allow: at most an eighth of what this process may use, so that the up-front memory
    // checks that count it (geotiff_buffer_bytes()) hold.
    const double cap = std::floor(machine_memory_bytes() / 8);
    if (cap < double(GDALGetCacheMax64())) GDALSetCacheMax64(static_cast<GIntBig>(cap));
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

  // Units: metres per horizontal unit of a projected CRS (a geographic one has none: degrees).
  if (crs.geographic) {
    const char* angular = nullptr;
    horizontal.GetAngularUnits(&angular);
    crs.linear_unit = angular ? angular : "degree";
    crs.linear_unit_m = 0;
  } else if (horizontal.IsProjected() || horizontal.IsLocal()) {
    const char* unit = nullptr;
    crs.linear_unit_m = horizontal.GetLinearUnits(&unit);
    crs.linear_unit = unit ? unit : "";
  }

  if (!srs.IsCompound() && (srs.IsProjected() || srs.IsGeographic()) && srs.GetAxesCount() == 3) {
    // A 3D CRS (PROJ's promote_to_3D; a GeoTIFF whose VerticalGeoKey is a geographic 3D CRS such
    // as 4979): heights above its datum's ellipsoid.
    OGRSpatialReference geographic;
    geographic.CopyGeogCSFrom(&srs);
    crs.vertical_name =
        std::string(geographic.GetName() ? geographic.GetName() : "the datum's") + " ellipsoidal height";
    double metres = 1;
    srs.GetAxis(nullptr, 2, nullptr, &metres);
    crs.vertical_unit = std::abs(metres - 1) < 1e-12 ? "metre" : "";
    crs.vertical_unit_m = metres;
  }
  if (srs.IsCompound() || srs.IsVertical()) {
    const char* vertical = srs.GetAttrValue("VERT_CS");
    if (vertical) crs.vertical_name = vertical;
    const char* unit = nullptr;
    const double metres = srs.GetTargetLinearUnits("VERT_CS", &unit);
    if (unit) {
      crs.vertical_unit = unit;
      crs.vertical_unit_m = metres;
    }
  }
}

// "us survey foot" for "US_survey_foot", "US-survey foot", "  US survey  foot ".
std::string unit_key(const std::string& name) {
  std::string key;
  for (char c : name) {
    const char lower = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (lower == '_' || lower == '-' || std::isspace(static_cast<unsigned char>(lower))) {
      if (!key.empty() && key.back() != ' ') key += ' ';
    } else {
      key += lower;
    }
  }
  while (!key.empty() && key.back() == ' ') key.pop_back();
  return key;
}

// Linear units by unit_key(): the spellings raster bands use, then every linear unit of PROJ's
// database by name and PROJ short name ("metre", "m", "foot", "ft", "US survey foot", "us-ft", ...).
const std::map<std::string, double>& unit_table() {
  static const std::map<std::string, double> table = [] {
    constexpr double us_foot = 1200.0 / 3937.0;
    std::map<std::string, double> units{{"m", 1},
                                        {"metre", 1},
                                        {"metres", 1},
                                        {"meter", 1},
                                        {"meters", 1},
                                        {"ft", 0.3048},
                                        {"foot", 0.3048},
                                        {"feet", 0.3048},
                                        {"international foot", 0.3048},
                                        {"ftus", us_foot},
                                        {"us ft", us_foot},
                                        {"ft us", us_foot},
                                        {"us foot", us_foot},
                                        {"us feet", us_foot},
                                        {"foot us", us_foot},
                                        {"us survey foot", us_foot},
                                        {"us survey feet", us_foot},
                                        {"survey foot", us_foot},
                                        {"cm", 0.01},
                                        {"centimetre", 0.01},
                                        {"centimeter", 0.01},
                                        {"centimetres", 0.01},
                                        {"centimeters", 0.01},
                                        {"mm", 0.001},
                                        {"millimetre", 0.001},
                                        {"millimeter", 0.001},
                                        {"millimetres", 0.001},
                                        {"millimeters", 0.001},
                                        {"dm", 0.1},
                                        {"km", 1000},
                                        {"kilometre", 1000},
                                        {"kilometer", 1000}};
    PJ_CONTEXT* ctx = proj_context_create();
    int count = 0;
    PROJ_UNIT_INFO** list = proj_get_units_from_database(ctx, nullptr, "linear", false, &count);
    for (int i = 0; list && i < count; ++i) {
      if (!(list[i]->conv_factor > 0)) continue;
      units.emplace(unit_key(list[i]->name), list[i]->conv_factor);
      if (list[i]->proj_short_name) units.emplace(unit_key(list[i]->proj_short_name), list[i]->conv_factor);
    }
    proj_unit_list_destroy(list);
    proj_context_destroy(ctx);
    return units;
  }();
  return table;
}

std::string metres_text(double metres) {
  char text[32];
  std::snprintf(text, sizeof text, "%.7g m", metres);
  return text;
}

// "dsm_m.tif" for "dsm_ft.tif": where an example command would write the input in metres.
std::string metric_name(const std::string& path, const std::string& extension) {
  std::string stem = std::filesystem::path(path).stem().string();
  for (const char* suffix : {"_ftus", "_ftUS", "_feet", "_ft", "-ft"}) {
    const std::string s = suffix;
    if (stem.size() > s.size() && stem.compare(stem.size() - s.size(), s.size(), s) == 0) {
      stem.erase(stem.size() - s.size());
      break;
    }
  }
  return stem + "_m" + extension;
}

enum class DataKind { Raster, Points, Mesh, Cameras };

DataKind kind_of(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension == ".las" || extension == ".laz" || extension == ".xyz" || extension == ".txt" || extension == ".csv")
    return DataKind::Points;
  if (extension == ".ply" || extension == ".obj" || extension == ".off" || extension == ".glb") return DataKind::Mesh;
  if (extension == ".json") return DataKind::Cameras;  // CAMERAS.json of `dsmplan stereo --cameras`
  return DataKind::Raster;
}

// The EPSG code of a vertical CRS in metres for the same heights as `vertical_name` when PROJ's
// database has one by name ("NAVD88 height (ftUS)" -> "NAVD88 height", EPSG:5703), else 0.
int metre_vertical_crs(const std::string& vertical_name) {
  const size_t open = vertical_name.rfind(" (");
  if (open == std::string::npos) return 0;
  const std::string base = vertical_name.substr(0, open);
  PJ_CONTEXT* ctx = proj_context_create();
  PROJ_CRS_LIST_PARAMETERS* params = proj_get_crs_list_parameters_create();
  PJ_TYPE types[] = {PJ_TYPE_VERTICAL_CRS};
  params->types = types;
  params->typesCount = 1;
  int count = 0, code = 0;
  PROJ_CRS_INFO** list = proj_get_crs_info_list_from_database(ctx, "EPSG", params, &count);
  for (int i = 0; list && i < count && !code; ++i) {
    if (list[i]->deprecated) continue;
    const std::string name = list[i]->name;
    if (name == base || name == base + " (m)") code = std::atoi(list[i]->code);
  }
  proj_crs_info_list_destroy(list);
  proj_get_crs_list_parameters_destroy(params);
  proj_context_destroy(ctx);
  return code;
}

bool is_geocentric(const Crs& crs) {
  OGRSpatialReference srs;
  const std::string& text = crs.wkt.empty() ? crs.definition : crs.wkt;
  return !text.empty() && srs.SetFromUserInput(text.c_str()) == OGRERR_NONE && srs.IsGeocentric();
}

}  // namespace

double unit_metres(const std::string& unit) {
  const auto& table = unit_table();
  const auto found = table.find(unit_key(unit));
  return found == table.end() ? 0 : found->second;
}

void resolve_units(Crs& crs) {
  init_gdal();
  if (crs.linear_unit_m == 0 && !crs.geographic && (!crs.wkt.empty() || !crs.definition.empty())) {
    OGRSpatialReference srs;
    if (srs.SetFromUserInput(crs.wkt.empty() ? crs.definition.c_str() : crs.wkt.c_str()) == OGRERR_NONE) {
      Crs described;
      describe(srs, described);
      crs.geographic = described.geographic;
      crs.linear_unit = described.linear_unit;
      crs.linear_unit_m = described.linear_unit_m;
      if (crs.vertical_unit.empty()) crs.vertical_unit = described.vertical_unit;
      if (crs.vertical_name.empty()) crs.vertical_name = described.vertical_name;
    }
  }
  if (crs.vertical_unit_m == 0 && !crs.vertical_unit.empty()) crs.vertical_unit_m = unit_metres(crs.vertical_unit);
}

std::string utm_epsg_at(const Crs& crs, double x, double y) {
  init_gdal();
  OGRSpatialReference source, wgs84;
  const std::string& text = crs.wkt.empty() ? crs.definition : crs.wkt;
  if (text.empty() || source.SetFromUserInput(text.c_str()) != OGRERR_NONE) return "";
  if (source.IsCompound()) source.StripVertical();
  wgs84.SetWellKnownGeogCS("WGS84");
  source.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);  // x, y as the data has them
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);   // longitude, latitude
  std::unique_ptr<OGRCoordinateTransformation> to_wgs84(OGRCreateCoordinateTransformation(&source, &wgs84));
  double lon = x, lat = y;
  if (!to_wgs84 || !to_wgs84->Transform(1, &lon, &lat) || !std::isfinite(lon) || !(std::abs(lat) <= 90)) return "";
  lon = std::remainder(lon, 360.0);  // -180 .. 180
  const int zone = std::clamp(static_cast<int>(std::floor((lon + 180) / 6)) + 1, 1, 60);
  return "EPSG:" + std::to_string(lat >= 0 ? 32600 + zone : 32700 + zone);
}

std::string metric_problem(const Crs& given, const std::string& path, double centre_x, double centre_y,
                           bool units_only) {
  if (proven_metric(given, centre_x, centre_y, units_only)) return "";
  Crs crs = given;
  resolve_units(crs);
  const bool geocentric = !units_only && is_geocentric(crs);
  const bool horizontal_wrong = crs.geographic ? !units_only : crs.linear_unit_m > 0 && !is_metre(crs.linear_unit_m);
  const bool vertical_wrong = !crs.vertical_unit.empty() && !is_metre(crs.vertical_unit_m);
  // A projected CRS in metres whose metres are not the ground's (Web Mercator: 1.6 at 51 N).
  const double stretch = !units_only && !horizontal_wrong && !geocentric && !crs.geographic
                             ? scale_departure(crs.wkt.empty() ? crs.definition : crs.wkt, centre_x, centre_y)
                             : 0;
  if (!geocentric && !horizontal_wrong && !vertical_wrong && !(stretch > kMaxScaleDeparture)) return "";

  const std::string name = crs.name.empty() ? std::string("unnamed") : crs.name;
  std::string utm = utm_epsg_at(crs, centre_x, centre_y);
  const bool known_utm = !utm.empty();
  if (!known_utm) utm = "EPSG:<UTM zone of the data>";
  const DataKind kind = kind_of(path);
  // An example that makes x, y (and, with a vertical CRS in metres, heights) metres.
  auto reproject = [&](const std::string& target) {
    switch (kind) {
      case DataKind::Points:
        return "pdal translate " + path + " " + metric_name(path, ".las") +
               " -f filters.reprojection --filters.reprojection.out_srs=" + target;
      case DataKind::Mesh:
        return "make the mesh again from its DSM reprojected with gdalwarp -t_srs " + target;
      case DataKind::Cameras:
        return "state the cameras in " + target + " (their centres and rotations transformed, e.g. by cs2cs)";
      case DataKind::Raster:
        break;
    }
    return "gdalwarp -t_srs " + target + " " + path + " " + metric_name(path, ".tif");
  };

  if (geocentric)
    return "CRS '" + name +
           "' is geocentric (x, y, z from the Earth's centre): reproject to a projected CRS in "
           "metres first, e.g. " +
           reproject(utm);
  if (stretch > kMaxScaleDeparture) {
    char factor[96];
    std::snprintf(factor, sizeof factor, "%.4g at the data's centre: 2 m in it are %.2f m on the ground", 1 + stretch,
                  2 / (1 + stretch));
    return "CRS '" + name + "' stretches lengths by a scale factor of " + factor + " (at most " +
           format_number(100 * kMaxScaleDeparture) +
           " % from 1 keeps --safety a ground distance); reproject to the UTM zone of the data first, e.g. " +
           reproject(utm);
  }
  if (horizontal_wrong && crs.geographic)
    return "CRS '" + name + "' is geographic (degrees); reproject to a projected CRS in metres first, e.g. " +
           reproject(utm);
  if (horizontal_wrong)
    return "CRS '" + name + "' has horizontal unit " + crs.linear_unit + " (" + metres_text(crs.linear_unit_m) +
           "): dsmplan measures in metres; reproject first, e.g. " + reproject(utm);

  // Heights in another unit: from the vertical axis of a compound CRS, or the band's unit type.
  if (crs.vertical_unit_m == 0)
    return "vertical unit '" + crs.vertical_unit +
           "' is not a length unit dsmplan knows: dsmplan measures heights in metres; declare them as metres "
           "(e.g. gdal_edit.py -units m " +
           path + ") only if they are";
  const std::string unit = crs.vertical_unit + " (" + metres_text(crs.vertical_unit_m) + ")";
  const std::string measures = ": dsmplan measures heights in metres; ";
  if (!crs.vertical_name.empty()) {
    const int vertical = metre_vertical_crs(crs.vertical_name);
    // A compound target converts the heights too (gdalwarp, PDAL apply the vertical transformation).
    std::string target = known_utm ? utm : "EPSG:<projected CRS in metres>";
    target += vertical ? "+" + std::to_string(vertical) : "+<vertical CRS in metres>";
    return "heights are in " + unit + " (vertical CRS '" + crs.vertical_name + "')" + measures +
           "reproject first, e.g. " + reproject(target);
  }
  char factor[32];
  std::snprintf(factor, sizeof factor, "%.10g", crs.vertical_unit_m);
  if (kind == DataKind::Raster) {
    const std::string out = metric_name(path, ".tif");
    return "heights are in " + unit + measures + "convert them first, e.g. gdal_calc.py -A " + path + " --calc=\"A*" +
           factor + "\" --outfile=" + out + " && gdal_edit.py -units m " + out;
  }
  if (kind == DataKind::Mesh) return "heights are in " + unit + measures + "make the mesh again from a DSM in metres";
  return "heights are in " + unit + measures + "convert them to metres first (multiply by " + factor + ")";
}

void resolve_crs(Crs& crs) {
  init_gdal();
  if (crs.definition.empty()) return;
  OGRSpatialReference srs;
  if (srs.SetFromUserInput(crs.definition.c_str()) != OGRERR_NONE) {
    throw ArgumentError("crs", "cannot interpret CRS '" + crs.definition.substr(0, 60) + "'" + gdal_message());
  }
  describe(srs, crs);
}

namespace {

// One band of a GDAL raster, read by windows. Every window gets read_raster()'s treatment:
// declared nodata and masked cells become NaN, scale and offset are applied, south-up rasters
// are turned north-up, and an undeclared NaN or an infinite height is refused by cell.
class GdalGridSource : public GridSource {
public:
  GdalGridSource(const std::string& path, const ReadRasterOptions& options) : path_(path), band_index_(options.band) {
    init_gdal();
    require_raster_files(path);  // a FIFO (or a VRT naming one) would hold GDALOpen forever
    VSIStatBufL stat;
    if (VSIStatL(path.c_str(), &stat) != 0) throw InputError(path, "", "no such file");
    if (VSI_ISDIR(stat.st_mode)) throw InputError(path, "", "is a directory, not a raster");
    CPLErrorReset();
    dataset_.reset(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
    if (!dataset_) throw InputError(path, "", "not a raster GDAL can read" + gdal_message());
    const int width = dataset_->GetRasterXSize(), height = dataset_->GetRasterYSize();
    if (width <= 0 || height <= 0) throw InputError(path, "", "raster has no cells");
    if (dataset_->GetRasterCount() < 1) throw InputError(path, "", "raster has no band");
    if (options.band < 1 || options.band > dataset_->GetRasterCount()) {
      throw ArgumentError("band", "band " + std::to_string(options.band) + " does not exist in " + path + " (it has " +
                                      std::to_string(dataset_->GetRasterCount()) + ")");
    }
    double gt[6];
    if (dataset_->GetGeoTransform(gt) != CE_None) throw InputError(path, "", "not geo-referenced (no geotransform)");
    if (gt[2] != 0 || gt[4] != 0)
      throw InputError(path, "geotransform", "rotated or sheared rasters are not supported");
    if (!(gt[1] > 0) || gt[5] == 0) throw InputError(path, "geotransform", "cell size must be positive");
    south_up_ = gt[5] > 0;
    frame_.width = width;
    frame_.height = height;
    frame_.x0 = gt[0];
    frame_.y0 = south_up_ ? gt[3] + height * gt[5] : gt[3];
    frame_.cell_x = gt[1];
    frame_.cell_y = std::abs(gt[5]);
    if (const std::string problem = frame_problem(frame_); !problem.empty())
      throw InputError(path, "geotransform", problem);
    // --crs overrides what the file states, as gdal_translate -a_srs and `grid --crs` do.
    const OGRSpatialReference* srs = dataset_->GetSpatialRef();
    if (!options.assign_crs.empty()) {
      frame_.crs.definition = options.assign_crs;
      resolve_crs(frame_.crs);
    } else if (srs && !srs->IsEmpty()) {
      OGRSpatialReference stated(*srs);
      const char* heights = dataset_->GetMetadataItem(kEllipsoidalHeightsKey);
      const std::string said = heights ? heights : "";
      const bool ellipsoidal = (said.rfind("EPSG:4979", 0) == 0 || said.find(" ellipsoid") != std::string::npos) &&
                               stated.IsProjected() && !stated.IsCompound() && stated.GetAxesCount() == 2;
      if (ellipsoidal) stated.PromoteTo3D(nullptr);
      describe(stated, frame_.crs);
      if (ellipsoidal) {  // the promoted CRS has no EPSG code of its own: the horizontal one's
        Crs flat;
        describe(*srs, flat);
        frame_.crs.epsg = flat.epsg;
      }
    } else if (!options.allow_no_crs) {
      throw InputError(path, "", "raster has no CRS; assign one with --crs (e.g. --crs EPSG:25832)");
    }
    band_ = dataset_->GetRasterBand(options.band);
    // The band's unit type names the heights' unit when the CRS does not, and stands against a
    // CRS in metres when it says otherwise (either way the heights are not known to be metres).
    const char* band_unit = band_->GetUnitType();
    if (band_unit && *band_unit) {
      const double band_metres = unit_metres(band_unit);
      if (frame_.crs.vertical_unit.empty() || std::abs(band_metres - 1) > 1e-9) {
        frame_.crs.vertical_unit = band_unit;
        frame_.crs.vertical_unit_m = band_metres;
      }
    }
    // dsmplan measures in metres: x, y or heights in feet are refused here, before any cell is
    // read, naming the unit (degrees are the tools' to refuse: `info` and `render` take them).
    if (!options.allow_other_units) {
      const std::string problem = metric_problem(frame_.crs, path, frame_.x0 + width * frame_.cell_x / 2,
                                                 frame_.y0 - height * frame_.cell_y / 2, /*units_only=*/true);
      if (!problem.empty()) throw InputError(path, "", problem);
    }
    read_mask_ = !(band_->GetMaskFlags() & (GMF_ALL_VALID | GMF_NODATA));
    int has_nodata = 0;
    nodata_ = band_->GetNoDataValue(&has_nodata);
    has_nodata_ = has_nodata != 0;
    int has_scale = 0, has_offset = 0;
    scale_ = band_->GetScale(&has_scale);
    offset_ = band_->GetOffset(&has_offset);
    if (!has_scale) scale_ = 1;
    if (!has_offset) offset_ = 0;
  }

  const Grid& frame() const override { return frame_; }
  bool reads_mask() const { return read_mask_; }

  void read(int col0, int row0, int w, int h, float* out) override { read(col0, row0, w, h, out, {}); }

  void read(int col0, int row0, int w, int h, float* out, const Progress& progress) {
    if (col0 < 0 || row0 < 0 || w <= 0 || h <= 0 || col0 + w > frame_.width || row0 + h > frame_.height)
      throw Error(path_ + ": window outside the raster");  // a caller's bug, not the data's
    // The file's rows for a south-up raster run the other way.
    const int file_row0 = south_up_ ? frame_.height - row0 - h : row0;
    GdalProgress bridge{progress};
    GDALRasterIOExtraArg extra;
    INIT_RASTERIO_EXTRA_ARG(extra);
    extra.pfnProgress = GdalProgress::call;
    extra.pProgressData = &bridge;
    CPLErrorReset();
    if (band_->RasterIO(GF_Read, col0, file_row0, w, h, out, w, h, GDT_Float32, 0, 0, &extra) != CE_None) {
      if (bridge.cancelled) throw Cancelled();
      throw InputError(path_, "band " + std::to_string(band_index_), "cannot read heights" + gdal_message());
    }
    const size_t cells = static_cast<size_t>(w) * h;
    if (south_up_) {
      for (int row = 0; row < h / 2; ++row)
        std::swap_ranges(out + static_cast<size_t>(row) * w, out + static_cast<size_t>(row + 1) * w,
                         out + static_cast<size_t>(h - 1 - row) * w);
    }
    // An explicit mask (internal mask, alpha) marks nodata too.
    std::vector<GByte> mask;
    if (read_mask_) {
      mask.resize(cells);
      if (band_->GetMaskBand()->RasterIO(GF_Read, col0, file_row0, w, h, mask.data(), w, h, GDT_Byte, 0, 0) !=
          CE_None) {
        throw InputError(path_, "mask band", "cannot read" + gdal_message());
      }
    }
    const bool nan_is_nodata = has_nodata_ && std::isnan(nodata_);
    const float nodata_value = static_cast<float>(nodata_);
    const bool rescale = scale_ != 1 || offset_ != 0;
    for (int row = 0; row < h; ++row) {
      const int mask_row = south_up_ ? h - 1 - row : row;
      for (int col = 0; col < w; ++col) {
        float& z = out[static_cast<size_t>(row) * w + col];
        if ((has_nodata_ && !nan_is_nodata && z == nodata_value) ||
            (!mask.empty() && mask[static_cast<size_t>(mask_row) * w + col] == 0)) {
          z = Grid::nodata;
          continue;
        }
        if (std::isnan(z)) {
          if (nan_is_nodata) continue;
          throw InputError(path_, cell_place(frame_, col0 + col, row0 + row),
                           "height is NaN but the raster declares no NaN nodata");
        }
        if (std::isinf(z)) throw InputError(path_, cell_place(frame_, col0 + col, row0 + row), "height is infinite");
        if (rescale) z = static_cast<float>(z * scale_ + offset_);
        if (!(std::abs(z) <= kMaxHeight)) {
          char text[160];
          std::snprintf(text, sizeof text,
                        "height %.6g is no height on Earth (beyond +-100 km): a nodata sentinel "
                        "the raster does not declare? Declare it as the band's nodata",
                        z);
          throw InputError(path_, cell_place(frame_, col0 + col, row0 + row), text);
        }
      }
    }
  }

private:
  std::string path_;
  int band_index_;
  GDALDatasetUniquePtr dataset_;
  GDALRasterBand* band_ = nullptr;
  Grid frame_;
  bool south_up_ = false, read_mask_ = false, has_nodata_ = false;
  double nodata_ = 0, scale_ = 1, offset_ = 0;
};

}  // namespace

std::unique_ptr<GridSource> open_raster(const std::string& path, const ReadRasterOptions& options) {
  return std::make_unique<GdalGridSource>(path, options);
}

Grid read_raster(const std::string& path, const ReadRasterOptions& options, const Progress& progress) {
  GdalGridSource source(path, options);
  Grid grid = source.frame();
  // A float per cell, a byte more when a mask band has to be read alongside.
  require_memory(path, std::to_string(grid.width) + " x " + std::to_string(grid.height) + " cells",
                 double(grid.width) * double(grid.height) *
                     (sizeof(float) + (source.reads_mask() ? 1 : 0) + options.extra_bytes_per_cell));
  grid.z.assign(static_cast<size_t>(grid.width) * grid.height, Grid::nodata);
  source.read(0, 0, grid.width, grid.height, grid.z.data(), progress);
  if (std::all_of(grid.z.begin(), grid.z.end(), [](float z) { return std::isnan(z); })) {
    throw InputError(path, "", "no valid cell: every cell is nodata");
  }
  return grid;
}

double geotiff_buffer_bytes() {
  init_gdal();
  return double(GDALGetCacheMax64());
}

void write_geotiff(const Grid& grid, const std::string& path, const Progress& progress) {
  init_gdal();
  // Nothing is written that dsmplan's own reader refuses (the callers check earlier, before their work).
  if (const std::string problem = frame_problem(grid); !problem.empty())
    throw OutputError(path, "not written: " + problem);
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
      // GeoTIFF stores a compound CRS as the codes of its parts: from the WKT of a compound
      // with one code of its own (EPSG:7415, RD New + NAP height) GDAL writes no vertical keys,
      // and the heights' datum would be lost. Its EPSG definition carries the parts' codes.
      const char* authority = srs.GetAuthorityName(nullptr);
      const char* code = srs.GetAuthorityCode(nullptr);
      if (srs.IsCompound() && authority && code && EQUAL(authority, "EPSG")) {
        OGRSpatialReference by_code;
        if (by_code.importFromEPSG(std::atoi(code)) == OGRERR_NONE) srs = by_code;
      }
      // A projected CRS made 3D (a satellite DSM's: heights above its datum's ellipsoid) has no
      // GeoTIFF keys: the 2D CRS goes to the keys and the heights to the metadata, or a DSM
      // written from memory (Python's Dsm.write()) would lose what its heights are.
      if (srs.IsProjected() && !srs.IsCompound() && srs.GetAxesCount() == 3) {
        dataset->SetMetadataItem(kEllipsoidalHeightsKey, ellipsoid_statement(srs).c_str());
        srs.DemoteTo2D(nullptr);
      }
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
  if (!(max_distance > 0)) throw ArgumentError("max_distance", "must be a positive distance in cells");
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDatasetUniquePtr dataset(driver->Create("", grid.width, grid.height, 1, GDT_Float32, nullptr));
  GDALRasterBand* band = dataset->GetRasterBand(1);
  band->SetNoDataValue(NAN);
  if (band->RasterIO(GF_Write, 0, 0, grid.width, grid.height, grid.z.data(), grid.width, grid.height, GDT_Float32, 0,
                     0) != CE_None) {
    throw Error("fill holes: cannot stage grid" + gdal_message());
  }
  GdalProgress bridge{progress};
  // Its work rasters in memory, not as GeoTIFFs in the current folder (see raster_io.hpp).
  CPLStringList options;
  options.SetNameValue("TEMP_FILE_DRIVER", "MEM");
  if (GDALFillNodata(band, nullptr, max_distance, 0, 0, options.List(), GdalProgress::call, &bridge) != CE_None) {
    if (bridge.cancelled) throw Cancelled();
    throw Error("fill holes: GDALFillNodata failed" + gdal_message());
  }
  if (band->RasterIO(GF_Read, 0, 0, grid.width, grid.height, grid.z.data(), grid.width, grid.height, GDT_Float32, 0,
                     0) != CE_None) {
    throw Error("fill holes: cannot read back" + gdal_message());
  }
}

std::string ellipsoid_statement(const OGRSpatialReference& srs) {
  OGRSpatialReference geographic;
  geographic.CopyGeogCSFrom(&srs);
  const std::string datum = geographic.GetName() ? geographic.GetName() : "";
  return datum == "WGS 84" ? "EPSG:4979 (heights above the WGS 84 ellipsoid)"
                           : "heights above the " + datum + " ellipsoid";
}

}  // namespace dsmplan
