// dsmplan/flight.hpp: stage 4's whole request: a flight through waypoints over the data, planned,
// held to every rule and verified against the data, in one call (plan_flight()). The command
// line (`dsmplan plan`), a C++ program and the Python module are faces over it: they read the
// files, call plan_flight(), and write what it returns.
//
// What it guarantees, for the path it returns (and refuses otherwise, naming the file and place):
//   - Every point keeps `safety` from the obstacles: with a DSM, from its cells as solid columns
//     (holes as high as their rim: columns.hpp), measured on the returned path itself; without,
//     from the mesh's triangles.
//   - No point is more than `max_agl` above the ground: the DTM, else the DSM, else the mesh's
//     floor (ground.hpp), measured exactly on every segment.
//   - Every constraint of PlanOptions::constraints (no-fly zones) holds on every segment.
//   - Data that disagree are refused before planning: a DTM or DSM in another CRS than the mesh,
//     one that does not overlap it, a DSM that does not cover it, a DTM above its surface
//     (terrain_above_surface()).
//   - Waypoints, home and the landing are refused, all of them in one message, when they lie
//     under the surface, closer than `safety` to the columns, above the ceiling or outside the
//     ground; a mission's vertical climb and descent are checked from 1 m plus `safety` above
//     the ground up, and a home that fails is answered with the nearest clear spot.
//   - A refused waypoint is answered with the nearest valid point; with FlightQuery::snap it is
//     moved there when that lies within the radius, and the move is reported (FlightReport::snapped).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/airspace.hpp"
#include "dsmplan/clearance.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/flight_space.hpp"
#include "dsmplan/free_airspace.hpp"
#include "dsmplan/ground.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

// ---- a mission's takeoff and end ---------------------------------------------------------------

enum class MissionEnd { rtl, land, none };  ///< after the route: return to launch, land there, nothing

/// How a mission takes off and ends. The takeoff is vertical at home, to the first waypoint's
/// height above the ground (with the default home, the first waypoint itself); when home is
/// elsewhere, the route from there to the first waypoint is planned like any leg. `rtl` plans a
/// leg back above home, so that the autopilot's RTL, which flies a straight unchecked line at its
/// own altitude, finds nothing left to fly but the descent; `land` descends at the last waypoint.
/// The vertical climb and descent keep the safety distance from 1 m plus `safety` above the
/// ground up (below, a drone is taking off or landing). Without a DTM the ground is the DSM's
/// (or the mesh floor's) surface: a roof cannot be told from a street.
struct MissionEnds {
  /// x, y in the mesh's CRS, or longitude, latitude in degrees when |a| <= 180 and |b| <= 90
  /// (turned into the CRS by `from_lonlat`); NaN: the ground under the first waypoint.
  std::array<double, 2> home{NAN, NAN};
  std::optional<MissionEnd> end;  ///< unset: rtl
  /// Longitude, latitude in degrees to x, y in the mesh's CRS; needed only for a home in degrees.
  std::function<Point3(double, double)> from_lonlat;
};

/// Home, the top of the takeoff above it, and the landing; the legs they add to the route.
struct MissionSite {
  Point3 home{NAN, NAN, NAN};         ///< x, y in the CRS; z the ground there
  Point3 takeoff_top{NAN, NAN, NAN};  ///< above home, as high above the ground as the first waypoint
  Point3 land{NAN, NAN, NAN};         ///< MissionEnd::land: the ground under the last waypoint
  MissionEnd end = MissionEnd::rtl;
  bool leading = false;  ///< the takeoff top is a waypoint of its own, before the first
  bool returns = false;  ///< a leg back to the takeoff top follows the last waypoint
};

// ---- the request -------------------------------------------------------------------------------

/// Where a face keeps the roadmaps a plan builds, for the next run (a file for the command line,
/// memory for a service). Both members may be empty. `key` names what a roadmap was built from:
/// the obstacles, the ground and the zones (FlightArea::roadmap_key()).
struct FlightStore {
  /// A roadmap kept for `key` and these options, or null to build one. When this member is
  /// empty no roadmap is kept, and the planner builds its own (plan_path()).
  std::function<std::shared_ptr<const Roadmap>(uint64_t key, const PlanOptions& options)> kept_roadmap;
  /// Given the roadmap built when kept_roadmap() had none.
  std::function<void(const Roadmap& map, uint64_t key, const PlanOptions& options)> keep_roadmap;
};

