// dsmplan/plan.hpp: stage 4, paths for a drone over the obstacle mesh (Adolf & Hirschmueller,
// Section 5: sampling-based planning on the polygonal surface with a 2 m safety distance).
//
// As OMPL separates them, the planner has three parts: the planner (roadmap, search), the
// validity checker (is a state, is a straight motion, at least the safety distance away from
// every triangle?) and the path simplifier. This header holds the validity checker, the part
// every other one relies on to be exactly right.
//
// ---- clearance ---------------------------------------------------------------------------
//
// Distances are Euclidean in 3D, in CRS units; they assume the vertical unit equals the
// horizontal one (metres for every dataset dsmplan ships with; not so for a geographic CRS).
//
// segment_triangle_distance(): the exact distance between a closed segment and a closed
// triangle (Ericson, Real-Time Collision Detection, 2005, ch. 5; Eberly, "Distance Between
// Segment and Triangle", Geometric Tools). Not a sample: when they do not intersect, the
// closest pair has an endpoint of the segment or a point on an edge of the triangle, so the
// distance is the least of two point-triangle and three segment-segment distances, each in
// closed form. Degenerate input is handled: a segment whose ends coincide is a point; a
// triangle of zero area (collinear or coincident corners) is the union of its edges. Exact up
// to floating-point rounding (about 1e-15 of the coordinates' magnitude): subtract a nearby
// origin from CRS coordinates first (ClearanceIndex does), a UTM northing is about 5.7e6.
//
// ClearanceIndex: a mesh made ready for many queries.
//   - Coordinates are stored relative to origin(), the centre of the mesh's bounding box
//     rounded to whole units, so the subtraction is exact for every vertex and query point on
//     the CRS's own grid, and the arithmetic works on numbers of about the mesh's size.
//   - segment_clear(p, q, d) is true iff every point of the segment is at distance >= d from
//     every triangle (touching at exactly d is clear): the distance compared is the one
//     clearance() returns, so segment_clear(p, q, d) == (clearance(p, q, m) >= d) for m >= d,
//     to the last bit. It decides with the exact distance of
//     every triangle it cannot rule out by a bound that is itself conservative (every quick
//     reject keeps a margin of 1e-9 of the mesh's size), so it agrees with brute force over all
//     triangles (tests/plan_test.cpp: zero disagreements on thousands of random segments).
//   - Acceleration: a uniform x,y grid of square buckets. A triangle is listed in every bucket
//     its x,y footprint overlaps (exact clipping, not its bounding box) with the highest point
//     of its part inside the bucket, highest first, and each bucket keeps the highest point of
//     the mesh inside it (clipped too, so a big sloped triangle of a simplified mesh does not
//     raise its neighbours' buckets). Blocks of 4 x 4 buckets keep the highest point of their
//     buckets: a two-level maximum pyramid (Tevs, Ihrke & Seidel, "Maximum mipmaps for fast,
//     accurate, and scalable dynamic height field rendering", I3D 2008), small enough to stay
//     in cache. A query visits only the blocks within d of the segment's x,y projection, row
//     by row, and skips a block, unread, whose highest point is at least d below the part of
//     the segment passing within d of it; in the others it does the same bucket by bucket,
//     and stops reading a bucket's list at the
//     first triangle that low, so the street under a segment beside a roof is never read. A
//     triangle left is then skipped by its x,y box, its height and its plane (both ends of the
//     nearby part of the segment at least d on one side), and only then measured exactly; one
//     listed in several buckets is measured once.
//     Why not a BVH: the mesh is 2.5D, so a column of the grid holds one sheet of surface and
//     its height bound is tight, whereas the boxes of a hierarchy around walls are tall and
//     overlap every segment passing beside them. Measured by bench/plan_collision.cpp on the
//     NRW 1 m tile (1,996,002 triangles, one thread of the 2-core machine), random 20-35 m
//     segments with both ends 2-120 m above ground, d = 2 m, segment_clear() per second:
//                                         build    2-120 m   2-10 m   10-30 m   30-120 m
//       this index (4 m buckets)          0.56 s   4.7 M     0.43 M   2.6 M     22.7 M
//       BVH (median split, 4 a leaf)      1.43 s   1.3 M     0.12 M   0.69 M    14.7 M
//       brute force (all triangles)       -        6.0 a second
//     (97 % of those segments are clear, 44 % of the 2-10 m ones; the BVH and brute force
//     agree with the index on every one.) Two threads (TBB): 8.5 M/s, 0.79 M/s at 2-10 m.
//     The blocks took the 30-120 m band from 12.9 M to 23 M a second; each triangle's ball
//     (centroid, farthest corner), tested before its exact distance, the rest of the gain.
//   - Bucket size: by default sqrt(32 * footprint area / triangles), 32 triangles a bucket on
//     average (4 m at 1 m cells: 1.54 listings a triangle). The benchmark's sweep: 1 m buckets
//     are 25 % slower over all heights (3.7 listings a triangle); 2-8 m stay within 10 % of the
//     best on every band; 16 m loses 30 % near the ground.
//     ClearanceOptions::bucket_size overrides it (enlarged when it would make more than four
//     buckets a triangle).
//   - Thread-safe: every query is const and allocates nothing; share one index among threads.
//   - Memory (memory_bytes()): 24 bytes a vertex, 32 a listing (it carries its triangle's
//     corners, so a query reads the vertices without a second miss), 8 a bucket; the mesh's
//     own triangle list is not kept: 123 MB for the NRW tile at 1 m.
//
// Errors: ArgumentError for a negative or NaN distance, a non-finite query point, or a mesh
// with a triangle index out of range or a non-finite vertex. See core.hpp.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/ground.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/simplify.hpp"

