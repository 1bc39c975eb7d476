// DJI WPML missions (.kmz): the route of mission_to_qgc_plan() as DJI's waypoint file, a ZIP
// holding wpmz/template.kml (the editable template) and wpmz/waylines.wpml (what the aircraft
// executes), both KML 2.2 with DJI's extension namespace http://www.dji.com/wpmz/1.0.2.
//
// Followed: DJI Cloud API documentation, "DJI WPML" (Overview, Template.kml, Waylines.wpml,
// Common Elements), release v1.11.3 (2024-11-07), https://developer.dji.com/doc/cloud-api-tutorial/
// en/api-reference/dji-wpml/overview.html, read from its source repository
// github.com/dji-sdk/Cloud-API-Doc, docs/en/60.api-reference/00.dji-wpml/{10.overview,
// 20.template-kml,30.waylines-wpml,40.common-element}.md at commit 4ec6b0c7. Its samples use
// namespace version 1.0.2, and so do we. What we rely on from it:
//   - A .kmz is a ZIP; the two files must be named exactly wpmz/template.kml, wpmz/waylines.wpml.
//   - wpml:missionConfig (both files): flyToWaylineMode safely (climb first, then level to the
//     first waypoint), finishAction goHome | autoLand ("lands on the spot") | noAction,
//     exitOnRCLost executeLostAction with executeRCLostAction goBack, takeOffSecurityHeight
//     (metres above the take-off point, [1.2, 1500] with a remote controller, [8, 1500] from a
//     dock), globalTransitionalSpeed, droneInfo.
//   - waylines.wpml Folder: templateId, executeHeightMode, waylineId, autoFlightSpeed; Placemark:
//     Point/coordinates "longitude,latitude", index 0.. ("monotonously and continuously increasing
//     from 0", at most 65535), executeHeight, waypointSpeed, waypointHeadingParam,
//     waypointTurnParam, useStraightLine.
//   - executeHeightMode is WGS84 (ellipsoidal height) or relativeToStartPoint (or DJI's real-time
//     terrain following). There is no EGM96 execution mode: EGM96 exists only as the template's
//     heightMode. Absolute missions are therefore executed in WGS84 with the EGM96 heights turned
//     into ellipsoidal ones through PROJ's EGM96 grid, as DJI's own samples pair a template in
//     EGM96 with a wayline executed in WGS84. A value outside the enumeration could be refused,
//     or read as WGS84 and fly the route about 47 m (the geoid's height at Muelheim) too low.
//     DJI's Mobile SDK v5 agrees: its wpmz library's enum dji.sdk.wpmz.value.mission.
//     WaylineExecuteAltitudeMode (as decompiled copies on GitHub show it) has WGS84,
//     RELATIVE_TO_START_POINT and REAL_TIME_SURFACE_FOLLOW only.
//   - waypointTurnMode toPointAndStopWithDiscontinuityCurvature: "Fly in a straight line and the
//     aircraft stops at the point". The planner checked the straight lines between the points;
//     the curved modes cut corners it never checked.
//   - template.kml Folder (templateType waypoint): waylineCoordinateSysParam (coordinateMode
//     WGS84, heightMode EGM96 | relativeToStartPoint), and per Placemark wpml:height in that mode
//     with wpml:ellipsoidHeight, "expressions of different elevation reference planes at the same
//     location", both required when useGlobalHeight is 0.
//
// Coordinates: degrees to 1e-9, metres and m/s to 1e-3, fixed-point, "C" formatting, as
// mission_writers.cpp.
#include <cpl_conv.h>
#include <cpl_error.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/atomic_file.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/wgs84.hpp"
#include "dsmplan/wpml.hpp"

namespace dsmplan {

namespace {

constexpr const char* kTurnMode = "toPointAndStopWithDiscontinuityCurvature";
constexpr size_t kMaxWaypoints = 65536;  // wpml:index lies in [0, 65535]

std::string fixed(double v, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, v);
  std::string s = buffer;
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);  // no "-0.000"
  return s;
}
std::string degrees(double v) { return fixed(v, 9); }
std::string metres(double v) { return fixed(v, 3); }

