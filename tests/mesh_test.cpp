// Mesh stage: the XY-3 Delaunay triangulation, checked on real DSMs against exact predicates,
// brute force and CGAL's own Delaunay_triangulation_2 with Projection_traits_xy_3.
#include "dsmplan/mesh.hpp"

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Projection_traits_xy_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <set>

#include "dsmplan/raster.hpp"
#include "testkit.hpp"

using namespace dsmplan;
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_2;

namespace {

Grid window(const Grid& grid, int col0, int row0, int width, int height) {
  Grid out(width, height, grid.x0 + col0 * grid.cell_x, grid.y0 - row0 * grid.cell_y, grid.cell_x, grid.cell_y);
  out.crs = grid.crs;
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) out.z[out.index(c, r)] = grid.at(col0 + c, row0 + r);
  return out;
}

// Real heights, real shapes of holes: everything below `level` becomes nodata (streets, yards).
Grid with_holes_below(Grid grid, float level) {
  for (float& z : grid.z)
    if (z < level) z = Grid::nodata;
  return grid;
}

// Vertex i <-> cell (col,row); the mesh promises row-major order over valid cells.
struct Cells {
  std::vector<std::pair<int, int>> of_vertex;
  explicit Cells(const Grid& grid) {
    for (int r = 0; r < grid.height; ++r)
      for (int c = 0; c < grid.width; ++c)
        if (grid.valid(c, r)) of_vertex.emplace_back(c, r);
  }
};

// Lattice position of a cell centre in units of the cell width: exact for square cells of any
// size (the CRS coordinates may carry rounding, which would break cocircular ties).
Point lattice(const Grid& grid, int col, int row) { return Point(col, -row * (grid.cell_y / grid.cell_x)); }

MeshOptions unlimited() {
  MeshOptions options;
  options.max_edge_length = INFINITY;
  return options;
}

// Empty circumcircle among all valid cells, by enumerating the lattice around the circle.
size_t count_nonempty_circles(const Grid& grid, const Mesh& mesh) {
  Cells cells(grid);
  size_t violations = 0;
  for (const Triangle& t : mesh.triangles) {
    Point p[3];
    for (int k = 0; k < 3; ++k) p[k] = lattice(grid, cells.of_vertex[t[k]].first, cells.of_vertex[t[k]].second);
    const Point centre = CGAL::circumcenter(p[0], p[1], p[2]);
    const double radius = std::sqrt(CGAL::squared_distance(centre, p[0]));
    const double aspect = grid.cell_y / grid.cell_x;
    const int c0 = static_cast<int>(std::floor(centre.x() - radius)) - 1;
    const int c1 = static_cast<int>(std::ceil(centre.x() + radius)) + 1;
    const int r0 = static_cast<int>(std::floor((-centre.y() - radius) / aspect)) - 1;
    const int r1 = static_cast<int>(std::ceil((-centre.y() + radius) / aspect)) + 1;
    for (int r = std::max(r0, 0); r <= std::min(r1, grid.height - 1); ++r) {
      for (int c = std::max(c0, 0); c <= std::min(c1, grid.width - 1); ++c) {
        if (grid.valid(c, r) &&
            CGAL::side_of_bounded_circle(p[0], p[1], p[2], lattice(grid, c, r)) == CGAL::ON_BOUNDED_SIDE) {
          ++violations;
        }
      }
    }
  }
  return violations;
}

double longest_edge(const Mesh& mesh, const Triangle& t) {
  double longest = 0;
  for (int k = 0; k < 3; ++k) {
    const Vertex& a = mesh.vertices[t[k]];
    const Vertex& b = mesh.vertices[t[(k + 1) % 3]];
    longest = std::max(longest, std::hypot(a.x - b.x, a.y - b.y));
  }
  return longest;
}

using Edge = std::pair<uint32_t, uint32_t>;
Edge undirected(uint32_t a, uint32_t b) { return {std::min(a, b), std::max(a, b)}; }

