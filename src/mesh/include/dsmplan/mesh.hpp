// dsmplan/mesh.hpp: stage 2, the XY-3 Delaunay mesh of a DSM.
//
// The paper (Adolf & Hirschmueller, Section 3) meshes every DSM cell centre as a 3D point with a
// 2D Delaunay triangulation of the x,y projection, z carried along ("XY-3", CGAL's
// Projection_traits_xy_3). triangulate_xy3() computes exactly that triangulation, up to the
// choice inside cocircular faces (every unit square of a grid is one), in O(cells):
//   - a square whose four corners are valid is a Delaunay face on its own: it is split along
//     the diagonal whose midpoint is higher, so the surface is the upper (conservative) of the
//     two possible interpolations;
//   - every other Delaunay face has all its vertices next to a hole; those vertices alone are
//     triangulated with CGAL's exact-predicate Delaunay_triangulation_2 and the triangles that
//     lie in full squares are dropped.
// Then triangles with an x,y edge longer than max_edge_length are dropped, so holes (nodata)
// and concave outlines are not bridged by long triangles.
//
// Guarantees (tests/mesh_test.cpp checks each on real data):
//   - one vertex per valid cell, in row-major order, at the cell centre, with
//     z = quantize_height(height, zstep) exactly; nodata cells have no vertex;
//   - triangles are counter-clockwise seen from above (+z), none degenerate;
//   - every triangle has an empty circumcircle in x,y among all vertices (exact predicates);
//   - with max_edge_length = infinity the triangles tile the convex hull of the vertices, so
//     every valid cell centre is covered; with a limit, exactly the triangles with a longer edge
//     are missing, and no nodata cell farther than the limit from data is covered. A lone
//     valid cell inside a wide hole then keeps its vertex but has no triangle (78 of 214,455
//     on the Delft data at 0.5 m).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

struct Vertex {
  double x, y, z;  ///< CRS coordinates (doubles: UTM northings do not fit float32 at cm precision)
};

using Triangle = std::array<uint32_t, 3>;  ///< vertex indices, counter-clockwise from above

struct Mesh {
  std::vector<Vertex> vertices;
  std::vector<Triangle> triangles;
  Crs crs;
};

/// Receives a mesh block by block, in order (simplify_bounded() streams out of core into one):
/// each call brings the block's new vertices, numbered on from all earlier ones, and its
/// triangles, which may use any vertex delivered so far.
class MeshSink {
public:
  virtual ~MeshSink() = default;
  virtual void append(const std::vector<Vertex>& vertices, const std::vector<Triangle>& triangles) = 0;
};

/// Collects the blocks into one Mesh.
class MeshCollector : public MeshSink {
public:
  explicit MeshCollector(Mesh& mesh) : mesh_(mesh) {}
  void append(const std::vector<Vertex>& vertices, const std::vector<Triangle>& triangles) override;

private:
  Mesh& mesh_;
};

struct MeshOptions {
  double zstep = 0.1;  ///< vertical resolution: heights are quantized to multiples of it (<= 0: keep; else 1e-6 to 100,
                       ///< else ArgumentError)
  /// Longest x,y edge a triangle may have, in CRS units. 0 means 2.5 times the larger cell size,
  /// which bridges a single missing cell (edges of 2 cells) and leaves wider gaps open.
  /// Use infinity to keep the whole Delaunay triangulation.
  double max_edge_length = 0;  ///< CRS units, 0 to 1e6 (0: 2.5 cells), or infinity: keep every triangle
  int band_rows = 0;           ///< out of core: rows a band (0: 256)
};

/// The longest edge allowed for `grid` under `options` (resolves the 0 default).
double max_edge_length(const Grid& grid, const MeshOptions& options);

/// XY-3 Delaunay mesh of the valid cells of `grid` (see the top of this header).
/// An all-nodata grid gives an empty mesh. Throws ArgumentError when max_edge_length < 0 or NaN,
/// or the grid has 2^32 or more valid cells. Time O(cells + h log h), h = cells next to holes.
Mesh triangulate_xy3(const Grid& grid, const MeshOptions& options = {}, const Progress& progress = {});

// Out of core: the same mesh from a GridSource, band by band (band_rows rows at a time, each
// read with a halo of rows above and below), into a MeshSink. Every triangle the whole grid's
// mesh has is made by exactly one band (the one holding its topmost vertex), from a window
// that holds every point its circumcircle could contain: with edges of at most L (max_edge)
// between lattice points, a kept triangle's circumradius is at most L^3 / (2 cell_x cell_y), and
// the halo is L plus twice that, in rows. Cocircular ties are broken by a rule that looks at the
// points alone (see xy3_delaunay.cpp), so a window decides as the whole grid does. The result:
// the same vertices (row-major, bit for bit) and the same triangles as triangulate_xy3(), in
// another order. Needs a finite max_edge_length. Memory O(width x (band_rows + 2 halo)).

struct MeshStreamResult {
  size_t vertices = 0, triangles = 0, valid_cells = 0, bands = 0;
};

/// See above. Throws what triangulate_xy3() throws, ArgumentError for an infinite
/// max_edge_length, and ArgumentError("grid") for 2^32 or more valid cells.
MeshStreamResult triangulate_xy3(GridSource& dsm, MeshSink& sink, const MeshOptions& options = {},
                                 const Progress& progress = {});

}  // namespace dsmplan