namespace dsmplan {

/// Exact distance between the segment [p, q] and the triangle (a, b, c); 0 when they touch or
/// intersect. See the top of this header. O(1).
double segment_triangle_distance(const Point3& p, const Point3& q, const Point3& a, const Point3& b, const Point3& c);

/// The square of segment_triangle_distance(), without the square root (what comparisons with a
/// squared threshold need).
double segment_triangle_squared_distance(const Point3& p, const Point3& q, const Point3& a, const Point3& b,
                                         const Point3& c);

struct ClearanceOptions {
  /// Side of a bucket of the x,y grid, CRS units; 0 = automatic (about 32 triangles a bucket).
  double bucket_size = 0;
  /// xmin, ymin, xmax, ymax (CRS units): footprint(), the planners' flight area, is clipped to
  /// it, while every triangle still counts as an obstacle. The corridor planner meshes a margin
  /// around the area it flies in, so nothing beyond a window's edge can come unseen within the
  /// safety distance. Default: no clipping.
  std::array<double, 4> flight_area{-INFINITY, -INFINITY, INFINITY, INFINITY};
};

class ClearanceIndex {
public:
  /// Builds the index of `mesh` (any triangle soup; 2.5D meshes are what it is fast for).
  /// Throws ArgumentError for an index out of range, a non-finite vertex, a bad bucket_size, or
  /// 2^32 or more triangles or bucket listings.
  /// Time O(triangles + buckets) (parallel), memory see the top of this header.
  explicit ClearanceIndex(const Mesh& mesh, const ClearanceOptions& options = {});

  /// True iff `p` is at distance >= d from every triangle.
  bool point_clear(const Point3& p, double d) const { return segment_clear(p, p, d); }

  /// True iff the segment [p, q] keeps distance >= d from every triangle (exact, no sampling).
  /// Throws ArgumentError when d < 0 or NaN, or p, q are not finite. An empty mesh is clear.
  /// Time O(buckets within d of the segment + triangles in those that the height bound keeps).
  bool segment_clear(const Point3& p, const Point3& q, double d) const;

  /// min(max_d, distance from the segment [p, q] to the mesh): the exact distance when it is
  /// below max_d. Same errors and cost as segment_clear(p, q, max_d).
  double clearance(const Point3& p, const Point3& q, double max_d) const;

  /// A lower bound of the clearance of point p, at most max_d, from the buckets' highest points
  /// alone (no triangle is read): min(R, p.z - the highest point within R horizontally),
  /// the best of R = max_d, max_d/2, max_d/4; 0 when p is not above everything near it.
  /// O((max_d / bucket_size)^2 / 16 + max_d / bucket_size): whole blocks read at once. The
  /// roadmap uses it to certify edges without checking them.
  double clearance_bound(const Point3& p, double max_d) const;

  /// The mesh's height at (x, y): the highest triangle whose x,y footprint contains the point
  /// (on a shared edge the neighbours agree), interpolated linearly; NaN where no triangle
  /// covers it. O(triangles in one bucket).
  double ground(double x, double y) const;

  /// ground() of n points: z[i] = ground(x[i], y[i]), the same answers. For many scattered
  /// points it is several times faster: the memory reads of later points are issued while
  /// earlier ones are computed (software prefetching), so their latencies overlap.
  void ground(const double* x, const double* y, double* z, size_t n) const;

