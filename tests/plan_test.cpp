// Plan stage, the validity checker: segment_triangle_distance() against cases solved by hand and
// two independent oracles (dense sampling, an upper bound; a convex 1D minimization of an
// independently written point-triangle distance), and ClearanceIndex against brute force over
// every triangle of real meshes (the NRW crop at 2 m, as meshed and as simplified).
#include "dsmplan/plan.hpp"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>
#include <xxhash.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <queue>
#include <random>
#include <set>
#include <tuple>

#include "dsmplan/columns.hpp"
#include "dsmplan/corridor.hpp"
#include "dsmplan/flight.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/roadmap_file.hpp"
#include "dsmplan/simplify.hpp"
#include "street_point.hpp"
#include "testkit.hpp"

using namespace dsmplan;

namespace {

double dist(const Point3& a, const Point3& b) { return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }
Point3 lerp(const Point3& a, const Point3& b, double t) {
  return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

// ---- oracles, written without the library's formulas ------------------------------------

// Upper bound: the closest pair among n samples of the segment and a barycentric lattice of
// m steps on the triangle.
double sampled_distance(const Point3& p, const Point3& q, const Point3& a, const Point3& b, const Point3& c, int n,
                        int m) {
  double best = INFINITY;
  for (int i = 0; i <= n; ++i) {
    const Point3 s = lerp(p, q, n ? double(i) / n : 0);
    for (int j = 0; j <= m; ++j)
      for (int k = 0; j + k <= m; ++k) {
        const double u = double(j) / m, v = double(k) / m;
        const Point3 t{a[0] + u * (b[0] - a[0]) + v * (c[0] - a[0]), a[1] + u * (b[1] - a[1]) + v * (c[1] - a[1]),
                       a[2] + u * (b[2] - a[2]) + v * (c[2] - a[2])};
        best = std::min(best, dist(s, t));
      }
  }
  return best;
}

// Point to segment by golden-section search on the (convex) distance along it.
template <class F>
double golden_min(F&& f, int iterations = 80) {
  double lo = 0, hi = 1;
  const double g = (std::sqrt(5.0) - 1) / 2;
  double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo), f1 = f(x1), f2 = f(x2);
  for (int i = 0; i < iterations; ++i) {
    if (f1 < f2) {
      hi = x2, x2 = x1, f2 = f1, x1 = hi - g * (hi - lo), f1 = f(x1);
    } else {
      lo = x1, x1 = x2, f1 = f2, x2 = lo + g * (hi - lo), f2 = f(x2);
    }
  }
  return std::min({f1, f2, f(0), f(1)});
}

// Point to triangle: projection onto the plane when it falls inside (tested by sub-areas),
// else the nearest edge (each by golden section).
double oracle_point_triangle(const Point3& s, const Point3& a, const Point3& b, const Point3& c) {
  auto edge = [&](const Point3& u, const Point3& w) {
    return golden_min([&](double t) { return dist(s, lerp(u, w, t)); });
  };
  double best = std::min({edge(a, b), edge(b, c), edge(c, a)});
  const Point3 ab{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ac{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const Point3 n{ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2], ab[0] * ac[1] - ab[1] * ac[0]};
  const double nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
  if (nn > 1e-20) {
    const double h = ((s[0] - a[0]) * n[0] + (s[1] - a[1]) * n[1] + (s[2] - a[2]) * n[2]) / nn;
    const Point3 r{s[0] - h * n[0], s[1] - h * n[1], s[2] - h * n[2]};
    auto side = [&](const Point3& u, const Point3& w) {
      const Point3 e{w[0] - u[0], w[1] - u[1], w[2] - u[2]}, f{r[0] - u[0], r[1] - u[1], r[2] - u[2]};
      return (e[1] * f[2] - e[2] * f[1]) * n[0] + (e[2] * f[0] - e[0] * f[2]) * n[1] +
             (e[0] * f[1] - e[1] * f[0]) * n[2];
    };
    if (side(a, b) >= 0 && side(b, c) >= 0 && side(c, a) >= 0) best = std::min(best, std::abs(h) * std::sqrt(nn));
  }
  return best;
}

// The distance from a point moving along the segment to a convex set is convex in the parameter.
double oracle_distance(const Point3& p, const Point3& q, const Point3& a, const Point3& b, const Point3& c) {
  return golden_min([&](double t) { return oracle_point_triangle(lerp(p, q, t), a, b, c); });
}

// ---- hand-solved cases ------------------------------------------------------------------

const Point3 A{0, 0, 0}, B{10, 0, 0}, C{0, 10, 0};

TEST(SegmentTriangleDistance, ClosedFormCases) {
  // Parallel above the face, and parallel above it reaching far beyond both sides.
  EXPECT_DOUBLE_EQ(segment_triangle_distance({1, 1, 3}, {3, 2, 3}, A, B, C), 3);
  EXPECT_DOUBLE_EQ(segment_triangle_distance({-5, 1, 3}, {20, 1, 3}, A, B, C), 3);
  // Piercing: vertical, oblique, through a corner.
  EXPECT_EQ(segment_triangle_distance({1, 1, -1}, {1, 1, 1}, A, B, C), 0);
  EXPECT_EQ(segment_triangle_distance({-1, 2, -3}, {4, 3, 5}, A, B, C), 0);
  EXPECT_EQ(segment_triangle_distance({0, 0, -1}, {0, 0, 1}, A, B, C), 0);
  // Beside an edge: parallel to it 2 away in the plane; vertical 3 away; crossing the line of
  // the hypotenuse x + y = 10 at (6, 6), a horizontal distance of 2 / sqrt(2).
  EXPECT_DOUBLE_EQ(segment_triangle_distance({2, -2, 0}, {8, -2, 0}, A, B, C), 2);
  EXPECT_DOUBLE_EQ(segment_triangle_distance({5, -3, -4}, {5, -3, 4}, A, B, C), 3);
  EXPECT_NEAR(segment_triangle_distance({6, 6, -1}, {6, 6, 1}, A, B, C), std::sqrt(2.0), 1e-14);
  // Skew over an edge: the segment (5,-4,2)-(5,4,2) passes above the face: 2.
  EXPECT_DOUBLE_EQ(segment_triangle_distance({5, -4, 2}, {5, 4, 2}, A, B, C), 2);
  // Vertical beyond corner B, in its Voronoi region: x = 12, y = -1, z in [-1, 1]: sqrt(4 + 1).
  EXPECT_NEAR(segment_triangle_distance({12, -1, -1}, {12, -1, 1}, A, B, C), std::sqrt(5.0), 1e-14);
  // An endpoint nearest a corner: (-3,-4,0) is 5 from A and the segment points away.
  EXPECT_DOUBLE_EQ(segment_triangle_distance({-3, -4, 0}, {-6, -8, 0}, A, B, C), 5);
  EXPECT_DOUBLE_EQ(segment_triangle_distance({-6, -8, 12}, {-3, -4, 0}, A, B, C), 5);
  // In the plane: inside (0), outside beside the hypotenuse.
  EXPECT_EQ(segment_triangle_distance({1, 1, 0}, {2, 3, 0}, A, B, C), 0);
  EXPECT_EQ(segment_triangle_distance({-1, 1, 0}, {20, 1, 0}, A, B, C), 0);
  EXPECT_NEAR(segment_triangle_distance({6, 6, 0}, {8, 4, 0}, A, B, C), std::sqrt(2.0), 1e-14);
}

TEST(SegmentTriangleDistance, DegenerateInput) {
  // A point: above the face, beyond a corner.
  EXPECT_DOUBLE_EQ(segment_triangle_distance({1, 1, 2}, {1, 1, 2}, A, B, C), 2);
  EXPECT_DOUBLE_EQ(segment_triangle_distance({13, -4, 0}, {13, -4, 0}, A, B, C), 5);
  // A triangle with collinear corners is a segment; with coincident ones, a point.
  const Point3 a{0, 0, 0}, b{5, 0, 0}, c{10, 0, 0};
  EXPECT_DOUBLE_EQ(segment_triangle_distance({5, 3, 4}, {5, 3, 4}, a, b, c), 5);
  EXPECT_DOUBLE_EQ(segment_triangle_distance({13, 0, 4}, {13, 0, -4}, a, b, c), 3);
  EXPECT_DOUBLE_EQ(segment_triangle_distance({2, 3, -4}, {8, 3, 4}, a, c, b), 3);
  EXPECT_EQ(segment_triangle_distance({2, -1, 0}, {2, 1, 0}, a, b, c), 0);
  EXPECT_DOUBLE_EQ(segment_triangle_distance({3, 4, 0}, {3, 4, 12}, a, a, a), 5);
  EXPECT_DOUBLE_EQ(segment_triangle_distance({3, 4, 0}, {3, 4, 0}, b, b, b), std::hypot(2.0, 4.0));
  // Both degenerate, and a near-sliver (a corner 1e-13 off the line) agrees with its edges.
  EXPECT_NEAR(segment_triangle_distance({5, 3, 4}, {5, 3, 4}, a, {5, 1e-13, 0}, c), 5, 1e-12);
}

TEST(SegmentTriangleDistance, AgreesWithOraclesOnRandomInput) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-5, 5);
  auto point = [&] { return Point3{u(rng), u(rng), u(rng)}; };
  double worst_oracle = 0;
  for (int i = 0; i < 3000; ++i) {
    Point3 p = point(), q = point(), a = point(), b = point(), c = point();
    // Mix in the hard shapes: flat triangles, parallel segments, short segments, points.
    if (i % 7 == 1) a[2] = b[2] = c[2] = 0, p[2] = q[2];
    if (i % 7 == 2) q = lerp(p, {p[0] + b[0] - a[0], p[1] + b[1] - a[1], p[2] + b[2] - a[2]}, 0.7);
    if (i % 7 == 3) q = p;
    if (i % 7 == 4) q = lerp(p, q, 1e-6);
    const double d = segment_triangle_distance(p, q, a, b, c);
    const double oracle = oracle_distance(p, q, a, b, c);
    worst_oracle = std::max(worst_oracle, std::abs(d - oracle));
    ASSERT_NEAR(d, oracle, 1e-7) << "case " << i;
    EXPECT_NEAR(d, segment_triangle_distance(q, p, b, c, a), 1e-12) << "case " << i;
    if (i % 50 == 0) {
      // Sampling only gives an upper bound; its resolution bounds how much above it may be.
      const int n = 200, m = 200;
      const double sampled = sampled_distance(p, q, a, b, c, n, m);
      const double step = dist(p, q) / n + std::max({dist(a, b), dist(b, c), dist(c, a)}) / m;
      EXPECT_LE(d, sampled + 1e-12) << "case " << i;
      EXPECT_GE(d, sampled - step) << "case " << i;
    }
  }
  RecordProperty("worst_oracle_difference", std::to_string(worst_oracle));
}

// ---- the index on real meshes ----------------------------------------------------------

const Grid& nrw_2m() {
  static const Grid grid =
      resample(read_raster(testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif")), 2.0, Resampling::Median);
  return grid;
}
const Mesh& mesh_2m() {
  static const Mesh mesh = triangulate_xy3(nrw_2m());
  return mesh;
}
const Mesh& mesh_bounded() {
  static const Mesh mesh = [] {
    BoundedSimplifyOptions options;
    options.max_error = 0.4;
    options.conservative = true;
    return simplify_bounded(nrw_2m(), options);
  }();
  return mesh;
}

// Every triangle, in the index's local coordinates (the same subtraction the index does).
struct BruteForce {
  std::vector<std::array<Point3, 3>> tris;
  Point3 origin;
  BruteForce(const Mesh& mesh, const Point3& o) : origin(o) {
    for (const Triangle& t : mesh.triangles) {
      std::array<Point3, 3> tri;
      for (int k = 0; k < 3; ++k) {
        const Vertex& v = mesh.vertices[t[k]];
        tri[k] = {v.x - o[0], v.y - o[1], v.z - o[2]};
      }
      tris.push_back(tri);
    }
  }
  Point3 local(const Point3& p) const { return {p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]}; }
  // Least squared distance over all triangles, or cap^2 when none is nearer than cap; a box
  // test (obviously conservative) only saves time.
  double min_squared(const Point3& p_, const Point3& q_, double cap) const {
    const Point3 p = local(p_), q = local(q_);
    double best = cap * cap;
    for (const auto& t : tris) {
      bool far = false;
      for (int k = 0; k < 3 && !far; ++k) {
        const double lo = std::min({t[0][k], t[1][k], t[2][k]}), hi = std::max({t[0][k], t[1][k], t[2][k]});
        far = std::min(p[k], q[k]) > hi + cap + 1e-6 || std::max(p[k], q[k]) < lo - cap - 1e-6;
      }
      if (!far) best = std::min(best, segment_triangle_squared_distance(p, q, t[0], t[1], t[2]));
    }
    return best;
  }
};

struct Query {
  Point3 p, q;
  double d;
};

// Segments near the surface, where answers are close calls: starts 0.5-8 m above ground (and
// some below it, and some beyond the mesh's edge), 0-30 m long in any direction, axis-aligned
// and vertical ones included.
std::vector<Query> random_queries(const ClearanceIndex& index, const Mesh& mesh, int count, uint64_t seed) {
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const Vertex& v : mesh.vertices)
    x0 = std::min(x0, v.x), x1 = std::max(x1, v.x), y0 = std::min(y0, v.y), y1 = std::max(y1, v.y);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(x0 - 10, x1 + 10), uy(y0 - 10, y1 + 10), unit(0, 1), ang(0, 2 * M_PI);
  const double ds[] = {0.5, 2, 2, 5};
  std::vector<Query> out;
  while (static_cast<int>(out.size()) < count) {
    const size_t i = out.size();
    Point3 p{ux(rng), uy(rng), 0};
    double g = index.ground(p[0], p[1]);
    if (std::isnan(g)) g = index.ground(std::clamp(p[0], x0, x1), std::clamp(p[1], y0, y1));
    if (std::isnan(g)) continue;
    p[2] = g + (i % 10 == 0 ? -1.0 : 0.5 + 7.5 * unit(rng));
    const double len = 30 * unit(rng), heading = ang(rng), climb = (unit(rng) - 0.5) * M_PI * 0.6;
    Point3 q{p[0] + len * std::cos(heading) * std::cos(climb), p[1] + len * std::sin(heading) * std::cos(climb),
             p[2] + len * std::sin(climb)};
    if (i % 13 == 1) q = {p[0] + len, p[1], p[2]};
    if (i % 13 == 2) q = {p[0], p[1] - len, p[2]};
    if (i % 13 == 3) q = {p[0], p[1], p[2] + len};
    if (i % 13 == 4) q = p;
    out.push_back({p, q, ds[i % 4]});
  }
  return out;
}

