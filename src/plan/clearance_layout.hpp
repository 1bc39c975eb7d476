// The clearance index's layout, private to the plan module: clearance_index.cpp builds and
// queries it, clearance_index_file.cpp keeps it in a file and maps it back. Its arrays are
// views: of vectors it owns when it was built, of a file's mapping when it was opened, so an
// index opened from a file is used where it lies, without a copy (see clearance.hpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "dsmplan/clearance.hpp"

namespace dsmplan {

namespace detail {
/// A read-only array somebody else holds: a vector of the layout's, or a mapped file's section.
template <class T>
struct ArrayView {
  const T* data_ = nullptr;
  size_t size_ = 0;
  ArrayView() = default;
  explicit ArrayView(const std::vector<T>& v) : data_(v.data()), size_(v.size()) {}
  ArrayView(const T* data, size_t size) : data_(data), size_(size) {}
  const T& operator[](size_t i) const { return data_[i]; }
  const T* data() const { return data_; }
  size_t size() const { return size_; }
};
}  // namespace detail

struct ClearanceIndex::Layout {
  /// `keep`: the same mesh, held by the caller; its vertices are then read where they lie (in
  /// CRS coordinates, less vertex_shift_ at every read) instead of copied: 24 bytes a vertex
  /// of fresh memory saved, which is most of what a build costs (clearance_index.cpp).
  Layout(const Mesh& mesh, const ClearanceOptions& options, std::shared_ptr<const Mesh> keep = nullptr);
  Layout() = default;              ///< for clearance_index_file.cpp, which fills it from a file
  Layout(const Layout&) = delete;  ///< the views would still show the other's vectors
  Layout& operator=(const Layout&) = delete;
  bool segment_clear(const Point3& p, const Point3& q, double d) const;
  double clearance(const Point3& p, const Point3& q, double max_d) const;
  double clearance_bound(const Point3& p, double max_d) const;
  double ground(double x, double y) const;
  void ground(const double* x, const double* y, double* z, size_t n) const;

  struct LocalVertex {
    double x, y, z;
  };
  size_t bucket_at(double X, double Y) const;  ///< of a local point; SIZE_MAX outside the grid
  double ground_in(size_t bucket, double X, double Y) const;
  template <bool Measure>
  double visit(const Point3& p, const Point3& q, double d) const;

  ClearanceOptions options_;  ///< what it was built with (a file records them)
  Point3 origin_{0, 0, 0};
  Footprint footprint_;
  detail::ArrayView<LocalVertex> verts_;
  /// Subtracted from verts_ at every read: the origin where verts_ views a mesh's own vertices,
  /// 0 where they are local already (a copy, or a file). The same subtraction a copy makes, so
  /// the values, and every answer, are the same either way.
  Point3 vertex_shift_{0, 0, 0};
  LocalVertex vertex(uint32_t i) const {
    const LocalVertex& v = verts_[i];
    return {v.x - vertex_shift_[0], v.y - vertex_shift_[1], v.z - vertex_shift_[2]};
  }
  size_t triangles_ = 0;
  double cell_ = 1, gx0_ = 0, gy0_ = 0;  ///< bucket (0,0) starts at local (gx0_, gy0_)
  int cols_ = 0, rows_ = 0;
  struct Listing {
    std::array<uint32_t, 3> corners;  ///< the triangle's vertices: no second read to find them
    float top;                        ///< highest point of the triangle inside the bucket, rounded up
  };
  /// Where a listing's triangle lies in its bucket: its x,y bounding box clipped to the bucket,
  /// in 255ths of the bucket's side from the bucket's corner, rounded outwards by one more.
  /// Apart from the listings, in the same order: a query reads it only for the triangles the
  /// heights leave open, and 4 bytes here and 16 a listing are half the fresh memory that
  /// 32-byte listings with float boxes took (most of what a build costs).
  struct Extent {
    uint8_t x0, x1, y0, y1;
  };
  struct Box {
    double x0, x1, y0, y1;
  };
  /// Listing k's box, in the bucket whose corner is (bx, by); `unit` is cell_ / 255.
  Box box_of(size_t k, double bx, double by, double unit) const {
    const Extent& e = extents_[k];
    return {bx + e.x0 * unit, bx + e.x1 * unit, by + e.y0 * unit, by + e.y1 * unit};
  }
  /// The same in bucket (r, c).
  Box box_of(size_t k, int r, int c) const { return box_of(k, gx0_ + c * cell_, gy0_ + r * cell_, cell_ / 255); }
  struct Bucket {
    uint32_t start;  ///< bucket b lists items_[start of b, start of b + 1), highest first
    float top;       ///< highest mesh point in the bucket, rounded up (-inf when empty)
  };
  detail::ArrayView<Bucket> buckets_;  ///< one more than there are buckets, for the last one's end
  detail::ArrayView<Listing> items_;
  detail::ArrayView<Extent> extents_;                        ///< one a listing
  bool box_holds(const Box& box, double X, double Y) const;  ///< local point in the box
  static constexpr int block = 4;                            ///< buckets a side of a block, the pyramid's coarse level
  int block_cols_ = 0, block_rows_ = 0;
  detail::ArrayView<float> block_top_;  ///< highest point of each block of block x block buckets
  /// The highest point in buckets [r0, r1] x [c0, c1], whole blocks read from block_top_.
  double highest(int r0, int r1, int c0, int c1) const;
  double zmin_ = 0, zmax_ = 0;  ///< lowest and highest vertex
  GroundGrid floor_;
  double margin_ = 0;  ///< conservative slack of the quick rejects

  // What the views show: the vectors of a built index, or a mapped file (then the vectors are empty).
  std::vector<LocalVertex> vert_store_;
  std::vector<Bucket> bucket_store_;
  std::vector<Listing> item_store_;
  std::vector<Extent> extent_store_;
  std::vector<float> block_top_store_;
  std::shared_ptr<const void> mapping_;
  std::shared_ptr<const Mesh> mesh_;  ///< whose vertices verts_ views, when it does
};

}  // namespace dsmplan
