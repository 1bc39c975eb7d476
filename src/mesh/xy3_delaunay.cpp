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

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "dsmplan/mesh.hpp"

namespace dsmplan {

namespace {

constexpr uint32_t no_vertex = std::numeric_limits<uint32_t>::max();

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
  bool border(int col, int row) const {
    for (int r = row - 1; r <= row + 1; ++r) {
      for (int c = col - 1; c <= col + 1; ++c) {
        const bool inside = c >= 0 && r >= 0 && c < grid.width && r < grid.height;
        if (inside && !valid(c, r)) return true;
      }
    }
    return false;
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

// Delaunay faces next to holes, from CGAL's exact-predicate triangulation of the border vertices.
void triangulate_border(const Lattice& lattice, std::vector<Triangle>& triangles, const Progress& progress) {
  const Grid& grid = lattice.grid;
  std::vector<std::pair<Kernel::Point_2, uint32_t>> border;
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      // Lattice coordinates (col, -row) scaled by the cell size: exact for the usual cell sizes,
      // and oriented like the CRS (x east, y north), so CGAL's counter-clockwise is ours.
      if (lattice.valid(col, row) && lattice.border(col, row)) {
        border.emplace_back(Kernel::Point_2(col * grid.cell_x, -row * grid.cell_y), lattice.id[grid.index(col, row)]);
      }
    }
  }
  report(progress, 0.2);
  if (border.size() < 3) return;
  Delaunay delaunay(border.begin(), border.end());
  report(progress, 0.8);
  for (auto face = delaunay.finite_faces_begin(); face != delaunay.finite_faces_end(); ++face) {
    Triangle triangle;
    int cols[3], rows[3];
    for (int k = 0; k < 3; ++k) {
      const auto& point = face->vertex(k)->point();
      cols[k] = static_cast<int>(std::lround(point.x() / grid.cell_x));
      rows[k] = static_cast<int>(std::lround(-point.y() / grid.cell_y));
      triangle[k] = face->vertex(k)->info();
    }
    if (!inside_full_squares(lattice, cols, rows)) triangles.push_back(triangle);
  }
}

}  // namespace

double max_edge_length(const Grid& grid, const MeshOptions& options) {
  if (std::isnan(options.max_edge_length) || options.max_edge_length < 0) {
    throw ArgumentError("--max-edge", "must be >= 0 (0 = 2.5 cells), got " + std::to_string(options.max_edge_length));
  }
  return options.max_edge_length > 0 ? options.max_edge_length : 2.5 * std::max(grid.cell_x, grid.cell_y);
}

Mesh triangulate_xy3(const Grid& grid, const MeshOptions& options, const Progress& progress) {
  const double max_edge = max_edge_length(grid, options);
  Mesh mesh;
  mesh.crs = grid.crs;
  Lattice lattice{grid, std::vector<uint32_t>(grid.cells(), no_vertex)};
  mesh.vertices.reserve(grid.cells() - std::count_if(grid.z.begin(), grid.z.end(), [](float z) { return std::isnan(z); }));

  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      const float z = grid.at(col, row);
      if (std::isnan(z)) continue;
      if (mesh.vertices.size() == no_vertex) throw ArgumentError("grid", "too many valid cells for 32-bit vertex indices");
      lattice.id[grid.index(col, row)] = static_cast<uint32_t>(mesh.vertices.size());
      mesh.vertices.push_back({grid.center_x(col), grid.center_y(row), quantize_height(z, options.zstep)});
    }
  }
  report(progress, 0.2);

  // Full squares: split along the diagonal with the higher midpoint, the upper of the two
  // interpolations, so the surface never sags below what the other diagonal would give.
  const bool squares_fit = std::hypot(grid.cell_x, grid.cell_y) <= max_edge;
  size_t full_squares = 0;
  for (int row = 0; squares_fit && row + 1 < grid.height; ++row) {
    for (int col = 0; col + 1 < grid.width; ++col) full_squares += lattice.full_square(col, row);
  }
  mesh.triangles.reserve(2 * full_squares);
  for (int row = 0; full_squares && row + 1 < grid.height; ++row) {
    for (int col = 0; col + 1 < grid.width; ++col) {
      if (!lattice.full_square(col, row)) continue;
      // a (col,row)  b (col+1,row)  c (col+1,row+1)  d (col,row+1); rows run south.
      const uint32_t a = lattice.id[grid.index(col, row)], b = lattice.id[grid.index(col + 1, row)];
      const uint32_t c = lattice.id[grid.index(col + 1, row + 1)], d = lattice.id[grid.index(col, row + 1)];
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