// What WPML needs beyond the checks of the MAVLink writers.
void check_for_wpml(const Mission& mission) {
  // autoLand lands where the route ends; WPML has no landing point elsewhere.
  if (mission.end == MissionEnd::land) {
    const Point3& last = mission.route.back();
    if (std::abs(last[0] - mission.land[0]) > 1e-7 || std::abs(last[1] - mission.land[1]) > 1e-7)
      throw ArgumentError("mission",
                          "DJI's autoLand lands where the route ends: the landing point must lie below the "
                          "route's last point");
  }
  if (mission.route.size() > kMaxWaypoints)
    throw ArgumentError("mission", "DJI WPML numbers waypoints 0 to 65535; the route has " +
                                       std::to_string(mission.route.size()) + " points");
}

// WGS 84 ellipsoidal heights of the route's points, then of home, from their EGM96 heights. Both
// frames need them: the template states each point's ellipsoidal height beside its height, and
// absolute missions execute in WGS84. Without PROJ's EGM96 grid the only operation left copies
// the heights (a "ballpark" one, which Wgs84Transform refuses): tens of metres wrong, so that is
// an error here, never a fallback.
std::vector<double> ellipsoidal_heights(const Mission& mission, const std::string& path) {
  std::array<double, 4> area{mission.home[0], mission.home[1], mission.home[0], mission.home[1]};
  for (const Point3& p : mission.route) {
    area[0] = std::min(area[0], p[0]), area[1] = std::min(area[1], p[1]);
    area[2] = std::max(area[2], p[0]), area[3] = std::max(area[3], p[1]);
  }
  std::vector<double> heights;
  try {
    Crs wgs84;
    wgs84.definition = "EPSG:4326";
    VerticalOptions egm96;
    egm96.vertical_crs = "EPSG:5773";
    const Wgs84Transform to_ellipsoid(wgs84, HeightReference::Ellipsoid, egm96, area);
    for (const Point3& p : mission.route) heights.push_back(to_ellipsoid.to_wgs84(p)[2]);
    heights.push_back(to_ellipsoid.to_wgs84(mission.home)[2]);
  } catch (const ArgumentError& e) {
    throw OutputError(path, std::string("cannot write: DJI WPML states heights above the WGS 84 ellipsoid, and PROJ "
                                        "cannot convert the mission's EGM96 heights here (") +
                                e.what() + ")");
  }
  return heights;
}

const char* finish_action(MissionEnd end) {
  switch (end) {
    case MissionEnd::rtl:
      return "goHome";
    case MissionEnd::land:
      return "autoLand";
    default:
      return "noAction";
  }
}

std::string head() {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<kml xmlns=\"http://www.opengis.net/kml/2.2\" xmlns:wpml=\"http://www.dji.com/wpmz/1.0.2\">\n"
         "  <Document>\n";
}

// `reference` is the template's optional takeOffRefPoint line (empty in waylines.wpml, which has
// no such element).
std::string mission_config(const Mission& mission, const MissionOptions& options, const std::string& reference = "") {
  // No globalRTHHeight: the aircraft keeps its own return altitude, as the MAVLink missions leave
  // RTL's altitude to the autopilot. A height written here would apply on any return, from any
  // point of the route, along a straight line the planner never checked; DJI's own sample
  // waylines.wpml leaves it out too.
  // droneInfo is required: the aircraft --drone names (dji_drones(), mission.hpp; default m3e).
  const auto& drones = dji_drones();
  const auto drone =
      std::find_if(drones.begin(), drones.end(), [&](const DjiDrone& d) { return options.drone == d.name; });
  if (drone == drones.end()) throw ArgumentError("drone", "is not a DJI aircraft WPML names: '" + options.drone + "'");
  return "    <wpml:missionConfig>\n"
         "      <wpml:flyToWaylineMode>safely</wpml:flyToWaylineMode>\n"
         "      <wpml:finishAction>" +
         std::string(finish_action(mission.end)) +
         "</wpml:finishAction>\n"
         "      <wpml:exitOnRCLost>executeLostAction</wpml:exitOnRCLost>\n"
         "      <wpml:executeRCLostAction>goBack</wpml:executeRCLostAction>\n"
         "      <wpml:takeOffSecurityHeight>" +
         metres(mission.route.front()[2] - mission.home[2]) + "</wpml:takeOffSecurityHeight>\n" + reference +
         "      <wpml:globalTransitionalSpeed>" + metres(options.speed) +
         "</wpml:globalTransitionalSpeed>\n"
         "      <wpml:droneInfo>\n"
         "        <wpml:droneEnumValue>" +
         std::to_string(drone->enum_value) +
         "</wpml:droneEnumValue>\n"
         "        <wpml:droneSubEnumValue>" +
         std::to_string(drone->sub_enum_value) +
         "</wpml:droneSubEnumValue>\n"
         "      </wpml:droneInfo>\n"
         "    </wpml:missionConfig>\n";
}

