// Simplify stage: the paper's one-pass simplification (Section 4), the bounded mode and the
// certified error, each checked against an oracle that does not share its code:
//   - mark_paper() on hand-made grids (plane, step, ramps, walls, courtyard, saddle) and on
//     hand-made fans, against mark pictures and counts derived by hand from the definitions at
//     the top of simplify.hpp (and the conservative diagonal of mesh.hpp), and on the real NRW
//     crop and Delft grid against a brute force of the same definitions over the mesh's edge
//     set, with heights in whole decimetres;
//   - simplify_paper() and simplify_bounded(delaunay) against exact in-circle tests (CGAL
//     predicates on lattice points) and CGAL's own Delaunay_triangulation_2; the footprint
//     against the input mesh's coverage of every cell centre;
//   - certify() against a per-cell point location written here (bucket grid of triangles, CGAL's
//     exact orientation test, barycentric interpolation);
//   - the bounded mode's bounds, watertightness (edge use, T-junctions, outward probes) and
//     thread independence on the real NRW tile/crop and on the Delft grid with real holes;
//   - thin walls and courtyards found in the real NRW data by scanning and flood fill, looked up
//     in the simplified meshes with the same point location.
// The oracles themselves are checked on broken meshes (Oracles.SeeBrokenMeshes). Tests marked
// REGRESSION failed on src/simplify before the 1 nm height slack and the put-back of co-linear
// vertices off the new surface (both documented at the top of simplify.hpp).
#include "dsmplan/simplify.hpp"

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <queue>
#include <set>
#include <string>
#include <vector>

#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/simplify_streamed.hpp"
#include "testkit.hpp"

using namespace dsmplan;
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_2;

namespace {

// ---- data ------------------------------------------------------------------------------------

// A hand-made 1 m grid away from the origin, so CRS coordinates are not lattice indices.
template <class Height>
Grid make_grid(int width, int height, Height z) {
  Grid grid(width, height, 350000.0, 5600000.0, 1.0, 1.0);
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) grid.z[grid.index(c, r)] = static_cast<float>(z(c, r));
  return grid;
}

// Hand-made heights are kept as they are (0.25 m steps must not be rounded to 0.1 m).
Mesh exact_mesh(const Grid& grid) {
  MeshOptions options;
  options.zstep = 0;
  return triangulate_xy3(grid, options);
}

PaperSimplifyOptions paper(PaperVariant variant, double dz = 0.4, double dco = 1e-5) {
  PaperSimplifyOptions options;
  options.variant = variant;
  options.dz = dz;
  options.dco = dco;
  return options;
}

BoundedSimplifyOptions bounded(double max_error, bool conservative = false, bool delaunay = false) {
  BoundedSimplifyOptions options;
  options.max_error = max_error;
  options.conservative = conservative;
  options.delaunay = delaunay;
  return options;
}

// Marks as a picture: one row of characters per grid row, K kept, P co-planar, L co-linear.
std::vector<std::string> picture(const Grid& grid, const std::vector<VertexMark>& marks) {
  std::vector<std::string> rows(grid.height, std::string(grid.width, '.'));
  size_t v = 0;
  for (int r = 0; r < grid.height; ++r)
    for (int c = 0; c < grid.width; ++c)
      if (grid.valid(c, r)) rows[r][c] = "KPL"[static_cast<int>(marks.at(v++))];
  return rows;
}

size_t count(const std::vector<VertexMark>& marks, VertexMark mark) {
  return static_cast<size_t>(std::count(marks.begin(), marks.end(), mark));
}

// ---- where vertices are on the grid -------------------------------------------------------------

struct CellOf {
  int col, row;
};

// Every vertex of these meshes is a cell centre; anything else is a failure of the caller.
CellOf cell_of(const Grid& grid, const Vertex& v) {
  const int col = static_cast<int>(std::lround((v.x - grid.x0) / grid.cell_x - 0.5));
  const int row = static_cast<int>(std::lround((grid.y0 - v.y) / grid.cell_y - 0.5));
  if (col < 0 || row < 0 || col >= grid.width || row >= grid.height || grid.center_x(col) != v.x ||
      grid.center_y(row) != v.y) {
    ADD_FAILURE() << "vertex " << v.x << "," << v.y << " is not a cell centre";
    return {std::clamp(col, 0, grid.width - 1), std::clamp(row, 0, grid.height - 1)};  // keep lookups in range
  }
  return {col, row};
}

// Lattice position in units of the cell width: exact integers, so in-circle tests see the ties.
Point lattice(const Grid& grid, CellOf cell) { return Point(cell.col, -cell.row * (grid.cell_y / grid.cell_x)); }

// ---- the oracle for heights: point location by brute force over a bucket grid --------------------

// The mesh's height at any x,y: the first triangle (in index order) that contains the point,
// closed, decided by CGAL's exact orientation on the CRS doubles; barycentric interpolation.
class MeshHeight {
public:
  MeshHeight(const Mesh& mesh, const Grid& grid, int bucket_cells = 4)
      : mesh_(mesh),
        x0_(grid.x0),
        y0_(grid.y0),
        size_x_(grid.cell_x * bucket_cells),
        size_y_(grid.cell_y * bucket_cells),
        columns_(grid.width / bucket_cells + 1),
        rows_(grid.height / bucket_cells + 1),
        buckets_(static_cast<size_t>(columns_) * rows_) {
    for (uint32_t t = 0; t < mesh.triangles.size(); ++t) {
      double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
      for (uint32_t v : mesh.triangles[t]) {
        xmin = std::min(xmin, mesh.vertices[v].x), xmax = std::max(xmax, mesh.vertices[v].x);
        ymin = std::min(ymin, mesh.vertices[v].y), ymax = std::max(ymax, mesh.vertices[v].y);
      }
      const int c0 = std::max(0, bucket_x(xmin)), c1 = std::min(columns_ - 1, bucket_x(xmax));
      const int r0 = std::max(0, bucket_y(ymax)), r1 = std::min(rows_ - 1, bucket_y(ymin));
      for (int r = r0; r <= r1; ++r)
        for (int c = c0; c <= c1; ++c) buckets_[static_cast<size_t>(r) * columns_ + c].push_back(t);
    }
  }

  std::optional<double> at(double x, double y) const {
    const int c = bucket_x(x), r = bucket_y(y);
    if (c < 0 || r < 0 || c >= columns_ || r >= rows_) return std::nullopt;
    const Point p(x, y);
    for (uint32_t t : buckets_[static_cast<size_t>(r) * columns_ + c]) {
      const Vertex* v[3];
      Point q[3];
      for (int k = 0; k < 3; ++k) v[k] = &mesh_.vertices[mesh_.triangles[t][k]], q[k] = Point(v[k]->x, v[k]->y);
      const CGAL::Orientation turn = CGAL::orientation(q[0], q[1], q[2]);
      if (turn == CGAL::COLLINEAR) continue;
      bool inside = true;
      for (int k = 0; k < 3 && inside; ++k) inside = CGAL::orientation(q[k], q[(k + 1) % 3], p) != -turn;
      if (!inside) continue;
      // Weights: the areas opposite each vertex, from coordinates relative to the point.
      double w[3];
      for (int k = 0; k < 3; ++k) {
        const Vertex &a = *v[(k + 1) % 3], &b = *v[(k + 2) % 3];
        w[k] = (a.x - x) * (b.y - y) - (b.x - x) * (a.y - y);
      }
      return (w[0] * v[0]->z + w[1] * v[1]->z + w[2] * v[2]->z) / (w[0] + w[1] + w[2]);
    }
    return std::nullopt;
  }

  std::optional<double> at_cell(const Grid& grid, int col, int row) const {
    return at(grid.center_x(col), grid.center_y(row));
  }

private:
  int bucket_x(double x) const { return static_cast<int>(std::floor((x - x0_) / size_x_)); }
  int bucket_y(double y) const { return static_cast<int>(std::floor((y0_ - y) / size_y_)); }

  const Mesh& mesh_;
  double x0_, y0_, size_x_, size_y_;
  int columns_, rows_;
  std::vector<std::vector<uint32_t>> buckets_;
};

// certify() redone with MeshHeight.
VerticalError brute_certify(const Mesh& mesh, const Grid& grid) {
  const MeshHeight height(mesh, grid);
  VerticalError error;
  double squares = 0;
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      if (!grid.valid(c, r)) continue;
      const std::optional<double> z = height.at_cell(grid, c, r);
      if (!z) {
        ++error.uncovered;
        continue;
      }
      const double d = *z - grid.at(c, r);
      error.max_above = std::max(error.max_above, d);
      error.max_below = std::max(error.max_below, -d);
      squares += d * d;
      ++error.cells;
    }
  }
  error.rms = error.cells ? std::sqrt(squares / error.cells) : 0;
  return error;
}

void expect_same_error(const VerticalError& expected, const VerticalError& actual) {
  EXPECT_NEAR(actual.max_above, expected.max_above, 1e-9);
  EXPECT_NEAR(actual.max_below, expected.max_below, 1e-9);
  EXPECT_NEAR(actual.rms, expected.rms, 1e-9);
  EXPECT_EQ(actual.cells, expected.cells);
  EXPECT_EQ(actual.uncovered, expected.uncovered);
}

// ---- mesh shape ----------------------------------------------------------------------------------

size_t count_not_ccw(const Mesh& mesh) {
  size_t bad = 0;
  for (const Triangle& t : mesh.triangles) {
    const Vertex &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    if (CGAL::orientation(Point(a.x, a.y), Point(b.x, b.y), Point(c.x, c.y)) != CGAL::LEFT_TURN) ++bad;
  }
  return bad;
}

using Edge = std::pair<uint32_t, uint32_t>;

struct Topology {
  size_t folds = 0;              // a directed edge used twice: two triangles on the same side
  std::vector<Edge> border;      // directed edges without their reverse
  std::vector<Edge> undirected;  // every edge once
};

Topology topology(const Mesh& mesh) {
  std::vector<Edge> directed;
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) directed.emplace_back(t[k], t[(k + 1) % 3]);
  std::sort(directed.begin(), directed.end());
  Topology topo;
  for (size_t i = 0; i < directed.size(); ++i) {
    const Edge e = directed[i];
    if (i > 0 && directed[i - 1] == e) {
      ++topo.folds;
      continue;
    }
    const bool has_reverse = std::binary_search(directed.begin(), directed.end(), Edge{e.second, e.first});
    if (!has_reverse) topo.border.push_back(e);
    if (!has_reverse || e.first < e.second) topo.undirected.push_back(e);
  }
  return topo;
}

