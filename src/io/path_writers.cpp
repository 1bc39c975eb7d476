// Paths as text: CSV in the data's CRS, GeoJSON (IETF RFC 7946, "The GeoJSON Format", 2016)
// in WGS 84. Formatting only; the coordinates come transformed (Wgs84Transform).
#include <charconv>
#include <cstdio>
#include <string>

#include "dsmplan/mission.hpp"

namespace dsmplan {

namespace {

std::string shortest(double v) {
  char buffer[32];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, v);
  return std::string(buffer, ec == std::errc() ? end : buffer);
}

}  // namespace

std::string path_to_csv(const std::vector<Point3>& path) {
  std::string text = "x,y,z\n";
  for (const Point3& p : path) text += shortest(p[0]) + "," + shortest(p[1]) + "," + shortest(p[2]) + "\n";
  return text;
}

std::string path_to_geojson(const std::vector<Point3>& lonlath, const std::string& properties) {
  std::string text =
      "{\"type\":\"Feature\",\"properties\":" + properties + ",\"geometry\":{\"type\":\"LineString\",\"coordinates\":[";
  char buffer[96];
  for (size_t i = 0; i < lonlath.size(); ++i) {
    std::snprintf(buffer, sizeof buffer, "%s[%.9f,%.9f,%.3f]", i ? "," : "", lonlath[i][0], lonlath[i][1],
                  lonlath[i][2]);
    text += buffer;
  }
  return text + "]}}\n";
}

}  // namespace dsmplan
