// plan_free_airspace(): a path over the free airspace's cells (free_airspace.hpp).
//
// Each leg: its ends are joined to the open cells within a few cells that a straight segment (or
// a climb, then a straight segment) reaches, checked exactly; A* (Hart, Nilsson & Raphael 1968)
// over the joined cells from the start's to the end's, a step costing its horizontal length plus
// the climb or descent between the floors times FreeAirspaceRules::climb_weight, the heuristic the
// octile distance to the end's cell less its joins' reach (admissible: no chain of steps is
// shorter), ties to the deeper node; then the path through the cells'
// centres at their floors, each change of floor a vertical step at the lower cell's centre, pulled
// tight: from each kept point the farthest later point that a straight segment reaches under the
// exact check, found by galloping then bisection (the post-smoothing of any-angle search: Daniel,
// Nash, Koenig & Felner, "Theta*: Any-Angle Path Planning on Grids", JAIR 39, 2010).
//
// Why the cells' staircase is valid without a check: a step between joined cells flies at the
// higher floor, which is at or above both cells' floors and under both tops, over the union of
// their closed squares (a diagonal step crosses only their common corner); each point of it is
// therefore clear and under the ceiling (free_airspace.hpp). It is checked once more anyway.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <queue>
#include <stdexcept>
#include <tuple>

#include "core/stopwatch.hpp"
#include "core/text.hpp"
#include "dsmplan/free_airspace.hpp"
#include "plan/path_parts.hpp"

