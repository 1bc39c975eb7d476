// Drone missions and KML from a path. Formatting only: the points come transformed to WGS 84
// longitude, latitude and height above mean sea level (Wgs84Transform, HeightReference::
// MeanSeaLevel, EGM96) and are written as the formats' documentation says, in the item order
// the autopilots check before they fly:
//   ArduPilot: AP_Mission::starts_with_takeoff_cmd() (libraries/AP_Mission/AP_Mission.cpp): the
//     first navigation command from index 1 (0 is home) must be MAV_CMD_NAV_TAKEOFF, else
//     ArduCopter refuses AUTO on the ground ("Missing Takeoff Cmd"); DO_ commands are skipped.
//   PX4: FeasibilityChecker::checkTakeoff() (src/modules/navigator/MissionFeasibility): the
//     takeoff must be the first item with a position and above home; older releases also want
//     it 1 m above the altitude acceptance radius (kMinTakeoffHeight).
//   MAVLink commands and frames: common.xml (MAV_CMD_NAV_TAKEOFF 22, MAV_CMD_NAV_WAYPOINT 16,
//     MAV_CMD_NAV_LAND 21, MAV_CMD_NAV_RETURN_TO_LAUNCH 20, MAV_CMD_DO_CHANGE_SPEED 178;
//     MAV_FRAME_GLOBAL 0, MAV_FRAME_MISSION 2, MAV_FRAME_GLOBAL_RELATIVE_ALT 3).
//   QGroundControl .plan: "Plan File Format", QGroundControl Developer Guide
//     (docs.qgroundcontrol.com, qgc-dev-guide/file_formats/plan): fileType "Plan", version 1;
//     mission version 2 with firmwareType (MAV_AUTOPILOT), vehicleType (MAV_TYPE), cruiseSpeed,
//     hoverSpeed, items (SimpleItem: command, frame, params = MISSION_ITEM param1..4, x = latitude,
//     y = longitude, z = altitude), plannedHomePosition [latitude, longitude, AMSL altitude].
//     QGC writes a NaN parameter as null and reads null back as NaN; AltitudeMode 1 and 2 are
//     QGC's Relative and Absolute (its enum: Mixed, Relative, Absolute, CalcAboveTerrain,
//     TerrainFrame). Items without a position (speed, return) carry no Altitude keys, as QGC's.
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

#include "core/text.hpp"
#include "dsmplan/mission.hpp"

