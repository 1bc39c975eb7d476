// dsmplan/simplify.hpp: stage 3, fewer triangles, known error.
//
// Two families, and one measure that judges them both.
//
// 1. The paper's one-pass simplification (Adolf & Hirschmueller, Section 4): simplify_paper().
//    One search pass over the whole, unmodified mesh marks vertices; all marked vertices go at
//    once; the survivors are re-triangulated to Delaunay (XY-3). Two criteria:
//      co-planar  every direct neighbour's height is within dz of the vertex's own
//                 (|z_n - z_a| <= dz for all neighbours n);
//      co-linear  the vertex A lies between two of its neighbours B, C:
//                 |AB| + |AC| <= |BC| + dco (3D lengths).
//    Variant one: co-planar, then co-linear. Variant two: co-planar, then co-linear only where
//    the co-linearity is not in the horizontal plane.
//    Readings of the paper this code had to choose, and why:
//      - Every vertex is tested against the original mesh, and a vertex whose neighbour is
//        already marked may be marked too. The paper tests "over the whole mesh" in "one step"
//        and deletes "at the end of the selection process"; and its Table 2 removes 61 % of
//        Mitte's vertices as co-planar, more than any set of pairwise non-adjacent vertices of a
//        grid triangulation (at most half of them) could hold. The "set of unique search hits"
//        only saves work: each vertex is decided once, and its neighbour list is read once.
//      - "Not in the horizontal plane" (variant two) means B and C differ in height by more than
//        dco: the line through them rises. dco is the only tolerance the paper gives for the
//        co-linear step; with heights in 0.1 m steps it reads "B and C not at the same height".
//      - Co-linear uses any two neighbours B, C of A (not only opposite ones): the paper's
//        definition names no order, and with dco = 1e-5 m only a straight line through A passes.
//      - Border vertices (on an edge with one triangle: the DSM's outline and holes) have an open
//        neighbour fan. They are never removed as co-planar, and as co-linear only between their
//        two border neighbours and on the x,y line between them, whatever dco allows in 3D:
//        otherwise the mesh's footprint would shrink and cells near the outline would be left
//        uncovered, with no surface for the planner to avoid.
//      - A vertex without triangles (a lone valid cell in a hole) has no neighbours and stays.
//      - Tolerances are compared with 1 nm of slack: heights in 0.1 m steps are decimals held in
//        binary (112.7 - 112.3 = 0.4000000000000057), and "within 0.4 m" must not depend on
//        the height.
//      - A co-linear vertex is removed because it lies "on an edge between two neighbour
//        vertices" (the paper's Fig. 5). The Delaunay re-triangulation need not contain that
//        edge; where it does not, the surface over the removed vertex can drop to the street
//        beside a thin wall whose top rises (measured on the NRW tile: wall tops cut down).
//        So after re-triangulation every removed co-linear vertex is located in the new mesh,
//        and those the surface misses by more than dz, or does not cover, are put back
//        (inserted again, Delaunay kept), until none is; they count as kept
//        (restored_colinear), not as removed.
//      - Re-triangulation keeps the outline and holes: the survivors get a constrained Delaunay
//        triangulation whose constraints are the input's border edges (between surviving border
//        vertices), and only the faces inside the input's footprint are kept. Where the input
//        has no holes and a convex outline (a DSM tile) this is the plain Delaunay triangulation.
//    Input: any 2.5D triangle mesh (check_2_5d()). O(n log n), n = vertices; the search pass is
//    O(sum of squared vertex degrees), the re-triangulation is CGAL's.
//
// 2. The bounded mode (beyond the paper): simplify_bounded(). Greedy insertion (Garland &
//    Heckbert, "Fast polygonal approximation of terrains and height fields", CMU-CS-95-181,
//    1995; Fowler & Little 1979) straight on the DSM grid: starting from the outline, the cell
//    farthest from the current Delaunay triangulation is inserted until every valid cell centre
//    is within the bound. Two guarantees, certified afterwards by certify():
//      two-sided     |mesh - dsm| <= max_error at every valid cell centre;
//      conservative  0 <= mesh - dsm <= max_error at every valid cell centre: vertices are lifted
//                    to dsm + E/2 and fitted within E/2, so a clearance measured on the mesh is a
//                    lower bound of the clearance to the data.
//    Parallel by tiles: tile borders (and the outline) are simplified first as polylines with
//    the same bound, so neighbouring tiles share exactly the same border vertices (watertight,
//    no T-junctions); then every tile is filled by greedy insertion on its own thread. Each tile
//    is a Delaunay triangulation; across tile borders the mesh is constrained Delaunay.
//    `delaunay = true` runs one tile over the whole grid on one thread: the whole mesh is then
//    the Delaunay triangulation of its vertices (the paper's requirement), at the cost of speed.
//    Nodata cells have no bound: the triangulation spans narrow holes from their rim and drops
//    triangles under which every covered cell centre is nodata.
//    A new vertex sits at its cell's target height, or nearer the current surface when that is
//    within 40 % of the bound (fewer vertices: the fit around it is disturbed less).
//    Heights are the grid's as given (not quantized). O(n log n) typical, n = cells.
//
// 3. The certified error: certify(). For every valid cell centre, the exact vertical distance
//    from the DSM to the mesh above it (the triangle containing the centre in x,y, interpolated
//    linearly; a centre on a shared edge belongs to either, they agree there). Not a sample.
//
// Errors: ArgumentError for a bad option (dz < 0, dco < 0, max_error outside 0.001 to 10000);
// InputError for a mesh that is not 2.5D. See core.hpp.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

