// RPC readers (dsmplan/rpc.hpp): OSSIM keyword lists (.geom), GDAL's RPC metadata domain,
// and the sensor offset of a crop from its GeoTIFF transform.
//
// The .geom keys are those OSSIM's ossimRpcModel::saveState writes and OTB, CARS and shareloc read
// (line_off .. height_scale, line_num_coeff_00 .. samp_den_coeff_19, polynomial_format B); GDAL's
// keys are those of its RPC domain (LINE_OFF .. SAMP_DEN_COEFF, GDALExtractRPCInfoV2).
#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal.h>
#include <gdal_priv.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "core/text.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/rpc.hpp"
#include "dsmplan/rpc_io.hpp"
#include "raster_inputs.hpp"

namespace dsmplan {

namespace {

constexpr std::uint64_t kMaxGeomBytes = 1 << 20;

void init_gdal_quietly() {
  static std::once_flag once;
  std::call_once(once, [] {
    GDALAllRegister();
    CPLSetConfigOption("GDAL_PAM_ENABLED", "NO");
    CPLSetErrorHandler(CPLQuietErrorHandler);
  });
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

// A whole string as a finite double, or false.
bool parse_double(const std::string& text, double& out) {
  const std::string t = trim(text);
  if (t.empty()) return false;
  errno = 0;
  char* end = nullptr;
  out = std::strtod(t.c_str(), &end);
  return end == t.c_str() + t.size() && errno != ERANGE && std::isfinite(out);
}

struct Keys {
  std::string file;
  std::map<std::string, std::string> values;
  double number(const std::string& key) const {
    const auto it = values.find(key);
    if (it == values.end()) throw InputError(file, key, "missing");
    double v = 0;
    if (!parse_double(it->second, v)) throw InputError(file, key, "not a number: " + shown(it->second));
    return v;
  }
};

// The ten offsets and scales, named in lower case in a .geom ("line_off"), in upper case in
// GDAL's RPC metadata ("LINE_OFF").
void read_offsets_and_scales(const Keys& keys, bool upper_case, RpcModel& m) {
  const std::pair<const char*, double*> fields[10] = {{"line_off", &m.line_off},     {"samp_off", &m.samp_off},
                                                      {"lat_off", &m.lat_off},       {"long_off", &m.long_off},
                                                      {"height_off", &m.height_off}, {"line_scale", &m.line_scale},
                                                      {"samp_scale", &m.samp_scale}, {"lat_scale", &m.lat_scale},
                                                      {"long_scale", &m.long_scale}, {"height_scale", &m.height_scale}};
  for (const auto& [name, field] : fields) {
    std::string key = name;
    if (upper_case)
      for (char& c : key) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    *field = keys.number(key);
  }
}

void check_scales(const RpcModel& m, const std::string& file, const char* const names[5]) {
  const double scales[5] = {m.line_scale, m.samp_scale, m.lat_scale, m.long_scale, m.height_scale};
  for (int i = 0; i < 5; ++i)
    if (scales[i] == 0) throw InputError(file, names[i], "is zero (a scale divides)");
}

}  // namespace

RpcModel read_ossim_geom(const std::string& path) {
  require_input_file(path, kMaxGeomBytes, "an OSSIM .geom");  // about 10 kB: 1 MB is no .geom
  std::ifstream in(path);
  if (!in) throw InputError(path, "", std::filesystem::exists(path) ? "cannot be read" : "no such file");
  Keys keys{path, {}};
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (trim(line).empty() || trim(line)[0] == '/' || trim(line)[0] == '#') continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos)
      throw InputError(path, "line " + std::to_string(number), "not a \"key: value\" line");
    const std::string key = trim(line.substr(0, colon));
    if (!keys.values.emplace(key, trim(line.substr(colon + 1))).second) throw InputError(path, key, "repeated");
  }
  if (const auto it = keys.values.find("polynomial_format"); it != keys.values.end() && it->second != "B")
    throw InputError(path, "polynomial_format", "is " + shown(it->second) + "; only B (RPC00B) is read");
  if (const auto it = keys.values.find("type"); it != keys.values.end() && it->second.find("Rpc") == std::string::npos)
    throw InputError(path, "type", "is " + shown(it->second) + ", not an RPC model");
  RpcModel m;
  read_offsets_and_scales(keys, false, m);
  auto coeffs = [&](const std::string& stem, std::array<double, 20>& out) {
    for (int i = 0; i < 20; ++i) out[i] = keys.number(stem + (i < 10 ? "0" : "") + std::to_string(i));
  };
  coeffs("line_num_coeff_", m.line_num);
  coeffs("line_den_coeff_", m.line_den);
  coeffs("samp_num_coeff_", m.samp_num);
  coeffs("samp_den_coeff_", m.samp_den);
  static const char* const names[5] = {"line_scale", "samp_scale", "lat_scale", "long_scale", "height_scale"};
  check_scales(m, path, names);
  return m;
}

namespace {

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};

