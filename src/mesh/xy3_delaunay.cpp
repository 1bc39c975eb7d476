// XY-3 Delaunay triangulation of a DSM grid: Adolf & Hirschmueller, Section 3 (after Boissonnat
// et al., CGAL's Projection_traits_xy_3): Delaunay on x,y, z carried along.
//
// Why not hand every point to a Delaunay library: on a grid the triangulation is known. Each
// square of four valid cell centres is cocircular with an empty circle (no lattice point lies
// strictly inside the circle through a rectangle's corners), so it is a face of the Delaunay
// subdivision. Any other face has an empty circle too; if one of its vertices had all eight
// neighbours valid, the four squares around that vertex would cover a neighbourhood of it and
// leave no room for the face. So all other faces have only "border" vertices (a nodata
// 8-neighbour), and they are faces of the Delaunay triangulation of the border vertices alone:
// their circle is empty of all points, hence of border points. That smaller triangulation also
// fills the full squares between border vertices with triangles of its own; those are recognised
// by their centroid lying in (or, on a grid line, only next to) full squares, and dropped.
#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/text.hpp"
#include "dsmplan/mesh.hpp"

namespace dsmplan {

namespace {

constexpr uint32_t no_vertex = std::numeric_limits<uint32_t>::max();

// Reserved but untouched vector storage may be backed by 2 MiB pages: a million-cell mesh then
// takes a few dozen page faults instead of tens of thousands, which halves meshing time.
template <typename T>
void prefer_huge_pages(const std::vector<T>& storage) {
#ifdef MADV_HUGEPAGE
  constexpr uintptr_t huge = uintptr_t{2} << 20;
  const auto begin = (reinterpret_cast<uintptr_t>(storage.data()) + huge - 1) & ~(huge - 1);
  const auto end = (reinterpret_cast<uintptr_t>(storage.data() + storage.capacity())) & ~(huge - 1);
  if (end > begin) ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)storage;
#endif
}

struct Lattice {
  const Grid& grid;
  std::vector<uint32_t> id;  // vertex index per cell, no_vertex for nodata

  bool valid(int col, int row) const {
    return col >= 0 && row >= 0 && col < grid.width && row < grid.height && id[grid.index(col, row)] != no_vertex;
  }
  // The square with corners (col,row) .. (col+1,row+1) has four valid corners.
  bool full_square(int col, int row) const {
    return valid(col, row) && valid(col + 1, row) && valid(col, row + 1) && valid(col + 1, row + 1);
  }
};

// Squares touching the coordinate sum/3 (sum >= 0) along one axis: one when it lies inside a
// square, the two on either side when it lies on a grid line.
std::pair<int, int> squares_touching(int sum) {
  return sum % 3 == 0 ? std::pair{sum / 3 - 1, sum / 3} : std::pair{sum / 3, sum / 3};
}

// True when the triangle with these lattice corners lies in full squares, i.e. all squares
// touching its centroid are full (its centroid is interior, so a face elsewhere cannot touch it).
bool inside_full_squares(const Lattice& lattice, const int cols[3], const int rows[3]) {
  const auto [c0, c1] = squares_touching(cols[0] + cols[1] + cols[2]);
  const auto [r0, r1] = squares_touching(rows[0] + rows[1] + rows[2]);
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      if (!lattice.full_square(c, r)) return false;
    }
  }
  return true;
}

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<uint32_t, Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase>;
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel, Tds>;

// Cocircular border vertices (a hole's rim is full of them: the four edge neighbours of a
// missing cell) leave the Delaunay triangulation open, and CGAL's choice may depend on the
// insertion order, hence on every other point. A window of the grid (the out-of-core mode) must
// choose as the whole grid does, so ties are broken by Simulation of Simplicity (Edelsbrunner &
// Muecke 1990): each point is lifted by an infinitesimal that grows with its cell's row-major
// index, which makes the triangulation the unique regular one of those lifts. In the 4x4
// in-circle determinant (rows a, b, c, d; columns x, y, x^2 + y^2, 1), positive when d lies
// inside the circle of the counter-clockwise a, b, c, the lift of the point in row i adds its
// cofactor, (-1)^(i+3) times the orientation of the other three; the largest lift decides. Four
// distinct cocircular points have no three on a line, so that orientation is never zero.
bool inside_perturbed(const Kernel::Point_2* p, const size_t* key) {
  const CGAL::Oriented_side side = CGAL::side_of_oriented_circle(p[0], p[1], p[2], p[3]);
  if (side != CGAL::ON_ORIENTED_BOUNDARY) return side == CGAL::ON_POSITIVE_SIDE;
  const int top = static_cast<int>(std::max_element(key, key + 4) - key);
  Kernel::Point_2 others[3];
  for (int i = 0, k = 0; i < 4; ++i)
    if (i != top) others[k++] = p[i];
  const int orientation = static_cast<int>(CGAL::orientation(others[0], others[1], others[2]));
  return (top % 2 == 0 ? orientation : -orientation) > 0;  // (-1)^(i+3), row i = top + 1
}

