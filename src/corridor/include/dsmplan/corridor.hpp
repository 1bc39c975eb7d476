// dsmplan/corridor.hpp: a city too large to mesh whole, planned window by window along a
// corridor; above the planner (plan.hpp), which it runs on each window's mesh.
//
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/flight.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/simplify.hpp"

namespace dsmplan {

// ---- a tiled city: planning along a corridor ---------------------------------------------
//
// A DSM too large to mesh whole (a VRT mosaic of a city) is planned over piece by piece, never
// holding more than two windows of it. Every leg is cut into pieces of at most `chunk` (x,y);
// a piece flies inside the x,y box of its two ends widened by `margin`, over the conservative
// bounded mesh (simplify_bounded(), conservative, max_error) of that box widened again by
// safety + 2 cells, so that every obstacle within the safety distance of the flight area is in
// the window. The point where two pieces meet (a "via" point, on the straight line of the leg)
// is put at the lowest height, in whole metres above safety over the higher of the two
// windows' surfaces, that keeps the safety distance from both windows' meshes and stays under
// max_agl; the path passes through it. Each piece is a flight of its own over its window
// (attempt_flight() on a FlightArea of the window's DSM and mesh): held to every rule of the plan
// stage and verified against the window's DSM columns. Rectangular windows keep every straight
// segment of a piece over known ground. Memory: two windows, O((chunk + 2 margin)^2 cells)
// whatever the city's size.

struct CorridorOptions {
  BoundedSimplifyOptions mesh;  ///< the windows' meshes; conservative is forced on
  double chunk = 1000;          ///< longest piece of a leg planned in one window (x,y), CRS units
  double margin = 150;          ///< flight area around a piece's x,y box, CRS units
  /// Each piece flown as the fewest straight legs that keep every limit (FlightQuery::straight_legs),
  /// as a mission flies.
  bool straight_legs = false;
  /// The ground --max-agl counts from (a DTM); null: each window's DSM cells.
  std::shared_ptr<const GroundGrid> terrain;
};

struct CorridorResult {
  PlanResult plan;     ///< the path through all waypoints; status, place and reason as plan_path()
  size_t windows = 0;  ///< pieces planned (one window each)
  size_t largest_window_cells = 0;
  VerticalError mesh_error;        ///< the windows' meshes against the DSM, merged (certified per tile)
  double min_clearance_m = 0;      ///< least clearance of the path to its windows' meshes
  double min_clearance_dsm_m = 0;  ///< least clearance to the DSM columns (holes as high as their rim)
  double max_agl_m = -INFINITY;    ///< greatest height of the path above the ground (exact)
  double safety_margin_m = 0;      ///< the largest widening of the safety distance on a window's mesh (column_margin())
  double seconds_windows = 0;      ///< reading and meshing the windows
  /// Each no-fly zone with the least distance of any piece to it (FlightReport::no_fly_zones).
  std::vector<FlightReport::ZoneFigure> no_fly_zones;
};

/// Plans through `waypoints` (CRS coordinates) over `dsm` along a corridor (see above). Throws
/// ArgumentError for bad options (chunk or margin <= 0) and what simplify_bounded() throws for
/// a window; a waypoint outside the DSM or no safe via point gives status InvalidWaypoint/NoPath
/// with the place and the reason, like plan_path().
/// `names` name the inputs in the messages of a piece's flight (names.mesh: the DSM's file);
/// `zones`, the no-fly zones every piece keeps out of (FlightData::no_fly, `airspace` which block).
CorridorResult plan_corridor(GridSource& dsm, const std::vector<Point3>& waypoints, const PlanOptions& plan,
                             const CorridorOptions& options, const Progress& progress = {},
                             const FlightNames& names = {}, const std::vector<AirspaceZone>& zones = {},
                             const AirspaceOptions& airspace = {});

/// plan_flight() for a DSM too large to mesh whole: one flight along a corridor of `dsm`, with the
/// same rules and the same answer (FlightPlan, its report's corridor figures set). The DTM is
/// checked beside and below the DSM (read a row at a time), a mission's home and landing against
/// the DSM read around them; each piece is verified on its window. Errors as plan_flight(), and
/// ArgumentError for bad corridor options, and ArgumentError("snap") for FlightQuery::snap, which
/// a corridor does not do. `dtm`: optional.
struct CorridorRequest : FlightQuery {
  std::shared_ptr<const Grid> dtm;
  std::vector<AirspaceZone> no_fly;  ///< as FlightData::no_fly
  AirspaceOptions airspace;
  CorridorOptions corridor;
  FlightNames names;  ///< names.mesh: the DSM
};
FlightPlan plan_flight_along(GridSource& dsm, const CorridorRequest& request, const Progress& progress = {});

}  // namespace dsmplan
