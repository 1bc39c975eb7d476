// LAZ in (issue 20). The oracles are independent of the decoder under test:
//  - every .laz in data/ has a .las twin (the same points, decompressed by LASzip/laspy): its
//    records are read here with memcpy at the offsets of the ASPRS LAS 1.4 R15 specification and
//    compared byte for byte with the decoder's;
//  - the DSMs gridded from the two are compared as files and, through GDAL, as pixels;
//  - to make chunk tables (variable chunks, lying tables) this file has its own arithmetic
//    *encoder*, written from A. Said, HPL-2004-76, and the LASzip specification's encoder side
//    (github.com/LASzip/LASzip at ac3e9e9f: src/arithmeticencoder.cpp, src/arithmeticmodel.cpp,
//    src/integercompressor.cpp); a table it writes that the decoder reads back to the LAS twin's
//    records checks both.
#include "dsmplan/laz.hpp"

#include <gdal.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"
#include "testkit.hpp"

namespace {

namespace laz = dsmplan::laz;

template <typename T>
T get(const std::string& bytes, size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof value);  // LAS and the test hosts are little-endian
  return value;
}
template <typename T>
void put(std::string& bytes, size_t offset, T value) {
  std::memcpy(bytes.data() + offset, &value, sizeof value);
}

struct Las {
  uint32_t header_size, point_offset;
  uint16_t record_length;
  uint64_t count;
  std::string records;
};

Las parse_las(const std::string& bytes) {
  Las las{};
  las.header_size = get<uint16_t>(bytes, 94);
  las.point_offset = get<uint32_t>(bytes, 96);
  las.record_length = get<uint16_t>(bytes, 105);
  las.count = get<uint32_t>(bytes, 107);
  if (las.count == 0 && bytes[25] >= 4) las.count = get<uint64_t>(bytes, 247);
  las.records = bytes.substr(las.point_offset, las.count * las.record_length);
  return las;
}

// Offset of the "laszip encoded" VLR's payload.
size_t laszip_payload(const std::string& bytes) {
  size_t pos = get<uint16_t>(bytes, 94);
  for (uint32_t k = 0; k < get<uint32_t>(bytes, 100); ++k) {
    if (std::string(bytes.data() + pos + 2) == "laszip encoded" && get<uint16_t>(bytes, pos + 18) == 22204)
      return pos + 54;
    pos += 54 + get<uint16_t>(bytes, pos + 20);
  }
  ADD_FAILURE() << "no laszip VLR";
  return 0;
}

// Records of a LAZ file through the public decoder, record length taken from the header.
std::string decoded_records(const std::string& path, int threads) {
  const std::string bytes = testkit::read_file(path);
  const uint16_t length = get<uint16_t>(bytes, 105);
  std::string records;
  laz::read_laz_records(
      path, [&](const uint8_t* r, size_t n) { records.append(reinterpret_cast<const char*>(r), n * length); },
      {threads});
  return records;
}

// The first differing record, or -1: a mismatch names the point instead of printing megabytes.
int64_t first_difference(const std::string& a, const std::string& b, size_t length) {
  for (size_t i = 0; i < std::min(a.size(), b.size()); i += length)
    if (a.compare(i, length, b, i, length) != 0) return static_cast<int64_t>(i / length);
  return a.size() == b.size() ? -1 : static_cast<int64_t>(std::min(a.size(), b.size()) / length);
}

struct Pair {
  std::string laz, las;
};
const std::vector<Pair>& pairs() {
  static const std::vector<Pair> list = {
      {testkit::data_path("delft-ahn3/ahn3_cropped_1.laz"), testkit::data_path("delft-ahn3/ahn3_cropped_1.las")},
      {testkit::data_path("delft-ahn3/ahn3_cropped_2.laz"), testkit::data_path("delft-ahn3/ahn3_cropped_2.las")},
      {testkit::data_path("laz-conformance/simple.laz"), testkit::data_path("laz-conformance/simple.las")},
      {testkit::data_path("laz-conformance/1_4_w_evlr.laz"), testkit::data_path("laz-conformance/1_4_w_evlr.las")}};
  return list;
}

// ---- an arithmetic encoder, for chunk tables -------------------------------------------------

constexpr uint32_t kMinLength = 0x01000000u;

