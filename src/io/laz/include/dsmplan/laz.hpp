// dsmplan/laz.hpp: a decoder of LAZ, the LASzip-compressed LAS point cloud, written in this
// project from the LASzip specification: "LASzip for LAS 1.4 (native extension)" (design/
// specification.rst) and the reference implementation in github.com/LASzip/LASzip (commit
// ac3e9e9f; the files each source names). No LASzip code is copied. dsmplan's LAS reader
// (read_las, read_points, `dsmplan grid`) uses it for every file whose point data format byte
// has the LASzip bit (7) set; this header is for tests, benchmarks, fuzzing and other tools.
//
// Supported: the LASzip arithmetic coder (coder 0) with
//   - point-wise compression (compressor 1, one stream; compressor 2, chunked) of items POINT10,
//     GPSTIME11, RGB12 and BYTE at version 2: point formats 0-3 (formats 4/5 have wave packets:
//     refused);
//   - layered chunked compression (compressor 3) of items POINT14, RGB14, RGBNIR14 and BYTE14 at
//     version 3 (version 2, LASzip's prototype numbering, is read as 3): point formats 6-8 with
//     or without extra bytes (9/10 have wave packets: refused);
//   - fixed chunk sizes (the VLR's) and variable ones (chunk size 0xFFFFFFFF: counts in the
//     chunk table), a chunk table located by its offset or, when the writer could not seek
//     back, by the file's last 8 bytes.
// Not supported (refused with one line): items of version 1 (LASzip 1.x files, 2011 and
// earlier), POINT14 v4 (LASzip 4's "selective decompression" variant is v3 on disk, but its
// item versions differ), wave packets, the "none" compressor in a LAZ file.
//
// Decoded records are the LAS record bytes, byte for byte what the uncompressed file holds.
//
// Errors: every problem is a LazError whose place() names where (e.g. "chunk 3 of 13 (point
// 150001, byte 1234567)", "chunk table at byte 3532875", "laszip VLR") and whose problem() says
// what, in one line; read_las turns it into an InputError naming the file. The decoder checks
// everything it reads before trusting it: the VLR (compressor, coder, item types, versions and
// sizes against the point format and record length), the chunk table (inside the file, version
// 0, chunk sizes that add up to exactly the compressed bytes, counts that add up to the header's
// point count), and every chunk (first point and layer sizes inside the chunk, point count equal
// to the table's, arithmetic code that ends exactly at the chunk's end, as LASzip's encoder
// makes it: bytes left over mean a count that lies). A corrupt file never
// makes it read out of bounds, loop or allocate beyond what the file can justify: every count is
// bounded by the file's size (at most kMaxPointsPerByte points per compressed byte, far above
// what the coder can reach).
//
// Memory: the chunk table (16 bytes a chunk) plus, per chunk in flight, its compressed bytes and
// its decoded records; at most 2 x threads + 1 chunks are in flight (LASzip writes 50,000-point
// chunks: about 2 MB each for 34-byte records). Compressor 1 has no chunks: its whole
// compressed stream is read at once and decoded in slices.
//
// Speed: O(points); chunks are decoded in parallel (TBB) and handed to the sink in file order.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace dsmplan::laz {

/// LASzip item types (laszip.hpp's LASitem::Type).
enum ItemType : uint16_t {
  kByte = 0,
  kPoint10 = 6,
  kGpsTime11 = 7,
  kRgb12 = 8,
  kWavePacket13 = 9,
  kPoint14 = 10,
  kRgb14 = 11,
  kRgbNir14 = 12,
  kWavePacket14 = 13,
  kByte14 = 14,
};

struct Item {
  uint16_t type = 0, size = 0, version = 0;
};

