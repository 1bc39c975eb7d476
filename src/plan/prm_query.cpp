// Queries on the roadmap: waypoints joined by a bounded local search, A* between consecutive
// ones (Hart, Nilsson, Raphael, "A Formal Basis for the Heuristic Determination of Minimum
// Cost Paths", IEEE Trans. SSC 4(2), 1968), then greedy shortcut smoothing as OMPL's
// PathSimplifier::shortcutPath does it deterministically (Geraerts & Overmars, "Creating
// High-quality Paths for Motion Planning", IJRR 26(8), 2007). The multi-query structure is
// Kavraki et al. 1996's: the roadmap is built once, each query only adds its waypoints.
//
// Where the roadmap fails a leg, the query refines it (see "Refinement" in plan.hpp): the
// expansion step of Kavraki, Svestka, Latombe & Overmars 1996 (more samples where the roadmap
// is poorly connected), here around the smaller of the two components the leg's waypoints lie
// in, with samples from the same Halton sequence continued at a finer spacing, and edges
// checked lazily (Bohlin & Kavraki, "Path Planning Using Lazy PRM", ICRA 2000): a candidate
// edge is measured only when the search would settle a node through it.
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <queue>
#include <string>
#include <unordered_map>

#include "core/stopwatch.hpp"
#include "dsmplan/plan.hpp"
#include "plan/path_parts.hpp"
#include "plan/prm_parts.hpp"