struct EncBitModel {
  uint32_t bit_0_count = 1, bit_count = 2, bit_0_prob = 1u << 12, update_cycle = 4, until = 4;
  void update() {
    if ((bit_count += update_cycle) > (1u << 13)) {
      bit_count = (bit_count + 1) >> 1;
      bit_0_count = (bit_0_count + 1) >> 1;
      if (bit_0_count == bit_count) ++bit_count;
    }
    bit_0_prob = (bit_0_count * (0x80000000u / bit_count)) >> 18;
    update_cycle = std::min<uint32_t>((5 * update_cycle) >> 2, 64);
    until = update_cycle;
  }
};

struct EncModel {
  explicit EncModel(uint32_t n) : symbols(n), count(n, 1), distribution(n) {
    update_cycle = n;
    update();
    until = update_cycle = (n + 6) >> 1;
  }
  void update() {
    if ((total += update_cycle) > (1u << 15)) {
      total = 0;
      for (auto& c : count) total += (c = (c + 1) >> 1);
    }
    const uint32_t scale = 0x80000000u / total;
    uint32_t sum = 0;
    for (uint32_t k = 0; k < symbols; ++k) {
      distribution[k] = (scale * sum) >> 16;
      sum += count[k];
    }
    update_cycle = std::min((5 * update_cycle) >> 2, (symbols + 6) << 3);
    until = update_cycle;
  }
  uint32_t symbols, total = 0, update_cycle = 0, until = 0;
  std::vector<uint32_t> count, distribution;
};

class Encoder {
public:
  void symbol(EncModel& m, uint32_t s) {
    const uint32_t init = base_;
    if (s == m.symbols - 1) {
      const uint32_t x = m.distribution[s] * (length_ >> 15);
      base_ += x;
      length_ -= x;
    } else {
      const uint32_t x = m.distribution[s] * (length_ >>= 15);
      base_ += x;
      length_ = m.distribution[s + 1] * length_ - x;
    }
    if (init > base_) carry();
    if (length_ < kMinLength) renormalize();
    ++m.count[s];
    if (--m.until == 0) m.update();
  }
  void bit(EncBitModel& m, uint32_t b) {
    const uint32_t x = m.bit_0_prob * (length_ >> 13);
    if (b == 0) {
      length_ = x;
      ++m.bit_0_count;
    } else {
      const uint32_t init = base_;
      base_ += x;
      length_ -= x;
      if (init > base_) carry();
    }
    if (length_ < kMinLength) renormalize();
    if (--m.until == 0) m.update();
  }
  void bits(uint32_t n, uint32_t value) {
    if (n > 19) {
      bits(16, value & 0xFFFF);
      value >>= 16;
      n -= 16;
    }
    const uint32_t init = base_;
    base_ += value * (length_ >>= n);
    if (init > base_) carry();
    if (length_ < kMinLength) renormalize();
  }
  std::string done() {
    const uint32_t init = base_;
    bool another = true;
    if (length_ > 2 * kMinLength) {
      base_ += kMinLength;
      length_ = kMinLength >> 1;
    } else {
      base_ += kMinLength >> 1;
      length_ = kMinLength >> 9;
      another = false;
    }
    if (init > base_) carry();
    renormalize();
    out_ += std::string(another ? 3 : 2, '\0');
    return out_;
  }

private:
  void carry() {
    size_t i = out_.size();
    while (static_cast<uint8_t>(out_[--i]) == 0xFF) out_[i] = 0;
    ++out_[i];
  }
  void renormalize() {
    do {
      out_ += static_cast<char>(base_ >> 24);
      base_ <<= 8;
    } while ((length_ <<= 8) < kMinLength);
  }
  uint32_t base_ = 0, length_ = 0xFFFFFFFFu;
  std::string out_;
};

