// Drone missions and KML from a path. Formatting only: the points come transformed to WGS 84
// longitude, latitude and height above mean sea level (Wgs84Transform, HeightReference::
// MeanSeaLevel, EGM96) and are written as the formats' documentation says:
//   QGroundControl .plan: "Plan File Format", QGroundControl Developer Guide
//     (docs.qgroundcontrol.com, qgc-dev-guide/file_formats/plan): fileType "Plan", version 1;
//     mission version 2 with firmwareType (MAV_AUTOPILOT), vehicleType (MAV_TYPE), cruiseSpeed,
//     hoverSpeed, items (SimpleItem: command, frame, params = MISSION_ITEM param1..4, x = latitude,
//     y = longitude, z = altitude), plannedHomePosition [latitude, longitude, AMSL altitude].
//     QGC writes a NaN parameter as null and reads null back as NaN; AltitudeMode 2 is QGC's
//     AltitudeModeAbsolute (its enum: Mixed, Relative, Absolute, CalcAboveTerrain, TerrainFrame).
//   QGC WPL 110: "File Formats", MAVLink Developer Guide (mavlink.io/en/file_formats): a header
//     line, then one mission item a line, 12 tab-separated fields INDEX CURRENT_WP COORD_FRAME
//     COMMAND PARAM1..4 PARAM5/X/LATITUDE PARAM6/Y/LONGITUDE PARAM7/Z/ALTITUDE AUTOCONTINUE; item 0
//     is the home position (QGC's loader takes it so for version 110). The page's example has its
//     latitude and longitude columns the wrong way round (8.548, 47.376 for Zurich); QGC's loader
//     (MissionItem::load(QTextStream&)) sets param5 = field 9 as the latitude, and so do we.
//   KML: OGC KML 2.2 (OGC 07-147r2): coordinates are "longitude,latitude,altitude" tuples in the
//     CRS LonLat84_5773, i.e. the altitude is above the EGM96 geoid; only <altitudeMode>absolute
//     </altitudeMode> makes a viewer use it (the default clampToGround drapes the path on terrain).
//
// Coordinates: degrees to 1e-9 (0.1 mm), altitudes to 1 mm, fixed-point, "C" formatting.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "dsmplan/export.hpp"

namespace dsmplan {

namespace {

constexpr int kMavCmdNavWaypoint = 16;  // MAV_CMD_NAV_WAYPOINT
constexpr int kMavFrameGlobal = 0;      // MAV_FRAME_GLOBAL: altitude above mean sea level
constexpr int kQgcAltitudeModeAbsolute = 2;

void check_points(const std::vector<Point3>& lonlatamsl, const char* what) {
  if (lonlatamsl.empty()) throw ArgumentError(what, "a mission needs at least one point");
  for (size_t i = 0; i < lonlatamsl.size(); ++i) {
    const Point3& p = lonlatamsl[i];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]) || std::abs(p[1]) > 90 ||
        std::abs(p[0]) > 180)
      throw ArgumentError(what, "point " + std::to_string(i + 1) +
                                    " is not a longitude, latitude, height (lon in [-180, 180], lat in [-90, 90])");
  }
}

// Degrees and metres as fixed-point text; "-0.000" is written as "0.000" so that golden files
// do not depend on the sign of a rounded zero.
std::string fixed(double v, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, v);
  std::string s = buffer;
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}
std::string degrees(double v) { return fixed(v, 9); }
std::string metres(double v) { return fixed(v, 3); }

std::string xml_escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace

std::string path_to_qgc_plan(const std::vector<Point3>& lonlatamsl, const MissionOptions& options) {
  check_points(lonlatamsl, "mission");
  if (!(options.cruise_speed > 0) || !(options.hover_speed > 0) || !std::isfinite(options.cruise_speed) ||
      !std::isfinite(options.hover_speed))
    throw ArgumentError("mission", "cruise and hover speeds must be positive and finite");
  const Point3& home = lonlatamsl.front();
  std::string text =
      "{\n"
      "    \"fileType\": \"Plan\",\n"
      "    \"geoFence\": {\n"
      "        \"circles\": [],\n"
      "        \"polygons\": [],\n"
      "        \"version\": 2\n"
      "    },\n"
      "    \"groundStation\": \"QGroundControl\",\n"
      "    \"mission\": {\n"
      "        \"cruiseSpeed\": " + fixed(options.cruise_speed, 3) + ",\n"
      "        \"firmwareType\": " + std::to_string(options.firmware_type) + ",\n"
      "        \"globalPlanAltitudeMode\": " + std::to_string(kQgcAltitudeModeAbsolute) + ",\n"
      "        \"hoverSpeed\": " + fixed(options.hover_speed, 3) + ",\n"
      "        \"items\": [\n";
  for (size_t i = 0; i < lonlatamsl.size(); ++i) {
    const Point3& p = lonlatamsl[i];
    // params: hold time 0 s, acceptance radius 0 (the autopilot's default), pass-through 0,
    // yaw NaN (null: keep the autopilot's heading behaviour), latitude, longitude, altitude.
    text += "            {\n"
            "                \"AMSLAltAboveTerrain\": null,\n"
            "                \"Altitude\": " + metres(p[2]) + ",\n"
            "                \"AltitudeMode\": " + std::to_string(kQgcAltitudeModeAbsolute) + ",\n"
            "                \"autoContinue\": true,\n"
            "                \"command\": " + std::to_string(kMavCmdNavWaypoint) + ",\n"
            "                \"doJumpId\": " + std::to_string(i + 1) + ",\n"
            "                \"frame\": " + std::to_string(kMavFrameGlobal) + ",\n"
            "                \"params\": [0, 0, 0, null, " + degrees(p[1]) + ", " + degrees(p[0]) + ", " +
            metres(p[2]) + "],\n"
            "                \"type\": \"SimpleItem\"\n"
            "            }" + (i + 1 < lonlatamsl.size() ? ",\n" : "\n");
  }
  text += "        ],\n"
          "        \"plannedHomePosition\": [" + degrees(home[1]) + ", " + degrees(home[0]) + ", " + metres(home[2]) +
          "],\n"
          "        \"vehicleType\": " + std::to_string(options.vehicle_type) + ",\n"
          "        \"version\": 2\n"
          "    },\n"
          "    \"rallyPoints\": {\n"
          "        \"points\": [],\n"
          "        \"version\": 2\n"
          "    },\n"
          "    \"version\": 1\n"
          "}\n";
  return text;
}

