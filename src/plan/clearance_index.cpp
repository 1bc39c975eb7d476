// The validity checker's index: a uniform x,y bucket grid over a 2.5D mesh (the uniform grid of
// Ericson, Real-Time Collision Detection, 2005, 7.1) with the highest surface point per bucket,
// the one-level form of the maximum mipmaps of height-field ray casting (Tevs, Ihrke & Seidel,
// I3D 2008), deciding most queries before any triangle is read. Buckets are found by scanning
// the rows the segment's d-neighbourhood crosses, each clipped to its x range (Liang-Barsky,
// Ericson 5.3.3). A bucket lists the triangles whose footprints overlap it (Sutherland-Hodgman
// clipping, Ericson 8.3.4) with the height of the clipped part, highest first, so a query
// reads only the triangles that reach up near the segment.
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <string>

#include "clearance_layout.hpp"
#include "core/huge_pages.hpp"
#include "core/text.hpp"
#include "dsmplan/plan.hpp"

namespace dsmplan {

namespace {

constexpr double lowest = -std::numeric_limits<double>::infinity();

struct ClipPoint {
  double x, y, z;
};

// Highest z of the triangle clipped to the rectangle [x0,x1] x [y0,y1] (closed); -inf when
// they do not overlap. z is linear on the triangle, so its maximum is at a corner of the clip.
double clipped_top(const ClipPoint tri[3], double x0, double x1, double y0, double y1) {
  ClipPoint buf_a[9], buf_b[9];
  ClipPoint* in = buf_a;
  ClipPoint* out = buf_b;
  int n = 3;
  std::copy(tri, tri + 3, in);
  for (int side = 0; side < 4 && n > 0; ++side) {
    // Signed inside-distance of a point from this side of the rectangle.
    auto inside = [&](const ClipPoint& p) {
      switch (side) {
        case 0:
          return p.x - x0;
        case 1:
          return x1 - p.x;
        case 2:
          return p.y - y0;
        default:
          return y1 - p.y;
      }
    };
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const ClipPoint& s = in[i];
      const ClipPoint& e = in[(i + 1) % n];
      const double ds = inside(s), de = inside(e);
      if (ds >= 0) out[m++] = s;
      if ((ds >= 0) != (de >= 0)) {
        const double t = ds / (ds - de);
        out[m++] = {s.x + t * (e.x - s.x), s.y + t * (e.y - s.y), s.z + t * (e.z - s.z)};
      }
    }
    std::swap(in, out);
    n = m;
  }
  double top = lowest;
  for (int i = 0; i < n; ++i) top = std::max(top, in[i].z);
  return top;
}

// Parameter interval of the segment P + t*D, t in [t0, t1], inside the box [lo, hi] (x and y
// only); false when it misses. Liang-Barsky, with the reciprocals of D (0 for an axis the
// segment does not move along) computed once a query.
inline bool clip_xy(double px, double py, double ix, double iy, double xlo, double xhi, double ylo, double yhi,
                    double& t0, double& t1) {
  auto axis = [&](double p, double inv, double lo, double hi) {
    if (inv == 0) return p >= lo && p <= hi;
    double a = (lo - p) * inv, b = (hi - p) * inv;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    return t0 <= t1;
  };
  return axis(px, ix, xlo, xhi) && axis(py, iy, ylo, yhi);
}

// A segment moving less than this along an axis is taken as still along it: the slack of the
// quick rejects is many orders larger.
constexpr double still = 1e-30;

inline float round_up(double v) {
  const float f = static_cast<float>(v);
  return f < v ? std::nextafter(f, INFINITY) : f;
}

// A listing's extent along an axis, in 255ths of the bucket's side (`unit`) from its corner:
// `v` is a bound of the triangle's box less the corner. Outwards by one more than the rounding
// (a decoded bound is a few ulps off the one encoded), and clipped to the bucket, which is all
// the bucket answers for. Casts, not std::floor: a library call each was a tenth of a build.
inline uint8_t extent_below(double v, double unit) {
  const double q = std::clamp(v / unit, -2.0, 257.0);
  return static_cast<uint8_t>(std::clamp(static_cast<int>(q + 2) - 3, 0, 255));  // floor(q) - 1
}
inline uint8_t extent_above(double v, double unit) {
  const double q = std::clamp(v / unit, -2.0, 257.0);
  return static_cast<uint8_t>(std::clamp(static_cast<int>(q + 2), 0, 255));  // floor(q) + 2 >= ceil(q) + 1
}

// A float's bits as a key that sorts the highest first (finite values and infinities).
inline uint32_t highest_first(float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  const uint32_t ascending = bits >> 31 ? ~bits : bits | 0x80000000u;
  return ~ascending;
}

inline int clamp_index(double v, int n) {
  if (!(v > 0)) return 0;
  if (v >= n - 1) return n - 1;
  return static_cast<int>(v);
}

}  // namespace