void check_against_brute_force(const Mesh& mesh, int count, uint64_t seed) {
  const ClearanceIndex index(mesh);
  const BruteForce brute(mesh, index.origin());
  const std::vector<Query> queries = random_queries(index, mesh, count, seed);
  std::atomic<int> disagree_clear{0}, disagree_clearance{0}, blocked{0}, touching_wrong{0};
  tbb::parallel_for(size_t(0), queries.size(), [&](size_t i) {
    const Query& s = queries[i];
    const bool clear = !(std::sqrt(brute.min_squared(s.p, s.q, s.d)) < s.d);
    if (!clear) ++blocked;
    if (index.segment_clear(s.p, s.q, s.d) != clear) ++disagree_clear;
    const double cap = 6;
    const double expected = std::min(cap, std::sqrt(brute.min_squared(s.p, s.q, cap)));
    const double got = index.clearance(s.p, s.q, cap);
    if (got != expected) ++disagree_clearance;
    // Touching exactly at the measured distance is clear; anything more is not.
    if (got > 0 && got < cap &&
        (!index.segment_clear(s.p, s.q, got) || index.segment_clear(s.p, s.q, std::nextafter(got, INFINITY))))
      ++touching_wrong;
  });
  EXPECT_EQ(disagree_clear.load(), 0);
  EXPECT_EQ(disagree_clearance.load(), 0);
  EXPECT_EQ(touching_wrong.load(), 0);
  // The sample must contain both answers in numbers, or it proves little.
  EXPECT_GT(blocked.load(), count / 10);
  EXPECT_LT(blocked.load(), count * 9 / 10);
}

TEST(ClearanceIndex, AgreesWithBruteForceOnRealMesh) { check_against_brute_force(mesh_2m(), 4000, 11); }

TEST(ClearanceIndex, AgreesWithBruteForceOnSimplifiedMesh) { check_against_brute_force(mesh_bounded(), 4000, 12); }

TEST(ClearanceIndex, AgreesWithBruteForceForEveryBucketSize) {
  const Mesh& mesh = mesh_bounded();
  for (double size : {0.7, 5.0, 40.0, 1000.0}) {
    ClearanceOptions options;
    options.bucket_size = size;
    const ClearanceIndex index(mesh, options);
    const BruteForce brute(mesh, index.origin());
    int disagree = 0;
    for (const Query& s : random_queries(index, mesh, 400, 13))
      disagree += index.segment_clear(s.p, s.q, s.d) != !(std::sqrt(brute.min_squared(s.p, s.q, s.d)) < s.d);
    EXPECT_EQ(disagree, 0) << "bucket " << size;
  }
}

TEST(ClearanceIndex, AgreesWithBruteForceOnTriangleSoup) {
  // Nothing 2.5D about it: vertical walls, overhangs, slivers and points, at UTM coordinates.
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> ux(356000, 356200), uy(5699000, 5699200), uz(40, 90), small(-6, 6);
  Mesh soup;
  for (uint32_t t = 0; t < 3000; ++t) {
    const Vertex a{ux(rng), uy(rng), uz(rng)};
    Vertex b{a.x + small(rng), a.y + small(rng), a.z + small(rng)},
        c{a.x + small(rng), a.y + small(rng), a.z + small(rng)};
    if (t % 10 == 1) b.x = a.x, c.x = a.x;                                     // a wall
    if (t % 20 == 2) c = {(a.x + b.x) / 2, (a.y + b.y) / 2, (a.z + b.z) / 2};  // collinear
    if (t % 50 == 3) b = a, c = a;                                             // a point
    soup.vertices.insert(soup.vertices.end(), {a, b, c});
    soup.triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
  }
  const ClearanceIndex index(soup);
  const BruteForce brute(soup, index.origin());
  std::uniform_real_distribution<double> len(0, 40), ang(0, 2 * M_PI), unit(0, 1);
  int disagree_clear = 0, disagree_clearance = 0, blocked = 0;
  for (int i = 0; i < 3000; ++i) {
    const Point3 p{ux(rng), uy(rng), uz(rng)};
    const double l = len(rng), h = ang(rng), c = (unit(rng) - 0.5) * M_PI;
    const Point3 q{p[0] + l * std::cos(h) * std::cos(c), p[1] + l * std::sin(h) * std::cos(c), p[2] + l * std::sin(c)};
    const double d = 0.5 + 4 * unit(rng);
    const bool clear = !(std::sqrt(brute.min_squared(p, q, d)) < d);
    blocked += !clear;
    disagree_clear += index.segment_clear(p, q, d) != clear;
    disagree_clearance += index.clearance(p, q, 8) != std::min(8.0, std::sqrt(brute.min_squared(p, q, 8)));
  }
  EXPECT_EQ(disagree_clear, 0);
  EXPECT_EQ(disagree_clearance, 0);
  EXPECT_GT(blocked, 300);
  EXPECT_LT(blocked, 2700);
}

TEST(ClearanceIndex, TouchingExactlyAtTheDistanceIsClear) {
  // A flat 10 m square at z = 60 in UTM-sized coordinates; every distance below is exact.
  Mesh mesh;
  const double x = 356000, y = 5699000;
  mesh.vertices = {{x, y, 60}, {x + 10, y, 60}, {x + 10, y + 10, 60}, {x, y + 10, 60}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  const ClearanceIndex index(mesh);
  const Point3 p{x + 1, y + 5, 62}, q{x + 9, y + 5, 62};
  EXPECT_TRUE(index.segment_clear(p, q, 2));
  EXPECT_FALSE(index.segment_clear(p, q, std::nextafter(2.0, 3.0)));
  EXPECT_EQ(index.clearance(p, q, 10), 2);
  // Beside a corner, level with it: 3 m away along x.
  EXPECT_TRUE(index.point_clear({x - 3, y, 60}, 3));
  EXPECT_FALSE(index.point_clear({x - 3, y, 60}, std::nextafter(3.0, 4.0)));
  // Past the edge, diagonally: 3-4-5 from the edge x = x + 10.
  EXPECT_TRUE(index.segment_clear({x + 13, y + 2, 64}, {x + 13, y + 8, 64}, 5));
  EXPECT_FALSE(index.segment_clear({x + 13, y + 2, 64}, {x + 13, y + 8, 64}, 5.000001));
  // Through the square, and the degenerate cases of the arguments.
  EXPECT_FALSE(index.segment_clear({x + 5, y + 5, 50}, {x + 5, y + 5, 70}, 0.1));
  EXPECT_TRUE(index.segment_clear({x + 5, y + 5, 50}, {x + 5, y + 5, 70}, 0));
  EXPECT_EQ(index.clearance({x + 5, y + 5, 50}, {x + 5, y + 5, 70}, 3), 0);
  EXPECT_FALSE(index.segment_clear(p, q, INFINITY));
  EXPECT_EQ(index.clearance(p, q, INFINITY), 2);
  EXPECT_EQ(index.clearance({x + 5, y + 5, 1e6}, {x + 5, y + 5, 1e6}, INFINITY), 1e6 - 60);
  EXPECT_EQ(index.ground(x + 2.5, y + 7.5), 60);
  EXPECT_TRUE(std::isnan(index.ground(x - 0.1, y + 5)));
}

TEST(ClearanceIndex, GroundIsTheMeshHeight) {
  // At every cell centre of the 2 m mesh the ground is the vertex's height.
  const Grid& grid = nrw_2m();
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  size_t v = 0, wrong = 0;
  for (int r = 0; r < grid.height; ++r)
    for (int c = 0; c < grid.width; ++c)
      if (grid.valid(c, r))
        wrong += std::abs(index.ground(grid.center_x(c), grid.center_y(r)) - mesh.vertices[v++].z) > 1e-9;
  EXPECT_EQ(wrong, 0u);
  // Anywhere on the simplified mesh: as certify() interpolates, by brute force over triangles.
  const Mesh& simple = mesh_bounded();
  const ClearanceIndex sindex(simple);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> ux(grid.x0 - 5, grid.x1() + 5), uy(grid.y1() - 5, grid.y0 + 5);
  size_t mismatches = 0, covered = 0;
  for (int i = 0; i < 3000; ++i) {
    const double x = ux(rng), y = uy(rng);
    double expected = NAN;
    for (const Triangle& t : simple.triangles) {
      const Vertex &a = simple.vertices[t[0]], &b = simple.vertices[t[1]], &c = simple.vertices[t[2]];
      const double area2 = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
      const double w1 = ((x - a.x) * (c.y - a.y) - (c.x - a.x) * (y - a.y)) / area2;
      const double w2 = ((b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y)) / area2;
      if (w1 >= -1e-12 && w2 >= -1e-12 && w1 + w2 <= 1 + 1e-12) {
        expected = a.z + w1 * (b.z - a.z) + w2 * (c.z - a.z);
        break;
      }
    }
    const double got = sindex.ground(x, y);
    covered += !std::isnan(expected);
    if (std::isnan(expected) != std::isnan(got) || std::abs(got - expected) > 1e-6) ++mismatches;
    // The surface itself is at distance 0: never clear just above it.
    if (!std::isnan(got)) EXPECT_FALSE(sindex.point_clear({x, y, got + 0.5}, 0.5 + 1e-6));
  }
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(covered, 2000u);
}

TEST(ClearanceIndex, MemoryCountsEveryVertexListingAndBucket) {
  // What the header promises: 24 bytes a vertex, 20 a listing, 8 a bucket, 4 a cell of the
  // floor, and nothing a triangle beyond its listings; the blocks are a sixteenth of the buckets.
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const double buckets = static_cast<double>(index.bucket_columns()) * index.bucket_rows();
  const double expected = 24.0 * mesh.vertices.size() + 20.0 * index.bucket_listings() + 8.0 * (buckets + 1) +
                          4.0 * static_cast<double>(index.floor().grid().cells());
  EXPECT_GT(index.floor().grid().cells(), 0u);
  EXPECT_GE(static_cast<double>(index.memory_bytes()), expected);
  const double blocks = buckets / 16 + index.bucket_columns() + index.bucket_rows() + 1;  // partial ones included
  EXPECT_LE(static_cast<double>(index.memory_bytes()), expected + 4.0 * blocks);
  EXPECT_GT(index.bucket_listings(), mesh.triangles.size());
}

TEST(ClearanceIndex, GroundOfManyPointsIsGroundOfEach) {
  // The batch form (prefetching) gives exactly what the point form gives, on the real 2 m mesh
  // and the simplified one, for points inside, outside, on the border and not finite, in runs
  // shorter and longer than its pipeline.
  const Grid& grid = nrw_2m();
  for (const Mesh* mesh : {&mesh_2m(), &mesh_bounded()}) {
    const ClearanceIndex index(*mesh);
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> ux(grid.x0 - 5, grid.x1() + 5), uy(grid.y1() - 5, grid.y0 + 5);
    std::vector<double> x, y;
    for (int i = 0; i < 5000; ++i) x.push_back(ux(rng)), y.push_back(uy(rng));
    x.insert(x.end(), {NAN, grid.x0, INFINITY, grid.center_x(0), grid.x1()});
    y.insert(y.end(), {grid.y0, NAN, grid.y0, grid.center_y(0), grid.y1()});
    for (size_t n : {size_t{0}, size_t{1}, size_t{7}, size_t{40}, x.size()}) {
      std::vector<double> z(n, 12345);
      index.ground(x.data() + x.size() - n, y.data() + y.size() - n, z.data(), n);
      size_t differ = 0, covered = 0;
      for (size_t i = 0; i < n; ++i) {
        const double one = index.ground(x[x.size() - n + i], y[y.size() - n + i]);
        covered += !std::isnan(one);
        differ += !(one == z[i] || (std::isnan(one) && std::isnan(z[i])));
      }
      EXPECT_EQ(differ, 0u) << n;
      if (n == x.size()) EXPECT_GT(covered, 4000u);
    }
  }
  std::vector<double> z(3, 0);
  const double x[3] = {0, 1, 2};
  ClearanceIndex(Mesh{}).ground(x, x, z.data(), 3);
  EXPECT_TRUE(std::isnan(z[0]) && std::isnan(z[1]) && std::isnan(z[2]));
}

TEST(ClearanceIndex, ConcurrentQueriesAgreeWithSerial) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const std::vector<Query> queries = random_queries(index, mesh, 20000, 3);
  std::vector<char> serial(queries.size()), parallel(queries.size());
  for (size_t i = 0; i < queries.size(); ++i) serial[i] = index.segment_clear(queries[i].p, queries[i].q, queries[i].d);
  tbb::parallel_for(size_t(0), queries.size(),
                    [&](size_t i) { parallel[i] = index.segment_clear(queries[i].p, queries[i].q, queries[i].d); });
  EXPECT_EQ(serial, parallel);
}

TEST(ClearanceIndex, BadInput) {
  Mesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 3}};
  EXPECT_THROW(ClearanceIndex{mesh}, ArgumentError);
  mesh.triangles = {{0, 1, 2}};
  mesh.vertices[1].z = NAN;
  EXPECT_THROW(ClearanceIndex{mesh}, ArgumentError);
  mesh.vertices[1].z = 0;
  ClearanceOptions options;
  options.bucket_size = -1;
  EXPECT_THROW(ClearanceIndex(mesh, options), ArgumentError);
  const ClearanceIndex index(mesh);
  EXPECT_THROW(index.segment_clear({0, 0, 1}, {1, 1, 1}, -1), ArgumentError);
  EXPECT_THROW(index.segment_clear({0, 0, 1}, {1, 1, 1}, NAN), ArgumentError);
  EXPECT_THROW(index.segment_clear({0, 0, NAN}, {1, 1, 1}, 1), ArgumentError);
  EXPECT_THROW(index.clearance({0, 0, 1}, {1, 1, 1}, -2), ArgumentError);
  try {
    index.segment_clear({0, 0, 1}, {1, 1, 1}, -1);
  } catch (const ArgumentError& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  }
  // An empty mesh: everything is clear, nothing has ground.
  const ClearanceIndex empty(Mesh{});
  EXPECT_TRUE(empty.segment_clear({0, 0, 0}, {1, 1, 1}, 5));
  EXPECT_EQ(empty.clearance({0, 0, 0}, {1, 1, 1}, 5), 5);
  EXPECT_TRUE(std::isnan(empty.ground(0, 0)));
}

}  // namespace