  /// The x,y bounding box of the triangles' vertices, in CRS coordinates (lone vertices left
  /// out), clipped to ClearanceOptions::flight_area; empty (min > max) for a mesh without
  /// triangles.
  struct Footprint {
    double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY;
  };
  const Footprint& footprint() const { return footprint_; }
  const Point3& origin() const { return origin_; }  ///< CRS point subtracted from all coordinates
  double bucket_size() const { return cell_; }
  int bucket_columns() const { return cols_; }
  int bucket_rows() const { return rows_; }
  size_t triangles() const { return triangles_; }
  /// The mesh's floor (GroundGrid::floor_of() on cells of a quarter bucket): the ground a
  /// ceiling counts from when a plan has no DSM or DTM.
  const GroundGrid& floor() const { return floor_; }
  size_t bucket_listings() const { return items_.size(); }  ///< sum of triangles over buckets
  /// Bytes the index holds: its vertices, listings, buckets and blocks.
  size_t memory_bytes() const {
    return verts_.capacity() * sizeof(LocalVertex) + items_.capacity() * sizeof(Listing) +
           buckets_.capacity() * sizeof(Bucket) + block_top_.capacity() * sizeof(float) +
           floor_.grid().z.capacity() * sizeof(float);
  }

private:
  struct LocalVertex {
    double x, y, z;
  };
  size_t bucket_at(double X, double Y) const;  ///< of a local point; SIZE_MAX outside the grid
  double ground_in(size_t bucket, double X, double Y) const;
  template <bool Measure>
  double visit(const Point3& p, const Point3& q, double d) const;

  Point3 origin_{0, 0, 0};
  Footprint footprint_;
  std::vector<LocalVertex> verts_;
  size_t triangles_ = 0;
  double cell_ = 1, gx0_ = 0, gy0_ = 0;  ///< bucket (0,0) starts at local (gx0_, gy0_)
  int cols_ = 0, rows_ = 0;
  struct Listing {
    std::array<uint32_t, 3> corners;  ///< the triangle's vertices: no second read to find them
    float top;             ///< highest point of the triangle inside the bucket, rounded up
    float x0, x1, y0, y1;  ///< the triangle's x,y bounding box, rounded outwards
  };
  struct Bucket {
    uint32_t start;  ///< bucket b lists items_[start of b, start of b + 1), highest first
    float top;       ///< highest mesh point in the bucket, rounded up (-inf when empty)
  };
  std::vector<Bucket> buckets_;  ///< one more than there are buckets, for the last one's end
  std::vector<Listing> items_;
  bool box_holds(const Listing& item, double X, double Y) const;  ///< local point in its x,y box
  static constexpr int block = 4;  ///< buckets a side of a block, the pyramid's coarse level
  int block_cols_ = 0, block_rows_ = 0;
  std::vector<float> block_top_;  ///< highest point of each block of block x block buckets
  /// The highest point in buckets [r0, r1] x [c0, c1], whole blocks read from block_top_.
  double highest(int r0, int r1, int c0, int c1) const;
  double zmin_ = 0, zmax_ = 0;  ///< lowest and highest vertex
  GroundGrid floor_;
  double margin_ = 0;           ///< conservative slack of the quick rejects
};

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
//     src/plan/path_parts.hpp): a straight motion is valid when it keeps `safety` from every
//     triangle and no point of it is higher than max_agl above the ground (measured exactly,
//     GroundGrid::below_ceiling()). So the ceiling holds for every edge, connection, shortcut
//     and spline chord, not only for the samples.
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
// Measured on the NRW 1 m tile (1,996,002 triangles, 2 cores), defaults, 3 waypoints 30 m above
// the ground at opposite corners and the middle: 14,510 samples kept, 124,018 edges, roadmap
// 0.020 s, a 3-leg query 0.0023 s (bench_plan_ompl), smoothing < 0.1 ms (reading the PLY and
// indexing it: 1.1 s).

/// Which planner plan_path() runs: the paper's roadmap (multi-query, see above) or RRT-Connect
/// (single-query, see plan_rrt_connect() below).
enum class PlannerKind { prm, rrt_connect };

struct PlanOptions {
  PlannerKind planner = PlannerKind::prm;  ///< what plan_path() runs
  double safety = 2;       ///< least distance to the mesh, CRS units (the paper's 2 m)
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
  /// The ground max_agl counts from (ground.hpp): the DTM, or the DSM's cells; null: the
  /// mesh's floor (ClearanceIndex::floor()). Every point of every path keeps
  /// height above it <= max_agl, not only the samples.
  std::shared_ptr<const GroundGrid> ground;
};

/// Throws ArgumentError naming the option ("--safety", "--spacing", "--max-edge", "--max-agl",
/// "connections", "--threads") when it is out of range: safety >= 0, the others > 0, finite.
void check_plan_options(const PlanOptions& options);

/// A roadmap: nodes and undirected edges in compressed adjacency form, CRS coordinates.
struct Roadmap {
  std::vector<Point3> nodes;
  std::vector<uint32_t> start;      ///< node i's neighbours are neighbour[start[i], start[i+1])
  std::vector<uint32_t> neighbour;  ///< ascending per node; each edge listed from both ends
  size_t edges() const { return neighbour.size() / 2; }
};

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
  /// "waypoint N" or "waypoints N to N+1" (1-based), empty when solved.
  std::string place() const;
};

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

