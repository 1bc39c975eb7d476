// libFuzzer target: the pipeline in memory (issue 21, point 2). The input decodes, through
// FuzzedDataProvider, into a small Grid (1-64 cells a side, nodata anywhere, heights that may be
// extreme: +-FLT_MAX, 1e20, sentinels, denormals, infinities; origins up to 1e300 and cell sizes
// tiny, huge, zero or negative) and random option values, which then go through the stages as
// `dsmplan mesh`, `simplify` and `plan` call them (src/tools/mesh_dsm.cpp, simplify_mesh.cpp,
// plan_path.cpp): resample() (--res), triangulate_xy3() and its band-by-band twin, simplify_paper()
// (variant1, variant2) or simplify_bounded() (two-sided or --conservative, tiled or --delaunay),
// and plan_path() (prm or rrtconnect) on the mesh, or on the mesh held to the DSM's columns as
// `plan --dsm` does.
//
// A dsmplan::Error is the expected refusal of a grid or an option. Anything else is a finding:
// a crash, a sanitizer report, another exception, more than 10 s, and every output that fails
// its own guarantee, checked here by brute force (the grids are tiny) and then __builtin_trap():
//   mesh      every index in range, coordinates finite, one vertex a valid cell at its centre
//             with z = quantize_height(z, zstep) exactly, triangles counter-clockwise, 2.5D
//             (check_2_5d()), empty circumcircles (exact lattice arithmetic), every valid cell
//             covered with max_edge inf; the band-by-band mesh the same vertices and triangles;
//   simplify  vertices at cell centres, 2.5D; bounded: |mesh - dsm| <= E at every valid cell
//             centre (0 <= mesh - dsm <= E conservative), every valid cell covered, and the
//             error the stream reports equal to the one measured here; the paper's variants:
//             survivors are input vertices, and every removed co-linear vertex is within dz of
//             the new surface (the guarantee of the restore step);
//   plan      a solved path starts and ends at the waypoints and passes through each in order,
//             every segment keeps the safety distance from every triangle (the exact distance
//             against all triangles, not the index), no point of it is above max_agl over the
//             ground; with the DSM's columns, column_clearance() >= safety - 1 cm as plan_path.cpp
//             demands of what it writes.
// Option values are drawn in the CLI's ranges and beyond; the planner's amount of work (samples,
// RRT samples, the query-time refinement's bounds) is kept small, since a large one is slow by
// request, not a bug (see plan_on()).
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <map>
#include <set>
#include <vector>

#include "dsmplan/columns.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/simplify_streamed.hpp"

using namespace dsmplan;

