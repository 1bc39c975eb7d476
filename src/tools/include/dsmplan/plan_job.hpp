// dsmplan/plan_job.hpp: `dsmplan plan` as a library function: waypoints in, a checked path and its
// mission files out (tools.hpp's conventions: an options struct in, a report out, to_json()
// keys a contract).
#pragma once

#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/corridor.hpp"
#include "dsmplan/flight.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/picture_job.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/waypoints.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

// ---- dsmplan plan ---------------------------------------------------------------------------

/// How a mission (.plan, .waypoints, .kmz) takes off and ends (MissionEnds, flight.hpp), and
/// how it is written.
struct MissionJobOptions {
  /// x, y in the mesh's CRS, or longitude, latitude in degrees when |a| <= 180 and |b| <= 90;
  /// NaN: the ground under the first waypoint.
  std::array<double, 2> home{NAN, NAN};
  std::optional<MissionEnd> end;  ///< unset: rtl; --home and --end apply to missions only
  MissionOptions format;          ///< firmware, altitude frame, speeds
};

struct PlanJobOptions {
  std::string mesh;  ///< mesh file (read_mesh: .ply, .obj, .off), a 2.5D obstacle surface
  /// .csv: x,y,z in the mesh's CRS (read_waypoints_csv); .geojson/.json: WGS 84 longitude,
  /// latitude, ellipsoidal height (read_waypoints_geojson), transformed by Wgs84Transform.
  std::string waypoints;
  /// The path, by extension: .csv "x,y,z" in the mesh's CRS (shortest exact decimals);
  /// .geojson/.json an RFC 7946 LineString Feature (WGS 84, ellipsoidal heights); missions in
  /// WGS 84 with heights above mean sea level (EGM96): .plan a QGroundControl plan
  /// (mission_to_qgc_plan), .waypoints a "QGC WPL 110" text mission (mission_to_qgc_wpl), both
  /// flyable (MissionJobOptions) with the fewest items whose straight lines keep the limits, and
  /// .kmz the same mission for DJI aircraft (write_wpml_kmz); .kml a KML 2.2 LineString
  /// with altitudeMode absolute and the waypoints as Points (path_to_kml), every path point.
  std::string output;
  std::string format;  ///< csv, geojson, plan, waypoints or kml; empty: from the output's extension
  /// More outputs of the same flight (-o repeated), each in the format of its extension. When one
  /// of the outputs is a mission, the flight is planned as one, and the others (.csv, .geojson,
  /// .kml) show it as flown: from home on the ground up, and down at the end (home legs included).
  std::vector<std::string> more_outputs;
  PlanOptions plan;  ///< planner (prm, rrt_connect), seed, safety, spacing, max_edge, max_agl, threads
  /// The waypoints' heights (FlightQuery::heights): "crs" (z in the mesh's CRS; GeoJSON's
  /// ellipsoidal heights), "agl" (above the ground the ceiling counts from), or empty: crs, unless
  /// a CSV's header names its third column "agl". parse_waypoint_heights() reads the names.
  std::string waypoint_heights;
  /// FlightQuery::snap (m, [0, 50], 0: off): a refused waypoint moved to the nearest valid point
  /// within it (a mission's home to the nearest clear spot), each move in the report
  /// (PlanReport::snapped) and the GeoJSON's properties.
  double snap = 0;
  /// Roadmap file (PRM): read when it exists (read_roadmap(): refused when made for another mesh
  /// or other options), else built and written there for the next query.
  std::string roadmap;
  /// Index file (--index): the mesh's clearance index, opened where it lies when it exists and
  /// was built from this mesh file (and this DSM, with `dsm`), else built and written there.
  /// Opening it takes milliseconds where building takes most of loading (bench/README.md,
  /// "Planning as a whole process"); the plan is the same to the bit. Not for a DSM input
  /// (corridor). A file that is no index file, or is damaged, is refused, never overwritten.
  std::string index;
  /// Raw DSM: when given, every point of the path keeps `safety` from its columns (each valid
  /// cell a box over its square; holes as high as their rim), planned with the safety widened
  /// by how far the mesh lies inside them (certify_columns()) and measured on the written path.
  std::string dsm;
  /// Terrain (any GDAL raster in the mesh's CRS, any resolution): the ground --max-agl counts
  /// from. Without it: the DSM's cells, else the mesh's floor (ground.hpp).
  std::string dtm;
  VerticalOptions vertical;  ///< heights for GeoJSON, missions, KML: --vertical-crs, --allow-approximate-vertical
  /// Many routes instead of `waypoints` (plan_routes_job()): CSV "route,x,y,z" or GeoJSON LineStrings.
  std::string routes;
  /// With `routes`: each route's own time limit (s, [0, 3600], 0: none); a route past it fails
  /// ("route_budget") and the others go on (plan_routes()).
  double route_budget = 0;
  /// No-fly zones (ED-269 JSON or GeoJSON: read_airspace()), and which restrictions block
  /// (empty: PROHIBITED and REQ_AUTHORISATION).
  std::vector<std::string> no_fly, no_fly_blocking;
  /// When `mesh` is a DSM (a raster or VRT mosaic, not a mesh file): planned along a corridor,
  /// window by window (plan_corridor()), on conservative bounded meshes made on the fly.
  CorridorOptions corridor;
  MissionJobOptions mission;  ///< .plan and .waypoints: home, end, firmware, altitude frame, speeds
  /// Pictures of the flight as flown (home legs included), .png, drawn before any file is written
  /// and written after the path: `render` the DSM from above with the path, the waypoints and the
  /// zones (render_job()); `profile` the path's height profile over the DSM and the DTM with the
  /// safety band and the ceiling (profile_job()). Each is the same, byte for byte, as `dsmplan
  /// render DSM --path CSV --waypoints ...` and `dsmplan profile DSM CSV ...` give of the written
  /// CSV. They need a DSM (`dsm`, or a DSM input): ArgumentError("--render" / "--profile").
  std::string render, profile;
};

