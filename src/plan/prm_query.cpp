// Queries on the roadmap: waypoints joined by a bounded local search, A* between consecutive
// ones (Hart, Nilsson, Raphael, "A Formal Basis for the Heuristic Determination of Minimum
// Cost Paths", IEEE Trans. SSC 4(2), 1968), then greedy shortcut smoothing as OMPL's
// PathSimplifier::shortcutPath does it deterministically (Geraerts & Overmars, "Creating
// High-quality Paths for Motion Planning", IJRR 26(8), 2007). The multi-query structure is
// Kavraki et al. 1996's: the roadmap is built once, each query only adds its waypoints.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <queue>
#include <string>

#include "core/stopwatch.hpp"
#include "dsmplan/plan.hpp"
#include "plan/path_parts.hpp"

namespace dsmplan {

namespace {

using detail::distance;
using detail::format_number;

// Roadmap nodes within max_edge of `w`, nearest first, that a clear straight segment joins to
// it; at most `limit`. Ties in distance break by node number.
std::vector<std::pair<double, uint32_t>> connect(const Point3& w, const Roadmap& map, const ClearanceIndex& index,
                                                 const PlanOptions& options) {
  std::vector<std::pair<double, uint32_t>> near;
  for (size_t i = 0; i < map.nodes.size(); ++i) {
    const double d = distance(w, map.nodes[i]);
    if (d < options.max_edge) near.emplace_back(d, static_cast<uint32_t>(i));
  }
  std::sort(near.begin(), near.end());
  std::vector<std::pair<double, uint32_t>> links;
  for (const auto& candidate : near) {
    if (links.size() >= static_cast<size_t>(options.connections)) break;
    if (index.segment_clear(w, map.nodes[candidate.second], options.safety)) links.push_back(candidate);
  }
  return links;
}

// A* from waypoint a to waypoint b through the roadmap; the points of the path (a and b
// included), or empty when none exists.
std::vector<Point3> astar(const Roadmap& map, const Point3& a, const Point3& b,
                          const std::vector<std::pair<double, uint32_t>>& from_a,
                          const std::vector<std::pair<double, uint32_t>>& to_b) {
  const uint32_t n = static_cast<uint32_t>(map.nodes.size()), S = n, G = n + 1;
  auto point = [&](uint32_t v) -> const Point3& { return v == S ? a : v == G ? b : map.nodes[v]; };
  std::vector<double> goal_cost(n, -1);
  for (const auto& [d, v] : to_b) goal_cost[v] = d;
  std::vector<double> g(n + 2, INFINITY);
  std::vector<uint32_t> parent(n + 2, UINT32_MAX);
  std::vector<char> closed(n + 2, 0);
  using Entry = std::pair<double, uint32_t>;  // f, node: ties break by node number
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  g[S] = 0;
  open.emplace(distance(a, b), S);
  auto relax = [&](uint32_t u, uint32_t v, double w) {
    const double cost = g[u] + w;
    if (cost < g[v]) {
      g[v] = cost;
      parent[v] = u;
      open.emplace(cost + distance(point(v), b), v);
    }
  };
  while (!open.empty()) {
    const uint32_t u = open.top().second;
    open.pop();
    if (closed[u]) continue;
    closed[u] = 1;
    if (u == G) break;
    if (u == S) {
      for (const auto& [d, v] : from_a) relax(u, v, d);
      continue;
    }
    if (goal_cost[u] >= 0) relax(u, G, goal_cost[u]);
    for (uint32_t k = map.start[u]; k < map.start[u + 1]; ++k) {
      const uint32_t v = map.neighbour[k];
      if (!closed[v]) relax(u, v, distance(map.nodes[u], map.nodes[v]));
    }
  }
  if (!closed[G]) return {};
  std::vector<Point3> path;
  for (uint32_t v = G; v != UINT32_MAX; v = parent[v]) path.push_back(point(v));
  std::reverse(path.begin(), path.end());
  return path;
}

}  // namespace

PlanResult query_roadmap(const Roadmap& map, const ClearanceIndex& index, const std::vector<Point3>& waypoints,
                         const PlanOptions& options) {
  check_plan_options(options);
  detail::check_waypoint_list(waypoints);
  PlanResult result;
  result.roadmap_nodes = map.nodes.size();
  result.roadmap_edges = map.edges();
  Stopwatch clock;
  if (detail::first_invalid_waypoint(waypoints, index, options.safety, result)) return result;
  std::vector<std::vector<std::pair<double, uint32_t>>> links(waypoints.size());
  std::vector<std::vector<Point3>> legs;
  for (size_t i = 0; i < waypoints.size(); ++i) links[i] = connect(waypoints[i], map, index, options);
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) {
    const Point3 &a = waypoints[i], &b = waypoints[i + 1];
    std::vector<Point3> leg;
    if (distance(a, b) < options.max_edge && index.segment_clear(a, b, options.safety)) {
      leg = {a, b};
    } else {
      leg = astar(map, a, b, links[i], links[i + 1]);
    }
    if (leg.empty()) {
      result.status = PlanStatus::NoPath;
      result.waypoint = i;
      const size_t lonely = links[i].empty() ? i : links[i + 1].empty() ? i + 1 : SIZE_MAX;
      // Samples fill surface .. surface + max_agl: a waypoint above that needs a higher volume, not denser samples.
      const bool above = lonely != SIZE_MAX && waypoints[lonely][2] > index.ground(waypoints[lonely][0],
                                                                                  waypoints[lonely][1]) + options.max_agl;
      const std::string hint = above ? "it is above the flight volume (the surface + --max-agl " +
                                           format_number(options.max_agl) + "): lower it or raise --max-agl"
                                     : "a smaller --spacing may give one";
      result.reason = lonely != SIZE_MAX ? "no roadmap sample within --max-edge " + format_number(options.max_edge) +
                                               " has a clear straight segment to waypoint " +
                                               std::to_string(lonely + 1) + "; " + hint
                                         : "no path within the roadmap (" + std::to_string(map.nodes.size()) +
                                               " samples); a smaller --spacing or a larger --max-edge may find one";
      result.seconds_query = clock.lap();
      return result;
    }
    legs.push_back(std::move(leg));
  }
  result.seconds_query = clock.lap();
  detail::finish_path(legs, index, options, result);
  result.seconds_smooth = clock.lap();
  return result;
}

PlanResult plan_path(const ClearanceIndex& index, const std::vector<Point3>& waypoints, const PlanOptions& options,
                     const Progress& progress) {
  if (options.planner == PlannerKind::rrt_connect) return plan_rrt_connect(index, waypoints, options, progress);
  check_plan_options(options);
  detail::check_waypoint_list(waypoints);
  if (PlanResult invalid; detail::first_invalid_waypoint(waypoints, index, options.safety, invalid)) return invalid;
  Stopwatch clock;
  const Roadmap map = build_roadmap(index, options, sub_progress(progress, 0, 0.95));
  const double seconds_roadmap = clock.lap();
  PlanResult result = query_roadmap(map, index, waypoints, options);
  result.seconds_roadmap = seconds_roadmap;
  report(progress, 1);
  return result;
}

}  // namespace dsmplan