std::string coordinates(const Point3& p) {
  return "        <Point>\n"
         "          <coordinates>" +
         degrees(p[0]) + "," + degrees(p[1]) +
         "</coordinates>\n"
         "        </Point>\n";
}

std::string template_kml(const Mission& mission, const MissionOptions& options, const std::vector<double>& heights,
                         const std::vector<double>& ellipsoidal, double home_ellipsoidal) {
  const bool relative = options.altitude_frame == AltitudeFrame::relative;
  const Point3& home = mission.home;
  // takeOffRefPoint is "latitude,longitude,altitude" (ellipsoidal), latitude first unlike
  // coordinates: the planned home, for the app to compare with where the aircraft stands.
  const std::string reference = "      <wpml:takeOffRefPoint>" + degrees(home[1]) + "," + degrees(home[0]) + "," +
                                metres(home_ellipsoidal) + "</wpml:takeOffRefPoint>\n";
  std::string text = head() + "    <wpml:author>dsmplan</wpml:author>\n" + mission_config(mission, options, reference);
  text +=
      "    <Folder>\n"
      "      <wpml:templateType>waypoint</wpml:templateType>\n"
      "      <wpml:templateId>0</wpml:templateId>\n"
      "      <wpml:waylineCoordinateSysParam>\n"
      "        <wpml:coordinateMode>WGS84</wpml:coordinateMode>\n"
      "        <wpml:heightMode>" +
      std::string(relative ? "relativeToStartPoint" : "EGM96") +
      "</wpml:heightMode>\n"
      "      </wpml:waylineCoordinateSysParam>\n"
      "      <wpml:autoFlightSpeed>" +
      metres(options.speed) +
      "</wpml:autoFlightSpeed>\n"
      // Required though every point has its own height: the takeoff's, above the take-off point.
      "      <wpml:globalHeight>" +
      metres(mission.route.front()[2] - home[2]) +
      "</wpml:globalHeight>\n"
      // manual: no camera work, so no per-point gimbal angles to invent.
      "      <wpml:gimbalPitchMode>manual</wpml:gimbalPitchMode>\n"
      "      <wpml:globalWaypointHeadingParam>\n"
      "        <wpml:waypointHeadingMode>followWayline</wpml:waypointHeadingMode>\n"
      "        <wpml:waypointHeadingPathMode>followBadArc</wpml:waypointHeadingPathMode>\n"
      "      </wpml:globalWaypointHeadingParam>\n"
      "      <wpml:globalWaypointTurnMode>" +
      std::string(kTurnMode) +
      "</wpml:globalWaypointTurnMode>\n"
      "      <wpml:globalUseStraightLine>1</wpml:globalUseStraightLine>\n";
  for (size_t i = 0; i < mission.route.size(); ++i)
    text += "      <Placemark>\n" + coordinates(mission.route[i]) + "        <wpml:index>" + std::to_string(i) +
            "</wpml:index>\n"
            "        <wpml:useGlobalHeight>0</wpml:useGlobalHeight>\n"
            "        <wpml:ellipsoidHeight>" +
            metres(ellipsoidal[i]) +
            "</wpml:ellipsoidHeight>\n"
            "        <wpml:height>" +
            metres(heights[i]) +
            "</wpml:height>\n"
            "        <wpml:useGlobalSpeed>1</wpml:useGlobalSpeed>\n"
            "        <wpml:useGlobalHeadingParam>1</wpml:useGlobalHeadingParam>\n"
            "        <wpml:useGlobalTurnParam>1</wpml:useGlobalTurnParam>\n"
            "      </Placemark>\n";
  text +=
      "    </Folder>\n"
      "  </Document>\n"
      "</kml>\n";
  return text;
}