std::unique_ptr<GDALDataset, DatasetCloser> open_raster(const std::string& path) {
  require_raster_files(path);
  init_gdal_quietly();
  VSIStatBufL stat;  // GDAL's stat: /vsizip/, /vsicurl/ ... paths are files too
  if (VSIStatL(path.c_str(), &stat) != 0) throw InputError(path, "", "no such file");
  std::unique_ptr<GDALDataset, DatasetCloser> ds(
      GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  if (!ds) throw InputError(path, "", "not a raster GDAL can read");
  return ds;
}

}  // namespace

RpcModel read_gdal_rpc(const std::string& raster_path) {
  auto ds = open_raster(raster_path);
  char** md = ds->GetMetadata("RPC");
  if (!md || CSLCount(md) == 0)
    throw InputError(raster_path, "", "has no RPC (no RPC tags, _RPC.TXT, .RPB or .geom beside it)");
  Keys keys{raster_path, {}};
  for (char** p = md; *p; ++p) {
    char* key = nullptr;
    const char* value = CPLParseNameValue(*p, &key);
    if (key && value) keys.values[key] = value;
    CPLFree(key);
  }
  RpcModel m;
  read_offsets_and_scales(keys, true, m);
  // The coefficient lists are 20 numbers separated by spaces.
  auto coeffs = [&](const std::string& key, std::array<double, 20>& out) {
    const auto it = keys.values.find(key);
    if (it == keys.values.end()) throw InputError(raster_path, key, "missing");
    const CPLStringList words(CSLTokenizeString2(it->second.c_str(), " ,", 0));
    if (words.size() != 20)
      throw InputError(raster_path, key, "has " + std::to_string(words.size()) + " numbers, RPC00B needs 20");
    for (int i = 0; i < 20; ++i)
      if (!parse_double(words[i], out[i]))
        throw InputError(raster_path, key, "term " + std::to_string(i + 1) + " is not a number: " + shown(words[i]));
  };
  coeffs("LINE_NUM_COEFF", m.line_num);
  coeffs("LINE_DEN_COEFF", m.line_den);
  coeffs("SAMP_NUM_COEFF", m.samp_num);
  coeffs("SAMP_DEN_COEFF", m.samp_den);
  static const char* const names[5] = {"LINE_SCALE", "SAMP_SCALE", "LAT_SCALE", "LONG_SCALE", "HEIGHT_SCALE"};
  check_scales(m, raster_path, names);
  return m;
}

std::array<double, 2> read_sensor_offset(const std::string& raster_path) {
  auto ds = open_raster(raster_path);
  double gt[6];
  if (ds->GetGeoTransform(gt) != CE_None) return {0, 0};  // no transform: the image is the scene
  if (ds->GetSpatialRef() != nullptr)
    throw InputError(raster_path, "transform", "is georeferenced (has a CRS): not a sensor-geometry image");
  if (gt[1] != 1 || gt[2] != 0 || gt[4] != 0 || gt[5] != 1)
    throw InputError(raster_path, "transform", "is not a shift by whole pixels (scale 1, no rotation)");
  std::array<double, 2> offset{};
  for (int axis = 0; axis < 2; ++axis) {
    const double origin = gt[axis * 3];
    const double fraction = origin - std::floor(origin);
    // Fraction .5: Airbus's writer, whose transform gives the RPC's own position (Pléiades RPCs
    // put the centre of the scene's first pixel at 1, the corner of the crop's first pixel at
    // sample k + 1 - 0.5 for a crop starting at the scene's (0-based) pixel k); fraction 0: GDAL's
    // convention (the corner at k; the RPC's position of that corner is k + 1 - 0.5). Proven on
    // the pairs by tie points (tests/rpc_test.cpp, RpcSensorOffset).
    if (std::abs(fraction - 0.5) < 1e-6)
      offset[axis] = origin + 0.5;
    else if (fraction < 1e-6 || fraction > 1 - 1e-6)
      offset[axis] = std::round(origin) + 1;
    else
      throw InputError(raster_path, "transform",
                       std::string(axis == 0 ? "column" : "row") + " origin " + std::to_string(origin) +
                           " is neither whole nor half: not a crop cut on the scene's pixel grid");
  }
  return offset;
}

bool has_rpc(const std::string& raster_path) {
  if (std::filesystem::exists(std::filesystem::path(raster_path).replace_extension(".geom"))) return true;
  auto ds = open_raster(raster_path);
  char** md = ds->GetMetadata("RPC");
  return md && CSLCount(md) > 0;
}

RpcCamera read_rpc_camera(const std::string& raster_path) {
  const std::filesystem::path geom = std::filesystem::path(raster_path).replace_extension(".geom");
  if (std::filesystem::exists(geom)) {
    const auto offset = read_sensor_offset(raster_path);
    return RpcCamera(read_ossim_geom(geom.string()), offset[0], offset[1]);
  }
  return RpcCamera(read_gdal_rpc(raster_path));
}

}  // namespace dsmplan