// ---- the planner (PRM, A*, shortcuts) on the real mesh ------------------------------------
//
// Oracles: the distance of every returned segment to every triangle of the mesh, by
// segment_triangle_distance() in a plain loop (no ClearanceIndex); the exact waypoint
// coordinates; the triangle inequality for smoothing; a second run (and one thread against
// two) for determinism.

namespace {

// Least distance from [p, q] to any triangle, brute force (capped at `cap`; a box test that
// is obviously conservative only saves time).
double brute_clearance(const Mesh& mesh, const Point3& origin, const Point3& p_, const Point3& q_, double cap) {
  const Point3 p{p_[0] - origin[0], p_[1] - origin[1], p_[2] - origin[2]};
  const Point3 q{q_[0] - origin[0], q_[1] - origin[1], q_[2] - origin[2]};
  double best = cap;
  for (const Triangle& t : mesh.triangles) {
    std::array<Point3, 3> c;
    for (int k = 0; k < 3; ++k) {
      const Vertex& v = mesh.vertices[t[k]];
      c[k] = {v.x - origin[0], v.y - origin[1], v.z - origin[2]};
    }
    bool far = false;
    for (int k = 0; k < 3 && !far; ++k) {
      const double lo = std::min({c[0][k], c[1][k], c[2][k]}), hi = std::max({c[0][k], c[1][k], c[2][k]});
      far = std::min(p[k], q[k]) > hi + cap + 1e-6 || std::max(p[k], q[k]) < lo - cap - 1e-6;
    }
    if (!far) best = std::min(best, segment_triangle_distance(p, q, c[0], c[1], c[2]));
  }
  return best;
}

struct MeshBox {
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  explicit MeshBox(const Mesh& mesh) {
    for (const Vertex& v : mesh.vertices)
      x0 = std::min(x0, v.x), x1 = std::max(x1, v.x), y0 = std::min(y0, v.y), y1 = std::max(y1, v.y);
  }
};

// A point `agl` above the surface near (x, y), moved in 3 m steps until it is `safety` clear of
// the mesh by brute force (a wall may stand right beside the spot).
Point3 waypoint_near(const Mesh& mesh, const ClearanceIndex& index, double x, double y, double agl, double safety) {
  for (int ring = 0; ring < 6; ++ring)
    for (int dx = -ring; dx <= ring; ++dx)
      for (int dy = -ring; dy <= ring; ++dy) {
        if (std::max(std::abs(dx), std::abs(dy)) != ring) continue;
        const double px = x + 3 * dx, py = y + 3 * dy, g = index.ground(px, py);
        if (std::isnan(g)) continue;
        const Point3 p{px, py, g + agl};
        if (brute_clearance(mesh, index.origin(), p, p, safety + 1) >= safety + 0.5) return p;
      }
  ADD_FAILURE() << "no clear waypoint near " << x << ", " << y;
  return {x, y, 1e4};
}

// Opposite corners and the middle, 35 m above the surface.
std::vector<Point3> three_waypoints(const Mesh& mesh, const ClearanceIndex& index, double agl = 35, double safety = 2) {
  const MeshBox b(mesh);
  return {waypoint_near(mesh, index, b.x0 + 20, b.y0 + 20, agl, safety),
          waypoint_near(mesh, index, 0.5 * (b.x0 + b.x1) + 10, 0.5 * (b.y0 + b.y1) - 30, agl, safety),
          waypoint_near(mesh, index, b.x1 - 20, b.y1 - 20, agl, safety)};
}

void expect_path_verified(const Mesh& mesh, const ClearanceIndex& index, const std::vector<Point3>& waypoints,
                          const PlanResult& result, double safety) {
  ASSERT_EQ(result.status, PlanStatus::Solved) << result.place() << ": " << result.reason;
  ASSERT_GE(result.path.size(), 2u);
  EXPECT_EQ(result.path.front(), waypoints.front());
  EXPECT_EQ(result.path.back(), waypoints.back());
  // Every waypoint, in order, exactly.
  size_t at = 0;
  for (const Point3& w : waypoints) {
    while (at < result.path.size() && result.path[at] != w) ++at;
    EXPECT_LT(at, result.path.size()) << "waypoint missing or out of order";
  }
  for (const auto* path : {&result.path, &result.raw_path})
    for (size_t k = 1; k < path->size(); ++k) {
      const double d = brute_clearance(mesh, index.origin(), (*path)[k - 1], (*path)[k], safety + 1);
      EXPECT_GE(d, safety) << "segment " << k << (path == &result.path ? " of the path" : " of the raw path");
    }
  // Shortcuts replace pieces of the raw path by straight segments, rounding replaces corners
  // by chords of a convex curve inside them: never longer.
  EXPECT_LE(path_length(result.path), path_length(result.raw_path) + 1e-9);
}

TEST(PlanPath, ThreeWaypointsLowOverTheRealMeshAreVerifiedByBruteForce) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = three_waypoints(mesh, index);
  PlanOptions options;
  options.max_agl = 45;  // low: the roadmap stays among the roofs
  options.spacing = 15;
  const PlanResult result = plan_path(index, waypoints, options);
  expect_path_verified(mesh, index, waypoints, result, options.safety);
  EXPECT_GT(result.roadmap_nodes, 0u);
  EXPECT_GT(result.roadmap_edges, 0u);
  EXPECT_LT(path_length(result.path), path_length(result.raw_path));  // the shortcuts did something
  RecordProperty("path_length_m", std::to_string(path_length(result.path)));
  RecordProperty("raw_length_m", std::to_string(path_length(result.raw_path)));
}

TEST(PlanPath, SimplifiedConservativeMeshWithLargerSafety) {
  const Mesh& mesh = mesh_bounded();
  const ClearanceIndex index(mesh);
  const auto waypoints = three_waypoints(mesh, index, 30, 5);
  PlanOptions options;
  options.safety = 5;
  options.max_agl = 50;
  options.spacing = 15;
  const PlanResult result = plan_path(index, waypoints, options);
  expect_path_verified(mesh, index, waypoints, result, options.safety);
}

TEST(PlanPath, WithoutSmoothingThePathIsTheRawPath) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = three_waypoints(mesh, index);
  PlanOptions options;
  options.max_agl = 60;
  options.smooth = false;
  options.spline = false;
  const PlanResult result = plan_path(index, waypoints, options);
  ASSERT_EQ(result.status, PlanStatus::Solved) << result.reason;
  EXPECT_EQ(result.path, result.raw_path);
}

// ---- spline smoothing, the roadmap file, clearance to the DSM's columns --------------------

TEST(PlanPath, SplineRoundsCornersNeverLongerAndStaysClear) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = three_waypoints(mesh, index, 8);
  PlanOptions options;
  options.max_agl = 25;  // low: the path weaves between roofs, so it has corners to round
  options.spacing = 12;
  options.spline = false;
  const PlanResult straight = plan_path(index, waypoints, options);
  options.spline = true;
  const PlanResult rounded = plan_path(index, waypoints, options);
  expect_path_verified(mesh, index, waypoints, straight, options.safety);
  expect_path_verified(mesh, index, waypoints, rounded, options.safety);
  EXPECT_EQ(straight.raw_path, rounded.raw_path);
  EXPECT_GT(rounded.path.size(), straight.path.size());  // some corner was rounded
  EXPECT_LT(path_length(rounded.path), path_length(straight.path));
  // No turn sharper than the shortcut path's sharpest: rounding only opens corners up.
  auto sharpest = [](const std::vector<Point3>& path) {
    double worst = 1;
    for (size_t k = 1; k + 1 < path.size(); ++k) {
      const Point3 a{path[k][0] - path[k - 1][0], path[k][1] - path[k - 1][1], path[k][2] - path[k - 1][2]};
      const Point3 b{path[k + 1][0] - path[k][0], path[k + 1][1] - path[k][1], path[k + 1][2] - path[k][2]};
      const double na = std::hypot(a[0], a[1], a[2]), nb = std::hypot(b[0], b[1], b[2]);
      if (na > 0 && nb > 0) worst = std::min(worst, (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (na * nb));
    }
    return worst;
  };
  EXPECT_GE(sharpest(rounded.path), sharpest(straight.path) - 1e-9);
}

namespace {

std::string read_bytes(const std::string& path) { return testkit::read_file(path); }

// The file's checksum recomputed after an edit (FNV-1a 64 of everything before it), so a test
// can reach the checks behind it.
void reseal(std::string& bytes) {
  uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i + 8 < bytes.size(); ++i) h = (h ^ static_cast<unsigned char>(bytes[i])) * 1099511628211ull;
  std::memcpy(&bytes[bytes.size() - 8], &h, 8);
}

void expect_refused(const std::string& path, uint64_t fingerprint, const PlanOptions& options, const std::string& why) {
  try {
    read_roadmap(path, fingerprint, options);
    ADD_FAILURE() << "accepted; expected: " << why;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(ClearanceIndex, ClearanceBoundNeverExceedsTheBruteForceClearance) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const MeshBox b(mesh);
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(0, 1);
  int positive = 0;
  for (int i = 0; i < 200; ++i) {
    const double x = b.x0 + u(rng) * (b.x1 - b.x0), y = b.y0 + u(rng) * (b.y1 - b.y0);
    const double g = index.ground(x, y);
    if (std::isnan(g)) continue;
    const Point3 p{x, y, g + 0.5 + 60 * u(rng) * u(rng)};
    const double cap = 36.5, bound = index.clearance_bound(p, cap);
    EXPECT_GE(bound, 0);
    EXPECT_LE(bound, brute_clearance(mesh, index.origin(), p, p, cap) + 1e-9) << i;
    positive += bound > 2;
  }
  EXPECT_GT(positive, 40);  // it certifies something: the roadmap relies on that for speed
  EXPECT_EQ(index.clearance_bound({b.x0 + 100, b.y0 + 100, 1e4}, 36.5), 36.5);
}

TEST(RoadmapFile, RoundTripGivesTheSameRoadmapAndPath) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  PlanOptions options;
  options.max_agl = 45;
  options.spacing = 15;
  const Roadmap built = build_roadmap(index, options);
  ASSERT_GT(built.edges(), 0u);
  testkit::TempDir dir;
  const std::string path = dir.path("map.bin");
  write_roadmap(path, built, mesh_fingerprint(mesh), options);
  EXPECT_EQ(read_bytes(path).size(),
            16 + 4 + 8 + 32 + 16 + built.nodes.size() * 28 + 4 + built.neighbour.size() * 4 + 8);
  const Roadmap read = read_roadmap(path, mesh_fingerprint(mesh), options);
  EXPECT_EQ(read.nodes, built.nodes);
  EXPECT_EQ(read.start, built.start);
  EXPECT_EQ(read.neighbour, built.neighbour);
  const auto waypoints = three_waypoints(mesh, index, 30);
  EXPECT_EQ(query_roadmap(read, index, waypoints, options).path, query_roadmap(built, index, waypoints, options).path);
}

// Found by fuzz/fuzz_roadmap (UBSan: memcpy to a null data() for 0 bytes): roadmaps without
// nodes, or with nodes and no edges, are valid files and read back as they were written.
TEST(RoadmapFile, EmptyRoadmapsAndRoadmapsWithoutEdgesRoundTrip) {
  testkit::TempDir dir;
  const std::string path = dir.path("map.bin");
  PlanOptions options;
  Roadmap empty;
  empty.start = {0};
  Roadmap lonely;
  lonely.nodes = {Point3{1, 2, 3}, Point3{4, 5, 6}};
  lonely.start = {0, 0, 0};
  for (const Roadmap& map : {empty, lonely}) {
    write_roadmap(path, map, 42, options);
    const Roadmap read = read_roadmap(path, 42, options);
    EXPECT_EQ(read.nodes, map.nodes);
    EXPECT_EQ(read.start, map.start);
    EXPECT_TRUE(read.neighbour.empty());
  }
}

TEST(RoadmapFile, AnotherMeshOtherOptionsOrDamageAreRefused) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  PlanOptions options;
  options.max_agl = 40;
  options.spacing = 25;
  const Roadmap built = build_roadmap(index, options);
  const uint64_t fingerprint = mesh_fingerprint(mesh);
  testkit::TempDir dir;
  const std::string path = dir.path("map.bin");
  write_roadmap(path, built, fingerprint, options);
  const std::string good = read_bytes(path);

  // Another mesh: the simplified one, and the same mesh with one vertex 1 mm higher.
  EXPECT_NE(mesh_fingerprint(mesh_bounded()), fingerprint);
  Mesh nudged = mesh;
  nudged.vertices[nudged.vertices.size() / 2].z += 0.001;
  EXPECT_NE(mesh_fingerprint(nudged), fingerprint);
  expect_refused(path, mesh_fingerprint(nudged), options, "another mesh");
  for (auto [field, value] : {std::pair{&PlanOptions::safety, 3.0},
                              {&PlanOptions::spacing, 20.0},
                              {&PlanOptions::max_edge, 30.0},
                              {&PlanOptions::max_agl, 41.0}}) {
    PlanOptions other = options;
    other.*field = value;
    expect_refused(path, fingerprint, other, "was built with --");
  }
  auto with = [&](const std::string& bytes) {
    testkit::write_file(path, bytes);
    return path;
  };
  std::string flipped = good;
  flipped[good.size() / 2] ^= 0x10;
  expect_refused(with(flipped), fingerprint, options, "checksum");
  expect_refused(with(good.substr(0, good.size() - 100)), fingerprint, options, "truncated roadmap file");
  expect_refused(with(good.substr(0, 40)), fingerprint, options, "truncated");
  expect_refused(with("x,y,z\n1,2,3\n"), fingerprint, options, "not a dsmplan roadmap");
  // Counts that lie, and an edge to a node that does not exist, behind a valid checksum.
  std::string lying = good;
  const uint64_t huge = uint64_t{1} << 40;
  std::memcpy(&lying[16 + 4 + 8 + 32], &huge, 8);
  reseal(lying);
  expect_refused(with(lying), fingerprint, options, "do not fill");
  std::string dangling = good;
  const size_t neighbours = 16 + 4 + 8 + 32 + 16 + built.nodes.size() * 28 + 4;
  const uint32_t missing = static_cast<uint32_t>(built.nodes.size()) + 7;
  std::memcpy(&dangling[neighbours], &missing, 4);
  reseal(dangling);
  expect_refused(with(dangling), fingerprint, options, "does not exist");
  // Found by fuzz/fuzz_roadmap (ASan: heap-buffer-overflow): a node's edge list that ends past
  // the edge listings, the next node's start being lower again, was read before it was refused.
  std::string past_end = good;
  const size_t starts = 16 + 4 + 8 + 32 + 16 + built.nodes.size() * sizeof(Point3);
  const uint32_t beyond = static_cast<uint32_t>(built.neighbour.size()) + 1000;
  std::memcpy(&past_end[starts + 4], &beyond, 4);
  reseal(past_end);
  expect_refused(with(past_end), fingerprint, options, "runs past");
  expect_refused(dir.path("none.bin"), fingerprint, options, "cannot open");
}