// Vertices lying strictly inside an edge (x,y): T-junctions. Every vertex is a cell centre, so
// only the lattice points on the edge can be one.
size_t count_t_junctions(const Mesh& mesh, const Grid& grid, const std::vector<Edge>& edges) {
  std::vector<char> has_vertex(grid.cells(), 0);
  std::vector<CellOf> cells;
  for (const Vertex& v : mesh.vertices) {
    cells.push_back(cell_of(grid, v));
    has_vertex[grid.index(cells.back().col, cells.back().row)] = 1;
  }
  size_t found = 0;
  for (auto [a, b] : edges) {
    const int dc = cells[b].col - cells[a].col, dr = cells[b].row - cells[a].row;
    const int steps = std::gcd(std::abs(dc), std::abs(dr));
    for (int k = 1; k < steps; ++k)
      found += has_vertex[grid.index(cells[a].col + k * dc / steps, cells[a].row + k * dr / steps)];
  }
  return found;
}

double area_xy(const Mesh& mesh) {
  double area = 0;
  for (const Triangle& t : mesh.triangles) {
    const Vertex &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    area += 0.5 * ((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
  }
  return area;
}

// Triangles whose circumcircle holds a vertex strictly inside (exact in-circle on the lattice).
// The lattice points in the circle are enumerated row by row, so the cost is the circle's area
// inside the grid, not its bounding box (thin triangles along the outline have huge circles).
size_t count_nonempty_circles(const Mesh& mesh, const Grid& grid) {
  std::vector<char> has_vertex(grid.cells(), 0);
  std::vector<CellOf> cells;
  for (const Vertex& v : mesh.vertices) {
    cells.push_back(cell_of(grid, v));
    has_vertex[grid.index(cells.back().col, cells.back().row)] = 1;
  }
  const double aspect = grid.cell_y / grid.cell_x;
  size_t violations = 0;
  for (const Triangle& t : mesh.triangles) {
    Point p[3];
    for (int k = 0; k < 3; ++k) p[k] = lattice(grid, cells[t[k]]);
    const Point centre = CGAL::circumcenter(p[0], p[1], p[2]);
    const double radius = std::sqrt(CGAL::squared_distance(centre, p[0])) + 1;  // 1: rounding margin
    const int r0 = std::max(0, static_cast<int>(std::floor((-centre.y() - radius) / aspect)));
    const int r1 = std::min(grid.height - 1, static_cast<int>(std::ceil((-centre.y() + radius) / aspect)));
    for (int r = r0; r <= r1; ++r) {
      const double dy = -r * aspect - centre.y();
      const double half = std::sqrt(std::max(0.0, radius * radius - dy * dy));
      const int c0 = std::max(0, static_cast<int>(std::floor(centre.x() - half)));
      const int c1 = std::min(grid.width - 1, static_cast<int>(std::ceil(centre.x() + half)));
      for (int c = c0; c <= c1; ++c) {
        if (has_vertex[grid.index(c, r)] &&
            CGAL::side_of_bounded_circle(p[0], p[1], p[2], lattice(grid, {c, r})) == CGAL::ON_BOUNDED_SIDE)
          ++violations;
      }
    }
  }
  return violations;
}

// CGAL's Delaunay triangulation of the same vertices: same number of faces, and every edge CGAL
// has for a strict reason (not a cocircular tie) is ours too.
void expect_cgal_delaunay(const Mesh& mesh, const Grid& grid) {
  using Vb = CGAL::Triangulation_vertex_base_with_info_2<uint32_t, K>;
  using Tds = CGAL::Triangulation_data_structure_2<Vb>;
  using Delaunay = CGAL::Delaunay_triangulation_2<K, Tds>;
  std::vector<std::pair<Point, uint32_t>> points;
  for (uint32_t v = 0; v < mesh.vertices.size(); ++v)
    points.emplace_back(lattice(grid, cell_of(grid, mesh.vertices[v])), v);
  Delaunay dt;
  dt.insert(points.begin(), points.end());
  ASSERT_EQ(dt.number_of_vertices(), mesh.vertices.size());
  EXPECT_EQ(dt.number_of_faces(), mesh.triangles.size());
  std::set<Edge> ours;
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ours.insert(std::minmax(t[k], t[(k + 1) % 3]));
  size_t strict = 0, missing = 0;
  for (auto e = dt.finite_edges_begin(); e != dt.finite_edges_end(); ++e) {
    const auto face = e->first, neighbour = face->neighbor(e->second);
    bool is_strict = dt.is_infinite(face) || dt.is_infinite(neighbour);
    if (!is_strict)
      is_strict = dt.side_of_oriented_circle(face, neighbour->vertex(neighbour->index(face))->point()) ==
                  CGAL::ON_NEGATIVE_SIDE;
    if (!is_strict) continue;
    ++strict;
    missing +=
        !ours.count(std::minmax(face->vertex(dt.cw(e->second))->info(), face->vertex(dt.ccw(e->second))->info()));
  }
  EXPECT_GT(strict, 0u);
  EXPECT_EQ(missing, 0u) << "strict Delaunay edges absent from the mesh";
}

}  // namespace

// =================================================================================================
// 1. mark_paper on hand-made meshes
// =================================================================================================

TEST(MarkPaper, FlatPlane) {
  const Grid grid = make_grid(7, 5, [](int, int) { return 100.0; });
  const Mesh mesh = exact_mesh(grid);
  // Interior: every neighbour at the same height. Border: never co-planar (open fan); co-linear
  // between its two border neighbours on a straight line, which is horizontal, so not in
  // variant two; corners turn 90 degrees.
  const std::vector<std::string> one = {
      "KLLLLLK",  //
      "LPPPPPL",  //
      "LPPPPPL",  //
      "LPPPPPL",  //
      "KLLLLLK",
  };
  const std::vector<std::string> two = {
      "KKKKKKK",  //
      "KPPPPPK",  //
      "KPPPPPK",  //
      "KPPPPPK",  //
      "KKKKKKK",
  };
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::One))), one);
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::Two))), two);
}

TEST(MarkPaper, StepBetweenTwoFlatLevels) {
  const Grid grid = make_grid(8, 6, [](int c, int) { return c < 4 ? 100.0 : 105.0; });
  const Mesh mesh = exact_mesh(grid);
  // Columns 3 and 4 see a neighbour 5 m off. Variant one: they lie on the horizontal line along
  // their column (interior), but the border ones at the step turn up or down. Variant two: a
  // vertex at one of only two levels can only lie between two neighbours at its own level.
  const std::vector<std::string> one = {
      "KLLKKLLK",  //
      "LPPLLPPL",  //
      "LPPLLPPL",  //
      "LPPLLPPL",  //
      "LPPLLPPL",  //
      "KLLKKLLK",
  };
  const std::vector<std::string> two = {
      "KKKKKKKK",  //
      "KPPKKPPK",  //
      "KPPKKPPK",  //
      "KPPKKPPK",  //
      "KPPKKPPK",  //
      "KKKKKKKK",
  };
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::One))), one);
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::Two))), two);
}

TEST(MarkPaper, RampRisesSoBothVariantsTakeItsLines) {
  // 0.6 m per column, quantized to 0.1 m as the mesh stage does: neighbours across columns
  // differ by more than dz, and every row is a straight rising line in 3D (within dco of the
  // decimal rounding). The west and east border columns are horizontal lines.
  const Grid grid = make_grid(7, 5, [](int c, int) { return 100.0 + 0.6 * c; });
  const Mesh mesh = triangulate_xy3(grid);
  const std::vector<std::string> one = {
      "KLLLLLK",  //
      "LLLLLLL",  //
      "LLLLLLL",  //
      "LLLLLLL",  //
      "KLLLLLK",
  };
  const std::vector<std::string> two = {
      "KLLLLLK",  //
      "KLLLLLK",  //
      "KLLLLLK",  //
      "KLLLLLK",  //
      "KLLLLLK",
  };
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::One))), one);
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::Two))), two);

  // Rising along both axes, every border line rises too: only the corners stay.
  const Grid diagonal = make_grid(6, 6, [](int c, int r) { return 100.0 + 0.5 * (c + r); });
  for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
    const std::vector<VertexMark> marks = mark_paper(exact_mesh(diagonal), paper(variant));
    EXPECT_EQ(picture(diagonal, marks),
              (std::vector<std::string>{"KLLLLK", "LLLLLL", "LLLLLL", "LLLLLL", "LLLLLL", "KLLLLK"}))
        << to_string(variant);
  }

  // A gentle ramp (0.25 m per column, every neighbour within dz) is co-planar inside.
  const Grid gentle = make_grid(6, 4, [](int c, int) { return 100.0 + 0.25 * c; });
  EXPECT_EQ(picture(gentle, mark_paper(exact_mesh(gentle), paper(PaperVariant::Two))),
            (std::vector<std::string>{"KLLLLK", "KPPPPK", "KPPPPK", "KLLLLK"}));
}

TEST(MarkPaper, ThinWallAcrossTheGrid) {
  // Flat ground at 100 m, a wall one cell wide and 8 m high in column 5, from border to border.
  const Grid grid = make_grid(11, 7, [](int c, int) { return c == 5 ? 108.0 : 100.0; });
  const Mesh mesh = exact_mesh(grid);
  // Columns 4..6 see the 8 m jump. Variant one takes them as the horizontal lines along the
  // wall's top and foot (the wall survives only at the border); variant two takes none.
  const std::vector<std::string> one = {
      "KLLLKKKLLLK",  //
      "LPPPLLLPPPL",  //
      "LPPPLLLPPPL",  //
      "LPPPLLLPPPL",  //
      "LPPPLLLPPPL",  //
      "LPPPLLLPPPL",  //
      "KLLLKKKLLLK",
  };
  const std::vector<std::string> two = {
      "KKKKKKKKKKK",  //
      "KPPPKKKPPPK",  //
      "KPPPKKKPPPK",  //
      "KPPPKKKPPPK",  //
      "KPPPKKKPPPK",  //
      "KPPPKKKPPPK",  //
      "KKKKKKKKKKK",
  };
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::One))), one);
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::Two))), two);
}