// LASzip's integer compressor with 32 bits and 2 contexts: the chunk table's.
class IntegerEncoder {
public:
  IntegerEncoder() {
    for (int i = 0; i < 2; ++i) k_models_.emplace_back(33);
    for (uint32_t k = 1; k <= 32; ++k) correctors_.emplace_back(k <= 8 ? 1u << k : 256u);
  }
  void compress(Encoder& e, int32_t prediction, int32_t real, int context) {
    const int32_t c = static_cast<int32_t>(static_cast<uint32_t>(real) - static_cast<uint32_t>(prediction));
    uint32_t c1 = c <= 0 ? 0u - static_cast<uint32_t>(c) : static_cast<uint32_t>(c) - 1;
    uint32_t k = 0;
    while (c1) {
      c1 >>= 1;
      ++k;
    }
    e.symbol(k_models_[context], k);
    if (k == 0) {
      e.bit(zero_or_one_, static_cast<uint32_t>(c));
    } else if (k < 32) {
      const uint32_t v = c < 0 ? static_cast<uint32_t>(c) + ((1u << k) - 1) : static_cast<uint32_t>(c) - 1;
      if (k <= 8) {
        e.symbol(correctors_[k - 1], v);
      } else {
        e.symbol(correctors_[k - 1], v >> (k - 8));
        e.bits(k - 8, v & ((1u << (k - 8)) - 1));
      }
    }
  }

private:
  std::vector<EncModel> k_models_, correctors_;
  EncBitModel zero_or_one_;
};

// A chunk table (version 0) of these chunks; with counts when the chunks are variable.
std::string chunk_table(const std::vector<laz::Decoder::Chunk>& chunks, bool variable) {
  std::string table(8, '\0');
  put<uint32_t>(table, 4, static_cast<uint32_t>(chunks.size()));
  Encoder e;
  IntegerEncoder ic;
  uint32_t last_count = 0, last_bytes = 0;
  for (const auto& c : chunks) {
    if (variable) ic.compress(e, static_cast<int32_t>(last_count), static_cast<int32_t>(c.count), 0);
    ic.compress(e, static_cast<int32_t>(last_bytes), static_cast<int32_t>(c.bytes), 1);
    last_count = static_cast<uint32_t>(c.count);
    last_bytes = static_cast<uint32_t>(c.bytes);
  }
  return table + e.done();
}

std::vector<laz::Decoder::Chunk> chunks_of(const std::string& path) {
  const std::string bytes = testkit::read_file(path);
  auto read_at = [&](uint64_t offset, void* buffer, size_t n) { std::memcpy(buffer, bytes.data() + offset, n); };
  laz::LazFile f = laz::read_laz_header(read_at, bytes.size());
  laz::PointSource source{read_at, bytes.size(), f.point_offset, f.point_count, f.record_length, f.points_end};
  return laz::Decoder(*f.laszip, source).chunks();
}

// `bytes` (a LAZ of format 0-3 whose chunk table ends the file) with its table replaced.
std::string with_table(std::string bytes, const std::string& table, bool variable, bool pointer_at_end = false) {
  const uint32_t point_offset = get<uint32_t>(bytes, 96);
  const int64_t table_at = get<int64_t>(bytes, point_offset);
  bytes.resize(static_cast<size_t>(table_at));
  bytes += table;
  if (variable) put<uint32_t>(bytes, laszip_payload(bytes) + 12, 0xFFFFFFFFu);
  if (pointer_at_end) {
    put<int64_t>(bytes, point_offset, -1);
    bytes.append(8, '\0');
    put<int64_t>(bytes, bytes.size() - 8, table_at);
  }
  return bytes;
}

// Reads `path` with read_las and checks the one-line InputError: it names the file and holds
// every fragment.
void expect_refused(const std::string& path, const std::vector<std::string>& fragments) {
  SCOPED_TRACE(path);
  try {
    dsmplan::read_las(path);
    ADD_FAILURE() << "no error";
  } catch (const dsmplan::InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    for (const auto& fragment : fragments) EXPECT_NE(message.find(fragment), std::string::npos) << message;
    if (std::getenv("LAZ_TEST_PRINT")) std::printf("%s\n", message.c_str());
  }
}

// ---- exact ------------------------------------------------------------------------------------

TEST(Laz, EveryRecordEqualsItsLasTwin) {
  for (const Pair& pair : pairs()) {
    SCOPED_TRACE(pair.laz);
    const Las las = parse_las(testkit::read_file(pair.las));
    const std::string decoded = decoded_records(pair.laz, 2);
    EXPECT_EQ(decoded.size() / las.record_length, las.count);
    EXPECT_EQ(first_difference(decoded, las.records, las.record_length), -1);
  }
}