// ---- the clearance index kept in a file -------------------------------------------------------

namespace {

// content_hash() as core/mapped_file.hpp defines it, with xxHash's plain XXH3 (the library uses
// its x86 dispatch): XXH3 of up to 1 MB, else XXH3 of the XXH3s of its 1 MB pieces.
uint64_t pieces_hash(const char* data, size_t n) {
  constexpr size_t piece = size_t(1) << 20;
  if (n <= piece) return XXH3_64bits(data, n);
  std::vector<uint64_t> hashes;
  for (size_t at = 0; at < n; at += piece) hashes.push_back(XXH3_64bits(data + at, std::min(piece, n - at)));
  return XXH3_64bits(hashes.data(), hashes.size() * sizeof(uint64_t));
}

// The checksum as clearance_index_file.cpp defines it: pieces_hash() of the header (up to the
// first section) and of the five sections, then XXH3 of those six. Offsets from the header's counts.
void reseal_index(std::string& bytes) {
  uint64_t counts[4];  // verts, buckets, items, block tops: after 16 + 8 + 16 + 40 + 24 + 56 + 8 + 48 + 16 bytes
  const size_t at_counts = 16 + 8 + 16 + 40 + 24 + 32 + 8 + 48 + 16;
  std::memcpy(counts, &bytes[at_counts], sizeof counts);
  uint64_t floor_cells = 0;
  std::memcpy(&floor_cells, &bytes[at_counts + 32 + 8 + 32], 8);
  auto align = [](size_t v) { return (v + 63) & ~size_t(63); };
  const size_t head = align(at_counts + 32 + 8 + 32 + 8);
  // Vertices, buckets, listings (16 bytes), their extents (4), block tops, floor cells.
  const size_t sizes[6] = {counts[0] * 24, counts[1] * 8, counts[2] * 16,
                           counts[2] * 4,  counts[3] * 4, floor_cells * 4};
  uint64_t hashes[7] = {pieces_hash(bytes.data(), head)};
  size_t at = head;
  for (int k = 0; k < 6; ++k) {
    hashes[k + 1] = pieces_hash(bytes.data() + at, sizes[k]);
    at = k < 5 ? align(at + sizes[k]) : at + sizes[k];
  }
  const uint64_t sum = XXH3_64bits(hashes, sizeof hashes);
  std::memcpy(&bytes[bytes.size() - 8], &sum, 8);
}

void expect_index_refused(const std::string& path, uint64_t hash, const std::string& why) {
  try {
    ClearanceIndex::open(path, hash);
    ADD_FAILURE() << "accepted; expected: " << why;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
  }
}

}  // namespace

// An index mapped from its file answers every query as the index that was saved, to the bit: on
// the real mesh and on the simplified one (whose floor has holes), after the built index and
// its vectors are gone, and a plan over it is the same plan.
TEST(ClearanceIndexFile, OpenedIndexAnswersAsTheSavedOne) {
  testkit::TempDir dir;
  // The real mesh with a hole: its floor then has cells no triangle meets.
  Mesh holed = mesh_2m();
  const MeshBox box(holed);
  const double hx = box.x0 + 0.7 * (box.x1 - box.x0), hy = box.y0 + 0.3 * (box.y1 - box.y0);
  std::erase_if(holed.triangles, [&](const Triangle& t) {
    const Vertex& v = holed.vertices[t[0]];
    return std::hypot(v.x - hx, v.y - hy) < 25;
  });
  for (const Mesh* mesh : {&mesh_2m(), &mesh_bounded(), static_cast<const Mesh*>(&holed)}) {
    const std::string path = dir.path("mesh.index");
    std::optional<ClearanceIndex> opened;
    auto built = std::make_unique<ClearanceIndex>(*mesh);
    built->save(path, {42, 7});
    ClearanceIndex::Source source;
    opened = ClearanceIndex::open(path, 42, {}, &source);
    ASSERT_TRUE(opened.has_value());
    EXPECT_EQ(source.input_hash, 42u);
    EXPECT_EQ(source.mesh_fingerprint, 7u);
    const ClearanceIndex& a = *built;
    const ClearanceIndex& b = *opened;
    EXPECT_EQ(a.triangles(), b.triangles());
    EXPECT_EQ(a.bucket_listings(), b.bucket_listings());
    EXPECT_EQ(a.memory_bytes(), b.memory_bytes());
    EXPECT_EQ(a.bucket_size(), b.bucket_size());
    EXPECT_EQ(a.origin(), b.origin());
    EXPECT_EQ(a.footprint().xmin, b.footprint().xmin);
    EXPECT_EQ(a.footprint().ymax, b.footprint().ymax);
    // The floor, hole by hole: holes count differently in the planner's quick refusals.
    const Grid &fa = a.floor().grid(), &fb = b.floor().grid();
    ASSERT_EQ(fa.cells(), fb.cells());
    EXPECT_EQ(std::memcmp(fa.z.data(), fb.z.data(), fa.cells() * sizeof(float)), 0);
    size_t holes = 0, hole_differs = 0;
    for (size_t i = 0; i < fa.cells(); ++i) {
      holes += a.floor().was_hole(i);
      hole_differs += a.floor().was_hole(i) != b.floor().was_hole(i);
    }
    EXPECT_EQ(hole_differs, 0u);
    if (mesh == &holed) EXPECT_GT(holes, 0u) << "the holed mesh's floor was to have holes";
    const std::vector<Query> queries = random_queries(a, *mesh, 3000, 21);
    size_t differ = 0, blocked = 0;
    for (const Query& s : queries) {
      const bool clear = a.segment_clear(s.p, s.q, s.d);
      blocked += !clear;
      differ += clear != b.segment_clear(s.p, s.q, s.d);
      differ += a.clearance(s.p, s.q, 6) != b.clearance(s.p, s.q, 6);
      differ += a.clearance_bound(s.q, 20) != b.clearance_bound(s.q, 20);
      const double ga = a.ground(s.p[0], s.p[1]), gb = b.ground(s.p[0], s.p[1]);
      differ += !(ga == gb || (std::isnan(ga) && std::isnan(gb)));
      differ += a.floor().max_height_above(s.p, s.q) != b.floor().max_height_above(s.p, s.q);
    }
    EXPECT_EQ(differ, 0u);
    EXPECT_GT(blocked, queries.size() / 10);
    // The plan over each; the built index (and its vectors) gone first, so the opened one can
    // only be answering from its mapping.
    PlanOptions options;
    options.max_agl = 45;
    options.spacing = 15;
    const std::vector<Point3> raised = three_waypoints(*mesh, a);
    const PlanResult first = plan_path(a, raised, options);
    built.reset();
    const PlanResult second = plan_path(b, raised, options);
    ASSERT_EQ(first.status, PlanStatus::Solved) << first.reason;
    EXPECT_EQ(first.path, second.path);
  }
}

TEST(ClearanceIndexFile, StaleFilesAreNotUsedAndBadFilesAreRefused) {
  testkit::TempDir dir;
  const std::string path = dir.path("mesh.index");
  const ClearanceIndex built(mesh_2m());
  built.save(path, {42, 7});
  const std::string good = read_bytes(path);
  // Built from another input or with other options: not used, nothing refused.
  ClearanceIndex::Source source;
  EXPECT_FALSE(ClearanceIndex::open(path, 43, {}, &source).has_value());
  EXPECT_EQ(source.input_hash, 42u) << "what the file was built from is told all the same";
  ClearanceOptions other;
  other.bucket_size = 5;
  EXPECT_FALSE(ClearanceIndex::open(path, 42, other).has_value());
  other = {};
  other.flight_area = {356100, 5699050, 356500, 5699450};
  EXPECT_FALSE(ClearanceIndex::open(path, 42, other).has_value());
  auto with = [&](const std::string& bytes) {
    testkit::write_file(path, bytes);
    return path;
  };
  std::string flipped = good;
  flipped[good.size() / 2] ^= 0x10;
  expect_index_refused(with(flipped), 42, "checksum");
  expect_index_refused(with(good.substr(0, good.size() - 100)), 42, "truncated");
  expect_index_refused(with(good.substr(0, 40)), 42, "not a dsmplan index");
  expect_index_refused(with("ply\nformat binary_little_endian 1.0\n"), 42, "not a dsmplan index");
  // Another format version or byte order: stale too (rebuilt, not refused).
  std::string version = good;
  version[16] = 9;
  EXPECT_FALSE(ClearanceIndex::open(with(version), 42).has_value());
  std::string order = good;
  std::swap(order[20], order[23]);
  EXPECT_FALSE(ClearanceIndex::open(with(order), 42).has_value());
  // The oracle of the checksum is right: resealing the good file changes nothing.
  std::string resealed = good;
  reseal_index(resealed);
  ASSERT_EQ(resealed, good);
  ASSERT_TRUE(ClearanceIndex::open(with(good), 42).has_value());
  // Arrays that do not fit each other behind a valid checksum: a listing naming a vertex that
  // is not there, a bucket list running backwards.
  std::string dangling = good;
  uint64_t counts[4];
  const size_t at_counts = 16 + 8 + 16 + 40 + 24 + 32 + 8 + 48 + 16;
  std::memcpy(counts, &good[at_counts], sizeof counts);
  auto align = [](size_t v) { return (v + 63) & ~size_t(63); };
  const size_t verts_at = align(at_counts + 32 + 8 + 32 + 8);
  const size_t buckets_at = align(verts_at + counts[0] * 24), items_at = align(buckets_at + counts[1] * 8);
  const uint32_t missing = static_cast<uint32_t>(counts[0]) + 3;
  std::memcpy(&dangling[items_at + 16 * (counts[2] / 2)], &missing, 4);
  reseal_index(dangling);
  expect_index_refused(with(dangling), 42, "names a vertex");
  std::string backwards = good;
  const uint32_t high = static_cast<uint32_t>(counts[2]);
  std::memcpy(&backwards[buckets_at + 8 * (counts[1] / 2)], &high, 4);
  reseal_index(backwards);
  expect_index_refused(with(backwards), 42, "lists");
  expect_index_refused(dir.path("none.index"), 42, "cannot be opened");
}

namespace {

// Distance from a point to the DSM's columns near it, by the definition: per cell, the
// distance to the box clamped coordinate by coordinate.
double point_column_distance(const Grid& g, const Point3& p, double reach) {
  double best = INFINITY;
  const int c0 = std::max(0, int((p[0] - reach - g.x0) / g.cell_x)),
            c1 = std::min(g.width - 1, int((p[0] + reach - g.x0) / g.cell_x));
  const int r0 = std::max(0, int((g.y0 - p[1] - reach) / g.cell_y)),
            r1 = std::min(g.height - 1, int((g.y0 - p[1] + reach) / g.cell_y));
  for (int row = r0; row <= r1; ++row)
    for (int col = c0; col <= c1; ++col) {
      if (!g.valid(col, row)) continue;
      const double x0 = g.x0 + col * g.cell_x, x1 = x0 + g.cell_x, y1 = g.y0 - row * g.cell_y, y0 = y1 - g.cell_y;
      const double dx = std::max({x0 - p[0], 0.0, p[0] - x1}), dy = std::max({y0 - p[1], 0.0, p[1] - y1});
      const double dz = std::max(0.0, p[2] - g.at(col, row));
      best = std::min(best, std::hypot(dx, dy, dz));
    }
  return best;
}

}  // namespace

TEST(ColumnClearance, HandCases) {
  Grid g(3, 3, 0, 3, 1, 1);
  for (float& z : g.z) z = 0;
  g.z[g.index(1, 1)] = 10;                                                        // a 10 m column over [1,2] x [1,2]
  EXPECT_DOUBLE_EQ(column_clearance(g, {1.5, 1.5, 14}, {1.5, 1.5, 14}, 100), 4);  // above it
  EXPECT_DOUBLE_EQ(column_clearance(g, {-5, 1.5, 15}, {5, 1.5, 15}, 100), 5);     // across it
  EXPECT_NEAR(column_clearance(g, {3, 3, 11}, {3, 3, 11}, 100), std::sqrt(3.0), 1e-12);            // off a corner
  EXPECT_DOUBLE_EQ(column_clearance(g, {1.5, 1.5, 5}, {1.5, 1.5, 20}, 100), 0);                    // through it
  EXPECT_NEAR(column_clearance(g, {0.5, 0.5, 2}, {0.5, 0.5, 2}, 100), std::sqrt(0.5), 1e-12);      // beside it
  EXPECT_DOUBLE_EQ(column_clearance(g, {0.5, 0.5, 2}, {0.5, 0.5, 2}, 0.25), 0.25);                 // capped
  g.z[g.index(1, 1)] = Grid::nodata;                                                               // a hole is air
  EXPECT_NEAR(column_clearance(g, {1.5, 1.5, 4}, {1.5, 1.5, 4}, 100), std::hypot(4, 0.5), 1e-12);  // to the rim
  EXPECT_THROW(column_clearance(g, {0, 0, NAN}, {1, 1, 1}, 1), ArgumentError);
  // Found by fuzz/fuzz_pipeline (UBSan): a segment 3e9 cells off the grid cast its cell indices
  // to int. Far away is simply clear.
  EXPECT_DOUBLE_EQ(column_clearance(g, {3e9, 1.5, 5}, {3e9, -3e9, 5}, 1000), 1000);
}