namespace dsmplan {

namespace {

using detail::distance;
using detail::format_number;
using detail::PointGrid;

std::vector<uint32_t> all_nodes(size_t n) {
  std::vector<uint32_t> ids(n);
  for (size_t i = 0; i < n; ++i) ids[i] = static_cast<uint32_t>(i);
  return ids;
}

// A*'s state for one thread, kept from query to query: a route is one query among thousands
// against a roadmap of ten thousand nodes and more, and clearing arrays that large for each leg
// cost more than the search itself (issue 35's routes at 120 m: A* was 20 % of the run). An
// entry is valid only when its stamp is the current search's.
struct AStarState {
  std::vector<double> g, goal_cost;
  std::vector<uint32_t> parent, seen, closed, goal;  // seen/closed/goal: the search's stamp
  std::vector<std::pair<double, uint32_t>> open;     // a binary heap: f, node (ties by node number)
  uint32_t stamp = 0;
  void start(size_t nodes) {
    if (g.size() < nodes || ++stamp == 0) {  // grown, or the stamps wrapped: cleared once
      g.assign(nodes, INFINITY), goal_cost.assign(nodes, 0), parent.assign(nodes, UINT32_MAX);
      seen.assign(nodes, 0), closed.assign(nodes, 0), goal.assign(nodes, 0);
      stamp = 1;
    }
    open.clear();
  }
};

// A* from waypoint a to waypoint b through the roadmap; the points of the path (a and b
// included), or empty when none exists.
std::vector<Point3> astar(const Roadmap& map, const Point3& a, const Point3& b,
                          const std::vector<std::pair<double, uint32_t>>& from_a,
                          const std::vector<std::pair<double, uint32_t>>& to_b) {
  const uint32_t n = static_cast<uint32_t>(map.nodes.size()), S = n, G = n + 1;
  auto point = [&](uint32_t v) -> const Point3& { return v == S ? a : v == G ? b : map.nodes[v]; };
  thread_local AStarState state;
  AStarState& st = state;
  st.start(n + 2);
  const uint32_t now = st.stamp;
  for (const auto& [d, v] : to_b) st.goal_cost[v] = d, st.goal[v] = now;
  const auto g = [&](uint32_t v) { return st.seen[v] == now ? st.g[v] : INFINITY; };
  using Entry = std::pair<double, uint32_t>;
  const auto push = [&](double f, uint32_t v) {
    st.open.emplace_back(f, v);
    std::push_heap(st.open.begin(), st.open.end(), std::greater<Entry>());
  };
  st.g[S] = 0, st.seen[S] = now, st.parent[S] = UINT32_MAX;
  push(distance(a, b), S);
  auto relax = [&](uint32_t u, uint32_t v, double w) {
    const double cost = st.g[u] + w;
    if (cost < g(v)) {
      st.g[v] = cost, st.seen[v] = now;
      st.parent[v] = u;
      push(cost + distance(point(v), b), v);
    }
  };
  while (!st.open.empty()) {
    std::pop_heap(st.open.begin(), st.open.end(), std::greater<Entry>());
    const uint32_t u = st.open.back().second;
    st.open.pop_back();
    if (st.closed[u] == now) continue;
    st.closed[u] = now;
    if (u == G) break;
    if (u == S) {
      for (const auto& [d, v] : from_a) relax(u, v, d);
      continue;
    }
    if (st.goal[u] == now) relax(u, G, st.goal_cost[u]);
    for (uint32_t k = map.start[u]; k < map.start[u + 1]; ++k) {
      const uint32_t v = map.neighbour[k];
      if (st.closed[v] != now) relax(u, v, distance(map.nodes[u], map.nodes[v]));
    }
  }
  if (st.closed[G] != now) return {};
  std::vector<Point3> path;
  for (uint32_t v = G; v != UINT32_MAX; v = st.parent[v]) path.push_back(point(v));
  std::reverse(path.begin(), path.end());
  return path;
}

// True when the roadmap's components show that no node linked to one waypoint (`from`) is
// joined to a node linked to the other (`to`): A* between them would search in vain.
bool links_apart(const Roadmap& map, const std::vector<std::pair<double, uint32_t>>& from,
                 const std::vector<std::pair<double, uint32_t>>& to) {
  if (map.component.size() != map.nodes.size()) return false;
  for (const auto& [d, u] : from)
    for (const auto& [e, v] : to)
      if (map.component[u] == map.component[v]) return false;
  return true;
}

// ---- refinement ---------------------------------------------------------------------------

constexpr int kMaxLevel = 3;               // finest spacing: spacing / 2^3
constexpr double kMaxHaltonIndex = 4.0e6;  // a level needs at most this many Halton indices
constexpr int kMaxWiden = 5;               // the region: at most 2^5 max_edge around the frontier
// The work bounds are PlanOptions (plan.hpp). Their defaults: refine_max_search_work 1e8, since an
// impossible leg over a million samples would otherwise be searched round after round for many
// minutes (a Delft leg under a 15 m ceiling: over 10 minutes; 1e8 is about 50 s there), while the
// hardest leg bench_table3 solves looks at 7e6; refine_max_lattice_nodes 2 million
// (kLatticeNodeBytes each: under 400 MB), since a whole 1 km x 1 km tile under a 15 m ceiling at
// 2.5 m is about 1.5 million.
// Memory an added sample and a lattice node hold at most, with their lookups, neighbour lists
// and queue entries (rounded up from the structures below), for the bounds a machine's memory sets.
constexpr double kRefinedSampleBytes = 256, kLatticeNodeBytes = 192;

// At most `count`, and at most what a quarter of the machine's memory holds (ulimit -v and
// cgroups included: machine_memory_bytes()), so that a small machine ends a search at its memory,
// the reason in the message, rather than the kernel ending the process.
size_t memory_bound(size_t count, double bytes_each) {
  return static_cast<size_t>(std::min(double(count), std::floor(machine_memory_bytes() / 4 / bytes_each)));
}

// The roadmap with the samples a query adds to it, connected lazily. Level l (1..kMaxLevel)
// continues the roadmap's Halton sequence from where build_roadmap() stopped to the count of
// spacing / 2^l over the whole flight volume, keeping only the indices inside a refinement
// region: the levels are nested, so a sample is the same point whichever round adds it. A
// sample of level l is joined to the samples within max_edge / 2^l (both ends' radius: the
// smaller), a roadmap node through its own edges, a waypoint to every sample within max_edge.
// Node numbers: the roadmap's, then the added samples in the order they were added.
class Refinement {
public:
  Refinement(const Roadmap& map, const PointGrid& base_grid, const FlightSpace& space, const PlanOptions& options)
      : map_(map),
        base_grid_(base_grid),
        space_(space),
        index_(space.index()),
        o_(options),
        nb_(static_cast<uint32_t>(map.nodes.size())),
        max_samples_(memory_bound(options.refine_max_samples, kRefinedSampleBytes)),
        max_lattice_nodes_(memory_bound(options.refine_max_lattice_nodes, kLatticeNodeBytes)) {
    const ClearanceIndex& index = index_;
    const ClearanceIndex::Footprint& e = index.footprint();
    wx_ = e.xmax - e.xmin, wy_ = e.ymax - e.ymin;
    count_[0] = std::round(wx_ * wy_ * o_.max_agl / std::pow(o_.spacing, 3));
    for (int l = 1; l <= kMaxLevel; ++l) {
      count_[l] = std::round(wx_ * wy_ * o_.max_agl / std::pow(o_.spacing / (1 << l), 3));
      if (count_[l] <= kMaxHaltonIndex) levels_ = l;
    }
    level_ids_.resize(kMaxLevel + 1);
    level_grid_.resize(kMaxLevel + 1);
    taken_.resize(kMaxLevel + 1);
  }