namespace {

bool verbose() {
  static const bool on = std::getenv("DSMPLAN_FUZZ_VERBOSE") != nullptr;
  return on;
}

// A broken guarantee: say which, then stop the way libFuzzer records.
[[noreturn]] void violated(const char* what, double a = NAN, double b = NAN) {
  std::fprintf(stderr, "fuzz_pipeline: guarantee broken: %s (%.17g, %.17g)\n", what, a, b);
  __builtin_trap();
}
#define REQUIRE(cond, what, ...)                \
  do {                                          \
    if (!(cond)) violated(what, ##__VA_ARGS__); \
  } while (0)

// A double drawn mostly from values that matter, sometimes any bit pattern.
double pick(FuzzedDataProvider& in, std::initializer_list<double> table) {
  const size_t k = in.ConsumeIntegralInRange<size_t>(0, table.size());
  if (k < table.size()) return table.begin()[k];
  return in.ConsumeFloatingPoint<double>();
}

float pick_height(FuzzedDataProvider& in, float base, float step) {
  switch (in.ConsumeIntegralInRange<int>(0, 15)) {
    case 0:
      return Grid::nodata;
    case 1: {
      static const float extreme[] = {FLT_MAX, -FLT_MAX,     1e20f,         -1e20f,   1e15f,     -9999.f,
                                      1e5f,    -1e5f,        100001.f,      -32768.f, 0.f,       -0.f,
                                      FLT_MIN, FLT_TRUE_MIN, -FLT_TRUE_MIN, INFINITY, -INFINITY, 3.4e38f};
      return extreme[in.ConsumeIntegralInRange<size_t>(0, std::size(extreme) - 1)];
    }
    case 2:
      return in.ConsumeFloatingPoint<float>();
    default:  // a surface: the base plus whole steps (roofs, walls, streets)
      return base + step * in.ConsumeIntegralInRange<int>(-40, 40);
  }
}

Grid make_grid(FuzzedDataProvider& in) {
  const int w = in.ConsumeIntegralInRange<int>(1, 64), h = in.ConsumeIntegralInRange<int>(1, 64);
  const double x0 = pick(in, {0, 500000, 5.7e6, -1e6, 1e9, -1e9, 1.5e9, 1e16, 1e300, -1e300, 0.25});
  const double y0 = pick(in, {0, 5.7e6, 1000, -5e6, 1e9, 1e9 + 0.5, 1e16, 1e300, -1e300});
  const double cx = pick(in, {1, 0.5, 0.1, 2, 25, 1e-3, 1e-6, 1e-9, 1e-12, 1e6, 1e9, 0, -1, 1e300, 5e-324});
  const double cy = in.ConsumeBool() ? cx : pick(in, {1, 0.5, 0.1, 2, 1e-6, 1e6, 0, -1, 1e-300});
  Grid grid(w, h, x0, y0, cx, cy);
  const float base = static_cast<float>(pick(in, {0, 100, 35.5, -400, 8848, 1e5, -1e5, 99990}));
  const float step = static_cast<float>(pick(in, {0.1, 1, 0.5, 10, 0, 3, 1e-3, 1e4}));
  // How the rest of the input fills the cells: each cell drawn (a rough surface), or runs of
  // one height (flat roofs and streets, where simplification removes most).
  const bool runs = in.ConsumeBool();
  float run_z = base;
  for (float& z : grid.z) {
    if (!runs || in.ConsumeIntegralInRange<int>(0, 7) == 0) run_z = pick_height(in, base, step);
    z = run_z;
    if (in.remaining_bytes() == 0) break;  // the rest keeps the last height (or nodata)
  }
  return grid;
}

// ---- measuring a mesh against its grid in lattice units -------------------------------------

struct Lattice {
  std::vector<int> col, row;  // per vertex
};

// Every vertex at a cell centre of `grid` (its lattice position); a finding otherwise.
Lattice lattice_of(const Mesh& mesh, const Grid& grid) {
  Lattice l;
  for (const Vertex& v : mesh.vertices) {
    REQUIRE(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z), "vertex not finite", v.x, v.z);
    const double u = (v.x - grid.x0) / grid.cell_x - 0.5, r = (grid.y0 - v.y) / grid.cell_y - 0.5;
    const double cu = std::round(u), cr = std::round(r);
    REQUIRE(std::abs(u - cu) < 1e-3 && std::abs(r - cr) < 1e-3, "vertex not at a cell centre", u, r);
    REQUIRE(cu >= 0 && cu < grid.width && cr >= 0 && cr < grid.height, "vertex outside the grid", u, r);
    l.col.push_back(static_cast<int>(cu));
    l.row.push_back(static_cast<int>(cr));
  }
  return l;
}

// In x,y orientation (x east, y north): twice the signed area in cells.
int64_t orient(const Lattice& l, uint32_t a, uint32_t b, uint32_t c) {
  const int64_t ux = l.col[b] - l.col[a], uy = l.row[a] - l.row[b];
  const int64_t vx = l.col[c] - l.col[a], vy = l.row[a] - l.row[c];
  return ux * vy - uy * vx;
}

void check_indices_and_orientation(const Mesh& mesh, const Lattice& l) {
  for (const Triangle& t : mesh.triangles) {
    for (uint32_t i : t) REQUIRE(i < mesh.vertices.size(), "triangle index out of range", i, mesh.vertices.size());
    REQUIRE(orient(l, t[0], t[1], t[2]) > 0, "triangle not counter-clockwise from above",
            double(orient(l, t[0], t[1], t[2])));
  }
  try {
    check_2_5d(mesh, "fuzz");
  } catch (const Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    violated("check_2_5d refuses a mesh the library made");
  }
}

// The mesh's height over each cell centre: lowest and highest of the triangles that hold it
// (they agree on shared edges), NaN where none does. Exact barycentric weights in lattice units.
struct Surface {
  std::vector<double> low, high;
};
Surface surface_at_centres(const Mesh& mesh, const Lattice& l, const Grid& grid) {
  Surface s{std::vector<double>(grid.cells(), NAN), std::vector<double>(grid.cells(), NAN)};
  for (const Triangle& t : mesh.triangles) {
    const int64_t area = orient(l, t[0], t[1], t[2]);
    const int c0 = std::min({l.col[t[0]], l.col[t[1]], l.col[t[2]]}),
              c1 = std::max({l.col[t[0]], l.col[t[1]], l.col[t[2]]});
    const int r0 = std::min({l.row[t[0]], l.row[t[1]], l.row[t[2]]}),
              r1 = std::max({l.row[t[0]], l.row[t[1]], l.row[t[2]]});
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        int64_t w[3];
        for (int k = 0; k < 3; ++k) {
          const uint32_t a = t[(k + 1) % 3], b = t[(k + 2) % 3];  // the edge opposite corner k
          const int64_t ux = l.col[b] - l.col[a], uy = l.row[a] - l.row[b];
          const int64_t vx = c - l.col[a], vy = l.row[a] - r;
          w[k] = ux * vy - uy * vx;
        }
        if (w[0] < 0 || w[1] < 0 || w[2] < 0) continue;
        double z = 0;
        for (int k = 0; k < 3; ++k) z += double(w[k]) * mesh.vertices[t[k]].z;
        z /= double(area);
        const size_t i = grid.index(c, r);
        s.low[i] = std::isnan(s.low[i]) ? z : std::min(s.low[i], z);
        s.high[i] = std::isnan(s.high[i]) ? z : std::max(s.high[i], z);
      }
    }
  }
  return s;
}