TEST(ColumnClearance, AgreesWithDenseSamplingOnTheRealDsm) {
  const Grid& g = testkit::nrw_crop();
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(0, 1);
  int near = 0;
  for (int trial = 0; trial < 80; ++trial) {
    const double x = g.x0 + 30 + u(rng) * (g.width * g.cell_x - 60),
                 y = g.y0 - 30 - u(rng) * (g.height * g.cell_y - 60);
    const int col = int((x - g.x0) / g.cell_x), row = int((g.y0 - y) / g.cell_y);
    const Point3 p{x, y, g.at(col, row) + 1 + 8 * u(rng)};
    const double a = 2 * M_PI * u(rng), len = 3 + 12 * u(rng);
    const Point3 q{x + len * std::cos(a), y + len * std::sin(a), p[2] + (u(rng) - 0.5) * 6};
    const double cap = 6, exact = column_clearance(g, p, q, cap);
    // Samples 1 cm apart: an upper bound within 5 mm (half a step) of the true distance.
    double sampled = cap;
    const int n = int(std::ceil(dist(p, q) / 0.01));
    for (int i = 0; i <= n; ++i)
      sampled = std::min(sampled, point_column_distance(g, lerp(p, q, double(i) / n), cap + 1));
    EXPECT_LE(exact, sampled + 1e-9) << trial;
    EXPECT_GE(exact, sampled - 0.005 - 1e-9) << trial;
    near += exact < cap;
  }
  EXPECT_GT(near, 40);  // most segments pass within the cap: the search is exercised
}

TEST(PlanPath, RoadmapHoldsExactlyTheClearPairsWithinMaxEdge) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  PlanOptions options;
  options.max_agl = 60;
  options.spacing = 25;
  const Roadmap map = build_roadmap(index, options);
  ASSERT_GT(map.nodes.size(), 100u);
  ASSERT_EQ(map.start.size(), map.nodes.size() + 1);
  const MeshBox b(mesh);
  for (size_t i = 0; i < map.nodes.size(); ++i) {
    const Point3& p = map.nodes[i];
    EXPECT_TRUE(p[0] >= b.x0 && p[0] <= b.x1 && p[1] >= b.y0 && p[1] <= b.y1);
    const double g = index.ground(p[0], p[1]);
    EXPECT_TRUE(p[2] >= g && p[2] <= g + options.max_agl) << i;
    EXPECT_TRUE(std::is_sorted(map.neighbour.begin() + map.start[i], map.neighbour.begin() + map.start[i + 1]));
  }
  // For the 40 nodes nearest the surface (where the close calls are): every other node within
  // max_edge is a neighbour iff brute force finds the segment clear; every node is clear.
  std::vector<std::pair<double, size_t>> low;
  for (size_t i = 0; i < map.nodes.size(); ++i)
    low.emplace_back(map.nodes[i][2] - index.ground(map.nodes[i][0], map.nodes[i][1]), i);
  std::sort(low.begin(), low.end());
  int clear_pairs = 0, blocked_pairs = 0;
  for (size_t n = 0; n < 40; ++n) {
    const size_t i = low[n].second;
    EXPECT_GE(brute_clearance(mesh, index.origin(), map.nodes[i], map.nodes[i], 3), options.safety);
    const auto begin = map.neighbour.begin() + map.start[i], end = map.neighbour.begin() + map.start[i + 1];
    for (size_t j = 0; j < map.nodes.size(); ++j) {
      if (j == i || dist(map.nodes[i], map.nodes[j]) >= options.max_edge) {
        EXPECT_FALSE(std::binary_search(begin, end, static_cast<uint32_t>(j)));
        continue;
      }
      const bool clear = brute_clearance(mesh, index.origin(), map.nodes[i], map.nodes[j], 3) >= options.safety;
      EXPECT_EQ(std::binary_search(begin, end, static_cast<uint32_t>(j)), clear) << i << "-" << j;
      ++(clear ? clear_pairs : blocked_pairs);
    }
  }
  // Not vacuous: both answers occur.
  EXPECT_GT(clear_pairs, 100);
  EXPECT_GT(blocked_pairs, 10);
  RecordProperty("clear_pairs", clear_pairs);
  RecordProperty("blocked_pairs", blocked_pairs);
}

TEST(PlanPath, SameInputSamePathOnOneAndTwoThreads) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = three_waypoints(mesh, index);
  PlanOptions options;
  options.max_agl = 60;
  options.threads = 1;
  const PlanResult one = plan_path(index, waypoints, options);
  const Roadmap map1 = build_roadmap(index, options);
  options.threads = 2;
  const PlanResult two = plan_path(index, waypoints, options);
  const PlanResult again = plan_path(index, waypoints, options);
  const Roadmap map2 = build_roadmap(index, options);
  ASSERT_EQ(one.status, PlanStatus::Solved);
  EXPECT_EQ(one.path, two.path);
  EXPECT_EQ(one.raw_path, two.raw_path);
  EXPECT_EQ(two.path, again.path);
  EXPECT_EQ(map1.nodes, map2.nodes);
  EXPECT_EQ(map1.start, map2.start);
  EXPECT_EQ(map1.neighbour, map2.neighbour);
  // Multi-query: the same roadmap answers the query as plan_path() did.
  const PlanResult reused = query_roadmap(map2, index, waypoints, options);
  EXPECT_EQ(reused.path, two.path);
}

TEST(PlanPath, BadWaypointsNameWhichAndWhy) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto good = three_waypoints(mesh, index);
  const MeshBox b(mesh);
  auto expect_invalid = [&](std::vector<Point3> waypoints, size_t which, const std::string& why) {
    const PlanResult r = plan_path(index, waypoints);
    EXPECT_EQ(r.status, PlanStatus::InvalidWaypoint);
    EXPECT_EQ(r.waypoint, which);
    EXPECT_EQ(r.place(), "waypoint " + std::to_string(which + 1));
    EXPECT_NE(r.reason.find(why), std::string::npos) << r.reason;
    EXPECT_EQ(r.reason.find('\n'), std::string::npos);
    EXPECT_EQ(r.roadmap_nodes, 0u);  // refused before any roadmap was built
  };
  auto w = good;
  w[1] = {b.x1 + 50, w[1][1], w[1][2]};
  expect_invalid(w, 1, "outside");
  w = good;
  w[2][2] = index.ground(w[2][0], w[2][1]) - 3;
  expect_invalid(w, 2, "under the surface");
  w = good;
  w[0][2] = index.ground(w[0][0], w[0][1]) + 1;
  expect_invalid(w, 0, "safety distance");
  EXPECT_THROW(plan_path(index, {good[0]}), ArgumentError);
  EXPECT_THROW(plan_path(index, {}), ArgumentError);
  PlanOptions bad;
  bad.spacing = 0;
  EXPECT_THROW(plan_path(index, good, bad), ArgumentError);
}

TEST(PlanPath, NoPathNamesTheLeg) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = three_waypoints(mesh, index);
  PlanOptions sparse;
  sparse.spacing = 200;      // a handful of samples
  sparse.max_edge = 10;      // that cannot reach each other
  sparse.refine_rounds = 0;  // and no refinement to help
  const PlanResult r = plan_path(index, waypoints, sparse);
  EXPECT_EQ(r.status, PlanStatus::NoPath);
  EXPECT_EQ(r.waypoint, 0u);
  EXPECT_EQ(r.place(), "waypoints 1 to 2");
  EXPECT_FALSE(r.reason.empty());
  EXPECT_TRUE(r.path.empty());
}

}  // namespace

// ---- RRT-Connect (Kuffner & LaValle 2000) on the real mesh ----------------------------------
//
// The same oracles as the PRM's: brute-force clearance of every segment (no ClearanceIndex),
// the waypoints' exact coordinates, the triangle inequality for smoothing. Besides: the trees'
// steps (raw path) are at most max_edge long and their nodes lie over the mesh and not under
// it, a fixed seed repeats the path bit for bit, and a leg that cannot be flown within the
// volume ends in NoPath after the sample limit.

namespace {

PlanOptions rrt_options(double max_agl = 45) {
  PlanOptions options;
  options.planner = PlannerKind::rrt_connect;
  options.max_agl = max_agl;
  return options;
}

// The trees' own steps: each at most the range (up to the rounding of UTM coordinates, about
// 1e-9 m), each node over the mesh and not under its surface.
void expect_tree_steps(const ClearanceIndex& index, const PlanResult& result, double range) {
  for (size_t k = 1; k < result.raw_path.size(); ++k)
    EXPECT_LE(dist(result.raw_path[k - 1], result.raw_path[k]), range + 1e-6) << "step " << k;
  for (const Point3& p : result.raw_path) {
    const double g = index.ground(p[0], p[1]);
    EXPECT_FALSE(std::isnan(g));
    EXPECT_GE(p[2], g);
  }
}

TEST(RrtConnect, ThreeWaypointsLowOverTheRealMeshAreVerifiedByBruteForce) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = three_waypoints(mesh, index, 15);
  const PlanOptions options = rrt_options(25);  // low: among the roofs, not over them
  const PlanResult result = plan_rrt_connect(index, waypoints, options);
  expect_path_verified(mesh, index, waypoints, result, options.safety);
  expect_tree_steps(index, result, options.max_edge);
  // Two legs of 300-odd metres need several steps each.
  EXPECT_GT(result.raw_path.size(), 2 * 300 / options.max_edge);
  EXPECT_GE(result.roadmap_nodes, result.raw_path.size());
  EXPECT_EQ(result.roadmap_edges, result.roadmap_nodes - 4);  // two legs, two trees each
  EXPECT_EQ(result.seconds_roadmap, 0);
  EXPECT_LT(path_length(result.path), path_length(result.raw_path));  // the shortcuts did something
  RecordProperty("path_length_m", std::to_string(path_length(result.path)));
  RecordProperty("raw_length_m", std::to_string(path_length(result.raw_path)));
  RecordProperty("tree_nodes", std::to_string(result.roadmap_nodes));
}

TEST(RrtConnect, SimplifiedConservativeMeshSmallStepsLargerSafety) {
  // Short steps: many nodes a leg, a nearest-neighbour grid of many occupied cells.
  const Mesh& mesh = mesh_bounded();
  const ClearanceIndex index(mesh);
  const auto waypoints = three_waypoints(mesh, index, 30, 5);
  PlanOptions options = rrt_options(50);
  options.safety = 5;
  options.max_edge = 6;
  const PlanResult result = plan_rrt_connect(index, waypoints, options);
  expect_path_verified(mesh, index, waypoints, result, options.safety);
  expect_tree_steps(index, result, options.max_edge);
  EXPECT_GT(result.raw_path.size(), 2 * 300 / 6u);
}

TEST(RrtConnect, SameSeedSamePathOtherSeedOtherValidPath) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = three_waypoints(mesh, index);
  PlanOptions options = rrt_options(60);
  options.seed = 7;
  const PlanResult first = plan_rrt_connect(index, waypoints, options);
  const PlanResult again = plan_rrt_connect(index, waypoints, options);
  ASSERT_EQ(first.status, PlanStatus::Solved) << first.reason;
  EXPECT_EQ(first.raw_path, again.raw_path);
  EXPECT_EQ(first.path, again.path);
  EXPECT_EQ(first.roadmap_nodes, again.roadmap_nodes);
  // plan_path() dispatches on options.planner to the very same planner.
  const PlanResult dispatched = plan_path(index, waypoints, options);
  EXPECT_EQ(dispatched.raw_path, first.raw_path);
  EXPECT_EQ(dispatched.seconds_roadmap, 0);

  options.seed = 8;
  const PlanResult other = plan_rrt_connect(index, waypoints, options);
  expect_path_verified(mesh, index, waypoints, other, options.safety);
  EXPECT_NE(other.raw_path, first.raw_path);  // the seed is used
}

TEST(RrtConnect, BadWaypointsNameWhichAndWhy) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto good = three_waypoints(mesh, index);
  const MeshBox b(mesh);
  auto expect_invalid = [&](std::vector<Point3> waypoints, size_t which, const std::string& why) {
    const PlanResult r = plan_path(index, waypoints, rrt_options());
    EXPECT_EQ(r.status, PlanStatus::InvalidWaypoint);
    EXPECT_EQ(r.waypoint, which);
    EXPECT_EQ(r.place(), "waypoint " + std::to_string(which + 1));
    EXPECT_NE(r.reason.find(why), std::string::npos) << r.reason;
    EXPECT_EQ(r.reason.find('\n'), std::string::npos);
    EXPECT_EQ(r.roadmap_nodes, 0u);  // refused before any tree grew
    EXPECT_TRUE(r.path.empty());
  };
  auto w = good;
  w[2] = {w[2][0], b.y1 + 40, w[2][2]};
  expect_invalid(w, 2, "outside");
  w = good;
  w[1][2] = index.ground(w[1][0], w[1][1]) - 2;
  expect_invalid(w, 1, "under the surface");
  w = good;
  w[0][2] = index.ground(w[0][0], w[0][1]) + 0.5;
  expect_invalid(w, 0, "safety distance");
  EXPECT_THROW(plan_rrt_connect(index, {good[0]}, rrt_options()), ArgumentError);
  PlanOptions bad = rrt_options();
  bad.rrt_max_samples = 0;
  EXPECT_THROW(plan_rrt_connect(index, good, bad), ArgumentError);
  bad = rrt_options();
  bad.max_edge = -1;
  EXPECT_THROW(plan_path(index, good, bad), ArgumentError);
}

// Two flat 100 m squares at z = 0 with a 50 m gap between them (no triangle: no ground).
// Every node lies over the mesh and every step is at most max_edge long, so with max_edge below
// 50 no path can cross the gap; above it one can.
Mesh two_islands() {
  Mesh mesh;
  const double x = 356000, y = 5699000;
  for (double x0 : {x, x + 150}) {
    const auto v = static_cast<uint32_t>(mesh.vertices.size());
    mesh.vertices.insert(mesh.vertices.end(), {{x0, y, 0}, {x0 + 100, y, 0}, {x0 + 100, y + 100, 0}, {x0, y + 100, 0}});
    mesh.triangles.push_back({v, v + 1, v + 2});
    mesh.triangles.push_back({v, v + 2, v + 3});
  }
  return mesh;
}