namespace dsmplan {

namespace {

constexpr int kJoinReach = 4;  // cells: how far from an end its joining cells are looked for
constexpr size_t kJoinsWanted = 8;

// Buffers of one thread's searches, reused: a stamp marks what this search has written, so a
// query over a million cells costs no clearing.
struct SearchBuffers {
  std::vector<uint32_t> stamp, parent;
  std::vector<double> g;
  uint32_t now = 0;
  void start(size_t cells) {
    if (stamp.size() != cells) stamp.assign(cells, 0), parent.assign(cells, 0), g.assign(cells, 0), now = 0;
    if (++now == 0) std::fill(stamp.begin(), stamp.end(), 0), now = 1;
  }
  bool seen(size_t i) const { return stamp[i] == now; }
};

struct Join {
  size_t cell;
  double cost;
  std::vector<Point3> via;  // points between the end and the cell's centre at its floor, in flying order
};

Point3 centre(const FreeAirspace& air, size_t cell) {
  const Grid& f = air.floor;
  const int col = static_cast<int>(cell % f.width), row = static_cast<int>(cell / f.width);
  return {f.center_x(col), f.center_y(row), f.z[cell]};
}

// The open cells within kJoinReach of `end` that it reaches under the exact check, nearest first:
// straight to the cell's centre at its floor, or first straight up (or down) to that floor.
std::vector<Join> joins(const FreeAirspace& air, const Point3& end, const FreeAirspaceRules& rules) {
  const Grid& f = air.floor;
  int col = 0, row = 0;
  std::vector<Join> out;
  if (!f.cell_at(end[0], end[1], col, row)) return out;
  std::vector<std::pair<double, size_t>> near;
  for (int dr = -kJoinReach; dr <= kJoinReach; ++dr)
    for (int dc = -kJoinReach; dc <= kJoinReach; ++dc) {
      const int c = col + dc, r = row + dr;
      if (c < 0 || r < 0 || c >= f.width || r >= f.height) continue;
      const size_t i = f.index(c, r);
      if (!air.open(i)) continue;
      const Point3 p = centre(air, i);
      near.push_back({std::hypot(p[0] - end[0], p[1] - end[1]), i});
    }
  std::sort(near.begin(), near.end());
  for (const auto& [d, i] : near) {
    const Point3 p = centre(air, i);
    if (rules.motion_valid(end, p)) {
      out.push_back({i, detail::distance(end, p), {}});
    } else {
      const Point3 turn{end[0], end[1], p[2]};
      if (rules.motion_valid(end, turn) && rules.motion_valid(turn, p))
        out.push_back({i, detail::distance(end, turn) + detail::distance(turn, p), {turn}});
    }
    if (out.size() >= kJoinsWanted) break;
  }
  return out;
}

std::string region_in_words(const FreeAirspace& air, size_t cell) {
  const double m2 = air.region_cells[air.region[cell]] * air.cell_area();
  char text[48];
  if (m2 < 1e5)
    std::snprintf(text, sizeof text, "%.0f m²", m2);
  else
    std::snprintf(text, sizeof text, "%.2f km²", m2 / 1e6);
  return text;
}

// Why a leg has no path, in one line: its ends' regions.
std::string no_path_words(const FreeAirspace& air, const std::vector<Join>& from, const std::vector<Join>& to,
                          size_t leg) {
  const std::string a = "waypoint " + std::to_string(leg + 1), b = "waypoint " + std::to_string(leg + 2);
  const std::string limits =
      " (" + short_number(air.safety) + " m from the obstacles, under the " + short_number(air.max_agl) + " m ceiling)";
  if (from.empty() || to.empty())
    return "no open cell within " + std::to_string(kJoinReach) + " cells of " + (from.empty() ? a : b) +
           " is reachable in a straight line" + limits + " (the free airspace at the DSM's resolution)";
  // The smaller region first: it is the one the obstacles and the ceiling enclose.
  const bool start_smaller =
      air.region_cells[air.region[from.front().cell]] <= air.region_cells[air.region[to.front().cell]];
  const Join &small = start_smaller ? from.front() : to.front(), &large = start_smaller ? to.front() : from.front();
  return (start_smaller ? a : b) + " lies in a region of " + region_in_words(air, small.cell) + " of free airspace" +
         limits + " that obstacles and the ceiling enclose; " + (start_smaller ? b : a) + "'s region is " +
         region_in_words(air, large.cell) + ": no path exists at the DSM's resolution";
}

struct Leg {
  bool found = false;
  std::vector<Point3> points;
  size_t settled = 0;
};

// A* from the start's joins to the end's, over the cells of the start's regions.
Leg search(const FreeAirspace& air, const Point3& a, const Point3& b, const std::vector<Join>& from,
           const std::vector<Join>& to, const FreeAirspaceRules& rules, SearchBuffers& buf) {
  const Grid& f = air.floor;
  buf.start(f.cells());
  auto goal_cost = [&](size_t i) -> const Join* {
    for (const Join& j : to)
      if (j.cell == i) return &j;
    return nullptr;
  };
  using Entry = std::tuple<double, double, uint32_t>;  // f, -g, cell
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  const double climb_weight = rules.climb_weight;
  // The octile distance to the end's cell less the farthest of its joins: a lower bound of every
  // chain of steps to a join (the octile metric keeps the triangle inequality), and exact where
  // nothing stands in the way, so A* settles few cells off the best chain.
  int goal_col = 0, goal_row = 0;
  f.cell_at(b[0], b[1], goal_col, goal_row);
  const double cx = f.cell_x, cy = f.cell_y, diag = std::hypot(cx, cy);
  const auto octile = [&](int dc, int dr) {
    const double x = std::abs(dc) * cx, y = std::abs(dr) * cy;
    const double lo = std::min(std::abs(dc), std::abs(dr));
    return x + y - lo * (cx + cy - diag);
  };
  double reach = 0;
  for (const Join& j : to)
    reach = std::max(
        reach, octile(static_cast<int>(j.cell % f.width) - goal_col, static_cast<int>(j.cell / f.width) - goal_row));
  auto h = [&](size_t i) {
    return std::max(0.0,
                    octile(static_cast<int>(i % f.width) - goal_col, static_cast<int>(i / f.width) - goal_row) - reach);
  };
  constexpr uint32_t kRoot = UINT32_MAX;
  for (const Join& j : from) {
    if (buf.seen(j.cell) && buf.g[j.cell] <= j.cost) continue;
    buf.stamp[j.cell] = buf.now, buf.g[j.cell] = j.cost, buf.parent[j.cell] = kRoot;
    open.push({j.cost + h(j.cell), -j.cost, static_cast<uint32_t>(j.cell)});
  }
  double best = INFINITY;
  uint32_t best_cell = kRoot;
  size_t settled = 0;
  while (!open.empty()) {
    const auto [fi, neg_g, i] = open.top();
    open.pop();
    if (fi >= best) break;
    if (-neg_g > buf.g[i]) continue;  // an older entry
    if (++settled % 4096 == 0) check_stop(rules.stop);
    if (const Join* end = goal_cost(i); end && buf.g[i] + end->cost < best) best = buf.g[i] + end->cost, best_cell = i;
    const int col = static_cast<int>(i % f.width), row = static_cast<int>(i / f.width);
    const Point3 here = centre(air, i);
    for (int dr = -1; dr <= 1; ++dr)
      for (int dc = -1; dc <= 1; ++dc) {
        const int c = col + dc, r = row + dr;
        if ((!dc && !dr) || c < 0 || r < 0 || c >= f.width || r >= f.height) continue;
        const size_t j = f.index(c, r);
        if (!air.open(j) || !air.joined(i, j)) continue;
        const double step = (dc && dr) ? diag : dc ? cx : cy;
        const double g = buf.g[i] + step + climb_weight * std::abs(double(f.z[j]) - f.z[i]);
        if (buf.seen(j) && buf.g[j] <= g) continue;
        if (!rules.constraints.empty()) {  // the zones are not in the cells: the step itself
          const Point3 there = centre(air, j);
          const double level = std::max(here[2], there[2]);
          const Point3 p{here[0], here[1], level}, q{there[0], there[1], level};
          bool allowed = true;
          for (const FlightConstraint* rule : rules.constraints)
            allowed =
                allowed && rule->motion_valid(here, p) && rule->motion_valid(p, q) && rule->motion_valid(q, there);
          if (!allowed) continue;
        }
        buf.stamp[j] = buf.now, buf.g[j] = g, buf.parent[j] = i;
        open.push({g + h(j), -g, static_cast<uint32_t>(j)});
      }
  }
  Leg leg;
  leg.settled = settled;
  if (best_cell == kRoot) return leg;
  std::vector<size_t> cells;
  for (uint32_t i = best_cell; i != kRoot; i = buf.parent[i]) cells.push_back(i);
  std::reverse(cells.begin(), cells.end());
  const auto join_of = [](const std::vector<Join>& list, size_t cell) -> const Join& {
    for (const Join& j : list)
      if (j.cell == cell) return j;
    throw std::logic_error("free airspace: a path's end cell without its join");
  };
  leg.points.push_back(a);
  for (const Point3& p : join_of(from, cells.front()).via) leg.points.push_back(p);
  leg.points.push_back(centre(air, cells.front()));
  for (size_t k = 1; k < cells.size(); ++k) {
    const Point3 p = centre(air, cells[k - 1]), q = centre(air, cells[k]);
    if (q[2] > p[2]) leg.points.push_back({p[0], p[1], q[2]});  // climb first, at the lower cell
    if (q[2] < p[2]) leg.points.push_back({q[0], q[1], p[2]});  // descend last, at the lower cell
    leg.points.push_back(q);
  }
  const std::vector<Point3>& via = join_of(to, cells.back()).via;
  for (auto it = via.rbegin(); it != via.rend(); ++it) leg.points.push_back(*it);
  leg.points.push_back(b);
  leg.found = true;
  return leg;
}

// The leg pulled tight: from each kept point, the farthest later one a straight segment reaches
// (galloping, then bisection between the last reached and the first not).
std::vector<Point3> pull_tight(const std::vector<Point3>& points, const FreeAirspaceRules& rules) {
  std::vector<Point3> out{points.front()};
  size_t at = 0;
  const size_t n = points.size();
  while (at + 1 < n) {
    size_t good = at + 1, bad = n;
    for (size_t step = 2; good + 1 < n; step *= 2) {
      const size_t probe = std::min(n - 1, at + step);
      if (probe <= good) break;
      if (!rules.motion_valid(points[at], points[probe])) {
        bad = probe;
        break;
      }
      good = probe;
      if (probe == n - 1) break;
    }
    while (bad - good > 1) {
      const size_t mid = good + (bad - good) / 2;
      (rules.motion_valid(points[at], points[mid]) ? good : bad) = mid;
    }
    out.push_back(points[good]);
    at = good;
  }
  return out;
}

}  // namespace

PlanResult plan_free_airspace(const FreeAirspace& air, const std::vector<Point3>& waypoints,
                              const FreeAirspaceRules& rules) {
  detail::check_waypoint_list(waypoints);
  Stopwatch clock;
  thread_local SearchBuffers buffers;
  PlanResult result;
  std::vector<Point3> path{waypoints.front()}, raw{waypoints.front()};
  for (size_t k = 0; k + 1 < waypoints.size(); ++k) {
    const Point3 &a = waypoints[k], &b = waypoints[k + 1];
    std::vector<Point3> leg_points;
    if (a == b) {
      leg_points = {a, b};
    } else if (rules.motion_valid(a, b)) {
      leg_points = {a, b};
    } else {
      const std::vector<Join> from = joins(air, a, rules), to = joins(air, b, rules);
      const bool together = !from.empty() && !to.empty() && [&] {
        for (const Join& s : from)
          for (const Join& e : to)
            if (air.region[s.cell] == air.region[e.cell]) return true;
        return false;
      }();
      Leg leg;
      if (together) leg = search(air, a, b, from, to, rules, buffers);
      result.lattice_nodes += leg.settled;
      if (!leg.found) {
        result.status = PlanStatus::NoPath;
        result.waypoint = k;
        result.reason = together ? "no path over the free airspace's cells (a no-fly zone may close it)"
                                 : no_path_words(air, from, to, k);
        result.seconds_query = clock.lap();
        return result;
      }
      raw.insert(raw.end(), leg.points.begin() + 1, leg.points.end());
      leg_points = pull_tight(leg.points, rules);
      path.insert(path.end(), leg_points.begin() + 1, leg_points.end());
      continue;
    }
    raw.push_back(b);
    path.push_back(b);
  }
  result.seconds_query = clock.lap();
  for (size_t k = 1; k < path.size(); ++k)
    if (!rules.motion_valid(path[k - 1], path[k]))
      throw std::logic_error("free airspace: segment " + std::to_string(k) + " of a pulled path fails its check");
  result.seconds_smooth = clock.lap();
  result.raw_path = std::move(raw);
  result.path = std::move(path);
  result.status = PlanStatus::Solved;
  return result;
}

}  // namespace dsmplan