// ---- clearance to the raw DSM ------------------------------------------------------------

/// min(max_d, the distance from the segment [p, q] to the DSM taken as solid columns): every
/// valid cell is a box over its square from -infinity up to its height; nodata cells are empty
/// air. Exact (the segment-box distance is minimised in closed form on each piece where the
/// segment enters or leaves a slab). An independent check of a path planned on a mesh: the
/// columns stand up to half a cell beyond the mesh's vertices at the cell centres, so over a
/// wall this distance can be below the mesh clearance by up to half a cell diagonal.
/// Throws ArgumentError for a non-finite point or max_d < 0.
/// Time O(cells within the distance found of the segment's box; doubling search from 2 cells).
double column_clearance(const Grid& dsm, const Point3& p, const Point3& q, double max_d);

// ---- holding a mesh plan to the DSM's columns ---------------------------------------------
//
// With the DSM known, dsmplan guarantees more than clearance to its mesh: every point of the
// path keeps `safety` from the DSM's columns themselves, at any cell size and with nothing
// subtracted. `columns` is the DSM with its holes filled from their rim (fill_holes_from_rim(),
// RimHeight::highest): unknown space is as high as the highest cell around it, so no path
// passes through a hole lower than the hole's rim. The planner is run on the mesh plus
// hole_columns() (exact boxes) with the safety distance widened by column_margin() (of the
// valid cells), and the written path is
// measured against the columns with column_clearance() (src/tools/plan_path.cpp).
// Without a DSM (`plan MESH` alone) the guarantee is the mesh's: clearance to its triangles.

/// The widening of the safety distance on `mesh` under which clearance to the mesh bounds
/// clearance to the columns of `dsm`'s valid cells (its holes are hole_columns()' part): the
/// smaller of the most a column rises above the mesh (certify_columns(); only when the mesh
/// covers every column) and sqrt((cell diagonal / 2)^2 + E^2) with E the mesh's certified depth
/// below the cell centres. 0.71 m for a conservative mesh of a 1 m DSM. O(cells + triangles x
/// edge length in cells). The two measurements it rests on go to `columns_above` and
/// `below_centres` when they are not null.
double column_margin(const Mesh& mesh, const Grid& dsm, ColumnError* columns_above = nullptr,
                     VerticalError* below_centres = nullptr);

/// The columns of the cells that are nodata in `dsm` but have a height in `columns` (its holes
/// filled), as triangles in `dsm`'s CRS: each cell's top, and walls down to 1 m below the
/// lowest column on the sides that face no other such cell. Empty when `dsm` has no hole. O(cells).
Mesh hole_columns(const Grid& dsm, const Grid& columns);

// ---- a tiled city: planning along a corridor ---------------------------------------------
//
// A DSM too large to mesh whole (a VRT mosaic of a city) is planned over piece by piece, never
// holding more than two windows of it. Every leg is cut into pieces of at most `chunk` (x,y);
// a piece flies inside the x,y box of its two ends widened by `margin`, over the conservative
// bounded mesh (simplify_bounded(), conservative, max_error) of that box widened again by
// safety + 2 cells, so that every obstacle within the safety distance of the flight area is in
// the window. The point where two pieces meet (a "via" point, on the straight line of the leg)
// is put at the lowest height, in whole metres above safety over the higher of the two
// windows' surfaces, that keeps the safety distance from both windows' meshes and stays under
// max_agl; the path passes through it. Each piece is planned by plan_path() on its window and
// measured there: clearance to the window's mesh, and to the window's DSM columns
// (column_clearance()). Rectangular windows keep every straight segment of a piece over known
// ground. Memory: two windows, O((chunk + 2 margin)^2 cells) whatever the city's size.

