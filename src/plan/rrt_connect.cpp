// RRT-Connect: Kuffner & LaValle, "RRT-Connect: An Efficient Approach to Single-Query Path
// Planning", IEEE ICRA 2000 (the RRT itself: LaValle, "Rapidly-exploring random trees: A new
// tool for path planning", TR 98-11, Iowa State University, 1998). Per leg, a tree grows from
// each waypoint; EXTEND moves one tree a step towards a random sample, CONNECT moves the other
// one greedily, step after step, towards the node just added, until it arrives or is blocked;
// then the trees swap roles. The validity checker is the PRM's (ClearanceIndex, exact), and the
// path is finished by the same shortcuts, corner rounding and last check (path_parts.hpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/stopwatch.hpp"
#include "dsmplan/plan.hpp"
#include "plan/path_parts.hpp"

namespace dsmplan {

namespace {

using detail::distance;

constexpr uint32_t kNoParent = std::numeric_limits<uint32_t>::max();

double squared_distance(const Point3& a, const Point3& b) {
  const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz;
}

Point3 lerp(const Point3& a, const Point3& b, double t) {
  return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

// splitmix64 (Steele, Lea, Flood, "Fast splittable pseudorandom number generators", OOPSLA
// 2014): one well-mixed seed for each leg from the user's seed, so legs do not share a stream
// and a change to one leg's waypoints leaves the others' trees alone.
uint64_t leg_seed(uint64_t seed, size_t leg) {
  uint64_t z = seed + 0x9E3779B97F4A7C15ull * (static_cast<uint64_t>(leg) + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// [0, 1) from the top 53 bits: std::uniform_real_distribution's algorithm is left to the
// standard library, this is the same everywhere, so a seed means the same path on every platform.
double unit(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

// The exact nearest node of one tree.
// Why a uniform 3D grid of cells and not a kd-tree: nodes arrive one at a time, between
// queries, and CGAL's Kd_tree is built once (an insertion invalidates it, the next query
// rebuilds it all); an incremental kd-tree degenerates into chains along CONNECT's straight
// runs of nodes. The flight volume is a thin slab (max_agl plus the relief high, hundreds of
// metres to kilometres wide), so cells of about the step length make few layers, a query near
// the tree reads a few cells, and one far from it reads only the rings of cells that overlap the
// box of occupied cells. Cells live in a hash map: no bounds to know in advance (a waypoint may
// lie far above the flight volume) and no memory for empty space.
class NearestGrid {
public:
  NearestGrid(const Point3& origin, double cell) : origin_(origin), cell_(cell) {}

  void insert(const Point3& p, uint32_t id) {
    const Cell c = cell_of(p);
    cells_[c].push_back(id);
    if (count_++ == 0) {
      lo_ = hi_ = c;
    } else {
      lo_ = {std::min(lo_.x, c.x), std::min(lo_.y, c.y), std::min(lo_.z, c.z)};
      hi_ = {std::max(hi_.x, c.x), std::max(hi_.y, c.y), std::max(hi_.z, c.z)};
    }
  }

  // The node of `nodes` (all inserted) nearest to q; ties go to the lower number, so the answer
  // does not depend on the order cells are read in. At least one node must be inserted.
  uint32_t nearest(const Point3& q, const std::vector<Point3>& nodes) const {
    const Cell c = cell_of(q);
    uint32_t best = kNoParent;
    double best_d2 = INFINITY;
    auto visit = [&](int64_t x, int64_t y, int64_t z) {
      const auto it = cells_.find({x, y, z});
      if (it == cells_.end()) return;
      for (uint32_t id : it->second) {
        const double d2 = squared_distance(q, nodes[id]);
        if (d2 < best_d2 || (d2 == best_d2 && id < best)) best_d2 = d2, best = id;
      }
    };
    // Ring r holds the cells at Chebyshev distance r (in cells) from q's own. A node in ring
    // r + 1 or beyond is more than r cells away along some axis, so once ring r is read a node
    // within r * cell is the nearest. (1 - 1e-9): slack for the rounding of the cell numbers.
    auto gap = [](int64_t v, int64_t lo, int64_t hi) { return std::max<int64_t>({lo - v, v - hi, 0}); };
    auto reach = [](int64_t v, int64_t lo, int64_t hi) { return std::max(v - lo, hi - v); };
    const int64_t first = std::max({gap(c.x, lo_.x, hi_.x), gap(c.y, lo_.y, hi_.y), gap(c.z, lo_.z, hi_.z)});
    const int64_t last = std::max({reach(c.x, lo_.x, hi_.x), reach(c.y, lo_.y, hi_.y), reach(c.z, lo_.z, hi_.z)});
    for (int64_t r = first; r <= last; ++r) {
      const int64_t x0 = std::max(c.x - r, lo_.x), x1 = std::min(c.x + r, hi_.x);
      const int64_t y0 = std::max(c.y - r, lo_.y), y1 = std::min(c.y + r, hi_.y);
      const int64_t z0 = std::max(c.z - r, lo_.z), z1 = std::min(c.z + r, hi_.z);
      for (int64_t x = x0; x <= x1; ++x)
        for (int64_t y = y0; y <= y1; ++y) {
          if (std::abs(x - c.x) == r || std::abs(y - c.y) == r) {
            for (int64_t z = z0; z <= z1; ++z) visit(x, y, z);  // a side of the ring: the whole column
          } else {
            // Inside the ring's square: only its top and bottom faces.
            if (c.z - r >= lo_.z && c.z - r <= hi_.z) visit(x, y, c.z - r);
            if (r > 0 && c.z + r >= lo_.z && c.z + r <= hi_.z) visit(x, y, c.z + r);
          }
        }
      const double bound = static_cast<double>(r) * cell_ * (1 - 1e-9);
      if (best != kNoParent && best_d2 <= bound * bound) break;
    }
    return best;
  }

private:
  struct Cell {
    int64_t x, y, z;
    bool operator==(const Cell& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct CellHash {
    size_t operator()(const Cell& c) const {
      uint64_t h = static_cast<uint64_t>(c.x) * 0x9E3779B97F4A7C15ull;
      h ^= static_cast<uint64_t>(c.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
      h ^= static_cast<uint64_t>(c.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
      return static_cast<size_t>(h);
    }
  };
  Cell cell_of(const Point3& p) const {
    return {static_cast<int64_t>(std::floor((p[0] - origin_[0]) / cell_)),
            static_cast<int64_t>(std::floor((p[1] - origin_[1]) / cell_)),
            static_cast<int64_t>(std::floor((p[2] - origin_[2]) / cell_))};
  }

  Point3 origin_;
  double cell_;
  std::unordered_map<Cell, std::vector<uint32_t>, CellHash> cells_;
  size_t count_ = 0;
  Cell lo_{0, 0, 0}, hi_{0, 0, 0};  ///< box of the occupied cells
};

struct Tree {
  std::vector<Point3> nodes;
  std::vector<uint32_t> parent;  ///< kNoParent for the root
  NearestGrid grid;

  Tree(const Point3& root, double cell) : grid(root, cell) { add(root, kNoParent); }
  uint32_t add(const Point3& p, uint32_t from) {
    const auto id = static_cast<uint32_t>(nodes.size());
    nodes.push_back(p);
    parent.push_back(from);
    grid.insert(p, id);
    return id;
  }
  // From the root to node v.
  std::vector<Point3> path_to(uint32_t v) const {
    std::vector<Point3> path;
    for (; v != kNoParent; v = parent[v]) path.push_back(nodes[v]);
    std::reverse(path.begin(), path.end());
    return path;
  }
};

enum class Growth { trapped, advanced, reached };

// What one leg's search needs to know of the world.
struct Space {
  const FlightSpace& flight;
  const ClearanceIndex& index;
  double range, safety;

  // A new node must lie over the mesh, not under its surface, and keep the safety distance.
  // point_clear() first: a point query reads the buckets around one point only, a cheap way to
  // refuse most blocked steps before the segment query (which would refuse them too).
  bool admissible(const Point3& p) const {
    const double g = index.ground(p[0], p[1]);
    return !std::isnan(g) && p[2] >= g && flight.state_valid(p);
  }

  // EXTEND (Kuffner & LaValle, Fig. 2): from the tree's nearest node, a step of at most
  // `range` towards `target`; `added` is the node that reached or advanced.
  Growth extend(Tree& tree, const Point3& target, uint32_t& added) const {
    const uint32_t near = tree.grid.nearest(target, tree.nodes);
    const Point3 from = tree.nodes[near];
    const double d = distance(from, target);
    if (d == 0) {
      added = near;
      return Growth::reached;
    }
    const bool arrives = d <= range;
    const Point3 to = arrives ? target : lerp(from, target, range / d);
    if (!admissible(to) || !flight.motion_valid(from, to)) return Growth::trapped;
    added = tree.add(to, near);
    return arrives ? Growth::reached : Growth::advanced;
  }

  // CONNECT (Fig. 3): EXTEND towards `target` until it is reached or a step is blocked. Each
  // advance ends `range` closer to the fixed target than the nearest node was, so it stops
  // after at most distance / range + 1 steps.
  Growth connect(Tree& tree, const Point3& target, uint32_t& added) const {
    Growth growth;
    do growth = extend(tree, target, added);
    while (growth == Growth::advanced);
    return growth;
  }
};

// Uniform in the flight volume: the footprint, from the surface up to the ceiling; false for a
// draw over a hole (no surface below) or where the ceiling leaves no room.
bool draw_sample(std::mt19937_64& rng, const FlightSpace& flight, Point3& sample) {
  const ClearanceIndex& index = flight.index();
  const ClearanceIndex::Footprint& e = index.footprint();
  const double x = e.xmin + unit(rng) * (e.xmax - e.xmin);
  const double y = e.ymin + unit(rng) * (e.ymax - e.ymin);
  const double h = unit(rng);  // drawn before the test: every draw uses three numbers
  return flight.place(x, y, index.ground(x, y), h, sample);
}

}  // namespace

PlanResult plan_rrt_connect(const ClearanceIndex& index, const std::vector<Point3>& waypoints,
                            const PlanOptions& options, const Progress& progress) {
  check_plan_options(options);
  if (options.rrt_max_samples < 1)
    throw ArgumentError("rrt_max_samples", "must be at least 1, got " + std::to_string(options.rrt_max_samples));
  detail::check_waypoint_list(waypoints);
  PlanResult result;
  const FlightSpace flight = detail::flight_space(index, options);
  if (detail::invalid_waypoints(waypoints, flight, result)) return result;

  const ClearanceIndex::Footprint& e = index.footprint();
  // Cells of the step length, but at most about 64 across the footprint: a small --max-edge
  // must not make a far query read thousands of empty rings.
  const double cell = std::max(options.max_edge, std::max(e.xmax - e.xmin, e.ymax - e.ymin) / 64);
  const Space space{flight, index, options.max_edge, options.safety};
  const size_t leg_count = waypoints.size() - 1;
  Stopwatch clock;
  std::vector<std::vector<Point3>> legs;
  for (size_t leg = 0; leg < leg_count; ++leg) {
    const Point3 &a = waypoints[leg], &b = waypoints[leg + 1];
    if (distance(a, b) == 0) {  // the same point twice: nothing to grow
      legs.push_back({a, b});
      continue;
    }
    Tree from_a(a, cell), from_b(b, cell);
    Tree *grow = &from_a, *other = &from_b;  // EXTEND grows `grow`, CONNECT `other`; they swap
    std::mt19937_64 rng(leg_seed(options.seed, leg));
    std::vector<Point3> path;
    for (int drawn = 0; drawn < options.rrt_max_samples && path.empty(); ++drawn) {
      if (drawn % 1024 == 1023)
        report(progress, (static_cast<double>(leg) + static_cast<double>(drawn) / options.rrt_max_samples) /
                             static_cast<double>(leg_count));
      Point3 sample;
      if (!draw_sample(rng, flight, sample)) continue;
      uint32_t added = 0, met = 0;
      if (space.extend(*grow, sample, added) != Growth::trapped &&
          space.connect(*other, grow->nodes[added], met) == Growth::reached) {
        // Both trees hold the meeting point (the same coordinates: CONNECT's last step copies
        // its target): root of `grow` ... meeting point ... root of `other`.
        path = grow->path_to(added);
        std::vector<Point3> rest = other->path_to(met);
        path.insert(path.end(), rest.rbegin() + 1, rest.rend());
        if (grow == &from_b) std::reverse(path.begin(), path.end());
      }
      std::swap(grow, other);
    }
    result.roadmap_nodes += from_a.nodes.size() + from_b.nodes.size();
    result.roadmap_edges += from_a.nodes.size() - 1 + from_b.nodes.size() - 1;
    if (path.empty()) {
      result.status = PlanStatus::NoPath;
      result.waypoint = leg;
      result.reason = "RRT-Connect's trees did not meet within " + std::to_string(options.rrt_max_samples) +
                      (options.rrt_max_samples == 1 ? " sample (" : " samples (") +
                      std::to_string(from_a.nodes.size() + from_b.nodes.size()) +
                      " nodes); another --seed, a larger --max-edge or --max-agl may find a path";
      result.seconds_query = clock.lap();
      report(progress, 1);
      return result;
    }
    legs.push_back(std::move(path));
  }
  result.seconds_query = clock.lap();
  detail::finish_path(legs, flight, options, result);
  result.seconds_smooth = clock.lap();
  report(progress, 1);
  return result;
}

}  // namespace dsmplan