  size_t added() const { return nodes_.size(); }
  bool out_of_work() const { return work_ >= o_.refine_max_search_work; }
  int rounds() const { return rounds_; }
  double finest_spacing() const { return o_.spacing / (1 << finest_); }
  size_t lattice_nodes() const { return lattice_nodes_; }
  /// ", a lattice search stopped at N nodes", ", stopped at N added samples" for each bound of
  /// those reached, with "(what a quarter of this machine's memory holds)" when the memory set it
  /// lower than the option; else empty.
  std::string bounds_note() const {
    const std::string by_memory =
        " (what a quarter of this machine's memory, " + format_bytes(machine_memory_bytes()) + ", holds)";
    std::string note;
    if (lattice_at_bound_)
      note += ", a lattice search stopped at its bound of " + std::to_string(max_lattice_nodes_) + " nodes" +
              (max_lattice_nodes_ < o_.refine_max_lattice_nodes ? by_memory : "");
    if (nodes_.size() >= max_samples_)
      note += ", stopped at its bound of " + std::to_string(max_samples_) + " added samples" +
              (max_samples_ < o_.refine_max_samples ? by_memory : "");
    return note;
  }

  // The points of a path from waypoint a (number ia in the query) to b, or empty; every edge on
  // it is clear (checked here or a roadmap edge).
  std::vector<Point3> solve(const Point3& a, size_t ia, const Point3& b, size_t ib) {
    // The roadmap (and the samples earlier legs added) with every candidate edge of the
    // waypoints: searched first, unless the roadmap's components show it cannot join them. Then
    // the search is needed only for the rounds, and the same whenever it is made.
    std::optional<Search> s;
    if (!joined_apart(a, b)) {
      s = search(a, ia, &b, ib, SIZE_MAX);
      if (!s->path.empty()) return s->path;
    }
    if (std::vector<Point3> path = via_escapes(a, ia, b, ib); !path.empty()) return path;
    // Lattices from coarse to fine: a coarse one that fails has cost an eighth of the next.
    double previous = 0;
    for (int level = 1; level <= kMaxLevel; ++level) {
      // No step longer than max_edge, as in the roadmap (a diagonal step is sqrt(3) sides).
      const double side = std::min(o_.spacing / (1 << level), o_.max_edge / std::sqrt(3.0));
      if (side == previous) break;  // the same lattice again
      previous = side;
      const detail::LatticeResult lattice = detail::lattice_path(space_, a, b, side, max_lattice_nodes_);
      lattice_nodes_ += lattice.nodes;
      if (lattice.out_of_work) lattice_at_bound_ = true;
      if (!lattice.path.empty()) return lattice.path;
    }
    if (!s) s = search(a, ia, &b, ib, SIZE_MAX);
    for (int round = 1; s->path.empty() && round <= o_.refine_rounds; ++round) {
      if (levels_ == 0 || nodes_.size() >= max_samples_ || out_of_work()) break;
      // The smaller component: s.closed is all of a's; b's is explored up to that size.
      Search t = search(b, ib, nullptr, 0, s->closed.size() + 1);
      const bool from_b = t.closed.size() <= s->closed.size();
      const std::vector<Point3> seeds = frontier(from_b ? b : a, from_b ? t.closed : s->closed);
      ++rounds_;
      const int level = std::min(round, levels_), widen = std::max(0, round - levels_);
      const size_t before = nodes_.size();
      add_samples(level, widen, seeds);
      // Nothing added at the finest level over the widest region: no later round would add any.
      if (nodes_.size() == before && level == levels_ && widen >= kMaxWiden) break;
      s = search(a, ia, &b, ib, SIZE_MAX);
    }
    return s->path;
  }

private:
  struct Search {
    std::vector<Point3> path;      // with a goal: the path found, else empty
    std::vector<uint32_t> closed;  // the nodes settled (waypoints left out)
  };

  // ---- escapes: a waypoint no roadmap node reaches in a straight line ----
  //
  // A waypoint in a courtyard or a street under trees may have no clear segment to any roadmap
  // node within max_edge while the air above the roofs is one well-joined roadmap. The lattices
  // below search the whole leg (on the NRW tile under a 120 m ceiling, one such street waypoint
  // 850 m from the other took 21 s and 2 million nodes); a lattice around the waypoint alone
  // finds the way out to the roadmap in milliseconds, and the roadmap does the rest.