TEST(RrtConnect, ALegAcrossAGapWiderThanTheStepEndsInNoPathAtTheLimit) {
  const Mesh mesh = two_islands();
  const ClearanceIndex index(mesh);
  const std::vector<Point3> waypoints{{356030, 5699050, 20}, {356070, 5699040, 25}, {356230, 5699050, 20}};
  PlanOptions options = rrt_options(40);
  options.rrt_max_samples = 3000;
  const auto started = std::chrono::steady_clock::now();
  const PlanResult r = plan_rrt_connect(index, waypoints, options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  EXPECT_EQ(r.status, PlanStatus::NoPath);
  EXPECT_EQ(r.waypoint, 1u);  // the first leg, on one island, was flown
  EXPECT_EQ(r.place(), "waypoints 2 to 3");
  EXPECT_NE(r.reason.find("3000 samples"), std::string::npos) << r.reason;
  EXPECT_EQ(r.reason.find('\n'), std::string::npos);
  EXPECT_TRUE(r.path.empty());
  EXPECT_GT(r.roadmap_nodes, 100u);  // the trees did grow, on their own islands
  EXPECT_LT(seconds, 5);
  // The control: steps longer than the gap cross it.
  options.max_edge = 60;
  const PlanResult crossed = plan_rrt_connect(index, waypoints, options);
  expect_path_verified(mesh, index, waypoints, crossed, options.safety);
  expect_tree_steps(index, crossed, options.max_edge);
}

// A 200 m square of ground at z = 0 and across it a wall 1 m thick and 60 m tall with a 20 m
// door in the middle (a triangle soup: the ground runs on under the wall).
Mesh wall_with_door() {
  Mesh mesh;
  const double x = 356000, y = 5699000;
  auto box = [&](double x0, double y0, double x1, double y1, double z0, double z1) {
    const auto v = static_cast<uint32_t>(mesh.vertices.size());
    for (double z : {z0, z1})
      mesh.vertices.insert(mesh.vertices.end(), {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}});
    mesh.triangles.push_back({v + 4, v + 5, v + 6});  // top
    mesh.triangles.push_back({v + 4, v + 6, v + 7});
    for (uint32_t k = 0; k < 4 && z1 > z0; ++k) {  // sides
      const uint32_t a = v + k, b = v + (k + 1) % 4;
      mesh.triangles.push_back({a, b, b + 4});
      mesh.triangles.push_back({a, b + 4, a + 4});
    }
  };
  box(x, y, x + 200, y + 200, 0, 0);
  box(x, y + 100, x + 90, y + 101, 0, 60);
  box(x + 110, y + 100, x + 200, y + 101, 0, 60);
  return mesh;
}

TEST(RrtConnect, ThroughTheDoorOrOverTheWallNeverThroughIt) {
  // The straight line between the waypoints crosses the wall: 30 m steps on both sides of it
  // would pass straight through it unless every step is checked.
  const Mesh mesh = wall_with_door();
  const ClearanceIndex index(mesh);
  const std::vector<Point3> waypoints{{356030, 5699060, 15}, {356030, 5699140, 15}};
  PlanOptions options = rrt_options(40);
  options.max_edge = 30;
  int solved = 0;
  for (uint64_t seed = 1; seed <= 5; ++seed) {
    options.seed = seed;
    const PlanResult r = plan_rrt_connect(index, waypoints, options);
    expect_path_verified(mesh, index, waypoints, r, options.safety);
    expect_tree_steps(index, r, options.max_edge);
    solved += r.status == PlanStatus::Solved;
  }
  EXPECT_EQ(solved, 5);
}

TEST(RrtConnect, ProgressRisesToOneAndStoppingCancels) {
  // A leg that runs to the sample limit: progress reports along the way, then exactly 1.
  const Mesh mesh = two_islands();
  const ClearanceIndex index(mesh);
  const std::vector<Point3> waypoints{{356030, 5699050, 20}, {356230, 5699050, 20}};
  PlanOptions options = rrt_options(40);
  options.rrt_max_samples = 5000;
  std::vector<double> seen;
  const PlanResult r = plan_rrt_connect(index, waypoints, options, [&](double f) {
    seen.push_back(f);
    return true;
  });
  EXPECT_EQ(r.status, PlanStatus::NoPath);
  ASSERT_GE(seen.size(), 4u);  // every 1024 samples, and the end
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_GE(seen.front(), 0);
  EXPECT_EQ(seen.back(), 1);
  EXPECT_THROW(plan_rrt_connect(index, waypoints, options, [](double) { return false; }), Cancelled);
}

TEST(RrtConnect, OneSampleGrowsOneExtendAndOneConnectAtMost) {
  const Mesh mesh = two_islands();
  const ClearanceIndex index(mesh);
  const std::vector<Point3> waypoints{{356030, 5699050, 20}, {356230, 5699050, 20}};
  PlanOptions options = rrt_options(40);
  options.rrt_max_samples = 1;
  const PlanResult r = plan_path(index, waypoints, options);
  EXPECT_EQ(r.status, PlanStatus::NoPath);
  EXPECT_EQ(r.place(), "waypoints 1 to 2");
  EXPECT_NE(r.reason.find("within 1 sample "), std::string::npos) << r.reason;
  // Two roots, one EXTEND step, and a CONNECT run of at most distance / step + 1 steps.
  const double reach = dist(waypoints[0], waypoints[1]) + options.max_edge;
  EXPECT_LE(r.roadmap_nodes, 3 + static_cast<size_t>(reach / options.max_edge) + 1);
  EXPECT_GE(r.roadmap_nodes, 2u);
}

}  // namespace

// ---- very low altitude: query-time refinement (prm_query.cpp) --------------------------
// Street-level waypoints (5 m above the ground of a street or square) with a flight volume
// only 30 m (and less) deep; the refinement's paths verified by brute force, its determinism,
// and the grid lookup that joins waypoints to the roadmap against a scan over every node.

#include "../src/plan/prm_parts.hpp"

namespace {

// A point `agl` above street level near (x, y) (scenario::street_point) that is `safety` clear
// by brute force. Deterministic: the same mesh gives the same point.
Point3 street_waypoint(const Mesh& mesh, const ClearanceIndex& index, double x, double y, double agl, double safety) {
  auto lifted = [agl](Point3 p) {
    p[2] += agl;
    return p;
  };
  const auto street = scenario::street_point(index, x, y, [&](const Point3& p) {
    return brute_clearance(mesh, index.origin(), lifted(p), lifted(p), safety + 1) >= safety + 0.5;
  });
  if (street) return lifted(*street);
  ADD_FAILURE() << "no street near " << x << ", " << y;
  return {x, y, 1e4};
}

// Corners of the crop, 40 m in: south-west, north-east, north-west, south-east (three legs,
// two of them across the whole crop).
std::vector<Point3> street_corners(const Mesh& mesh, const ClearanceIndex& index) {
  const MeshBox b(mesh);
  const double in = 40;
  return {street_waypoint(mesh, index, b.x0 + in, b.y0 + in, 5, 2),
          street_waypoint(mesh, index, b.x1 - in, b.y1 - in, 5, 2),
          street_waypoint(mesh, index, b.x0 + in, b.y1 - in, 5, 2),
          street_waypoint(mesh, index, b.x1 - in, b.y0 + in, 5, 2)};
}

TEST(LowAltitude, StreetWaypointsThirtyMetresDeepAreVerifiedByBruteForce) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = street_corners(mesh, index);
  PlanOptions options;
  options.max_agl = 30;
  const PlanResult result = plan_path(index, waypoints, options);
  expect_path_verified(mesh, index, waypoints, result, options.safety);
  RecordProperty("refined_samples", std::to_string(result.refined_samples));
  RecordProperty("path_length_m", std::to_string(path_length(result.path)));
}

TEST(LowAltitude, RefinementSolvesWhatTheRoadmapAloneCannot) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = street_corners(mesh, index);
  for (double agl : {20.0, 15.0, 10.0}) {
    PlanOptions options;
    options.max_agl = agl;
    options.refine_rounds = 0;
    const PlanResult alone = plan_path(index, waypoints, options);
    options.refine_rounds = PlanOptions{}.refine_rounds;
    const PlanResult refined = plan_path(index, waypoints, options);
    expect_path_verified(mesh, index, waypoints, refined, options.safety);
    RecordProperty("alone_" + std::to_string(int(agl)), alone.status == PlanStatus::Solved ? "solved" : alone.place());
    RecordProperty("refined_samples_" + std::to_string(int(agl)), std::to_string(refined.refined_samples));
    if (agl <= 15) {
      // The roadmap alone fails here: refinement did the work (at 10 m through its widened
      // rounds, along the streets).
      EXPECT_EQ(alone.status, PlanStatus::NoPath);
      EXPECT_EQ(alone.refined_samples, 0u);
      EXPECT_EQ(alone.lattice_nodes, 0u);
      EXPECT_GT(refined.refined_samples + refined.lattice_nodes, 0u);
    }
    // The roadmap itself is untouched by queries (multi-query): the same for both.
    EXPECT_EQ(alone.roadmap_nodes, refined.roadmap_nodes);
    EXPECT_EQ(alone.roadmap_edges, refined.roadmap_edges);
  }
}

TEST(LowAltitude, RefinementIsTheSameOnOneAndTwoThreads) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = street_corners(mesh, index);
  PlanOptions options;
  options.max_agl = 10;  // every refinement stage: finer levels, then widened rounds
  options.threads = 1;
  const PlanResult one = plan_path(index, waypoints, options);
  options.threads = 2;
  const PlanResult two = plan_path(index, waypoints, options);
  const Roadmap map = build_roadmap(index, options);
  const PlanResult reused = query_roadmap(map, index, waypoints, options);
  ASSERT_EQ(one.status, PlanStatus::Solved) << one.reason;
  EXPECT_GT(one.refined_samples + one.lattice_nodes, 0u);
  EXPECT_EQ(one.refined_samples, two.refined_samples);
  EXPECT_EQ(one.lattice_nodes, two.lattice_nodes);
  EXPECT_EQ(one.raw_path, two.raw_path);
  EXPECT_EQ(one.path, two.path);
  EXPECT_EQ(reused.path, two.path);
}

TEST(LowAltitude, ComponentLabelsOnlySpareSearchesThatWouldFail) {
  // label_components() against a breadth-first search over the lists taken both ways, on the
  // roadmaps of 20 m and 10 m ceilings (many components) and on lists made one-sided.
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = street_corners(mesh, index);
  for (double agl : {20.0, 10.0}) {
    PlanOptions options;
    options.max_agl = agl;
    Roadmap map = build_roadmap(index, options);
    for (bool one_sided : {false, true}) {
      if (one_sided) {  // keep each edge listed from its lower end only, as a damaged file might
        Roadmap half = map;
        half.neighbour.clear();
        half.start.assign(1, 0);
        for (uint32_t u = 0; u < map.nodes.size(); ++u) {
          for (uint32_t k = map.start[u]; k < map.start[u + 1]; ++k)
            if (map.neighbour[k] > u) half.neighbour.push_back(map.neighbour[k]);
          half.start.push_back(static_cast<uint32_t>(half.neighbour.size()));
        }
        label_components(half);
        EXPECT_EQ(half.component, map.component);
        continue;
      }
      std::vector<std::vector<uint32_t>> both(map.nodes.size());
      for (uint32_t u = 0; u < map.nodes.size(); ++u)
        for (uint32_t k = map.start[u]; k < map.start[u + 1]; ++k) {
          both[u].push_back(map.neighbour[k]);
          both[map.neighbour[k]].push_back(u);
        }
      std::vector<uint32_t> label(map.nodes.size(), UINT32_MAX);
      size_t components = 0;
      for (uint32_t first = 0; first < map.nodes.size(); ++first) {
        if (label[first] != UINT32_MAX) continue;
        ++components;
        std::vector<uint32_t> stack{first};
        label[first] = first;
        while (!stack.empty()) {
          const uint32_t u = stack.back();
          stack.pop_back();
          for (uint32_t v : both[u])
            if (label[v] == UINT32_MAX) label[v] = first, stack.push_back(v);
        }
      }
      EXPECT_EQ(map.component, label) << agl;
      EXPECT_GT(components, 1u) << agl;  // else the labels spare nothing here
    }
    // A query with the labels and one without (a roadmap made by hand) give the same path, with
    // legs A* cannot fly over the roadmap among them (the refinement flew them).
    Roadmap unlabelled_map = map;
    unlabelled_map.component.clear();
    const PlanResult labelled = query_roadmap(map, index, waypoints, options);
    const PlanResult unlabelled = query_roadmap(unlabelled_map, index, waypoints, options);
    ASSERT_EQ(labelled.status, PlanStatus::Solved) << labelled.reason;
    EXPECT_GT(labelled.lattice_nodes + labelled.refined_samples, 0u) << agl;  // legs the labels spared A* for
    EXPECT_EQ(labelled.raw_path, unlabelled.raw_path) << agl;
    EXPECT_EQ(labelled.path, unlabelled.path) << agl;
    EXPECT_EQ(labelled.refined_samples, unlabelled.refined_samples) << agl;
    EXPECT_EQ(labelled.lattice_nodes, unlabelled.lattice_nodes) << agl;
  }
}

TEST(LowAltitude, ComponentLabelsNeverSpareASearchThatWouldSucceed) {
  // A roadmap made by hand over flat ground: a chain of five nodes 10 m up, and a lone node
  // nearer the first waypoint than the chain's end. With one link a waypoint, A* joins the first
  // waypoint to the lone node only and fails; the refinement's first search, which joins it to
  // every node within max_edge, finds the chain. The labels may spare A* (no common component of
  // the links) but not that search (a node near each waypoint shares the chain's component), so
  // the path is the chain, with or without labels, and no lattice is searched.
  Grid flat(50, 50, 0, 200, 4, 4);
  std::fill(flat.z.begin(), flat.z.end(), 0.0f);
  const ClearanceIndex index(triangulate_xy3(flat));
  Roadmap map;
  map.nodes = {{20, 110, 10}, {40, 100, 10}, {70, 100, 10}, {100, 100, 10}, {130, 100, 10}, {160, 100, 10}};
  const std::vector<std::vector<uint32_t>> lists = {{}, {2}, {1, 3}, {2, 4}, {3, 5}, {4}};
  map.start = {0};
  for (const auto& list : lists) {
    map.neighbour.insert(map.neighbour.end(), list.begin(), list.end());
    map.start.push_back(static_cast<uint32_t>(map.neighbour.size()));
  }
  label_components(map);
  ASSERT_EQ(map.component, (std::vector<uint32_t>{0, 1, 1, 1, 1, 1}));
  PlanOptions options;
  options.connections = 1;
  const Point3 a{20, 100, 10}, b{180, 100, 10};
  Roadmap unlabelled = map;
  unlabelled.component.clear();
  const PlanResult labelled = query_roadmap(map, index, {a, b}, options);
  const PlanResult without = query_roadmap(unlabelled, index, {a, b}, options);
  ASSERT_EQ(labelled.status, PlanStatus::Solved) << labelled.reason;
  const std::vector<Point3> chain{a, map.nodes[1], map.nodes[2], map.nodes[3], map.nodes[4], map.nodes[5], b};
  EXPECT_EQ(labelled.raw_path, chain);
  EXPECT_EQ(without.raw_path, chain);
  EXPECT_EQ(labelled.lattice_nodes, 0u);
  EXPECT_EQ(labelled.refined_samples, 0u);
}

