// The planner on the free airspace (free_airspace.hpp), checked against what it does not use:
// column_clearance() measured point by point over the cells' squares, and an independent voxel
// search of the free airspace on a real crop (NRW DOM1).
#include "dsmplan/free_airspace.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <queue>
#include <random>
#include <vector>

#include "dsmplan/columns.hpp"
#include "dsmplan/ground.hpp"
#include "testkit.hpp"

using namespace dsmplan;

namespace {

// A window of the NRW crop: streets, yards and buildings of 5-25 m.
Grid window(int col0, int row0, int width, int height) {
  const Grid& crop = testkit::nrw_crop();
  Grid g(width, height, crop.x0 + col0 * crop.cell_x, crop.y0 - row0 * crop.cell_y, crop.cell_x, crop.cell_y);
  g.crs = crop.crs;
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) g.z[g.index(c, r)] = crop.at(col0 + c, row0 + r);
  return g;
}

double length(const std::vector<Point3>& path) {
  double sum = 0;
  for (size_t k = 1; k < path.size(); ++k)
    sum += std::hypot(path[k][0] - path[k - 1][0], path[k][1] - path[k - 1][1], path[k][2] - path[k - 1][2]);
  return sum;
}

}  // namespace

TEST(FreeAirspace, EveryPointOfACellsSquareAtItsFloorKeepsTheSafetyAndTheFloorIsTight) {
  const Grid g = window(300, 0, 80, 80);
  const GroundGrid ground(g);
  for (const double safety : {2.0, 5.5}) {
    const auto air = free_airspace(g, ground, safety, 30);
    std::mt19937 random(7);
    std::uniform_int_distribution<int> pick(1, 78);
    int tight = 0;
    for (int n = 0; n < 150; ++n) {
      const int col = pick(random), row = pick(random);
      const size_t i = g.index(col, row);
      const double floor = air->floor.z[i];
      ASSERT_TRUE(std::isfinite(floor));
      const double xa = g.x0 + col * g.cell_x, ya = g.y0 - row * g.cell_y;
      double least = INFINITY;  // the least clearance over the square's boundary and inside, 0.1 m apart
      for (int v = 0; v <= 10; ++v)
        for (int u = 0; u <= 10; ++u) {
          const Point3 p{xa + u * 0.1 * g.cell_x, ya - v * 0.1 * g.cell_y, floor};
          const double d = column_clearance(g, p, p, safety + 1);
          EXPECT_GE(d, safety) << "cell " << col << "," << row << " at " << u << "," << v;
          const Point3 lower{p[0], p[1], floor - 0.05};
          least = std::min(least, column_clearance(g, lower, lower, safety + 1));
        }
      tight += least < safety;  // 5 cm lower, some point of the square is too near
    }
    EXPECT_EQ(tight, 150) << "safety " << safety;
  }
}