double tolerance_of(const Grid& grid) {
  const GridSummary summary = summarize(grid);
  const double top = std::max({1.0, std::abs(summary.z_min), std::abs(summary.z_max)});
  return 1e-9 * top;
}

// ---- the stages ------------------------------------------------------------------------------

void check_xy3(const Mesh& mesh, const Grid& grid, const MeshOptions& options) {
  const Lattice l = lattice_of(mesh, grid);
  check_indices_and_orientation(mesh, l);
  // One vertex a valid cell, row-major, with its quantized height exactly.
  const HeightQuantizer quantize(options.zstep);
  size_t v = 0;
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      if (!grid.valid(c, r)) continue;
      REQUIRE(v < mesh.vertices.size(), "fewer vertices than valid cells", v);
      REQUIRE(l.col[v] == c && l.row[v] == r, "vertex not at the next valid cell", l.col[v], c);
      REQUIRE(mesh.vertices[v].z == quantize(grid.at(c, r)), "vertex height not the cell's quantized height",
              mesh.vertices[v].z, grid.at(c, r));
      ++v;
    }
  }
  REQUIRE(v == mesh.vertices.size(), "more vertices than valid cells", v, mesh.vertices.size());
  // Exactly the triangles with no edge longer than max_edge_length kept: every kept one short.
  const double limit = max_edge_length(grid, options);
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const Vertex &a = mesh.vertices[t[k]], &b = mesh.vertices[t[(k + 1) % 3]];
      REQUIRE(std::hypot(a.x - b.x, a.y - b.y) <= limit * (1 + 1e-12), "triangle edge longer than max_edge",
              std::hypot(a.x - b.x, a.y - b.y), limit);
    }
  // Empty circumcircles in x,y: for lattice points scaled by the cell sizes the in-circle
  // determinant is cx cy (cx^2 D1 + cy^2 D2), D1 and D2 exact in integers.
  if (mesh.triangles.size() * mesh.vertices.size() <= 400000) {
    const double cx2 = grid.cell_x * grid.cell_x, cy2 = grid.cell_y * grid.cell_y;
    for (const Triangle& t : mesh.triangles) {
      for (size_t p = 0; p < mesh.vertices.size(); ++p) {
        if (p == t[0] || p == t[1] || p == t[2]) continue;
        int64_t a[3], b[3];
        for (int k = 0; k < 3; ++k) a[k] = l.col[t[k]] - l.col[p], b[k] = l.row[p] - l.row[t[k]];
        auto det3 = [&](const int64_t* m) {  // det [a b m]
          return a[0] * (b[1] * m[2] - b[2] * m[1]) - a[1] * (b[0] * m[2] - b[2] * m[0]) +
                 a[2] * (b[0] * m[1] - b[1] * m[0]);
        };
        const int64_t aa[3] = {a[0] * a[0], a[1] * a[1], a[2] * a[2]}, bb[3] = {b[0] * b[0], b[1] * b[1], b[2] * b[2]};
        const long double d1 = det3(aa), d2 = det3(bb);
        const long double in = cx2 * d1 + cy2 * d2, scale = cx2 * std::abs(d1) + cy2 * std::abs(d2);
        REQUIRE(!(in > 1e-12L * scale), "a vertex inside a triangle's circumcircle", double(p), double(in / scale));
      }
    }
  }
  // With every triangle kept, the triangles tile the convex hull: every valid cell is covered
  // unless the valid cells are collinear (no triangle at all).
  if (std::isinf(options.max_edge_length) && !mesh.triangles.empty()) {
    const Surface s = surface_at_centres(mesh, l, grid);
    for (size_t i = 0; i < grid.cells(); ++i)
      if (!std::isnan(grid.z[i])) REQUIRE(!std::isnan(s.low[i]), "valid cell uncovered with max_edge inf", double(i));
  }
}