std::string waylines_wpml(const Mission& mission, const MissionOptions& options, const std::vector<double>& heights) {
  const bool relative = options.altitude_frame == AltitudeFrame::relative;
  std::string text = head() + mission_config(mission, options);
  text +=
      "    <Folder>\n"
      "      <wpml:templateId>0</wpml:templateId>\n"
      "      <wpml:executeHeightMode>" +
      std::string(relative ? "relativeToStartPoint" : "WGS84") +
      "</wpml:executeHeightMode>\n"
      "      <wpml:waylineId>0</wpml:waylineId>\n"
      "      <wpml:autoFlightSpeed>" +
      metres(options.speed) + "</wpml:autoFlightSpeed>\n";
  // Waypoint 0 is route[0], the takeoff's top above home. The aircraft climbs to
  // takeOffSecurityHeight by itself and, flying "safely", then goes level to waypoint 0: left
  // out, it would climb to route[1]'s height and fly level to it, not the straight line from the
  // top that the planner checked. With it, the climb ends where waypoint 0 already is.
  for (size_t i = 0; i < mission.route.size(); ++i)
    text += "      <Placemark>\n" + coordinates(mission.route[i]) + "        <wpml:index>" + std::to_string(i) +
            "</wpml:index>\n"
            "        <wpml:executeHeight>" +
            metres(heights[i]) +
            "</wpml:executeHeight>\n"
            "        <wpml:waypointSpeed>" +
            metres(options.speed) +
            "</wpml:waypointSpeed>\n"
            "        <wpml:waypointHeadingParam>\n"
            "          <wpml:waypointHeadingMode>followWayline</wpml:waypointHeadingMode>\n"
            "          <wpml:waypointHeadingPathMode>followBadArc</wpml:waypointHeadingPathMode>\n"
            "        </wpml:waypointHeadingParam>\n"
            "        <wpml:waypointTurnParam>\n"
            "          <wpml:waypointTurnMode>" +
            std::string(kTurnMode) +
            "</wpml:waypointTurnMode>\n"
            // 0 as in DJI's sample: a damping distance applies only to the turning modes.
            "          <wpml:waypointTurnDampingDist>0</wpml:waypointTurnDampingDist>\n"
            "        </wpml:waypointTurnParam>\n"
            "        <wpml:useStraightLine>1</wpml:useStraightLine>\n"
            "      </Placemark>\n";
  text +=
      "    </Folder>\n"
      "  </Document>\n"
      "</kml>\n";
  return text;
}

// GDAL reports through its error handler; its last message is what we quote.
class QuietGdal {
public:
  QuietGdal() {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
  }
  ~QuietGdal() { CPLPopErrorHandler(); }
  QuietGdal(const QuietGdal&) = delete;
  QuietGdal& operator=(const QuietGdal&) = delete;
};

std::string gdal_reason(const char* what) {
  const std::string message = CPLGetLastErrorMsg();
  return std::string(what) + (message.empty() ? std::string() : ": " + message);
}

// Closes the archive on every path out, so that a failure leaves no open handle on the temporary.
class Zip {
public:
  explicit Zip(const std::string& path) : handle_(CPLCreateZip(path.c_str(), nullptr)) {}
  ~Zip() {
    if (handle_) CPLCloseZip(handle_);
  }
  Zip(const Zip&) = delete;
  Zip& operator=(const Zip&) = delete;
  void* get() const { return handle_; }
  bool close() {
    void* handle = handle_;
    handle_ = nullptr;
    return CPLCloseZip(handle) == CE_None;
  }

private:
  void* handle_;
};

}  // namespace

