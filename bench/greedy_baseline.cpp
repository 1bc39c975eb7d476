// Greedy insertion as in Garland & Heckbert, CMU-CS-95-181 (1995), algorithm III: a Delaunay
// triangulation of the inserted points, each triangle's worst cell as its candidate, a max-heap
// of candidates, insert the top, rescan the triangles the insertion created. See the header.
//
// The triangulation works in lattice coordinates (col, row): every coordinate is a small whole
// number, so CGAL's predicates, the inside test and the barycentric weights are exact, and a
// cell on a triangle's edge is counted in both triangles that share it (harmless: both carry the
// same interpolated height there). Lattice y grows southward, so triangles are flipped on output
// to be counter-clockwise in the CRS.
#include "greedy_baseline.hpp"

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>
#include <stdexcept>
#include <vector>

namespace bench {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<uint32_t, Kernel>;  // info: cell index
using Tds = CGAL::Triangulation_data_structure_2<VertexBase>;
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel, Tds>;
using VertexHandle = Delaunay::Vertex_handle;

// A face is named by its three vertices rather than its handle: vertices are never removed, so
// a stale entry is recognised with is_face() without touching a face CGAL may have freed.
struct Candidate {
  double error;
  uint32_t cell;
  VertexHandle a, b, c;
  bool operator<(const Candidate& other) const { return error < other.error; }
};

struct Worst {
  double error = -1;
  uint32_t cell = 0;
};

// The valid cell with the largest |mesh - dsm| inside triangle (a, b, c), edges included.
Worst worst_cell(const dsmplan::Grid& dsm, VertexHandle a, VertexHandle b, VertexHandle c) {
  const double u[3] = {a->point().x(), b->point().x(), c->point().x()};
  const double v[3] = {a->point().y(), b->point().y(), c->point().y()};
  const double z[3] = {dsm.z[a->info()], dsm.z[b->info()], dsm.z[c->info()]};
  const double du1 = u[1] - u[0], dv1 = v[1] - v[0], du2 = u[2] - u[0], dv2 = v[2] - v[0];
  const double area2 = du1 * dv2 - du2 * dv1;  // > 0: CGAL's faces are counter-clockwise
  Worst worst;
  if (!(area2 > 0)) return worst;
  // The plane through the three vertices as z0 + pu * slope_u + pv * slope_v.
  const double slope_u = (dv2 * (z[1] - z[0]) - dv1 * (z[2] - z[0])) / area2;
  const double slope_v = (du1 * (z[2] - z[0]) - du2 * (z[1] - z[0])) / area2;
  const int row_begin = static_cast<int>(std::min({v[0], v[1], v[2]}));
  const int row_end = static_cast<int>(std::max({v[0], v[1], v[2]}));
  for (int row = row_begin; row <= row_end; ++row) {
    // The row's span from the edges it crosses; rounded outwards, then every cell is tested
    // exactly, so the span's rounding cannot lose a cell.
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (int k = 0; k < 3; ++k) {
      const int m = (k + 1) % 3;
      if ((row < v[k] && row < v[m]) || (row > v[k] && row > v[m])) continue;
      if (v[k] == v[m]) {
        lo = std::min({lo, u[k], u[m]});
        hi = std::max({hi, u[k], u[m]});
      } else {
        const double at = u[k] + (row - v[k]) * (u[m] - u[k]) / (v[m] - v[k]);
        lo = std::min(lo, at);
        hi = std::max(hi, at);
      }
    }
    if (lo > hi) continue;
    const int col_begin = std::max(0, static_cast<int>(std::floor(lo))),
              col_end = std::min(dsm.width - 1, static_cast<int>(std::ceil(hi)));
    const double pv = row - v[0];
    const float* heights = &dsm.z[dsm.index(0, row)];
    for (int col = col_begin; col <= col_end; ++col) {
      const double pu = col - u[0];
      const double w1 = pu * dv2 - du2 * pv, w2 = du1 * pv - pu * dv1;
      if (w1 < 0 || w2 < 0 || w1 + w2 > area2) continue;
      // NaN (nodata) compares false and is skipped.
      const double error = std::abs(z[0] + pu * slope_u + pv * slope_v - heights[col]);
      if (error > worst.error) worst = {error, static_cast<uint32_t>(dsm.index(col, row))};
    }
  }
  return worst;
}

}  // namespace