ClearanceIndex::Layout::Layout(const Mesh& mesh, const ClearanceOptions& options, std::shared_ptr<const Mesh> keep)
    : options_(options) {
  if (!(options.bucket_size >= 0) || !std::isfinite(options.bucket_size))
    throw ArgumentError("bucket_size", "must be a finite number >= 0, not " + short_number(options.bucket_size));
  const size_t nv = mesh.vertices.size();
  // Both scans are parallel reductions; the first offender (lowest number) is named, as a
  // serial scan would name it.
  struct TriangleScan {
    Footprint box;
    size_t bad = SIZE_MAX;  ///< first triangle naming a vertex out of range
  };
  const TriangleScan tri_scan = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, mesh.triangles.size()), TriangleScan{},
      [&](const tbb::blocked_range<size_t>& range, TriangleScan scan) {
        for (size_t t = range.begin(); t != range.end(); ++t) {
          const Triangle& tri = mesh.triangles[t];
          if (tri[0] >= nv || tri[1] >= nv || tri[2] >= nv) {
            scan.bad = std::min(scan.bad, t);
            continue;
          }
          for (uint32_t i : tri) {
            const Vertex& v = mesh.vertices[i];
            scan.box.xmin = std::min(scan.box.xmin, v.x), scan.box.xmax = std::max(scan.box.xmax, v.x);
            scan.box.ymin = std::min(scan.box.ymin, v.y), scan.box.ymax = std::max(scan.box.ymax, v.y);
          }
        }
        return scan;
      },
      [](TriangleScan a, const TriangleScan& b) {
        a.box.xmin = std::min(a.box.xmin, b.box.xmin), a.box.xmax = std::max(a.box.xmax, b.box.xmax);
        a.box.ymin = std::min(a.box.ymin, b.box.ymin), a.box.ymax = std::max(a.box.ymax, b.box.ymax);
        a.bad = std::min(a.bad, b.bad);
        return a;
      });
  if (tri_scan.bad != SIZE_MAX) {
    for (uint32_t i : mesh.triangles[tri_scan.bad])
      if (i >= nv)
        throw ArgumentError("mesh", "triangle " + std::to_string(tri_scan.bad) + " names vertex " + std::to_string(i) +
                                        " of " + std::to_string(nv));
  }
  footprint_ = tri_scan.box;
  if (!mesh.triangles.empty()) {
    footprint_.xmin = std::max(footprint_.xmin, options.flight_area[0]);
    footprint_.ymin = std::max(footprint_.ymin, options.flight_area[1]);
    footprint_.xmax = std::min(footprint_.xmax, options.flight_area[2]);
    footprint_.ymax = std::min(footprint_.ymax, options.flight_area[3]);
  }
  struct VertexScan {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t bad = SIZE_MAX;  ///< first vertex that is not finite
  };
  const VertexScan vertex_scan = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, nv), VertexScan{},
      [&](const tbb::blocked_range<size_t>& range, VertexScan scan) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
          const Vertex& v = mesh.vertices[i];
          if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) {
            scan.bad = std::min(scan.bad, i);
            continue;
          }
          const double c[3] = {v.x, v.y, v.z};
          for (int k = 0; k < 3; ++k) scan.lo[k] = std::min(scan.lo[k], c[k]), scan.hi[k] = std::max(scan.hi[k], c[k]);
        }
        return scan;
      },
      [](VertexScan a, const VertexScan& b) {
        for (int k = 0; k < 3; ++k) a.lo[k] = std::min(a.lo[k], b.lo[k]), a.hi[k] = std::max(a.hi[k], b.hi[k]);
        a.bad = std::min(a.bad, b.bad);
        return a;
      });
  if (vertex_scan.bad != SIZE_MAX)
    throw ArgumentError("mesh", "vertex " + std::to_string(vertex_scan.bad) + " is not finite");
  const double* lo = vertex_scan.lo;
  const double* hi = vertex_scan.hi;
  const std::vector<std::array<uint32_t, 3>>& tris = mesh.triangles;
  triangles_ = tris.size();
  if (tris.empty()) return;
  // Whole units: v - origin is then exact for any coordinate on the CRS's grid.
  for (int k = 0; k < 3; ++k) origin_[k] = std::round(0.5 * (lo[k] + hi[k]));
  static_assert(sizeof(Vertex) == sizeof(LocalVertex) && offsetof(Vertex, z) == offsetof(LocalVertex, z));
  if (keep && keep.get() == &mesh) {
    mesh_ = std::move(keep);
    verts_ = detail::ArrayView<LocalVertex>(reinterpret_cast<const LocalVertex*>(mesh.vertices.data()), nv);
    vertex_shift_ = origin_;
  } else {
    detail::reserve_on_huge_pages(vert_store_, nv);
    vert_store_.resize(nv);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t i = range.begin(); i != range.end(); ++i) {
        const Vertex& v = mesh.vertices[i];
        vert_store_[i] = {v.x - origin_[0], v.y - origin_[1], v.z - origin_[2]};
      }
    });
    verts_ = detail::ArrayView<LocalVertex>(vert_store_);
  }
  zmax_ = hi[2] - origin_[2];
  zmin_ = lo[2] - origin_[2];
  const double wx = hi[0] - lo[0], wy = hi[1] - lo[1];
  const double extent = std::max({1.0, wx, wy, hi[2] - lo[2]});
  // Rounding in the clipping and bounds is ~1e-16 of the coordinates; this is far above it and
  // far below anything a drone cares about.
  margin_ = 1e-9 * (extent + std::abs(origin_[2]));
  cell_ = options.bucket_size > 0 ? options.bucket_size
                                  : std::sqrt(32.0 * std::max(wx * wy, 1e-12) / static_cast<double>(tris.size()));
  if (!(cell_ > 0)) cell_ = 1;
  // Never more buckets than a few per triangle (a long thin mesh), never beyond int range.
  const double max_buckets = std::min(4.0 * static_cast<double>(tris.size()) + 16, 5e8);
  // Bucket borders on the vertex lattice (a grid's cell centres, at a bucket size that is a
  // multiple of the cell) would list every triangle in up to nine buckets once the borders are
  // widened by the margin; shifted by an irrational-looking fraction they fall between.
  constexpr double shift = 0.30901699437494745;
  while ((std::floor(wx / cell_ + shift) + 1) * (std::floor(wy / cell_ + shift) + 1) > max_buckets) cell_ *= 1.5;
  cols_ = static_cast<int>(std::floor(wx / cell_ + shift)) + 1;
  rows_ = static_cast<int>(std::floor(wy / cell_ + shift)) + 1;
  gx0_ = lo[0] - origin_[0] - shift * cell_;
  gy0_ = lo[1] - origin_[1] - shift * cell_;
  const size_t buckets = static_cast<size_t>(cols_) * static_cast<size_t>(rows_);
  // The floor a ceiling counts from without a DSM: a quarter bucket (the mesh's own cell size
  // at the automatic bucket size), coarser only where that would exceed 5e7 cells.
  floor_ = GroundGrid::floor_of(mesh, std::max(cell_ / 4, std::sqrt(std::max(wx * wy, 1e-12) / 5e7)));

  // Pass 1 counts the buckets each triangle's box meets; pass 2 clips the triangle to each of
  // them, keeps the height of its part there (-inf where the box meets the bucket but the
  // triangle misses it) and counts the bucket's listings; pass 3 scatters the listings into
  // their buckets. All three are parallel over triangles; each bucket's order is set by the
  // sort below, so the scatter's order does not matter. Fresh memory is most of what building
  // costs (the kernel zeroes every new page: 45 % of a first plan's time, perf), so what
  // passes 1 and 2 keep is 8 bytes a listing and 4 a triangle: a listing's bucket follows from
  // its triangle's box.
  const size_t nt = tris.size();
  if (nt >= UINT32_MAX) throw ArgumentError("mesh", "has 2^32 or more triangles");
  std::vector<uint32_t> per_tri;
  detail::reserve_on_huge_pages(per_tri, nt + 1);
  per_tri.resize(nt + 1);
  per_tri[0] = 0;
  const double eps = margin_;
  struct Cells {  // of the buckets a triangle's box meets
    int c0, c1, r0, r1;
  };
  auto cells_of = [&](size_t t) {
    double bx0 = INFINITY, bx1 = -INFINITY, by0 = INFINITY, by1 = -INFINITY;
    for (uint32_t i : tris[t]) {
      const LocalVertex v = vertex(i);
      bx0 = std::min(bx0, v.x), bx1 = std::max(bx1, v.x), by0 = std::min(by0, v.y), by1 = std::max(by1, v.y);
    }
    return Cells{clamp_index((bx0 - eps - gx0_) / cell_, cols_), clamp_index((bx1 + eps - gx0_) / cell_, cols_),
                 clamp_index((by0 - eps - gy0_) / cell_, rows_), clamp_index((by1 + eps - gy0_) / cell_, rows_)};
  };
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nt), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t t = range.begin(); t != range.end(); ++t) {
      const Cells b = cells_of(t);
      // At most cols_ * rows_ <= 5e8 each.
      per_tri[t + 1] = static_cast<uint32_t>(size_t(b.c1 - b.c0 + 1) * size_t(b.r1 - b.r0 + 1));
    }
  });
  uint64_t pairs = 0;
  for (size_t t = 0; t < nt; ++t) {
    pairs += per_tri[t + 1];
    if (pairs >= UINT32_MAX) throw ArgumentError("bucket_size", "too small: 2^32 or more bucket listings");
    per_tri[t + 1] = static_cast<uint32_t>(pairs);
  }
  std::vector<float> pair_top;  // rounded up, as the listing keeps it
  detail::reserve_on_huge_pages(pair_top, pairs);
  pair_top.resize(pairs);
  detail::reserve_on_huge_pages(bucket_store_, buckets + 1);
  bucket_store_.assign(buckets + 1, {0, -INFINITY});
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nt), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t t = range.begin(); t != range.end(); ++t) {
      size_t k = per_tri[t];
      const bool one_bucket = per_tri[t + 1] - k == 1;  // then no clipping: the whole triangle is in it
      const Cells b = cells_of(t);
      ClipPoint tri[3];
      double top = lowest;
      for (int i = 0; i < 3; ++i) {
        const LocalVertex v = vertex(tris[t][i]);
        tri[i] = {v.x, v.y, v.z};
        top = std::max(top, v.z);
      }
      for (int r = b.r0; r <= b.r1; ++r)
        for (int c = b.c0; c <= b.c1; ++c, ++k) {
          double z = top;
          if (!one_bucket) {
            const double x0 = gx0_ + c * cell_, y0 = gy0_ + r * cell_;
            z = clipped_top(tri, x0 - eps, x0 + cell_ + eps, y0 - eps, y0 + cell_ + eps);
          }
          pair_top[k] = z > lowest ? round_up(z) : -INFINITY;
          if (z > lowest)
            std::atomic_ref<uint32_t>(bucket_store_[static_cast<size_t>(r) * cols_ + c + 1].start)
                .fetch_add(1, std::memory_order_relaxed);
        }
    }
  });
  for (size_t b = 0; b < buckets; ++b) bucket_store_[b + 1].start += bucket_store_[b].start;
  detail::reserve_on_huge_pages(item_store_, bucket_store_[buckets].start);
  item_store_.resize(bucket_store_[buckets].start);
  detail::reserve_on_huge_pages(extent_store_, bucket_store_[buckets].start);
  extent_store_.resize(bucket_store_[buckets].start);
  const double unit = cell_ / 255;
  std::vector<uint32_t> fill;
  detail::reserve_on_huge_pages(fill, buckets);
  fill.resize(buckets);
  for (size_t b = 0; b < buckets; ++b) fill[b] = bucket_store_[b].start;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nt), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t t = range.begin(); t != range.end(); ++t) {
      const LocalVertex A = vertex(tris[t][0]);
      const LocalVertex B = vertex(tris[t][1]);
      const LocalVertex C = vertex(tris[t][2]);
      const double tx0 = std::min({A.x, B.x, C.x}), tx1 = std::max({A.x, B.x, C.x});
      const double ty0 = std::min({A.y, B.y, C.y}), ty1 = std::max({A.y, B.y, C.y});
      const Cells box = cells_of(t);
      size_t k = per_tri[t];
      for (int r = box.r0; r <= box.r1; ++r)
        for (int c = box.c0; c <= box.c1; ++c, ++k) {
          if (pair_top[k] == -INFINITY) continue;
          const size_t b = static_cast<size_t>(r) * cols_ + c;
          const uint32_t at = std::atomic_ref<uint32_t>(fill[b]).fetch_add(1, std::memory_order_relaxed);
          item_store_[at] = {tris[t], pair_top[k]};
          const double bx = gx0_ + c * cell_, by = gy0_ + r * cell_;
          extent_store_[at] = {extent_below(tx0 - bx, unit), extent_above(tx1 - bx, unit), extent_below(ty0 - by, unit),
                               extent_above(ty1 - by, unit)};
        }
    }
  });
  // Highest first: a query stops reading a bucket at the first triangle that is low enough,
  // so the street under a segment passing beside a roof is never read. Ties by corners, so the
  // order (and a kept index file) does not depend on the scatter's. The listings are sorted by
  // 8-byte keys (the height's bits, highest first, then the listing's place), then each run of
  // one height by corners: the same order as comparing whole listings, for less (the sort of
  // 32-byte listings was 13 % of a first plan's samples).
  tbb::parallel_for(tbb::blocked_range<size_t>(0, buckets), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<uint64_t> keys;
    std::vector<Listing> moved;
    std::vector<Extent> moved_extents;
    for (size_t b = range.begin(); b != range.end(); ++b) {
      Listing* const first = item_store_.data() + bucket_store_[b].start;
      Extent* const first_extent = extent_store_.data() + bucket_store_[b].start;
      const size_t n = bucket_store_[b + 1].start - bucket_store_[b].start;
      if (n > 1) {
        keys.resize(n);
        for (size_t i = 0; i < n; ++i) keys[i] = uint64_t(highest_first(first[i].top)) << 32 | i;
        std::sort(keys.begin(), keys.end());
        moved.assign(first, first + n);
        moved_extents.assign(first_extent, first_extent + n);
        const auto at = [&](uint64_t key) -> const Listing& { return moved[static_cast<uint32_t>(key)]; };
        for (size_t i = 0, j = 1; i < n; i = j, j = i + 1) {
          while (j < n && at(keys[j]).top == at(keys[i]).top) ++j;  // +0 and -0 too, as a comparison has them
          if (j - i > 1)
            std::sort(keys.begin() + i, keys.begin() + j,
                      [&](uint64_t x, uint64_t y) { return at(x).corners < at(y).corners; });
        }
        for (size_t i = 0; i < n; ++i) {
          first[i] = moved[static_cast<uint32_t>(keys[i])];
          first_extent[i] = moved_extents[static_cast<uint32_t>(keys[i])];
        }
      }
      if (n > 0) bucket_store_[b].top = first[0].top;
    }
  });
  // The coarse level of the height pyramid: one small array that stays in cache.
  block_cols_ = (cols_ + block - 1) / block;
  block_rows_ = (rows_ + block - 1) / block;
  block_top_store_.assign(static_cast<size_t>(block_cols_) * block_rows_, -INFINITY);
  for (int r = 0; r < rows_; ++r)
    for (int c = 0; c < cols_; ++c) {
      float& top = block_top_store_[static_cast<size_t>(r / block) * block_cols_ + c / block];
      top = std::max(top, bucket_store_[static_cast<size_t>(r) * cols_ + c].top);
    }
  buckets_ = detail::ArrayView<Bucket>(bucket_store_);
  items_ = detail::ArrayView<Listing>(item_store_);
  extents_ = detail::ArrayView<Extent>(extent_store_);
  block_top_ = detail::ArrayView<float>(block_top_store_);
}