using TriangleSet = std::set<std::array<uint32_t, 3>>;
TriangleSet canonical(const std::vector<Triangle>& triangles) {
  TriangleSet set;
  for (Triangle t : triangles) {
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    set.insert(t);
  }
  return set;
}

// The band-by-band mesh (mesh --stream) must be the same mesh.
void check_streamed(const Mesh& whole, const Grid& grid, MeshOptions options, FuzzedDataProvider& in) {
  if (!std::isfinite(max_edge_length(grid, options))) return;
  options.band_rows = in.ConsumeBool() ? in.ConsumeIntegral<int>() : in.ConsumeIntegralInRange<int>(0, 70);
  Mesh banded;
  MeshCollector sink(banded);
  GridView view(grid);
  try {
    (void)triangulate_xy3(view, sink, options);
  } catch (const Error& e) {
    if (verbose()) std::fprintf(stderr, "streamed: %s\n", e.what());
    violated("the band-by-band mesh refused what the whole-grid mesh made");
  }
  REQUIRE(banded.vertices.size() == whole.vertices.size(), "band-by-band vertex count differs", banded.vertices.size(),
          whole.vertices.size());
  for (size_t i = 0; i < whole.vertices.size(); ++i)
    REQUIRE(banded.vertices[i].x == whole.vertices[i].x && banded.vertices[i].y == whole.vertices[i].y &&
                banded.vertices[i].z == whole.vertices[i].z,
            "band-by-band vertex differs", double(i));
  REQUIRE(canonical(banded.triangles) == canonical(whole.triangles), "band-by-band triangles differ",
          banded.triangles.size(), whole.triangles.size());
}

