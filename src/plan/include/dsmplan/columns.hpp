// dsmplan/columns.hpp: the DSM as solid columns, the guarantee a path planned on a mesh keeps
// against the data itself, and the distance from a segment to those columns.
//
#pragma once

#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/simplify.hpp"

namespace dsmplan {

// ---- clearance to the raw DSM ------------------------------------------------------------

/// min(max_d, the distance from the segment [p, q] to the DSM taken as solid columns): every
/// valid cell is a box over its square from -infinity up to its height; nodata cells are empty
/// air. Exact (the segment-box distance is minimised in closed form on each piece where the
/// segment enters or leaves a slab). An independent check of a path planned on a mesh: the
/// columns stand up to half a cell beyond the mesh's vertices at the cell centres, so over a
/// wall this distance can be below the mesh clearance by up to half a cell diagonal.
/// Throws ArgumentError for a non-finite point or max_d < 0.
/// Time O(cells within the distance found of the segment's box; doubling search from 2 cells).
double column_clearance(const Grid& dsm, const Point3& p, const Point3& q, double max_d);

/// The DSM's column nearest to the point `p` within `max_d`: where an obstacle stands, for the
/// message that refuses a waypoint. `distance` is column_clearance(dsm, p, p, max_d) (0 inside
/// a column); x, y the cell's centre and `top` its height; found = false when none is nearer than
/// max_d. O(cells within max_d).
struct NearestColumn {
  bool found = false;
  double distance = 0, x = 0, y = 0, top = 0;
};
NearestColumn nearest_column(const Grid& dsm, const Point3& p, double max_d);

/// L_s(x, y): the least height at which the point (x, y, z) keeps `safety` from every column of
/// `dsm` (column_clearance() >= safety exactly when z >= it, the columns reaching down without
/// end): the largest, over the valid cells within `safety` of (x, y), of the cell's height plus
/// sqrt(safety^2 - d^2), d the horizontal distance to the cell's square; -infinity when none lies
/// within. The free airspace's floor at a place (free_airspace.hpp), and what `profile` draws
/// under a path. ArgumentError for a place that is not finite or a safety that is not >= 0.
/// O((safety / cell)^2).
double lowest_clear_height(const Grid& dsm, double x, double y, double safety);

// ---- holding a mesh plan to the DSM's columns ---------------------------------------------
//
// With the DSM known, dsmplan guarantees more than clearance to its mesh: every point of the
// path keeps `safety` from the DSM's columns themselves, at any cell size and with nothing
// subtracted. `columns` is the DSM with its holes filled from their rim (fill_holes_from_rim(),
// RimHeight::highest): unknown space is as high as the highest cell around it, so no path
// passes through a hole lower than the hole's rim. The planner is run on the mesh plus
// hole_columns() (exact boxes) with the safety distance widened by column_margin() (of the
// valid cells), and the written path is
// measured against the columns with column_clearance() (src/tools/plan_path.cpp).
// Without a DSM (`plan MESH` alone) the guarantee is the mesh's: clearance to its triangles.

/// The widening of the safety distance on `mesh` under which clearance to the mesh bounds
/// clearance to the columns of `dsm`'s valid cells (its holes are hole_columns()' part): the
/// smaller of the most a column rises above the mesh (certify_columns(); only when the mesh
/// covers every column) and sqrt((cell diagonal / 2)^2 + E^2) with E the mesh's certified depth
/// below the cell centres. 0.71 m for a conservative mesh of a 1 m DSM. O(cells + triangles x
/// edge length in cells). The two measurements it rests on go to `columns_above` and
/// `below_centres` when they are not null.
double column_margin(const Mesh& mesh, const Grid& dsm, ColumnError* columns_above = nullptr,
                     VerticalError* below_centres = nullptr);

/// The columns of the cells that are nodata in `dsm` but have a height in `columns` (its holes
/// filled), as triangles in `dsm`'s CRS: each cell's top, and walls down to 1 m below the
/// lowest column on the sides that face no other such cell. Empty when `dsm` has no hole. O(cells).
Mesh hole_columns(const Grid& dsm, const Grid& columns);

}  // namespace dsmplan
