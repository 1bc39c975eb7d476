// How far the DSM's columns (each valid cell a box over its whole square, up to its height)
// rise above a mesh, exactly, with no sampling. Over a cell the mesh is piecewise linear and
// has no vertex it does not show, so mesh - (cell height) is smallest at a vertex of the
// arrangement of the mesh's edges and the cell's square: a corner of the square, a point where
// a mesh edge crosses the square's border, or a mesh vertex in the square. Each of those is
// measured against the highest cell it touches (the columns are closed boxes):
//   - corners: certify() against column_envelope(), whose "cells" are the corners;
//   - crossings: every triangle edge walked across the lattice lines, against the two cells
//     on either side of the line where it crosses;
//   - vertices: against the one, two or four cells whose closed square holds them.
// A mesh that lies on or above every column everywhere has max_below 0: a clearance measured
// on it is then a lower bound of the clearance to the columns (columns.hpp).
#include <algorithm>
#include <cmath>

#include "dsmplan/simplify.hpp"

namespace dsmplan {

namespace {

// The highest valid cell among columns [c0, c1] x [r0, r1] (clipped to the grid); -inf if none.
double highest_cell(const Grid& dsm, int c0, int c1, int r0, int r1) {
  double top = -INFINITY;
  for (int r = std::max(r0, 0); r <= std::min(r1, dsm.height - 1); ++r)
    for (int c = std::max(c0, 0); c <= std::min(c1, dsm.width - 1); ++c) {
      const float z = dsm.at(c, r);
      if (!std::isnan(z)) top = std::max<double>(top, z);
    }
  return top;
}

}  // namespace

ColumnError certify_columns(const Mesh& mesh, const Grid& dsm, const Progress& progress) {
  ColumnError error;
  const Grid corners = column_envelope(dsm);
  const VerticalError at_corners = certify(mesh, corners, sub_progress(progress, 0, 0.6));
  error.max_below = at_corners.max_below;
  error.uncovered_corners = at_corners.uncovered;
  if (mesh.triangles.empty() || dsm.cells() == 0) return error;

  // Lattice coordinates: cell (c, r) covers u in [c, c + 1], v in [r, r + 1].
  auto u_of = [&](const Vertex& p) { return (p.x - dsm.x0) / dsm.cell_x; };
  auto v_of = [&](const Vertex& p) { return (dsm.y0 - p.y) / dsm.cell_y; };
  double worst = error.max_below;
  auto measure = [&](double columns_top, double mesh_z) {
    if (columns_top > -INFINITY) worst = std::max(worst, columns_top - mesh_z);
  };
  // The cells whose closed span along one axis holds coordinate s: floor(s), and s - 1 too
  // when s is a whole number (on the line between two cells).
  auto span = [](double s, int& lo, int& hi) {
    hi = static_cast<int>(std::floor(s));
    lo = s == std::floor(s) ? hi - 1 : hi;
  };
  std::vector<uint8_t> used(mesh.vertices.size(), 0);
  const size_t triangles = mesh.triangles.size();
  for (size_t t = 0; t < triangles; ++t) {
    const Triangle& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      used[tri[k]] = 1;
      const Vertex &a = mesh.vertices[tri[k]], &b = mesh.vertices[tri[(k + 1) % 3]];
      const double ua = u_of(a), va = v_of(a), ub = u_of(b), vb = v_of(b);
      if (!(std::abs(ub - ua) < 1e9 && std::abs(vb - va) < 1e9)) continue;  // no finite walk: left to the corners
      // Crossings of the vertical lattice lines u = i (cells i - 1 and i on either side) ...
      if (ua != ub)
        for (double i = std::ceil(std::min(ua, ub)); i <= std::floor(std::max(ua, ub)); ++i) {
          const double s = (i - ua) / (ub - ua), v = va + s * (vb - va);
          int r0, r1;
          span(v, r0, r1);
          const int col = static_cast<int>(i);
          measure(highest_cell(dsm, col - 1, col, r0, r1), a.z + s * (b.z - a.z));
        }
      // ... and of the horizontal ones v = j (rows j - 1 and j).
      if (va != vb)
        for (double j = std::ceil(std::min(va, vb)); j <= std::floor(std::max(va, vb)); ++j) {
          const double s = (j - va) / (vb - va), u = ua + s * (ub - ua);
          int c0, c1;
          span(u, c0, c1);
          const int row = static_cast<int>(j);
          measure(highest_cell(dsm, c0, c1, row - 1, row), a.z + s * (b.z - a.z));
        }
    }
    if (t % 65536 == 0) report(progress, 0.6 + 0.35 * static_cast<double>(t) / static_cast<double>(triangles));
  }
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (!used[i]) continue;
    const Vertex& p = mesh.vertices[i];
    const double u = u_of(p), v = v_of(p);
    if (!(std::abs(u) < 1e9 && std::abs(v) < 1e9)) continue;
    int c0, c1, r0, r1;
    span(u, c0, c1);
    span(v, r0, r1);
    measure(highest_cell(dsm, c0, c1, r0, r1), p.z);
  }
  error.max_below = std::max(0.0, worst);
  report(progress, 1);
  return error;
}

}  // namespace dsmplan