void check_bounded(const Mesh& mesh, const Grid& grid, const BoundedSimplifyOptions& options,
                   const VerticalError& reported) {
  const Lattice l = lattice_of(mesh, grid);
  check_indices_and_orientation(mesh, l);
  const Surface s = surface_at_centres(mesh, l, grid);
  const double tol = tolerance_of(grid);
  VerticalError measured;
  for (size_t i = 0; i < grid.cells(); ++i) {
    if (std::isnan(grid.z[i])) continue;
    REQUIRE(!std::isnan(s.low[i]), "bounded: a valid cell centre is uncovered", double(i));
    REQUIRE(s.high[i] - s.low[i] <= tol, "bounded: triangles disagree over a cell centre", s.low[i], s.high[i]);
    const double above = s.high[i] - grid.z[i], below = grid.z[i] - s.low[i];
    measured.max_above = std::max(measured.max_above, above);
    measured.max_below = std::max(measured.max_below, below);
    REQUIRE(above <= options.max_error + tol, "bounded: mesh above the DSM by more than max_error", above,
            options.max_error);
    REQUIRE(below <= (options.conservative ? tol : options.max_error + tol),
            "bounded: mesh below the DSM beyond the bound", below, options.max_error);
  }
  REQUIRE(reported.uncovered == 0, "bounded: reported uncovered cells", reported.uncovered);
  REQUIRE(std::abs(reported.max_above - measured.max_above) <= tol, "bounded: reported max_above is not the mesh's",
          reported.max_above, measured.max_above);
  REQUIRE(std::abs(reported.max_below - measured.max_below) <= tol, "bounded: reported max_below is not the mesh's",
          reported.max_below, measured.max_below);
}

void check_paper(const Mesh& input, const Grid& grid, const PaperSimplifyOptions& options,
                 const PaperSimplifyResult& result) {
  const Mesh& mesh = result.mesh;
  const Lattice l = lattice_of(mesh, grid), li = lattice_of(input, grid);
  check_indices_and_orientation(mesh, l);
  // Survivors are input vertices, unchanged, in their input order.
  std::map<std::pair<int, int>, size_t> input_at;
  for (size_t i = 0; i < input.vertices.size(); ++i) input_at[{li.col[i], li.row[i]}] = i;
  std::vector<char> kept(input.vertices.size(), 0);
  size_t last = 0;
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    const auto it = input_at.find({l.col[v], l.row[v]});
    REQUIRE(it != input_at.end(), "paper: an output vertex that is no input vertex", double(v));
    const Vertex& was = input.vertices[it->second];
    REQUIRE(was.x == mesh.vertices[v].x && was.y == mesh.vertices[v].y && was.z == mesh.vertices[v].z,
            "paper: a survivor moved", double(v));
    REQUIRE(v == 0 || it->second > last, "paper: survivors out of input order", double(v));
    last = it->second;
    kept[it->second] = 1;
  }
  // Restored co-linear vertices count as kept, not as removed.
  REQUIRE(input.vertices.size() - mesh.vertices.size() == result.removed_coplanar + result.removed_colinear,
          "paper: removed counts do not add up", input.vertices.size() - mesh.vertices.size(),
          result.removed_coplanar + result.removed_colinear);
  // Every removed co-linear vertex lies on the new surface within dz (else it is put back).
  const std::vector<VertexMark> marks = mark_paper(input, options);
  const Surface s = surface_at_centres(mesh, l, grid);
  const double tol = tolerance_of(grid);
  for (size_t v = 0; v < input.vertices.size(); ++v) {
    if (marks[v] != VertexMark::Colinear || kept[v]) continue;
    const size_t i = grid.index(li.col[v], li.row[v]);
    REQUIRE(!std::isnan(s.low[i]), "paper: a removed co-linear vertex is left uncovered", double(v));
    const double z = input.vertices[v].z;
    REQUIRE(s.high[i] - z <= options.dz + 1e-9 + tol && z - s.low[i] <= options.dz + 1e-9 + tol,
            "paper: a removed co-linear vertex is off the surface by more than dz", s.low[i] - z, s.high[i] - z);
  }
}

// ---- planning -------------------------------------------------------------------------------