/// Names of the inputs, for the messages that refuse them (file names on the command line).
struct FlightNames {
  std::string mesh = "the mesh", waypoints = "the waypoints", dsm = "the DSM", dtm = "the DTM";
};

/// The data flights are planned over.
struct FlightData {
  /// The obstacles: a 2.5D mesh in a projected CRS. With `index` given and no DSM, only its CRS
  /// is used (the triangles may be left unread: read_mesh_crs()).
  std::shared_ptr<const Mesh> mesh;
  /// A clearance index kept from an earlier plan over this very mesh (and DSM: obstacle_key()
  /// names it), and the fingerprint `keep_index` was given with it; null: built from the mesh.
  std::shared_ptr<const ClearanceIndex> index;
  uint64_t index_fingerprint = 0;
  /// The raw DSM (the mesh's CRS, covering the mesh): every point of the path keeps `safety` from
  /// its columns (columns.hpp), planned with the safety widened by how far the mesh lies inside
  /// them (column_margin()). Optional.
  std::shared_ptr<const Grid> dsm;
  /// The mesh was made of `dsm` with its holes filled (fill_holes_from_rim(), RimHeight::highest),
  /// as a corridor's windows are: the safety's widening is measured over every column, and no
  /// hole's column is joined to the mesh. False: the mesh leaves the holes void, and their columns
  /// join it (hole_columns()).
  bool mesh_fills_holes = false;
  /// The terrain (the mesh's CRS, any resolution): the ground max_agl counts from. Optional:
  /// without it the DSM's cells, else the mesh's floor.
  std::shared_ptr<const Grid> dtm;
  /// The terrain already made a GroundGrid, instead of `dtm` (built once for many areas: a
  /// corridor's windows).
  std::shared_ptr<const GroundGrid> terrain;
  /// No-fly zones (airspace.hpp, read_airspace()): the blocking ones (`airspace`) kept at the
  /// query's safety distance like the obstacles, AGL limits counted from the ground in use; a
  /// waypoint, home or landing inside one refused, naming it and its file.
  std::vector<AirspaceZone> no_fly;
  AirspaceOptions airspace;
  FlightNames names;
  /// Given the clearance index as soon as it is built, with the obstacles' key.
  std::function<void(const ClearanceIndex& index, uint64_t key)> keep_index;
};

/// What a waypoint's z is: a height in the mesh's CRS, or above the ground (agl): the ground the
/// ceiling counts from (FlightArea::ground(): the DTM, else the DSM, else the mesh's floor), as
/// ground stations let pilots give it.
enum class WaypointHeights { crs, agl };

/// One flight over the data: the waypoints and the limits.
struct FlightQuery {
  std::vector<Point3> waypoints;  ///< x, y in the mesh's CRS, z as `heights` says; at least two
  WaypointHeights heights = WaypointHeights::crs;
  /// Metres, in [0, 50]; 0: off. A waypoint that is refused (closer than the safety distance to
  /// the obstacles, under the surface, above the ceiling, inside a no-fly zone that blocks) is
  /// moved to the nearest valid point within this 3D distance: straight up first (steps of
  /// 0.1 m), then sideways (square rings of max(0.5 m, snap / 40), nearest in 3D first, each
  /// with the least vertical shift), held to the very check that refuses it, at most 16,000
  /// points tried (nearest first). None within: refused as without, naming the nearest valid
  /// point (within 50 m). Each move is reported
  /// (FlightReport::snapped). A mission's home whose climb is refused is moved sideways to the
  /// nearest clear spot within the radius (snap_home()); without, its refusal names that spot.
  double snap = 0;
  /// Planner, safety, ceiling, constraints (no-fly zones). `ground` is set from the data.
  PlanOptions options;
  /// A mission: a takeoff from home, the end, and the fewest straight legs that keep every
  /// limit (merge_straight_legs()). Unset: the path alone.
  std::optional<MissionEnds> mission;
  /// Fly straight from item to item without a mission of its own (a corridor's pieces of one).
  bool straight_legs = false;
  FlightStore store;
};

/// Everything one flight needs: the data and the query.
struct FlightRequest : FlightData, FlightQuery {};