TEST(MarkPaper, FreeStandingWallTopIsNeverCoplanarAndVariantTwoKeepsIt) {
  // A wall in column 5, rows 2..6 of 9, 6 m high: its ends have ground on three sides.
  const Grid grid = make_grid(11, 9, [](int c, int r) { return c == 5 && r >= 2 && r <= 6 ? 106.0 : 100.0; });
  const Mesh mesh = exact_mesh(grid);
  const std::vector<VertexMark> one = mark_paper(mesh, paper(PaperVariant::One));
  const std::vector<VertexMark> two = mark_paper(mesh, paper(PaperVariant::Two));
  for (int r = 2; r <= 6; ++r) {
    const size_t v = grid.index(5, r);
    EXPECT_NE(one[v], VertexMark::Coplanar) << "row " << r;
    EXPECT_EQ(two[v], VertexMark::Kept) << "row " << r;
    // Variant one: between the wall vertices above and below at the same height.
    EXPECT_EQ(one[v], r == 2 || r == 6 ? VertexMark::Kept : VertexMark::Colinear) << "row " << r;
  }
  // A wall whose top rises 0.5 m per cell is a rising straight line: variant two takes it too
  // (the paper's rule; the wall then rests only on its ends).
  const Grid sloped =
      make_grid(11, 9, [](int c, int r) { return c == 5 && r >= 2 && r <= 6 ? 106.0 + 0.5 * r : 100.0; });
  const std::vector<VertexMark> rising = mark_paper(exact_mesh(sloped), paper(PaperVariant::Two));
  for (int r = 3; r <= 5; ++r) EXPECT_EQ(rising[grid.index(5, r)], VertexMark::Colinear) << "row " << r;
}

TEST(MarkPaper, CourtyardInsideARing) {
  // Ground at 100 m; a building ring at 110 m over cells 3..10 (both axes) around a courtyard
  // at 100 m over cells 5..8. Derived by hand with the conservative diagonal of mesh.hpp: at a
  // ring's outer corner the ground cell diagonal to it is its neighbour (the split goes up to
  // the ring), at the inner corners the court cell diagonal to the ring corner is not (the
  // split runs along the ring), so the four inner ring corners are co-planar.
  auto height = [](int c, int r) {
    const bool block = c >= 3 && c <= 10 && r >= 3 && r <= 10, court = c >= 5 && c <= 8 && r >= 5 && r <= 8;
    return block && !court ? 110.0 : 100.0;
  };
  const Grid grid = make_grid(14, 14, height);
  const Mesh mesh = exact_mesh(grid);
  const std::vector<std::string> one = {
      "KLLLLLLLLLLLLK",  //
      "LPPPPPPPPPPPPL",  //
      "LPLLLLLLLLLLPL",  //
      "LPLKLLLLLLKLPL",  //
      "LPLLPLLLLPLLPL",  //
      "LPLLLKLLKLLLPL",  //
      "LPLLLLPPLLLLPL",  //
      "LPLLLLPPLLLLPL",  //
      "LPLLLKLLKLLLPL",  //
      "LPLLPLLLLPLLPL",  //
      "LPLKLLLLLLKLPL",  //
      "LPLLLLLLLLLLPL",  //
      "LPPPPPPPPPPPPL",  //
      "KLLLLLLLLLLLLK",
  };
  const std::vector<std::string> two = {
      "KKKKKKKKKKKKKK",  //
      "KPPPPPPPPPPPPK",  //
      "KPKKKKKKKKKKPK",  //
      "KPKKKKKKKKKKPK",  //
      "KPKKPKKKKPKKPK",  //
      "KPKKKKKKKKKKPK",  //
      "KPKKKKPPKKKKPK",  //
      "KPKKKKPPKKKKPK",  //
      "KPKKKKKKKKKKPK",  //
      "KPKKPKKKKPKKPK",  //
      "KPKKKKKKKKKKPK",  //
      "KPKKKKKKKKKKPK",  //
      "KPPPPPPPPPPPPK",  //
      "KKKKKKKKKKKKKK",
  };
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::One))), one);
  EXPECT_EQ(picture(grid, mark_paper(mesh, paper(PaperVariant::Two))), two);

  // Variant two keeps the courtyard: its floor stays at 100 m, 10 m below the ring.
  const PaperSimplifyResult result = simplify_paper(mesh, paper(PaperVariant::Two));
  const MeshHeight surface(result.mesh, grid);
  for (int r = 5; r <= 8; ++r)
    for (int c = 5; c <= 8; ++c) EXPECT_EQ(surface.at_cell(grid, c, r).value_or(NAN), 100.0) << c << "," << r;
  for (int c = 3; c <= 10; ++c) EXPECT_EQ(surface.at_cell(grid, c, 3).value_or(NAN), 110.0) << c;
}

TEST(MarkPaper, SaddleIsRuledSoAlmostEverythingIsMarked) {
  // z = 100 + 0.25 (c-4)(r-4): a ruled surface, every row and column a straight line, rising
  // except through the centre. The centre's eight neighbours are within 0.25 m: co-planar; two
  // or more cells from the centre a straight neighbour is >= 0.5 m off: co-linear. Everything
  // but the four corners goes, in both variants.
  const Grid grid = make_grid(9, 9, [](int c, int r) { return 100.0 + 0.25 * (c - 4) * (r - 4); });
  const Mesh mesh = exact_mesh(grid);
  for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
    SCOPED_TRACE(to_string(variant));
    const std::vector<VertexMark> marks = mark_paper(mesh, paper(variant));
    for (int r = 0; r < 9; ++r) {
      for (int c = 0; c < 9; ++c) {
        const VertexMark mark = marks[grid.index(c, r)];
        const bool corner = (c == 0 || c == 8) && (r == 0 || r == 8);
        if (corner)
          EXPECT_EQ(mark, VertexMark::Kept) << c << "," << r;
        else if (c == 4 && r == 4)
          EXPECT_EQ(mark, VertexMark::Coplanar);
        else if (std::abs(c - 4) >= 2 || std::abs(r - 4) >= 2)
          EXPECT_EQ(mark, VertexMark::Colinear) << c << "," << r;
        else
          EXPECT_NE(mark, VertexMark::Kept) << c << "," << r;
      }
    }
    // Removing them all would leave two triangles over the corners (104, 96, 104, 96 m), 4 m
    // off at the centre; the removed co-linear vertices the surface then misses by more than dz
    // are put back, so the result has more than the corners and is within dz of every removed
    // co-linear vertex (checked on real data in SimplifyPaper.SurfaceStaysWithinDz...).
    const PaperSimplifyResult result = simplify_paper(mesh, paper(variant));
    EXPECT_GT(result.restored_colinear, 0u);
    EXPECT_EQ(result.mesh.vertices.size(), 4u + result.restored_colinear);
    EXPECT_EQ(result.removed_coplanar, count(marks, VertexMark::Coplanar));
    const MeshHeight surface(result.mesh, grid);
    for (int r = 0; r < 9; ++r)
      for (int c = 0; c < 9; ++c)
        if (marks[grid.index(c, r)] == VertexMark::Colinear)
          EXPECT_NEAR(surface.at_cell(grid, c, r).value_or(NAN), grid.at(c, r), 0.4 + 1e-9) << c << "," << r;
  }
}

TEST(MarkPaper, CoplanarStepsAddUpWithoutBound) {
  // A stepped tower: z = 104 - 0.25 d, d the Chebyshev distance from the centre of 17 x 17
  // cells. Every neighbour (diagonals too) is at most 0.25 m off, so every inner vertex is
  // co-planar, the peak included; the border ring is level (102 m), so variant two keeps it
  // whole and variant one its corners. Either way the surface left is flat at 102 m: the tower
  // top is 2 m below the data and nothing is above it.
  const Grid grid =
      make_grid(17, 17, [](int c, int r) { return 104.0 - 0.25 * std::max(std::abs(c - 8), std::abs(r - 8)); });
  const Mesh mesh = exact_mesh(grid);
  for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
    SCOPED_TRACE(to_string(variant));
    const PaperSimplifyResult result = simplify_paper(mesh, paper(variant));
    EXPECT_EQ(result.removed_coplanar, 15u * 15u);
    EXPECT_EQ(result.mesh.vertices.size(), variant == PaperVariant::One ? 4u : 16u * 4u);
    const VerticalError error = certify(result.mesh, grid);
    EXPECT_DOUBLE_EQ(error.max_below, 2.0);
    EXPECT_EQ(error.max_above, 0.0);
    EXPECT_EQ(error.uncovered, 0u);
  }
}

namespace {

// A fan around vertex 0 (A) with B west and C east of it on the x axis, and D (and E, when
// closed) 6 m north (south) at height far_z. far_z is chosen on the side where the directions
// A->B and A->C point, so the path over A from B or C to D or E is at least 3.8 m longer than
// the direct one (computed by hand as |AX| (1 + cos) for far_z >> 6): only B, C can be
// co-linear for dco <= 2.
Mesh fan(Vertex b, Vertex a, Vertex c, bool closed, double far_z) {
  Mesh mesh;
  mesh.vertices = {a, b, c, {1, 6, far_z}};
  mesh.triangles = {{0, 2, 3}, {0, 3, 1}};
  if (closed) {
    mesh.vertices.push_back({1, -6, far_z});
    mesh.triangles.push_back({0, 1, 4});
    mesh.triangles.push_back({0, 4, 2});
  }
  return mesh;
}

}  // namespace

TEST(MarkPaper, ColinearToleranceIsInclusive) {
  // |AB| = 4, |AC| = 13, |BC| = 15 (3D, exact in doubles): |AB| + |AC| - |BC| = 2, B and C at
  // heights 0 and 12 (the line rises). As a border vertex A has only B, C as border neighbours.
  const Vertex a{0, 0, 0}, b{-4, 0, 0}, c{5, 0, 12};
  for (bool closed : {false, true}) {
    SCOPED_TRACE(closed ? "interior vertex" : "border vertex");
    const Mesh mesh = fan(b, a, c, closed, 60);
    for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
      EXPECT_EQ(mark_paper(mesh, paper(variant, 0.4, 2.0))[0], VertexMark::Colinear) << to_string(variant);
      EXPECT_EQ(mark_paper(mesh, paper(variant, 0.4, 1.99))[0], VertexMark::Kept) << to_string(variant);
    }
    // The same excess of 2 with B and C at one height (|AB| = |AC| = 5, |BC| = 8): variant one
    // only.
    const Mesh level = fan({-4, 0, 0}, {0, 0, 3}, {4, 0, 0}, closed, -60);
    EXPECT_EQ(mark_paper(level, paper(PaperVariant::One, 0.4, 2.0))[0], VertexMark::Colinear);
    EXPECT_EQ(mark_paper(level, paper(PaperVariant::Two, 0.4, 2.0))[0], VertexMark::Kept);
    // Variant two's "not horizontal" is |zB - zC| > dco: exactly dco apart is horizontal.
    // (A at 0 between B at 0 and C at 2 or 2.5: excess 0.17 and 0.25, both <= dco = 2.)
    const Mesh two_up = fan({-4, 0, 0}, {0, 0, 0}, {5, 0, 2}, closed, 60);
    const Mesh more_up = fan({-4, 0, 0}, {0, 0, 0}, {5, 0, 2.5}, closed, 60);
    EXPECT_EQ(mark_paper(two_up, paper(PaperVariant::Two, 0.4, 2.0))[0], VertexMark::Kept);
    EXPECT_EQ(mark_paper(two_up, paper(PaperVariant::One, 0.4, 2.0))[0], VertexMark::Colinear);
    EXPECT_EQ(mark_paper(more_up, paper(PaperVariant::Two, 0.4, 2.0))[0], VertexMark::Colinear);
  }
}

