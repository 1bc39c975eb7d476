// The limits of a path held against the data itself (plan.hpp, "holding a mesh plan to the
// DSM's columns"; ground.hpp): every point of a path keeps the safety distance from the DSM
// taken as solid columns (holes as high as their rim), and no point is higher above the ground
// (the DSM's cells, or the terrain) than the ceiling. Checked on real data by checkers written
// here, independent of the planner's: the distance from a segment to a box by a ternary search
// (it is convex along the segment), the height above ground by clipping the segment to every
// cell's square.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <random>

#include "dsmplan/columns.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/point_io.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/tools.hpp"
#include "street_point.hpp"
#include "testkit.hpp"

namespace {

using namespace dsmplan;

Point3 lerp(const Point3& a, const Point3& b, double t) {
  return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

// ---- the independent checkers ------------------------------------------------------------

double point_box(const Point3& x, double x0, double x1, double y0, double y1, double top) {
  const double dx = std::max({x0 - x[0], 0.0, x[0] - x1});
  const double dy = std::max({y0 - x[1], 0.0, x[1] - y1});
  const double dz = std::max(0.0, x[2] - top);
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// The distance to a convex set is convex along a segment: a ternary search finds its least value.
double segment_box(const Point3& p, const Point3& q, double x0, double x1, double y0, double y1, double top) {
  auto f = [&](double t) { return point_box(lerp(p, q, t), x0, x1, y0, y1, top); };
  double a = 0, b = 1;
  for (int i = 0; i < 200; ++i) {
    const double m1 = a + (b - a) / 3, m2 = b - (b - a) / 3;
    if (f(m1) < f(m2))
      b = m2;
    else
      a = m1;
  }
  return std::min({f(0), f(1), f(0.5 * (a + b))});
}

// Least distance (up to `reach`) from the segment to the columns of `grid` (NaN cells: air).
double columns_distance(const Grid& grid, const Point3& p, const Point3& q, double reach) {
  double best = reach;
  const double low = std::min(p[2], q[2]);
  const int c0 = std::max(0, static_cast<int>(std::floor((std::min(p[0], q[0]) - reach - grid.x0) / grid.cell_x)));
  const int c1 =
      std::min(grid.width - 1, static_cast<int>(std::floor((std::max(p[0], q[0]) + reach - grid.x0) / grid.cell_x)));
  const int r0 = std::max(0, static_cast<int>(std::floor((grid.y0 - std::max(p[1], q[1]) - reach) / grid.cell_y)));
  const int r1 =
      std::min(grid.height - 1, static_cast<int>(std::floor((grid.y0 - std::min(p[1], q[1]) + reach) / grid.cell_y)));
  for (int r = r0; r <= r1; ++r)
    for (int c = c0; c <= c1; ++c) {
      const float h = grid.at(c, r);
      if (std::isnan(h) || h < low - reach) continue;
      const double x0 = grid.x0 + c * grid.cell_x, y1 = grid.y0 - r * grid.cell_y;
      best = std::min(best, segment_box(p, q, x0, x0 + grid.cell_x, y1 - grid.cell_y, y1, h));
    }
  return best;
}

// Greatest height of the segment above the ground: over each cell's closed square the segment
// is one straight piece (Liang-Barsky clipping), highest at one of its ends. +inf where the
// segment leaves the grid or crosses a cell without ground.
double height_above_ground(const Grid& ground, const Point3& p, const Point3& q) {
  double best = -INFINITY;
  auto cell_of = [&](double x, double y, int& c, int& r) {
    c = static_cast<int>(std::floor((x - ground.x0) / ground.cell_x));
    r = static_cast<int>(std::floor((ground.y0 - y) / ground.cell_y));
  };
  for (const Point3& e : {p, q})
    if (!(e[0] >= ground.x0 && e[0] <= ground.x1() && e[1] >= ground.y1() && e[1] <= ground.y0)) return INFINITY;
  int ca, ra, cb, rb;
  cell_of(std::min(p[0], q[0]), std::max(p[1], q[1]), ca, ra);
  cell_of(std::max(p[0], q[0]), std::min(p[1], q[1]), cb, rb);
  if (ca < -1 || ra < -1 || cb > ground.width || rb > ground.height) return INFINITY;
  for (int r = std::max(0, ra - 1); r <= std::min(ground.height - 1, rb + 1); ++r)
    for (int c = std::max(0, ca - 1); c <= std::min(ground.width - 1, cb + 1); ++c) {
      const double x0 = ground.x0 + c * ground.cell_x, x1 = x0 + ground.cell_x;
      const double y1 = ground.y0 - r * ground.cell_y, y0 = y1 - ground.cell_y;
      double t0 = 0, t1 = 1;
      const double d[2] = {q[0] - p[0], q[1] - p[1]}, lo[2] = {x0, y0}, hi[2] = {x1, y1};
      bool inside = true;
      for (int k = 0; k < 2 && inside; ++k) {
        if (d[k] == 0) {
          inside = p[k] >= lo[k] && p[k] <= hi[k];
          continue;
        }
        double ta = (lo[k] - p[k]) / d[k], tb = (hi[k] - p[k]) / d[k];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta), t1 = std::min(t1, tb);
        inside = t0 <= t1;
      }
      if (!inside) continue;
      const float g = ground.at(c, r);
      if (std::isnan(g)) return INFINITY;
      best = std::max(best, std::max(lerp(p, q, t0)[2], lerp(p, q, t1)[2]) - g);
    }
  return best;
}

// ---- scenarios ---------------------------------------------------------------------------

struct Limits {
  double min_clearance = INFINITY;  // to the columns, over every checked path
  double max_agl = -INFINITY;
  int solved = 0, missions = 0;
};

// `missions` random low-altitude missions (2 or 3 waypoints 5-15 m above streets, a 30 m
// ceiling, 2 m safety) over `dsm` (its ground the DSM's cells, or `dtm`), planned as
// `dsmplan plan MESH --dsm DSM [--dtm DTM]` does on the conservative bounded mesh of the DSM,
// every solved path checked by the checkers above.
Limits fly_missions(const Grid& dsm, const Grid* dtm, int missions, uint64_t seed) {
  Grid columns = dsm;
  fill_holes_from_rim(columns, RimHeight::highest);
  BoundedSimplifyOptions conservative;
  conservative.conservative = true;
  Mesh mesh = simplify_bounded(dsm, conservative);
  PlanOptions plan;
  plan.safety = 2;
  plan.max_agl = 30;
  plan.spacing = 12;
  plan.ground = std::make_shared<GroundGrid>(dtm ? *dtm : dsm);
  Grid ground = dtm ? *dtm : dsm;  // the checker's ground: holes as low as their rim (ground.hpp)
  fill_holes_from_rim(ground, RimHeight::lowest);
  PlanOptions on_mesh = plan;
  on_mesh.safety += column_margin(mesh, dsm);
  const Mesh holes = hole_columns(dsm, columns);
  const uint32_t offset = static_cast<uint32_t>(mesh.vertices.size());
  mesh.vertices.insert(mesh.vertices.end(), holes.vertices.begin(), holes.vertices.end());
  for (Triangle t : holes.triangles) mesh.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  const ClearanceIndex index(mesh);
  const Roadmap map = build_roadmap(index, on_mesh);

  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  const ClearanceIndex::Footprint& e = index.footprint();
  const double in = 0.1 * std::min(e.xmax - e.xmin, e.ymax - e.ymin);
  Limits limits;
  for (int m = 0; m < missions; ++m) {
    std::vector<Point3> waypoints;
    const int count = 2 + static_cast<int>(unit(rng) * 2);
    for (int tries = 0; static_cast<int>(waypoints.size()) < count && tries < 50; ++tries) {
      const double x = e.xmin + in + unit(rng) * (e.xmax - e.xmin - 2 * in);
      const double y = e.ymin + in + unit(rng) * (e.ymax - e.ymin - 2 * in);
      const double h = 5 + 10 * unit(rng);
      Point3 chosen;
      auto flyable = [&](const Point3& p) {
        chosen = {p[0], p[1], p[2] + h};
        return index.point_clear(chosen, on_mesh.safety) && plan.ground->height_above(chosen) <= plan.max_agl;
      };
      if (!dtm) {
        if (scenario::street_point(index, x, y, flyable)) waypoints.push_back(chosen);
      } else {
        // On the ground (the surface within 1 m of the terrain), not on a roof or a tree.
        const double surface = index.ground(x, y), terrain = h - plan.ground->height_above({x, y, h});
        if (surface <= terrain + 1 && flyable({x, y, surface})) waypoints.push_back(chosen);
      }
    }
    if (waypoints.size() < 2) continue;
    ++limits.missions;
    const PlanResult result = query_roadmap(map, index, waypoints, on_mesh);
    if (result.status != PlanStatus::Solved) continue;
    ++limits.solved;
    // Through every waypoint, in order, exactly.
    size_t next = 0;
    for (const Point3& p : result.path)
      if (next < waypoints.size() && p == waypoints[next]) ++next;
    EXPECT_EQ(next, waypoints.size()) << "mission " << m;
    for (size_t k = 1; k < result.path.size(); ++k) {
      const double d = columns_distance(columns, result.path[k - 1], result.path[k], plan.safety + 1);
      const double above = height_above_ground(ground, result.path[k - 1], result.path[k]);
      limits.min_clearance = std::min(limits.min_clearance, d);
      limits.max_agl = std::max(limits.max_agl, above);
      EXPECT_GE(d, plan.safety - 1e-6) << "mission " << m << " segment " << k;
      EXPECT_LE(above, plan.max_agl + 1e-6) << "mission " << m << " segment " << k;
    }
  }
  return limits;
}

void expect_flown(const Limits& limits, int missions, const char* name) {
  std::printf(
      "%s: %d of %d missions solved, least clearance to the columns %.3f m, greatest height above ground %.3f m\n",
      name, limits.solved, limits.missions, limits.min_clearance, limits.max_agl);
  EXPECT_EQ(limits.missions, missions) << name << ": street waypoints not found";
  // Street to street under a 30 m ceiling: nearly all are flyable; a checker of no path checks nothing.
  EXPECT_GE(limits.solved, limits.missions * 8 / 10) << name;
}

TEST(PlanLimits, RandomLowMissionsOverNrwAt1mKeepSafetyAndCeilingAgainstTheColumns) {
  const Limits limits = fly_missions(testkit::nrw_crop(), nullptr, 40, 1401);
  expect_flown(limits, 40, "NRW 1 m");
}

TEST(PlanLimits, RandomLowMissionsOverNrwAt2mKeepSafetyAndCeilingAgainstTheColumns) {
  const Grid coarse = resample(testkit::nrw_crop(), 2, Resampling::Median);
  const Limits limits = fly_missions(coarse, nullptr, 40, 1402);
  expect_flown(limits, 40, "NRW 2 m");
}

TEST(PlanLimits, RandomLowMissionsOverDelftKeepSafetyAboveTheDsmAndCeilingAboveTheTerrain) {
  // The terrain from the same LiDAR, ground points (class 2) alone, at another resolution.
  std::vector<PointCloud> clouds{read_las(testkit::data_path("delft-ahn3/ahn3_cropped_1.las")),
                                 read_las(testkit::data_path("delft-ahn3/ahn3_cropped_2.las"))};
  GridPointsOptions ground_points;
  ground_points.resolution = 1.0;
  ground_points.keep_classes = {2};
  const Grid dtm = grid_points(clouds, ground_points);
  const Limits limits = fly_missions(testkit::delft_grid(), &dtm, 30, 1403);
  expect_flown(limits, 30, "Delft DSM/DTM");
}

// ---- a terrain that disagrees with its surface (ground.hpp) --------------------------------

// The Delft DTM (ground points, class 2, 1 m) from the LiDAR of testkit::delft_grid() (0.5 m).
Grid delft_dtm() {
  std::vector<PointCloud> clouds{read_las(testkit::data_path("delft-ahn3/ahn3_cropped_1.las")),
                                 read_las(testkit::data_path("delft-ahn3/ahn3_cropped_2.las"))};
  GridPointsOptions ground_points;
  ground_points.resolution = 1.0;
  ground_points.keep_classes = {2};
  return grid_points(clouds, ground_points);
}

// The share of the terrain's measured cells standing more than the tolerance above the DSM, by
// brute force over every cell, the DSM's height taken at each cell's centre (the check's
// 512 x 512 lattice takes every cell of the Delft DTM's 265 x 230).
double share_above(const Grid& dtm, const Grid& dsm) {
  size_t compared = 0, above = 0;
  for (int row = 0; row < dtm.height; ++row)
    for (int col = 0; col < dtm.width; ++col) {
      const double d = double(dtm.at(col, row)) - dsm.height_at(dtm.center_x(col), dtm.center_y(row));
      if (std::isnan(d)) continue;
      ++compared;
      above += d > kTerrainAboveSurfaceM;
    }
  return double(above) / compared;
}

TEST(PlanLimits, ATerrainAboveItsSurfaceIsRefusedAtAPlaceOrOverTheCells) {
  const Grid dsm = testkit::delft_grid();
  const Grid dtm = delft_dtm();
  const auto surface_z = [&](double x, double y) { return double(dsm.height_at(x, y)); };
  const std::vector<NamedPlace> street{{"waypoint 1", 84842.5, 447611.5}, {"waypoint 2", 85033.5, 447455.5}};
  // The real pair agrees: the terrain under the surface but on a few cells (measured: 0.002 %).
  const double real_share = share_above(dtm, dsm);
  EXPECT_LT(real_share, kTerrainAboveShare / 10);
  EXPECT_FALSE(terrain_above_surface(GroundGrid(dtm), surface_z, street, "the DSM"));

  // A datum mismatch of 10 m (or 1.5 m): refused at the first place, by the offset.
  for (const double offset : {10.0, 1.5}) {
    Grid raised = dtm;
    for (float& z : raised.z) z += static_cast<float>(offset);
    const auto problem = terrain_above_surface(GroundGrid(raised), surface_z, street, "the DSM d.tif");
    ASSERT_TRUE(problem) << offset;
    EXPECT_EQ(problem->place, "waypoint 1");
    const double above = double(raised.height_at(84842.5, 447611.5)) - dsm.height_at(84842.5, 447611.5);
    char stands[64];
    std::snprintf(stands, sizeof stands, "stands %.2f m above the DSM d.tif", above);
    EXPECT_NE(problem->problem.find(stands), std::string::npos) << problem->problem;
    // No place given: the cells tell it, in the share brute force counts.
    const auto cells = terrain_above_surface(GroundGrid(raised), surface_z, {}, "the DSM");
    ASSERT_TRUE(cells) << offset;
    EXPECT_EQ(cells->place, "");
    char share[32];
    std::snprintf(share, sizeof share, "%.1f %%", 100 * share_above(raised, dsm));
    EXPECT_NE(cells->problem.find(share), std::string::npos) << cells->problem << " (brute force " << share << ")";
  }

  // Raised by 3 m over a band of columns away from the places: refused over the cells when the
  // band holds more than the share, not when it holds less.
  for (const double band : {0.10, 0.03}) {
    Grid raised = dtm;
    const int first = static_cast<int>(dtm.width * (0.5 - band / 2));
    const int last = static_cast<int>(dtm.width * (0.5 + band / 2));
    for (int row = 0; row < dtm.height; ++row)
      for (int col = first; col < last; ++col) raised.z[raised.index(col, row)] += 3;
    const double brute = share_above(raised, dsm);
    const auto problem = terrain_above_surface(GroundGrid(raised), surface_z, street, "the DSM");
    EXPECT_EQ(problem.has_value(), brute > kTerrainAboveShare) << "band " << band << ", brute force share " << brute;
    if (problem) EXPECT_EQ(problem->place, "");
  }
}

TEST(PlanLimits, TheGroundsSpreadIsHalfTheRangeOfTheNineCellsAround) {
  Grid g(7, 6, 1000, 2000, 2, 2);
  std::mt19937_64 rng(33);
  std::uniform_real_distribution<float> height(10, 30);
  for (float& z : g.z) z = height(rng);
  g.z[g.index(3, 3)] = NAN;  // a hole: filled from its rim, not measured
  const GroundGrid ground(g);
  const Grid& filled = ground.grid();
  for (int row = 0; row < g.height; ++row)
    for (int col = 0; col < g.width; ++col) {
      const double x = g.center_x(col), y = g.center_y(row);
      double low = INFINITY, high = -INFINITY;
      for (int r = row - 1; r <= row + 1; ++r)
        for (int c = col - 1; c <= col + 1; ++c)
          if (c >= 0 && r >= 0 && c < g.width && r < g.height)
            low = std::min(low, double(filled.at(c, r))), high = std::max(high, double(filled.at(c, r)));
      EXPECT_DOUBLE_EQ(ground.spread_at(x, y), (high - low) / 2) << col << ", " << row;
      if (col == 3 && row == 3)
        EXPECT_TRUE(std::isnan(ground.measured_at(x, y)));
      else
        EXPECT_EQ(ground.measured_at(x, y), g.at(col, row));
    }
  EXPECT_TRUE(std::isnan(ground.spread_at(990, 2000)));
  EXPECT_TRUE(std::isnan(ground.measured_at(990, 2000)));
}

// ---- the parts, each against brute force --------------------------------------------------

TEST(PlanLimits, HolesTakeTheHighestOrLowestOfTheirRim) {
  Grid g(6, 5, 0, 5, 1, 1);
  std::mt19937 rng(7);
  for (float& z : g.z) z = static_cast<float>(rng() % 100);
  // Two holes: one inside, one on the border.
  for (auto [c, r] : {std::pair{2, 2}, {3, 2}, {2, 1}, {0, 4}, {1, 4}}) g.z[g.index(c, r)] = Grid::nodata;
  for (RimHeight rule : {RimHeight::highest, RimHeight::lowest}) {
    Grid filled = g;
    EXPECT_EQ(fill_holes_from_rim(filled, rule), 2u);
    auto rim = [&](std::vector<std::pair<int, int>> cells) {
      double best = rule == RimHeight::highest ? -INFINITY : INFINITY;
      for (auto [c, r] : cells)
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc) {
            const int x = c + dc, y = r + dr;
            if (x < 0 || y < 0 || x >= g.width || y >= g.height || std::isnan(g.at(x, y))) continue;
            best = rule == RimHeight::highest ? std::max<double>(best, g.at(x, y)) : std::min<double>(best, g.at(x, y));
          }
      return best;
    };
    const double inner = rim({{2, 2}, {3, 2}, {2, 1}}), border = rim({{0, 4}, {1, 4}});
    EXPECT_EQ(filled.at(2, 2), inner);
    EXPECT_EQ(filled.at(3, 2), inner);
    EXPECT_EQ(filled.at(2, 1), inner);
    EXPECT_EQ(filled.at(0, 4), border);
    EXPECT_EQ(filled.at(1, 4), border);
  }
}

TEST(PlanLimits, GroundWalkIsTheHighestPointAboveEveryCellCrossed) {
  // Rough ground (every block needs its cells walked) and smooth ground over more blocks (most
  // settled by their lowest cell): below_ceiling() against the exact walk either way.
  for (int seed = 11; seed < 16; ++seed)
    for (bool smooth : {false, true}) {
      Grid g = smooth ? Grid(130, 90, 356000.5, 5699030.25, 0.5, 0.75) : Grid(40, 30, 356000.5, 5699030.25, 0.5, 0.75);
      std::mt19937_64 rng(seed);
      std::uniform_real_distribution<double> unit(0, 1);
      for (int r = 0; r < g.height; ++r)
        for (int c = 0; c < g.width; ++c)
          g.z[g.index(c, r)] =
              static_cast<float>(smooth ? 10 + 8 * std::sin(c / 17.0) + 0.05 * r + 0.3 * unit(rng) : 40 * unit(rng));
      const GroundGrid ground(g);
      for (int i = 0; i < 3000; ++i) {
        auto point = [&] {
          return Point3{g.x0 + unit(rng) * g.width * g.cell_x, g.y1() + unit(rng) * g.height * g.cell_y,
                        60 * unit(rng)};
        };
        Point3 p = point(), q = point();
        if (i % 10 == 0) q[0] = p[0];  // along a column of cells
        if (i % 10 == 1) q[1] = p[1];
        if (i % 10 == 2)
          q = {p[0] + 2 * g.cell_x, p[1] - 2 * g.cell_y, q[2]};  // through corners, where rounding lets it
        if (i % 10 == 3) q = {p[0] + 16 * g.cell_x, p[1] - 16 * g.cell_y, q[2]};
        if (i % 10 == 4) {  // from a cell's corner diagonally: through every corner on the way, blocks' edges too
          const int c = static_cast<int>(rng() % g.width), r = static_cast<int>(rng() % g.height),
                    m = 1 + static_cast<int>(rng() % 24);
          const int sx = rng() % 2 ? 1 : -1, sy = rng() % 2 ? 1 : -1;
          p = {g.x0 + c * g.cell_x, g.y0 - r * g.cell_y, p[2]};
          q = {p[0] + sx * m * g.cell_x, p[1] + sy * m * g.cell_y, q[2]};
        }
        const double expected = height_above_ground(g, p, q);
        if (std::isinf(expected)) {  // leaves the raster
          EXPECT_EQ(ground.max_height_above(p, q), INFINITY) << i;
          EXPECT_FALSE(ground.below_ceiling(p, q, 1e300)) << i;
          continue;
        }
        ASSERT_NEAR(ground.max_height_above(p, q), expected, 1e-9) << i;
        EXPECT_EQ(ground.below_ceiling(p, q, expected + 1e-6), true) << i;
        EXPECT_EQ(ground.below_ceiling(p, q, expected - 1e-6), false)
            << i << " smooth " << smooth << std::setprecision(17) << " p " << p[0] << " " << p[1] << " " << p[2]
            << " q " << q[0] << " " << q[1] << " " << q[2];
        EXPECT_EQ(ground.below_ceiling(p, q, expected + 3), true) << i;  // what the blocks' lowest cells settle
      }
      EXPECT_EQ(ground.height_above({g.x0 - 1, g.y0 - 1, 0}), INFINITY);  // beyond the raster: nothing flies there
    }
}

TEST(PlanLimits, QuickRefusalsRefuseOnlyWhatTheExactChecksRefuse) {
  // rises_above() against the exact walk, on rough ground with holes: never true where the walk
  // finds the segment under the ceiling, and true for most of the segments just above it.
  {
    Grid g(40, 30, 356000.5, 5699030.25, 0.5, 0.75);
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> unit(0, 1);
    for (float& z : g.z) z = unit(rng) < 0.1 ? Grid::nodata : static_cast<float>(40 * unit(rng));
    const GroundGrid ground(g);
    int refused = 0, above = 0;
    for (int i = 0; i < 5000; ++i) {
      auto point = [&] {
        return Point3{g.x0 + unit(rng) * g.width * g.cell_x, g.y1() + unit(rng) * g.height * g.cell_y, 60 * unit(rng)};
      };
      const Point3 p = point(), q = point();
      const double exact = ground.max_height_above(p, q), ceiling = exact - 1 + 2 * unit(rng);
      const bool quick = ground.rises_above(p, q, ceiling);
      if (quick) EXPECT_GT(exact, ceiling) << i;
      above += exact > ceiling, refused += quick;
    }
    EXPECT_GT(refused, above / 4);  // a refusal that never answers would pass the line above
  }
  // dips_below() of the mesh's floor, and FlightSpace::surely_invalid(), against the exact
  // clearance of the real tile's mesh, for segments between valid points: a true answer is
  // always a segment segment_clear() refuses.
  const Mesh mesh = triangulate_xy3(testkit::nrw_crop());
  const ClearanceIndex index(mesh);
  const GroundGrid dsm(testkit::nrw_crop());
  const FlightSpace space(index, dsm, 2.0, 30.0);
  const ClearanceIndex::Footprint& e = index.footprint();
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> unit(0, 1);
  auto valid_point = [&] {
    for (;;) {
      const double x = e.xmin + unit(rng) * (e.xmax - e.xmin), y = e.ymin + unit(rng) * (e.ymax - e.ymin);
      const double g = index.ground(x, y);
      const Point3 p{x, y, g + 0.5 + 30 * unit(rng)};
      if (space.state_valid(p)) return p;
    }
  };
  int refused = 0, blocked = 0;
  for (int i = 0; i < 4000; ++i) {
    const Point3 p = valid_point();
    Point3 q = valid_point();
    q = lerp(p, q, std::min(1.0, 60 / std::hypot(q[0] - p[0], q[1] - p[1])));  // at most 60 m apart
    if (!space.state_valid(q)) continue;
    const bool clear = index.segment_clear(p, q, 2.0), floor_says = index.floor().dips_below(p, q, 2.0);
    if (floor_says) EXPECT_FALSE(clear) << i;
    if (space.surely_invalid(p, q)) EXPECT_FALSE(space.motion_valid(p, q)) << i;
    blocked += !clear, refused += floor_says;
  }
  EXPECT_GT(refused, blocked / 3) << blocked;  // and it answers for many of them
  // Over a hole of a mesh (cells no triangle meets) the floor proves nothing.
  Grid holed(20, 20, 0, 20, 1, 1);
  std::fill(holed.z.begin(), holed.z.end(), 10.0f);
  for (int r = 5; r < 15; ++r)
    for (int c = 5; c < 15; ++c) holed.z[holed.index(c, r)] = Grid::nodata;
  const ClearanceIndex holed_index(triangulate_xy3(holed));
  EXPECT_FALSE(holed_index.floor().dips_below({7.5, 12.5, 3}, {12.5, 7.5, 3}, 2.0));   // inside the hole, below its rim
  EXPECT_TRUE(holed_index.floor().dips_below({1.5, 18.5, 11}, {18.5, 1.5, 11}, 2.0));  // over the rim: 1 m above it
}

// nearest_column() names the column column_clearance() measures: the same distance, and the
// named cell's box is that far from the point (brute force over every cell as the oracle).
TEST(PlanLimits, NearestColumnIsTheOneAtTheClearance) {
  const Grid& dsm = testkit::nrw_crop();
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> u(0, 1);
  int found = 0;
  for (int k = 0; k < 300; ++k) {
    const double x = dsm.x0 + 5 + u(rng) * (dsm.width - 10), y = dsm.y0 - 5 - u(rng) * (dsm.height - 10);
    const Point3 p{x, y, dsm.height_at(x, y) + 6 * u(rng) - 1};
    const NearestColumn c = nearest_column(dsm, p, 3);
    const double measured = column_clearance(dsm, p, p, 3);
    EXPECT_EQ(c.found, measured < 3) << k;
    if (!c.found) continue;
    ++found;
    EXPECT_NEAR(c.distance, measured, 1e-9) << k;
    double brute = INFINITY;
    for (int row = 0; row < dsm.height; ++row)
      for (int col = 0; col < dsm.width; ++col)
        if (std::abs(dsm.center_x(col) - x) < 5 && std::abs(dsm.center_y(row) - y) < 5)
          brute = std::min(brute, point_box(p, dsm.center_x(col) - 0.5, dsm.center_x(col) + 0.5,
                                            dsm.center_y(row) - 0.5, dsm.center_y(row) + 0.5, dsm.at(col, row)));
    EXPECT_NEAR(c.distance, brute, 1e-9) << k;
    EXPECT_NEAR(point_box(p, c.x - 0.5, c.x + 0.5, c.y - 0.5, c.y + 0.5, c.top), c.distance, 1e-9) << k;
  }
  EXPECT_GT(found, 100);
}

// lowest_clear_height() is where the free airspace starts above a place: a point a hair above it
// keeps the safety from the columns and one a millimetre below does not, by this file's own
// segment-box checker (ternary search), at random places on the crop and two safety distances.
TEST(PlanLimits, TheLowestClearHeightIsWhereTheColumnsDistanceReachesTheSafety) {
  const Grid& dsm = testkit::nrw_crop();
  std::mt19937_64 rng(78);
  std::uniform_real_distribution<double> u(0, 1);
  for (const double safety : {2.0, 5.0})
    for (int k = 0; k < 200; ++k) {
      const double x = dsm.x0 + 10 + u(rng) * (dsm.width - 20), y = dsm.y0 - 10 - u(rng) * (dsm.height - 20);
      const double lowest = lowest_clear_height(dsm, x, y, safety);
      ASSERT_TRUE(std::isfinite(lowest)) << k;  // the crop has no holes: cells all around
      EXPECT_GE(lowest, dsm.height_at(x, y) + 0.0);
      EXPECT_GE(columns_distance(dsm, {x, y, lowest + 1e-6}, {x, y, lowest + 1e-6}, safety + 1), safety - 1e-6) << k;
      EXPECT_LT(columns_distance(dsm, {x, y, lowest - 1e-3}, {x, y, lowest - 1e-3}, safety + 1), safety) << k;
    }
  EXPECT_THROW(lowest_clear_height(dsm, NAN, dsm.y0, 2), ArgumentError);
  EXPECT_THROW(lowest_clear_height(dsm, dsm.x0, dsm.y0, -1), ArgumentError);
  EXPECT_EQ(lowest_clear_height(dsm, dsm.x0 - 100, dsm.y0 + 100, 2), -INFINITY);  // no cell within
}

TEST(PlanLimits, ColumnsAboveTheMeshAreMeasuredExactly) {
  // A DSM of 1 m with buildings, the mesh through the cell centres: the most a column rises
  // above it, against a dense sampling (a lower bound that approaches it).
  Grid g(24, 20, 1000, 2000, 1, 1);
  std::mt19937_64 rng(5);
  for (int r = 0; r < g.height; ++r)
    for (int c = 0; c < g.width; ++c)
      g.z[g.index(c, r)] = static_cast<float>((rng() % 4 == 0) ? 12 + rng() % 9 : rng() % 2);
  const Mesh mesh = triangulate_xy3(g);
  const ColumnError certified = certify_columns(mesh, g);
  const ClearanceIndex index(mesh);
  double sampled = 0;
  const int n = 32;  // samples a cell side, on the borders too
  for (int r = 0; r < g.height; ++r)
    for (int c = 0; c < g.width; ++c)
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
          const double x = g.x0 + c + double(i) / n, y = g.y0 - r - double(j) / n;
          const double m = index.ground(x, y);
          if (!std::isnan(m)) sampled = std::max(sampled, g.at(c, r) - m);
        }
  EXPECT_GT(sampled, 1);
  EXPECT_GE(certified.max_below, sampled - 1e-9);
  EXPECT_LE(certified.max_below, sampled + 20.0 / n);  // the steepest slope (20 m a cell) times the sample step
  EXPECT_GT(certified.uncovered_corners, 0u);          // the outer half cells: the mesh stops at the centres
}

