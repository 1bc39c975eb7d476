// What it takes for a path planned on a mesh to keep its safety distance from the DSM's
// columns (each valid cell a box over its whole square up to its height; nodata cells as high
// as their rim, fill_holes_from_rim()):
//   - column_margin(): how much wider the safety distance must be on the mesh. Two bounds, the
//     smaller taken: the most any column rises above the mesh (certify_columns(), exact; valid
//     when the mesh covers every column), and, when the mesh is at most E below every cell
//     centre (certify()), sqrt((cell diagonal / 2)^2 + E^2): every point of a column lies
//     within that of the vertical under its centre, which is under the mesh.
//   - hole_columns(): the columns of the filled holes as triangles (top and outer walls), for
//     the mesh lacks them: a hole is a void in a mesh, and a path could otherwise pass through
//     it below its rim.
#include <algorithm>
#include <cmath>

#include "dsmplan/columns.hpp"
#include "dsmplan/plan.hpp"

namespace dsmplan {

double column_margin(const Mesh& mesh, const Grid& dsm, ColumnError* columns_above, VerticalError* below_centres) {
  const Grid& columns = dsm;
  const ColumnError above = certify_columns(mesh, columns);
  const VerticalError below = certify(mesh, columns);
  if (columns_above) *columns_above = above;
  if (below_centres) *below_centres = below;
  const double half_diagonal = std::hypot(std::hypot(columns.cell_x, columns.cell_y) / 2, below.max_below);
  return above.uncovered_corners == 0 ? std::min(above.max_below, half_diagonal) : half_diagonal;
}

Mesh hole_columns(const Grid& dsm, const Grid& columns) {
  Mesh out;
  out.crs = dsm.crs;
  double lowest = INFINITY;
  for (float z : columns.z)
    if (!std::isnan(z)) lowest = std::min<double>(lowest, z);
  const double foot = lowest - 1;  // walls reach below every column: nothing passes under them
  auto hole = [&](int c, int r) {
    return c >= 0 && r >= 0 && c < dsm.width && r < dsm.height && std::isnan(dsm.at(c, r)) &&
           !std::isnan(columns.at(c, r));
  };
  auto vertex = [&](double x, double y, double z) {
    out.vertices.push_back({x, y, z});
    return static_cast<uint32_t>(out.vertices.size() - 1);
  };
  for (int row = 0; row < dsm.height; ++row)
    for (int col = 0; col < dsm.width; ++col) {
      if (!hole(col, row)) continue;
      const double top = columns.at(col, row);
      const double x0 = dsm.x0 + col * dsm.cell_x, x1 = x0 + dsm.cell_x;
      const double y1 = dsm.y0 - row * dsm.cell_y, y0 = y1 - dsm.cell_y;
      // Top: counter-clockwise from above.
      const uint32_t a = vertex(x0, y0, top), b = vertex(x1, y0, top), c = vertex(x1, y1, top), d = vertex(x0, y1, top);
      out.triangles.push_back({a, b, c});
      out.triangles.push_back({a, c, d});
      // A wall on every side that does not face another cell of a hole (those share its top).
      auto wall = [&](double xa, double ya, double xb, double yb) {
        const uint32_t p = vertex(xa, ya, top), q = vertex(xb, yb, top), s = vertex(xb, yb, foot),
                       t = vertex(xa, ya, foot);
        out.triangles.push_back({p, q, s});
        out.triangles.push_back({p, s, t});
      };
      if (!hole(col, row + 1)) wall(x0, y0, x1, y0);
      if (!hole(col + 1, row)) wall(x1, y0, x1, y1);
      if (!hole(col, row - 1)) wall(x1, y1, x0, y1);
      if (!hole(col - 1, row)) wall(x0, y1, x0, y0);
    }
  return out;
}

}  // namespace dsmplan