TEST(MarkPaper, ColinearUsesAnyTwoNeighboursNotOnlyOpposite) {
  // A at the origin on the rising line from B (-1, 0, -1) to C (1, 0, 1); four neighbours 40 m
  // up north of the line and one south. Around A the fan runs C, four north, B, south: B and C
  // are two apart in a ring of seven, not opposite.
  Mesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 1}, {3, 2, 40}, {1, 3, 40}, {-1, 3, 40}, {-3, 2, 40}, {-1, 0, -1}, {0, -3, 40}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}, {0, 5, 6}, {0, 6, 7}, {0, 7, 1}};
  ASSERT_NO_THROW(check_2_5d(mesh, "fan"));
  EXPECT_EQ(mark_paper(mesh, paper(PaperVariant::One))[0], VertexMark::Colinear);
  EXPECT_EQ(mark_paper(mesh, paper(PaperVariant::Two))[0], VertexMark::Colinear);
  // Lift C by 0.1 m: the path over A is then longer than B-C by about 0.0008 m, far above dco.
  mesh.vertices[1].z = 1.1;
  EXPECT_EQ(mark_paper(mesh, paper(PaperVariant::One))[0], VertexMark::Kept);
}

TEST(MarkPaper, CoplanarToleranceIsInclusiveOnBinaryHeights) {
  // 3 x 3, centre 100 m, neighbours 100.5 m (exact in binary): co-planar iff dz >= 0.5.
  const Grid grid = make_grid(3, 3, [](int c, int r) { return c == 1 && r == 1 ? 100.0 : 100.5; });
  const Mesh mesh = exact_mesh(grid);
  EXPECT_EQ(mark_paper(mesh, paper(PaperVariant::Two, 0.5))[4], VertexMark::Coplanar);
  EXPECT_EQ(mark_paper(mesh, paper(PaperVariant::Two, 0.49))[4], VertexMark::Kept);  // a pit: not co-linear either
  EXPECT_EQ(mark_paper(mesh, paper(PaperVariant::Two, 0.0))[4], VertexMark::Kept);
  // dz = 0 still removes the centre of a flat patch.
  const Grid flat = make_grid(3, 3, [](int, int) { return 7.0; });
  EXPECT_EQ(mark_paper(exact_mesh(flat), paper(PaperVariant::Two, 0.0))[4], VertexMark::Coplanar);
}

// REGRESSION: heights quantized to 0.1 m (Table 1) are doubles near decimals,
// and the difference of two of them that are 0.4 m apart is 0.4 +- a few ulps of the height:
// 112.7 - 112.3 = 0.4000000000000057 > 0.4, while 112.6 - 112.2 = 0.3999999999999915. So with
// the paper's dz = 0.4 the "<=" of the definition holds or not depending on the absolute height
// (without slack 112.2 passes here, 112.3 fails).
TEST(MarkPaper, CoplanarToleranceIsInclusiveOnDecimalHeights) {
  for (double base : {112.2, 112.3, 100.0, 99.9, 0.7}) {
    SCOPED_TRACE("centre at " + std::to_string(base));
    const Grid grid = make_grid(3, 3, [&](int c, int r) { return c == 1 && r == 1 ? base : base + 0.4; });
    const Mesh mesh = triangulate_xy3(grid);  // quantized to 0.1 m, as the CLI does
    EXPECT_EQ(mark_paper(mesh, paper(PaperVariant::Two, 0.4))[4], VertexMark::Coplanar);
    EXPECT_EQ(mark_paper(mesh, paper(PaperVariant::Two, 0.3))[4], VertexMark::Kept);
  }
}

TEST(MarkPaper, LoneVertexStays) {
  Mesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 5, 0}};
  mesh.triangles = {{0, 1, 2}};
  const std::vector<VertexMark> marks = mark_paper(mesh, paper(PaperVariant::One, 1.0, 1.0));
  EXPECT_EQ(marks[3], VertexMark::Kept);
}

namespace {

// The definitions at the top of simplify.hpp once more, by brute force over the mesh's edge set,
// with heights in whole decimetres (the mesh stage quantizes to 0.1 m), so a neighbour exactly
// dz away is exactly dz away.
std::vector<VertexMark> brute_marks(const Mesh& mesh, PaperVariant variant, int dz_dm, double dco) {
  const size_t n = mesh.vertices.size();
  std::vector<std::set<uint32_t>> neighbours(n), border_out(n), border_in(n);
  const Topology topo = topology(mesh);
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) neighbours[t[k]].insert({t[(k + 1) % 3], t[(k + 2) % 3]});
  for (auto [a, b] : topo.border) border_out[a].insert(b), border_in[b].insert(a);
  auto dm = [&](uint32_t v) { return std::llround(mesh.vertices[v].z * 10); };
  auto length = [&](uint32_t p, uint32_t q) {
    const Vertex &a = mesh.vertices[p], &b = mesh.vertices[q];
    return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
  };
  auto between = [&](uint32_t a, uint32_t b, uint32_t c) {
    if (variant == PaperVariant::Two && dm(b) == dm(c)) return false;  // dco is far below 0.1 m
    return length(a, b) + length(a, c) <= length(b, c) + dco;
  };
  std::vector<VertexMark> marks(n, VertexMark::Kept);
  for (uint32_t a = 0; a < n; ++a) {
    const bool border = !border_out[a].empty();
    bool coplanar = !border && !neighbours[a].empty();
    for (uint32_t b : neighbours[a]) coplanar = coplanar && std::llabs(dm(b) - dm(a)) <= dz_dm;
    if (coplanar) {
      marks[a] = VertexMark::Coplanar;
      continue;
    }
    bool colinear = false;
    if (border) {
      colinear = border_in[a].size() == 1 && border_out[a].size() == 1 &&
                 between(a, *border_in[a].begin(), *border_out[a].begin());
    } else {
      const std::vector<uint32_t> ring(neighbours[a].begin(), neighbours[a].end());
      for (size_t i = 0; i < ring.size() && !colinear; ++i)
        for (size_t j = i + 1; j < ring.size() && !colinear; ++j) colinear = between(a, ring[i], ring[j]);
    }
    if (colinear) marks[a] = VertexMark::Colinear;
  }
  return marks;
}

// Thin walls: 1 or 2 cells across (along a row or a column), at least `rise` above the cell on
// either side. `side` and `far_side` are the cells beside the wall.
struct WallCell {
  int col, row;
  int side_col, side_row, far_col, far_row;
};

std::vector<WallCell> find_walls(const Grid& grid, double rise) {
  std::vector<WallCell> walls;
  auto z = [&](int c, int r) {
    return c >= 0 && r >= 0 && c < grid.width && r < grid.height && grid.valid(c, r) ? double(grid.at(c, r)) : NAN;
  };
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      for (auto [dc, dr] : {std::pair{1, 0}, {0, 1}}) {
        const double before = z(c - dc, r - dr), top = z(c, r), next = z(c + dc, r + dr),
                     after = z(c + 2 * dc, r + 2 * dr);
        if (before <= top - rise && next <= top - rise)  // one cell wide (false for NaN)
          walls.push_back({c, r, c - dc, r - dr, c + dc, r + dr});
        if (before <= std::min(top, next) - rise && after <= std::min(top, next) - rise) {  // two cells wide
          walls.push_back({c, r, c - dc, r - dr, c + 2 * dc, r + 2 * dr});
          walls.push_back({c + dc, r + dr, c - dc, r - dr, c + 2 * dc, r + 2 * dr});
        }
      }
    }
  }
  return walls;
}

// Per cell, the lowest height a path from it to the grid's edge (or to a hole) must climb to:
// a priority flood from the edge (Barnes et al. 2014). A cell at least `depth` below its spill
// height lies in a pit whose whole rim is that much higher: an enclosed courtyard.
std::vector<double> spill_heights(const Grid& grid) {
  std::vector<double> spill(grid.cells(), INFINITY);
  using Entry = std::pair<double, size_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      if (r == 0 || c == 0 || r == grid.height - 1 || c == grid.width - 1 || !grid.valid(c, r)) {
        const size_t i = grid.index(c, r);
        spill[i] = grid.valid(c, r) ? grid.at(c, r) : -INFINITY;
        queue.push({spill[i], i});
      }
    }
  }
  while (!queue.empty()) {
    const auto [height, i] = queue.top();
    queue.pop();
    if (height > spill[i]) continue;
    const int c = static_cast<int>(i % grid.width), r = static_cast<int>(i / grid.width);
    for (auto [dc, dr] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      if (c + dc < 0 || r + dr < 0 || c + dc >= grid.width || r + dr >= grid.height) continue;
      const size_t j = grid.index(c + dc, r + dr);
      const double climb = std::max(height, double(grid.z[j]));
      if (climb < spill[j]) {
        spill[j] = climb;
        queue.push({climb, j});
      }
    }
  }
  return spill;
}

struct Courtyards {
  std::vector<size_t> floor;  // cells at least 5 m below their rim
  size_t regions = 0;         // 4-connected regions of at least 9 such cells
};