// ---- the paper (Section 4) ---------------------------------------------------------------

enum class PaperVariant { One, Two };
const char* to_string(PaperVariant);

struct PaperSimplifyOptions {
  PaperVariant variant = PaperVariant::Two;
  double dz = 0.4;    ///< co-planar tolerance, vertical units (the paper: 0.4 m), >= 0
  double dco = 1e-5;  ///< co-linear tolerance, CRS units (the paper: 1e-5 m), >= 0
};

/// Throws ArgumentError for dz or dco < 0 or NaN (what mark_paper() and simplify_paper() check).
void check_paper_options(const PaperSimplifyOptions& options);

/// What the search pass decided for one vertex.
enum class VertexMark : uint8_t { Kept, Coplanar, Colinear };

/// The search pass alone: one mark per vertex of `mesh` (see the top of this header).
/// Throws ArgumentError for dz or dco < 0 or NaN. Does not check that the mesh is 2.5D.
std::vector<VertexMark> mark_paper(const Mesh& mesh, const PaperSimplifyOptions& options);

struct PaperSimplifyResult {
  Mesh mesh;  ///< survivors in their input order, re-triangulated
  size_t removed_coplanar = 0, removed_colinear = 0;
  size_t restored_colinear = 0;  ///< marked co-linear, put back because Delaunay lost their line
  double seconds_search = 0, seconds_triangulate = 0;
};

/// mark_paper(), removal of every marked vertex, constrained Delaunay re-triangulation.
PaperSimplifyResult simplify_paper(const Mesh& mesh, const PaperSimplifyOptions& options,
                                   const Progress& progress = {});

// ---- the bounded mode (beyond the paper) ------------------------------------------------

struct BoundedSimplifyOptions {
  double max_error = 0.4;     ///< E: certified bound on |mesh - dsm|, vertical units, 0.001 to 10000
  bool conservative = false;  ///< 0 <= mesh - dsm <= E instead of |mesh - dsm| <= E
  bool delaunay = false;      ///< one global Delaunay triangulation (single-threaded)
  int tile_size = 0;          ///< cells per tile side; 0 = automatic, 24 (ignored with delaunay)
  int block_tiles = 0;        ///< tiles per block side (the unit read and farmed out); 0 = 42
  int threads = 0;            ///< 0 = every core
};

/// Throws ArgumentError for max_error outside 0.001 to 10000, or tile_size < 0 (what
/// simplify_bounded() checks of its options).
void check_bounded_options(const BoundedSimplifyOptions& options);

/// Greedy-insertion mesh of `dsm` within the bound (see the top of this header). Vertices are
/// cell centres (CRS coordinates); triangles counter-clockwise from above. Throws
/// ArgumentError for a bad max_error, tile_size < 0, a grid with fewer than 2x2 cells or none
/// valid. The result does not depend on `threads`.
Mesh simplify_bounded(const Grid& dsm, const BoundedSimplifyOptions& options, const Progress& progress = {});

struct VerticalError {
  double max_above = 0;  ///< max(0, max over cells of mesh - dsm)
  double max_below = 0;  ///< max(0, max over cells of dsm - mesh)
  double rms = 0;        ///< root mean square of mesh - dsm over the covered cells
  size_t cells = 0;      ///< valid cells whose centre the mesh covers (the ones measured)
  size_t uncovered = 0;  ///< valid cells whose centre no triangle covers

  /// Adds the figures of other cells (disjoint from these).
  void merge(const VerticalError& other);
};

// ---- the certified error ------------------------------------------------------------------

/// Vertical deviation of `mesh` from `dsm` at every valid cell centre (see the top). Both must
/// be in the same CRS. O(cells + triangles).
VerticalError certify(const Mesh& mesh, const Grid& dsm, const Progress& progress = {});

/// How a mesh lies against the DSM taken as solid columns (each valid cell a box over its
/// whole square, up to its height), the reading columns.hpp's guarantees are stated in.
struct ColumnError {
  /// The most any column rises above the mesh, anywhere over its square (0: the mesh encloses
  /// every column it covers). Exact: see src/simplify/certify_columns.cpp.
  double max_below = 0;
  /// Corners of valid cells that no triangle covers: those columns are not enclosed at all.
  size_t uncovered_corners = 0;
};

/// Measures `mesh` against the columns of `dsm` (same CRS): at every cell corner, wherever an
/// edge of the mesh crosses a cell's border, and at every vertex, which is where mesh minus
/// column height is least. A mesh made by simplify_bounded() of column_envelope(dsm) with
/// conservative on is at or above every corner; this says whether it is above every column
/// everywhere (max_below 0) or by how much it is not. O(cells + triangles x edge length in cells).
ColumnError certify_columns(const Mesh& mesh, const Grid& dsm, const Progress& progress = {});

/// Throws InputError(file, place, problem) unless `mesh` is 2.5D: every index in range, every
/// triangle counter-clockwise from above with positive area, no two vertices at the same x,y,
/// every edge in at most two triangles, in opposite directions (the surface does not fold).
void check_2_5d(const Mesh& mesh, const std::string& file);

}  // namespace dsmplan