void check_path(const PlanResult& result, const std::vector<Point3>& waypoints, const Mesh& mesh,
                const ClearanceIndex& index, const PlanOptions& plan, const GroundGrid& ground, const Grid* columns,
                double column_safety) {
  const std::vector<Point3>& path = result.path;
  REQUIRE(path.size() >= 2, "plan: a solved path of fewer than two points", path.size());
  REQUIRE(path.front() == waypoints.front() && path.back() == waypoints.back(),
          "plan: path does not start and end at the waypoints");
  size_t next = 0;
  for (const Point3& p : path) {
    for (double c : p) REQUIRE(std::isfinite(c), "plan: a path point is not finite", c);
    if (next < waypoints.size() && p == waypoints[next]) ++next;
  }
  REQUIRE(next == waypoints.size(), "plan: path misses a waypoint", next, waypoints.size());
  // The exact distance of every segment to every triangle, relative to the index's origin.
  const Point3 o = index.origin();
  auto local = [&](const Point3& p) { return Point3{p[0] - o[0], p[1] - o[1], p[2] - o[2]}; };
  double scale = 1;
  for (const Vertex& v : mesh.vertices)
    scale = std::max({scale, std::abs(v.x - o[0]), std::abs(v.y - o[1]), std::abs(v.z - o[2])});
  const double tol = 1e-9 * scale;
  for (size_t k = 1; k < path.size(); ++k) {
    const Point3 p = local(path[k - 1]), q = local(path[k]);
    for (const Triangle& t : mesh.triangles) {
      const Vertex &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
      const double d =
          segment_triangle_distance(p, q, local({a.x, a.y, a.z}), local({b.x, b.y, b.z}), local({c.x, c.y, c.z}));
      REQUIRE(d >= plan.safety - tol, "plan: a segment closer to a triangle than the safety distance", d, plan.safety);
    }
    const double above = ground.max_height_above(path[k - 1], path[k]);
    REQUIRE(above <= plan.max_agl + tol, "plan: a segment above the ceiling", above, plan.max_agl);
    if (columns) {
      const double d = column_clearance(*columns, path[k - 1], path[k], column_safety);
      REQUIRE(d >= column_safety - 0.01, "plan: a segment closer to the DSM's columns than the safety distance", d,
              column_safety);
    }
  }
}