Courtyards find_courtyards(const Grid& grid, const std::vector<double>& spill) {
  Courtyards found;
  std::vector<char> deep(grid.cells(), 0), seen(grid.cells(), 0);
  for (size_t i = 0; i < grid.cells(); ++i) deep[i] = !std::isnan(grid.z[i]) && spill[i] - grid.z[i] >= 5;
  for (size_t start = 0; start < grid.cells(); ++start) {
    if (!deep[start] || seen[start]) continue;
    std::vector<size_t> region{start}, stack{start};
    seen[start] = 1;
    while (!stack.empty()) {
      const size_t i = stack.back();
      stack.pop_back();
      const int c = static_cast<int>(i % grid.width), r = static_cast<int>(i / grid.width);
      for (auto [dc, dr] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        if (c + dc < 0 || r + dr < 0 || c + dc >= grid.width || r + dr >= grid.height) continue;
        const size_t j = grid.index(c + dc, r + dr);
        if (deep[j] && !seen[j]) seen[j] = 1, stack.push_back(j), region.push_back(j);
      }
    }
    if (region.size() >= 9) {
      ++found.regions;
      found.floor.insert(found.floor.end(), region.begin(), region.end());
    }
  }
  return found;
}

}  // namespace

TEST(MarkPaper, RealMeshesAgreeWithBruteForce) {
  for (const Grid* grid : {&testkit::nrw_crop(), &testkit::delft_grid()}) {
    const Mesh mesh = triangulate_xy3(*grid);  // 0.1 m heights, holes in Delft
    std::vector<int> largest_step(mesh.vertices.size(), 0);
    for (const Triangle& t : mesh.triangles) {
      for (int k = 0; k < 3; ++k) {
        const auto a = t[k], b = t[(k + 1) % 3];
        const int step =
            static_cast<int>(std::llabs(std::llround(mesh.vertices[a].z * 10) - std::llround(mesh.vertices[b].z * 10)));
        largest_step[a] = std::max(largest_step[a], step), largest_step[b] = std::max(largest_step[b], step);
      }
    }
    for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
      SCOPED_TRACE(std::string(grid == &testkit::nrw_crop() ? "nrw " : "delft ") + to_string(variant));
      const std::vector<VertexMark> marks = mark_paper(mesh, paper(variant));
      const std::vector<VertexMark> truth = brute_marks(mesh, variant, 4, 1e-5);
      ASSERT_EQ(marks.size(), truth.size());
      EXPECT_GT(count(truth, VertexMark::Coplanar), mesh.vertices.size() / 5);
      EXPECT_GT(count(truth, VertexMark::Colinear), mesh.vertices.size() / 50);
      size_t at_threshold = 0, elsewhere = 0;
      for (size_t v = 0; v < marks.size(); ++v)
        if (marks[v] != truth[v]) ++(largest_step[v] == 4 ? at_threshold : elsewhere);
      EXPECT_EQ(elsewhere, 0u);
      // REGRESSION (as CoplanarToleranceIsInclusiveOnDecimalHeights): vertices whose largest
      // neighbour step is exactly dz = 0.4 m are co-planar by the definition; without slack,
      // double arithmetic missed 3,781 of them on the crop and 4,247 on Delft.
      EXPECT_EQ(at_threshold, 0u);
    }
  }
}

// =================================================================================================
// 2. simplify_paper
// =================================================================================================

TEST(SimplifyPaper, KeepsTheUnmarkedAndRestoredVerticesInTheirOrder) {
  for (const Grid* grid : {&testkit::nrw_crop(), &testkit::delft_grid()}) {
    const Mesh mesh = triangulate_xy3(*grid);
    // Input vertex of each cell (vertices are cell centres, one per valid cell).
    std::vector<int64_t> input_at(grid->cells(), -1);
    for (size_t v = 0; v < mesh.vertices.size(); ++v) {
      const CellOf cell = cell_of(*grid, mesh.vertices[v]);
      input_at[grid->index(cell.col, cell.row)] = static_cast<int64_t>(v);
    }
    for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
      SCOPED_TRACE(std::string(grid == &testkit::nrw_crop() ? "nrw " : "delft ") + to_string(variant));
      const std::vector<VertexMark> marks = mark_paper(mesh, paper(variant));
      const PaperSimplifyResult result = simplify_paper(mesh, paper(variant));
      // The output is a subsequence of the input, unchanged: every kept vertex, no co-planar
      // one, and co-linear ones only as many as were put back.
      std::vector<bool> present(mesh.vertices.size(), false);
      int64_t last = -1;
      size_t out_of_order = 0, changed = 0, colinear_present = 0, coplanar_present = 0;
      for (const Vertex& out : result.mesh.vertices) {
        const CellOf cell = cell_of(*grid, out);
        const int64_t v = input_at[grid->index(cell.col, cell.row)];
        ASSERT_GE(v, 0);
        out_of_order += v <= last;
        last = v;
        changed += out.z != mesh.vertices[v].z;
        present[v] = true;
        colinear_present += marks[v] == VertexMark::Colinear;
        coplanar_present += marks[v] == VertexMark::Coplanar;
      }
      size_t kept_missing = 0;
      for (size_t v = 0; v < marks.size(); ++v) kept_missing += marks[v] == VertexMark::Kept && !present[v];
      EXPECT_EQ(out_of_order, 0u);
      EXPECT_EQ(changed, 0u);
      EXPECT_EQ(kept_missing, 0u);
      EXPECT_EQ(coplanar_present, 0u);
      EXPECT_EQ(colinear_present, result.restored_colinear);
      EXPECT_EQ(result.removed_coplanar, count(marks, VertexMark::Coplanar));
      EXPECT_EQ(result.removed_colinear + result.restored_colinear, count(marks, VertexMark::Colinear));
      EXPECT_EQ(result.removed_coplanar + result.removed_colinear + result.mesh.vertices.size(), mesh.vertices.size());
      EXPECT_EQ(count_not_ccw(result.mesh), 0u);
      EXPECT_EQ(topology(result.mesh).folds, 0u);
    }
  }
}

TEST(SimplifyPaper, SurfaceStaysWithinDzOfEveryRemovedColinearVertex) {
  // The header's promise for co-linear removals (they lie on a line of the input), checked by
  // point location in the output: removed co-linear vertices the surface misses by more than dz
  // must have been put back.
  for (const Grid* grid : {&testkit::nrw_crop(), &testkit::delft_grid()}) {
    const Mesh mesh = triangulate_xy3(*grid);
    for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
      SCOPED_TRACE(std::string(grid == &testkit::nrw_crop() ? "nrw " : "delft ") + to_string(variant));
      const std::vector<VertexMark> marks = mark_paper(mesh, paper(variant));
      const PaperSimplifyResult result = simplify_paper(mesh, paper(variant));
      std::vector<char> kept(grid->cells(), 0);
      for (const Vertex& out : result.mesh.vertices) {
        const CellOf cell = cell_of(*grid, out);
        kept[grid->index(cell.col, cell.row)] = 1;
      }
      const MeshHeight surface(result.mesh, *grid);
      size_t removed = 0, off = 0, uncovered = 0;
      for (size_t v = 0; v < marks.size(); ++v) {
        const Vertex& p = mesh.vertices[v];
        const CellOf cell = cell_of(*grid, p);
        if (marks[v] != VertexMark::Colinear || kept[grid->index(cell.col, cell.row)]) continue;
        ++removed;
        const std::optional<double> z = surface.at(p.x, p.y);
        if (!z) {
          ++uncovered;
          continue;
        }
        off += std::abs(*z - p.z) > 0.4 + 1e-9;
      }
      EXPECT_GT(removed, mesh.vertices.size() / 50);
      EXPECT_EQ(uncovered, 0u);
      EXPECT_EQ(off, 0u) << "of " << removed << " removed co-linear vertices";
    }
  }
}

TEST(SimplifyPaper, IsDelaunayWhereTheInputHasNoHoles) {
  const Grid& grid = testkit::nrw_crop();
  const Mesh mesh = triangulate_xy3(grid);
  for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
    SCOPED_TRACE(to_string(variant));
    const PaperSimplifyResult result = simplify_paper(mesh, paper(variant));
    EXPECT_EQ(count_nonempty_circles(result.mesh, grid), 0u);
    expect_cgal_delaunay(result.mesh, grid);
    // The whole rectangle of cell centres, once.
    EXPECT_NEAR(area_xy(result.mesh), (grid.width - 1) * (grid.height - 1) * grid.cell_x * grid.cell_y, 1e-6);
  }
  // The hand-made step: only the two step columns and the outline remain.
  const Grid step = make_grid(8, 6, [](int c, int) { return c < 4 ? 100.0 : 105.0; });
  const PaperSimplifyResult result = simplify_paper(exact_mesh(step), paper(PaperVariant::Two));
  EXPECT_EQ(result.mesh.vertices.size(), 8u * 6u - 2u * 2u * 4u);
  EXPECT_EQ(count_nonempty_circles(result.mesh, step), 0u);
  expect_cgal_delaunay(result.mesh, step);
  // The flat halves are flat and the step columns are vertices: the step stays exact.
  const VerticalError error = certify(result.mesh, step);
  EXPECT_EQ(error.max_above, 0.0);
  EXPECT_EQ(error.max_below, 0.0);
}

// Found by fuzz/fuzz_pipeline. With a large --dco (1 m on 1 m cells; up to 1000 is allowed) the
// corners of the outline passed as co-linear in 3D and were cut off: their cells were left outside
// every triangle (and a mesh whose every vertex was marked dereferenced a null hint). Border
// vertices now go only on the x,y line between their border neighbours.
TEST(SimplifyPaper, ALargeDcoKeepsTheOutlinesCorners) {
  const Grid flat = make_grid(6, 5, [](int, int) { return 100.0; });
  Grid notched = flat;  // a concave corner and a diagonal border too
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c) notched.z[notched.index(c, r)] = Grid::nodata;
  for (const Grid* grid : std::initializer_list<const Grid*>{&flat, &notched}) {
    for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
      for (double dco : {1.0, 1000.0}) {
        SCOPED_TRACE(std::string(to_string(variant)) + " dco " + std::to_string(dco));
        const Mesh mesh = exact_mesh(*grid);
        const PaperSimplifyResult result = simplify_paper(mesh, paper(variant, 10, dco));
        check_2_5d(result.mesh, "simplified");
        EXPECT_EQ(certify(result.mesh, *grid).uncovered, 0u);
        EXPECT_EQ(certify(mesh, *grid).uncovered, 0u);
      }
    }
  }
  // Cells 25 x 1e6 m: dco 1000 is nothing across a row and everything along one.
  Grid tall(3, 26, 500000, 1e9, 25, 1e6);
  for (size_t i = 0; i < tall.z.size(); ++i) tall.z[i] = 100.0f + float(i % 4);
  const Mesh mesh = exact_mesh(tall);
  const PaperSimplifyResult result = simplify_paper(mesh, paper(PaperVariant::One, 10, 1000));
  check_2_5d(result.mesh, "simplified");
  EXPECT_EQ(certify(result.mesh, tall).uncovered, 0u);
}

