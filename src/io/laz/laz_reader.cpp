// The LAZ container: the "laszip encoded" VLR, the chunk table and the order-preserving parallel
// decoding of chunks. Written for dsmplan from the LASzip specification and its reference
// implementation (github.com/LASzip/LASzip at ac3e9e9f: src/laszip.cpp for the VLR layout, item
// types and versions; src/lasreadpoint.cpp for the chunk table: an 8-byte offset before the first
// chunk (or -1 and the offset in the file's last 8 bytes), then at that offset version 0, the
// number of chunks, and per chunk its point count (variable chunks only) and byte size, coded
// with the integer compressor (32 bits, 2 contexts) relative to the previous chunk's).
#include <fcntl.h>
#include <sys/stat.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <exception>

#include "laz_private.hpp"

namespace dsmplan::laz {

using detail::ArithmeticDecoder;
using detail::ChunkDecoder;
using detail::ChunkInput;
using detail::CorruptStream;
using detail::IntegerDecompressor;
using detail::load_u16;
using detail::load_u32;
using detail::load_u64;

namespace {

std::string item_name(uint16_t type) {
  switch (type) {
    case kByte:
      return "BYTE";
    case kPoint10:
      return "POINT10";
    case kGpsTime11:
      return "GPSTIME11";
    case kRgb12:
      return "RGB12";
    case kWavePacket13:
      return "WAVEPACKET13";
    case kPoint14:
      return "POINT14";
    case kRgb14:
      return "RGB14";
    case kRgbNir14:
      return "RGBNIR14";
    case kWavePacket14:
      return "WAVEPACKET14";
    case kByte14:
      return "BYTE14";
    default:
      return "unknown item type " + std::to_string(type);
  }
}

// The items a point format is made of, in record order (extra bytes may follow).
std::vector<uint16_t> items_of_format(int format) {
  switch (format) {
    case 0:
      return {kPoint10};
    case 1:
      return {kPoint10, kGpsTime11};
    case 2:
      return {kPoint10, kRgb12};
    case 3:
      return {kPoint10, kGpsTime11, kRgb12};
    case 6:
      return {kPoint14};
    case 7:
      return {kPoint14, kRgb14};
    case 8:
      return {kPoint14, kRgbNir14};
    default:
      return {};
  }
}

uint16_t fixed_size(uint16_t type) {
  switch (type) {
    case kPoint10:
      return 20;
    case kGpsTime11:
      return 8;
    case kRgb12:
      return 6;
    case kPoint14:
      return 30;
    case kRgb14:
      return 6;
    case kRgbNir14:
      return 8;
    default:
      return 0;
  }
}

}  // namespace

LaszipVlr parse_laszip_vlr(const uint8_t* payload, size_t bytes, int point_format, uint32_t record_length) {
  const std::string place = "laszip VLR";
  if (bytes < 34) throw LazError(place, std::to_string(bytes) + " bytes, fewer than the 34 of its fixed part");
  LaszipVlr vlr;
  vlr.compressor = load_u16(payload);
  vlr.coder = load_u16(payload + 2);
  vlr.version_major = payload[4];
  vlr.version_minor = payload[5];
  vlr.version_revision = load_u16(payload + 6);
  vlr.options = load_u32(payload + 8);
  vlr.chunk_size = load_u32(payload + 12);
  const uint16_t item_count = load_u16(payload + 32);
  if (34 + 6 * size_t{item_count} > bytes)
    throw LazError(place, "says it lists " + std::to_string(item_count) + " items, but its " + std::to_string(bytes) +
                              " bytes hold " + std::to_string((bytes - 34) / 6));
  for (uint16_t i = 0; i < item_count; ++i)
    vlr.items.push_back(
        {load_u16(payload + 34 + 6 * i), load_u16(payload + 36 + 6 * i), load_u16(payload + 38 + 6 * i)});

  if (vlr.compressor == 0 || vlr.compressor > 3)
    throw LazError(place, "unknown compressor " + std::to_string(vlr.compressor) +
                              " (LASzip defines 1 point-wise, 2 point-wise chunked, 3 layered chunked)");
  if (vlr.coder != 0)
    throw LazError(place, "unknown coder " + std::to_string(vlr.coder) + " (LASzip defines 0, arithmetic)");
  if (vlr.compressor != 1 && vlr.chunk_size == 0) throw LazError(place, "chunk size 0");

  const std::vector<uint16_t> expected = items_of_format(point_format);
  if (expected.empty())
    throw LazError(place, "point format " + std::to_string(point_format) +
                              " is not one dsmplan's LAZ decoder reads (0-3 and 6-8; 4, 5, 9 and 10 carry wave "
                              "packets)");
  const bool las14 = point_format >= 6;
  if (las14 != (vlr.compressor == 3))
    throw LazError(place, "compressor " + std::to_string(vlr.compressor) + " with point format " +
                              std::to_string(point_format) +
                              (las14 ? " (formats 6-10 are compressed layered, compressor 3)"
                                     : " (formats 0-5 are compressed point-wise, compressor 1 or 2)"));
  if (vlr.items.size() < expected.size())
    throw LazError(place, std::to_string(vlr.items.size()) + " items, point format " + std::to_string(point_format) +
                              " needs at least " + std::to_string(expected.size()));
  uint64_t total = 0;
  for (size_t i = 0; i < vlr.items.size(); ++i) {
    const Item& it = vlr.items[i];
    const std::string which = "item " + std::to_string(i + 1) + " (" + item_name(it.type) + ")";
    const uint16_t want = i < expected.size() ? expected[i] : static_cast<uint16_t>(las14 ? kByte14 : kByte);
    if (it.type != want)
      throw LazError(place, which + " where point format " + std::to_string(point_format) + " has " + item_name(want) +
                                (i >= expected.size() ? " (extra bytes)" : ""));
    const bool version_ok = las14 ? (it.version == 2 || it.version == 3) : it.version == 2;
    if (!version_ok)
      throw LazError(place, which + " version " + std::to_string(it.version) + " is not supported (dsmplan reads " +
                                (las14 ? "version 3" : "version 2") + ")");
    const uint16_t size = fixed_size(it.type);
    if ((size && it.size != size) || it.size == 0)
      throw LazError(place, which + " of " + std::to_string(it.size) + " bytes" +
                                (size ? " (it has " + std::to_string(size) + ")" : ""));
    total += it.size;
  }
  if (total != record_length)
    throw LazError(place, "the items add up to " + std::to_string(total) + " bytes, the point record length is " +
                              std::to_string(record_length));
  return vlr;
}

struct ChunkEntry {
  uint64_t offset, bytes, first_point, count;
};

struct Decoder::State {
  LaszipVlr vlr;
  PointSource source;
  std::vector<ChunkEntry> chunks;