double ClearanceIndex::Layout::highest(int r0, int r1, int c0, int c1) const {
  float top = -INFINITY;
  for (int R = r0 / block; R <= r1 / block; ++R)
    for (int C = c0 / block; C <= c1 / block; ++C) {
      const int br0 = std::max(r0, R * block), br1 = std::min(r1, R * block + block - 1);
      const int bc0 = std::max(c0, C * block), bc1 = std::min(c1, C * block + block - 1);
      const float whole = block_top_[static_cast<size_t>(R) * block_cols_ + C];
      if (whole <= top) continue;
      if (br1 - br0 == block - 1 && bc1 - bc0 == block - 1) {
        top = whole;
        continue;
      }
      for (int r = br0; r <= br1; ++r)
        for (int c = bc0; c <= bc1; ++c) top = std::max(top, buckets_[static_cast<size_t>(r) * cols_ + c].top);
    }
  return top;
}

template <bool Measure>
double ClearanceIndex::Layout::visit(const Point3& p, const Point3& q, double d) const {
  const double px = p[0] - origin_[0], py = p[1] - origin_[1], pz = p[2] - origin_[2];
  const Point3 P{px, py, pz}, Q{q[0] - origin_[0], q[1] - origin_[1], q[2] - origin_[2]};
  const double dx = Q[0] - px, dy = Q[1] - py, dz = Q[2] - pz;
  // The query's own magnitude adds rounding of its own.
  const double slack = margin_ + 1e-12 * std::max({std::abs(px), std::abs(py), std::abs(pz), std::abs(Q[0]),
                                                   std::abs(Q[1]), std::abs(Q[2])});
  // No triangle is farther from p than the farthest corner of the mesh's box; a larger d (or
  // infinity) says no more, and would make the bucket range meaningless.
  const double ex = std::max(std::abs(px - gx0_), std::abs(px - (gx0_ + cols_ * cell_)));
  const double ey = std::max(std::abs(py - gy0_), std::abs(py - (gy0_ + rows_ * cell_)));
  const double ez = std::max(std::abs(pz - zmin_), std::abs(pz - zmax_));
  const double reach_cap = std::sqrt(ex * ex + ey * ey + ez * ez) + 1;
  double best = d;  // Measure: the least distance so far; otherwise the fixed threshold
  const double dmin_z = std::min(pz, Q[2]);
  if (dmin_z - zmax_ >= best + slack) return best;
  const double reach0 = std::min(best, reach_cap) + slack;
  const double ylo = std::min(py, Q[1]) - reach0, yhi = std::max(py, Q[1]) + reach0;
  if (yhi < gy0_ || ylo > gy0_ + rows_ * cell_) return best;
  const int r0 = clamp_index((ylo - gy0_) / cell_, rows_), r1 = clamp_index((yhi - gy0_) / cell_, rows_);
  const double d2_fixed = d * d;
  const double ix = std::abs(dx) < still ? 0 : 1 / dx, iy = std::abs(dy) < still ? 0 : 1 / dy;
  // Triangles already measured: one listed in several buckets near the segment is read once.
  // Direct-mapped, so a collision only costs a second measurement.
  // Keyed by the corners: a triangle listed twice (or the same corners twice) is the same.
  // Cleared at the first triangle read: most queries decide from the heights alone.
  std::array<uint32_t, 3> seen[64];
  bool seen_cleared = false;
  // The rows (band_lo/hi: of buckets or blocks, widened by the reach) give the segment's
  // parameter range within them, Liang-Barsky along y.
  auto band = [&](double band_lo, double band_hi, double& ta, double& tb) {
    ta = 0, tb = 1;
    if (iy == 0) return py >= band_lo && py <= band_hi;
    double a = (band_lo - py) * iy, b = (band_hi - py) * iy;
    if (a > b) std::swap(a, b);
    ta = std::max(ta, a), tb = std::min(tb, b);
    return ta <= tb;
  };
  const double coarse = block * cell_, unit = cell_ / 255;
  for (int R = r0 / block; R <= r1 / block; ++R) {
    double ta, tb;
    const double reach_row = std::min(best, reach_cap) + slack;
    if (!band(gy0_ + R * coarse - reach_row, gy0_ + (R + 1) * coarse + reach_row, ta, tb)) continue;
    const double xa = px + ta * dx, xb = px + tb * dx;
    const double xlo = std::min(xa, xb) - reach_row, xhi = std::max(xa, xb) + reach_row;
    const int C0 = clamp_index((xlo - gx0_) / coarse, block_cols_),
              C1 = clamp_index((xhi - gx0_) / coarse, block_cols_);
    for (int C = C0; C <= C1; ++C) {
      // A block whose highest point is at least the reach below the part of the segment near
      // it holds nothing within reach: its buckets are not read at all.
      const double reach_block = std::min(best, reach_cap) + slack;
      const double bx0 = gx0_ + C * coarse, by0 = gy0_ + R * coarse;
      double s0 = 0, s1 = 1;
      if (!clip_xy(px, py, ix, iy, bx0 - reach_block, bx0 + coarse + reach_block, by0 - reach_block,
                   by0 + coarse + reach_block, s0, s1))
        continue;
      if (std::min(pz + s0 * dz, pz + s1 * dz) - block_top_[static_cast<size_t>(R) * block_cols_ + C] >= reach_block)
        continue;
      for (int r = std::max(r0, R * block); r <= std::min(r1, R * block + block - 1); ++r) {
        const double reach = std::min(best, reach_cap) + slack;
        if (!band(gy0_ + r * cell_ - reach, gy0_ + (r + 1) * cell_ + reach, ta, tb)) continue;
        const double fxa = px + ta * dx, fxb = px + tb * dx;
        const double fxlo = std::min(fxa, fxb) - reach, fxhi = std::max(fxa, fxb) + reach;
        if (fxhi < gx0_ || fxlo > gx0_ + cols_ * cell_) continue;
        const int c0 = std::max(clamp_index((fxlo - gx0_) / cell_, cols_), C * block);
        const int c1 = std::min(clamp_index((fxhi - gx0_) / cell_, cols_), C * block + block - 1);
        for (int c = c0; c <= c1; ++c) {
          const size_t bucket = static_cast<size_t>(r) * cols_ + c;
          const uint32_t begin = buckets_[bucket].start, end = buckets_[bucket + 1].start;
          if (begin == end) continue;
          const double reach_b = std::min(best, reach_cap) + slack;
          const double x0 = gx0_ + c * cell_, y0 = gy0_ + r * cell_;
          double t0 = 0, t1 = 1;
          if (!clip_xy(px, py, ix, iy, x0 - reach_b, x0 + cell_ + reach_b, y0 - reach_b, y0 + cell_ + reach_b, t0, t1))
            continue;
          // z is linear along the segment: its least value on the clipped part is at an end.
          const double zlow = std::min(pz + t0 * dz, pz + t1 * dz);
          if (zlow - buckets_[bucket].top >= reach_b) continue;
          // The listings' extents are an array apart: their first line is asked for now, so its
          // miss overlaps the first listing's instead of following it.
          __builtin_prefetch(extents_.data() + begin);
          for (uint32_t k = begin; k < end; ++k) {
            // The triangle's part in this bucket is what the bucket answers for (a point of it
            // nearest the segment lies in some bucket it is listed in); the rest are lower still.
            if (zlow - items_[k].top >= std::min(best, reach_cap) + slack) break;
            const auto& tri = items_[k].corners;
            const double reach_t = std::min(best, reach_cap) + slack;
            double u0 = 0, u1 = 1;
            const Box box = box_of(k, x0, y0, unit);
            if (!clip_xy(px, py, ix, iy, box.x0 - reach_t, box.x1 + reach_t, box.y0 - reach_t, box.y1 + reach_t, u0,
                         u1))
              continue;
            const LocalVertex A = vertex(tri[0]);
            const LocalVertex B = vertex(tri[1]);
            const LocalVertex C = vertex(tri[2]);
            const double za = pz + u0 * dz, zb = pz + u1 * dz;
            if (std::min(za, zb) - std::max({A.z, B.z, C.z}) >= reach_t) continue;
            // Both ends of the nearby part on one side of the plane, at least d from it.
            const double abx = B.x - A.x, aby = B.y - A.y, abz = B.z - A.z;
            const double acx = C.x - A.x, acy = C.y - A.y, acz = C.z - A.z;
            const double nx = aby * acz - abz * acy, ny = abz * acx - abx * acz, nz = abx * acy - aby * acx;
            const double nn = nx * nx + ny * ny + nz * nz;
            if (nn > 0) {
              const double s0 = nx * (px + u0 * dx - A.x) + ny * (py + u0 * dy - A.y) + nz * (za - A.z);
              const double s1 = nx * (px + u1 * dx - A.x) + ny * (py + u1 * dy - A.y) + nz * (zb - A.z);
              if ((s0 > 0) == (s1 > 0) && s0 != 0 && s1 != 0) {
                const double s = std::min(std::abs(s0), std::abs(s1));
                if (s * s >= reach_t * reach_t * nn) continue;
              }
            }
            // The tests above are of the triangle's part in this bucket (its box is clipped to
            // the bucket), so one that fails here may pass in another: it counts as measured only
            // from here on, where the tests are of the whole triangle.
            if (!seen_cleared) {
              std::fill(std::begin(seen), std::end(seen), std::array<uint32_t, 3>{UINT32_MAX, UINT32_MAX, UINT32_MAX});
              seen_cleared = true;
            }
            const uint32_t slot = (tri[0] ^ (tri[1] * 0x9E3779B1u) ^ (tri[2] * 0x85EBCA77u)) >> 26;
            if (seen[slot] == tri) continue;
            seen[slot] = tri;
            {
              // A ball around the triangle: the segment's distance to its centroid less the
              // farthest corner's is a lower bound, a tenth of the exact distance's cost.
              const double gx = (A.x + B.x + C.x) / 3, gy = (A.y + B.y + C.y) / 3, gz = (A.z + B.z + C.z) / 3;
              auto far2 = [&](const LocalVertex& v) {
                return (v.x - gx) * (v.x - gx) + (v.y - gy) * (v.y - gy) + (v.z - gz) * (v.z - gz);
              };
              const double radius = std::sqrt(std::max({far2(A), far2(B), far2(C)}));
              const double wx = gx - px, wy = gy - py, wz = gz - pz;
              const double along =
                  std::clamp((wx * dx + wy * dy + wz * dz) / std::max(dx * dx + dy * dy + dz * dz, 1e-300), 0.0, 1.0);
              const double ex = wx - along * dx, ey = wy - along * dy, ez = wz - along * dz;
              const double reach_ball = reach_t + radius;
              if (ex * ex + ey * ey + ez * ez >= reach_ball * reach_ball * (1 + 1e-12)) continue;
            }
            const double d2 =
                segment_triangle_squared_distance(P, Q, {A.x, A.y, A.z}, {B.x, B.y, B.z}, {C.x, C.y, C.z});
            if constexpr (Measure) {
              if (d2 < best * best) {
                best = std::sqrt(d2);
                if (best == 0) return 0;
              }
            } else {
              // The distance itself, not its square, is compared: then segment_clear(p, q, d) is
              // exactly clearance(p, q, cap) >= d, touching included.
              if (d2 < d2_fixed * 1.0000000000000004 && std::sqrt(d2) < d) return 0;
            }
          }
        }
      }
    }
  }
  return Measure ? best : 1.0;
}