/// FlightData checked against itself and made ready for many flights: the DSM's columns (holes
/// as high as their rim), the ground, how far the safety is widened on the mesh, and the
/// clearance index (built on first use, then given to FlightData::keep_index). Immutable but for
/// that first build, which is done once under a lock: one area answers many plan_flight() calls
/// from many threads. Errors: InputError(names.mesh/dsm/dtm) for data that disagree: a DTM or DSM
/// in another CRS than the mesh, one that does not overlap it, a DSM that does not cover it, a
/// mesh without triangles.
class FlightArea {
public:
  explicit FlightArea(FlightData data);
  ~FlightArea();
  FlightArea(const FlightArea&) = delete;
  FlightArea& operator=(const FlightArea&) = delete;

  const FlightData& data() const { return data_; }
  const Crs& crs() const { return data_.mesh->crs; }
  /// The DSM's columns, holes as high as their rim; null without a DSM.
  const Grid* columns() const { return data_.dsm ? &columns_ : nullptr; }
  /// The terrain (the DTM) max_agl counts from; null without one.
  const GroundGrid* terrain() const { return terrain_.get(); }
  /// The ground max_agl counts from: the terrain, the DSM's cells, or the mesh's floor; and its name
  /// ("dtm", "dsm", "mesh floor").
  const GroundGrid& ground() const;
  std::shared_ptr<const GroundGrid> shared_ground() const;
  const char* ground_name() const;
  /// Added to the safety distance on the mesh so that it holds against the columns (0 without a
  /// DSM): column_margin(), measured on first use (the free-airspace planner over the columns
  /// never asks).
  double safety_margin() const;
  /// The clearance index: the data's, or built now (the first call) from the mesh and the holes' columns.
  const ClearanceIndex& index() const;
  std::shared_ptr<const ClearanceIndex> shared_index() const;
  /// What kept files are named by: mesh_fingerprint() of the obstacles (O(mesh), once), or the
  /// kept index's.
  uint64_t obstacles_key() const;
  /// True when `options` plan over the DSM's columns themselves (the freespace planner with a
  /// DSM): the mesh's index and the safety's widening are then never needed.
  bool plans_on_columns(const PlanOptions& options) const {
    return options.planner == PlannerKind::free_space && columns();
  }
  /// The options the planner runs with: `options` with the ground set, the safety widened (not
  /// when plans_on_columns()), and the zones that block (zone_constraints()) added to its constraints.
  PlanOptions planner_options(const PlanOptions& options) const;
  /// The free airspace (free_airspace.hpp) over the DSM's columns, or over a mesh alone the
  /// columns enclosing it on its floor's cells, under `max_agl` over ground(), keeping `safety`:
  /// made on first use, then kept (4 kept). ArgumentError("--planner") over a mesh whose
  /// triangles were not read (a kept index alone).
  std::shared_ptr<const FreeAirspace> free_airspace(double safety, double max_agl,
                                                    const StopToken* stop = nullptr) const;
  /// The no-fly zones that block, kept at `safety` (airspace_constraints()); the same objects for
  /// the same distance (16 distances kept), so that queries share a roadmap.
  std::vector<std::shared_ptr<const FlightConstraint>> zone_constraints(double safety) const;
  /// The key a roadmap over this area is kept by (FlightStore): the obstacles, the ground and
  /// the zones that block. O(ground cells + zones) once.
  uint64_t roadmap_key() const;
  /// With a DSM: the mesh's certified depth below it, and the most a column rises above the mesh
  /// (column_margin()'s two measures); NaN without.
  double mesh_max_below_dsm() const;
  double column_max_above_mesh() const;

private:
  FlightData data_;
  Grid columns_;
  std::shared_ptr<const GroundGrid> terrain_, dsm_ground_;
  void measure_margin() const;
  struct Lazy;
  std::unique_ptr<Lazy> lazy_;
};

/// The key a kept index is named by: the mesh's own key (e.g. a hash of its file) and, when there
/// is a DSM, its holes' columns, which join the mesh in the index. O(DSM cells).
uint64_t obstacle_key(uint64_t mesh_key, const Grid* dsm);

/// A 64-bit hash of the mesh's vertices (their exact bits) and triangles. O(mesh).
uint64_t mesh_fingerprint(const Mesh& mesh);