  std::unique_ptr<ChunkDecoder> make_chunk_decoder() const {
    return vlr.compressor == 3 ? detail::make_layered_decoder(vlr.items, source.record_length)
                               : detail::make_pointwise_decoder(vlr.items, source.record_length);
  }
  std::string chunk_place(size_t index) const {
    const ChunkEntry& c = chunks[index];
    return "chunk " + std::to_string(index + 1) + " of " + std::to_string(chunks.size()) + " at byte " +
           std::to_string(c.offset);
  }
  void read_chunk_table();
  void decode_chunk(size_t index, std::vector<uint8_t>& compressed, std::vector<uint8_t>& records) const;
};

void Decoder::State::read_chunk_table() {
  const uint64_t size = source.file_size, count = source.point_count;
  const uint32_t length = source.record_length;
  if (vlr.compressor == 1) {  // one stream, no table
    if (count == 0) return;
    if (source.points_end < source.point_offset + length || source.points_end > size)
      throw LazError("point data at byte " + std::to_string(source.point_offset),
                     "the compressed points end at byte " + std::to_string(source.points_end) +
                         ", before their first point does (truncated file?)");
    const uint64_t bytes = source.points_end - source.point_offset;
    if (count > bytes * kMaxPointsPerByte)
      throw LazError("point data at byte " + std::to_string(source.point_offset),
                     std::to_string(count) + " points cannot fit in " + std::to_string(bytes) + " compressed bytes");
    chunks.push_back({source.point_offset, bytes, 0, count});
    return;
  }

  const uint64_t chunks_start = source.point_offset + 8;
  const std::string pointer_place = "chunk table offset at byte " + std::to_string(source.point_offset);
  if (chunks_start > size) throw LazError(pointer_place, "the file ends before it (truncated file)");
  uint8_t b[8];
  source.read_at(source.point_offset, b, 8);
  int64_t table = static_cast<int64_t>(load_u64(b));
  if (table == -1) {  // the writer could not seek back: the offset is the file's last 8 bytes
    if (size < chunks_start + 8) throw LazError(pointer_place, "is -1 (at the end), but the file ends too soon");
    source.read_at(size - 8, b, 8);
    table = static_cast<int64_t>(load_u64(b));
  }
  if (table == static_cast<int64_t>(chunks_start) && count > 0)
    throw LazError(pointer_place, "no chunk table was written (the compressor was interrupted?)");
  if (table < static_cast<int64_t>(chunks_start) || static_cast<uint64_t>(table) > size - std::min<uint64_t>(size, 8))
    throw LazError(pointer_place, "says the chunk table is at byte " + std::to_string(table) +
                                      ", outside the file's compressed points (bytes " + std::to_string(chunks_start) +
                                      "-" + std::to_string(size) + "; truncated file?)");
  const uint64_t table_at = static_cast<uint64_t>(table);
  const std::string place = "chunk table at byte " + std::to_string(table_at);
  source.read_at(table_at, b, 8);
  const uint32_t version = load_u32(b), number = load_u32(b + 4);
  if (version != 0) throw LazError(place, "version " + std::to_string(version) + " (LASzip writes 0)");
  const uint64_t compressed = table_at - chunks_start;
  if (count == 0 && number == 0) return;
  if (number == 0) throw LazError(place, "no chunks, but the header counts " + std::to_string(count) + " points");
  if (number > compressed / length)
    throw LazError(place, std::to_string(number) + " chunks cannot fit in the " + std::to_string(compressed) +
                              " compressed bytes (each starts with a " + std::to_string(length) + "-byte point)");

  // Each entry takes at most two 32-bit integers and their length symbols: 10 bytes at most.
  const uint64_t coded = std::min<uint64_t>(size - table_at - 8, 64 + 24 * uint64_t{number});
  std::vector<uint8_t> bytes(coded);
  source.read_at(table_at + 8, bytes.data(), bytes.size());
  ArithmeticDecoder decoder;
  decoder.start(bytes.data(), bytes.data() + bytes.size());
  IntegerDecompressor ic(32, 2);
  chunks.resize(number);
  uint32_t last_count = 0, last_bytes = 0;
  uint64_t offset = chunks_start, first = 0;
  try {
    for (uint32_t i = 0; i < number; ++i) {
      ChunkEntry& c = chunks[i];
      if (vlr.variable_chunks()) {
        last_count = static_cast<uint32_t>(ic.decompress(decoder, static_cast<int32_t>(last_count), 0));
        c.count = last_count;
      } else {
        c.count = std::min<uint64_t>(vlr.chunk_size, count - std::min(count, first));
      }
      last_bytes = static_cast<uint32_t>(ic.decompress(decoder, static_cast<int32_t>(last_bytes), 1));
      c.bytes = last_bytes;
      c.offset = offset;
      c.first_point = first;
      offset += c.bytes;
      first += c.count;
    }
  } catch (const CorruptStream& e) {
    throw LazError(place, e.problem);
  }
  if (decoder.overrun() > 0) throw LazError(place, "its entries run past the end of the file (truncated file?)");
  if (offset != table_at)
    throw LazError(place, "its " + std::to_string(number) +
                              (number == 1 ? " chunk adds up to " : " chunks add up to ") +
                              std::to_string(offset - chunks_start) + " bytes, but the compressed points take " +
                              std::to_string(compressed) + " (bytes " + std::to_string(chunks_start) + "-" +
                              std::to_string(table_at) + ")");
  if (first != count)
    throw LazError(place,
                   "its chunks hold " + std::to_string(first) + " points, the header counts " + std::to_string(count));
  for (size_t i = 0; i < chunks.size(); ++i) {
    const ChunkEntry& c = chunks[i];
    if (c.count == 0 || c.bytes < length || c.count > c.bytes * kMaxPointsPerByte)
      throw LazError(chunk_place(i) + " (chunk table at byte " + std::to_string(table_at) + ")",
                     std::to_string(c.count) + " points in " + std::to_string(c.bytes) + " bytes is impossible");
  }
}

void Decoder::State::decode_chunk(size_t index, std::vector<uint8_t>& compressed, std::vector<uint8_t>& records) const {
  const ChunkEntry& c = chunks[index];
  compressed.resize(c.bytes);
  source.read_at(c.offset, compressed.data(), compressed.size());
  auto decoder = make_chunk_decoder();
  try {
    decoder->begin({compressed.data(), compressed.size(), c.count});
    // The records grow with the points decoded, so that a count that lies costs memory only for
    // the points decoded before the stream gives it away. A buffer used before keeps its size:
    // the records are written over, not cleared and filled with zeros again for every chunk.
    constexpr uint64_t kSlice = 8192;
    for (uint64_t done = 0; done < c.count;) {
      const uint64_t n = std::min(kSlice, c.count - done);
      if (records.size() < (done + n) * source.record_length) records.resize((done + n) * source.record_length);
      decoder->next(records.data() + done * source.record_length, n);
      done += n;
    }
  } catch (const CorruptStream& e) {
    // After the last point (bytes left over) the place is the last point.
    const uint64_t point = c.first_point + std::min(decoder->done, c.count - 1) + 1;
    throw LazError(chunk_place(index) + ", point " + std::to_string(point), e.problem);
  }
}

Decoder::Decoder(LaszipVlr vlr, PointSource source) : state_(std::make_unique<State>()) {
  state_->vlr = std::move(vlr);
  state_->source = std::move(source);
  state_->read_chunk_table();
}
Decoder::~Decoder() = default;
Decoder::Decoder(Decoder&&) noexcept = default;
Decoder& Decoder::operator=(Decoder&&) noexcept = default;

uint64_t Decoder::chunk_count() const { return state_->chunks.size(); }

std::vector<Decoder::Chunk> Decoder::chunks() const {
  std::vector<Chunk> list;
  for (const ChunkEntry& c : state_->chunks) list.push_back({c.offset, c.bytes, c.first_point, c.count});
  return list;
}

void Decoder::decode(const RecordSink& sink, const DecodeOptions& options) const {
  const State& s = *state_;
  const size_t n = s.chunks.size();
  if (n == 0) return;

  if (s.vlr.compressor == 1) {  // one long stream: decode it in slices, in order
    const ChunkEntry& c = s.chunks[0];
    std::vector<uint8_t> compressed(c.bytes);
    s.source.read_at(c.offset, compressed.data(), compressed.size());
    auto decoder = s.make_chunk_decoder();
    constexpr uint64_t kSlice = 65536;
    std::vector<uint8_t> records(std::min(c.count, kSlice) * s.source.record_length);
    try {
      decoder->begin({compressed.data(), compressed.size(), c.count});
      for (uint64_t done = 0; done < c.count;) {
        const uint64_t slice = std::min(kSlice, c.count - done);
        decoder->next(records.data(), slice);
        sink(records.data(), slice);
        done += slice;
      }
    } catch (const CorruptStream& e) {
      throw LazError(
          "point " + std::to_string(decoder->done + 1) + " (point data at byte " + std::to_string(c.offset) + ")",
          e.problem);
    }
    return;
  }

  const int threads = options.threads > 0 ? options.threads : tbb::this_task_arena::max_concurrency();
  if (threads == 1 || n == 1) {
    std::vector<uint8_t> compressed, records;
    for (size_t i = 0; i < n; ++i) {
      s.decode_chunk(i, compressed, records);
      sink(records.data(), s.chunks[i].count);
    }
    return;
  }

  // Read in order, decode in parallel, hand over in order: at most 2 x threads + 1 chunks live.
  // A chunk's error travels with it to the in-order stage, so that the first broken chunk in
  // file order is the one reported, whichever thread met its error first. Nothing is thrown
  // inside the pipeline: a cancelled TBB pipeline does not free the items it holds.
  // The jobs are a ring of as many as there are live chunks: chunk i enters only once chunk
  // i - live has left the last stage, so its job is free again. Buffers used again are pages
  // mapped already (a fresh 1.4 MB of records per chunk cost 7 % of the time in page faults).
  struct Job {
    size_t index = 0;
    std::vector<uint8_t> compressed, records;
    std::exception_ptr error;
  };
  const size_t live = static_cast<size_t>(2 * threads + 1);
  std::vector<Job> jobs(live);
  size_t next_chunk = 0;
  std::atomic<bool> failed{false};
  std::exception_ptr first_error;
  auto next_job = [&](tbb::flow_control& control) -> Job* {
    if (next_chunk == n || failed) {
      control.stop();
      return nullptr;
    }
    Job* job = &jobs[next_chunk % live];
    job->index = next_chunk++;
    job->error = nullptr;
    return job;
  };
  auto decode_job = [&](Job* job) {
    if (failed) return job;
    try {
      s.decode_chunk(job->index, job->compressed, job->records);
    } catch (...) {
      job->error = std::current_exception();
    }
    return job;
  };
  auto hand_over = [&](Job* job) {
    if (failed) return;
    try {
      if (job->error) std::rethrow_exception(job->error);
      sink(job->records.data(), s.chunks[job->index].count);
    } catch (...) {
      first_error = std::current_exception();
      failed = true;
    }
  };
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_pipeline(live, tbb::make_filter<void, Job*>(tbb::filter_mode::serial_in_order, next_job) &
                                     tbb::make_filter<Job*, Job*>(tbb::filter_mode::parallel, decode_job) &
                                     tbb::make_filter<Job*, void>(tbb::filter_mode::serial_in_order, hand_over));
  });
  if (first_error) std::rethrow_exception(first_error);
}