namespace {
void check_query(const Point3& p, const Point3& q, double d, const char* name) {
  if (!(d >= 0)) throw ArgumentError(name, "must be >= 0, not " + std::to_string(d));
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(p[k]) || !std::isfinite(q[k])) throw ArgumentError("point", "coordinates must be finite");
}
}  // namespace

bool ClearanceIndex::Layout::segment_clear(const Point3& p, const Point3& q, double d) const {
  check_query(p, q, d, "distance");
  if (triangles_ == 0 || d == 0) return true;
  return visit<false>(p, q, d) > 0;
}

double ClearanceIndex::Layout::clearance(const Point3& p, const Point3& q, double max_d) const {
  check_query(p, q, max_d, "max_d");
  if (triangles_ == 0 || max_d == 0) return max_d;
  return visit<true>(p, q, max_d);
}

double ClearanceIndex::Layout::clearance_bound(const Point3& p, double max_d) const {
  if (triangles_ == 0) return max_d;
  const double X = p[0] - origin_[0], Y = p[1] - origin_[1], Z = p[2] - origin_[2];
  // Every mesh point within R of p horizontally lies in a bucket meeting the square of side 2R
  // around it, so no higher than those buckets' highest point H: it is at least min(R, Z - H)
  // away. A smaller square can give a lower H: try R, R/2, R/4.
  double best = 0;
  for (double R = max_d; R > cell_ * 0.5 && best < R; R *= 0.5) {
    const int c0 = clamp_index((X - R - gx0_) / cell_, cols_), c1 = clamp_index((X + R - gx0_) / cell_, cols_);
    const int r0 = clamp_index((Y - R - gy0_) / cell_, rows_), r1 = clamp_index((Y + R - gy0_) / cell_, rows_);
    // The blocks inside the square and those meeting it bound its highest point from below and
    // above, from a few reads of the small block array; the buckets along the square's border
    // are read only when the two bounds leave the answer open.
    float inside = -INFINITY, meeting = -INFINITY;
    for (int br = r0 / block; br <= r1 / block; ++br)
      for (int bc = c0 / block; bc <= c1 / block; ++bc) {
        const float top = block_top_[static_cast<size_t>(br) * block_cols_ + bc];
        meeting = std::max(meeting, top);
        if (br * block >= r0 && br * block + block - 1 <= r1 && bc * block >= c0 && bc * block + block - 1 <= c1)
          inside = std::max(inside, top);
      }
    const double at_most = std::min(R, Z - inside - margin_), at_least = std::min(R, Z - meeting - margin_);
    if (at_most <= best) continue;
    best = std::max(best, at_least < at_most ? std::min(R, Z - highest(r0, r1, c0, c1) - margin_) : at_least);
  }
  return std::min(max_d, best);
}

