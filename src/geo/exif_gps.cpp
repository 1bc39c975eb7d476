// The camera centres images record in their EXIF GPS tags (dsmplan/stereo_io.hpp), for `dsmplan
// stereo --colmap MODEL --centres exif`. The tags (EXIF 2.32, CIPA DC-008-2019, Section 4.6.6,
// "GPS Attribute Information"): GPSLatitude and GPSLongitude three RATIONALs, degrees, minutes,
// seconds, with GPSLatitudeRef 'N'/'S' and GPSLongitudeRef 'E'/'W'; GPSAltitude one RATIONAL, metres,
// with GPSAltitudeRef 0 (above sea level) or 1 (below). GDAL's JPEG and GTiff drivers give them as
// metadata items EXIF_GPSLatitude = "(51) (25) (30.5)" (gcore/gdalexif.cpp). The altitude is above
// sea level by the standard's definition: it is taken as an EGM96 height (EPSG:5773, the mean sea
// level GPS receivers report), with the position on WGS 84 (EPSG:4326), and carried into the
// --crs by PROJ through Wgs84Transform (wgs84_transform.cpp): horizontally exact; a 2D --crs keeps
// the EGM96 height (so the DSM's heights are EGM96 heights), a compound one gets its own heights
// through the geoid grids or is refused where PROJ has only a ballpark.
#include <gdal_priv.h>

#include <cmath>
#include <memory>
#include <sstream>

#include "core/text.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/stereo_io.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {
namespace {

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};

// The numbers of a GDAL EXIF value: "(51) (25) (30.5)", "(123.5)", or bare numbers.
std::vector<double> exif_numbers(const std::string& path, const char* tag, const std::string& text) {
  std::string spaced = text;
  for (char& c : spaced)
    if (c == '(' || c == ')' || c == ',') c = ' ';
  std::istringstream in(spaced);
  std::vector<double> out;
  for (std::string word; in >> word;) {
    std::size_t used = 0;
    double value = NAN;
    try {
      value = std::stod(word, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != word.size() || !std::isfinite(value))
      throw InputError(path, std::string("EXIF ") + tag, "not a number: " + shown(text));
    out.push_back(value);
  }
  return out;
}

// Degrees of a GPSLatitude or GPSLongitude: degrees, minutes, seconds (or fewer, as some writers do).
double exif_degrees(const std::string& path, const char* tag, const std::string& text, double limit) {
  const std::vector<double> dms = exif_numbers(path, tag, text);
  if (dms.empty() || dms.size() > 3)
    throw InputError(path, std::string("EXIF ") + tag, "expected degrees, minutes, seconds, got " + shown(text));
  double degrees = 0;
  for (std::size_t i = 0; i < dms.size(); ++i) {
    if (dms[i] < 0 || (i > 0 && dms[i] >= 60))
      throw InputError(path, std::string("EXIF ") + tag, "degrees, minutes, seconds out of range: " + shown(text));
    degrees += dms[i] / std::pow(60.0, static_cast<double>(i));
  }
  if (degrees > limit) throw InputError(path, std::string("EXIF ") + tag, "beyond " + short_number(limit) + " degrees");
  return degrees;
}

std::string item(GDALDataset& data, const char* name) {
  const char* value = data.GetMetadataItem(name);
  std::string out = value ? value : "";
  const auto first = out.find_first_not_of(" \t");
  return first == std::string::npos ? "" : out.substr(first, out.find_last_not_of(" \t") - first + 1);
}

}  // namespace

std::optional<ExifGps> read_exif_gps(const std::string& path) {
  require_input_file(path);
  std::unique_ptr<GDALDataset, DatasetCloser> data(
      GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  if (!data) throw InputError(path, "", "missing, or not an image GDAL can read");
  const std::string latitude = item(*data, "EXIF_GPSLatitude"), longitude = item(*data, "EXIF_GPSLongitude");
  const std::string altitude = item(*data, "EXIF_GPSAltitude");
  if (latitude.empty() || longitude.empty() || altitude.empty()) return std::nullopt;
  ExifGps gps;
  gps.latitude = exif_degrees(path, "GPSLatitude", latitude, 90);
  gps.longitude = exif_degrees(path, "GPSLongitude", longitude, 180);
  const std::string north = item(*data, "EXIF_GPSLatitudeRef"), east = item(*data, "EXIF_GPSLongitudeRef");
  if (north == "S" || north == "s")
    gps.latitude = -gps.latitude;
  else if (!north.empty() && north != "N" && north != "n")
    throw InputError(path, "EXIF GPSLatitudeRef", "must be N or S, got " + shown(north));
  if (east == "W" || east == "w")
    gps.longitude = -gps.longitude;
  else if (!east.empty() && east != "E" && east != "e")
    throw InputError(path, "EXIF GPSLongitudeRef", "must be E or W, got " + shown(east));
  const std::vector<double> metres = exif_numbers(path, "GPSAltitude", altitude);
  if (metres.size() != 1 || metres[0] < 0)
    throw InputError(path, "EXIF GPSAltitude", "expected one number of metres, got " + shown(altitude));
  gps.altitude = metres[0];
  const std::string below = item(*data, "EXIF_GPSAltitudeRef");
  // GDAL gives the BYTE as "0x00" or "0x01"; writers that store the character '0' or '1' give "0x30", "0x31".
  if (below == "1" || below == "0x01" || below == "0x31")
    gps.altitude = -gps.altitude;
  else if (!below.empty() && below != "0" && below != "0x00" && below != "0x30")
    throw InputError(path, "EXIF GPSAltitudeRef", "must be 0 (above sea level) or 1 (below), got " + shown(below));
  return gps;
}

ImageCentres exif_centres(const std::vector<std::string>& image_paths, const std::string& crs_definition) {
  Crs crs;
  crs.definition = crs_definition;
  resolve_crs(crs);
  VerticalOptions vertical;
  vertical.vertical_crs = "EPSG:5773";  // EGM96 height: used when the --crs has no vertical part of its own
  std::optional<Wgs84Transform> transform;
  try {
    transform.emplace(crs, HeightReference::MeanSeaLevel, vertical);
  } catch (const ArgumentError& error) {
    throw ArgumentError("--crs", "the EXIF GPS centres cannot be carried into it: " + error.problem());
  }
  ImageCentres out;
  out.heights =
      "EXIF GPSAltitude (above mean sea level) taken as EGM96 heights (EPSG:4326+5773), converted by "
      "PROJ: " +
      transform->description();
  for (const std::string& path : image_paths) {
    const std::optional<ExifGps> gps = read_exif_gps(path);
    if (!gps) {
      out.centres.emplace_back();
      continue;
    }
    const Point3 p = transform->from_wgs84({gps->longitude, gps->latitude, gps->altitude});
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      throw InputError(path, "EXIF GPS", "PROJ cannot carry this position into the --crs");
    out.centres.emplace_back(Vec3{p[0], p[1], p[2]});
  }
  return out;
}

}  // namespace dsmplan