// Lawson flips of the edges that are cocircular ties until every edge is Delaunay under the
// perturbation above. The rest of the triangulation is strictly Delaunay already.
template <typename Key>
void break_ties(Delaunay& delaunay, const Key& key_of) {
  std::vector<std::pair<Delaunay::Face_handle, int>> stack;
  for (auto edge = delaunay.finite_edges_begin(); edge != delaunay.finite_edges_end(); ++edge)
    stack.emplace_back(edge->first, edge->second);
  while (!stack.empty()) {
    auto [face, i] = stack.back();
    stack.pop_back();
    const auto neighbour = face->neighbor(i);
    if (delaunay.is_infinite(face) || delaunay.is_infinite(neighbour)) continue;
    const auto opposite = neighbour->vertex(neighbour->index(face));
    const Kernel::Point_2 p[4] = {face->vertex(0)->point(), face->vertex(1)->point(), face->vertex(2)->point(),
                                  opposite->point()};
    if (CGAL::side_of_oriented_circle(p[0], p[1], p[2], p[3]) != CGAL::ON_ORIENTED_BOUNDARY) continue;
    const size_t key[4] = {key_of(face->vertex(0)), key_of(face->vertex(1)), key_of(face->vertex(2)), key_of(opposite)};
    if (!inside_perturbed(p, key)) continue;

    delaunay.flip(face, i);
    // The four edges around the flipped pair may now be ties to break.
    for (auto f : {face, neighbour})
      for (int k = 0; k < 3; ++k) stack.emplace_back(f, k);
  }
}

// Delaunay faces next to holes, from CGAL's exact-predicate triangulation of the border vertices.
void triangulate_border(const Lattice& lattice, std::vector<Triangle>& triangles, const Progress& progress) {
  const Grid& grid = lattice.grid;
  // Border vertices: the valid 8-neighbours of nodata cells.
  std::vector<bool> is_border(grid.cells(), false);
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      if (lattice.valid(col, row)) continue;
      for (int r = row - 1; r <= row + 1; ++r)
        for (int c = col - 1; c <= col + 1; ++c)
          if (lattice.valid(c, r)) is_border[grid.index(c, r)] = true;
    }
  }
  // Lattice coordinates (col, -row * cell_y/cell_x): whole numbers for square cells of any size,
  // so a cocircular square stays exactly cocircular, and oriented like the CRS (x east, y north),
  // so CGAL's counter-clockwise is ours.
  const double aspect = grid.cell_y / grid.cell_x;
  std::vector<std::pair<Kernel::Point_2, uint32_t>> border;
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      if (is_border[grid.index(col, row)]) {
        border.emplace_back(Kernel::Point_2(col, -row * aspect), lattice.id[grid.index(col, row)]);
      }
    }
  }
  report(progress, 0.2);
  if (border.size() < 3) return;
  Delaunay delaunay(border.begin(), border.end());
  if (delaunay.dimension() < 2) return;  // collinear cells (one row, one column, a diagonal): no triangle
  // Row-major cell index, from the rounded lattice coordinates: a window of whole rows orders
  // its cells as the whole grid does.
  break_ties(delaunay, [&](Delaunay::Vertex_handle v) {
    const long col = std::lround(v->point().x()), row = std::lround(-v->point().y() / aspect);
    return static_cast<size_t>(row) * static_cast<size_t>(grid.width) + static_cast<size_t>(col);
  });
  report(progress, 0.8);
  for (auto face = delaunay.finite_faces_begin(); face != delaunay.finite_faces_end(); ++face) {
    Triangle triangle;
    int cols[3], rows[3];
    for (int k = 0; k < 3; ++k) {
      const auto& point = face->vertex(k)->point();
      cols[k] = static_cast<int>(std::lround(point.x()));
      rows[k] = static_cast<int>(std::lround(-point.y() / aspect));
      triangle[k] = face->vertex(k)->info();
    }
    if (!inside_full_squares(lattice, cols, rows)) triangles.push_back(triangle);
  }
}

}  // namespace