// The oracle: CGAL's incremental Delaunay triangulation with Projection_traits_xy_3.
struct CgalReference {
  using Traits = CGAL::Projection_traits_xy_3<K>;
  using Vb = CGAL::Triangulation_vertex_base_with_info_2<uint32_t, Traits>;
  using Tds = CGAL::Triangulation_data_structure_2<Vb>;
  using Delaunay = CGAL::Delaunay_triangulation_2<Traits, Tds>;
  Delaunay delaunay;
  explicit CgalReference(const Grid& grid) {
    Cells cells(grid);
    std::vector<std::pair<K::Point_3, uint32_t>> points;
    for (uint32_t i = 0; i < cells.of_vertex.size(); ++i) {
      const auto [c, r] = cells.of_vertex[i];
      const Point p = lattice(grid, c, r);
      points.emplace_back(K::Point_3(p.x(), p.y(), grid.at(c, r)), i);
    }
    delaunay.insert(points.begin(), points.end());
  }
};

// Same vertex set, same number of triangles, same covered area, and every edge CGAL has for a
// strict reason (not a cocircular tie) is ours too: the two refine the same Delaunay subdivision.
void expect_delaunay_equivalent(const Grid& grid, const Mesh& mesh) {
  CgalReference reference(grid);
  const auto& dt = reference.delaunay;
  ASSERT_EQ(dt.number_of_vertices(), mesh.vertices.size());
  ASSERT_EQ(dt.number_of_faces(), mesh.triangles.size());
  std::set<Edge> ours;
  Cells cells(grid);
  double our_area = 0;
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) ours.insert(undirected(t[k], t[(k + 1) % 3]));
    our_area += CGAL::area(lattice(grid, cells.of_vertex[t[0]].first, cells.of_vertex[t[0]].second),
                           lattice(grid, cells.of_vertex[t[1]].first, cells.of_vertex[t[1]].second),
                           lattice(grid, cells.of_vertex[t[2]].first, cells.of_vertex[t[2]].second));
  }
  double cgal_area = 0;
  for (auto f = dt.finite_faces_begin(); f != dt.finite_faces_end(); ++f) {
    const auto& a = f->vertex(0)->point();
    const auto& b = f->vertex(1)->point();
    const auto& c = f->vertex(2)->point();
    cgal_area += CGAL::area(Point(a.x(), a.y()), Point(b.x(), b.y()), Point(c.x(), c.y()));
  }
  EXPECT_DOUBLE_EQ(our_area, cgal_area);
  size_t strict = 0, missing = 0;
  for (auto e = dt.finite_edges_begin(); e != dt.finite_edges_end(); ++e) {
    const auto face = e->first;
    const int i = e->second;
    const auto neighbour = face->neighbor(i);
    bool is_strict = dt.is_infinite(face) || dt.is_infinite(neighbour);
    if (!is_strict) {
      const auto opposite = neighbour->vertex(neighbour->index(face));
      is_strict = dt.side_of_oriented_circle(face, opposite->point()) == CGAL::ON_NEGATIVE_SIDE;
    }
    if (!is_strict) continue;
    ++strict;
    const Edge edge = undirected(face->vertex(dt.cw(i))->info(), face->vertex(dt.ccw(i))->info());
    if (!ours.count(edge)) ++missing;
  }
  EXPECT_GT(strict, 0u);
  EXPECT_EQ(missing, 0u) << "strict Delaunay edges of CGAL's triangulation absent from ours";
  EXPECT_EQ(count_nonempty_circles(grid, mesh), 0u);
}

}  // namespace

TEST(Xy3Delaunay, FullRealTileIsTheGridTriangulationOfTable1) {
  const Grid& grid = testkit::nrw_crop();
  const Mesh mesh = triangulate_xy3(grid);
  // Table 1's counts for a hole-free W x H grid: W*H vertices, 2(W-1)(H-1) faces.
  EXPECT_EQ(mesh.vertices.size(), 500u * 500u);
  EXPECT_EQ(mesh.triangles.size(), 2u * 499u * 499u);
  EXPECT_EQ(count_nonempty_circles(grid, mesh), 0u);
}