/// InputError(name) unless `raster` (what: "DSM" or "DTM") shares `crs` (when both name an EPSG
/// code) and overlaps the x,y box [xmin, xmax] x [ymin, ymax]; a DSM must cover it (to half a
/// cell), or a path there would go unchecked.
void require_beside(const Grid& raster, const std::string& name, const char* what, const Crs& crs, double xmin,
                    double ymin, double xmax, double ymax);

// ---- the answer --------------------------------------------------------------------------------

/// The figures of a flight, each measured on the returned path (measure_flight()), not taken from
/// the planner: what a user checks the path by.
struct FlightReport {
  size_t waypoint_count = 0, path_points = 0;
  double path_length_m = 0;
  /// Least distance of the path to the mesh (ClearanceIndex::clearance(), capped at safety + max_agl).
  double min_clearance_m = 0;
  /// With a DSM: least distance of the path to the DSM's columns (column_clearance(), same cap); NaN without.
  double min_clearance_dsm_m = NAN;
  /// With a DSM: the mesh's certified depth below it (certify().max_below), and the tolerance the
  /// path is held to: min_clearance_dsm_m >= safety - dsm_tolerance_m (the rounding of written decimals).
  double mesh_max_below_dsm_m = NAN, dsm_tolerance_m = NAN;
  /// With a DSM: the most a column rises above the mesh anywhere (certify_columns()), and the
  /// margin the safety distance was widened by on the mesh to hold against the columns.
  double column_max_above_mesh_m = NAN, safety_margin_m = NAN;
  /// Greatest height of the path above the ground in use (exact), and which ground: "dtm", "dsm"
  /// or "mesh floor".
  double max_agl_m = NAN;
  std::string ground;
  size_t roadmap_nodes = 0, roadmap_edges = 0;
  bool roadmap_reused = false;  ///< the roadmap came from FlightStore::kept_roadmap
  bool index_reused = false;    ///< the clearance index came with the data
  size_t refined_samples = 0;   ///< samples the query added where the roadmap failed a leg (plan.hpp)
  std::string planner = "prm";
  size_t corridor_windows = 0;               ///< planned along a corridor: windows (0: a mesh)
  size_t corridor_largest_window_cells = 0;  ///< planned along a corridor: cells of the largest window
  /// Seconds: before the planner (index, columns, ground, a kept roadmap), then the planner's parts.
  double seconds_load = 0, seconds_roadmap = 0, seconds_query = 0, seconds_smooth = 0;
  /// seconds_load split: reading the files (the face's, added by it) and the rest.
  double seconds_read = 0, seconds_index = 0;
  /// Missions: home (x, y in the CRS, z its ground), the surface its ground was taken from, the
  /// best given ("dtm", "dsm" or "mesh floor"), and that ground's uncertainty
  /// (GroundGrid::spread_at()); the height of the takeoff above home; the end.
  Point3 home{NAN, NAN, NAN};
  std::string home_ground;
  double home_ground_uncertainty_m = NAN;
  double takeoff_height_m = NAN;
  std::string mission_end;  ///< rtl, land or none (missions only)
  /// Each no-fly zone of the data, in order, with whether it blocks and the least distance of the
  /// path to it (zone_distance(): a lower bound, 0 when the path enters a zone that does not block).
  struct ZoneFigure {
    std::string label, id, name, file;
    bool blocks = false;
    double min_distance_m = NAN;
  };
  std::vector<ZoneFigure> no_fly_zones;
  /// Each waypoint FlightQuery::snap moved, in order, then home: its number (1-based; 0 for
  /// home), where it was and where it went (the CRS), how far (3D) and why it was refused there.
  struct Snap {
    size_t waypoint = 0;  ///< 0: home
    std::string place;    ///< "waypoint N" or "home"
    Point3 from{NAN, NAN, NAN}, to{NAN, NAN, NAN};
    double distance_m = NAN;
    std::string reason;
  };
  std::vector<Snap> snapped;
};

/// The waypoints with z in the CRS: with WaypointHeights::agl, each z is a height above the ground
/// and the ground's height there, `ground_z(x, y)`, is added (the same ground the ceiling counts
/// from). InputError(file, "waypoint N") where `ground_z` is not finite (no ground known there;
/// `ground_name` names the ground: "dtm", "dsm", "mesh floor").
std::vector<Point3> waypoints_in_crs(std::vector<Point3> waypoints, WaypointHeights heights,
                                     const std::function<double(double, double)>& ground_z, const std::string& file,
                                     const std::string& ground_name);