namespace {

// GDAL's ZIP writer (CPLCreateFileInZip) stamps every entry with the MS-DOS date 0, which reads
// as 1980-00-00: no date at all, shown as such by unzip and refused by strict readers. Each entry
// is dated 1980-01-01 00:00 instead, the first date the format has: a real date, and the same
// bytes for the same mission. The date is patched in the central directory (APPNOTE.TXT 4.3.12:
// time at offset 12, date at 14) and in each entry's local header (4.3.7: 10 and 12); no
// checksum covers them.
void date_zip_entries(const std::string& zip, const std::string& path) {
  std::fstream file(zip, std::ios::in | std::ios::out | std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const auto u16 = [&](size_t at) { return unsigned(uint8_t(bytes[at])) | unsigned(uint8_t(bytes[at + 1])) << 8; };
  const auto u32 = [&](size_t at) { return u16(at) | u16(at + 2) << 16; };
  const auto put16 = [&](size_t at, unsigned v) { bytes[at] = char(v & 0xff), bytes[at + 1] = char(v >> 8); };
  constexpr unsigned kTime = 0, kDate = (0u << 9) | (1u << 5) | 1u;  // 00:00:00, 1980-01-01
  // The end of central directory record: the last "PK\5\6" (no archive comment is written).
  const size_t end = bytes.size() >= 22 ? bytes.rfind(std::string("PK\5\6", 4)) : std::string::npos;
  if (end == std::string::npos || end + 22 > bytes.size()) throw OutputError(path, "cannot date the ZIP entries");
  size_t at = u32(end + 16);
  for (unsigned entry = 0, entries = u16(end + 10); entry < entries; ++entry) {
    if (at + 46 > bytes.size() || u32(at) != 0x02014b50) throw OutputError(path, "cannot date the ZIP entries");
    put16(at + 12, kTime), put16(at + 14, kDate);
    const size_t local = u32(at + 42);
    if (local + 30 > bytes.size() || u32(local) != 0x04034b50) throw OutputError(path, "cannot date the ZIP entries");
    put16(local + 10, kTime), put16(local + 12, kDate);
    at += 46 + u16(at + 28) + u16(at + 30) + u16(at + 32);
  }
  file.clear();
  file.seekp(0);
  file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!file.flush()) throw OutputError(path, "cannot write the ZIP entries' dates");
}

}  // namespace

void write_wpml_kmz(const Mission& mission, const MissionOptions& options, const std::string& path) {
  // The same refusals as the .plan and .waypoints writers, by calling them: a mission one format
  // refuses must not fly through another. The text itself is not needed.
  (void)mission_to_qgc_plan(mission, options);
  check_for_wpml(mission);

  const std::vector<double> ellipsoidal = ellipsoidal_heights(mission, path);
  const double home_ellipsoidal = ellipsoidal.back();
  const bool relative = options.altitude_frame == AltitudeFrame::relative;
  std::vector<double> heights, execute;  // in the template's height mode, in the execution mode
  for (size_t i = 0; i < mission.route.size(); ++i) {
    heights.push_back(relative ? mission.route[i][2] - mission.home[2] : mission.route[i][2]);
    execute.push_back(relative ? heights.back() : ellipsoidal[i]);
  }
  const std::string files[2][2] = {
      {"wpmz/template.kml", template_kml(mission, options, heights, ellipsoidal, home_ellipsoidal)},
      {"wpmz/waylines.wpml", waylines_wpml(mission, options, execute)}};

  AtomicFile out(path);
  out.close_stream();  // GDAL writes the archive by name
  {
    const QuietGdal quiet;
    Zip zip(out.temp_path());
    if (!zip.get()) throw OutputError(path, "cannot write: " + gdal_reason("cannot create the ZIP archive"));
    for (const auto& [name, text] : files) {
      if (CPLCreateFileInZip(zip.get(), name.c_str(), nullptr) != CE_None)
        throw OutputError(path, "cannot write: " + gdal_reason(("cannot add " + name).c_str()));
      for (size_t at = 0; at < text.size();) {
        const int chunk = static_cast<int>(std::min<size_t>(text.size() - at, INT_MAX / 2));
        if (CPLWriteFileInZip(zip.get(), text.data() + at, chunk) != CE_None) {
          CPLCloseFileInZip(zip.get());
          throw OutputError(path, "cannot write: " + gdal_reason(("cannot write " + name).c_str()));
        }
        at += static_cast<size_t>(chunk);
      }
      if (CPLCloseFileInZip(zip.get()) != CE_None)
        throw OutputError(path, "cannot write: " + gdal_reason(("cannot finish " + name).c_str()));
    }
    if (!zip.close()) throw OutputError(path, "cannot write: " + gdal_reason("cannot finish the ZIP archive"));
  }
  date_zip_entries(out.temp_path(), path);
  out.commit();
}

}  // namespace dsmplan