  // True when some node within max_edge of waypoint w (id wid) has a clear segment to it.
  bool reaches_roadmap(const Point3& w, uint32_t wid) {
    bool reached = false;
    near_waypoint(w, [&](uint32_t v, double) {
      if (!reached) reached = clear(wid, v, w, point(v));
    });
    return reached;
  }

  // The lattice path from w out to a point with a clear segment to one of the four nearest
  // roadmap nodes within max_edge, at spacing / 4 then / 8, within two max_edge of w (x,y);
  // empty when none. (Any node, not the largest component's: the component labels only spare
  // searches, they never change a path.)
  std::vector<Point3> escape(const Point3& w) {
    const std::function<bool(const Point3&)> is_exit = [&](const Point3& p) {
      std::vector<std::pair<double, uint32_t>> near;
      base_grid_.around(p, [&](uint32_t v) {
        const double d2 = detail::squared_distance(p, map_.nodes[v]);
        if (d2 < o_.max_edge * o_.max_edge) near.emplace_back(d2, v);
      });
      std::sort(near.begin(), near.end());
      for (size_t k = 0; k < std::min<size_t>(4, near.size()); ++k)
        if (space_.motion_valid(p, map_.nodes[near[k].second])) return true;
      return false;
    };
    for (const int level : {2, 3}) {
      const double side = std::min(o_.spacing / (1 << level), o_.max_edge / std::sqrt(3.0));
      const detail::LatticeResult way = detail::lattice_escape(space_, w, side, 2 * o_.max_edge,
                                                               std::min<size_t>(max_lattice_nodes_, 200000), is_exit);
      lattice_nodes_ += way.nodes;
      if (way.path.size() >= 2) return way.path;
    }
    return {};
  }

  // The leg through the escapes of its ends that need one (none needed: empty): each end's way
  // out, joined by a search over the roadmap from its last point (searched as a waypoint of its
  // own: its edges are cached apart from the waypoint's).
  std::vector<Point3> via_escapes(const Point3& a, size_t ia, const Point3& b, size_t ib) {
    const uint32_t wa = kWaypoint + static_cast<uint32_t>(ia), wb = kWaypoint + static_cast<uint32_t>(ib);
    std::vector<Point3> out_a{a}, out_b{b};
    if (!reaches_roadmap(a, wa) && (out_a = escape(a)).empty()) return {};
    if (!reaches_roadmap(b, wb) && (out_b = escape(b)).empty()) return {};
    if (out_a.size() == 1 && out_b.size() == 1) return {};  // both reach it: nothing to add
    const size_t ea = kEscape + escapes_++, eb = kEscape + escapes_++;
    const Search s = search(out_a.back(), ea, &out_b.back(), eb, SIZE_MAX);
    if (s.path.empty()) return {};
    std::vector<Point3> path(out_a.begin(), out_a.end() - 1);
    path.insert(path.end(), s.path.begin(), s.path.end());
    path.insert(path.end(), out_b.rbegin() + 1, out_b.rend());
    return path;
  }

  // True when no roadmap node within max_edge of a (a waypoint's candidate edges) shares a
  // component with one within max_edge of b, and no samples were added (they join components):
  // then no search over them finds a path.
  bool joined_apart(const Point3& a, const Point3& b) const {
    if (!nodes_.empty() || map_.component.size() != nb_) return false;
    std::vector<uint32_t> near_a, near_b;
    near_waypoint(a, [&](uint32_t v, double) { near_a.push_back(map_.component[v]); });
    near_waypoint(b, [&](uint32_t v, double) { near_b.push_back(map_.component[v]); });
    std::sort(near_a.begin(), near_a.end());
    for (uint32_t c : near_b)
      if (std::binary_search(near_a.begin(), near_a.end(), c)) return false;
    return true;
  }

  const Point3& point(uint32_t v) const { return v < nb_ ? map_.nodes[v] : nodes_[v - nb_]; }
  int level_of(uint32_t v) const { return v < nb_ ? 0 : level_[v - nb_]; }
  double radius(int level) const { return o_.max_edge / (1 << level); }

