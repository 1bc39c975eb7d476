// dsmplan/free_airspace.hpp: the planner on the free airspace itself (`--planner freespace`).
//
// The obstacles are solid columns that reach down without end: the DSM's cells (holes as high as
// their rim, columns.hpp), or over a mesh alone the highest the mesh comes over each cell of its
// floor's raster. A point keeps `safety` from all of them exactly when its height is at least
//     L_s(x, y) = max over the cells k within `safety` of (h_k + sqrt(safety^2 - d_k^2)),
// d_k the horizontal distance from (x, y) to cell k's square. Above each (x, y) the free airspace
// is therefore one interval, from L_s up to the ceiling: planning is a 2.5D problem.
//
// The airspace at the DSM's resolution (free_airspace()): for every cell, `floor` is the largest
// L_s over its closed square (so every point of the square at or above it is clear) and `top` the
// ceiling's least over it (max_agl over the lowest ground touching the square). A cell is open
// when floor <= top; two of the 8 neighbouring cells are joined when the higher floor is under
// the lower top: the drone can then fly from one centre to the other at the higher floor. The
// joined open cells fall into connected regions (`region`), labelled once.
//
// What it means to be complete at the DSM's resolution: a leg is solved whenever a chain of
// joined cells leads from a cell its start can reach in a straight line to one its end can;
// where none does, no path exists that keeps `safety` from every cell square it passes over
// (a passage narrower than the cells' conservative floors can leave is not used).
//
// A query (plan_free_airspace()): A* (Hart, Nilsson & Raphael 1968) over the joined cells, the cost
// of a step its horizontal length plus the floors' difference (the climb), then the path pulled
// tight with exact segment checks as post-smoothed any-angle planners do (Daniel, Nash, Koenig &
// Felner, "Theta*: Any-Angle Path Planning on Grids", JAIR 39, 2010). The path keeps low: its
// points lie on the floors of the cells it crosses, and only pulled segments that the exact check
// accepts leave them. A leg whose ends lie in different regions is refused at once, naming the
// regions' areas: the refusal is the proof.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/flight_space.hpp"
#include "dsmplan/ground.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

/// The free airspace of a raster of columns, cell by cell (see the top). Immutable once made.
struct FreeAirspace {
  Grid floor;                          ///< per cell: the least height its whole closed square is clear from; NaN: none
  std::vector<float> top;              ///< per cell: the ceiling's least over its closed square; -inf: none
  std::vector<uint32_t> region;        ///< per cell: its connected region's number; kClosed: not open
  std::vector<uint32_t> region_cells;  ///< per region: how many cells
  double safety = 0, max_agl = 0;
  static constexpr uint32_t kClosed = UINT32_MAX;
  bool open(size_t cell) const { return region[cell] != kClosed; }
  /// The higher floor of two cells is under the lower top.
  bool joined(size_t a, size_t b) const { return std::max(floor.z[a], floor.z[b]) <= std::min(top[a], top[b]); }
  double cell_area() const { return floor.cell_x * floor.cell_y; }
  size_t open_cells() const {
    size_t n = 0;
    for (uint32_t cells : region_cells) n += cells;
    return n;
  }
  size_t memory_bytes() const;
};

/// The free airspace over `columns` (solid columns; NaN cells are unknown, never flown over)
/// under `max_agl` over `ground`, keeping `safety`. Floors are raised and tops lowered by 1 cm,
/// the room rounding needs for the exact checks to agree. Cells on the raster's edge are closed
/// (the ground beyond is unknown). ArgumentError("--safety"/"--max-agl") for a value out of
/// range, and ArgumentError("--safety") before any work when cells x (2 safety / cell)^2 passes 2
/// billion comparisons (a safety of 25 m over a million 1 m cells), saying so. Time
/// O(cells x (safety / cell)^2), parallel, stopped within a row by `stop`; memory 13 bytes a cell.
std::shared_ptr<const FreeAirspace> free_airspace(const Grid& columns, const GroundGrid& ground, double safety,
                                                  double max_agl, const StopToken* stop = nullptr);

/// The highest the mesh comes over each cell of `like`'s raster, a bound from above (the larger
/// of its triangles' planes over the part of the cell their x,y box meets, at most their highest
/// corner): columns that enclose the region under a 2.5D mesh. NaN where no triangle meets a cell.
/// O(triangles x cells each box meets).
Grid mesh_columns(const Mesh& mesh, const Grid& like);

/// What a query is held to beside the cells: the exact check of a straight motion (the
/// obstacles' clearance, the ceiling, the constraints; FlightRules::keeps()), and the
/// constraints alone, asked of every step between cells (no-fly zones are not in the cells).
struct FreeAirspaceRules {
  std::function<bool(const Point3&, const Point3&)> motion_valid;
  std::vector<const FlightConstraint*> constraints;
  const StopToken* stop = nullptr;
  /// What a metre of climb or descent between the cells' floors costs in the search, in metres
  /// flown (PlanOptions::objective: 1 for low, 0.25 for shortest).
  double climb_weight = 1;
};

/// A path through `waypoints` (CRS, in order, each already a valid point: the caller checks
/// them) over `air`, leg by leg, every segment accepted by rules.motion_valid (checked once
/// more before it is returned: std::logic_error if not, a bug). NoPath names the leg and why: its
/// ends' regions and their areas, or an end no open cell within reach of a straight line joins.
/// PlanResult::lattice_nodes counts the cells the searches settled. Deterministic.
/// Time O(cells settled x log) a leg, plus O(log n) exact checks per point of the pulled path.
PlanResult plan_free_airspace(const FreeAirspace& air, const std::vector<Point3>& waypoints,
                              const FreeAirspaceRules& rules);

}  // namespace dsmplan