TEST(SimplifyPaper, KeepsTheFootprint) {
  for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
    SCOPED_TRACE(to_string(variant));
    const Grid& crop = testkit::nrw_crop();
    EXPECT_EQ(certify(simplify_paper(triangulate_xy3(crop), paper(variant)).mesh, crop).uncovered, 0u);

    // Delft has canals: every cell centre (valid or nodata) is covered by the simplified mesh
    // exactly when it is covered by the input mesh.
    const Grid& delft = testkit::delft_grid();
    const Mesh mesh = triangulate_xy3(delft);
    const Mesh simplified = simplify_paper(mesh, paper(variant)).mesh;
    const MeshHeight before(mesh, delft), after(simplified, delft);
    size_t differ = 0, covered_nodata = 0;
    for (int r = 0; r < delft.height; ++r) {
      for (int c = 0; c < delft.width; ++c) {
        const bool was = before.at_cell(delft, c, r).has_value(), is = after.at_cell(delft, c, r).has_value();
        differ += was != is;
        covered_nodata += is && !delft.valid(c, r);
      }
    }
    EXPECT_EQ(differ, 0u);
    EXPECT_GT(covered_nodata, 0u);  // single missing cells were bridged by the input, and still are
    const VerticalError input_error = certify(mesh, delft), output_error = certify(simplified, delft);
    EXPECT_GT(input_error.uncovered, 0u);  // lone valid cells in wide holes
    EXPECT_EQ(output_error.uncovered, input_error.uncovered);
  }
}

// =================================================================================================
// 3. certify
// =================================================================================================

TEST(Certify, OneTriangleByHand) {
  // 3 x 3 cells, one triangle over the centres of cells (0,0), (0,2), (2,0) with heights 0, 0, 2
  // (the plane z = col). It covers the six centres with col + row <= 2. The DSM is 0 except
  // 3 m at (1,1) (the mesh there is 1: 2 below) and nodata at (0,1).
  Grid grid = make_grid(3, 3, [](int c, int r) { return c == 1 && r == 1 ? 3.0 : 0.0; });
  grid.z[grid.index(0, 1)] = Grid::nodata;
  Mesh mesh;
  mesh.vertices = {{grid.center_x(0), grid.center_y(0), 0},
                   {grid.center_x(0), grid.center_y(2), 0},
                   {grid.center_x(2), grid.center_y(0), 2}};
  mesh.triangles = {{0, 1, 2}};
  const VerticalError error = certify(mesh, grid);
  // Measured: (0,0) 0, (1,0) +1, (2,0) +2, (1,1) -2, (0,2) 0. Uncovered: (2,1), (1,2), (2,2).
  EXPECT_DOUBLE_EQ(error.max_above, 2.0);
  EXPECT_DOUBLE_EQ(error.max_below, 2.0);
  EXPECT_DOUBLE_EQ(error.rms, std::sqrt(9.0 / 5.0));
  EXPECT_EQ(error.cells, 5u);
  EXPECT_EQ(error.uncovered, 3u);
  expect_same_error(error, brute_certify(mesh, grid));
}

// Far from the CRS origin with thin cells, vertex coordinates miss the cell centres by rounding
// (5.7e6 m in y: about 1e-9 m), and a wall-steep triangle (126 m over a 0.1 m cell) turns that
// into micrometres of height at the centres inside it. The certified error is of the mesh on
// the lattice, as its vertices are placed: exactly the plane through the three centres (found
// by the pipeline fuzzer: it reported 0.0005 where the mesh was 0.00050047 above).
TEST(Certify, FarFromTheOriginTheLatticeIsExact) {
  Grid grid = make_grid(9, 9, [](int, int) { return 0.0; });
  grid.x0 = -1000000, grid.y0 = 5700000, grid.cell_x = 1, grid.cell_y = 0.1;
  // The plane z = 42 - 126 * row / 8 over the triangle (0,0), (8,0), (0,8): exactly 42 - 15.75 row.
  Mesh mesh;
  mesh.vertices = {{grid.center_x(0), grid.center_y(0), 42},
                   {grid.center_x(8), grid.center_y(0), 42},
                   {grid.center_x(0), grid.center_y(8), -84}};
  mesh.triangles = {{0, 2, 1}};
  for (int r = 0; r < 9; ++r)
    for (int c = 0; c < 9; ++c)
      grid.z[grid.index(c, r)] = static_cast<float>(42 - 15.75 * r - (c + r <= 8 ? 0.0005 : 0));
  double expected = -INFINITY;  // the plane (exact in doubles here) less the stored float heights
  for (int r = 0; r < 9; ++r)
    for (int c = 0; c + r <= 8; ++c) expected = std::max(expected, 42 - 15.75 * r - double(grid.z[grid.index(c, r)]));
  const VerticalError error = certify(mesh, grid);
  EXPECT_EQ(error.cells, 45u);
  EXPECT_NEAR(error.max_above, expected, 1e-12);
}

TEST(Certify, MatchesPointLocationOnRealSimplifiedMeshes) {
  const Grid& crop = testkit::nrw_crop();
  const Grid& delft = testkit::delft_grid();
  struct Case {
    const char* name;
    const Grid& grid;
    Mesh mesh;
  };
  const std::vector<Case> cases = {
      {"nrw variant two", crop, simplify_paper(triangulate_xy3(crop), paper(PaperVariant::Two)).mesh},
      {"nrw bounded 0.4", crop, simplify_bounded(crop, bounded(0.4))},
      {"nrw bounded 0.4 conservative", crop, simplify_bounded(crop, bounded(0.4, true))},
      {"delft variant two", delft, simplify_paper(triangulate_xy3(delft), paper(PaperVariant::Two)).mesh},
      {"delft bounded 1.0", delft, simplify_bounded(delft, bounded(1.0))},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const VerticalError expected = brute_certify(c.mesh, c.grid);
    EXPECT_GT(expected.cells, c.grid.cells() / 2);
    EXPECT_GT(expected.max_above, 0.0);
    expect_same_error(expected, certify(c.mesh, c.grid));
  }
}

// =================================================================================================
// 4. simplify_bounded
// =================================================================================================

namespace {

void expect_within_bound(const Mesh& mesh, const Grid& grid, double max_error, bool conservative) {
  const VerticalError error = certify(mesh, grid);
  EXPECT_LE(error.max_above, max_error);
  if (conservative)
    EXPECT_EQ(error.max_below, 0.0);
  else
    EXPECT_LE(error.max_below, max_error);
  EXPECT_LT(mesh.vertices.size(), summarize(grid).valid);
  EXPECT_EQ(count_not_ccw(mesh), 0u);
}

// Watertight: no edge used twice on one side, no vertex inside another edge, and just outside
// every border edge there is no surface (a crack or an overlap would put some there).
struct Seams {
  size_t folds = 0, t_junctions = 0, covered_outside = 0;
};

Seams seams(const Mesh& mesh, const Grid& grid) {
  const Topology topo = topology(mesh);
  Seams found;
  found.folds = topo.folds;
  found.t_junctions = count_t_junctions(mesh, grid, topo.undirected);
  const MeshHeight surface(mesh, grid);
  for (auto [a, b] : topo.border) {
    const Vertex &p = mesh.vertices[a], &q = mesh.vertices[b];
    // The surface is left of a->b (counter-clockwise); probe a hair to the right of the middle.
    // (A lattice line not through the middle passes at least 1/(2 * 2000) cells from it.)
    const double length = std::hypot(q.x - p.x, q.y - p.y), hair = 1e-6 * grid.cell_x;
    const double x = (p.x + q.x) / 2 + hair * (q.y - p.y) / length, y = (p.y + q.y) / 2 - hair * (q.x - p.x) / length;
    found.covered_outside += surface.at(x, y).has_value();
  }
  return found;
}

void expect_watertight(const Mesh& mesh, const Grid& grid) {
  const Seams found = seams(mesh, grid);
  EXPECT_EQ(found.folds, 0u);
  EXPECT_EQ(found.t_junctions, 0u);
  EXPECT_EQ(found.covered_outside, 0u);
}

// On a grid without nodata the border is the rectangle of outer cell centres, and the triangles
// tile it once.
void expect_rectangle(const Mesh& mesh, const Grid& grid) {
  size_t inner = 0;
  for (auto [a, b] : topology(mesh).border) {
    const CellOf p = cell_of(grid, mesh.vertices[a]), q = cell_of(grid, mesh.vertices[b]);
    const bool outer = (p.col == q.col && (p.col == 0 || p.col == grid.width - 1)) ||
                       (p.row == q.row && (p.row == 0 || p.row == grid.height - 1));
    inner += !outer;
  }
  EXPECT_EQ(inner, 0u);
  EXPECT_NEAR(area_xy(mesh), (grid.width - 1) * (grid.height - 1) * grid.cell_x * grid.cell_y, 1e-3);
}

bool identical(const Mesh& a, const Mesh& b) {
  if (a.vertices.size() != b.vertices.size() || a.triangles != b.triangles) return false;
  for (size_t v = 0; v < a.vertices.size(); ++v)
    if (a.vertices[v].x != b.vertices[v].x || a.vertices[v].y != b.vertices[v].y || a.vertices[v].z != b.vertices[v].z)
      return false;
  return true;
}

}  // namespace

// The oracles see what they are meant to see: a T-junction, a crack, a fold, a wrong diagonal.
TEST(Oracles, SeeBrokenMeshes) {
  const Grid grid = make_grid(3, 4, [](int, int) { return 0.0; });
  auto at = [&](int c, int r) { return Vertex{grid.center_x(c), grid.center_y(r), 0.0}; };
  // Triangle (0,0) (2,0) (1,1) above, and below the edge (0,0)-(2,0) two triangles meeting at
  // (1,0): a T-junction, and the probe below the upper triangle's border edge finds surface.
  Mesh t_junction;
  t_junction.vertices = {at(0, 1), at(2, 1), at(1, 0), at(1, 1), at(1, 2)};
  t_junction.triangles = {{0, 1, 2}, {0, 4, 3}, {3, 4, 1}};
  ASSERT_EQ(count_not_ccw(t_junction), 0u);
  const Seams broken = seams(t_junction, grid);
  EXPECT_EQ(broken.t_junctions, 1u);
  EXPECT_GE(broken.covered_outside, 1u);
  EXPECT_EQ(broken.folds, 0u);
  // A kite (0,1) (1,0) (2,1) (1,3) split along (1,0)-(1,3) instead of its Delaunay diagonal.
  Mesh kite;
  kite.vertices = {at(0, 1), at(1, 0), at(2, 1), at(1, 3)};
  kite.triangles = {{0, 3, 1}, {1, 3, 2}};
  ASSERT_EQ(count_not_ccw(kite), 0u);
  EXPECT_GT(count_nonempty_circles(kite, grid), 0u);
  kite.triangles = {{0, 2, 1}, {0, 3, 2}};
  ASSERT_EQ(count_not_ccw(kite), 0u);
  EXPECT_EQ(count_nonempty_circles(kite, grid), 0u);
  Mesh folded = kite;
  folded.triangles.push_back({0, 2, 1});  // the same triangle twice: its three edges repeat
  EXPECT_EQ(topology(folded).folds, 3u);
}