/// The stage's figures (FlightReport, flight.hpp) and the files around them.
struct PlanReport : FlightReport {
  std::string mesh, waypoints, output;
  /// The PROJ operation(s) used: GeoJSON waypoints' and GeoJSON output's (to ellipsoidal
  /// heights), then "; path by: " the missions' and KML's (to EGM96 heights); empty when none.
  std::string transformation;
  size_t mission_items = 0;  ///< missions: the items written (takeoff, speed, waypoints, end)
  /// .plan: the blocking zones its geofence keeps out (every ring an exclusion polygon), and those
  /// left out (caption, why: a flat fence the path passes over or under would be breached).
  size_t geofence_zones = 0;
  std::vector<std::pair<std::string, std::string>> geofence_left_out;
  std::optional<RenderReport> render;    ///< --render: its window and zoom
  std::optional<ProfileReport> profile;  ///< --profile: its figures
};

/// Mesh file + waypoints -> roadmap -> path (plan_path(), see plan.hpp) -> CSV, GeoJSON, a
/// mission (.plan, .waypoints) or KML, written atomically. The transformation to WGS 84 is made
/// before planning: ArgumentError("--vertical-crs") then for an unknown or approximate vertical
/// reference that is not allowed (Wgs84Transform). Options and the output's extension are checked before anything is
/// read. A bad waypoint is an InputError(waypoints file, "waypoint N", why: outside the extent, under the surface,
/// closer than the safety distance); a leg without a path InputError(waypoints file, "waypoints N to M", why); fewer
/// than two waypoints InputError(waypoints file); a roadmap file of another mesh or other options InputError(roadmap
/// file); an index file that is no index file or is damaged InputError(index file), never overwritten; with a DSM,
/// a path closer to its columns than safety - dsm_tolerance_m InputError(DSM file). Nothing is written then (an
/// index file built before a leg fails is kept: it depends on the mesh only). seconds_load includes reading a
/// reused roadmap and opening a kept index (in seconds_read).
PlanReport plan_job(const PlanJobOptions& options, const Progress& progress = {});
/// The names every face takes for the plan's choices (the CLI's flags, Python's keywords), one
/// ArgumentError naming the field ("planner", "end", "firmware", "altitude_frame": the CLI
/// shows --planner, ...) and listing the names otherwise.
PlannerKind parse_planner(const std::string& name);               ///< prm, rrtconnect, freespace
Objective parse_objective(const std::string& name);               ///< low, shortest
MissionEnd parse_mission_end(const std::string& name);            ///< rtl, land, none
Firmware parse_firmware(const std::string& name);                 ///< px4, ardupilot, generic
std::string parse_drone(const std::string& name);                 ///< a dji_drones() name: m350, m300, ..., m3td
AltitudeFrame parse_altitude_frame(const std::string& name);      ///< relative, amsl
WaypointHeights parse_waypoint_heights(const std::string& name);  ///< crs, agl ("waypoint_heights")