TEST(Xy3Delaunay, VerticesSitAtCellCentresWithQuantizedHeights) {
  const Grid grid = with_holes_below(testkit::nrw_crop(), 112.0f);
  const Mesh mesh = triangulate_xy3(grid);
  Cells cells(grid);
  ASSERT_EQ(mesh.vertices.size(), cells.of_vertex.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const auto [c, r] = cells.of_vertex[i];
    const Vertex& v = mesh.vertices[i];
    ASSERT_EQ(v.x, grid.center_x(c));
    ASSERT_EQ(v.y, grid.center_y(r));
    // Independent of quantize_height: the decimal with one digit nearest to the height.
    char text[32];
    std::snprintf(text, sizeof text, "%.1f", std::round(double(grid.at(c, r)) * 10) / 10);
    ASSERT_EQ(v.z, std::strtod(text, nullptr)) << "cell " << c << "," << r;
  }
}

TEST(Xy3Delaunay, TrianglesAreCounterClockwiseAndNotDegenerate) {
  for (const Grid& grid : {with_holes_below(testkit::nrw_crop(), 115.0f), testkit::delft_grid()}) {
    const Mesh mesh = triangulate_xy3(grid, unlimited());
    Cells cells(grid);
    size_t bad = 0;
    for (const Triangle& t : mesh.triangles) {
      const auto& [c0, r0] = cells.of_vertex[t[0]];
      const auto& [c1, r1] = cells.of_vertex[t[1]];
      const auto& [c2, r2] = cells.of_vertex[t[2]];
      if (CGAL::orientation(lattice(grid, c0, r0), lattice(grid, c1, r1), lattice(grid, c2, r2)) != CGAL::LEFT_TURN)
        ++bad;
    }
    EXPECT_EQ(bad, 0u);
  }
}

TEST(Xy3Delaunay, EmptyCircumcirclesOnRealHoles) {
  // The whole Delft grid (canals) and the NRW crop with its low parts cut away.
  for (const Grid& grid : {testkit::delft_grid(), with_holes_below(testkit::nrw_crop(), 113.0f)}) {
    const Mesh mesh = triangulate_xy3(grid, unlimited());
    ASSERT_GE(summarize(grid).holes, 5u);  // real canals/yards, not a toy
    EXPECT_EQ(count_nonempty_circles(grid, mesh), 0u);
    // With nothing dropped, every valid cell centre is a vertex of some triangle.
    std::vector<bool> used(mesh.vertices.size(), false);
    for (const Triangle& t : mesh.triangles)
      for (uint32_t v : t) used[v] = true;
    EXPECT_EQ(std::count(used.begin(), used.end(), false), 0);
  }
}

TEST(Xy3Delaunay, EqualsCgalOnRealWindows) {
  // Windows across Delft canals and the NRW crop with real-shaped holes, plus random holes.
  const Grid& delft = testkit::delft_grid();
  for (int k = 0; k < 6; ++k) {
    const Grid part = window(delft, 40 + 70 * k, 30 + 60 * k, 48, 40);
    SCOPED_TRACE("delft window " + std::to_string(k));
    expect_delaunay_equivalent(part, triangulate_xy3(part, unlimited()));
  }
  std::mt19937 random(7);
  for (int k = 0; k < 6; ++k) {
    Grid part = window(with_holes_below(testkit::nrw_crop(), 112.0f + k), 60 * k, 50 * k, 40, 40);
    for (float& z : part.z)
      if (random() % 7 == 0) z = Grid::nodata;
    SCOPED_TRACE("nrw window " + std::to_string(k));
    expect_delaunay_equivalent(part, triangulate_xy3(part, unlimited()));
  }
}