TEST(Laz, OneThreadAndTwoGiveTheSameRecords) {
  for (const Pair& pair : {pairs()[1], pairs()[2], pairs()[3]}) {
    SCOPED_TRACE(pair.laz);
    EXPECT_TRUE(decoded_records(pair.laz, 1) == decoded_records(pair.laz, 2));
  }
}

TEST(Laz, ReadLasGivesTheSamePointsAndCrs) {
  for (const Pair& pair : {pairs()[1], pairs()[3]}) {
    SCOPED_TRACE(pair.laz);
    const dsmplan::PointCloud from_laz = dsmplan::read_las(pair.laz), from_las = dsmplan::read_las(pair.las);
    EXPECT_EQ(from_laz.x, from_las.x);
    EXPECT_EQ(from_laz.y, from_las.y);
    EXPECT_EQ(from_laz.z, from_las.z);
    EXPECT_EQ(from_laz.classification, from_las.classification);
    EXPECT_EQ(from_laz.crs.definition, from_las.crs.definition);
    EXPECT_EQ(from_laz.crs.known(), pair.laz.find("1_4_w_evlr") != std::string::npos);  // Delft's has none
  }
}

// The DSM of both Delft crops, from the LAZ and from the LAS, through the CLI as users run it.
TEST(Laz, TheDsmFromLazEqualsTheDsmFromLas) {
  testkit::TempDir dir;
  auto grid = [&](const std::string& extension, const std::string& out) {
    const auto r = testkit::run_cli({"grid", testkit::data_path("delft-ahn3/ahn3_cropped_1" + extension),
                                     testkit::data_path("delft-ahn3/ahn3_cropped_2" + extension), "-o", out, "--res",
                                     "0.5", "--crs", "EPSG:28992", "-q"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
  };
  grid(".laz", dir.path("from_laz.tif"));
  grid(".las", dir.path("from_las.tif"));
  EXPECT_TRUE(testkit::read_file(dir.path("from_laz.tif")) == testkit::read_file(dir.path("from_las.tif")));

  auto pixels = [](const std::string& path) {
    GDALDatasetH ds = GDALOpen(path.c_str(), GA_ReadOnly);
    EXPECT_NE(ds, nullptr);
    const int w = GDALGetRasterXSize(ds), h = GDALGetRasterYSize(ds);
    std::vector<float> values(static_cast<size_t>(w) * h);
    EXPECT_EQ(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Read, 0, 0, w, h, values.data(), w, h, GDT_Float32, 0, 0),
              CE_None);
    GDALClose(ds);
    return values;
  };
  const std::vector<float> a = pixels(dir.path("from_laz.tif")), b = pixels(dir.path("from_las.tif"));
  ASSERT_GT(a.size(), 100000u);
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0);
  EXPECT_EQ(a.size(), b.size());
}

// ---- layouts the data files do not have ---------------------------------------------------

// The same five Delft chunks declared variable (counts in the table), and the table found through
// the file's last 8 bytes (a writer that could not seek back).
TEST(Laz, VariableChunksAndATableAtTheEnd) {
  const Pair& pair = pairs()[1];
  const std::vector<laz::Decoder::Chunk> chunks = chunks_of(pair.laz);
  ASSERT_EQ(chunks.size(), 5u);
  EXPECT_EQ(chunks[4].count, 208432u - 4 * 50000u);
  const std::string original = testkit::read_file(pair.laz);
  const Las las = parse_las(testkit::read_file(pair.las));
  testkit::TempDir dir;

  // First: our encoder's fixed-size table must be the file's own, byte for byte.
  const int64_t table_at = get<int64_t>(original, get<uint32_t>(original, 96));
  EXPECT_TRUE(chunk_table(chunks, false) == original.substr(static_cast<size_t>(table_at)));

  for (bool at_end : {false, true}) {
    const std::string path = dir.path(at_end ? "variable_end.laz" : "variable.laz");
    testkit::write_file(path, with_table(original, chunk_table(chunks, true), true, at_end));
    EXPECT_EQ(first_difference(decoded_records(path, 2), las.records, las.record_length), -1) << path;
  }
}

// Compressor 1: one stream, no chunk table (LASzip 2.0's point-wise, unchunked layout). A chunk
// of compressor 2 is exactly such a stream.
std::string unchunked(const std::string& chunked) {
  const uint32_t point_offset = get<uint32_t>(chunked, 96);
  const int64_t table_at = get<int64_t>(chunked, point_offset);
  std::string bytes = chunked.substr(0, point_offset) +
                      chunked.substr(point_offset + 8, static_cast<size_t>(table_at) - point_offset - 8);
  put<uint16_t>(bytes, laszip_payload(bytes), 1);
  return bytes;
}