std::string path_to_qgc_wpl(const std::vector<Point3>& lonlatamsl) {
  check_points(lonlatamsl, "mission");
  std::string text = "QGC WPL 110\n";
  // Line 0 is home (current = 1), here the first point; the waypoints follow from index 1.
  // param4 (yaw) is 0, not NaN: readers of this format parse it as a plain number, and
  // ArduPilot, whose format this is, does not use it for a copter's waypoint.
  const auto line = [&](size_t index, bool current, const Point3& p) {
    text += std::to_string(index) + "\t" + (current ? "1" : "0") + "\t" + std::to_string(kMavFrameGlobal) + "\t" +
            std::to_string(kMavCmdNavWaypoint) + "\t0\t0\t0\t0\t" + degrees(p[1]) + "\t" + degrees(p[0]) + "\t" +
            metres(p[2]) + "\t1\n";
  };
  line(0, true, lonlatamsl.front());
  for (size_t i = 0; i < lonlatamsl.size(); ++i) line(i + 1, false, lonlatamsl[i]);
  return text;
}

std::string path_to_kml(const std::vector<Point3>& lonlatamsl, const std::vector<Point3>& marks,
                        const MissionOptions& options) {
  check_points(lonlatamsl, "kml");
  if (!marks.empty()) check_points(marks, "kml");
  const auto tuple = [](const Point3& p) { return degrees(p[0]) + "," + degrees(p[1]) + "," + metres(p[2]); };
  std::string text =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n"
      "  <Document>\n"
      "    <name>" + xml_escaped(options.name) + "</name>\n";
  if (!options.description.empty())
    text += "    <description>" + xml_escaped(options.description) + "</description>\n";
  text += "    <Placemark>\n"
          "      <name>path</name>\n"
          "      <LineString>\n"
          "        <altitudeMode>absolute</altitudeMode>\n"
          "        <coordinates>\n";
  for (const Point3& p : lonlatamsl) text += "          " + tuple(p) + "\n";
  text += "        </coordinates>\n"
          "      </LineString>\n"
          "    </Placemark>\n";
  for (size_t i = 0; i < marks.size(); ++i)
    text += "    <Placemark>\n"
            "      <name>waypoint " + std::to_string(i + 1) + "</name>\n"
            "      <Point>\n"
            "        <altitudeMode>absolute</altitudeMode>\n"
            "        <coordinates>" + tuple(marks[i]) + "</coordinates>\n"
            "      </Point>\n"
            "    </Placemark>\n";
  text += "  </Document>\n"
          "</kml>\n";
  return text;
}

std::vector<Point3> drop_straight_points(const std::vector<Point3>& path, double tolerance) {
  if (path.size() < 3) return path;
  // Distance of p to the segment a-b.
  const auto distance = [](const Point3& p, const Point3& a, const Point3& b) {
    const double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double ap[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    const double len2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    double t = len2 > 0 ? (ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]) / len2 : 0;
    t = std::clamp(t, 0.0, 1.0);
    return std::hypot(ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]);
  };
  // Greedy: from the last kept point, reach as far as every skipped point stays within the
  // tolerance of the one segment. Each kept-to-kept segment then lies within the tolerance of the
  // original polyline and the other way round (distance to a segment is convex along a segment).
  std::vector<Point3> kept{path.front()};
  size_t anchor = 0;
  for (size_t end = 2; end < path.size(); ++end) {
    bool fits = true;
    for (size_t k = anchor + 1; k < end && fits; ++k) fits = distance(path[k], path[anchor], path[end]) <= tolerance;
    if (!fits) {
      anchor = end - 1;
      kept.push_back(path[anchor]);
    }
  }
  kept.push_back(path.back());
  return kept;
}

}  // namespace dsmplan