TEST(Xy3Delaunay, EqualsCgalForOddAndRectangularCells) {
  // Real heights and holes on cells of 0.3 m (not a binary fraction) and of 1 x 2 m.
  const Grid part = window(testkit::delft_grid(), 240, 0, 44, 40);  // across the canal in the north
  for (auto [cell_x, cell_y] : {std::pair{0.3, 0.3}, {1.0, 2.0}, {2.0, 1.0}}) {
    Grid grid = part;
    grid.cell_x = cell_x, grid.cell_y = cell_y;
    SCOPED_TRACE(std::to_string(cell_x) + " x " + std::to_string(cell_y));
    ASSERT_GT(summarize(grid).nodata, 200u);
    expect_delaunay_equivalent(grid, triangulate_xy3(grid, unlimited()));
  }
}

TEST(Xy3Delaunay, LongEdgesDropExactlyTheBridgingTriangles) {
  const Grid& grid = testkit::delft_grid();
  const Mesh all = triangulate_xy3(grid, unlimited());
  MeshOptions options;  // default limit: 2.5 cells
  const double limit = max_edge_length(grid, options);
  EXPECT_DOUBLE_EQ(limit, 1.25);
  const Mesh kept = triangulate_xy3(grid, options);
  std::set<Triangle> expected;
  for (const Triangle& t : all.triangles)
    if (longest_edge(all, t) <= limit) expected.insert(t);
  const std::set<Triangle> actual(kept.triangles.begin(), kept.triangles.end());
  EXPECT_EQ(actual, expected);
  EXPECT_LT(kept.triangles.size(), all.triangles.size());
  for (const Triangle& t : kept.triangles) ASSERT_LE(longest_edge(kept, t), limit);

  // No nodata cell is covered unless a valid cell lies within the limit (holes stay holes).
  Cells cells(grid);
  size_t bridged_far = 0, covered_nodata = 0;
  for (const Triangle& t : kept.triangles) {
    Point p[3];
    int cmin = grid.width, cmax = 0, rmin = grid.height, rmax = 0;
    for (int k = 0; k < 3; ++k) {
      const auto [c, r] = cells.of_vertex[t[k]];
      p[k] = lattice(grid, c, r);
      cmin = std::min(cmin, c), cmax = std::max(cmax, c), rmin = std::min(rmin, r), rmax = std::max(rmax, r);
    }
    for (int r = rmin; r <= rmax; ++r) {
      for (int c = cmin; c <= cmax; ++c) {
        if (grid.valid(c, r)) continue;
        const auto side = K::Triangle_2(p[0], p[1], p[2]).bounded_side(lattice(grid, c, r));
        if (side == CGAL::ON_UNBOUNDED_SIDE) continue;
        ++covered_nodata;
        bool near = false;
        for (int dr = -2; dr <= 2 && !near; ++dr)
          for (int dc = -2; dc <= 2 && !near; ++dc)
            near = c + dc >= 0 && r + dr >= 0 && c + dc < grid.width && r + dr < grid.height &&
                   grid.valid(c + dc, r + dr) && std::hypot(dc * grid.cell_x, dr * grid.cell_y) <= limit;
        if (!near) ++bridged_far;
      }
    }
  }
  EXPECT_GT(covered_nodata, 0u);  // single missing cells are bridged
  EXPECT_EQ(bridged_far, 0u);
}

TEST(Xy3Delaunay, ConservativeDiagonalIsTheUpperSurface) {
  const Grid& grid = testkit::nrw_crop();
  const Mesh mesh = triangulate_xy3(grid);
  // Brute force: for each square, the centre height of our split is the max of both splits'.
  std::map<Edge, int> diagonal_count;
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) diagonal_count[undirected(t[k], t[(k + 1) % 3])]++;
  size_t wrong = 0;
  for (int r = 0; r + 1 < grid.height; ++r) {
    for (int c = 0; c + 1 < grid.width; ++c) {
      const uint32_t a = r * grid.width + c, b = a + 1, d = a + grid.width, cc = d + 1;
      const double ac = mesh.vertices[a].z + mesh.vertices[cc].z, bd = mesh.vertices[b].z + mesh.vertices[d].z;
      const bool has_ac = diagonal_count.count(undirected(a, cc)), has_bd = diagonal_count.count(undirected(b, d));
      if (has_ac == has_bd || (has_ac && ac < bd) || (has_bd && bd < ac)) ++wrong;
    }
  }
  EXPECT_EQ(wrong, 0u);
}