TEST(PlanLimits, NoPathPassesThroughAHoleLowerThanItsRim) {
  // Flat ground at 0 m, a 20 x 20 m hole in the middle whose rim holds one 15 m cell. The
  // waypoints face each other across the hole at 5 m: flying straight would cross it at 5 m.
  Grid g(100, 60, 500000, 5600060, 1, 1);
  std::fill(g.z.begin(), g.z.end(), 0.0f);
  for (int r = 20; r < 40; ++r)
    for (int c = 40; c < 60; ++c) g.z[g.index(c, r)] = Grid::nodata;
  g.z[g.index(60, 22)] = 15;  // on the rim, 7.5 m from the line between the waypoints
  Grid columns = g;
  fill_holes_from_rim(columns, RimHeight::highest);
  PlanOptions plan;
  plan.safety = 2;
  plan.max_agl = 40;
  plan.spacing = 6;
  plan.ground = std::make_shared<GroundGrid>(g);
  Mesh mesh = triangulate_xy3(g);
  PlanOptions on_mesh = plan;
  on_mesh.safety += column_margin(mesh, g);
  const Mesh holes = hole_columns(g, columns);
  ASSERT_FALSE(holes.triangles.empty());
  const uint32_t offset = static_cast<uint32_t>(mesh.vertices.size());
  mesh.vertices.insert(mesh.vertices.end(), holes.vertices.begin(), holes.vertices.end());
  for (Triangle t : holes.triangles) mesh.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  const ClearanceIndex index(mesh);
  const PlanResult result = plan_path(index, {{500020, 5600030, 5}, {500080, 5600030, 5}}, on_mesh);
  ASSERT_EQ(result.status, PlanStatus::Solved) << result.reason;
  bool over_hole = false;
  for (size_t k = 1; k < result.path.size(); ++k) {
    EXPECT_GE(columns_distance(columns, result.path[k - 1], result.path[k], 3), 2 - 1e-6) << k;
    for (double t = 0; t <= 1; t += 1.0 / 64) {
      const Point3 p = lerp(result.path[k - 1], result.path[k], t);
      if (p[0] > 500040 && p[0] < 500060 && p[1] > 5600020 && p[1] < 5600040) {
        over_hole = true;
        EXPECT_GE(p[2], 15 + 2 - 1e-6);  // over the hole only above its rim, by the safety distance
      }
    }
  }
  // Without the hole's columns the straight line at 5 m is clear of the mesh: the policy made the difference.
  const ClearanceIndex bare(triangulate_xy3(g));
  EXPECT_TRUE(bare.segment_clear({500020, 5600030, 5}, {500080, 5600030, 5}, 2.71));
  std::printf("hole: the path %s\n", over_hole ? "climbs over the hole" : "goes around the hole");
}

}  // namespace