/// A mission's site in its report: home, the takeoff's height, the end.
void report_site(const MissionSite& site, FlightReport& report);

struct FlightPlan {
  /// The waypoints flown through, in the CRS: the query's, their heights above the ground turned
  /// into the CRS's and the refused ones snapped (FlightQuery::snap).
  std::vector<Point3> waypoints;
  /// The path through every waypoint, in order; a mission's from the top of the takeoff above
  /// home (or the first waypoint) with the fewest straight legs that keep every limit.
  std::vector<Point3> path;
  std::optional<MissionSite> site;  ///< missions: home, takeoff, landing
  FlightReport report;
  /// The clearance index planned on (the data's, or built: FlightData::keep_index had it).
  std::shared_ptr<const ClearanceIndex> index;
};

/// The flight as the drone flies it: a mission's path from home on the ground up to the route,
/// along it, and down (at home after the leg back above it, or at the landing); without a site,
/// the path. What every output but a mission's items shows (CSV, GeoJSON, KML, pictures).
std::vector<Point3> flown_path(const FlightPlan& flight);

/// Plans the request and verifies the path against the data, as the top of this header says:
/// FlightArea(request) then plan_flight(area, request).
/// Errors: ArgumentError for options out of range (check_plan_options()); DataFault("--home",
/// "--end") for a home or landing the data refuse (its nearest() the nearest clear spot); InputError(names.waypoints,
/// "waypoint N" or "waypoints N to M", why) for waypoints that cannot be flown to or legs without a path;
/// InputError(names.dsm / names.dtm / names.mesh, ...) for data that disagree. Deterministic.
FlightPlan plan_flight(const FlightRequest& request, const Progress& progress = {});

/// One flight over a prepared area (many may run at once over one area). Errors as above.
FlightPlan plan_flight(const FlightArea& area, const FlightQuery& query, const Progress& progress = {});

/// A flight whose failure is a value, for a caller that words it itself (a corridor numbers its
/// windows' ends as the user's legs): waypoints refused and legs without a path come back in
/// `failure` (InvalidWaypoint, every refused waypoint listed, or NoPath), numbered along the
/// route the planner flew: failure_in_words(failure, plan.site ? &*plan.site : nullptr, count of
/// the query's waypoints) says it in the user's words. Other errors throw as plan_flight().
struct FlightAttempt {
  bool solved = false;
  FlightPlan plan;     ///< solved: the flight; else its site when a mission's was made, and the figures so far
  PlanResult failure;  ///< not solved: why
};
FlightAttempt attempt_flight(const FlightArea& area, const FlightQuery& query, const Progress& progress = {});

/// Why a route has no flight, for a program. Waypoints are numbered from 1 as the route gives
/// them; 0 is the takeoff's top above a mission's home. `code`:
///   "waypoint_refused"  `waypoint` cannot be flown to (the first of those refused)
///   "no_path"           no path on `leg` (from, to)
///   "home_refused"      a mission's home or its climb; "end_refused" its landing
///   "route_budget"      past the route's own time limit (plan_routes()'s `route_budget`)
///   "refused"           another refusal of the data (a DTM above the DSM, ...)
/// `nearest`: where it would be accepted (CRS), when searched and found: the nearest valid point
/// to a refused waypoint, the nearest clear spot on the ground for a refused home.
struct RouteFailure {
  std::string code;
  std::optional<size_t> waypoint;            ///< waypoint_refused
  std::optional<std::array<size_t, 2>> leg;  ///< no_path
  std::optional<Point3> nearest;
};

/// RouteFailure of a failed plan, numbered as failure_in_words() names it.
RouteFailure route_failure(const PlanResult& result, const MissionSite* site, size_t user_waypoints);

/// One route of plan_routes(): its flight, or why there is none in the user's words (`place`
/// as "waypoint 2" or "waypoints 1 to 2", empty when the refusal was not a waypoint's: then `why`
/// is the whole line, e.g. "--home: ...") and for a program (`failure`).
struct RouteResult {
  bool solved = false;
  FlightPlan plan;
  std::string place, why;
  RouteFailure failure;
  /// The one line a failed route is reported by: "place: why", or `why` alone.
  std::string reason() const { return place.empty() ? why : place + ": " + why; }
};