TEST(LowAltitude, RefinementIsBoundedAndSaysWhy) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = street_corners(mesh, index);
  PlanOptions options;
  options.max_agl = 6;  // a 6 m layer: no way over any building
  options.refine_rounds = 2;
  const PlanResult r = plan_path(index, waypoints, options);
  ASSERT_EQ(r.status, PlanStatus::NoPath);
  EXPECT_LE(r.refine_rounds, 2 * 3);  // at most refine_rounds a leg, one failing leg stops the query
  EXPECT_NE(r.reason.find("refinement rounds"), std::string::npos) << r.reason;
  EXPECT_EQ(r.reason.find('\n'), std::string::npos);
  options.refine_rounds = -1;
  EXPECT_THROW(plan_path(index, waypoints, options), ArgumentError);
}

TEST(LowAltitude, RefinementStopsAtItsWorkBoundsAndNamesThem) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto waypoints = street_corners(mesh, index);
  PlanOptions options;
  options.max_agl = 10;  // solved with refinement (RefinementIsTheSameOnOneAndTwoThreads)
  const PlanResult free = plan_path(index, waypoints, options);
  ASSERT_EQ(free.status, PlanStatus::Solved) << free.reason;
  // The same legs with bounds at their least: stopped at once, each bound reached named, held.
  const auto bounded = [&](size_t PlanOptions::*bound, const std::string& named) {
    PlanOptions o = options;
    o.refine_max_lattice_nodes = 1;
    o.*bound = 1;
    const PlanResult r = plan_path(index, waypoints, o);
    EXPECT_EQ(r.status, PlanStatus::NoPath);
    for (const std::string& said : {std::string("a lattice search stopped at its bound of 1 nodes"), named})
      EXPECT_NE(r.reason.find(said), std::string::npos) << said << " in: " << r.reason;
    EXPECT_EQ(r.reason.find('\n'), std::string::npos);
    return r;
  };
  EXPECT_LE(bounded(&PlanOptions::refine_max_samples, "stopped at its bound of 1 added samples").refined_samples, 1u);
  bounded(&PlanOptions::refine_max_search_work, "stopped at its bound of 1 candidate edges searched");
  // On a machine with little memory (DSMPLAN_MAX_MEMORY, as ulimit -v would say it) the bounds
  // are what a quarter of it holds, and the reason says so: the refusal, not the kernel's kill.
  const Roadmap map = build_roadmap(index, options);
  ::setenv("DSMPLAN_MAX_MEMORY", "64K", 1);
  const PlanResult small = query_roadmap(map, index, waypoints, options);
  ::unsetenv("DSMPLAN_MAX_MEMORY");
  ASSERT_EQ(small.status, PlanStatus::NoPath);
  EXPECT_NE(small.reason.find("(what a quarter of this machine's memory, 64 kB, holds)"), std::string::npos)
      << small.reason;
  EXPECT_LE(small.refined_samples, 65536 / 4 / 256);
  options.refine_max_samples = 0;
  EXPECT_THROW(plan_path(index, waypoints, options), ArgumentError);
}

// A 120 m square of ground at z = 0 with two walls 30 m tall across it, each with a 20 m gap at
// opposite ends (or, closed, without it): under a 15 m ceiling a leg from the south to the north
// must snake east through the first gap and west through the second.
// A box from z = 0 to z1 over [x0, x1] x [y0, y1] (metres east and north of 356000, 5699000):
// its top and, when z1 > 0, its four walls.
void add_box(Mesh& mesh, double x0, double y0, double x1, double y1, double z1) {
  const double x = 356000, y = 5699000;
  const auto v = static_cast<uint32_t>(mesh.vertices.size());
  for (double z : {0.0, z1})
    mesh.vertices.insert(mesh.vertices.end(),
                         {{x + x0, y + y0, z}, {x + x1, y + y0, z}, {x + x1, y + y1, z}, {x + x0, y + y1, z}});
  mesh.triangles.push_back({v + 4, v + 5, v + 6});
  mesh.triangles.push_back({v + 4, v + 6, v + 7});
  for (uint32_t k = 0; k < 4 && z1 > 0; ++k) {
    const uint32_t a = v + k, b = v + (k + 1) % 4;
    mesh.triangles.push_back({a, b, b + 4});
    mesh.triangles.push_back({a, b + 4, a + 4});
  }
}

Mesh maze(bool closed) {
  Mesh mesh;
  const auto box = [&](double x0, double y0, double x1, double y1, double z1) { add_box(mesh, x0, y0, x1, y1, z1); };
  box(0, 0, 120, 120, 0);
  box(0, 40, 100, 41, 30);
  box(closed ? 0 : 20, 80, 120, 81, 30);
  return mesh;
}

// The independent answer: an eager Dijkstra over the same lattice (anchored at a, side h, 26
// neighbours, a node valid when over the maze's ground, 0 <= z <= ceiling and brute-force
// clear, an edge when
// brute-force clear; the goal reached from a node within 2h of b by a clear segment): the
// least lattice cost to b, or infinity.
double lattice_oracle(const Mesh& mesh, const Point3& origin, const Point3& a, const Point3& b, double h, double safety,
                      double ceiling) {
  const int span = 40;  // the maze fits in +-40 steps of 5 m
  auto id = [&](int i, int j, int k) {
    return ((i + span) * (2 * span + 1) + (j + span)) * (2 * span + 1) + (k + span);
  };
  auto at = [&](int i, int j, int k) { return Point3{a[0] + i * h, a[1] + j * h, a[2] + k * h}; };
  auto segment_ok = [&](const Point3& p, const Point3& q) {
    return std::max(p[2], q[2]) <= ceiling && brute_clearance(mesh, origin, p, q, safety + 1) >= safety;
  };
  std::map<int, double> cost;
  std::set<int> done;
  std::map<int, int> valid;
  auto node_ok = [&](int i, int j, int k) {
    auto [it, fresh] = valid.try_emplace(id(i, j, k), 0);
    if (fresh) {
      const Point3 p = at(i, j, k);
      const bool over = p[0] >= 356000 && p[0] <= 356120 && p[1] >= 5699000 && p[1] <= 5699120;
      it->second = over && p[2] >= 0 && segment_ok(p, p);
    }
    return it->second == 1;
  };
  using Item = std::tuple<double, int, int, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  open.emplace(0, 0, 0, 0);
  double best = INFINITY;
  while (!open.empty()) {
    const auto [g, i, j, k] = open.top();
    open.pop();
    if (g >= best) break;
    if (!done.insert(id(i, j, k)).second) continue;
    const Point3 p = at(i, j, k);
    if (dist(p, b) <= 2 * h && segment_ok(p, b)) best = std::min(best, g + dist(p, b));
    for (int di = -1; di <= 1; ++di)
      for (int dj = -1; dj <= 1; ++dj)
        for (int dk = -1; dk <= 1; ++dk) {
          const int ni = i + di, nj = j + dj, nk = k + dk;
          if (std::max({std::abs(ni), std::abs(nj), std::abs(nk)}) > span || done.count(id(ni, nj, nk))) continue;
          if (!node_ok(ni, nj, nk) || !segment_ok(p, at(ni, nj, nk))) continue;
          const double c = g + h * std::sqrt(double(di * di + dj * dj + dk * dk));
          auto [it, fresh] = cost.try_emplace(id(ni, nj, nk), c);
          if (fresh || c < it->second) it->second = c, open.emplace(c, ni, nj, nk);
        }
  }
  return best;
}

TEST(LowAltitude, LatticeSearchFindsWhatAnEagerSearchFindsAtMostTwiceAsLong) {
  for (bool closed : {false, true}) {
    const Mesh mesh = maze(closed);
    const ClearanceIndex index(mesh);
    PlanOptions options;
    options.max_agl = 15;
    const FlightSpace space = detail::flight_space(index, options);
    const Point3 a{356010, 5699020, 5}, b{356012, 5699101, 6};
    const double h = 5;
    const detail::LatticeResult found = detail::lattice_path(space, a, b, h, 1000000);
    const double oracle = lattice_oracle(mesh, index.origin(), a, b, h, options.safety, options.max_agl);
    EXPECT_FALSE(found.out_of_work);
    EXPECT_GT(found.nodes, 50u);
    if (closed) {
      EXPECT_TRUE(std::isinf(oracle));
      EXPECT_TRUE(found.path.empty());
      continue;
    }
    ASSERT_TRUE(std::isfinite(oracle));
    ASSERT_GE(found.path.size(), 4u);  // at least two bends
    EXPECT_EQ(found.path.front(), a);
    EXPECT_EQ(found.path.back(), b);
    double length = 0;
    for (size_t k = 1; k < found.path.size(); ++k) {
      const Point3 &p = found.path[k - 1], &q = found.path[k];
      length += dist(p, q);
      EXPECT_GE(brute_clearance(mesh, index.origin(), p, q, options.safety + 1), options.safety) << k;
      EXPECT_LE(std::max(p[2], q[2]), options.max_agl) << k;  // the ground is z = 0 everywhere
      EXPECT_GE(std::min(p[2], q[2]), 0) << k;
    }
    // Through both gaps: the path goes east of the first wall's end and west of the second's.
    double east = -INFINITY, west = INFINITY;
    for (const Point3& p : found.path) east = std::max(east, p[0] - 356000), west = std::min(west, p[0] - 356000);
    EXPECT_GT(east, 100);
    EXPECT_LT(west, 20);
    // Weighted A* (weight 2) over the same lattice, then pulled tight: at most twice the least.
    EXPECT_LE(length, 2 * oracle + 1e-9);
    EXPECT_GE(length, dist(a, b));
    // The bound of nodes is kept, and says so.
    const detail::LatticeResult bounded = detail::lattice_path(space, a, b, h, 40);
    EXPECT_TRUE(bounded.out_of_work);
    EXPECT_TRUE(bounded.path.empty());
    EXPECT_LE(bounded.nodes, 40u + 26u);
  }
}

// The way out from a waypoint (lattice_escape(), the query's first step for a waypoint no
// roadmap node reaches): a Dijkstra over the same lattice to the nearest node an exit test
// accepts, here "within 2h of b with a clear segment to it" so that the eager oracle's least
// cost to b bounds it; only nodes within the radius (x,y) are made.
TEST(LowAltitude, EscapeReachesTheNearestExitAndStaysWithinItsRadius) {
  const Mesh mesh = maze(false);
  const ClearanceIndex index(mesh);
  PlanOptions options;
  options.max_agl = 15;
  const FlightSpace space = detail::flight_space(index, options);
  const Point3 a{356010, 5699020, 5}, b{356012, 5699101, 6};
  const double h = 5;
  const std::function<bool(const Point3&)> near_b = [&](const Point3& p) {
    return dist(p, b) <= 2 * h && space.motion_valid(p, b);
  };
  const detail::LatticeResult way = detail::lattice_escape(space, a, h, 500, 1000000, near_b);
  ASSERT_GE(way.path.size(), 3u);
  EXPECT_EQ(way.path.front(), a);
  EXPECT_TRUE(near_b(way.path.back()));
  double length = 0;
  for (size_t k = 1; k < way.path.size(); ++k) {
    const Point3 &p = way.path[k - 1], &q = way.path[k];
    length += dist(p, q);
    EXPECT_GE(brute_clearance(mesh, index.origin(), p, q, options.safety + 1), options.safety) << k;
    EXPECT_LE(std::max(p[2], q[2]), options.max_agl) << k;
  }
  // Dijkstra's least lattice cost, pulled tight: never more than the eager oracle's to b.
  const double oracle = lattice_oracle(mesh, index.origin(), a, b, h, options.safety, options.max_agl);
  EXPECT_LE(length + dist(way.path.back(), b), oracle + 1e-9);
  // Through the first gap (east of x = 100) a radius of 60 m cannot reach: nothing, and no node
  // made beyond it.
  const detail::LatticeResult bounded = detail::lattice_escape(space, a, h, 60, 1000000, near_b);
  EXPECT_TRUE(bounded.path.empty());
  EXPECT_FALSE(bounded.out_of_work);
  EXPECT_LT(bounded.nodes, way.nodes);
}

// A waypoint deep in a light well (8 x 8 m, walls 40 m tall) that no roadmap node sees: the
// query climbs out by a lattice around it (its escape) instead of one over the whole leg, and
// the path is verified by brute force.
TEST(LowAltitude, AWaypointInALightWellClimbsOutToTheRoadmap) {
  Mesh mesh;
  const double x = 356000, y = 5699000;
  const auto box = [&](double x0, double y0, double x1, double y1, double z1) { add_box(mesh, x0, y0, x1, y1, z1); };
  box(0, 0, 600, 300, 0);
  box(40, 40, 76, 46, 40), box(40, 54, 76, 60, 40), box(40, 46, 54, 54, 40), box(62, 46, 76, 54, 40);
  const ClearanceIndex index(mesh);
  PlanOptions options;
  options.max_agl = 120;
  const std::vector<Point3> waypoints{{x + 58, y + 50, 3}, {x + 560, y + 250, 5}};
  const Roadmap map = build_roadmap(index, options);
  const PlanResult result = query_roadmap(map, index, waypoints, options);
  expect_path_verified(mesh, index, waypoints, result, options.safety);
  EXPECT_GT(result.lattice_nodes, 0u);  // the roadmap alone could not
  EXPECT_LT(result.lattice_nodes, 50000u);
  double top = 0;
  for (const Point3& p : result.path) top = std::max(top, p[2]);
  EXPECT_GT(top, 40 + options.safety);  // out over the walls
}

