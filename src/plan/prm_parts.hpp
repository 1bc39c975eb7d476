// What the PRM's roadmap (prm_roadmap.cpp) and its queries (prm_query.cpp) share: the Halton
// sequence that places samples, and a uniform 3D grid that finds the points near a point.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "dsmplan/plan.hpp"
#include "path_parts.hpp"

namespace dsmplan::detail {

/// Element `index` of the van der Corput sequence in `base` (Halton 1960: one base a coordinate).
inline double halton(uint64_t index, uint32_t base) {
  double result = 0, f = 1;
  while (index > 0) {
    f /= base;
    result += f * static_cast<double>(index % base);
    index /= base;
  }
  return result;
}

inline double squared_distance(const Point3& a, const Point3& b) {
  const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz;
}

/// Points (given by number) in cubes of side `cell`; within(p, r) for r <= cell visits every
/// point closer than r to p by reading the 27 cubes around p's own. Cubes are found by binary
/// search in the points sorted by cube, so the structure is a flat array, built in O(n log n).
class PointGrid {
public:
  PointGrid() = default;
  PointGrid(const std::vector<Point3>& points, const std::vector<uint32_t>& ids, double cell) : cell_(cell) {
    sorted_.reserve(ids.size());
    for (uint32_t id : ids) sorted_.emplace_back(key(points[id]), id);
    std::sort(sorted_.begin(), sorted_.end());
  }
  double cell() const { return cell_; }
  bool empty() const { return sorted_.empty(); }
  size_t size() const { return sorted_.size(); }
  /// fn(id) for every point in the 27 cubes around p (a superset of those within `cell`), in
  /// ascending order of cube, then id.
  template <class F>
  void around(const Point3& p, F&& fn) const {
    if (sorted_.empty()) return;
    const int64_t cx = coord(p[0]), cy = coord(p[1]), cz = coord(p[2]);
    for (int64_t z = cz - 1; z <= cz + 1; ++z)
      for (int64_t y = cy - 1; y <= cy + 1; ++y)
        for (int64_t x = cx - 1; x <= cx + 1; ++x) {
          const uint64_t k = pack(x, y, z);
          auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::make_pair(k, uint32_t{0}));
          for (; it != sorted_.end() && it->first == k; ++it) fn(it->second);
        }
  }

private:
  int64_t coord(double v) const { return static_cast<int64_t>(std::floor(v / cell_)); }
  // 21 bits a coordinate, offset to be non-negative: cubes wrap only 2^20 cubes away, and a
  // wrapped cube only adds candidates (callers measure the distance), never loses one.
  static uint64_t pack(int64_t x, int64_t y, int64_t z) {
    constexpr int64_t mask = (int64_t{1} << 21) - 1, off = int64_t{1} << 20;
    return (static_cast<uint64_t>((x + off) & mask) << 42) | (static_cast<uint64_t>((y + off) & mask) << 21) |
           static_cast<uint64_t>((z + off) & mask);
  }
  uint64_t key(const Point3& p) const { return pack(coord(p[0]), coord(p[1]), coord(p[2])); }
  double cell_ = 1;
  std::vector<std::pair<uint64_t, uint32_t>> sorted_;
};

/// Each node's connected component, the least node in it, of the graph on nodes 0..n-1 whose
/// undirected edges each_edge(join) hands to join(u, v): union-find with path halving (Tarjan,
/// "Efficiency of a Good But Not Linear Set Union Algorithm", JACM 22(2), 1975), each set's root
/// its least node. O(n + edges) in practice.
template <class EachEdge>
std::vector<uint32_t> components(size_t n, EachEdge&& each_edge) {
  std::vector<uint32_t> parent(n);
  for (uint32_t i = 0; i < n; ++i) parent[i] = i;
  auto root = [&](uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  each_edge([&](uint32_t u, uint32_t v) {
    const uint32_t a = root(u), b = root(v);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  });
  for (uint32_t i = 0; i < n; ++i) parent[i] = root(i);
  return parent;
}

/// Roadmap nodes within options.max_edge of `w`, nearest first, that a clear straight segment
/// joins to it (ClearanceIndex::segment_clear(w, node, safety)); at most options.connections.
/// Ties in distance break by node number. `grid` holds every node of `map` in cubes of side
/// max_edge, so only the 27 cubes around w are read, not every node; the answer is the same
/// as a scan over all nodes (tests/plan_test.cpp checks it against one).
inline std::vector<std::pair<double, uint32_t>> roadmap_links(const Point3& w, const Roadmap& map,
                                                              const PointGrid& grid, const FlightSpace& space,
                                                              const PlanOptions& options) {
  std::vector<std::pair<double, uint32_t>> near;
  grid.around(w, [&](uint32_t i) {
    const Point3& p = map.nodes[i];
    const double d = std::hypot(w[0] - p[0], w[1] - p[1], w[2] - p[2]);
    if (d < options.max_edge) near.emplace_back(d, i);
  });
  std::sort(near.begin(), near.end());
  std::vector<std::pair<double, uint32_t>> links;
  for (const auto& candidate : near) {
    if (links.size() >= static_cast<size_t>(options.connections)) break;
    if (space.motion_valid(w, map.nodes[candidate.second])) links.push_back(candidate);
  }
  return links;
}

/// What lattice_path() found: the path (empty when none), the lattice nodes it made, and
/// whether it stopped at its bound of nodes.
struct LatticeResult {
  std::vector<Point3> path;
  size_t nodes = 0;
  bool out_of_work = false;
};

/// The shortest path from waypoint a to waypoint b over the clear edges of the lattice of side
/// `step` anchored at a (26 neighbours a node; nodes valid as FlightSpace states not under the
/// surface; the path ends at b from a node within 2 step of it), runs of equal steps merged; at
/// most `max_nodes` nodes are made. Every segment of the path is motion_valid. Deterministic.
/// Time O(n log n) for the n nodes made; a node is tested (point_clear) when it first comes
/// first in the queue, and one motion is checked per settled node plus one per blocked edge
/// (lattice_search.cpp).
LatticeResult lattice_path(const FlightSpace& space, const Point3& a, const Point3& b, double step, size_t max_nodes);

/// The way out from a waypoint `a` that no roadmap node reaches in a straight line (a courtyard,
/// a street under trees): the shortest path over the same lattice (Dijkstra, no goal) from a to
/// the first node for which `is_exit` holds (one motion to a roadmap node, checked by the
/// caller), exploring only nodes within `radius` (x,y) of a; path from a to that node, or empty.
/// Local, so far cheaper than a lattice over the whole leg. Deterministic.
LatticeResult lattice_escape(const FlightSpace& space, const Point3& a, double step, double radius, size_t max_nodes,
                             const std::function<bool(const Point3&)>& is_exit);

}  // namespace dsmplan::detail