LazFile read_laz_header(const std::function<void(uint64_t, void*, size_t)>& read_at, uint64_t file_size) {
  uint8_t h[375] = {};
  if (file_size < 227)
    throw LazError("header", "the file has " + std::to_string(file_size) + " bytes, a LAS header 227");
  read_at(0, h, static_cast<size_t>(std::min<uint64_t>(file_size, sizeof h)));
  if (std::memcmp(h, "LASF", 4) != 0) throw LazError("byte 0 (signature)", "not a LAS/LAZ file");
  const int minor = h[25];
  LazFile f;
  const uint16_t header_size = load_u16(h + 94);
  f.point_offset = load_u32(h + 96);
  const uint32_t vlr_count = load_u32(h + 100);
  f.point_format = h[104] & 0x3F;
  const bool compressed = (h[104] & 0xC0) != 0;
  f.record_length = load_u16(h + 105);
  f.point_count = load_u32(h + 107);
  f.points_end = file_size;
  if (minor >= 4 && file_size >= 375) {
    if (f.point_count == 0) f.point_count = load_u64(h + 247);
    const uint64_t evlr_start = load_u64(h + 235);
    if (load_u32(h + 243) > 0 && evlr_start > f.point_offset && evlr_start <= file_size) f.points_end = evlr_start;
  }
  if (f.point_offset > file_size || header_size > f.point_offset)
    throw LazError("byte 96 (offset to point data)", std::to_string(f.point_offset) + " is not inside the file");
  if (f.record_length == 0) throw LazError("byte 105 (point record length)", "is 0");
  if (!compressed) {
    if (f.point_count > (file_size - f.point_offset) / f.record_length)
      throw LazError("byte 107 (point count)", "the points do not fit in the file");
    return f;
  }
  uint64_t pos = header_size;
  for (uint32_t k = 0; k < vlr_count; ++k) {
    const std::string place = "VLR " + std::to_string(k + 1) + " at byte " + std::to_string(pos);
    uint8_t record[54];
    if (pos + 54 > f.point_offset) throw LazError(place, "runs past the start of the point data");
    read_at(pos, record, 54);
    const uint64_t length = load_u16(record + 20);
    if (pos + 54 + length > f.point_offset) throw LazError(place, "runs past the start of the point data");
    if (strncmp(reinterpret_cast<const char*>(record + 2), kLaszipUserId, 16) == 0 &&
        load_u16(record + 18) == kLaszipRecordId) {
      std::vector<uint8_t> payload(length);
      read_at(pos + 54, payload.data(), payload.size());
      f.laszip = std::make_unique<LaszipVlr>(
          parse_laszip_vlr(payload.data(), payload.size(), f.point_format, f.record_length));
    }
    pos += 54 + length;
  }
  if (!f.laszip) throw LazError("byte 104 (point data format)", "compressed points, but no 'laszip encoded' VLR");
  return f;
}

