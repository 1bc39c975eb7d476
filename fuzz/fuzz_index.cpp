// libFuzzer target: dsmplan::ClearanceIndex::open() on arbitrary bytes (a --index file), then a
// few queries of whatever it accepts: an index file is mapped and used where it lies, so what
// open() lets through must never make a query read outside its arrays.
//
// The file ends in a checksum (clearance_index_file.cpp) that random mutations would practically
// never match, so the checks behind it would go unfuzzed: inputs of even size whose header's
// counts fit their size get the right checksum written into their last 8 bytes (the fuzzer
// explores the arrays), the others are read as they are (the header, size and checksum refusals).
#include <cmath>
#include <cstring>
#include <vector>

#include "core/mapped_file.hpp"
#include "dsmplan/clearance.hpp"
#include "fuzz_file.hpp"

namespace {

// The format's offsets (clearance_index_file.cpp): the counts after 208 bytes of header, the
// floor's cell count at 280, the first section at 320, sections on 64-byte boundaries.
void reseal(std::vector<uint8_t>& bytes) {
  if (bytes.size() < 328 || bytes.size() % 2 != 0) return;
  uint64_t counts[4], floor_cells = 0;
  std::memcpy(counts, bytes.data() + 208, sizeof counts);
  std::memcpy(&floor_cells, bytes.data() + 280, 8);
  // Vertices, buckets, listings (16 bytes), their extents (4), block tops, floor cells.
  const uint64_t sizes[6] = {counts[0] * 24, counts[1] * 8, counts[2] * 16,
                             counts[2] * 4,  counts[3] * 4, floor_cells * 4};
  for (uint64_t s : sizes)
    if (s > bytes.size()) return;
  auto align = [](uint64_t v) { return (v + 63) & ~uint64_t(63); };
  uint64_t starts[6], at = 320;
  for (int k = 0; k < 6; ++k) {
    starts[k] = at;
    at = k < 5 ? align(at + sizes[k]) : (at + sizes[k] + 7) & ~uint64_t(7);
  }
  if (at + 8 != bytes.size()) return;
  uint64_t hashes[7] = {dsmplan::content_hash(bytes.data(), 320)};
  for (int k = 0; k < 6; ++k) hashes[k + 1] = dsmplan::content_hash(bytes.data() + starts[k], sizes[k]);
  const uint64_t sum = dsmplan::content_hash(hashes, sizeof hashes);
  std::memcpy(bytes.data() + at, &sum, 8);
}

// Queries around the middle of the footprint, some crossing the surface.
void query(const dsmplan::ClearanceIndex& index) {
  const auto& f = index.footprint();
  const double x = std::isfinite(f.xmin + f.xmax) ? (f.xmin + f.xmax) / 2 : 0;
  const double y = std::isfinite(f.ymin + f.ymax) ? (f.ymin + f.ymax) / 2 : 0;
  const double z = std::isfinite(index.origin()[2]) ? index.origin()[2] : 0;
  const dsmplan::Point3 p0{x - 3, y - 2, z + 5}, p1{x + 4, y + 1, z - 1};
  (void)index.segment_clear(p0, p1, 2);
  (void)index.clearance(p0, p1, 10);
  (void)index.clearance_bound(p0, 20);
  (void)index.ground(x, y);
  (void)index.floor().max_height_above(p0, p1);
  (void)index.floor().below_ceiling(p0, p1, 30);
  (void)index.floor().dips_below(p0, p1, 2);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  reseal(bytes);
  return dsmplan_fuzz::run(bytes.data(), bytes.size(), ".index", [](const std::string& p) {
    // Asked for what the file says it was built from, so that no input is merely stale.
    dsmplan::ClearanceIndex::Source source;
    auto index = dsmplan::ClearanceIndex::open(p, 0, {}, &source);
    if (!index) index = dsmplan::ClearanceIndex::open(p, source.input_hash);
    if (index) query(*index);
  });
}
