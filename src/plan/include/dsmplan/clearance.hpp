// dsmplan/clearance.hpp: stage 4's validity checker, the part every planner relies on to be
// exactly right: is a point, is a straight motion, at least the safety distance away from
// every triangle of the obstacle mesh? (Adolf & Hirschmueller, Section 5: a 2 m safety distance.)
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
//     overlap every segment passing beside them (bench/plan_collision.cpp; its figures are in
//     bench/README.md, "Clearance queries").
//   - Bucket size: by default sqrt(32 * footprint area / triangles), 32 triangles a bucket on
//     average (4 m at 1 m cells); 2-8 m buckets stay within 10 % of the best (bench/README.md).
//     ClearanceOptions::bucket_size overrides it (enlarged when it would make more than four
//     buckets a triangle).
//   - Thread-safe: every query is const and allocates nothing; share one index among threads.
//   - Memory (memory_bytes()): 24 bytes a vertex (the mesh's own, when the index holds it), 20
//     a listing (16 with its triangle's corners, so a query reads the vertices without a second
//     miss, and 4 of where the triangle lies in the bucket), 8 a bucket; the mesh's own triangle
//     list is not kept: 88 MB for the NRW tile at 1 m.
//   - Kept in a file (save(), open()): building is most of what loading a mesh for planning
//     costs (0.2 s of 0.33 s at 1 m), so the index can be saved and mapped back by later runs
//     over the same mesh: opened in about 0.02 s, answering every query as the saved index did.
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
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/ground.hpp"
#include "dsmplan/mesh.hpp"

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
  /// The same index of a mesh the index then holds, reading its vertices where they lie rather
  /// than copying them (24 bytes a vertex less to build; the same answers). ArgumentError("mesh")
  /// for a null pointer, else as above.
  explicit ClearanceIndex(std::shared_ptr<const Mesh> mesh, const ClearanceOptions& options = {});

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
  const Footprint& footprint() const;
  const Point3& origin() const;  ///< CRS point subtracted from all coordinates
  /// The lowest and the highest z of the mesh's vertices (lone ones too), CRS units; 0 without triangles.
  double lowest_vertex() const;
  double highest_vertex() const;
  double bucket_size() const;
  int bucket_columns() const;
  int bucket_rows() const;
  size_t triangles() const;
  /// The mesh's floor (GroundGrid::floor_of() on cells of a quarter bucket): the ground a
  /// ceiling counts from when a plan has no DSM or DTM.
  const GroundGrid& floor() const;
  size_t bucket_listings() const;  ///< sum of triangles over buckets
  /// Bytes the index holds: its vertices, listings, buckets and blocks (mapped from a file or not).
  size_t memory_bytes() const;

  // ---- kept in a file (src/plan/clearance_index_file.cpp) ----------------------------------
  /// What an index file was built from, in its writer's words: hashes the caller computed
  /// (dsmplan plan: the mesh file's bytes, mixed with the DSM's when its holes' columns joined
  /// the mesh; and mesh_fingerprint(), which its roadmap files are keyed by), so that a later run
  /// can tell whether the file still fits without reading the mesh.
  struct Source {
    uint64_t input_hash = 0;
    uint64_t mesh_fingerprint = 0;
  };
  /// Writes the index, `source` and the options it was built with to `path`, atomically (the
  /// whole file or nothing); about the size of memory_bytes(). dsmplan's own format, in this
  /// machine's byte order, with a checksum. OutputError when it cannot be written. O(size).
  void save(const std::string& path, const Source& source) const;
  /// Opens an index file written by save(), mapped, not read: its arrays are used where the page
  /// cache holds them, so a second run over the same mesh skips the build (bench/README.md).
  /// The answers are those of the index that was saved, to the bit. std::nullopt when the file
  /// was built from another input (input_hash differs), with other options, or is of another
  /// format version or byte order: build it anew. InputError(path, place, why) when it is not an
  /// index file, is truncated or damaged (checksum), or its arrays do not fit each other.
  /// `source` (may be null) receives what the file says it was built from (zeros for another
  /// format), whatever the outcome short of an error. O(file size): the checksum and the arrays'
  /// structure are checked, in one pass.
  static std::optional<ClearanceIndex> open(const std::string& path, uint64_t input_hash,
                                            const ClearanceOptions& options = {}, Source* source = nullptr);

private:
  struct Layout;                          ///< the vertices, buckets, listings and blocks: src/plan/clearance_index.cpp
  std::shared_ptr<const Layout> layout_;  ///< immutable once built, so copies share it
  explicit ClearanceIndex(std::shared_ptr<const Layout> layout);
};

}  // namespace dsmplan