void read_laz_records(const std::string& path, const RecordSink& sink, const DecodeOptions& options) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw LazError(path, std::string("cannot open: ") + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat info {};
  if (::fstat(fd, &info) != 0) throw LazError(path, std::string("cannot read: ") + std::strerror(errno));
  const uint64_t size = static_cast<uint64_t>(info.st_size);
  auto read_at = [fd, size, path](uint64_t offset, void* buffer, size_t bytes) {
    auto* out = static_cast<uint8_t*>(buffer);
    if (offset > size || bytes > size - offset)
      throw LazError(path + ": byte " + std::to_string(offset), "past the end of the file");
    while (bytes > 0) {
      const ssize_t got = ::pread(fd, out, bytes, static_cast<off_t>(offset));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) throw LazError(path + ": byte " + std::to_string(offset), "cannot read");
      out += got;
      offset += static_cast<uint64_t>(got);
      bytes -= static_cast<size_t>(got);
    }
  };
  try {
    LazFile f = read_laz_header(read_at, size);
    if (!f.laszip) {
      constexpr uint64_t kBlock = 65536;
      std::vector<uint8_t> records(std::min(f.point_count, kBlock) * f.record_length);
      for (uint64_t done = 0; done < f.point_count;) {
        const uint64_t n = std::min(kBlock, f.point_count - done);
        read_at(f.point_offset + done * f.record_length, records.data(), n * f.record_length);
        sink(records.data(), n);
        done += n;
      }
      return;
    }
    PointSource source{read_at, size, f.point_offset, f.point_count, f.record_length, f.points_end};
    Decoder(*f.laszip, source).decode(sink, options);
  } catch (const LazError& e) {
    if (e.place().rfind(path, 0) == 0) throw;
    throw LazError(path + (e.place().empty() ? "" : ": " + e.place()), e.problem());
  }
}

}  // namespace dsmplan::laz