TEST(SimplifyBounded, BoundHoldsOnTheNrwCrop) {
  const Grid& grid = testkit::nrw_crop();
  for (double max_error : {0.1, 0.4, 1.0}) {
    for (bool conservative : {false, true}) {
      for (bool delaunay : {false, true}) {
        SCOPED_TRACE("E " + std::to_string(max_error) + (conservative ? " conservative" : " two-sided") +
                     (delaunay ? " delaunay" : " tiled"));
        const Mesh mesh = simplify_bounded(grid, bounded(max_error, conservative, delaunay));
        expect_within_bound(mesh, grid, max_error, conservative);
        EXPECT_EQ(certify(mesh, grid).uncovered, 0u);
        if (delaunay) EXPECT_EQ(count_nonempty_circles(mesh, grid), 0u);
      }
    }
  }
}

TEST(SimplifyBounded, DelaunayModeIsCgalsDelaunayTriangulation) {
  const Grid& grid = testkit::nrw_crop();
  const Mesh mesh = simplify_bounded(grid, bounded(0.4, false, true));
  expect_cgal_delaunay(mesh, grid);
  expect_rectangle(mesh, grid);
}

TEST(SimplifyBounded, BoundHoldsOnTheFullNrwTile) {
  const Grid& grid = testkit::nrw_full();
  ASSERT_EQ(grid.cells(), 1000u * 1000u);
  {
    SCOPED_TRACE("E 0.4 two-sided tiled");
    const Mesh mesh = simplify_bounded(grid, bounded(0.4));
    expect_within_bound(mesh, grid, 0.4, false);
    EXPECT_EQ(certify(mesh, grid).uncovered, 0u);
    expect_watertight(mesh, grid);
    expect_rectangle(mesh, grid);
  }
  {
    SCOPED_TRACE("E 1.0 conservative tiled");
    const Mesh mesh = simplify_bounded(grid, bounded(1.0, true));
    expect_within_bound(mesh, grid, 1.0, true);
    EXPECT_EQ(certify(mesh, grid).uncovered, 0u);
  }
  {
    SCOPED_TRACE("E 0.1 conservative delaunay");
    const Mesh mesh = simplify_bounded(grid, bounded(0.1, true, true));
    expect_within_bound(mesh, grid, 0.1, true);
    EXPECT_EQ(certify(mesh, grid).uncovered, 0u);
    EXPECT_EQ(count_nonempty_circles(mesh, grid), 0u);
  }
}

TEST(SimplifyBounded, BoundHoldsOnDelftWithHoles) {
  const Grid& grid = testkit::delft_grid();
  ASSERT_GE(summarize(grid).holes, 100u);
  for (double max_error : {0.1, 0.4, 1.0}) {
    for (bool conservative : {false, true}) {
      SCOPED_TRACE("E " + std::to_string(max_error) + (conservative ? " conservative" : " two-sided"));
      expect_within_bound(simplify_bounded(grid, bounded(max_error, conservative)), grid, max_error, conservative);
    }
  }
  const Mesh mesh = simplify_bounded(grid, bounded(0.4, false, true));
  expect_within_bound(mesh, grid, 0.4, false);
  EXPECT_EQ(count_nonempty_circles(mesh, grid), 0u);
}

TEST(SimplifyBounded, TiledMeshIsWatertight) {
  const Grid& crop = testkit::nrw_crop();
  for (int tile : {0, 64, 37}) {
    for (bool conservative : {false, true}) {
      SCOPED_TRACE("tile " + std::to_string(tile) + (conservative ? " conservative" : " two-sided"));
      BoundedSimplifyOptions options = bounded(0.4, conservative);
      options.tile_size = tile;
      const Mesh mesh = simplify_bounded(crop, options);
      expect_watertight(mesh, crop);
      expect_rectangle(mesh, crop);
      expect_within_bound(mesh, crop, 0.4, conservative);
    }
  }
  const Grid& delft = testkit::delft_grid();
  for (int tile : {0, 50}) {
    SCOPED_TRACE("delft tile " + std::to_string(tile));
    BoundedSimplifyOptions options = bounded(0.4);
    options.tile_size = tile;
    const Mesh mesh = simplify_bounded(delft, options);
    expect_watertight(mesh, delft);
    expect_within_bound(mesh, delft, 0.4, false);
  }
}

TEST(SimplifyBounded, ResultDoesNotDependOnThreads) {
  for (const Grid* grid : {&testkit::nrw_crop(), &testkit::delft_grid()}) {
    BoundedSimplifyOptions options = bounded(0.4, grid == &testkit::delft_grid());
    options.tile_size = 64;
    options.threads = 1;
    const Mesh one = simplify_bounded(*grid, options);
    options.threads = 0;
    const Mesh every = simplify_bounded(*grid, options);
    options.threads = 2;
    const Mesh two = simplify_bounded(*grid, options);
    EXPECT_TRUE(identical(one, every));
    EXPECT_TRUE(identical(one, two));
  }
}

// Vertices are numbered at their first use, in triangle order: the streamed mesh never refers
// to a vertex it has not delivered yet. Each is a distinct cell centre.
TEST(SimplifyBounded, VerticesAreDistinctCellCentresNumberedAtFirstUse) {
  const Grid& grid = testkit::delft_grid();
  BoundedSimplifyOptions options = bounded(0.4);
  options.block_tiles = 2;
  const Mesh mesh = simplify_bounded(grid, options);
  size_t next = 0, ahead = 0;
  for (const Triangle& t : mesh.triangles) {
    for (uint32_t v : t) {
      ahead += v > next;
      if (v == next) ++next;
    }
  }
  EXPECT_EQ(ahead, 0u);
  EXPECT_EQ(next, mesh.vertices.size());  // and none unused
  std::set<size_t> cells;
  for (const Vertex& v : mesh.vertices) {
    const CellOf cell = cell_of(grid, v);
    cells.insert(grid.index(cell.col, cell.row));
  }
  EXPECT_EQ(cells.size(), mesh.vertices.size());
}

namespace {

// The triangles as cells (triangle_set): the surface without the numbering, which depends on
// the block order.
std::vector<Triangle> cell_triangles(const Mesh& mesh, const Grid& grid) {
  std::vector<Triangle> cells;
  for (const Triangle& t : mesh.triangles) {
    Triangle c;
    for (int k = 0; k < 3; ++k) {
      const CellOf cell = cell_of(grid, mesh.vertices[t[k]]);
      c[k] = static_cast<uint32_t>(grid.index(cell.col, cell.row));
    }
    cells.push_back(c);
  }
  return testkit::triangle_set(std::move(cells));
}

class CountingSink : public MeshSink {
public:
  void append(const std::vector<Vertex>& vertices, const std::vector<Triangle>& triangles) override {
    ++calls;
    largest = std::max(largest, triangles.size());
    mesh.vertices.insert(mesh.vertices.end(), vertices.begin(), vertices.end());
    mesh.triangles.insert(mesh.triangles.end(), triangles.begin(), triangles.end());
  }
  Mesh mesh;
  size_t calls = 0, largest = 0;
};

}  // namespace

// Blocks are the out-of-core unit: however the grid is cut into blocks, the surface is the same
// (the same triangles over the same cells, the same heights), the seams between blocks are
// watertight, and the error certified block by block is certify() of the whole mesh.
TEST(SimplifyBounded, BlocksMeetWatertightAndMakeTheSameSurface) {
  for (const Grid* grid : {&testkit::nrw_crop(), &testkit::delft_grid()}) {
    const bool nrw = grid == &testkit::nrw_crop();
    BoundedSimplifyOptions options = bounded(0.4, nrw);
    options.tile_size = 37;
    const Mesh whole_block = [&] {
      BoundedSimplifyOptions one = options;
      one.block_tiles = 1000;
      return simplify_bounded(*grid, one);
    }();
    const auto reference = cell_triangles(whole_block, *grid);
    for (int block_tiles : {1, 3, 0}) {
      SCOPED_TRACE((nrw ? "nrw" : "delft") + std::string(" block_tiles ") + std::to_string(block_tiles));
      options.block_tiles = block_tiles;
      testkit::CountingSource source(*grid);
      CountingSink sink;
      const BoundedStreamResult result = simplify_bounded(source, options, sink);
      const BoundedLayout layout = bounded_layout(grid->width, grid->height, options);
      EXPECT_EQ(sink.calls, layout.blocks());
      EXPECT_EQ(result.vertices, sink.mesh.vertices.size());
      EXPECT_EQ(result.triangles, sink.mesh.triangles.size());
      EXPECT_EQ(cell_triangles(sink.mesh, *grid), reference);
      expect_watertight(sink.mesh, *grid);
      if (nrw) expect_rectangle(sink.mesh, *grid);
      expect_within_bound(sink.mesh, *grid, 0.4, nrw);
      const VerticalError whole = certify(sink.mesh, *grid);
      EXPECT_EQ(result.error.cells, whole.cells);
      EXPECT_EQ(result.error.uncovered, whole.uncovered);
      EXPECT_DOUBLE_EQ(result.error.max_above, whole.max_above);
      EXPECT_DOUBLE_EQ(result.error.max_below, whole.max_below);
      EXPECT_NEAR(result.error.rms, whole.rms, 1e-12);
      EXPECT_EQ(result.valid_cells, summarize(*grid).valid);
      // Bounded memory: no window larger than a block and its margin, each cell read about once.
      const int side = layout.block_tiles * int(std::ceil(1.5 * layout.tile)) + 2 * layout.tile + 1;
      EXPECT_LE(source.largest, size_t(side) * side);
      if (block_tiles != 1) EXPECT_LT(source.cells_read, 4 * grid->cells());
    }
  }
}

