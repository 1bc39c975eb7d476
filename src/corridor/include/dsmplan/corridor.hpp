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
// max_agl; the path passes through it. Each piece is planned by plan_path() on its window and
// measured there: clearance to the window's mesh, and to the window's DSM columns
// (column_clearance()). Rectangular windows keep every straight segment of a piece over known
// ground. Memory: two windows, O((chunk + 2 margin)^2 cells) whatever the city's size.

struct CorridorOptions {
  BoundedSimplifyOptions mesh;  ///< the windows' meshes; conservative is forced on
  double chunk = 1000;          ///< longest piece of a leg planned in one window (x,y), CRS units
  double margin = 150;          ///< flight area around a piece's x,y box, CRS units
  /// Applied to each piece's path before it is measured and joined (the tool drops the points
  /// on straight runs for missions); empty: none.
  std::function<std::vector<Point3>(const std::vector<Point3>&)> finish_piece;
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
};

/// Plans through `waypoints` (CRS coordinates) over `dsm` along a corridor (see above). Throws
/// ArgumentError for bad options (chunk or margin <= 0) and what simplify_bounded() throws for
/// a window; a waypoint outside the DSM or no safe via point gives status InvalidWaypoint/NoPath
/// with the place and the reason, like plan_path().
CorridorResult plan_corridor(GridSource& dsm, const std::vector<Point3>& waypoints, const PlanOptions& plan,
                             const CorridorOptions& options, const Progress& progress = {});

}  // namespace dsmplan