TEST(Laz, UnchunkedPointwiseStream) {
  const Pair& pair = pairs()[2];
  testkit::TempDir dir;
  const std::string path = dir.path("unchunked.laz");
  testkit::write_file(path, unchunked(testkit::read_file(pair.laz)));
  const Las las = parse_las(testkit::read_file(pair.las));
  EXPECT_EQ(first_difference(decoded_records(path, 1), las.records, las.record_length), -1);
  const dsmplan::PointCloud cloud = dsmplan::read_las(path);
  EXPECT_EQ(cloud.x.size(), las.count);
}

// ---- hostile: one line naming the file, the place and the problem -------------------------

TEST(Laz, TruncatedFilesAndChunks) {
  testkit::TempDir dir;
  const std::string simple = testkit::read_file(pairs()[2].laz);
  std::string path = dir.path("cut.laz");
  testkit::write_file(path, simple.substr(0, simple.size() * 6 / 10));
  expect_refused(path, {"chunk table offset at byte 333", "truncated file?"});

  // A stream that ends inside its points: the decoder runs out of bytes.
  const std::string stream = unchunked(simple);
  path = dir.path("cut_stream.laz");
  testkit::write_file(path, stream.substr(0, stream.size() * 6 / 10));
  expect_refused(path, {"point ", "(point data at byte 333)", "ends before the point does"});

  // A layered chunk cut inside its layers (the chunk table copied to the new end).
  std::string layered = testkit::read_file(pairs()[3].laz);
  const uint32_t point_offset = get<uint32_t>(layered, 96);
  const int64_t table_at = get<int64_t>(layered, point_offset);
  std::string cut =
      layered.substr(0, static_cast<size_t>(table_at) - 500) + layered.substr(static_cast<size_t>(table_at));
  put<int64_t>(cut, point_offset, table_at - 500);
  put<uint64_t>(cut, 235, get<uint64_t>(cut, 235) - 500);  // the EVLRs moved too
  path = dir.path("cut_layers.laz");
  testkit::write_file(path, cut);
  expect_refused(path, {"chunk table at byte", "up to"});
}