GreedyBaselineResult greedy_insertion_baseline(const dsmplan::Grid& dsm, double max_error) {
  if (!(max_error > 0) || !std::isfinite(max_error)) throw std::invalid_argument("max_error must be > 0");
  if (dsm.width < 2 || dsm.height < 2) throw std::invalid_argument("the grid needs at least 2 x 2 cells");
  GreedyBaselineResult result;
  Delaunay dt;
  auto insert = [&](int col, int row, Delaunay::Face_handle hint) {
    const size_t before = dt.number_of_vertices();
    const VertexHandle v = dt.insert(Delaunay::Point(col, row), hint);
    // A vertex's own cell interpolates to its height, so it is never a candidate again; if it
    // were, the loop would not end.
    if (dt.number_of_vertices() == before) throw std::logic_error("greedy baseline: cell inserted twice");
    v->info() = static_cast<uint32_t>(dsm.index(col, row));
    return v;
  };
  for (const auto& [col, row] :
       {std::pair{0, 0}, {dsm.width - 1, 0}, {0, dsm.height - 1}, {dsm.width - 1, dsm.height - 1}}) {
    if (!dsm.valid(col, row)) throw std::invalid_argument("greedy baseline: a corner cell is nodata");
    insert(col, row, Delaunay::Face_handle());
  }

  std::priority_queue<Candidate> heap;
  auto consider = [&](Delaunay::Face_handle f) {
    const Worst worst = worst_cell(dsm, f->vertex(0), f->vertex(1), f->vertex(2));
    if (worst.error <= max_error) return;
    heap.push({worst.error, worst.cell, f->vertex(0), f->vertex(1), f->vertex(2)});
    ++result.candidates;
  };
  for (auto f = dt.finite_faces_begin(); f != dt.finite_faces_end(); ++f) consider(f);

  while (!heap.empty()) {
    const Candidate top = heap.top();
    heap.pop();
    Delaunay::Face_handle face;
    if (!dt.is_face(top.a, top.b, top.c, face)) {
      ++result.stale;
      continue;
    }
    const int col = static_cast<int>(top.cell % dsm.width), row = static_cast<int>(top.cell / dsm.width);
    const VertexHandle v = insert(col, row, face);
    // Delaunay insertion replaces exactly the faces around the new vertex.
    Delaunay::Face_circulator around = dt.incident_faces(v), done = around;
    do {
      if (!dt.is_infinite(around)) consider(around);
    } while (++around != done);
  }

  dsmplan::Mesh& mesh = result.mesh;
  mesh.crs = dsm.crs;
  std::vector<uint32_t> index_of_cell(dsm.cells(), 0);
  mesh.vertices.reserve(dt.number_of_vertices());
  for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v) {
    const int col = static_cast<int>(v->info() % dsm.width), row = static_cast<int>(v->info() / dsm.width);
    index_of_cell[v->info()] = static_cast<uint32_t>(mesh.vertices.size());
    mesh.vertices.push_back({dsm.center_x(col), dsm.center_y(row), dsm.z[v->info()]});
  }
  mesh.triangles.reserve(dt.number_of_faces());
  for (auto f = dt.finite_faces_begin(); f != dt.finite_faces_end(); ++f) {
    // Counter-clockwise with rows growing south is clockwise in x, y: swap two corners.
    mesh.triangles.push_back({index_of_cell[f->vertex(0)->info()], index_of_cell[f->vertex(2)->info()],
                              index_of_cell[f->vertex(1)->info()]});
  }
  return result;
}

}  // namespace bench