namespace dsmplan {

namespace {

constexpr int kMavCmdNavWaypoint = 16;
constexpr int kMavCmdNavReturnToLaunch = 20;
constexpr int kMavCmdNavLand = 21;
constexpr int kMavCmdNavTakeoff = 22;
constexpr int kMavCmdDoChangeSpeed = 178;
constexpr int kMavFrameGlobal = 0;             // altitude above mean sea level
constexpr int kMavFrameMission = 2;            // no position
constexpr int kMavFrameGlobalRelativeAlt = 3;  // altitude above home
constexpr int kQgcAltitudeModeRelative = 1;
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
// A parameter: its shortest exact-enough decimal, null (.plan) or 0 (.waypoints) for NaN.
std::string parameter(double v, bool nan_as_null) {
  if (std::isnan(v)) return nan_as_null ? "null" : "0";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.9g", v);
  return buffer;
}

struct Item {
  int command, frame;
  double param[4];
  double latitude = 0, longitude = 0, altitude = 0;
  bool positional = false;
};

// The items in flying order (see the top); positions in latitude, longitude, altitude in frame.
std::vector<Item> mission_items(const Mission& mission, const MissionOptions& options) {
  if (mission.route.empty()) throw ArgumentError("mission", "a mission needs at least one point");
  check_points({mission.home}, "mission home");
  check_points(mission.route, "mission");
  for (const double speed : {options.speed, options.hover_speed})
    if (!(speed > 0 && speed <= 100))
      throw ArgumentError("mission", "speeds must lie in (0, 100] m/s, got " + fixed(speed, 3));
  const Point3& top = mission.route.front();
  if (std::abs(top[0] - mission.home[0]) > 1e-7 || std::abs(top[1] - mission.home[1]) > 1e-7)
    throw ArgumentError("mission", "the route's first point is the top of the takeoff and must lie above home");
  if (!(top[2] - mission.home[2] >= kMinTakeoffHeight))
    throw ArgumentError("mission", "the takeoff climbs only " + fixed(top[2] - mission.home[2], 2) +
                                       " m above home; autopilots want at least " + fixed(kMinTakeoffHeight, 1) + " m");
  if (mission.end == MissionEnd::land) check_points({mission.land}, "mission landing");
  const bool relative = options.altitude_frame == AltitudeFrame::relative;
  const int frame = relative ? kMavFrameGlobalRelativeAlt : kMavFrameGlobal;
  const auto at = [&](int command, const Point3& p) {
    Item item{command, frame, {0, 0, 0, NAN}};
    item.latitude = p[1], item.longitude = p[0];
    item.altitude = relative ? p[2] - mission.home[2] : p[2];
    item.positional = true;
    return item;
  };
  // Takeoff at home to the top's altitude (params: pitch, -, -, yaw: the vehicle's own).
  std::vector<Item> items{at(kMavCmdNavTakeoff, {mission.home[0], mission.home[1], top[2]})};
  items.push_back(
      {kMavCmdDoChangeSpeed, kMavFrameMission, {1, options.speed, -1, 0}});  // ground speed, m/s, throttle as is
  for (size_t i = 1; i < mission.route.size(); ++i)
    items.push_back(at(kMavCmdNavWaypoint, mission.route[i]));  // hold 0 s, acceptance and pass radius the autopilot's
  if (mission.end == MissionEnd::rtl) items.push_back({kMavCmdNavReturnToLaunch, kMavFrameMission, {0, 0, 0, 0}});
  if (mission.end == MissionEnd::land) items.push_back(at(kMavCmdNavLand, mission.land));
  return items;
}

int mav_autopilot(Firmware firmware) {
  switch (firmware) {
    case Firmware::px4:
      return 12;
    case Firmware::ardupilot:
      return 3;
    default:
      return 0;
  }
}

// Markup escaped, and what XML 1.0 cannot hold at all (control characters, bytes that are not
// UTF-8) shown as "\x1b" (visible_text()): the file stays well-formed whatever a name holds.
std::string xml_escaped(const std::string& text) {
  std::string out;
  for (const char c : visible_text(text)) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// The keep-out rings as QGC's geofence polygons (QGCFencePolygon::saveToJson: version 1,
// inclusion, then QGCMapPolygon's "polygon" of [latitude, longitude] without altitude). QGC keeps
// its polygons open and clockwise (QGCMapPolygon::verifyClockwiseWinding: the sum over the edges
// of (lon2 - lon1) (lat2 + lat1) positive), so they are written so.
std::string fence_polygons(const std::vector<std::vector<std::array<double, 2>>>& keep_out) {
  if (keep_out.empty()) return "[]";
  std::string text = "[\n";
  for (size_t z = 0; z < keep_out.size(); ++z) {
    std::vector<std::array<double, 2>> ring = keep_out[z];
    if (ring.size() > 1 && ring.front() == ring.back()) ring.pop_back();
    for (const auto& c : ring)
      if (!std::isfinite(c[0]) || !std::isfinite(c[1]) || std::abs(c[0]) > 180 || std::abs(c[1]) > 90)
        throw ArgumentError("mission", "keep-out area " + std::to_string(z + 1) + " has a corner not in degrees");
    if (ring.size() < 3)
      throw ArgumentError("mission", "keep-out area " + std::to_string(z + 1) + " has fewer than 3 corners");
    double turn = 0;
    for (size_t k = 0; k < ring.size(); ++k) {
      const auto &a = ring[k], &b = ring[(k + 1) % ring.size()];
      turn += (b[0] - a[0]) * (b[1] + a[1]);
    }
    if (turn < 0) std::reverse(ring.begin(), ring.end());
    text += "            {\n                \"inclusion\": false,\n                \"polygon\": [\n";
    for (size_t k = 0; k < ring.size(); ++k)
      text += "                    [\n                        " + degrees(ring[k][1]) + ",\n                        " +
              degrees(ring[k][0]) + "\n                    ]" + (k + 1 < ring.size() ? ",\n" : "\n");
    text += "                ],\n                \"version\": 1\n            }";
    text += z + 1 < keep_out.size() ? ",\n" : "\n";
  }
  return text + "        ]";
}

}  // namespace

std::string mission_to_qgc_plan(const Mission& mission, const MissionOptions& options) {
  const std::vector<Item> items = mission_items(mission, options);
  const int mode =
      options.altitude_frame == AltitudeFrame::relative ? kQgcAltitudeModeRelative : kQgcAltitudeModeAbsolute;
  std::string text =
      "{\n"
      "    \"fileType\": \"Plan\",\n"
      "    \"geoFence\": {\n"
      "        \"circles\": [],\n"
      "        \"polygons\": " +
      fence_polygons(mission.keep_out) +
      ",\n"
      "        \"version\": 2\n"
      "    },\n"
      "    \"groundStation\": \"QGroundControl\",\n"
      "    \"mission\": {\n"
      "        \"cruiseSpeed\": " +
      parameter(options.speed, true) +
      ",\n"
      "        \"firmwareType\": " +
      std::to_string(mav_autopilot(options.firmware)) +
      ",\n"
      "        \"globalPlanAltitudeMode\": " +
      std::to_string(mode) +
      ",\n"
      "        \"hoverSpeed\": " +
      parameter(options.hover_speed, true) +
      ",\n"
      "        \"items\": [\n";
  for (size_t i = 0; i < items.size(); ++i) {
    const Item& item = items[i];
    text += "            {\n";
    if (item.positional)
      text +=
          "                \"AMSLAltAboveTerrain\": null,\n"
          "                \"Altitude\": " +
          metres(item.altitude) +
          ",\n"
          "                \"AltitudeMode\": " +
          std::to_string(mode) + ",\n";
    text +=
        "                \"autoContinue\": true,\n"
        "                \"command\": " +
        std::to_string(item.command) +
        ",\n"
        "                \"doJumpId\": " +
        std::to_string(i + 1) +
        ",\n"
        "                \"frame\": " +
        std::to_string(item.frame) +
        ",\n"
        "                \"params\": [";
    for (const double q : item.param) text += parameter(q, true) + ", ";
    text += item.positional ? degrees(item.latitude) + ", " + degrees(item.longitude) + ", " + metres(item.altitude)
                            : std::string("0, 0, 0");
    text +=
        "],\n"
        "                \"type\": \"SimpleItem\"\n"
        "            }" +
        std::string(i + 1 < items.size() ? ",\n" : "\n");
  }
  const Point3& home = mission.home;
  text +=
      "        ],\n"
      "        \"plannedHomePosition\": [" +
      degrees(home[1]) + ", " + degrees(home[0]) + ", " + metres(home[2]) +
      "],\n"
      "        \"vehicleType\": " +
      std::to_string(options.vehicle_type) +
      ",\n"
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

std::string mission_to_qgc_wpl(const Mission& mission, const MissionOptions& options) {
  const std::vector<Item> items = mission_items(mission, options);
  std::string text = "QGC WPL 110\n";
  // Line 0 is home, always absolute (ArduPilot keeps it so); NaN parameters are written as 0:
  // readers of this format parse plain numbers, and no field here needs "unset".
  const auto line = [&](size_t index, const Item& item) {
    text += std::to_string(index) + "\t" + (index == 0 ? "1" : "0") + "\t" + std::to_string(item.frame) + "\t" +
            std::to_string(item.command);
    for (const double q : item.param) text += "\t" + parameter(q, false);
    text += "\t" + degrees(item.latitude) + "\t" + degrees(item.longitude) + "\t" + metres(item.altitude) + "\t1\n";
  };
  Item home{kMavCmdNavWaypoint, kMavFrameGlobal, {0, 0, 0, 0}};
  home.latitude = mission.home[1], home.longitude = mission.home[0], home.altitude = mission.home[2];
  line(0, home);
  for (size_t i = 0; i < items.size(); ++i) line(i + 1, items[i]);
  return text;
}

namespace {

const char* kml_mode(KmlZone::Altitude mode) {
  switch (mode) {
    case KmlZone::Altitude::relative:
      return "relativeToGround";
    case KmlZone::Altitude::absolute:
      return "absolute";
    default:
      return "clampToGround";
  }
}

// One Polygon of the zone at its floor (which = 2) or ceiling (3), holes inside.
std::string kml_zone_face(const KmlZone& zone, int which, KmlZone::Altitude mode, bool extrude) {
  std::string text = "        <Polygon>\n";
  if (extrude) text += "          <extrude>1</extrude>\n";
  text += std::string("          <altitudeMode>") + kml_mode(mode) + "</altitudeMode>\n";
  for (size_t r = 0; r < zone.rings.size(); ++r) {
    const char* boundary = r == 0 ? "outerBoundaryIs" : "innerBoundaryIs";
    text += std::string("          <") + boundary + "><LinearRing><coordinates>\n";
    const auto& ring = zone.rings[r];
    for (size_t k = 0; k <= ring.size(); ++k) {  // closed: the first corner again
      const auto& c = ring[k % ring.size()];
      const double z = mode == KmlZone::Altitude::ground ? 0 : c[which];
      text += "            " + degrees(c[0]) + "," + degrees(c[1]) + "," + metres(z) + "\n";
    }
    text += std::string("          </coordinates></LinearRing></") + boundary + ">\n";
  }
  return text + "        </Polygon>\n";
}

// The wall under one edge a-b: floor to ceiling, both in `mode`.
std::string kml_zone_wall(const std::array<double, 4>& a, const std::array<double, 4>& b, KmlZone::Altitude mode) {
  const auto at = [](const std::array<double, 4>& c, int which) {
    return "            " + degrees(c[0]) + "," + degrees(c[1]) + "," + metres(c[which]) + "\n";
  };
  return std::string("        <Polygon>\n          <altitudeMode>") + kml_mode(mode) +
         "</altitudeMode>\n          <outerBoundaryIs><LinearRing><coordinates>\n" + at(a, 2) + at(b, 2) + at(b, 3) +
         at(a, 3) + at(a, 2) + "          </coordinates></LinearRing></outerBoundaryIs>\n        </Polygon>\n";
}

std::string kml_zones(const std::vector<KmlZone>& zones) {
  using Altitude = KmlZone::Altitude;
  std::string text;
  for (const KmlZone& zone : zones) {
    for (const auto& ring : zone.rings) {
      if (ring.size() < 3) throw ArgumentError("kml", "zone '" + zone.name + "' has a ring of fewer than 3 corners");
      std::vector<Point3> corners;
      for (const auto& c : ring) corners.push_back({c[0], c[1], 0});
      check_points(corners, "kml zone");
      for (const auto& c : ring)
        if (!std::isfinite(c[2]) || !std::isfinite(c[3]))
          throw ArgumentError("kml", "zone '" + zone.name + "' has a height that is not finite");
    }
    text += "    <Placemark>\n      <name>" + xml_escaped(zone.name) + "</name>\n";
    if (!zone.description.empty()) text += "      <description>" + xml_escaped(zone.description) + "</description>\n";
    text += std::string("      <styleUrl>#") + (zone.blocking ? "zone-blocking" : "zone-other") + "</styleUrl>\n";
    text += "      <MultiGeometry>\n";
    const bool grounded = zone.floor == Altitude::ground, topped = zone.ceiling != Altitude::none;
    if (topped) text += kml_zone_face(zone, 3, zone.ceiling, grounded);
    if (!grounded || !topped) text += kml_zone_face(zone, 2, zone.floor, false);
    if (!grounded && topped && zone.floor == zone.ceiling)
      for (const auto& ring : zone.rings)
        for (size_t k = 0; k < ring.size(); ++k)
          text += kml_zone_wall(ring[k], ring[(k + 1) % ring.size()], zone.floor);
    text += "      </MultiGeometry>\n    </Placemark>\n";
  }
  return text;
}

// KML colours are aabbggrr: kZoneBlocking (204, 0, 0) and kZoneOther (230, 140, 0) of the pictures.
constexpr const char* kZoneStyles =
    "    <Style id=\"zone-blocking\">\n"
    "      <LineStyle>\n        <color>ff0000cc</color>\n        <width>2</width>\n      </LineStyle>\n"
    "      <PolyStyle>\n        <color>400000cc</color>\n      </PolyStyle>\n"
    "    </Style>\n"
    "    <Style id=\"zone-other\">\n"
    "      <LineStyle>\n        <color>ff008ce6</color>\n        <width>2</width>\n      </LineStyle>\n"
    "      <PolyStyle>\n        <color>40008ce6</color>\n      </PolyStyle>\n"
    "    </Style>\n";

}  // namespace

std::string path_to_kml(const std::vector<Point3>& lonlatamsl, const std::vector<Point3>& marks,
                        const MissionOptions& options, const std::vector<KmlZone>& zones) {
  const std::string zone_text = kml_zones(zones);  // checked before anything is formatted
  check_points(lonlatamsl, "kml");
  if (!marks.empty()) check_points(marks, "kml");
  const auto tuple = [](const Point3& p) { return degrees(p[0]) + "," + degrees(p[1]) + "," + metres(p[2]); };
  // KML 2.2's element order: extrude before altitudeMode before coordinates; KML colours are
  // aabbggrr. The path magenta and the waypoints cyan, as the renderings and the 3D viewer draw them.
  const std::string extrude = options.extrude ? "        <extrude>1</extrude>\n" : "";
  std::string text =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n"
      "  <Document>\n"
      "    <name>" +
      xml_escaped(options.name) + "</name>\n";
  if (!options.description.empty()) text += "    <description>" + xml_escaped(options.description) + "</description>\n";
  text +=
      "    <Style id=\"path\">\n"
      "      <LineStyle>\n"
      "        <color>ffff00ff</color>\n"
      "        <width>4</width>\n"
      "      </LineStyle>\n"
      "      <PolyStyle>\n"
      "        <color>40ff00ff</color>\n"
      "      </PolyStyle>\n"
      "    </Style>\n"
      "    <Style id=\"waypoint\">\n"
      "      <IconStyle>\n"
      "        <color>ffffff00</color>\n"
      "      </IconStyle>\n"
      "      <LabelStyle>\n"
      "        <color>ffffff00</color>\n"
      "      </LabelStyle>\n"
      "    </Style>\n" +
      std::string(zones.empty() ? "" : kZoneStyles) +
      "    <Placemark>\n"
      "      <name>path</name>\n"
      "      <styleUrl>#path</styleUrl>\n"
      "      <LineString>\n" +
      extrude +
      "        <altitudeMode>absolute</altitudeMode>\n"
      "        <coordinates>\n";
  for (const Point3& p : lonlatamsl) text += "          " + tuple(p) + "\n";
  text +=
      "        </coordinates>\n"
      "      </LineString>\n"
      "    </Placemark>\n";
  for (size_t i = 0; i < marks.size(); ++i)
    text +=
        "    <Placemark>\n"
        "      <name>waypoint " +
        std::to_string(i + 1) +
        "</name>\n"
        "      <styleUrl>#waypoint</styleUrl>\n"
        "      <Point>\n" +
        extrude +
        "        <altitudeMode>absolute</altitudeMode>\n"
        "        <coordinates>" +
        tuple(marks[i]) +
        "</coordinates>\n"
        "      </Point>\n"
        "    </Placemark>\n";
  text += zone_text +
          "  </Document>\n"
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

// DJI's Cloud API demo (github.com/dji-sdk/DJI-Cloud-API-Demo, cloud-sdk .../device/DeviceEnum.java
// and DeviceTypeEnum.java, v1.7+): the drones' "domain-type-subType" keys 0-89-0 (M350 RTK),
// 0-60-0 (M300 RTK), 0-67-0/1 (M30/M30T), 0-77-0/1/2 (M3E/M3T/M3M), 0-91-0/1 (M3D/M3TD). WPML's
// droneInfo takes the type as droneEnumValue and the sub-type as droneSubEnumValue.
const std::vector<DjiDrone>& dji_drones() {
  static const std::vector<DjiDrone> drones{
      {"m350", 89, 0}, {"m300", 60, 0}, {"m30", 67, 0}, {"m30t", 67, 1}, {"m3e", 77, 0},
      {"m3t", 77, 1},  {"m3m", 77, 2},  {"m3d", 91, 0}, {"m3td", 91, 1},
  };
  return drones;
}

}  // namespace dsmplan