/// The waypoints of options.waypoints (CSV or GeoJSON, as plan_job() reads them) and their
/// heights' reference: options.waypoint_heights, else a CSV header's "agl" column.
/// ArgumentError("waypoint_heights") for "crs" over a file whose header says agl.
std::vector<Point3> read_job_waypoints(const PlanJobOptions& options, WaypointHeights& heights);

/// Writes a flight planned by plan_flight() over a mesh in `crs` (around `zones`, which a KML
/// carries) as `dsmplan plan -o` does:
/// options.output in options.format or by its extension (csv, geojson, plan, waypoints, kmz,
/// kml), atomically; missions with options.mission.format, heights to WGS 84 through
/// options.vertical. ArgumentError for an unknown format, options that do not belong to it, or a
/// mission asked of a flight planned without a site. Fills report.transformation and
/// report.mission_items. Python's Flight.write() is this.
void write_flight(const FlightPlan& flight, const std::vector<Point3>& waypoints, const Crs& crs,
                  const ZoneLayer& zones, const PlanJobOptions& options, PlanReport& report);
/// Keys: path_length_m, min_clearance_m, roadmap_nodes, roadmap_edges, seconds_load (=
/// seconds_read + seconds_index), seconds_roadmap, seconds_query, seconds_smooth; min_clearance_dsm_m, dsm_tolerance_m,
/// mesh_max_below_dsm_m with a DSM;
/// roadmap_reused, index_reused, refined_samples, planner; transformation when WGS 84 was involved;
/// render and profile (their reports' keys) when drawn; snapped (each move: waypoint, place, from,
/// to, distance_m, reason) when --snap moved a waypoint or home.
Json to_json(const PlanReport& report);
/// One summary line for people.
std::string to_text(const PlanReport& report);

// ---- many routes in one run: dsmplan plan --routes -------------------------------------------

struct RoutesReport {
  std::string output;
  size_t routes = 0, solved = 0;
  std::vector<std::string> failed;  ///< "ID: why", one line each, in the routes' order
  /// Each failed route for a program, in the routes' order: {"id", "code", "waypoint", "leg",
  /// "nearest_valid_point" ([x, y, z] in the mesh's CRS, or null), "message"} (RouteFailure).
  Json failures = Json::array();
  size_t roadmap_nodes = 0, roadmap_edges = 0;
  bool roadmap_reused = false;
  double seconds_read = 0, seconds_index = 0, seconds_roadmap = 0, seconds_plan = 0, seconds_write = 0;
};

/// plan_routes() over options.mesh for every route of options.routes (read_routes_csv(), or
/// read_routes_geojson() for .geojson/.json), with plan_job()'s options and checks. Writes
/// options.output: a .geojson FeatureCollection, one feature per route (its id, its figures, the
/// path as flown in WGS 84, or for a route without a path a null geometry and its one-line
/// reason), or a folder (a name ending in '/', or an existing directory) with one file per
/// route (its id, made safe as a file name, then the extension of options.format, default csv;
/// any path or mission format) and routes.json beside them (every route's id, status, reason or
/// figures). A route without a path has a "failure" object (code, waypoint, leg,
/// nearest_valid_point: in WGS 84 in the FeatureCollection, in the mesh's CRS in routes.json). A route that fails stops
/// no other: the report lists it (the CLI exits 4 then). Errors as plan_job() for the inputs and options;
/// ArgumentError("--routes") with --waypoints or a DSM input (routes are planned over a mesh).
RoutesReport plan_routes_job(const PlanJobOptions& options, const Progress& progress = {});
Json to_json(const RoutesReport& report);
std::string to_text(const RoutesReport& report);

}  // namespace dsmplan