// =================================================================================================
// 5. features kept, on the real 1 m tile
// =================================================================================================

namespace {

struct Features {
  std::vector<WallCell> walls;
  std::vector<double> spill;
  Courtyards courtyards;
};

const Features& nrw_features() {
  static const Features features = [] {
    Features f;
    f.walls = find_walls(testkit::nrw_full(), 5.0);
    f.spill = spill_heights(testkit::nrw_full());
    f.courtyards = find_courtyards(testkit::nrw_full(), f.spill);
    return f;
  }();
  return features;
}

}  // namespace

TEST(Features, RealTileHasThinWallsAndCourtyards) {
  // Not a toy: the tile has hundreds of wall cells and a handful of enclosed yards.
  EXPECT_GE(nrw_features().walls.size(), 500u);
  EXPECT_GE(nrw_features().courtyards.regions, 3u);
}

TEST(Features, BoundedModeKeepsWallsAndCourtyards) {
  const Grid& grid = testkit::nrw_full();
  const Features& features = nrw_features();
  for (bool conservative : {false, true}) {
    SCOPED_TRACE(conservative ? "conservative" : "two-sided");
    const double max_error = 0.4;
    const Mesh mesh = simplify_bounded(grid, bounded(max_error, conservative));
    const MeshHeight surface(mesh, grid);
    const double low = conservative ? 0.0 : -max_error;
    size_t off = 0, wall_lost = 0;
    for (const WallCell& w : features.walls) {
      const double top = surface.at_cell(grid, w.col, w.row).value_or(NAN);
      const double deviation = top - grid.at(w.col, w.row);
      off += !(deviation >= low - 1e-9 && deviation <= max_error + 1e-9);
      // Both the top and the ground are within the bound: the wall still stands 5 - 2E above it.
      for (auto [c, r] : {std::pair{w.side_col, w.side_row}, {w.far_col, w.far_row}})
        wall_lost += !(top - surface.at_cell(grid, c, r).value_or(NAN) >= 5 - 2 * max_error - 1e-9);
    }
    EXPECT_EQ(off, 0u);
    EXPECT_EQ(wall_lost, 0u);
    size_t floor_off = 0, filled = 0;
    for (size_t i : features.courtyards.floor) {
      const int c = static_cast<int>(i % grid.width), r = static_cast<int>(i / grid.width);
      const double z = surface.at_cell(grid, c, r).value_or(NAN);
      floor_off += !(z - grid.z[i] >= low - 1e-9 && z - grid.z[i] <= max_error + 1e-9);
      filled += !(z <= features.spill[i] - 5 + max_error + 1e-9);
    }
    EXPECT_EQ(floor_off, 0u);
    EXPECT_EQ(filled, 0u);
  }
}

// REGRESSION: variant two removes a vertex that lies on a rising straight line between two
// neighbours B, C, and the Delaunay re-triangulation need not contain the edge B-C. Where B-C
// runs along a wall top (or across a courtyard floor) the triangle over the removed vertex then
// spans the ground (or the rim) beside it: the wall is cut down, the yard filled. Without the
// put-back, 36 of these wall cells were cut. The paper's Fig. 7 (b, c) claims variant two keeps
// both.
TEST(Features, VariantTwoKeepsWallsAndCourtyards) {
  const Grid& grid = testkit::nrw_full();
  const Features& features = nrw_features();
  const Mesh input = triangulate_xy3(grid);
  ASSERT_EQ(input.vertices.size(), grid.cells());  // no nodata: vertex i is cell i
  const Mesh mesh = simplify_paper(input, paper(PaperVariant::Two)).mesh;
  const std::vector<VertexMark> marks = mark_paper(input, paper(PaperVariant::Two));
  const MeshHeight surface(mesh, grid);
  // No bound to derive from: the wall top must still stand 3 m above the real ground beside it
  // (a raised ground beside the wall only makes the obstacle wider). A kept wall vertex holds
  // its cell exactly, so a lost wall cell is a removed one: never co-planar (its sides are 5 m
  // lower), so co-linear; the count says so.
  size_t wall_lost = 0, lost_colinear = 0;
  for (const WallCell& w : features.walls) {
    const double top = surface.at_cell(grid, w.col, w.row).value_or(NAN);
    if (top >= std::max(grid.at(w.side_col, w.side_row), grid.at(w.far_col, w.far_row)) + 3) continue;
    ++wall_lost;
    lost_colinear += marks[grid.index(w.col, w.row)] == VertexMark::Colinear;
  }
  EXPECT_EQ(wall_lost, 0u) << "of " << features.walls.size() << " wall cells; " << lost_colinear
                           << " of the lost ones removed as co-linear";
  // A courtyard floor stays below the lowest point of its rim.
  size_t filled = 0;
  for (size_t i : features.courtyards.floor) {
    const int c = static_cast<int>(i % grid.width), r = static_cast<int>(i / grid.width);
    filled += !(surface.at_cell(grid, c, r).value_or(NAN) < features.spill[i]);
  }
  EXPECT_EQ(filled, 0u) << "of " << features.courtyards.floor.size() << " courtyard floor cells";
}

// The smallest case of the regression above: a wall one cell wide whose top rises 0.5 m per
// cell. Its inner vertices are co-linear (MarkPaper.FreeStandingWallTopIsNeverCoplanarAndVariant-
// TwoKeepsIt); once they are all gone, the cell (5, 4), 108 m in the DSM, lies on the edge between
// the ground cells (4, 4) and (6, 4) or in a triangle of ground cells, all at 100 m (nothing else
// is nearer), so they must come back.
TEST(Features, VariantTwoKeepsAWallWithARisingTop) {
  const Grid grid = make_grid(11, 9, [](int c, int r) { return c == 5 && r >= 2 && r <= 6 ? 106.0 + 0.5 * r : 100.0; });
  const Mesh mesh = simplify_paper(exact_mesh(grid), paper(PaperVariant::Two)).mesh;
  const MeshHeight surface(mesh, grid);
  for (int r = 2; r <= 6; ++r) EXPECT_GE(surface.at_cell(grid, 5, r).value_or(NAN), 103.0) << "wall cell in row " << r;
}

// =================================================================================================
// 6. bad input
// =================================================================================================

TEST(BadInput, OptionsOutOfRangeAreArgumentErrors) {
  const Mesh mesh = exact_mesh(make_grid(4, 4, [](int c, int) { return 100.0 + c; }));
  for (auto [dz, dco] : {std::pair{-0.1, 1e-5}, {0.4, -1e-5}, {NAN, 1e-5}, {0.4, NAN}}) {
    SCOPED_TRACE("dz " + std::to_string(dz) + " dco " + std::to_string(dco));
    EXPECT_THROW(mark_paper(mesh, paper(PaperVariant::One, dz, dco)), ArgumentError);
    EXPECT_THROW(simplify_paper(mesh, paper(PaperVariant::Two, dz, dco)), ArgumentError);
  }
  const Grid grid = make_grid(5, 5, [](int c, int r) { return 100.0 + c * r; });
  constexpr double inf = std::numeric_limits<double>::infinity();
  for (double max_error : {0.0, -1.0, inf, -inf, std::numeric_limits<double>::quiet_NaN()}) {
    SCOPED_TRACE("max_error " + std::to_string(max_error));
    EXPECT_THROW(simplify_bounded(grid, bounded(max_error)), ArgumentError);
    EXPECT_THROW(simplify_bounded(grid, bounded(max_error, true)), ArgumentError);
  }
  BoundedSimplifyOptions negative_tile = bounded(0.4);
  negative_tile.tile_size = -1;
  EXPECT_THROW(simplify_bounded(grid, negative_tile), ArgumentError);
  EXPECT_THROW(simplify_bounded(make_grid(1, 7, [](int, int) { return 1.0; }), bounded(0.4)), ArgumentError);
  EXPECT_THROW(simplify_bounded(make_grid(7, 1, [](int, int) { return 1.0; }), bounded(0.4)), ArgumentError);
  EXPECT_THROW(simplify_bounded(Grid(4, 4, 0, 4, 1, 1), bounded(0.4)), ArgumentError);  // all nodata
  // The smallest grid that is allowed works: its four corners, two triangles, exact.
  const Grid two = make_grid(2, 2, [](int c, int r) { return 10.0 * c + r; });
  Mesh smallest;
  ASSERT_NO_THROW(smallest = simplify_bounded(two, bounded(0.1)));
  EXPECT_EQ(smallest.vertices.size(), 4u);
  EXPECT_EQ(smallest.triangles.size(), 2u);
  EXPECT_EQ(certify(smallest, two).max_above, 0.0);
  EXPECT_EQ(certify(smallest, two).max_below, 0.0);
}

TEST(BadInput, Check2_5dRejectsFoldsAndNamesTheFile) {
  // A unit square of two counter-clockwise triangles is fine.
  Mesh square;
  square.vertices = {{0, 0, 1}, {1, 0, 2}, {1, 1, 3}, {0, 1, 4}};
  square.triangles = {{0, 1, 2}, {0, 2, 3}};
  EXPECT_NO_THROW(check_2_5d(square, "square.ply"));
  EXPECT_NO_THROW(check_2_5d(triangulate_xy3(testkit::delft_grid()), "delft.ply"));

  auto expect_rejected = [](const Mesh& mesh, const std::string& why) {
    SCOPED_TRACE(why);
    try {
      check_2_5d(mesh, "broken-mesh.ply");
      ADD_FAILURE() << "accepted";
    } catch (const InputError& error) {
      EXPECT_NE(std::string(error.what()).find("broken-mesh.ply"), std::string::npos) << error.what();
    }
  };
  Mesh clockwise = square;
  clockwise.triangles[1] = {0, 3, 2};
  expect_rejected(clockwise, "clockwise triangle");
  Mesh flat = square;
  flat.vertices.push_back({2, 0, 0});
  flat.triangles.push_back({0, 1, 4});  // three points on y = 0
  expect_rejected(flat, "zero-area triangle");
  Mesh twin = square;
  twin.vertices.push_back({1, 1, 9});  // same x,y as vertex 2, another height
  expect_rejected(twin, "two vertices at one x,y");
  Mesh out_of_range = square;
  out_of_range.triangles[1] = {0, 2, 4};
  expect_rejected(out_of_range, "index out of range");
  Mesh folded = square;
  folded.triangles[1] = {0, 1, 3};  // counter-clockwise too, but over the same side of 0->1
  expect_rejected(folded, "edge used twice in one direction");
}