void plan_on(const Mesh& input, const Grid& grid, FuzzedDataProvider& in) {
  if (input.triangles.empty()) return;
  Mesh mesh = input;
  PlanOptions plan;
  plan.threads = 1;
  plan.planner = in.ConsumeBool() ? PlannerKind::prm : PlannerKind::rrt_connect;
  double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY, zmin = INFINITY, zmax = -INFINITY;
  for (const Vertex& v : mesh.vertices) {
    xmin = std::min(xmin, v.x), xmax = std::max(xmax, v.x), ymin = std::min(ymin, v.y), ymax = std::max(ymax, v.y);
    zmin = std::min(zmin, v.z), zmax = std::max(zmax, v.z);
  }
  const double extent = std::max({xmax - xmin, ymax - ymin, grid.cell_x, grid.cell_y});
  // Lengths relative to the site, sometimes the CLI's absolute values or beyond its ranges.
  plan.safety = pick(in, {0, 2, 0.1 * extent, 0.01 * extent, 0.3 * extent, 1000, 1e-9, -1, NAN});
  plan.max_agl = pick(in, {120, 2 * (zmax - zmin) + 3 * plan.safety + 1, 0.5 * extent, 10, 1e5, 1e-3, 0, INFINITY});
  const double volume = std::max(xmax - xmin, grid.cell_x) * std::max(ymax - ymin, grid.cell_y) *
                        (std::isfinite(plan.max_agl) ? std::max(plan.max_agl, 0.0) : 1.0);
  const double samples = in.ConsumeIntegralInRange<int>(1, 400);
  plan.spacing = in.ConsumeIntegralInRange<int>(0, 15) == 0 ? pick(in, {20, 1e4, 1e5, 0, -1})
                                                            : std::max(std::cbrt(volume / samples), 1e-3);
  plan.max_edge = plan.spacing * pick(in, {1.725, 1, 3, 0.5, 0.1, 10});
  plan.spacing = std::min(plan.spacing, 1e4 + (in.ConsumeBool() ? 1 : 0));
  // The roadmap's sample count (build_roadmap()): beyond a few thousand the run is slow by
  // request, not by a bug.
  if (plan.spacing > 0 && volume / std::pow(plan.spacing, 3) > 4000) return;
  // Refinement on, its work bounded as the samples are: at its default bounds (2 million
  // lattice nodes a search, 1e8 candidate edges a leg) a search is slow by request, not by a
  // bug (43 s under ASan on a 3 x 26-cell grid of 25 x 1e6 m cells, 5.6 million nodes).
  plan.refine_rounds = in.ConsumeIntegralInRange<int>(0, 8);
  plan.refine_max_lattice_nodes = 20000;
  plan.refine_max_samples = 20000;
  plan.refine_max_search_work = 300000;
  plan.connections = in.ConsumeIntegralInRange<int>(0, 12);
  plan.smooth = in.ConsumeBool();
  plan.spline = in.ConsumeBool();
  plan.rrt_max_samples = in.ConsumeIntegralInRange<int>(0, 300);
  plan.seed = in.ConsumeIntegral<uint64_t>();

  // `plan --dsm`: the mesh held to the DSM's columns (plan_path.cpp, in that order).
  const bool with_columns = in.ConsumeBool();
  Grid columns;
  const double safety = plan.safety;
  if (with_columns) {
    columns = grid;
    fill_holes_from_rim(columns, RimHeight::highest);
    plan.ground = std::make_shared<GroundGrid>(grid);
    plan.safety += column_margin(mesh, grid);
    const Mesh holes = hole_columns(grid, columns);
    const uint32_t offset = static_cast<uint32_t>(mesh.vertices.size());
    mesh.vertices.insert(mesh.vertices.end(), holes.vertices.begin(), holes.vertices.end());
    for (Triangle t : holes.triangles) mesh.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  }
  const ClearanceIndex index(mesh);
  const GroundGrid& ground = plan.ground ? *plan.ground : index.floor();

  // Waypoints over the mesh, at a height above its surface (or anywhere: refusals are answers).
  std::vector<Point3> waypoints(in.ConsumeIntegralInRange<int>(2, 4));
  for (Point3& w : waypoints) {
    w[0] = xmin + in.ConsumeProbability<double>() * (xmax - xmin);
    w[1] = ymin + in.ConsumeProbability<double>() * (ymax - ymin);
    const double surface = index.ground(w[0], w[1]);
    const double up = pick(
        in, {safety + 1, 2 * safety + 1, 0.5 * (std::isfinite(plan.max_agl) ? plan.max_agl : 100), 0, 0.2 * extent});
    w[2] = (std::isnan(surface) ? zmax : surface) + up;
  }
  if (with_columns)  // plan_path.cpp refuses these before planning (refuse_near_columns)
    for (const Point3& w : waypoints)
      if (column_clearance(columns, w, w, safety) < safety) return;
  const PlanResult result = plan_path(index, waypoints, plan);
  if (verbose())
    std::fprintf(stderr, "plan: status %d, %zu points, %zu lattice nodes, samples %.17g, rounds %d: %s\n",
                 int(result.status), result.path.size(), result.lattice_nodes, volume / std::pow(plan.spacing, 3),
                 plan.refine_rounds, result.reason.c_str());
  if (result.status == PlanStatus::Solved)
    check_path(result, waypoints, mesh, index, plan, ground, with_columns ? &columns : nullptr, safety);
}

