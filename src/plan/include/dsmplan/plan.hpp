// dsmplan/plan.hpp: stage 4, paths for a drone over the obstacle mesh (Adolf & Hirschmueller,
// Section 5: sampling-based planning on the polygonal surface with a 2 m safety distance).
//
// As OMPL separates them, the planner has three parts: the planner (roadmap, search: here),
// the validity checker (flight_space.hpp: the clearance of clearance.hpp, the ceiling of
// ground.hpp, and pluggable FlightConstraints such as a NoFlyZone) and the path simplifier
// (here). Above the planner: corridor.hpp (a city too large to mesh whole), columns.hpp (a plan
// held to the DSM's own columns), roadmap_file.hpp (a roadmap kept for many queries).
//
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/clearance.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/flight_space.hpp"
#include "dsmplan/ground.hpp"
#include "dsmplan/mesh.hpp"

namespace dsmplan {

// ---- the planner: roadmap, query, smoothing -----------------------------------------------
//
// A probabilistic roadmap (Kavraki, Svestka, Latombe, Overmars 1996) as the paper's Section 5
// builds it, then A* (Hart, Nilsson, Raphael 1968) and shortcut smoothing.
//   - Flight volume: the mesh's x,y bounding box; at (x, y) from the surface (ground()) up to
//     the ceiling, max_agl above the ground of PlanOptions::ground (ground.hpp: the terrain, the
//     DSM's cells, or the mesh's floor). Samples are the Halton sequence (Halton 1960) in bases
//     2, 3, 5, from index 1, mapped to x, y and the fraction of the way from surface to ceiling;
//     a sample where no triangle covers (x, y), where the ceiling is below the surface, or
//     closer than `safety` to the mesh is dropped. Their number before dropping is
//     round(area * max_agl / spacing^3), so `spacing` is the mean distance between samples.
//     Quasi-random, not random: the roadmap is a function of the mesh, ground and options alone.
//   - Validity, in OMPL's sense, is one checker that every planner here asks (FlightSpace,
//     flight_space.hpp): a straight motion is valid when it keeps `safety` from every
//     triangle, no point of it is higher than max_agl above the ground (measured exactly,
//     GroundGrid::below_ceiling()) and every PlanOptions::constraints allows it. So the ceiling
//     and the constraints hold for every edge, connection, shortcut and spline chord, not only
//     for the samples.
//   - Edges: every pair of samples closer than max_edge whose straight segment is valid (clear by
//     `safety`, ClearanceIndex::segment_clear, exact; under the ceiling). Candidates come from a uniform 3D grid
//     of max_edge cells; the segments are checked in parallel (TBB), and the result (nodes,
//     edges, their order) is the same for every number of threads. Most pairs need no check:
//     each sample carries a lower bound r of its clearance (ClearanceIndex::clearance_bound,
//     from bucket heights, up to safety + max_edge), and a segment with r_p + r_q - |pq| >=
//     2 safety is clear (free-space balls, Quinlan & Khatib 1993), so the exact check could
//     only agree (83 % of the pairs on the NRW tile with the defaults).
//   - Query: each waypoint must lie inside the x,y extent over a triangle, not below the
//     surface and at least `safety` from the mesh. It joins the roadmap through up to
//     `connections` of the samples within max_edge, nearest first, whose segments are clear (a
//     bounded local search); consecutive waypoints closer than max_edge are also joined
//     directly when clear. A* with the Euclidean distance (admissible and consistent) finds
//     the shortest roadmap path of each leg; ties break by node number, so it is deterministic.
//   - Smoothing: within each leg, from each path point the farthest later point the straight
//     segment to which is clear is joined directly (greedy shortcuts). A shortcut replaces a
//     polygonal piece by a straight segment between its ends, so it is never longer, and it is
//     kept only when segment_clear() holds with the same safety distance, so never unsafe.
//     Then corner rounding (PlanOptions::spline): each interior corner is replaced by the
//     quadratic Bezier from the middle of the incoming segment over the corner to the middle
//     of the outgoing one (the clamped uniform quadratic B-spline of the shortcut polygon),
//     drawn as chords of about 2 m, every chord checked with segment_clear(); a corner whose
//     chords are not all clear is tried cutting 1/4, 1/8, 1/16 of the segments, then kept
//     sharp. The curve is convex and lies in the triangle of its ends and the corner, so the
//     rounded path is never longer than the shortcut one.
//     Legs are smoothed apart, so the path passes through every waypoint, in order, exactly
//     (the waypoints' own coordinates, not copies rounded through the roadmap).
//   - Work spared without changing an answer: most candidate motions of the shortcuts and of
//     the lattice search below fail, and are refused first from the ground rasters alone
//     (FlightSpace::surely_invalid: a point sampled once a cell within the safety distance of
//     the mesh's floor or above the ceiling) before the exact checks; the roadmap labels its
//     connected components (Roadmap::component), so a leg whose ends reach no common component
//     skips A* and the refinement's first search, which would search that whole component in vain.
//   - Refinement (very low altitude; PlanOptions::refine_rounds, default 8, 0 = off): where the
//     roadmap fails a leg, the query grows a query-local extension of it (build_roadmap()'s
//     result stays a function of mesh and options; later legs of the query reuse the extension).
//     It follows the expansion step of Kavraki et al. 1996 (more samples where the roadmap is
//     poorly connected) with Lazy PRM's edge checks (Bohlin & Kavraki, "Path Planning Using
//     Lazy PRM", ICRA 2000). First the query as above (the paper's planner, unchanged); then
//       0. A lazy A* over the roadmap with each waypoint joined to every sample within max_edge
//          (not only the first `connections`). A queue entry is a node with the edge it would
//          be reached by; that edge is measured (segment_clear, exact, cached) only when the
//          entry comes first, so the search finds the shortest path over clear edges while
//          measuring few of them. Roadmap edges are known clear.
//       1. Failing that, a lattice search (lattice_search.cpp): A* over the regular lattice
//          anchored at the leg's first waypoint, each node joined to its 26 neighbours,
//          nodes tested as samples are (and not under the surface), edges measured lazily as
//          in 0; the heuristic weighted by 2 (a path at most twice the lattice's shortest
//          before smoothing, found visiting far fewer nodes), the path pulled tight over up to
//          8 nodes. Lattices of spacing / 2, / 4, / 8 in turn (sides at most max_edge / sqrt(3):
//          no step longer than a roadmap edge), at most 2 million nodes each
//          (their lookup and queue: about 300 MB at most).
//          Under a low ceiling the free space is a thin layer over the streets; a lattice at
//          the streets' scale follows it where random samples would have to become very dense.
//       2. Failing that, round r: the component of each waypoint is explored (the smaller one
//          only as far as the other's size), and around the smaller one's frontier (its
//          waypoint and its nodes with an unjoined node within their joining radius) new
//          samples are placed: the roadmap's Halton sequence continued at spacing / 2^l,
//          l = min(r, 3), over the whole flight volume, keeping the indices whose x,y lie
//          within max_edge of a frontier point and that pass the roadmap's sample test. The
//          levels are nested (level l is the sequence's indices from the count of level l-1
//          to that of spacing / 2^l), so an index is one point whichever round adds it. A
//          level-l sample is joined (lazily) to samples within max_edge / 2^l (of two levels,
//          the smaller radius), a roadmap node to a sample through the sample's radius.
//       3. The lazy A* again; repeat until solved or a bound. Rounds past the finest level
//          widen the region to 2, 4, ... 32 times max_edge around the frontier (a street
//          network at 10 m above ground is crossed that way). Bounds: refine_rounds rounds a
//          leg, a level needing more than 4 million Halton indices is not used,
//          refine_max_samples added samples a query, refine_max_search_work candidate edges
//          looked at by a leg's searches; a round at the finest level over the widest region
//          that adds nothing stops.
//          Then NoPath, the reason naming the rounds, the samples added and the finest spacing.
//     Deterministic: samples are tested in parallel and kept in index order, the searches are
//     sequential with ties broken by node number. Times: bench/README.md (bench_table3).
// Every segment of a returned path satisfies segment_clear(p, q, safety) and the ceiling (checked once more
// before it is returned; tests/plan_test.cpp re-verifies it by brute force over all triangles).

/// Which planner runs: the paper's roadmap (multi-query, see above), RRT-Connect (single-query,
/// see plan_rrt_connect() below), or the search over the free airspace's cells (free_airspace.hpp;
/// plan_flight() runs it, plan_path() does not).
enum class PlannerKind { prm, rrt_connect, free_space };

/// "prm", "rrtconnect", "freespace": the name every face gives the planner.
const char* planner_name(PlannerKind kind);

/// What the freespace planner minimises (free_airspace.hpp). `low`: each metre of climb or
/// descent between the cells' floors costs as a metre flown, so the path keeps as low as the
/// safety distance allows and climbs only where that saves as much as it costs; `shortest`: a
/// quarter, so the path goes over a low roof where that is shorter.
enum class Objective { low, shortest };

/// "low", "shortest": the name every face gives the objective.
const char* objective_name(Objective objective);
/// What a metre of climb or descent costs the freespace search, in metres flown: 1 (low), 0.25 (shortest).
double climb_weight(Objective objective);

struct PlanOptions {
  PlannerKind planner = PlannerKind::prm;  ///< what plan_path() runs
  Objective objective = Objective::low;    ///< freespace only: what its search minimises
  double safety = 2;                       ///< least distance to the mesh, CRS units (the paper's 2 m)
  /// Least distance from the no-fly zones that block, CRS units: a zone's own margin apart from
  /// the obstacles' (`--no-fly-buffer`); NaN: `safety`. zone_keep_distance() is the rule.
  double no_fly_buffer = NAN;
  double spacing = 20;     ///< relative sample distance: samples = volume / spacing^3
  double max_edge = 34.5;  ///< longest roadmap edge, CRS units
  double max_agl = 120;    ///< the ceiling: no point of a path higher above the ground (see `ground`)
  int connections = 10;    ///< roadmap samples each waypoint is joined to, at most
  bool smooth = true;      ///< shortcut smoothing
  bool spline = true;      ///< then corner rounding by a quadratic B-spline, each chord re-checked
  int threads = 0;         ///< 0: every core
  /// RRT-Connect only (the PRM's samples are quasi-random, it has none): its random numbers.
  /// The same seed, mesh and waypoints give the same path.
  uint64_t seed = 1;
  /// RRT-Connect only: random samples drawn per leg before it gives up with NoPath (those
  /// falling over a hole of the mesh count too), so it always ends. RRT-Connect's step length
  /// ("range") is max_edge.
  int rrt_max_samples = 20000;
  /// Query-time refinement where the roadmap fails a leg (see "Refinement" above): at most
  /// this many rounds; 0 turns it off (the roadmap alone, as the paper's planner).
  int refine_rounds = 8;
  /// Refinement's bounds on its work: counts, not clocks, so the answer is the same on every
  /// machine; the first two are lowered further to what a quarter of the machine's memory
  /// holds. Reaching one ends the leg with NoPath, the bound named in the reason.
  size_t refine_max_samples = 1000000;        ///< samples a query adds, at most
  size_t refine_max_lattice_nodes = 2000000;  ///< nodes one lattice search makes, at most
  size_t refine_max_search_work = 100000000;  ///< candidate edges a leg's lazy searches look at, at most
  /// The ground max_agl counts from (ground.hpp): the DTM, or the DSM's cells; null: the mesh's
  /// floor (ClearanceIndex::floor()). Every point of every path keeps height above it <= max_agl.
  std::shared_ptr<const GroundGrid> ground;
  /// Further rules every point of every path keeps (flight_space.hpp: NoFlyZone, or your own).
  std::vector<std::shared_ptr<const FlightConstraint>> constraints;
  /// The request's stop (core.hpp): once it is requested (or its deadline passes) every planner
  /// and every search of plan_flight() throws Cancelled within a few validity checks. Null: runs
  /// to the end. Not part of the roadmap's key: a roadmap is the same however it may be stopped.
  std::shared_ptr<const StopToken> stop;
};

/// Throws ArgumentError naming the option ("--safety", "--spacing", "--max-edge", "--max-agl",
/// "connections", "--threads", "no_fly_buffer") when it is out of range: safety and a given
/// no_fly_buffer from 0 to 1000, the others > 0, finite.
void check_plan_options(const PlanOptions& options);

/// The distance every path keeps from the no-fly zones that block: no_fly_buffer, else safety.
inline double zone_keep_distance(const PlanOptions& options) {
  return std::isnan(options.no_fly_buffer) ? options.safety : options.no_fly_buffer;
}

/// A roadmap: nodes and undirected edges in compressed adjacency form, CRS coordinates.
namespace detail {
class PointGrid;
}

/// What a roadmap's queries share once one has made it (the nodes bucketed for the lookups of
/// nearby nodes): made by the first query that needs it, under a lock, so that many queries in
/// parallel over one roadmap (plan_routes(), dsmplan serve) make it once instead of each (1 ms
/// of a 2 ms query on the NRW tile's 14,509 nodes). A copy starts empty. Internal to the queries.
class RoadmapCache {
public:
  RoadmapCache() = default;
  RoadmapCache(const RoadmapCache&) {}
  RoadmapCache& operator=(const RoadmapCache&);
  /// The grid of `nodes` in cubes of `cell`, made now when there is none of that cell and size.
  std::shared_ptr<const detail::PointGrid> node_grid(const std::vector<Point3>& nodes, double cell) const;

private:
  mutable std::mutex mutex_;
  mutable std::shared_ptr<const detail::PointGrid> grid_;
};

struct Roadmap {
  std::vector<Point3> nodes;
  std::vector<uint32_t> start;      ///< node i's neighbours are neighbour[start[i], start[i+1])
  std::vector<uint32_t> neighbour;  ///< ascending per node; each edge listed from both ends
  /// Node i's connected component: the least node number in it (label_components()); or empty,
  /// as in a roadmap made by hand. build_roadmap() and read_roadmap() fill it; a query then gives
  /// up on the roadmap at once for a leg whose ends reach no common component, where A* would
  /// learn it by searching the whole component of one end.
  std::vector<uint32_t> component;
  RoadmapCache cache;  ///< the queries' (not saved; nodes are not changed once a query ran)
  size_t edges() const { return neighbour.size() / 2; }
};

/// Fills map.component from its edges. O(nodes + edges).
void label_components(Roadmap& map);

/// Samples and connects the roadmap of the mesh `index` was built from.
/// Throws ArgumentError ("--safety", "--spacing", "--max-edge", "--max-agl") for a value that
/// is not positive and finite (safety may be 0), 2^31 samples or more ("--spacing"), or 2^32
/// edge listings or more ("--max-edge"); an empty mesh gives an empty roadmap.
/// Time O(samples * neighbours within max_edge * segment_clear), parallel.
Roadmap build_roadmap(const ClearanceIndex& index, const PlanOptions& options, const Progress& progress = {});

/// OMPL-style outcome of a query.
enum class PlanStatus { Solved, NoPath, InvalidWaypoint };

struct PlanResult {
  PlanStatus status = PlanStatus::NoPath;
  std::vector<Point3> path;      ///< Solved: from the first waypoint to the last, smoothed
  std::vector<Point3> raw_path;  ///< Solved: the A* path before smoothing
  size_t waypoint = 0;           ///< InvalidWaypoint: which (0-based); NoPath: the leg's start
  std::string reason;            ///< InvalidWaypoint, NoPath: why, for people, one line
  size_t roadmap_nodes = 0, roadmap_edges = 0;
  double seconds_roadmap = 0, seconds_query = 0, seconds_smooth = 0;
  size_t refined_samples = 0;  ///< samples query-time refinement added (0: the roadmap sufficed)
  int refine_rounds = 0;       ///< refinement rounds run, over all legs
  size_t lattice_nodes = 0;    ///< nodes the refinement's lattice searches made, over all legs
  /// InvalidWaypoint: every waypoint that cannot be flown to, in order, with why (the first is
  /// `waypoint` and `reason`): a user mends them all in one go.
  struct Invalid {
    size_t waypoint = 0;
    std::string reason;
    std::optional<Point3> nearest;  ///< the nearest valid point, when plan_flight() searched and found one
  };
  std::vector<Invalid> invalid;
  /// "waypoint N" or "waypoints N to N+1" (1-based), empty when solved.
  std::string place() const;
  /// `reason`, then every further invalid waypoint as waypoint_problems() lists them.
  std::string problems(const std::function<std::string(size_t)>& name = {}) const;
};

/// How many refused waypoints a line names after the first (waypoint_problems()); the rest are
/// counted. plan_flight() searches the nearest valid point for those named only.
constexpr size_t kListedWaypoints = 10;

/// One line naming every waypoint refused: the first one's reason, then "; also <name(k)>:
/// <reason>" for the others (at most kListedWaypoints, then how many more). `name` (default "waypoint k+1")
/// names a 0-based waypoint as the caller's user numbers them. The planner's refusals and the
/// tools' own checks against the DSM list theirs with it.
std::string waypoint_problems(const std::vector<PlanResult::Invalid>& invalid,
                              const std::function<std::string(size_t)>& name = {});

/// A path through `waypoints` (CRS coordinates, in order) over an existing roadmap built by
/// build_roadmap() from the same index and options: validation, connection, A* per leg, smoothing
/// (see above). Never throws for a bad waypoint or a missing path: the status says which and
/// why ("outside the mesh's extent", "under the surface", "closer than the safety distance";
/// for a leg, no roadmap sample reachable from a waypoint, or no path in the roadmap).
/// Throws ArgumentError("waypoints") for fewer than two or a non-finite one, and for bad
/// options as build_roadmap(). Time O(nodes) once for a grid of the nodes (cubes of max_edge),
/// then O(nodes within max_edge) a waypoint for the connection, A* O(E log V) a leg; a leg the
/// roadmap fails costs the refinement's rounds (see "Refinement" above).
PlanResult query_roadmap(const Roadmap& roadmap, const ClearanceIndex& index, const std::vector<Point3>& waypoints,
                         const PlanOptions& options);

/// build_roadmap() then query_roadmap(): the whole single-query planner. Waypoints are checked
/// first, so a bad one costs no roadmap (roadmap_nodes is 0 then). With options.planner
/// rrt_connect it is plan_rrt_connect() instead (see below).
PlanResult plan_path(const ClearanceIndex& index, const std::vector<Point3>& waypoints, const PlanOptions& options = {},
                     const Progress& progress = {});

// ---- RRT-Connect --------------------------------------------------------------------------
//
// Kuffner & LaValle, "RRT-Connect: An Efficient Approach to Single-Query Path Planning", ICRA
// 2000: for each leg two rapidly-exploring random trees, one rooted at each waypoint. Each
// iteration draws a random sample, EXTENDs one tree one step towards it, then CONNECTs the
// other tree greedily (step after step) towards the new node; the trees swap roles every
// iteration. The leg is the path through both trees once they meet.
//   - Samples: uniform (std::mt19937_64 from options.seed and the leg's number, mapped to
//     [0, 1) by its top 53 bits, so the same on every platform) in the PRM's flight volume: the
//     mesh's x,y bounding box, from the surface up to the ceiling; a sample over a hole
//     (ground() NaN) is skipped and counts towards rrt_max_samples.
//   - Steps: at most max_edge (the range; up to rounding, about 1e-9 m at UTM coordinates)
//     from the tree's nearest node (exact nearest, ties to the older node, by a uniform 3D grid
//     of cells max_edge wide, at least 1/64 of the footprint's longer side); the new node must
//     lie over the mesh, not under its surface, and be point_clear(safety), and the new edge
//     segment_clear(safety) (exact). spacing, connections and threads are the PRM's alone.
//   - Limits: rrt_max_samples samples a leg, then NoPath naming the leg; each CONNECT ends
//     after at most distance / max_edge + 1 steps. Single-threaded (options.threads is not
//     used), deterministic for a fixed seed.
//   - Then detail::finish_path(), the PRM's shortcuts and corner rounding and last check:
//     raw_path is the trees' path, path the smoothed one; every segment clear by safety. A leg
//     between two equal waypoints is that point twice.
//   - PlanResult: roadmap_nodes, roadmap_edges are the nodes and edges of all trees grown,
//     summed over the legs (roots included; a tree of n nodes has n - 1 edges); seconds_roadmap
//     is 0 (there is no roadmap), seconds_query the trees' growth, seconds_smooth finish_path().
// Random trees give longer paths than a dense roadmap after the same smoothing; they need no
// roadmap and find narrow passages a sparse one misses (bench/README.md, "RRT-Connect").
// Errors as plan_path(); ArgumentError("rrt_max_samples") when it is below 1.
// Time per leg O(samples * (nearest search + segment_clear)); the nearest search visits the
// grid's cells around the query until no unvisited cell can hold a nearer node.

/// RRT-Connect through `waypoints` (CRS coordinates, in order), leg by leg; the same
/// validation, statuses, reasons and smoothing as query_roadmap(). NoPath names the leg when
/// its trees did not meet within rrt_max_samples samples.
PlanResult plan_rrt_connect(const ClearanceIndex& index, const std::vector<Point3>& waypoints,
                            const PlanOptions& options = {}, const Progress& progress = {});

/// Length of a polyline, CRS units.
double path_length(const std::vector<Point3>& path);

}  // namespace dsmplan