  // Cached exact check of the edge u-v (node numbers; a waypoint is kWaypoint + its number).
  static constexpr uint32_t kWaypoint = 0xF0000000u;
  bool clear(uint32_t u, uint32_t v, const Point3& p, const Point3& q) {
    const uint64_t key = u < v ? (uint64_t{u} << 32 | v) : (uint64_t{v} << 32 | u);
    auto [it, fresh] = cache_.try_emplace(key, false);
    if (fresh) it->second = u < v ? space_.motion_valid(p, q) : space_.motion_valid(q, p);
    return it->second;
  }
  int cached(uint32_t u, uint32_t v) const {  // 1 clear, 0 blocked, -1 not measured yet
    const uint64_t key = u < v ? (uint64_t{u} << 32 | v) : (uint64_t{v} << 32 | u);
    auto it = cache_.find(key);
    return it == cache_.end() ? -1 : it->second;
  }

  // fn(v) for every node that may be joined to the node u (not a waypoint) by a candidate edge,
  // with `known` true for a roadmap edge.
  template <class F>
  void candidates(uint32_t u, F&& fn) const {
    const Point3& p = point(u);
    const int lu = level_of(u);
    const double ru = radius(lu);
    if (lu == 0)
      for (uint32_t k = map_.start[u]; k < map_.start[u + 1]; ++k) fn(map_.neighbour[k], true);
    else
      base_grid_.around(p, [&](uint32_t v) {
        if (detail::squared_distance(p, map_.nodes[v]) < ru * ru) fn(v, false);
      });
    for (int l = 1; l <= levels_; ++l) {
      if (level_grid_[l].empty()) continue;
      const double r = std::min(ru, radius(l));
      level_grid_[l].around(p, [&](uint32_t k) {
        const uint32_t v = nb_ + k;
        if (v != u && detail::squared_distance(p, nodes_[k]) < r * r) fn(v, false);
      });
    }
  }

  // Where the component `part` (settled from waypoint w) may be joined to the rest: w and the
  // nodes of `part` with a node outside it within their joining radius (a candidate edge
  // measured blocked, or a roadmap pair never joined). Refinement samples around these.
  std::vector<Point3> frontier(const Point3& w, const std::vector<uint32_t>& part) const {
    std::vector<char> inside(nb_ + nodes_.size(), 0);
    for (uint32_t v : part) inside[v] = 1;
    std::vector<Point3> seeds{w};
    for (uint32_t v : part) {
      const Point3& p = point(v);
      const double r = radius(level_of(v));
      bool border = false;
      base_grid_.around(p, [&](uint32_t x) {
        if (!border && !inside[x] && detail::squared_distance(p, map_.nodes[x]) < r * r) border = true;
      });
      if (!border) candidates(v, [&](uint32_t x, bool) { border = border || !inside[x]; });
      if (border) seeds.push_back(p);
    }
    return seeds;
  }

  // fn(v, d) for every node within max_edge of the waypoint w.
  template <class F>
  void near_waypoint(const Point3& w, F&& fn) const {
    base_grid_.around(w, [&](uint32_t v) {
      const double d = distance(w, map_.nodes[v]);
      if (d < o_.max_edge) fn(v, d);
    });
    for (size_t k = 0; k < nodes_.size(); ++k) {
      const double d = distance(w, nodes_[k]);
      if (d < o_.max_edge) fn(nb_ + static_cast<uint32_t>(k), d);
    }
  }

