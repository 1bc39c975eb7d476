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
#include "dsmplan/mission.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/waypoints.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

// ---- dsmplan plan ---------------------------------------------------------------------------

/// How a mission (.plan, .waypoints) takes off and ends. The takeoff is vertical at home, to the
/// first waypoint's height above the ground (with the default home, the first waypoint itself);
/// when home is elsewhere, the route from there to the first waypoint is planned like any leg.
/// `--end rtl` plans a leg back above home, so that the autopilot's RTL, which flies a straight
/// unchecked line at its own altitude, finds nothing left to fly but the descent; `land` descends
/// at the last waypoint. The vertical climb and descent keep the safety distance from 1 m plus
/// `safety` above the ground up (below, a drone is taking off or landing). Without a DTM the
/// ground is the DSM's (or the mesh floor's) surface: a roof cannot be told from a street.
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
  PlanOptions plan;    ///< planner (prm, rrt_connect), seed, safety, spacing, max_edge, max_agl, threads
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
  /// When `mesh` is a DSM (a raster or VRT mosaic, not a mesh file): planned along a corridor,
  /// window by window (plan_corridor()), on conservative bounded meshes made on the fly.
  CorridorOptions corridor;
  MissionJobOptions mission;  ///< .plan and .waypoints: home, end, firmware, altitude frame, speeds
};

struct PlanReport {
  std::string mesh, waypoints, output;
  size_t waypoint_count = 0, path_points = 0;
  double path_length_m = 0;
  /// Least distance of the written path to the mesh, measured on its own with
  /// ClearanceIndex::clearance() (capped at safety + max_agl).
  double min_clearance_m = 0;
  /// With a DSM: least distance of the path to the DSM's columns (column_clearance(), same cap); NaN without.
  double min_clearance_dsm_m = NAN;
  /// With a DSM: the mesh's certified depth below it (certify().max_below) and the tolerance
  /// the path is held to, sqrt((cell diagonal / 2)^2 + max_below^2): the path is written only
  /// when min_clearance_dsm_m >= safety - tolerance and > 0.
  double mesh_max_below_dsm_m = NAN, dsm_tolerance_m = NAN;
  /// With a DSM: the most a column rises above the mesh anywhere (certify_columns()), and the
  /// margin the safety distance was widened by on the mesh to hold against the columns.
  double column_max_above_mesh_m = NAN, safety_margin_m = NAN;
  /// Greatest height of the written path above the ground in use (exact), and which ground.
  double max_agl_m = NAN;
  std::string ground;
  size_t roadmap_nodes = 0, roadmap_edges = 0;
  bool roadmap_reused = false;  ///< the roadmap came from the --roadmap file
  bool index_reused = false;    ///< the clearance index came from the --index file
  size_t refined_samples = 0;   ///< samples the query added where the roadmap failed a leg (plan.hpp, "Refinement")
  std::string planner = "prm";
  size_t corridor_windows = 0;               ///< a DSM input: windows planned in (0: a mesh input)
  size_t corridor_largest_window_cells = 0;  ///< a DSM input: cells of the largest window
  /// The PROJ operation(s) used: GeoJSON waypoints' and GeoJSON output's (to ellipsoidal
  /// heights), then "; path by: " the missions' and KML's (to EGM96 heights); empty when none.
  std::string transformation;
  double seconds_load = 0, seconds_roadmap = 0, seconds_query = 0, seconds_smooth = 0;
  /// seconds_load split: reading the files (mesh, DSM, DTM, a reused roadmap) and the rest
  /// (the clearance index, the mesh's floor, the DSM's columns against the mesh).
  double seconds_read = 0, seconds_index = 0;
  /// Missions: the items written (takeoff, speed, waypoints, end), home (x, y in the CRS, z its
  /// ground) and the height of the takeoff above it.
  size_t mission_items = 0;
  Point3 home{NAN, NAN, NAN};
  /// The surface home's ground (home[2]) was taken from, the best given: "dtm", "dsm" or "mesh
  /// floor" (a lower bound of the mesh); and its uncertainty, GroundGrid::spread_at(): half the
  /// range of that ground over the 3 x 3 cells around home. The relative altitudes count from it.
  std::string home_ground;
  double home_ground_uncertainty_m = NAN;
  double takeoff_height_m = NAN;
  std::string mission_end;  ///< rtl, land or none
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
/// Keys: path_length_m, min_clearance_m, roadmap_nodes, roadmap_edges, seconds_load (=
/// seconds_read + seconds_index), seconds_roadmap, seconds_query, seconds_smooth; min_clearance_dsm_m, dsm_tolerance_m,
/// mesh_max_below_dsm_m with a DSM;
/// roadmap_reused, index_reused, refined_samples, planner; transformation when WGS 84 was involved.
Json to_json(const PlanReport& report);
/// One summary line for people.
std::string to_text(const PlanReport& report);

}  // namespace dsmplan
