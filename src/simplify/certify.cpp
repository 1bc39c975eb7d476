// The certified error of a mesh against its DSM: every valid cell centre is located in the
// triangle above it and the mesh's height there is compared with the cell's. Triangles are
// scan-converted over the cell lattice, so the cost is O(cells + triangles), with no sampling.
#include <algorithm>
#include <cmath>
#include <vector>

#include "dsmplan/simplify.hpp"

namespace dsmplan {

namespace {

// A triangle's vertices in lattice units (cell centres at whole numbers; v grows southward).
struct LatticeTriangle {
  double u[3], v[3], z[3];
};

// Points on an edge computed from CRS coordinates miss it by rounding; this much (in lattice
// units, relative to the triangle's doubled area) is still "on the edge".
constexpr double on_edge_tolerance = 1e-9;

// A vertex this near a cell centre (in lattice units) is at it: the simplifiers put every vertex
// on a centre, and CRS coordinates far from the origin (1e6 m and more, with 0.1 m cells) miss it
// by rounding, which a steep triangle (a wall: 100 m over a cell) turns into micrometres of
// height at the next centre, enough for the reported error to understate the mesh's own.
constexpr double at_centre = 1e-6;

double snapped(double lattice) {
  const double centre = std::round(lattice);
  return std::abs(lattice - centre) <= at_centre ? centre : lattice;
}

}  // namespace

VerticalError certify(const Mesh& mesh, const Grid& dsm, const Progress& progress) {
  const size_t cells = dsm.cells();
  std::vector<double> mesh_z(cells, NAN);
  const double u0 = dsm.x0 + 0.5 * dsm.cell_x, v0 = dsm.y0 - 0.5 * dsm.cell_y;
  const size_t triangles = mesh.triangles.size();
  for (size_t t = 0; t < triangles; ++t) {
    LatticeTriangle tri;
    for (int k = 0; k < 3; ++k) {
      const Vertex& p = mesh.vertices[mesh.triangles[t][k]];
      tri.u[k] = snapped((p.x - u0) / dsm.cell_x);
      tri.v[k] = snapped((v0 - p.y) / dsm.cell_y);
      tri.z[k] = p.z;
    }
    // Barycentric weights from edge functions taken relative to vertex 0 (small numbers).
    const double du1 = tri.u[1] - tri.u[0], dv1 = tri.v[1] - tri.v[0];
    const double du2 = tri.u[2] - tri.u[0], dv2 = tri.v[2] - tri.v[0];
    const double area2 = du1 * dv2 - du2 * dv1;
    if (!(std::abs(area2) > 0)) continue;  // degenerate: covers no area, its edges belong to others
    const double tolerance = on_edge_tolerance * std::max(1.0, std::abs(area2));
    const int row_begin = std::max(0, static_cast<int>(std::ceil(std::min({tri.v[0], tri.v[1], tri.v[2]}) - 1e-6)));
    const int row_end =
        std::min(dsm.height - 1, static_cast<int>(std::floor(std::max({tri.v[0], tri.v[1], tri.v[2]}) + 1e-6)));
    const int col_begin = std::max(0, static_cast<int>(std::ceil(std::min({tri.u[0], tri.u[1], tri.u[2]}) - 1e-6)));
    const int col_end =
        std::min(dsm.width - 1, static_cast<int>(std::floor(std::max({tri.u[0], tri.u[1], tri.u[2]}) + 1e-6)));
    for (int row = row_begin; row <= row_end; ++row) {
      const double pv = row - tri.v[0];
      for (int col = col_begin; col <= col_end; ++col) {
        const double pu = col - tri.u[0];
        // Weights of vertices 1 and 2, scaled by area2; the sign of area2 is the orientation.
        const double w1 = (pu * dv2 - du2 * pv), w2 = (du1 * pv - pu * dv1);
        const double w0 = area2 - w1 - w2;
        const bool inside = area2 > 0 ? (w0 >= -tolerance && w1 >= -tolerance && w2 >= -tolerance)
                                      : (w0 <= tolerance && w1 <= tolerance && w2 <= tolerance);
        if (!inside) continue;
        const size_t cell = dsm.index(col, row);
        if (!std::isnan(mesh_z[cell])) continue;  // on a shared edge: the first triangle says it
        mesh_z[cell] = (w0 * tri.z[0] + w1 * tri.z[1] + w2 * tri.z[2]) / area2;
      }
    }
    if (t % 65536 == 0) report(progress, 0.9 * t / triangles);
  }

  VerticalError error;
  double sum_squares = 0;
  for (size_t cell = 0; cell < cells; ++cell) {
    const float height = dsm.z[cell];
    if (std::isnan(height)) continue;
    if (std::isnan(mesh_z[cell])) {
      ++error.uncovered;
      continue;
    }
    const double deviation = mesh_z[cell] - height;
    error.max_above = std::max(error.max_above, deviation);
    error.max_below = std::max(error.max_below, -deviation);
    sum_squares += deviation * deviation;
    ++error.cells;
  }
  error.rms = error.cells ? std::sqrt(sum_squares / error.cells) : 0;
  report(progress, 1);
  return error;
}

}  // namespace dsmplan

namespace dsmplan {

void VerticalError::merge(const VerticalError& other) {
  const double squares = rms * rms * double(cells) + other.rms * other.rms * double(other.cells);
  max_above = std::max(max_above, other.max_above);
  max_below = std::max(max_below, other.max_below);
  cells += other.cells;
  uncovered += other.uncovered;
  rms = cells ? std::sqrt(squares / double(cells)) : 0;
}

}  // namespace dsmplan