TEST(LowAltitude, GridLookupJoinsTheSameNodesAsAScanOverAll) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  PlanOptions options;
  options.max_agl = 30;
  const Roadmap map = build_roadmap(index, options);
  ASSERT_GT(map.nodes.size(), 500u);
  std::vector<uint32_t> ids(map.nodes.size());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<uint32_t>(i);
  const detail::PointGrid grid(map.nodes, ids, options.max_edge);
  const MeshBox b(mesh);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> ux(b.x0, b.x1), uy(b.y0, b.y1), up(2, 40), jitter(-3, 3);
  int compared = 0, with_links = 0;
  for (int k = 0; k < 400; ++k) {
    // Half anywhere, half right beside a node (equal distances and cube borders included).
    Point3 w;
    if (k % 2) {
      const double x = ux(rng), y = uy(rng), g = index.ground(x, y);
      if (std::isnan(g)) continue;
      w = {x, y, g + up(rng)};
    } else {
      const Point3& p = map.nodes[rng() % map.nodes.size()];
      w = {p[0] + jitter(rng), p[1] + jitter(rng), p[2] + jitter(rng)};
    }
    for (int connections : {1, 10, 1000}) {
      options.connections = connections;
      // The scan over every node: what the query did before the grid.
      std::vector<std::pair<double, uint32_t>> near, links;
      for (size_t i = 0; i < map.nodes.size(); ++i) {
        const double d = dist(w, map.nodes[i]);
        if (d < options.max_edge) near.emplace_back(d, static_cast<uint32_t>(i));
      }
      std::sort(near.begin(), near.end());
      for (const auto& c : near)
        if (links.size() < static_cast<size_t>(connections) && index.segment_clear(w, map.nodes[c.second], 2) &&
            index.floor().below_ceiling(w, map.nodes[c.second], options.max_agl))
          links.push_back(c);
      EXPECT_EQ(detail::roadmap_links(w, map, grid, detail::flight_space(index, options), options), links) << k;
      ++compared;
      with_links += !links.empty();
    }
  }
  EXPECT_GT(compared, 900);
  EXPECT_GT(with_links, 300);
}

}  // namespace

// ---- a tiled city: the corridor planner --------------------------------------------------------

// The corridor planner never holds the whole DSM, and its path is checked against the whole
// DSM taken as solid columns (an oracle that knows nothing of its windows or meshes): at least
// the safety distance less half a cell diagonal (the windows' meshes are conservative), through
// every waypoint in order.
TEST(PlanCorridor, PathAcrossWindowsKeepsClearOfTheWholeDsm) {
  const Grid& dsm = testkit::nrw_full();
  const Mesh& mesh = mesh_bounded();  // only to place waypoints that are clear of the roofs
  const ClearanceIndex index(mesh);
  std::vector<Point3> waypoints = three_waypoints(mesh, index, 40);
  PlanOptions plan;
  plan.spacing = 15;
  CorridorOptions options;
  options.chunk = 120;
  options.margin = 40;
  testkit::CountingSource source(dsm);
  const CorridorResult result = plan_corridor(source, waypoints, plan, options);
  ASSERT_EQ(result.plan.status, PlanStatus::Solved) << result.plan.place() << ": " << result.plan.reason;
  EXPECT_GE(result.windows, 4u);
  EXPECT_EQ(result.plan.path.front(), waypoints.front());
  EXPECT_EQ(result.plan.path.back(), waypoints.back());
  size_t at = 0;
  for (const Point3& w : waypoints) {
    while (at < result.plan.path.size() && result.plan.path[at] != w) ++at;
    EXPECT_LT(at, result.plan.path.size()) << "waypoint missing or out of order";
  }
  const double tolerance = std::hypot(dsm.cell_x, dsm.cell_y) / 2;
  double worst = INFINITY;
  for (size_t k = 1; k < result.plan.path.size(); ++k)
    worst = std::min(worst, column_clearance(dsm, result.plan.path[k - 1], result.plan.path[k], 10));
  EXPECT_GE(worst, plan.safety - tolerance);
  EXPECT_GT(worst, 0);
  EXPECT_NEAR(worst, result.min_clearance_dsm_m, 1e-9);  // what it reports is what it flew
  EXPECT_GE(result.min_clearance_m, plan.safety);
  EXPECT_EQ(result.mesh_error.max_below, 0.0);  // conservative windows
  EXPECT_LE(result.mesh_error.max_above, options.mesh.max_error);
  // Bounded windows: a piece's box, its margin and the obstacle pad, far below the whole tile.
  const double side = options.chunk + 2 * options.margin + 2 * (plan.safety + 2 * dsm.cell_x) + 2;
  EXPECT_LE(source.largest, size_t(side * side));
  EXPECT_LT(source.largest, dsm.cells() / 4);
  EXPECT_EQ(result.largest_window_cells, source.largest);
}

TEST(PlanCorridor, WaypointOutsideTheDsmIsNamed) {
  const Grid& dsm = nrw_2m();
  GridView source(dsm);
  const std::vector<Point3> waypoints{{dsm.center_x(10), dsm.center_y(10), 200},
                                      {dsm.x1() + 50, dsm.center_y(10), 200}};
  const CorridorResult result = plan_corridor(source, waypoints, PlanOptions{}, CorridorOptions{});
  EXPECT_EQ(result.plan.status, PlanStatus::InvalidWaypoint);
  EXPECT_EQ(result.plan.place(), "waypoint 2");
  EXPECT_NE(result.plan.reason.find("outside the DSM's extent"), std::string::npos) << result.plan.reason;
  CorridorOptions bad;
  bad.chunk = 0;
  EXPECT_THROW(plan_corridor(source, waypoints, PlanOptions{}, bad), ArgumentError);
}

// ---- flight constraints: a no-fly zone, asked by every planner through FlightSpace -----------

namespace {

// The oracle: a point in the axis-aligned box [x0, x1] x [y0, y1] (all heights), and a segment
// sampled every 5 cm.
struct Box {
  double x0, x1, y0, y1;
  bool holds(const Point3& p) const { return p[0] >= x0 && p[0] <= x1 && p[1] >= y0 && p[1] <= y1; }
  bool touched_by(const Point3& p, const Point3& q) const {
    const int steps = std::max(1, static_cast<int>(std::ceil(detail_length(p, q) / 0.05)));
    for (int k = 0; k <= steps; ++k) {
      const double t = static_cast<double>(k) / steps;
      if (holds({p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), p[2] + t * (q[2] - p[2])})) return true;
    }
    return false;
  }
  static double detail_length(const Point3& p, const Point3& q) {
    return std::hypot(q[0] - p[0], q[1] - p[1], q[2] - p[2]);
  }
  std::shared_ptr<NoFlyZone> zone(const std::string& name) const {
    return std::make_shared<NoFlyZone>(name,
                                       std::vector<std::array<double, 2>>{{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}});
  }
};

bool path_touches(const std::vector<Point3>& path, const Box& box) {
  for (size_t k = 1; k < path.size(); ++k)
    if (box.touched_by(path[k - 1], path[k])) return true;
  return false;
}

// The point halfway along a path.
Point3 middle_of(const std::vector<Point3>& path) {
  double left = path_length(path) / 2;
  for (size_t k = 1; k < path.size(); ++k) {
    const double d = Box::detail_length(path[k - 1], path[k]);
    if (d >= left) {
      const double t = left / d;
      return {path[k - 1][0] + t * (path[k][0] - path[k - 1][0]), path[k - 1][1] + t * (path[k][1] - path[k - 1][1]),
              0};
    }
    left -= d;
  }
  return path.back();
}

}  // namespace

TEST(NoFlyZone, AgreesWithDenseSamplingOnRandomSegments) {
  // A concave star of 10 corners with a height band, and random segments through its box.
  std::vector<std::array<double, 2>> star;
  for (int k = 0; k < 10; ++k) {
    const double r = k % 2 ? 20 : 50, a = k * M_PI / 5;
    star.push_back({100 + r * std::cos(a), 200 + r * std::sin(a)});
  }
  const NoFlyZone zone("star", star, 10, 40);
  auto inside = [&](const Point3& p) {  // crossing number, written again for the oracle
    if (p[2] < 10 || p[2] > 40) return false;
    bool odd = false;
    for (size_t i = 0, j = star.size() - 1; i < star.size(); j = i++)
      if ((star[j][1] > p[1]) != (star[i][1] > p[1]) &&
          p[0] < star[j][0] + (p[1] - star[j][1]) * (star[i][0] - star[j][0]) / (star[i][1] - star[j][1]))
        odd = !odd;
    return odd;
  };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> x(30, 170), y(130, 270), z(0, 50);
  int blocked = 0, agreed = 0;
  const int n = 3000;
  for (int i = 0; i < n; ++i) {
    const Point3 p{x(rng), y(rng), z(rng)}, q{x(rng), y(rng), z(rng)};
    EXPECT_EQ(zone.state_valid(p), !inside(p));
    bool sampled_inside = false;
    for (int k = 0; k <= 4000 && !sampled_inside; ++k) {
      const double t = k / 4000.0;
      sampled_inside = inside({p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), p[2] + t * (q[2] - p[2])});
    }
    const bool valid = zone.motion_valid(p, q);
    // Never optimistic: a sampled point inside means the exact test must refuse the motion.
    if (sampled_inside) EXPECT_FALSE(valid) << i;
    blocked += !valid;
    agreed += valid != sampled_inside;
  }
  // Sampling can only miss a graze thinner than a step: nearly all answers agree.
  EXPECT_GE(agreed, n - 10);
  EXPECT_GT(blocked, n / 5);
  EXPECT_LT(blocked, n - n / 5);
  EXPECT_THROW(NoFlyZone("two", {{0, 0}, {1, 1}}), ArgumentError);
  EXPECT_THROW(NoFlyZone("upside down", star, 40, 10), ArgumentError);
}

TEST(NoFlyZone, EveryPlannerGoesAroundItAndAWaypointInsideIsRefused) {
  const Mesh& mesh = mesh_2m();
  const ClearanceIndex index(mesh);
  const auto three = three_waypoints(mesh, index);
  const std::vector<Point3> waypoints{three[0], three[2]};
  for (PlannerKind planner : {PlannerKind::prm, PlannerKind::rrt_connect}) {
    PlanOptions options;
    options.planner = planner;
    options.max_agl = 45;
    options.spacing = 15;
    const PlanResult free = plan_path(index, waypoints, options);
    ASSERT_EQ(free.status, PlanStatus::Solved) << free.reason;
    // A 60 m square over all heights where the unconstrained path is halfway: it must go around.
    const Point3 m = middle_of(free.path);
    const Box box{m[0] - 30, m[0] + 30, m[1] - 30, m[1] + 30};
    ASSERT_TRUE(path_touches(free.path, box));
    options.constraints = {box.zone("square")};
    const PlanResult around = plan_path(index, waypoints, options);
    expect_path_verified(mesh, index, waypoints, around, options.safety);
    EXPECT_FALSE(path_touches(around.path, box)) << (planner == PlannerKind::prm ? "prm" : "rrt-connect");
    EXPECT_FALSE(path_touches(around.raw_path, box));
    // A waypoint inside the zone: refused, naming the zone.
    const PlanResult bad = plan_path(index, {waypoints[0], {m[0], m[1], waypoints[0][2]}, waypoints[1]}, options);
    EXPECT_EQ(bad.status, PlanStatus::InvalidWaypoint);
    EXPECT_EQ(bad.waypoint, 1u);
    EXPECT_NE(bad.reason.find("no-fly zone 'square'"), std::string::npos) << bad.reason;
  }
  // A roadmap file does not record constraints, so it is not written or read under them.
  PlanOptions options;
  options.constraints = {Box{0, 1, 0, 1}.zone("tiny")};
  const testkit::TempDir dir;
  EXPECT_THROW(write_roadmap(dir.path("zone.roadmap"), Roadmap{}, 1, options), ArgumentError);
  EXPECT_TRUE(dir.files().empty());
}

// A failed route's numbers (RouteFailure) and its words (failure_in_words()) name the same
// waypoint and leg, along a mission's route [takeoff top, 1, 2, 3, takeoff top] and a route alone.
TEST(RouteFailure, NumbersTheWaypointsAndLegsAsTheWordsNameThem) {
  dsmplan::MissionSite site;
  site.leading = true, site.returns = true;
  const size_t user = 3, route = user + 2;
  const auto number = [](size_t n) { return n == 0 ? std::string("takeoff") : std::to_string(n); };
  const std::vector<const dsmplan::MissionSite*> sites{&site, nullptr};
  for (const dsmplan::MissionSite* s : sites) {
    const size_t count = s ? route : user;
    for (size_t w = 0; w + 1 < count; ++w) {
      dsmplan::PlanResult leg;
      leg.status = dsmplan::PlanStatus::NoPath;
      leg.waypoint = w;
      const dsmplan::RouteFailure f = dsmplan::route_failure(leg, s, user);
      EXPECT_EQ(f.code, "no_path");
      ASSERT_TRUE(f.leg.has_value());
      EXPECT_FALSE(f.waypoint.has_value());
      const auto [from, to] = *f.leg;
      const std::string words = dsmplan::failure_in_words(leg, s, user).place;
      if (from == 0)
        EXPECT_NE(words.find("takeoff above --home to waypoint " + number(to)), std::string::npos) << words;
      else if (to == 0)
        EXPECT_NE(words.find("waypoint " + number(from) + " back above home"), std::string::npos) << words;
      else
        EXPECT_EQ(words, "waypoints " + number(from) + " to " + number(to));
    }
    for (size_t w = 0; w < count; ++w) {
      dsmplan::PlanResult refused;
      refused.status = dsmplan::PlanStatus::InvalidWaypoint;
      refused.waypoint = w;
      refused.invalid = {{w, "under the surface", dsmplan::Point3{1, 2, 3}}};
      const dsmplan::RouteFailure f = dsmplan::route_failure(refused, s, user);
      EXPECT_EQ(f.code, "waypoint_refused");
      EXPECT_EQ(f.nearest, (dsmplan::Point3{1, 2, 3}));
      const std::string words = dsmplan::failure_in_words(refused, s, user).place;
      ASSERT_TRUE(f.waypoint.has_value());
      EXPECT_FALSE(f.leg.has_value());
      EXPECT_EQ(words, *f.waypoint == 0 ? "the takeoff's top above --home" : "waypoint " + number(*f.waypoint));
    }
  }
}
