// The lattice step of the query-time refinement (plan.hpp, "Refinement", step 1): A* (Hart,
// Nilsson & Raphael, "A Formal Basis for the Heuristic Determination of Minimum Cost Paths",
// IEEE Trans. SSC 4(2), 1968) over a regular 3D lattice anchored at the leg's first waypoint,
// each node joined to its 26 neighbours, the motions checked lazily (Bohlin & Kavraki, "Path
// Planning Using Lazy PRM", ICRA 2000): an edge is measured only when the search would settle a
// node through it, and a node whose best edge proves blocked is offered again through its next
// best settled neighbour, so the path is the shortest over the lattice's clear edges.
//
// Why a lattice: under a low ceiling the free space is a thin layer over the streets. Random
// samples spread over the whole volume must become very dense before they chain through a
// street canyon (about 1.35 million for three legs at max_agl 15 m on the NRW tile); a lattice
// at the canyon's own scale finds the way by visiting the nodes along it, a few per metre.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <queue>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "plan/prm_parts.hpp"

namespace dsmplan::detail {

namespace {

constexpr uint32_t kNone = UINT32_MAX;
constexpr uint32_t kGoal = UINT32_MAX - 1;
constexpr double kWeight = 2;
constexpr size_t kPull = 8;  // points a straight pull may skip, at most

struct Step {
  int di, dj, dk;
  double length;  // in lattice units
};

std::vector<Step> neighbour_steps() {
  std::vector<Step> steps;
  for (int dk = -1; dk <= 1; ++dk)
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di)
        if (di || dj || dk) steps.push_back({di, dj, dk, std::sqrt(double(di * di + dj * dj + dk * dk))});
  return steps;
}

class LatticeSearch {
public:
  LatticeSearch(const FlightSpace& space, const Point3& a, const Point3& b, double step, size_t max_nodes)
      : space_(space), a_(a), b_(b), h_(step), max_nodes_(max_nodes), steps_(neighbour_steps()) {}
  // An escape (lattice_escape()): no goal point, the first settled node `is_exit` accepts ends
  // it, nodes farther than `radius` (x,y) from a are out.
  LatticeSearch(const FlightSpace& space, const Point3& a, double step, double radius, size_t max_nodes,
                const std::function<bool(const Point3&)>& is_exit)
      : LatticeSearch(space, a, a, step, max_nodes) {
    is_exit_ = &is_exit;
    radius_ = radius;
  }

  LatticeResult run() {
    LatticeResult result;
    const uint32_t start = node(0, 0, 0);  // the waypoint a itself, valid (checked by the query)
    nodes_[start].state = kValid;
    nodes_[start].best = 0;
    open_.push({h(start), 0, start, kNone});
    const double reach = 2 * h_;  // nodes this near b may end the path
    while (!open_.empty()) {
      const Entry e = open_.top();
      open_.pop();
      if (e.v == kGoal) {
        if (space_.motion_valid(nodes_[e.u].p, b_)) {
          result.path = path_to(e.u);
          break;
        }
        continue;
      }
      if (nodes_[e.v].closed || e.g > nodes_[e.v].best) continue;  // settled, or a stale entry
      if (!valid(e.v)) continue;  // tested when first it comes first: most nodes made never do
      Node& v = nodes_[e.v];
      if (e.u != kNone && !space_.candidate_valid(nodes_[e.u].p, v.p)) {  // both ends valid nodes
        blocked_.insert(edge_key(e.u, e.v));
        offer_again(e.v);
        continue;
      }
      v.closed = true;
      v.parent = e.u;
      const double gv = e.g;
      const Point3 pv = v.p;
      const int i = v.i, j = v.j, k = v.k;
      if (is_exit_ && (*is_exit_)(pv)) {
        result.path = path_to(e.v);
        break;
      }
      if (!is_exit_ && squared_distance(pv, b_) <= reach * reach)
        open_.push({gv + distance(pv, b_), gv + distance(pv, b_), kGoal, e.v});
      for (const Step& s : steps_) {
        const uint32_t w = node(i + s.di, j + s.dj, k + s.dk);
        Node& n = nodes_[w];
        if (n.state == kInvalid || n.closed) continue;
        const double cost = gv + s.length * h_;
        if (cost < n.best) {
          n.best = cost;
          open_.push({cost + h(w), cost, w, e.v});
        }
      }
      if (nodes_.size() >= max_nodes_) {
        result.out_of_work = true;
        break;
      }
    }
    result.nodes = nodes_.size();
    return result;
  }

private:
  struct Node {
    Point3 p;
    int i, j, k;
    double best = INFINITY;  // least cost offered so far
    uint32_t parent = kNone;
    uint8_t state = kUntested;
    bool closed = false;
  };
  static constexpr uint8_t kUntested = 0, kValid = 1, kInvalid = 2;
  struct Entry {
    double f, g;
    uint32_t v, u;
    bool operator>(const Entry& o) const { return f != o.f ? f > o.f : v != o.v ? v > o.v : u > o.u; }
  };