TEST(Xy3Delaunay, EmptyGridGivesEmptyMeshAndBadOptionsThrow) {
  Grid empty(4, 4, 0, 4, 1, 1);
  EXPECT_TRUE(triangulate_xy3(empty).triangles.empty());
  MeshOptions negative;
  negative.max_edge_length = -1;
  EXPECT_THROW(triangulate_xy3(testkit::nrw_crop(), negative), ArgumentError);
}

// ---- out of core: band by band ----------------------------------------------------------------

// Band by band, with windows that each hold a few dozen rows, the mesh is the whole grid's:
// the same vertices bit for bit, the same triangles. On Delft's holes the border triangulation
// is full of cocircular ties that a window of other points would break otherwise than the whole.
TEST(Xy3Streamed, BandsGiveTheWholeGridsMesh) {
  for (const Grid* grid : {&testkit::delft_grid(), &testkit::nrw_crop()}) {
    const Grid holes = grid == &testkit::nrw_crop() ? with_holes_below(*grid, 113.0f) : *grid;
    const Mesh whole = triangulate_xy3(holes);
    for (int band : {7, 40, 0}) {
      SCOPED_TRACE("band " + std::to_string(band));
      MeshOptions options;
      options.band_rows = band;
      testkit::CountingSource source(holes);
      Mesh streamed;
      MeshCollector sink(streamed);
      const MeshStreamResult result = triangulate_xy3(source, sink, options);
      ASSERT_EQ(streamed.vertices.size(), whole.vertices.size());
      EXPECT_EQ(std::memcmp(streamed.vertices.data(), whole.vertices.data(), whole.vertices.size() * sizeof(Vertex)),
                0);
      EXPECT_EQ(testkit::triangle_set(streamed.triangles), testkit::triangle_set(whole.triangles));
      EXPECT_EQ(result.triangles, whole.triangles.size());
      if (band == 7) EXPECT_LT(source.largest_rows, holes.height / 3);
    }
  }
}

// Found by fuzz/fuzz_pipeline (UBSan): --max-edge 1e6 over 1 m cells asked for a halo of 1e18
// rows, cast to an int. More rows than the grid has are the whole grid: one band, the same mesh.
TEST(Xy3Streamed, AHaloBeyondTheGridIsTheWholeGrid) {
  Grid column(1, 64, -1e6, 0, 1, 1);
  for (int r = 0; r < 64; ++r) column.z[column.index(0, r)] = 100.0f + r % 3;
  Grid square(5, 9, 350000, 5600000, 1, 1);
  for (size_t i = 0; i < square.z.size(); ++i) square.z[i] = 100.0f + float(i % 7);
  for (const Grid* grid : {&column, &square}) {
    for (int band : {0, 3, std::numeric_limits<int>::max()}) {
      MeshOptions options;
      options.max_edge_length = 1e6;
      options.band_rows = band;
      const Mesh whole = triangulate_xy3(*grid, options);
      Mesh streamed;
      MeshCollector sink(streamed);
      GridView view(*grid);
      const MeshStreamResult result = triangulate_xy3(view, sink, options);
      EXPECT_EQ(result.bands, 1u);
      ASSERT_EQ(streamed.vertices.size(), whole.vertices.size());
      EXPECT_EQ(testkit::triangle_set(streamed.triangles), testkit::triangle_set(whole.triangles));
    }
  }
}