struct CorridorOptions {
  BoundedSimplifyOptions mesh;  ///< the windows' meshes; conservative is forced on
  double chunk = 1000;          ///< longest piece of a leg planned in one window (x,y), CRS units
  double margin = 150;          ///< flight area around a piece's x,y box, CRS units
  /// Applied to each piece's path before it is measured and joined (the tool drops the points
  /// on straight runs for missions); empty: none.
  std::function<std::vector<Point3>(const std::vector<Point3>&)> finish_piece;
  /// The ground --max-agl counts from (a DTM); null: each window's DSM cells.
  std::shared_ptr<const GroundGrid> terrain;
};

struct CorridorResult {
  PlanResult plan;                ///< the path through all waypoints; status, place and reason as plan_path()
  size_t windows = 0;             ///< pieces planned (one window each)
  size_t largest_window_cells = 0;
  VerticalError mesh_error;       ///< the windows' meshes against the DSM, merged (certified per tile)
  double min_clearance_m = 0;     ///< least clearance of the path to its windows' meshes
  double min_clearance_dsm_m = 0; ///< least clearance to the DSM columns (holes as high as their rim)
  double max_agl_m = -INFINITY;   ///< greatest height of the path above the ground (exact)
  double safety_margin_m = 0;     ///< the largest widening of the safety distance on a window's mesh (column_margin())
  double seconds_windows = 0;     ///< reading and meshing the windows
};

/// Plans through `waypoints` (CRS coordinates) over `dsm` along a corridor (see above). Throws
/// ArgumentError for bad options (chunk or margin <= 0) and what simplify_bounded() throws for
/// a window; a waypoint outside the DSM or no safe via point gives status InvalidWaypoint/NoPath
/// with the place and the reason, like plan_path().
CorridorResult plan_corridor(GridSource& dsm, const std::vector<Point3>& waypoints, const PlanOptions& plan,
                             const CorridorOptions& options, const Progress& progress = {});

// ---- multi-query: the roadmap file ---------------------------------------------------------
//
// A roadmap is built once and queried many times (Kavraki et al. 1996). write_roadmap() keeps
// it with what it depends on: the mesh's fingerprint and the four options that shape it
// (safety, spacing, max_edge, max_agl); read_roadmap() gives it back only when all of them are
// what this run uses, so a roadmap is never used on a mesh or with a safety distance it was not
// checked against. The format is dsmplan's own (src/plan/roadmap_file.cpp), 28 bytes a node
// and 8 an edge, with a checksum; a file from a machine of the other byte order is refused.

/// A 64-bit hash of the mesh's vertices (their exact bits) and triangles. O(mesh).
uint64_t mesh_fingerprint(const Mesh& mesh);

/// Writes `map` atomically (the whole file or nothing). OutputError when it cannot.
void write_roadmap(const std::string& path, const Roadmap& map, uint64_t mesh_fingerprint,
                   const PlanOptions& options);

/// Reads a roadmap written by write_roadmap(). InputError(path, place, why) when the file
/// cannot be read, is not a roadmap file, is truncated or damaged (checksum), declares counts
/// that do not fit its size, has an edge to a node that does not exist, was built for another
/// mesh ("built for another mesh") or with other options ("was built with --spacing 20, this
/// run asks for 15"). O(file size).
Roadmap read_roadmap(const std::string& path, uint64_t mesh_fingerprint, const PlanOptions& options);

/// What a roadmap file says it was built for.
struct RoadmapHeader {
  uint64_t mesh_fingerprint = 0;
  double safety = 0, spacing = 0, max_edge = 0, max_agl = 0;
};

/// Reads a roadmap file without asking what it was built for (to draw it, say); the same checks
/// of the file itself as above. `header` (may be null) receives what it was built for.
Roadmap read_roadmap(const std::string& path, RoadmapHeader* header);

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
// Measured on the NRW 1 m tile (1,996,002 triangles, one thread), 3 waypoints 10 m above the
// surface at the south-west corner, the middle and the north-east corner, defaults but
// max_agl 30, seeds 1-5: trees of 71-101 nodes grown in 2-7 ms, paths of 1308-1498 m (the PRM:
// 3,296 samples, roadmap 0.07-0.12 s, 1292 m). With max_agl 15 every seed found a path
// (1383-1523 m, 2-16 ms) where the PRM needs spacing 12 (0.35 s, 1291 m). Random trees give
// longer paths than a dense roadmap after the same smoothing; they need no roadmap and find
// narrow passages a sparse one misses. A leg it cannot fly costs about 13 us a sample there
// (the 20,000 of the default: 0.2-0.5 s, 6,000-9,000 nodes).
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