  // A* from waypoint a to waypoint b (Dijkstra's exploration of a's component, at most `limit`
  // nodes, when b is null) over the roadmap and the added samples. An entry of the queue is a
  // node with the edge it would be reached by; that edge is measured when the entry comes first
  // (Lazy PRM), so a settled node's cost is its least over clear edges only and the path is the
  // shortest in the graph of clear candidate edges. Ties break by node, then by predecessor.
  Search search(const Point3& a, size_t ia, const Point3* b, size_t ib, size_t limit) {
    const uint32_t total = nb_ + static_cast<uint32_t>(nodes_.size()), S = total, G = total + 1;
    const uint32_t wa = kWaypoint + static_cast<uint32_t>(ia), wb = kWaypoint + static_cast<uint32_t>(ib);
    auto pt = [&](uint32_t v) -> const Point3& { return v == S ? a : v == G ? *b : point(v); };
    auto h = [&](uint32_t v) { return b ? distance(pt(v), *b) : 0.0; };
    std::vector<double> goal_cost;
    if (b) {
      goal_cost.assign(total, -1);
      near_waypoint(*b, [&](uint32_t v, double d) { goal_cost[v] = d; });
    }
    std::vector<double> best(total + 2, INFINITY);  // least cost over edges known to be clear
    std::vector<uint32_t> parent(total + 2, UINT32_MAX);
    std::vector<char> closed(total + 2, 0);
    struct Entry {
      double f, g;
      uint32_t v, u;
      bool operator>(const Entry& o) const { return f != o.f ? f > o.f : v != o.v ? v > o.v : u > o.u; }
    };
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
    auto push = [&](uint32_t u, double gu, uint32_t v, double w, int known) {
      if (closed[v] || known == 0) return;
      const double cost = gu + w;
      if (!(cost < best[v])) return;
      if (known == 1) best[v] = cost;
      open.push({cost + h(v), cost, v, u});
    };
    Search result;
    best[S] = 0;
    open.push({h(S), 0, S, UINT32_MAX});
    while (!open.empty()) {
      const Entry e = open.top();
      open.pop();
      const uint32_t v = e.v, u = e.u;
      if (closed[v]) continue;
      if (u != UINT32_MAX && !(u < nb_ && v < nb_)) {
        // Not a roadmap edge (those were measured when the roadmap was built): measure it now.
        const bool ok = u == S ? clear(wa, v, a, pt(v)) : v == G ? clear(u, wb, pt(u), *b) : clear(u, v, pt(u), pt(v));
        if (!ok) continue;
      }
      closed[v] = 1;
      parent[v] = u;
      if (v == G) break;
      if (v != S) {
        result.closed.push_back(v);
        if (result.closed.size() >= limit) break;
      }
      if (v == S) {
        near_waypoint(a, [&](uint32_t x, double d) { push(S, e.g, x, d, cached(wa, x)); });
        continue;
      }
      if (b && goal_cost[v] >= 0) push(v, e.g, G, goal_cost[v], cached(v, wb));
      candidates(v, [&](uint32_t x, bool known) {
        ++work_;
        push(v, e.g, x, distance(point(v), point(x)), known ? 1 : cached(v, x));
      });
      if (out_of_work()) break;
    }
    if (b && closed[G]) {
      for (uint32_t v = G; v != UINT32_MAX; v = parent[v]) result.path.push_back(pt(v));
      std::reverse(result.path.begin(), result.path.end());
    }
    return result;
  }