struct RoutesPlan {
  std::vector<RouteResult> routes;  ///< in the order given
  size_t roadmap_nodes = 0, roadmap_edges = 0;
  bool roadmap_reused = false;                                 ///< from FlightStore::kept_roadmap
  double seconds_index = 0, seconds_roadmap = 0, seconds = 0;  ///< seconds: the whole call
};

/// Many flights over one area: the paper's multi-query planner. One roadmap (the store's, else
/// built once for `common`'s options and given to FlightStore::keep_roadmap), every route a
/// query against it with `common`'s options and mission, in parallel (TBB), each held to every
/// rule and verified as plan_flight() does. A route that fails does not stop the others: its
/// RouteResult says why. With the rrtconnect planner every route grows its own trees.
/// Deterministic: the same routes give the same paths whatever the number of threads.
/// `route_budget` (s, [0, 3600], 0: none): each route's own time limit, counted from its start;
/// a route past it fails ("route_budget") and the others go on. The roadmap or free airspace
/// the routes share is then made first, on no route's time. A stop of `common.options.stop`
/// still stops the whole call (Cancelled).
/// Errors: ArgumentError for options out of range; everything else is a route's.
RoutesPlan plan_routes(const FlightArea& area, const std::vector<std::vector<Point3>>& routes,
                       const FlightQuery& common, const Progress& progress = {}, double route_budget = 0);
/// ArgumentError("route_budget") unless `seconds` lies in [0, 3600].
void check_route_budget(double seconds);

// ---- the rules, one implementation each ------------------------------------------------------

/// Keeps `safety` from obstacles, and says how far they are: the DSM's columns or the mesh.
class ObstacleClearance : public FlightConstraint {
public:
  explicit ObstacleClearance(double safety) : safety_(safety) {}
  double safety() const { return safety_; }
  /// min(safety, the distance of the segment [p, q] to the obstacles).
  virtual double clearance(const Point3& p, const Point3& q) const = 0;
  bool state_valid(const Point3& p) const override { return clearance(p, p) >= safety_; }
  bool motion_valid(const Point3& p, const Point3& q) const override { return clearance(p, q) >= safety_; }

private:
  double safety_;
};

/// The DSM's cells as solid columns (`columns`: holes filled from their rim, RimHeight::highest).
class ColumnsClearance : public ObstacleClearance {
public:
  ColumnsClearance(const Grid& columns, double safety) : ObstacleClearance(safety), columns_(columns) {}
  double clearance(const Point3& p, const Point3& q) const override;
  std::string name() const override { return "the DSM's columns"; }

private:
  const Grid& columns_;
};

/// The mesh's triangles.
class MeshClearance : public ObstacleClearance {
public:
  MeshClearance(const ClearanceIndex& index, double safety) : ObstacleClearance(safety), index_(index) {}
  double clearance(const Point3& p, const Point3& q) const override;
  std::string name() const override { return "the mesh"; }

private:
  const ClearanceIndex& index_;
};

/// What a straight motion of a flight is held to: the obstacles, the ceiling over `ground`, the
/// constraints (no-fly zones).
struct FlightRules {
  const ObstacleClearance* obstacles = nullptr;
  const GroundGrid* ground = nullptr;  ///< null: no ceiling
  double max_agl = INFINITY;
  std::vector<const FlightConstraint*> constraints;
  const StopToken* stop = nullptr;  ///< the request's stop: keeps() throws Cancelled once it is requested
  bool keeps(const Point3& p, const Point3& q) const;
};

/// Path simplification for missions, which fly straight from item to item: the fewest points of
/// `path` (first and last kept, and every one of `waypoints`, which the path passes in order)
/// whose straight segments keep `rules`; greedy, from each kept point to the farthest point
/// before the first whose direct segment fails. O(n x run) clearance queries.
std::vector<Point3> merge_straight_legs(const std::vector<Point3>& path, const std::vector<Point3>& waypoints,
                                        const FlightRules& rules);

/// The site of a mission through `waypoints` (CRS). `ground_z(x, y)`: the ground's height there,
/// not finite where unknown. DataFault("--home"/"--end") for a home or landing over no ground;
/// ArgumentError("--home") for a home that is not two finite numbers.
MissionSite mission_site(const MissionEnds& ends, const std::vector<Point3>& waypoints,
                         const std::function<double(double, double)>& ground_z);

/// The waypoints the planner goes through: the takeoff top first when it is a leg of its own,
/// the takeoff top last when the mission returns.
std::vector<Point3> route_waypoints(const std::vector<Point3>& waypoints, const MissionSite& site);