size_t ClearanceIndex::Layout::bucket_at(double X, double Y) const {
  const double u = (X - gx0_) / cell_, v = (Y - gy0_) / cell_;
  // A point on the grid's far edge (or a rounding hair beyond) belongs to the last bucket.
  const double tol = margin_ / cell_;
  if (!(u >= -tol && u <= cols_ + tol && v >= -tol && v <= rows_ + tol)) return SIZE_MAX;
  return static_cast<size_t>(clamp_index(std::floor(v), rows_)) * cols_ + clamp_index(std::floor(u), cols_);
}

bool ClearanceIndex::Layout::box_holds(const Box& box, double X, double Y) const {
  // The box is rounded outwards; the margin covers ground_in()'s tolerance of the inside test,
  // and bucket_at()'s of a point a rounding hair beyond the bucket.
  return X >= box.x0 - margin_ && X <= box.x1 + margin_ && Y >= box.y0 - margin_ && Y <= box.y1 + margin_;
}

double ClearanceIndex::Layout::ground_in(size_t bucket, double X, double Y) const {
  double top = NAN;
  const int r = static_cast<int>(bucket / cols_), c = static_cast<int>(bucket % cols_);
  for (uint32_t k = buckets_[bucket].start; k < buckets_[bucket + 1].start; ++k) {
    const Listing& item = items_[k];
    // Listed highest first: nothing further down can be higher than what was found.
    if (item.top + origin_[2] < top) break;
    if (!box_holds(box_of(k, r, c), X, Y)) continue;
    const auto& tri = item.corners;
    const LocalVertex A = vertex(tri[0]);
    const LocalVertex B = vertex(tri[1]);
    const LocalVertex C = vertex(tri[2]);
    // Barycentric weights from edge functions relative to A, as certify() does.
    const double du1 = B.x - A.x, dv1 = B.y - A.y, du2 = C.x - A.x, dv2 = C.y - A.y;
    const double area2 = du1 * dv2 - du2 * dv1;
    if (!(std::abs(area2) > 0)) continue;
    const double pu = X - A.x, pv = Y - A.y;
    const double w1 = pu * dv2 - du2 * pv, w2 = du1 * pv - pu * dv1, w0 = area2 - w1 - w2;
    const double tolerance = 1e-9 * std::max(1.0, std::abs(area2));
    const bool inside = area2 > 0 ? (w0 >= -tolerance && w1 >= -tolerance && w2 >= -tolerance)
                                  : (w0 <= tolerance && w1 <= tolerance && w2 <= tolerance);
    if (!inside) continue;
    const double z = (w0 * A.z + w1 * B.z + w2 * C.z) / area2 + origin_[2];
    if (!(z <= top)) top = z;
  }
  return top;
}