  // Adds the level's samples whose x,y lie within max_edge * 2^widen of a seed (not added
  // before).
  void add_samples(int level, int widen, const std::vector<Point3>& seeds) {
    finest_ = std::max(finest_, level);
    const ClearanceIndex::Footprint& e = index_.footprint();
    // The region as a bitmap of square cells of a quarter max_edge.
    const double c = o_.max_edge / 4;
    const int cols = static_cast<int>(wx_ / c) + 1, rows = static_cast<int>(wy_ / c) + 1;
    std::vector<char> region(static_cast<size_t>(cols) * rows, 0);
    auto cell_of = [&](const Point3& p) {
      const int ci = std::clamp(static_cast<int>((p[0] - e.xmin) / c), 0, cols - 1);
      const int cj = std::clamp(static_cast<int>((p[1] - e.ymin) / c), 0, rows - 1);
      return std::make_pair(ci, cj);
    };
    if (widen == 0) {
      // A cell is in when its centre is within max_edge plus half its diagonal of a seed.
      const double reach = o_.max_edge + c * 0.7072;
      const int span = static_cast<int>(std::ceil(reach / c)) + 1;
      for (const Point3& p : seeds) {
        const auto [ci, cj] = cell_of(p);
        for (int j = std::max(0, cj - span); j <= std::min(rows - 1, cj + span); ++j)
          for (int i = std::max(0, ci - span); i <= std::min(cols - 1, ci + span); ++i) {
            const double x = e.xmin + (i + 0.5) * c, y = e.ymin + (j + 0.5) * c;
            if (std::hypot(x - p[0], y - p[1]) <= reach) region[static_cast<size_t>(j) * cols + i] = 1;
          }
      }
    } else {
      // Wide: the cells within as many steps (8-neighbours, so a square, a little more than
      // the disc) of a seed's cell, by a breadth-first search from all seeds: O(cells).
      const int steps = static_cast<int>(std::ceil(o_.max_edge * (1 << std::min(widen, kMaxWiden)) / c)) + 1;
      std::vector<int> depth(region.size(), -1);
      std::vector<size_t> queue;
      for (const Point3& p : seeds) {
        const auto [ci, cj] = cell_of(p);
        const size_t k = static_cast<size_t>(cj) * cols + ci;
        if (depth[k] < 0) depth[k] = 0, queue.push_back(k);
      }
      for (size_t head = 0; head < queue.size(); ++head) {
        const size_t k = queue[head];
        region[k] = 1;
        if (depth[k] == steps) continue;
        const int i = static_cast<int>(k % cols), j = static_cast<int>(k / cols);
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int x = i + di, y = j + dj;
            if (x < 0 || y < 0 || x >= cols || y >= rows) continue;
            const size_t n = static_cast<size_t>(y) * cols + x;
            if (depth[n] < 0) depth[n] = depth[k] + 1, queue.push_back(n);
          }
      }
    }
    const uint64_t first = static_cast<uint64_t>(count_[level - 1]) + 1;
    const uint64_t last = static_cast<uint64_t>(count_[level]);
    if (last < first) return;
    const size_t n = static_cast<size_t>(last - first + 1);
    std::vector<char>& taken = taken_[level];
    if (taken.empty()) taken.assign(n, 0);
    // Fixed chunks, each filling its own list, joined in order: the same samples on any
    // number of threads.
    constexpr size_t chunk = 1 << 15;
    const size_t chunks = (n + chunk - 1) / chunk;
    std::vector<std::vector<std::pair<uint64_t, Point3>>> found(chunks);
    tbb::task_arena arena(o_.threads > 0 ? o_.threads : tbb::task_arena::automatic);
    arena.execute([&] {
      tbb::parallel_for(size_t(0), chunks, [&](size_t k) {
        for (size_t off = k * chunk; off < std::min(n, (k + 1) * chunk); ++off) {
          if (taken[off]) continue;
          const uint64_t i = first + off;
          const double x = e.xmin + detail::halton(i, 2) * wx_, y = e.ymin + detail::halton(i, 3) * wy_;
          const int ci = std::min(cols - 1, static_cast<int>((x - e.xmin) / c));
          const int cj = std::min(rows - 1, static_cast<int>((y - e.ymin) / c));
          if (!region[static_cast<size_t>(cj) * cols + ci]) continue;
          space_.check_stop();
          taken[off] = 1;  // decided once: a sample of this index is the same point every time
          Point3 p;
          if (space_.place(x, y, index_.ground(x, y), detail::halton(i, 5), p) && !space_.broken_by(p) &&
              index_.point_clear(p, o_.safety))
            found[k].emplace_back(i, p);
        }
      });
    });
    for (const auto& list : found)
      for (const auto& [i, p] : list) {
        if (nodes_.size() >= max_samples_) break;
        level_ids_[level].push_back(static_cast<uint32_t>(nodes_.size()));
        nodes_.push_back(p);
        level_.push_back(static_cast<uint8_t>(level));
      }
    level_grid_[level] = PointGrid(nodes_, level_ids_[level], radius(level));
  }

  const Roadmap& map_;
  const PointGrid& base_grid_;
  const FlightSpace& space_;
  const ClearanceIndex& index_;
  const PlanOptions& o_;
  const uint32_t nb_;
  const size_t max_samples_, max_lattice_nodes_;  // the fixed bounds, or less on a small machine
  static constexpr size_t kEscape = 0x08000000;   // ids of escapes' ends, apart from the waypoints'
  size_t escapes_ = 0;
  bool lattice_at_bound_ = false;
  double wx_ = 0, wy_ = 0;
  double count_[kMaxLevel + 1] = {};
  int levels_ = 0, finest_ = 0, rounds_ = 0;
  size_t work_ = 0;  // candidate edges looked at by the searches of this query
  size_t lattice_nodes_ = 0;
  std::vector<Point3> nodes_;
  std::vector<uint8_t> level_;
  std::vector<std::vector<uint32_t>> level_ids_;
  std::vector<PointGrid> level_grid_;
  std::vector<std::vector<char>> taken_;
  std::unordered_map<uint64_t, bool> cache_;
};

}  // namespace

RoadmapCache& RoadmapCache::operator=(const RoadmapCache&) {
  const std::lock_guard lock(mutex_);
  grid_.reset();  // the roadmap it belongs to was given other nodes
  return *this;
}

std::shared_ptr<const PointGrid> RoadmapCache::node_grid(const std::vector<Point3>& nodes, double cell) const {
  const std::lock_guard lock(mutex_);
  if (!grid_ || grid_->cell() != cell || grid_->size() != nodes.size())
    grid_ = std::make_shared<const PointGrid>(nodes, all_nodes(nodes.size()), cell);
  return grid_;
}