// Completeness against an independent search: voxels at the cells' centres every 0.25 m of
// height, free when column_clearance() keeps the safety plus half the cell's diagonal (so the
// whole square at that height keeps the safety) and the ceiling holds over the square (its corners
// and centre: the ground's rule takes the lowest cell a point touches); moves between 8
// neighbours at one height and up or down one step. Every path of voxels is a path the planner's
// definition allows, so every pair of voxels it joins the planner must solve; and its length
// (a path that exists) bounds the shortest from above.
TEST(FreeAirspace, SolvesEveryRouteAnIndependentVoxelSearchSolvesAndIsNoLonger) {
  const Grid g = window(250, 20, 110, 110);
  const GroundGrid ground(g);
  const double safety = 2, max_agl = 10, step = 0.25;
  const auto air = free_airspace(g, ground, safety, max_agl);
  const double half_diagonal = std::hypot(g.cell_x, g.cell_y) / 2;
  float low = INFINITY, high = -INFINITY;
  for (float z : g.z) low = std::min(low, z), high = std::max(high, z);
  const int levels = static_cast<int>((high + max_agl - low) / step) + 1;
  const int w = g.width, h = g.height;
  auto voxel = [&](int c, int r, int k) { return (static_cast<size_t>(k) * h + r) * w + c; };
  std::vector<uint8_t> free(static_cast<size_t>(w) * h * levels, 0);
  for (int r = 1; r < h - 1; ++r)
    for (int c = 1; c < w - 1; ++c) {
      const double x = g.center_x(c), y = g.center_y(r);
      double ceiling = INFINITY;
      for (const auto& [dx, dy] :
           std::vector<std::pair<double, double>>{{0, 0}, {-.5, -.5}, {-.5, .5}, {.5, -.5}, {.5, .5}})
        ceiling =
            std::min(ceiling, low + max_agl - ground.height_above({x + dx * g.cell_x, y + dy * g.cell_y, low}) + 0);
      for (int k = 0; k < levels; ++k) {
        const Point3 p{x, y, low + k * step};
        if (p[2] > ceiling) break;
        free[voxel(c, r, k)] = column_clearance(g, p, p, safety + 2) >= safety + half_diagonal;
      }
    }
  // Dijkstra over the voxels from one voxel: the length of the shortest voxel path to each.
  auto voxel_paths = [&](size_t from) {
    std::vector<double> dist(free.size(), INFINITY);
    using Entry = std::pair<double, size_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
    dist[from] = 0;
    open.push({0, from});
    while (!open.empty()) {
      const auto [d, v] = open.top();
      open.pop();
      if (d > dist[v]) continue;
      const int c = static_cast<int>(v % w), r = static_cast<int>(v / w % h), k = static_cast<int>(v / w / h);
      for (int dk = -1; dk <= 1; ++dk)
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc) {
            if ((dk != 0 && (dc != 0 || dr != 0)) || (!dk && !dc && !dr)) continue;  // up, down or sideways
            const int cc = c + dc, rr = r + dr, kk = k + dk;
            if (cc < 0 || rr < 0 || cc >= w || rr >= h || kk < 0 || kk >= levels) continue;
            const size_t u = voxel(cc, rr, kk);
            if (!free[u]) continue;
            const double cost = dk ? step : std::hypot(dc * g.cell_x, dr * g.cell_y);
            if (d + cost < dist[u]) dist[u] = d + cost, open.push({d + cost, u});
          }
    }
    return dist;
  };
  // Street-level voxels, 5 m and more above their cell, as the routes' ends.
  std::vector<size_t> ends;
  for (int r = 5; r < h - 5; r += 3)
    for (int c = 5; c < w - 5; c += 3) {
      const int k = static_cast<int>((g.at(c, r) + 5 - low) / step) + 1;
      if (k < levels && free[voxel(c, r, k)] && g.at(c, r) < low + 3) ends.push_back(voxel(c, r, k));
    }
  ASSERT_GE(ends.size(), 40u);
  std::mt19937 random(11);
  std::shuffle(ends.begin(), ends.end(), random);
  auto point = [&](size_t v) {
    const int c = static_cast<int>(v % w), r = static_cast<int>(v / w % h), k = static_cast<int>(v / w / h);
    return Point3{g.center_x(c), g.center_y(r), low + k * step};
  };
  const FreeAirspaceRules rules{[&](const Point3& p, const Point3& q) {
    return column_clearance(g, p, q, safety) >= safety && ground.below_ceiling(p, q, max_agl);
  }};
  int joined = 0, apart = 0;
  double worst = 0;
  for (size_t n = 0; n + 1 < 40; n += 2) {
    const std::vector<double> dist = voxel_paths(ends[n]);
    const std::vector<Point3> waypoints{point(ends[n]), point(ends[n + 1])};
    const PlanResult result = plan_free_airspace(*air, waypoints, rules);
    if (!std::isfinite(dist[ends[n + 1]])) {
      ++apart;
      continue;
    }
    ++joined;
    ASSERT_EQ(result.status, PlanStatus::Solved) << result.reason;
    for (size_t k = 1; k < result.path.size(); ++k) {  // measured on the data, not asked of the planner
      EXPECT_GE(column_clearance(g, result.path[k - 1], result.path[k], safety), safety - 1e-9);
      EXPECT_LE(ground.max_height_above(result.path[k - 1], result.path[k]), max_agl + 1e-9);
    }
    worst = std::max(worst, length(result.path) / dist[ends[n + 1]]);
  }
  EXPECT_GE(joined, 10);
  EXPECT_LE(worst, 1.0) << "the planner's path is longer than a voxel path";
  RecordProperty("joined", joined);
  RecordProperty("apart", apart);
}

TEST(FreeAirspace, ALegBetweenEnclosedRegionsIsRefusedNamingBoth) {
  const Grid g = window(0, 0, 500, 500);
  const GroundGrid ground(g);
  const auto air = free_airspace(g, ground, 2, 10);
  // The two largest regions: a waypoint in each, on a cell of its own.
  std::vector<uint32_t> order(air->region_cells.size());
  for (uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(),
            [&](uint32_t a, uint32_t b) { return air->region_cells[a] > air->region_cells[b]; });
  ASSERT_GE(order.size(), 2u);
  std::vector<Point3> ends;
  for (uint32_t region : {order[1], order[0]})
    for (int r = 1; r < g.height - 1 && ends.size() < (region == order[1] ? 1u : 2u); ++r)
      for (int c = 1; c < g.width - 1; ++c)
        if (air->region[g.index(c, r)] == region) {
          ends.push_back({g.center_x(c), g.center_y(r), air->floor.at(c, r) + 0.5});
          break;
        }
  ASSERT_EQ(ends.size(), 2u);
  const FreeAirspaceRules rules{[&](const Point3& p, const Point3& q) {
    return column_clearance(g, p, q, 2) >= 2 && ground.below_ceiling(p, q, 10);
  }};
  const PlanResult result = plan_free_airspace(*air, ends, rules);
  ASSERT_EQ(result.status, PlanStatus::NoPath);
  EXPECT_NE(result.reason.find("waypoint 1 lies in a region of"), std::string::npos) << result.reason;
  EXPECT_NE(result.reason.find("no path exists"), std::string::npos) << result.reason;
  EXPECT_EQ(result.lattice_nodes, 0u) << "refused from the regions alone, without a search";
}

// The floors' cost grows with the safety distance squared: beyond the bound the request is refused
// before any work, naming --safety and the cost (issue 49: a cost that grows with safety is bounded
// before the work starts).
TEST(FreeAirspace, ASafetyWhoseCostPassesTheBoundIsRefusedBeforeTheWork) {
  const Grid& tile = testkit::nrw_full();
  const GroundGrid ground(tile);
  try {
    free_airspace(tile, ground, 900, 1000);
    FAIL() << "a 900 m safety over a million cells was not refused";
  } catch (const ArgumentError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--safety"), std::string::npos) << what;
    EXPECT_NE(what.find("billion column comparisons"), std::string::npos) << what;
  }
  EXPECT_THROW(free_airspace(tile, ground, 30, 120), ArgumentError);
  const auto air = free_airspace(tile, ground, 10, 120);  // within the bound: made
  EXPECT_GT(air->open_cells(), 0u);
}
