// libFuzzer target: dsmplan's LAZ decoder (dsmplan/laz.hpp) on arbitrary bytes held in memory:
// the LAS header, the "laszip encoded" VLR, the chunk table and every chunk, decoded on one
// thread. A LazError is the expected answer to bad input; anything else (another exception, a
// crash, a sanitizer report, a leak, a timeout, an out-of-memory) is a finding, and so is a
// decode that succeeds with another number of points than the header's.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "dsmplan/laz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace laz = dsmplan::laz;
  auto read_at = [&](uint64_t offset, void* buffer, size_t bytes) {
    if (offset > size || bytes > size - offset)
      throw laz::LazError("byte " + std::to_string(offset), "past the end of the input");
    std::memcpy(buffer, data + offset, bytes);
  };
  try {
    const laz::LazFile file = laz::read_laz_header(read_at, size);
    if (!file.laszip) return 0;
    laz::PointSource source{read_at, size, file.point_offset, file.point_count, file.record_length, file.points_end};
    const laz::Decoder decoder(*file.laszip, source);
    uint64_t points = 0;
    uint32_t checksum = 0;  // touch every byte handed over
    decoder.decode(
        [&](const uint8_t* records, size_t count) {
          points += count;
          for (size_t i = 0; i < count * file.record_length; ++i) checksum += records[i];
        },
        {1});
    if (points != file.point_count) {
      std::fprintf(stderr, "decoded %llu points, the header counts %llu (checksum %u)\n",
                   static_cast<unsigned long long>(points), static_cast<unsigned long long>(file.point_count),
                   checksum);
      std::abort();
    }
  } catch (const laz::LazError& e) {
    static const bool verbose = std::getenv("DSMPLAN_FUZZ_VERBOSE") != nullptr;  // to check seeds
    if (verbose) std::fprintf(stderr, "refused: %s\n", e.what());
  }
  return 0;
}