double ClearanceIndex::Layout::ground(double x, double y) const {
  if (triangles_ == 0 || !std::isfinite(x) || !std::isfinite(y)) return NAN;
  const double X = x - origin_[0], Y = y - origin_[1];
  const size_t bucket = bucket_at(X, Y);
  return bucket == SIZE_MAX ? NAN : ground_in(bucket, X, Y);
}

void ClearanceIndex::Layout::ground(const double* x, const double* y, double* z, size_t n) const {
  if (triangles_ == 0) {
    std::fill(z, z + n, NAN);
    return;
  }
  // A point's reads depend on each other: its bucket, the bucket's list, the corners of the
  // triangles listed. Each is issued `lag` points ahead of the next, so while one point is
  // computed the reads of the next 3 lag points are under way (software prefetching; scattered
  // points otherwise wait for each miss in turn).
  constexpr size_t lag = 6, ring = 4 * lag;
  size_t bucket[ring];
  auto at = [&](size_t i) -> size_t& { return bucket[i % ring]; };
  for (size_t i = 0; i < n + 3 * lag; ++i) {
    if (i < n) {
      at(i) = std::isfinite(x[i]) && std::isfinite(y[i]) ? bucket_at(x[i] - origin_[0], y[i] - origin_[1]) : SIZE_MAX;
      if (at(i) != SIZE_MAX) __builtin_prefetch(&buckets_[at(i)]);
    }
    if (i >= lag && i - lag < n && at(i - lag) != SIZE_MAX) {
      // The first sixteen listings (four lines): about the part a point in a street scans, past the
      // roofs listed before it (more ties up the memory system for no gain: bench/plan_ompl).
      const char* first = reinterpret_cast<const char*>(items_.data() + buckets_[at(i - lag)].start);
      const char* last = reinterpret_cast<const char*>(items_.data() + buckets_[at(i - lag) + 1].start);
      for (int line = 0; line < 4 && first + 64 * line < last; ++line) __builtin_prefetch(first + 64 * line);
      __builtin_prefetch(extents_.data() + buckets_[at(i - lag)].start);  // their 16 extents
    }
    if (i >= 2 * lag && i - 2 * lag < n && at(i - 2 * lag) != SIZE_MAX) {
      // The corners of the first triangles whose boxes hold the point: usually the answer.
      const size_t j = i - 2 * lag, b = at(j);
      const double X = x[j] - origin_[0], Y = y[j] - origin_[1];
      int found = 0;
      const int r = static_cast<int>(b / cols_), c = static_cast<int>(b % cols_);
      for (uint32_t k = buckets_[b].start; k < buckets_[b + 1].start && found < 2; ++k) {
        const Listing& item = items_[k];
        if (!box_holds(box_of(k, r, c), X, Y)) continue;
        for (uint32_t v : item.corners) __builtin_prefetch(&verts_[v]);
        ++found;
      }
    }
    if (i >= 3 * lag) {
      const size_t j = i - 3 * lag;
      z[j] = at(j) == SIZE_MAX ? NAN : ground_in(at(j), x[j] - origin_[0], y[j] - origin_[1]);
    }
  }
}

}  // namespace dsmplan