/// The "laszip encoded" VLR (user id "laszip encoded", record id 22204).
struct LaszipVlr {
  uint16_t compressor = 0;  ///< 1 point-wise, 2 point-wise chunked, 3 layered chunked
  uint16_t coder = 0;       ///< 0 arithmetic (the only one LASzip defines)
  uint8_t version_major = 0, version_minor = 0;
  uint16_t version_revision = 0;
  uint32_t options = 0;
  uint32_t chunk_size = 0;  ///< points per chunk; 0xFFFFFFFF: variable, counts in the chunk table
  std::vector<Item> items;
  bool variable_chunks() const { return chunk_size == 0xFFFFFFFFu; }
};

inline constexpr uint16_t kLaszipRecordId = 22204;
inline constexpr const char* kLaszipUserId = "laszip encoded";
/// A bound no valid file reaches (the coder needs over 1/1000 bit a point); it caps what a
/// lying count can make the decoder do.
inline constexpr uint64_t kMaxPointsPerByte = 4096;

class LazError : public std::runtime_error {
public:
  LazError(const std::string& place, const std::string& problem)
      : std::runtime_error(place.empty() ? problem : place + ": " + problem), place_(place), problem_(problem) {}
  const std::string& place() const { return place_; }
  const std::string& problem() const { return problem_; }

private:
  std::string place_, problem_;
};

/// Parses and checks the VLR payload against the LAS header's point format (0-10, without the
/// LASzip bits) and record length. Throws LazError (place "laszip VLR").
LaszipVlr parse_laszip_vlr(const uint8_t* payload, size_t bytes, int point_format, uint32_t record_length);

/// Where the compressed points are. read_at(offset, buffer, bytes) fills `buffer` or throws; it
/// is called from several threads at once and must be safe for that (pread is).
struct PointSource {
  std::function<void(uint64_t offset, void* buffer, size_t bytes)> read_at;
  uint64_t file_size = 0;
  uint64_t point_offset = 0;  ///< LAS header's "offset to point data"
  uint64_t point_count = 0;   ///< LAS header's point count
  uint32_t record_length = 0;
  /// End of the compressed data when the file has no chunk table (compressor 1): the first EVLR
  /// or the file's end.
  uint64_t points_end = 0;
};

/// Receives consecutive batches of decoded records, in file order, from one thread at a time.
/// It may throw; decoding then stops and the exception reaches decode()'s caller.
using RecordSink = std::function<void(const uint8_t* records, size_t count)>;

struct DecodeOptions {
  int threads = 0;  ///< 0: as many as TBB's default arena; 1: decode on the calling thread only
};

class Decoder {
public:
  /// Reads and checks the chunk table; throws LazError before anything is decoded.
  Decoder(LaszipVlr vlr, PointSource source);
  ~Decoder();
  Decoder(Decoder&&) noexcept;
  Decoder& operator=(Decoder&&) noexcept;

  uint64_t chunk_count() const;
  /// The chunk table as read: where each chunk is and which points it holds.
  struct Chunk {
    uint64_t offset = 0, bytes = 0, first_point = 0, count = 0;
  };
  std::vector<Chunk> chunks() const;
  /// Decodes every point once into `sink`. Throws LazError on a corrupt chunk (records of the
  /// chunks before it may already have reached the sink).
  void decode(const RecordSink& sink, const DecodeOptions& options = {}) const;

private:
  struct State;
  std::unique_ptr<State> state_;
};

/// A LAZ (or LAS) file's header fields the decoder needs, read with minimal checks: for tools
/// and tests that want records without dsmplan's full LAS reader. `laszip` is empty for a file
/// without the LASzip bit. Throws LazError.
struct LazFile {
  int point_format = 0;  ///< without the LASzip bits
  uint32_t record_length = 0;
  uint64_t point_count = 0;
  uint64_t point_offset = 0;
  uint64_t points_end = 0;
  std::unique_ptr<LaszipVlr> laszip;
};
LazFile read_laz_header(const std::function<void(uint64_t, void*, size_t)>& read_at, uint64_t file_size);

/// Every record of the LAZ file at `path` (or, when it is not compressed, of the LAS file),
/// through `sink`. Throws LazError with the path in place().
void read_laz_records(const std::string& path, const RecordSink& sink, const DecodeOptions& options = {});

}  // namespace dsmplan::laz
