// dsmplan/mission.hpp: stage 5, results out: paths as files and flyable drone missions.
//
// Formatting only: the caller transforms coordinates (wgs84.hpp).
#pragma once

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/flight.hpp"  // MissionEnd

namespace dsmplan {

// ---- paths as files -----------------------------------------------------------------------

/// The CSV of a path: "x,y,z" then one point a line, shortest decimals that read back exactly.
std::string path_to_csv(const std::vector<Point3>& path);

/// A GeoJSON (RFC 7946) Feature with a LineString of [longitude, latitude, height] positions
/// (degrees to 1e-9, about 0.1 mm; heights to 1 mm), and `properties` (a JSON object's text,
/// "{}" for none). Plain text, no PROJ: the caller transforms (Wgs84Transform).
std::string path_to_geojson(const std::vector<Point3>& lonlath, const std::string& properties = "{}");

// ---- drone missions and KML (formatting only; the caller transforms) ----------------------
//
// Input: WGS 84 longitude, latitude (degrees) and height above mean sea level (EGM96,
// Wgs84Transform with HeightReference::MeanSeaLevel): what MAVLink's MAV_FRAME_GLOBAL and
// QGroundControl call AMSL, and what KML 2.2 states its altitudes in (CRS LonLat84_5773).
// Degrees are written to 1e-9 (0.1 mm), altitudes to 1 mm. ArgumentError when a point is not
// finite or outside longitude [-180, 180], latitude [-90, 90] (e.g. still in UTM).
// The formats' sources (QGC's and MAVLink's documentation, the autopilots' mission checks,
// OGC KML 2.2): mission_writers.cpp.

enum class Firmware { generic, px4, ardupilot };  ///< MAV_AUTOPILOT 0, 12, 3

/// The DJI aircraft a WPML mission (.kmz) names in its droneInfo: the enterprise models DJI's
/// Cloud API enumerates (its demo's DeviceEnum: domain 0, type = droneEnumValue, sub-type =
/// droneSubEnumValue). A mission is accepted by the pilot app only for the aircraft it names.
struct DjiDrone {
  const char* name;  ///< as --drone takes it: "m3e"
  int enum_value, sub_enum_value;
};
/// Every DjiDrone, in the order the docs list them: m350, m300, m30, m30t, m3e, m3t, m3m, m3d, m3td.
const std::vector<DjiDrone>& dji_drones();
enum class AltitudeFrame {
  relative,  ///< metres above home (MAV_FRAME_GLOBAL_RELATIVE_ALT, QGC AltitudeMode 1): how most missions fly
  amsl       ///< metres above mean sea level (MAV_FRAME_GLOBAL, QGC AltitudeMode 2)
};

/// A mission as an autopilot flies it: armed at `home` on the ground, a vertical takeoff to
/// route[0] (directly above home), straight lines through the route, then `end`.
struct Mission {
  Point3 home{NAN, NAN, NAN};  ///< lon, lat, AMSL height of the ground at home (the planned home)
  std::vector<Point3> route;   ///< lon, lat, AMSL; route[0] is the top of the takeoff, above home
  MissionEnd end = MissionEnd::rtl;
  Point3 land{NAN, NAN, NAN};  ///< end == land: lon, lat, AMSL height of the ground it lands on
  /// Areas the vehicle must stay out of (a .plan's geofence exclusion polygons): each the
  /// longitude, latitude (degrees) of a ring's corners, in any winding, closed or not.
  std::vector<std::vector<std::array<double, 2>>> keep_out;
};

/// Takeoff tops closer to home than this are refused: PX4 accepts a takeoff only 1 m above its
/// altitude acceptance radius (0.8 m by default), and lower than that is no flight anyway.
constexpr double kMinTakeoffHeight = 2.0;

struct MissionOptions {
  Firmware firmware = Firmware::generic;  ///< .plan's firmwareType; NAV_* items are common to all three
  AltitudeFrame altitude_frame = AltitudeFrame::relative;
  /// m/s along the route: a MAV_CMD_DO_CHANGE_SPEED (ground speed) after the takeoff, and the
  /// .plan's cruiseSpeed. (0, 100].
  double speed = 5;
  double hover_speed = 5;             ///< m/s, .plan's hoverSpeed (QGC's time estimate for multirotors). (0, 100]
  int vehicle_type = 2;               ///< .plan: MAV_TYPE, 2 = quadrotor
  std::string name = "dsmplan path";  ///< KML: the Document's name
  std::string description;            ///< KML: the Document's description (e.g. the transformation), may be empty
  bool extrude = false;               ///< KML: <extrude>1</extrude>, a wall from the path down to the ground
  std::string drone = "m3e";          ///< .kmz: the aircraft (dji_drones()'s name); ArgumentError("drone") else
};

/// The mission items, in this order for both formats: MAV_CMD_NAV_TAKEOFF (22) at home to the
/// altitude of route[0]; MAV_CMD_DO_CHANGE_SPEED (178: ground speed, `speed`, throttle -1);
/// MAV_CMD_NAV_WAYPOINT (16) for route[1..]; then MAV_CMD_NAV_RETURN_TO_LAUNCH (20) or
/// MAV_CMD_NAV_LAND (21) at `land`, or nothing. Altitudes in `altitude_frame`; relative ones
/// are the AMSL height less home's. What the autopilots check is met: ArduPilot's first
/// navigation command after home (item 0 of a WPL) is the takeoff (AP_Mission::
/// starts_with_takeoff_cmd, else "Missing Takeoff Cmd"); PX4's takeoff is the first item with a
/// position and above home (FeasibilityChecker::checkTakeoff).
/// ArgumentError: an empty route; a point as above; route[0] more than 1e-7 degrees from above
/// home; a takeoff less than kMinTakeoffHeight above home; end == land without a land point;
/// speeds outside (0, 100].
///
/// A QGroundControl plan (JSON, "Plan File Format"): fileType "Plan", version 1; mission version
/// 2 with firmwareType, vehicleType, cruiseSpeed, hoverSpeed, globalPlanAltitudeMode (1 relative,
/// 2 absolute), plannedHomePosition [lat, lon, AMSL] of home; SimpleItems {autoContinue true,
/// command, doJumpId 1.., frame, params [p1..p4, lat, lon, alt], type}; positional items also
/// AMSLAltAboveTerrain null, Altitude, AltitudeMode. geoFence version 2: no circles, each of
/// `keep_out` an exclusion polygon {inclusion false, polygon [[lat, lon], ...] clockwise and
/// not closed, as QGC saves its own (QGCMapPolygon::verifyClockwiseWinding), version 1}; QGC's
/// fences hold no heights. Empty rallyPoints (version 2). ArgumentError also for a keep-out
/// ring of fewer than 3 corners or a corner not in degrees.
std::string mission_to_qgc_plan(const Mission& mission, const MissionOptions& options = {});

/// A MAVLink plain-text mission, "QGC WPL 110" (Mission Planner's .waypoints, ArduPilot's): the
/// header line, then "INDEX CURRENT FRAME COMMAND P1 P2 P3 P4 LATITUDE LONGITUDE ALTITUDE
/// AUTOCONTINUE" separated by tabs: line 0 is home (current 1, frame 0, AMSL, as ArduPilot
/// keeps it), then the items as mission_to_qgc_plan() lists them (current 0, autocontinue 1).
/// Latitude comes before longitude. Errors as mission_to_qgc_plan().
std::string mission_to_qgc_wpl(const Mission& mission, const MissionOptions& options = {});

/// A no-fly zone as KML draws it (the caller transforms; path_to_kml()). Each corner holds its
/// longitude, latitude (degrees), floor height and ceiling height, each in its limit's mode.
struct KmlZone {
  enum class Altitude {
    ground,    ///< a floor at (or below) the ground: the ceiling extruded down to it; no ceiling: clamped to it
    relative,  ///< metres above the ground (relativeToGround: the viewer's terrain), as AGL limits
    absolute,  ///< metres above mean sea level (EGM96), as AMSL limits and the path
    none       ///< a ceiling that is unlimited: none drawn
  };
  std::string name, description;  ///< the Placemark's (XML-escaped)
  bool blocking = true;           ///< style "zone-blocking" (dark red), else "zone-other" (amber)
  Altitude floor = Altitude::ground, ceiling = Altitude::none;
  std::vector<std::vector<std::array<double, 4>>> rings;  ///< outer first, then holes: lon, lat, floor, ceiling
};

/// KML 2.2: a Document with a Placemark "path" whose LineString has <altitudeMode>absolute
/// </altitudeMode> and "lon,lat,alt" tuples one a line, then a Point Placemark "waypoint k"
/// (also absolute) for each of `marks` (may be empty). Without altitudeMode a viewer would clamp
/// the path to the ground. Styles: the path a magenta line 4 px wide (its extrusion translucent),
/// the waypoints cyan; `extrude` adds a wall down to the ground under each. Name and
/// description are XML-escaped. Then, for each of `zones`, a Placemark named after it (styles
/// "zone-blocking" dark red, "zone-other" amber, translucent faces) holding a MultiGeometry of
/// Polygons (outer boundary, holes as inner boundaries, rings closed): the ceiling, extruded down
/// to the ground when the floor is the ground; the floor when it is above the ground; and with
/// both in the same mode the walls, one Polygon per edge of every ring, so the zone reads as a
/// prism; with no ceiling and the floor at the ground, the area clamped to the ground. Without
/// zones the text is what it was before zones existed, to the byte. ArgumentError as for the path
/// when a corner is not finite or not in degrees, or a zone has a ring of fewer than 3 corners.
std::string path_to_kml(const std::vector<Point3>& lonlatamsl, const std::vector<Point3>& marks = {},
                        const MissionOptions& options = {}, const std::vector<KmlZone>& zones = {});

/// The path without the points that lie within `tolerance` of the straight segment between the
/// points kept around them (first and last always kept), so that every mission item is a turn:
/// the result is within `tolerance` of the path and the path within `tolerance` of it
/// (Hausdorff). For points in a metric CRS. O(n * longest dropped run).
std::vector<Point3> drop_straight_points(const std::vector<Point3>& path, double tolerance);

}  // namespace dsmplan