  double h(uint32_t v) const { return is_exit_ ? 0.0 : kWeight * distance(nodes_[v].p, b_); }

  static uint64_t key(int i, int j, int k) {
    constexpr int64_t mask = (int64_t{1} << 21) - 1, off = int64_t{1} << 20;
    return (static_cast<uint64_t>((i + off) & mask) << 42) | (static_cast<uint64_t>((j + off) & mask) << 21) |
           static_cast<uint64_t>((k + off) & mask);
  }
  static uint64_t edge_key(uint32_t u, uint32_t v) { return u < v ? (uint64_t{u} << 32 | v) : (uint64_t{v} << 32 | u); }

  // The node (i, j, k), made on first sight.
  uint32_t node(int i, int j, int k) {
    auto [it, fresh] = ids_.try_emplace(key(i, j, k), static_cast<uint32_t>(nodes_.size()));
    if (!fresh) return it->second;
    Node n;
    n.p = {a_[0] + i * h_, a_[1] + j * h_, a_[2] + k * h_};
    n.i = i, n.j = j, n.k = k;
    nodes_.push_back(n);
    return it->second;
  }

  // Valid when within the limits (ceiling, constraints), not under the surface and clear of the
  // mesh by the safety distance; tested once.
  bool valid(uint32_t v) {
    Node& n = nodes_[v];
    if (n.state == kUntested) {
      const ClearanceIndex& index = space_.index();
      const double dx = n.p[0] - a_[0], dy = n.p[1] - a_[1];
      if (dx * dx + dy * dy > radius_ * radius_) return n.state = kInvalid, false;
      // The floor first: a node less than the safety distance above it is in a building or
      // too near a roof, and reading the floor costs far less than the triangles.
      const bool ok = space_.within_limits(n.p) && !(index.floor().height_above(n.p) < space_.safety()) &&
                      n.p[2] >= index.ground(n.p[0], n.p[1]) && index.point_clear(n.p, space_.safety());
      n.state = ok ? kValid : kInvalid;
    }
    return n.state == kValid;
  }

  // v's best edge was blocked: offer it through the settled neighbour that now gives the least
  // cost over an edge not known to be blocked.
  void offer_again(uint32_t v) {
    Node& n = nodes_[v];
    n.best = INFINITY;
    uint32_t via = kNone;
    for (const Step& s : steps_) {
      auto it = ids_.find(key(n.i + s.di, n.j + s.dj, n.k + s.dk));
      if (it == ids_.end()) continue;
      const Node& u = nodes_[it->second];
      if (!u.closed || blocked_.count(edge_key(it->second, v))) continue;
      const double cost = u.best + s.length * h_;
      if (cost < n.best || (cost == n.best && it->second < via)) n.best = cost, via = it->second;
    }
    if (via != kNone) open_.push({n.best + h(v), n.best, v, via});
  }

  std::vector<Point3> path_to(uint32_t last) const {
    std::vector<Point3> path;
    if (!is_exit_) path.push_back(b_);  // an escape ends at its exit node
    for (uint32_t v = last; v != kNone; v = nodes_[v].parent) path.push_back(nodes_[v].p);
    path.back() = a_;  // exactly the waypoint, not a copy
    std::reverse(path.begin(), path.end());
    // Pulled tight a little: from each kept point straight on to the farthest of the next
    // kPull points that a valid motion reaches (short segments, so cheap to check; the
    // smoothing's shortcuts then start from a few points instead of one per step).
    std::vector<Point3> out{path.front()};
    for (size_t m = 0; m + 1 < path.size();) {
      size_t far = std::min(path.size() - 1, m + kPull);
      while (far > m + 1 && !space_.candidate_valid(path[m], path[far])) --far;  // most pulls fail
      out.push_back(path[far]);
      m = far;
    }
    return out;
  }

  const FlightSpace& space_;
  const Point3 a_, b_;
  const double h_;
  const size_t max_nodes_;
  const std::vector<Step> steps_;
  const std::function<bool(const Point3&)>* is_exit_ = nullptr;
  double radius_ = INFINITY;
  std::vector<Node> nodes_;
  std::unordered_map<uint64_t, uint32_t> ids_;
  std::unordered_set<uint64_t> blocked_;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open_;
};

}  // namespace

LatticeResult lattice_path(const FlightSpace& space, const Point3& a, const Point3& b, double step, size_t max_nodes) {
  return LatticeSearch(space, a, b, step, max_nodes).run();
}

LatticeResult lattice_escape(const FlightSpace& space, const Point3& a, double step, double radius, size_t max_nodes,
                             const std::function<bool(const Point3&)>& is_exit) {
  return LatticeSearch(space, a, step, radius, max_nodes, is_exit).run();
}

}  // namespace dsmplan::detail