double max_edge_length(const Grid& grid, const MeshOptions& options) {
  if (!(options.max_edge_length >= 0 && (options.max_edge_length <= 1e6 || options.max_edge_length == INFINITY))) {
    throw ArgumentError("max_edge", "must be from 0 (2.5 cells) to 1e6, or inf (keep every triangle), got " +
                                        short_number(options.max_edge_length));
  }
  return options.max_edge_length > 0 ? options.max_edge_length : 2.5 * std::max(grid.cell_x, grid.cell_y);
}

Mesh triangulate_xy3(const Grid& grid, const MeshOptions& options, const Progress& progress) {
  check_grid(grid);
  const double max_edge = max_edge_length(grid, options);
  const HeightQuantizer quantize(options.zstep);
  const size_t valid =
      grid.cells() - std::count_if(grid.z.begin(), grid.z.end(), [](float z) { return std::isnan(z); });
  if (valid >= no_vertex) throw ArgumentError("grid", "too many valid cells for 32-bit vertex indices");
  Mesh mesh;
  mesh.crs = grid.crs;
  mesh.vertices.reserve(valid);
  prefer_huge_pages(mesh.vertices);
  Lattice lattice{grid, {}};
  lattice.id.reserve(grid.cells());
  prefer_huge_pages(lattice.id);
  lattice.id.assign(grid.cells(), no_vertex);
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      const float z = grid.at(col, row);
      if (std::isnan(z)) continue;
      lattice.id[grid.index(col, row)] = static_cast<uint32_t>(mesh.vertices.size());
      mesh.vertices.push_back({grid.center_x(col), grid.center_y(row), quantize(z)});
    }
  }
  report(progress, 0.2);

  // Full squares: split along the diagonal with the higher midpoint, the upper of the two
  // interpolations, so the surface never sags below what the other diagonal would give.
  // Reserving for every square costs address space, not memory: untouched pages stay unmapped.
  const bool squares_fit = std::hypot(grid.cell_x, grid.cell_y) <= max_edge;
  const size_t squares = grid.width > 1 && grid.height > 1 ? size_t(grid.width - 1) * size_t(grid.height - 1) : 0;
  mesh.triangles.reserve(squares_fit ? 2 * squares : 0);
  prefer_huge_pages(mesh.triangles);
  for (int row = 0; squares_fit && row + 1 < grid.height; ++row) {
    const uint32_t* north = &lattice.id[grid.index(0, row)];
    const uint32_t* south = north + grid.width;
    for (int col = 0; col + 1 < grid.width; ++col) {
      // a (col,row)  b (col+1,row)  c (col+1,row+1)  d (col,row+1); rows run south.
      const uint32_t a = north[col], b = north[col + 1], c = south[col + 1], d = south[col];
      if (a == no_vertex || b == no_vertex || c == no_vertex || d == no_vertex) continue;
      const auto& v = mesh.vertices;
      if (v[a].z + v[c].z >= v[b].z + v[d].z) {
        mesh.triangles.push_back({a, d, c});
        mesh.triangles.push_back({a, c, b});
      } else {
        mesh.triangles.push_back({a, d, b});
        mesh.triangles.push_back({b, d, c});
      }
    }
    if (row % 256 == 0) report(progress, 0.2 + 0.3 * row / grid.height);
  }
  report(progress, 0.5);
  if (valid == grid.cells()) {
    report(progress, 1);
    return mesh;  // no holes: the squares are the whole triangulation
  }

  const size_t square_triangles = mesh.triangles.size();
  triangulate_border(lattice, mesh.triangles, sub_progress(progress, 0.5, 0.95));

  // Holes and concave outlines are not bridged: drop border triangles with a long edge.
  auto too_long = [&](const Triangle& t) {
    for (int k = 0; k < 3; ++k) {
      const Vertex& p = mesh.vertices[t[k]];
      const Vertex& q = mesh.vertices[t[(k + 1) % 3]];
      if (std::hypot(p.x - q.x, p.y - q.y) > max_edge) return true;
    }
    return false;
  };
  auto kept_end = std::remove_if(mesh.triangles.begin() + square_triangles, mesh.triangles.end(), too_long);
  mesh.triangles.erase(kept_end, mesh.triangles.end());
  report(progress, 1);
  return mesh;
}

}  // namespace dsmplan