TEST(Laz, LyingChunkTables) {
  testkit::TempDir dir;
  const Pair& pair = pairs()[1];
  const std::string original = testkit::read_file(pair.laz);
  const auto chunks = chunks_of(pair.laz);
  auto refused = [&](const std::string& name, std::vector<laz::Decoder::Chunk> lie, bool variable,
                     const std::vector<std::string>& fragments) {
    const std::string path = dir.path(name);
    testkit::write_file(path, with_table(original, chunk_table(lie, variable), variable));
    expect_refused(path, fragments);
  };
  auto lie = chunks;
  lie[2].bytes += 100;  // sizes that run past the table
  refused("sizes.laz", lie, false, {"chunk table at byte", "up to"});
  lie = chunks;
  lie[0].count += 1;  // counts that do not sum to the header's
  refused("counts.laz", lie, true, {"its chunks hold 208433 points, the header counts 208432"});
  lie = chunks;
  lie[0].count += 1;  // counts that sum, but not per chunk
  lie[1].count -= 1;
  refused("shifted_counts.laz", lie, true, {"chunk 1 of 5 at byte 337", "point 5000"});
  lie = chunks;
  lie[1].bytes += 1000;  // sizes that sum, but not per chunk
  lie[2].bytes -= 1000;
  refused("shifted_sizes.laz", lie, false, {"chunk 2 of 5 at byte"});

  std::string bytes = original;
  const uint32_t point_offset = get<uint32_t>(bytes, 96);
  put<uint32_t>(bytes, static_cast<size_t>(get<int64_t>(bytes, point_offset)), 1);
  testkit::write_file(dir.path("version.laz"), bytes);
  expect_refused(dir.path("version.laz"), {"chunk table at byte", "version 1 (LASzip writes 0)"});

  bytes = original;
  put<uint32_t>(bytes, static_cast<size_t>(get<int64_t>(bytes, point_offset)) + 4, 1000000);
  testkit::write_file(dir.path("many_chunks.laz"), bytes);
  expect_refused(dir.path("many_chunks.laz"), {"1000000 chunks cannot fit"});

  bytes = original;
  put<int64_t>(bytes, point_offset, 1'000'000'000'000);
  testkit::write_file(dir.path("pointer.laz"), bytes);
  expect_refused(dir.path("pointer.laz"), {"chunk table offset at byte 329", "1000000000000"});

  // A layered chunk whose own count disagrees with the table, and layers larger than the chunk.
  std::string layered = testkit::read_file(pairs()[3].laz);
  const size_t chunk = get<uint32_t>(layered, 96) + 8;
  bytes = layered;
  put<uint32_t>(bytes, chunk + 30, 777);
  testkit::write_file(dir.path("layer_count.laz"), bytes);
  expect_refused(dir.path("layer_count.laz"),
                 {"chunk 1 of 1 at byte 2407, point 1", "the chunk says it holds 777 points, the chunk table 1000"});
  bytes = layered;
  put<uint32_t>(bytes, chunk + 34 + 4, get<uint32_t>(bytes, chunk + 34 + 4) + 100000);
  testkit::write_file(dir.path("layer_size.laz"), bytes);
  expect_refused(dir.path("layer_size.laz"), {"chunk 1 of 1", "lying layer sizes"});
  bytes = layered;
  put<uint32_t>(bytes, chunk + 34 + 4, get<uint32_t>(bytes, chunk + 34 + 4) - 100);  // z layer shorter
  testkit::write_file(dir.path("layer_short.laz"), bytes);
  expect_refused(dir.path("layer_short.laz"), {"chunk 1 of 1"});

  // A header count far beyond what the compressed bytes could hold is refused before anything.
  bytes = testkit::read_file(pairs()[2].laz);
  put<uint32_t>(bytes, 107, 4'000'000'000u);
  testkit::write_file(dir.path("count.laz"), bytes);
  expect_refused(dir.path("count.laz"), {"byte 107 (point count)", "compressed"});
}

TEST(Laz, WrongCompressorVersionOrItem) {
  testkit::TempDir dir;
  const std::string simple = testkit::read_file(pairs()[2].laz);
  const size_t vlr = laszip_payload(simple);
  auto refused = [&](const std::string& name, size_t offset, uint16_t value,
                     const std::vector<std::string>& fragments) {
    std::string bytes = simple;
    put<uint16_t>(bytes, offset, value);
    testkit::write_file(dir.path(name), bytes);
    expect_refused(dir.path(name), fragments);
  };
  refused("compressor9.laz", vlr, 9, {"laszip VLR", "unknown compressor 9"});
  refused("compressor3.laz", vlr, 3, {"laszip VLR", "compressor 3 with point format 3"});
  refused("coder.laz", vlr + 2, 1, {"laszip VLR", "unknown coder 1"});
  refused("item_version.laz", vlr + 34 + 4, 1, {"item 1 (POINT10) version 1 is not supported"});
  refused("item_type.laz", vlr + 34 + 6, 42, {"item 2 (unknown item type 42) where point format 3 has GPSTIME11"});
  refused("item_size.laz", vlr + 34 + 2, 21, {"item 1 (POINT10) of 21 bytes"});
  refused("wave_packets.laz", vlr + 34 + 12, 9, {"item 3 (WAVEPACKET13)"});

  std::string bytes = simple;
  bytes[104] = static_cast<char>(0x80 | 5);  // format 5: wave packets
  put<uint16_t>(bytes, 105, 63);
  testkit::write_file(dir.path("format5.laz"), bytes);
  expect_refused(dir.path("format5.laz"), {"laszip VLR", "point format 5"});
}

// Nothing is written when the input is refused (the CLI writes atomically).
TEST(Laz, GridWritesNothingFromABrokenLaz) {
  testkit::TempDir dir;
  const std::string simple = testkit::read_file(pairs()[2].laz);
  testkit::write_file(dir.path("cut.laz"), simple.substr(0, simple.size() / 2));
  const auto r = testkit::run_cli(
      {"grid", dir.path("cut.laz"), "-o", dir.path("dsm.tif"), "--res", "1", "--crs", "EPSG:32615", "-q"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(dir.path("cut.laz")), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif")));
}

}  // namespace