namespace dsmplan {

ClearanceIndex::ClearanceIndex(const Mesh& mesh, const ClearanceOptions& options)
    : layout_(std::make_shared<const Layout>(mesh, options)) {}
ClearanceIndex::ClearanceIndex(std::shared_ptr<const Mesh> mesh, const ClearanceOptions& options) {
  if (!mesh) throw ArgumentError("mesh", "is null");
  const Mesh& m = *mesh;
  layout_ = std::make_shared<const Layout>(m, options, std::move(mesh));
}
bool ClearanceIndex::segment_clear(const Point3& p, const Point3& q, double d) const {
  return layout_->segment_clear(p, q, d);
}
double ClearanceIndex::clearance(const Point3& p, const Point3& q, double max_d) const {
  return layout_->clearance(p, q, max_d);
}
double ClearanceIndex::clearance_bound(const Point3& p, double max_d) const {
  return layout_->clearance_bound(p, max_d);
}
double ClearanceIndex::ground(double x, double y) const { return layout_->ground(x, y); }
void ClearanceIndex::ground(const double* x, const double* y, double* z, size_t n) const {
  layout_->ground(x, y, z, n);
}
const ClearanceIndex::Footprint& ClearanceIndex::footprint() const { return layout_->footprint_; }
const Point3& ClearanceIndex::origin() const { return layout_->origin_; }
double ClearanceIndex::lowest_vertex() const { return layout_->zmin_ + layout_->origin_[2]; }
double ClearanceIndex::highest_vertex() const { return layout_->zmax_ + layout_->origin_[2]; }
double ClearanceIndex::bucket_size() const { return layout_->cell_; }
int ClearanceIndex::bucket_columns() const { return layout_->cols_; }
int ClearanceIndex::bucket_rows() const { return layout_->rows_; }
size_t ClearanceIndex::triangles() const { return layout_->triangles_; }
const GroundGrid& ClearanceIndex::floor() const { return layout_->floor_; }
size_t ClearanceIndex::bucket_listings() const { return layout_->items_.size(); }
size_t ClearanceIndex::memory_bytes() const {
  const Layout& l = *layout_;
  return l.verts_.size() * sizeof(Layout::LocalVertex) +
         l.items_.size() * (sizeof(Layout::Listing) + sizeof(Layout::Extent)) +
         l.buckets_.size() * sizeof(Layout::Bucket) + l.block_top_.size() * sizeof(float) +
         l.floor_.grid().z.capacity() * sizeof(float);
}

}  // namespace dsmplan