PlanResult query_roadmap(const Roadmap& map, const ClearanceIndex& index, const std::vector<Point3>& waypoints,
                         const PlanOptions& options) {
  check_plan_options(options);
  detail::check_waypoint_list(waypoints);
  PlanResult result;
  result.roadmap_nodes = map.nodes.size();
  result.roadmap_edges = map.edges();
  Stopwatch clock;
  const FlightSpace space = detail::flight_space(index, options);
  if (detail::invalid_waypoints(waypoints, space, result)) return result;
  const std::shared_ptr<const PointGrid> shared_grid = map.cache.node_grid(map.nodes, options.max_edge);
  const PointGrid& grid = *shared_grid;
  std::vector<std::vector<std::pair<double, uint32_t>>> links(waypoints.size());
  std::vector<std::vector<Point3>> legs;
  for (size_t i = 0; i < waypoints.size(); ++i)
    links[i] = detail::roadmap_links(waypoints[i], map, grid, space, options);
  std::unique_ptr<Refinement> refinement;  // made when a leg first needs it
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) {
    // A leg's search over the roadmap checks nothing against the space: stopped between legs,
    // or a 20,000-waypoint request computed on for seconds past its budget.
    space.check_stop();
    const Point3 &a = waypoints[i], &b = waypoints[i + 1];
    std::vector<Point3> leg;
    if (distance(a, b) < options.max_edge && space.motion_valid(a, b)) {
      leg = {a, b};
    } else if (!links_apart(map, links[i], links[i + 1])) {
      leg = astar(map, a, b, links[i], links[i + 1]);
    }
    if (leg.empty() && options.refine_rounds > 0) {
      if (!refinement) refinement = std::make_unique<Refinement>(map, grid, space, options);
      leg = refinement->solve(a, i, b, i + 1);
    }
    if (refinement) {
      result.refined_samples = refinement->added();
      result.refine_rounds = refinement->rounds();
      result.lattice_nodes = refinement->lattice_nodes();
    }
    if (leg.empty()) {
      result.status = PlanStatus::NoPath;
      result.waypoint = i;
      const size_t lonely = links[i].empty() ? i : links[i + 1].empty() ? i + 1 : SIZE_MAX;
      std::string refined;
      if (refinement)
        refined =
            " nor after " + std::to_string(refinement->rounds()) + " refinement rounds (" +
            std::to_string(refinement->added()) + " samples added, spacing down to " +
            format_number(refinement->finest_spacing()) +
            (refinement->out_of_work() ? ", stopped at its bound of " + std::to_string(options.refine_max_search_work) +
                                             " candidate edges searched"
                                       : "") +
            refinement->bounds_note() + ")";
      const std::string hint = "a smaller --spacing may give one";
      result.reason = lonely != SIZE_MAX
                          ? "no roadmap sample within --max-edge " + format_number(options.max_edge) +
                                " has a clear straight segment to waypoint " + std::to_string(lonely + 1) + refined +
                                "; " + hint
                          : "no path within the roadmap (" + std::to_string(map.nodes.size()) + " samples)" + refined +
                                "; a smaller --spacing or a larger --max-edge may find one";
      result.seconds_query = clock.lap();
      return result;
    }
    legs.push_back(std::move(leg));
  }
  result.seconds_query = clock.lap();
  detail::finish_path(legs, space, options, result);
  result.seconds_smooth = clock.lap();
  return result;
}

PlanResult plan_path(const ClearanceIndex& index, const std::vector<Point3>& waypoints, const PlanOptions& options,
                     const Progress& progress) {
  if (options.planner == PlannerKind::rrt_connect) return plan_rrt_connect(index, waypoints, options, progress);
  if (options.planner == PlannerKind::free_space)
    throw ArgumentError("--planner",
                        "freespace plans over the data through plan_flight(); plan_path() runs prm or "
                        "rrtconnect");
  check_plan_options(options);
  detail::check_waypoint_list(waypoints);
  if (PlanResult invalid; detail::invalid_waypoints(waypoints, detail::flight_space(index, options), invalid))
    return invalid;
  Stopwatch clock;
  const Roadmap map = build_roadmap(index, options, sub_progress(progress, 0, 0.95));
  const double seconds_roadmap = clock.lap();
  PlanResult result = query_roadmap(map, index, waypoints, options);
  result.seconds_roadmap = seconds_roadmap;
  report(progress, 1);
  return result;
}

}  // namespace dsmplan
