// merge_straight_legs(): the plan stage's last path simplification for missions, which an
// autopilot flies as straight lines from item to item (flight.hpp). Greedy, as the shortcut step
// of path_smoothing.cpp, but held to the data (the DSM's columns when known) rather than the mesh.
#include <cmath>

#include "dsmplan/flight.hpp"

namespace dsmplan {

namespace {

constexpr double kSameSpot = 1e-6;  // m: a path point this close to a waypoint is that waypoint

bool same_point(const Point3& a, const Point3& b) {
  return std::abs(a[0] - b[0]) <= kSameSpot && std::abs(a[1] - b[1]) <= kSameSpot && std::abs(a[2] - b[2]) <= kSameSpot;
}

}  // namespace

std::vector<Point3> merge_straight_legs(const std::vector<Point3>& path, const std::vector<Point3>& waypoints,
                                        const FlightRules& rules) {
  if (path.size() < 3) return path;
  // The waypoints are visited in order: the path's points that are them are kept.
  std::vector<bool> visit(path.size(), false);
  for (size_t i = 0, k = 0; i < path.size() && k < waypoints.size(); ++i)
    if (same_point(path[i], waypoints[k])) visit[i] = true, ++k;
  std::vector<Point3> kept{path.front()};
  for (size_t i = 0; i + 1 < path.size();) {
    size_t j = i + 1;
    while (j + 1 < path.size() && !visit[j] && rules.keeps(path[i], path[j + 1])) ++j;
    kept.push_back(path[j]);
    i = j;
  }
  return kept;
}

}  // namespace dsmplan