/// DataFault("--home") or DataFault("--end") when the vertical climb at home or the
/// descent at the landing passes nearer the obstacles than the safety distance (less 1 cm) from
/// 1 m plus `safety` above the ground up, rises above the ceiling, or breaks a constraint from
/// the ground up (a no-fly zone over home); `dsm_z`, when given, also
/// refuses a home or landing under a roof or tree (DSM more than 1 m above the ground). A home
/// that fails is answered with the nearest clear spot within 50 m (DataFault::nearest(): on the
/// ground there).
void check_vertical_legs(const MissionSite& site, const std::vector<Point3>& waypoints, const FlightRules& rules,
                         const std::function<double(double, double)>& dsm_z);

/// FlightQuery::snap for home: when check_vertical_legs() would refuse the climb at home, home is
/// moved to the nearest clear spot within `radius` metres (horizontally; on the ground's cells,
/// nearest first) whose climb keeps the rules and whose top `top_valid` accepts (when given: the
/// planner's check of a waypoint). The takeoff top moves with it, as high above the new ground,
/// and becomes a leg of its own. Returns the move; none when the climb is clear or no spot lies
/// within (check_vertical_legs() then refuses home, naming the nearest clear spot).
std::optional<FlightReport::Snap> snap_home(MissionSite& site, const std::vector<Point3>& waypoints,
                                            const FlightRules& rules,
                                            const std::function<double(double, double)>& dsm_z, double radius,
                                            const std::function<bool(const Point3&)>& top_valid = {});

/// The no-fly zones a vertical leg keeps out of, where the ground is read piece by piece: their
/// AGL limits count from `terrain`, else from the DSM read around the leg.
struct ZonesAround {
  const std::vector<AirspaceZone>* zones = nullptr;
  AirspaceOptions airspace;
  std::shared_ptr<const GroundGrid> terrain;
  double distance = NAN;  ///< kept from the zones (zone_keep_distance()); NaN: the legs' safety
};

/// check_vertical_legs() for a DSM read window by window (along a corridor): the columns around
/// each vertical leg read from `dsm` (holes as high as their rim), and the zones; no ceiling
/// check (the takeoff top is as high above the ground as the first waypoint, which is checked).
void check_vertical_legs_in(GridSource& dsm, const MissionSite& site, const std::vector<Point3>& waypoints,
                            double safety, const ZonesAround& zones = {});

/// The planner's place of a failure in the user's words: "waypoint k" of the user's list, or the
/// takeoff above --home, or the leg back above home (--end rtl).
std::string mission_place(const PlanResult& result, const MissionSite& site, size_t user_waypoints);

/// A failed plan in the user's words: where (mission_place() for a mission, `site` given, else
/// PlanResult::place()) and why, every invalid waypoint named the same way (PlanResult::problems()).
struct FailureInWords {
  std::string place, why;
};
FailureInWords failure_in_words(const PlanResult& result, const MissionSite* site, size_t user_waypoints);

/// InputError(terrain_name, place, problem) when the terrain stands above the surface it should
/// lie under (terrain_above_surface()): at home, a waypoint ("waypoint N", 1-based), the landing
/// (those of `site` when given), or over the cells. `surface_z(x, y)` as terrain_above_surface()
/// takes it; `surface_name` names the surface in the message ("the DSM dsm.tif").
void refuse_terrain_above(const GroundGrid& terrain, const std::function<double(double, double)>& surface_z,
                          const std::vector<Point3>& waypoints, const MissionSite* site,
                          const std::string& terrain_name, const std::string& surface_name);

/// The measures of a path, each defined once: the greatest height above `ground` (exact, per
/// segment: GroundGrid::max_height_above()) with the segment where it is reached (1-based), and,
/// when `columns` is given, the least distance to the DSM's columns (column_clearance(), capped at
/// `cap`) with its segment. plan_flight()'s verification, `dsmplan profile` and Python read these.
struct PathMeasures {
  double max_agl_m = -INFINITY;
  size_t max_agl_segment = 0;
  double min_clearance_dsm_m = NAN;
  size_t min_clearance_dsm_segment = 0;
};
PathMeasures measure_path(const std::vector<Point3>& path, const GroundGrid& ground, const Grid* columns, double cap);

}  // namespace dsmplan