void pipeline(FuzzedDataProvider& in) {
  Grid grid = make_grid(in);
  if (verbose()) {
    const GridSummary summary = summarize(grid);
    std::fprintf(stderr, "grid %d x %d, corner %.17g %.17g, cells %.17g x %.17g, z %.17g to %.17g\n", grid.width,
                 grid.height, grid.x0, grid.y0, grid.cell_x, grid.cell_y, summary.z_min, summary.z_max);
  }
  // mesh --res R --resampling M
  if (in.ConsumeIntegralInRange<int>(0, 3) == 0) {
    const double res = pick(in, {2 * grid.cell_x, 3 * grid.cell_x, 1.5 * grid.cell_x, grid.cell_x, 0.5 * grid.cell_x,
                                 64 * grid.cell_x, 1e300, 0, -1, NAN});
    const Resampling method = static_cast<Resampling>(in.ConsumeIntegralInRange<int>(0, 4));
    if (verbose()) std::fprintf(stderr, "resample to %.17g by %s\n", res, to_string(method));
    grid = resample(grid, res, method);
    REQUIRE(grid.width >= 1 && grid.height >= 1 && grid.cells() == size_t(grid.width) * size_t(grid.height),
            "resample: a grid whose size does not match its cells", grid.width, grid.height);
  }
  MeshOptions mesh_options;
  mesh_options.zstep = pick(in, {0.1, 0, 0.01, 1, 100, 100.5, -1, 1e-300, 5e-324, INFINITY, NAN, 0.25});
  mesh_options.max_edge_length =
      pick(in, {0, INFINITY, 2.5 * grid.cell_x, 1.5 * grid.cell_x, 1e6, 1e6 + 1, -1, NAN, 1e-9, 100 * grid.cell_x});
  const int stage = in.ConsumeIntegralInRange<int>(0, 2);  // simplify: 0 none, 1 paper, 2 bounded
  if (verbose())
    std::fprintf(stderr, "mesh: zstep %.17g, max_edge %.17g\n", mesh_options.zstep, mesh_options.max_edge_length);
  Mesh mesh;
  if (stage != 2) {
    mesh = triangulate_xy3(grid, mesh_options);
    check_xy3(mesh, grid, mesh_options);
    if (in.ConsumeBool()) check_streamed(mesh, grid, mesh_options, in);
  }
  if (stage == 1) {
    PaperSimplifyOptions options;
    options.variant = in.ConsumeBool() ? PaperVariant::One : PaperVariant::Two;
    options.dz = pick(in, {0.4, 0, 1, 1000, 1000.5, -1, NAN, 1e-9, 10});
    options.dco = pick(in, {1e-5, 0, 1e-3, 1, 1000, -1, NAN, INFINITY});
    if (verbose())
      std::fprintf(stderr, "%s: dz %.17g, dco %.17g\n", to_string(options.variant), options.dz, options.dco);
    const PaperSimplifyResult result = simplify_paper(mesh, options);
    check_paper(mesh, grid, options, result);
    mesh = result.mesh;
  } else if (stage == 2) {
    BoundedSimplifyOptions options;
    options.max_error = pick(in, {0.4, 0.001, 0.1, 1, 10, 10000, 1e-4, 10001, 0, -1, NAN, INFINITY});
    options.conservative = in.ConsumeBool();
    options.delaunay = in.ConsumeBool();
    options.tile_size = in.ConsumeIntegralInRange<int>(-1, 20);
    options.block_tiles = in.ConsumeIntegralInRange<int>(-1, 4);
    options.threads = 1;
    if (verbose())
      std::fprintf(stderr, "bounded: max_error %.17g%s%s, tile %d, block %d\n", options.max_error,
                   options.conservative ? ", conservative" : "", options.delaunay ? ", delaunay" : "",
                   options.tile_size, options.block_tiles);
    if (in.ConsumeBool()) {  // as simplify_job() runs it: a GridView streamed into a collector
      GridView view(grid);
      MeshCollector sink(mesh);
      const BoundedStreamResult result = simplify_bounded(view, options, sink);
      check_bounded(mesh, grid, options, result.error);
    } else {
      mesh = simplify_bounded(grid, options);
      check_bounded(mesh, grid, options, certify(mesh, grid));
    }
  }
  if (in.ConsumeBool()) plan_on(mesh, grid, in);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  try {
    pipeline(in);
  } catch (const Error& e) {
    // The expected answer to a grid or an option the stages cannot work with.
    if (verbose()) std::fprintf(stderr, "refused: %s\n", e.what());
  }
  return 0;
}
