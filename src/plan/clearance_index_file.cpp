// The clearance index kept in a file and mapped back (clearance.hpp, "Kept in a file"). Building
// the index is most of what loading a mesh for planning costs; a file the page cache holds is
// mapped in a few milliseconds, its arrays used where they lie (the way LAStools' .lax spatial
// index sits beside a LAS file, and GDAL's .ovr overviews beside a raster).
//
// Layout, native byte order (a file of the other order, or of another version, is stale: rebuilt):
//   FileHeader (below), then five sections each starting on a 64-byte boundary: the local
//   vertices (3 f64), the buckets (u32 start, f32 top; one more than there are buckets), the
//   listings (3 u32 corners, 5 f32), the blocks' tops (f32), the floor's heights (f32, NaN where
//   the cell was a hole, filled again from its rim when opened); then, on an 8-byte boundary, a
//   checksum: content_hash() (core/mapped_file.hpp: XXH3-64 in 1 MB pieces) of the content_hash()
//   of the header and of each section.
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <functional>
#include <type_traits>

#include "clearance_layout.hpp"
#include "core/atomic_file.hpp"
#include "core/mapped_file.hpp"

namespace dsmplan {

namespace {

constexpr char kMagic[16] = "dsmplan index\n";
// Raise it with every change to the layout or to what the index holds (how it is built, the
// floor, the DSM's hole columns dsmplan plan adds to the mesh): a file of another version is
// rebuilt, so no run uses an index an older build made differently.
constexpr uint32_t kVersion = 2;  // 2: listings of 16 bytes, their extents apart
constexpr uint32_t kByteOrder = 0x01020304;

struct FileHeader {
  char magic[16];
  uint32_t version, byte_order;
  uint64_t input_hash, mesh_fingerprint;
  double bucket_size_option, flight_area[4];
  double origin[3], footprint[4];
  uint64_t triangles;
  double cell, gx0, gy0, zmin, zmax, margin;
  int32_t cols, rows, block_cols, block_rows;
  uint64_t verts, buckets, items, block_tops;
  int32_t floor_width, floor_height;
  double floor_x0, floor_y0, floor_cell_x, floor_cell_y;
  uint64_t floor_cells;
};
static_assert(std::is_trivially_copyable_v<FileHeader>);

constexpr size_t align64(size_t at) { return (at + 63) & ~size_t(63); }

// Where each section starts and where the checksum is, from the header's counts; false when
// the counts overflow.
struct Sections {
  size_t verts, buckets, items, extents, block_tops, floor, checksum, end;
};
// Bytes of a vertex, a bucket and a listing (the layout's types are private to the index).
constexpr size_t kVertexBytes = 24, kBucketBytes = 8, kListingBytes = 16, kExtentBytes = 4;
bool sections_of(const FileHeader& h, Sections& s) {
  constexpr uint64_t limit = uint64_t(1) << 40;  // counts beyond any file this machine maps
  if (h.verts > limit || h.buckets > limit || h.items > limit || h.block_tops > limit || h.floor_cells > limit)
    return false;
  s.verts = align64(sizeof(FileHeader));
  s.buckets = align64(s.verts + h.verts * kVertexBytes);
  s.items = align64(s.buckets + h.buckets * kBucketBytes);
  s.extents = align64(s.items + h.items * kListingBytes);
  s.block_tops = align64(s.extents + h.items * kExtentBytes);
  s.floor = align64(s.block_tops + h.block_tops * sizeof(float));
  s.checksum = (s.floor + h.floor_cells * sizeof(float) + 7) & ~size_t(7);
  s.end = s.checksum + sizeof(uint64_t);
  return true;
}

// The header and the six sections hashed each where it lies (the zero padding between them is
// not), then their hashes: no copy of the arrays is needed to write or to check a file.
// `visit_listings` sees the listings' section piece by piece as it is hashed (content_hash()).
uint64_t checksum_of(const std::pair<const void*, size_t> (&parts)[7],
                     const std::function<void(const unsigned char*, size_t)>& visit_listings = {}) {
  uint64_t hashes[7];
  for (int k = 0; k < 7; ++k)
    hashes[k] = content_hash(parts[k].first, parts[k].second, k == 3 ? visit_listings : nullptr);
  return content_hash(hashes, sizeof hashes);
}

bool same_options(const ClearanceOptions& a, const FileHeader& h) {
  if (a.bucket_size != h.bucket_size_option) return false;
  for (int k = 0; k < 4; ++k)
    if (a.flight_area[k] != h.flight_area[k]) return false;
  return true;
}

}  // namespace

ClearanceIndex::ClearanceIndex(std::shared_ptr<const Layout> layout) : layout_(std::move(layout)) {}

void ClearanceIndex::save(const std::string& path, const Source& source) const {
  static_assert(offsetof(Layout::Listing, corners) == 0 && sizeof(Layout::LocalVertex) == kVertexBytes &&
                sizeof(Layout::Bucket) == kBucketBytes && sizeof(Layout::Listing) == kListingBytes &&
                sizeof(Layout::Extent) == kExtentBytes);
  const Layout& l = *layout_;
  FileHeader h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kVersion;
  h.byte_order = kByteOrder;
  h.input_hash = source.input_hash;
  h.mesh_fingerprint = source.mesh_fingerprint;
  h.bucket_size_option = l.options_.bucket_size;
  for (int k = 0; k < 4; ++k) h.flight_area[k] = l.options_.flight_area[k];
  for (int k = 0; k < 3; ++k) h.origin[k] = l.origin_[k];
  h.footprint[0] = l.footprint_.xmin, h.footprint[1] = l.footprint_.ymin;
  h.footprint[2] = l.footprint_.xmax, h.footprint[3] = l.footprint_.ymax;
  h.triangles = l.triangles_;
  h.cell = l.cell_, h.gx0 = l.gx0_, h.gy0 = l.gy0_, h.zmin = l.zmin_, h.zmax = l.zmax_, h.margin = l.margin_;
  h.cols = l.cols_, h.rows = l.rows_, h.block_cols = l.block_cols_, h.block_rows = l.block_rows_;
  h.verts = l.verts_.size(), h.buckets = l.buckets_.size(), h.items = l.items_.size();
  h.block_tops = l.block_top_.size();
  const Grid& floor = l.floor_.grid();
  h.floor_width = floor.width, h.floor_height = floor.height;
  h.floor_x0 = floor.x0, h.floor_y0 = floor.y0, h.floor_cell_x = floor.cell_x, h.floor_cell_y = floor.cell_y;
  h.floor_cells = floor.cells();
  std::vector<float> floor_z(floor.z);
  for (size_t i = 0; i < floor_z.size(); ++i)
    if (l.floor_.was_hole(i)) floor_z[i] = Grid::nodata;
  Sections s{};
  sections_of(h, s);
  // The file keeps local vertices: made here when the index reads a mesh's own (CRS) vertices.
  std::vector<Layout::LocalVertex> local;
  if (l.vertex_shift_ != Point3{0, 0, 0}) {
    local.resize(l.verts_.size());
    for (size_t i = 0; i < local.size(); ++i) local[i] = l.vertex(static_cast<uint32_t>(i));
  }
  const void* verts = local.empty() ? static_cast<const void*>(l.verts_.data()) : local.data();

  std::vector<unsigned char> head(s.verts, 0);
  std::memcpy(head.data(), &h, sizeof h);
  const std::pair<const void*, size_t> parts[] = {{head.data(), head.size()},
                                                  {verts, h.verts * sizeof(Layout::LocalVertex)},
                                                  {l.buckets_.data(), h.buckets * sizeof(Layout::Bucket)},
                                                  {l.items_.data(), h.items * sizeof(Layout::Listing)},
                                                  {l.extents_.data(), h.items * sizeof(Layout::Extent)},
                                                  {l.block_top_.data(), h.block_tops * sizeof(float)},
                                                  {floor_z.data(), floor_z.size() * sizeof(float)}};
  const size_t starts[] = {0, s.verts, s.buckets, s.items, s.extents, s.block_tops, s.floor, s.checksum};
  AtomicFile out(path);
  static const unsigned char zeros[64] = {};
  size_t at = 0;
  for (int k = 0; k < 7; ++k) {
    out.write(parts[k].first, parts[k].second);
    at += parts[k].second;
    out.write(zeros, starts[k + 1] - at);
    at = starts[k + 1];
  }
  const uint64_t checksum = checksum_of(parts);
  out.write(&checksum, sizeof checksum);
  out.commit();
}

std::optional<ClearanceIndex> ClearanceIndex::open(const std::string& path, uint64_t input_hash,
                                                   const ClearanceOptions& options, Source* source) {
  const std::shared_ptr<const MappedFile> file = MappedFile::open(path);
  const unsigned char* bytes = file->data();
  FileHeader h{};
  if (file->size() < sizeof h || std::memcmp(bytes, kMagic, sizeof kMagic) != 0)
    throw InputError(path, "", "is not a dsmplan index file (dsmplan plan --index writes them)");
  std::memcpy(&h, bytes, sizeof h);
  // An index of another format version or byte order is dsmplan's own all the same: stale, as
  // one of another mesh is (a newer dsmplan rebuilds its files without being asked).
  if (h.byte_order != kByteOrder || h.version != kVersion) {
    if (source) *source = {};
    return std::nullopt;
  }
  if (source) *source = {h.input_hash, h.mesh_fingerprint};
  if (h.input_hash != input_hash || !same_options(options, h)) return std::nullopt;
  Sections s{};
  if (!sections_of(h, s) || s.end != file->size())
    throw InputError(path, "",
                     "is " + std::to_string(file->size()) + " bytes, its header asks for " +
                         (s.end ? std::to_string(s.end) : std::string("more")) + ": truncated or damaged");
  uint64_t stored = 0;
  std::memcpy(&stored, bytes + s.checksum, sizeof stored);
  const std::pair<const void*, size_t> parts[] = {{bytes, s.verts},
                                                  {bytes + s.verts, h.verts * sizeof(Layout::LocalVertex)},
                                                  {bytes + s.buckets, h.buckets * sizeof(Layout::Bucket)},
                                                  {bytes + s.items, h.items * sizeof(Layout::Listing)},
                                                  {bytes + s.extents, h.items * sizeof(Layout::Extent)},
                                                  {bytes + s.block_tops, h.block_tops * sizeof(float)},
                                                  {bytes + s.floor, h.floor_cells * sizeof(float)}};
  // The highest vertex the listings name, found while they are hashed: a second pass over them
  // would cost a second trip to memory (they are most of the file).
  std::atomic<uint32_t> highest_corner{0};
  const auto scan_listings = [&](const unsigned char* piece, size_t piece_bytes) {
    static_assert(hash_piece_bytes % kListingBytes == 0);  // pieces hold whole listings
    uint32_t top = 0;
    for (size_t at = 0; at + kListingBytes <= piece_bytes; at += kListingBytes) {
      uint32_t corners[3];
      std::memcpy(corners, piece + at, sizeof corners);
      top = std::max({top, corners[0], corners[1], corners[2]});
    }
    uint32_t seen = highest_corner.load(std::memory_order_relaxed);
    while (top > seen && !highest_corner.compare_exchange_weak(seen, top, std::memory_order_relaxed)) {
    }
  };
  if (checksum_of(parts, scan_listings) != stored)
    throw InputError(path, "", "is damaged (checksum differs); delete it to rebuild");

  // A checksum finds damage, not a file written to mislead: the arrays are checked against each
  // other too, so that no query can read outside them.
  auto bad = [&](const std::string& why) { return InputError(path, "", "does not hold together: " + why); };
  const bool finite = std::isfinite(h.cell) && h.cell > 0 && std::isfinite(h.gx0) && std::isfinite(h.gy0) &&
                      std::isfinite(h.margin) && std::isfinite(h.origin[0]) && std::isfinite(h.origin[1]) &&
                      std::isfinite(h.origin[2]);
  if (!finite) throw bad("the grid's frame is not finite");
  if (h.triangles == 0) {
    if (h.verts || h.items) throw bad("vertices or listings without triangles");
  } else {
    if (h.cols <= 0 || h.rows <= 0 || h.buckets != uint64_t(h.cols) * uint64_t(h.rows) + 1)
      throw bad("the bucket count is not columns x rows + 1");
    if (h.block_cols != (h.cols + Layout::block - 1) / Layout::block ||
        h.block_rows != (h.rows + Layout::block - 1) / Layout::block ||
        h.block_tops != uint64_t(h.block_cols) * uint64_t(h.block_rows))
      throw bad("the block count does not fit the bucket grid");
  }
  if (h.floor_cells != uint64_t(std::max(h.floor_width, 0)) * uint64_t(std::max(h.floor_height, 0)) ||
      (h.floor_cells &&
       !(h.floor_cell_x > 0 && h.floor_cell_y > 0 && std::isfinite(h.floor_x0) && std::isfinite(h.floor_y0))))
    throw bad("the floor's frame does not fit its cells");

  auto layout = std::make_shared<Layout>();
  Layout& l = *layout;
  l.options_ = options;
  for (int k = 0; k < 3; ++k) l.origin_[k] = h.origin[k];
  l.footprint_ = {h.footprint[0], h.footprint[1], h.footprint[2], h.footprint[3]};
  l.triangles_ = h.triangles;
  l.cell_ = h.cell, l.gx0_ = h.gx0, l.gy0_ = h.gy0, l.zmin_ = h.zmin, l.zmax_ = h.zmax, l.margin_ = h.margin;
  l.cols_ = h.cols, l.rows_ = h.rows, l.block_cols_ = h.block_cols, l.block_rows_ = h.block_rows;
  l.verts_ = {reinterpret_cast<const Layout::LocalVertex*>(bytes + s.verts), h.verts};
  l.buckets_ = {reinterpret_cast<const Layout::Bucket*>(bytes + s.buckets), h.buckets};
  l.items_ = {reinterpret_cast<const Layout::Listing*>(bytes + s.items), h.items};
  l.extents_ = {reinterpret_cast<const Layout::Extent*>(bytes + s.extents), h.items};
  l.block_top_ = {reinterpret_cast<const float*>(bytes + s.block_tops), h.block_tops};
  l.mapping_ = file;

  if (h.triangles > 0) {
    if (l.buckets_[0].start != 0 || l.buckets_[h.buckets - 1].start != h.items) throw bad("the buckets' lists");
    // Branch-free (it vectorises).
    const bool backwards = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(1, h.buckets), false,
        [&](const tbb::blocked_range<size_t>& r, bool any) {
          for (size_t b = r.begin(); b != r.end(); ++b) any |= l.buckets_[b - 1].start > l.buckets_[b].start;
          return any;
        },
        [](bool a, bool b) { return a || b; });
    if (backwards) throw bad("the buckets' lists");
    const bool named = h.items == 0 || highest_corner.load() < h.verts;
    if (!named) throw bad("a listing names a vertex that is not there");
  }
  if (h.floor_cells > 0) {
    Grid floor(h.floor_width, h.floor_height, h.floor_x0, h.floor_y0, h.floor_cell_x, h.floor_cell_y);
    std::memcpy(floor.z.data(), bytes + s.floor, h.floor_cells * sizeof(float));
    l.floor_ = GroundGrid(std::move(floor));
  }
  return ClearanceIndex(std::move(layout));
}

}  // namespace dsmplan
