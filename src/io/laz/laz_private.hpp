// The LASzip decoder's inner parts: the arithmetic decoder and its adaptive models, the integer
// decompressor, and the chunk decoders of the two LASzip layouts. Written for dsmplan from the
// LASzip specification as its reference implementation states it (github.com/LASzip/LASzip,
// commit ac3e9e9f: src/arithmeticdecoder.cpp, src/arithmeticmodel.cpp, src/integercompressor.cpp,
// src/lasreadpoint.cpp, src/lasreaditemcompressed_v2.cpp, src/lasreaditemcompressed_v3.cpp,
// src/laszip_common_v2.hpp, src/laszip_common_v3.hpp), which follows A. Said, "Introduction to
// Arithmetic Coding Theory and Practice", HP Labs HPL-2004-76. No code is taken from LASzip: the
// numbers (model sizes, contexts, update schedules) must match its encoder bit for bit, the code
// around them is ours.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/laz.hpp"

namespace dsmplan::laz::detail {

// Little-endian fields of a LAS point record (the items read and write them in place).
inline uint16_t load_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
inline uint32_t load_u32(const uint8_t* p) {
  return uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
}
inline uint64_t load_u64(const uint8_t* p) { return uint64_t{load_u32(p)} | uint64_t{load_u32(p + 4)} << 32; }
inline void store_u16(uint8_t* p, uint32_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
inline void store_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline void store_u64(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}

// A stream the decoder cannot follow: thrown deep inside a chunk and turned into a LazError
// naming the chunk, the point and the byte by the code that knows them.
struct CorruptStream {
  std::string problem;
};

// Bytes of one arithmetic-coded stream. Past its end it yields zeros and counts them: a valid
// encoder pads its streams so that the decoder never reads past the end, so an overrun means a
// truncated or lying chunk, reported after the point that caused it (never a read out of bounds).
class ByteSource {
public:
  ByteSource() = default;
  ByteSource(const uint8_t* begin, const uint8_t* end) : data_(begin), size_(static_cast<size_t>(end - begin)) {}
  uint8_t get() {
    const uint8_t byte = pos_ < size_ ? data_[pos_] : 0;
    ++pos_;
    return byte;
  }
  // The next four bytes, big-endian (zeros past the end), without moving on: one bounds check
  // for all of them while four bytes remain, byte by byte near the end.
  uint32_t peek4() const {
    if (pos_ + 4 <= size_) {
      uint32_t word;
      std::memcpy(&word, data_ + pos_, 4);
      if constexpr (std::endian::native == std::endian::little) word = __builtin_bswap32(word);
      return word;
    }
    uint32_t word = 0;
    for (size_t i = pos_; i < pos_ + 4; ++i) word = word << 8 | (i < size_ ? data_[i] : 0);
    return word;
  }
  void skip(uint32_t bytes) { pos_ += bytes; }
  size_t overrun() const { return pos_ > size_ ? pos_ - size_ : 0; }
  size_t remaining() const { return pos_ < size_ ? size_ - pos_ : 0; }

private:
  const uint8_t* data_ = nullptr;
  size_t size_ = 0, pos_ = 0;
};

// Adaptive binary model (Said's "adaptive bit model"; 13-bit probabilities).
struct BitModel {
  uint32_t bit_0_count = 1, bit_count = 2, bit_0_prob = 1u << 12, update_cycle = 4, bits_until_update = 4;
  void update();
};

// Adaptive multi-symbol model (15-bit cumulative distribution). LASzip gives only models of more
// than 16 symbols a decoder table, of a quarter to half an entry per symbol, and finds the symbol
// by bisection between two entries (or, without a table, by bisection over all symbols). Here
// every model has one, of two to four entries per symbol (at least 64): the entries bracket the
// symbol so closely that the search mostly ends at once, where each step of a bisection is a
// branch the processor cannot predict (one to two entries per symbol: 4 % slower; four to eight:
// no faster, dearer updates). The table only speeds up the search: the decoded symbol is the
// same (the update schedule, which the encoder shares, is unchanged).
class SymbolModel {
public:
  SymbolModel() = default;  // no symbols yet: init() before use (models made on first use)
  explicit SymbolModel(uint32_t symbols) { init(symbols); }
  void init(uint32_t symbols);
  void reset();  // back to the equiprobable start, as at the beginning of every chunk
  void update();

  uint32_t symbols = 0;
  uint32_t last_symbol = 0;
  uint32_t table_size = 0, table_shift = 0;
  uint32_t total_count = 0, update_cycle = 0, symbols_until_update = 0;

  // The distribution, the symbol counts and the decoder table, in one block of 16-bit numbers
  // (more models stay in the L1 cache): the distribution is below 2^15; the counts add up to
  // total_count, at most 2^15 plus one update cycle ((516 + 6) * 8) before the update halves
  // them; the symbols (table entries) number at most 516.
  uint16_t* distribution() { return block_.data(); }
  uint16_t* symbol_count() { return block_.data() + symbols; }
  uint16_t* decoder_table() { return block_.data() + 2 * symbols; }

private:
  std::vector<uint16_t> block_;
};

class ArithmeticDecoder {
public:
  void start(const uint8_t* begin, const uint8_t* end) {
    source_ = ByteSource(begin, end);
    length_ = 0xFFFFFFFFu;
    value_ = uint32_t{source_.get()} << 24;
    value_ |= uint32_t{source_.get()} << 16;
    value_ |= uint32_t{source_.get()} << 8;
    value_ |= uint32_t{source_.get()};
  }
  size_t overrun() const { return source_.overrun(); }
  size_t remaining() const { return source_.remaining(); }

  uint32_t decode_bit(BitModel& m) {
    const uint32_t x = m.bit_0_prob * (length_ >> 13);
    uint32_t bit;
    if (value_ < x) {
      bit = 0;
      length_ = x;
      ++m.bit_0_count;
    } else {
      bit = 1;
      value_ -= x;
      length_ -= x;
    }
    renormalize();  // without a branch, as in decode_symbol
    if (--m.bits_until_update == 0) m.update();
    return bit;
  }

  // The hot path of the whole decoder (about a dozen symbols a point): inlined into the items.
  [[gnu::always_inline]] uint32_t decode_symbol(SymbolModel& m) {
    uint32_t symbol, x, y = length_;
    const uint16_t* distribution = m.distribution();
    length_ >>= 15;
    const uint32_t scaled = value_ / length_;
    // A valid stream keeps value < length, so the index is at most table_size; a corrupt one
    // must not read past the table.
    const uint32_t t = std::min(scaled >> m.table_shift, m.table_size);
    const uint16_t* table = m.decoder_table();
    symbol = table[t];
    uint32_t upper = table[t + 1] + 1;
    while (upper > symbol + 1) {
      const uint32_t middle = (symbol + upper) >> 1;
      if (distribution[middle] > scaled)
        upper = middle;
      else
        symbol = middle;
    }
    x = uint32_t{distribution[symbol]} * length_;
    if (symbol != m.last_symbol) y = uint32_t{distribution[symbol + 1]} * length_;
    value_ -= x;
    length_ = y - x;
    // Without a branch: whether a symbol needs new bytes is as unpredictable as the symbol.
    renormalize();
    ++m.symbol_count()[symbol];
    if (--m.symbols_until_update == 0) m.update();
    return symbol;
  }

  // Raw bits (uniform), at most 32.
  uint32_t read_bits(uint32_t bits) {
    if (bits > 19) {
      const uint32_t low = read_short();
      return (read_bits(bits - 16) << 16) | low;
    }
    length_ >>= bits;
    const uint32_t value = value_ / length_;
    value_ -= length_ * value;
    renormalize();  // without a branch, as in decode_symbol
    if (value >= (1u << bits)) throw CorruptStream{"the arithmetic code is corrupt (raw bits out of range)"};
    return value;
  }
  uint32_t read_short() { return read_bits(16); }
  uint32_t read_int() {
    const uint32_t low = read_short();
    return (read_short() << 16) | low;
  }

private:
  // Shifts in bytes until length >= 2^24 again: as many as length has leading zero bytes
  // (none when it is large enough; length is never 0, every symbol keeps a share of it, and
  // "| 1" spares the compiler a branch for 0). The bytes come in as one 64-bit shift of value
  // and the next four bytes: no loop, no branch on how many.
  void renormalize() {
    const uint32_t shift = static_cast<uint32_t>(std::countl_zero(length_ | 1)) & 24;  // 0, 8, 16 or 24
    value_ = static_cast<uint32_t>(((uint64_t{value_} << 32) | source_.peek4()) >> (32 - shift));
    length_ <<= shift;
    source_.skip(shift >> 3);
  }

  uint32_t value_ = 0, length_ = 0;
  ByteSource source_;
};

// LASzip's integer compressor, decoding side: a corrector c = real - prediction coded as its bit
// length k (one symbol model per context) and then its value within that length class.
class IntegerDecompressor {
public:
  explicit IntegerDecompressor(uint32_t bits = 16, uint32_t contexts = 1, uint32_t bits_high = 8, uint32_t range = 0);

  int32_t decompress(ArithmeticDecoder& decoder, int32_t prediction, uint32_t context = 0) {
    const int32_t corrector = read_corrector(decoder, k_model(context));
    if (corr_range_ == 0)  // 32 bits: the sum wraps around
      return static_cast<int32_t>(static_cast<uint32_t>(prediction) + static_cast<uint32_t>(corrector));
    int64_t real = int64_t{prediction} + corrector;
    if (real < 0)
      real += corr_range_;
    else if (real >= int64_t{corr_range_})
      real -= corr_range_;
    return static_cast<int32_t>(real);
  }
  // The bit length class of the last corrector: the next coordinate's context depends on it.
  uint32_t k() const { return k_; }

private:
  // Models come into being when first used: a fresh model is what LASzip's per-chunk reset
  // makes of an existing one, and most of the 32 length classes never occur in a chunk. They
  // are held by value, not behind pointers: the model of a corrector depends on the symbol just
  // decoded, so every pointer to follow would lengthen the chain from one symbol to the next.
  SymbolModel& k_model(uint32_t context) {
    SymbolModel& m = k_models_[context];
    if (m.symbols == 0) m.init(corr_bits_ + 1);
    return m;
  }
  SymbolModel& corrector_model(uint32_t k) {
    SymbolModel& m = corrector_models_[k - 1];
    if (m.symbols == 0) m.init(k <= bits_high_ ? 1u << k : 1u << bits_high_);
    return m;
  }

  int32_t read_corrector(ArithmeticDecoder& decoder, SymbolModel& bits_model) {
    k_ = decoder.decode_symbol(bits_model);
    if (k_ == 0) return static_cast<int32_t>(decoder.decode_bit(zero_or_one_));
    if (k_ >= 32) return corr_min_;
    uint32_t c = decoder.decode_symbol(corrector_model(k_));
    if (k_ > bits_high_) {  // the high bits through the model, the low ones raw
      const uint32_t low_bits = k_ - bits_high_;
      c = (c << low_bits) | decoder.read_bits(low_bits);
    }
    // c in [0, 2^k): the upper half are the positive correctors 2^(k-1)+1 .. 2^k (c + 1), the
    // lower half the negative ones -(2^k-1) .. -2^(k-1) (c + 1 - 2^k). Without a branch (the
    // sign is a coin toss); unsigned arithmetic: k = 31 must not overflow.
    const uint32_t negative = c < (1u << (k_ - 1)) ? 1u << k_ : 0u;
    return static_cast<int32_t>(c + 1 - negative);
  }

  uint32_t bits_high_;
  uint32_t corr_bits_ = 0, corr_range_ = 0;
  int32_t corr_min_ = 0;
  uint32_t k_ = 0;
  std::vector<SymbolModel> k_models_;          // per context
  BitModel zero_or_one_;                       // k == 0: the corrector is 0 or 1
  std::vector<SymbolModel> corrector_models_;  // index k-1 for k in 1..corr_bits
};

// The running median of the last five values (LASzip's StreamingMedian5): predicts x and y steps.
// Its five values stay sorted; a new one replaces the largest or the smallest, by turns that
// depend on where the values fall (high_: the largest goes), and the median is the middle one.
// LASzip shifts the values with a branch at each comparison, coin tosses for noisy coordinates;
// here the new value goes into the four kept ones by a min/max insertion, which has no branch
// and gives the same five values in the same order.
class Median5 {
public:
  void add(int32_t v) {
    int32_t* s = values_;
    const int32_t* kept = s + (high_ ? 0 : 1);  // an index, not a branch per value
    const int32_t a[4] = {kept[0], kept[1], kept[2], kept[3]};
    // Next time the largest goes if v is below the median (or equal to it, after the smallest
    // went): v < median + 1 in 64 bits, again no branch.
    const bool high = int64_t{v} < int64_t{s[2]} + (high_ ? 0 : 1);
    s[0] = std::min(a[0], v);
    s[1] = std::min(a[1], std::max(a[0], v));
    s[2] = std::min(a[2], std::max(a[1], v));
    s[3] = std::min(a[3], std::max(a[2], v));
    s[4] = std::max(a[3], v);
    high_ = high;
  }
  int32_t get() const { return values_[2]; }

private:
  int32_t values_[5] = {0, 0, 0, 0, 0};
  bool high_ = true;
};

// GPS time of LASzip's GPSTIME11 v2 and POINT14 v3 (which differ only in the codes of the
// "difference was zero" model): four interleaved time sequences, each predicted by its last
// integer difference times a small multiplier.
class GpsTimeState {
public:
  GpsTimeState(int version, uint64_t first_time_bits);
  uint64_t decode(ArithmeticDecoder& decoder);  // the next time's bits
  uint64_t current() const { return last_time_[last_]; }

private:
  int version_;
  uint32_t last_ = 0, next_ = 0;
  uint64_t last_time_[4] = {};
  int32_t last_diff_[4] = {};
  int32_t extreme_count_[4] = {};
  SymbolModel multi_;
  SymbolModel zero_diff_;
  IntegerDecompressor diff_{32, 9};
};

// RGB of RGB12 v2 and RGB14/RGBNIR14 v3 (the same coding): `last` and `out` hold r, g, b.
struct RgbModels {
  SymbolModel byte_used{128};
  SymbolModel diff[6] = {SymbolModel(256), SymbolModel(256), SymbolModel(256),
                         SymbolModel(256), SymbolModel(256), SymbolModel(256)};
};
void decode_rgb(ArithmeticDecoder& decoder, RgbModels& models, const uint16_t last[3], uint16_t out[3]);

// One chunk's points, decoded from its bytes. `records` receives count records of
// record_length bytes. Throws CorruptStream (the point index within the chunk is in `done`).
struct ChunkInput {
  const uint8_t* bytes;
  size_t size;
  uint64_t count;
};

class ChunkDecoder {
public:
  virtual ~ChunkDecoder() = default;
  // Decodes points [done, done + n) of the current chunk into `out`; begin() starts a chunk.
  virtual void begin(const ChunkInput& input) = 0;
  virtual void next(uint8_t* out, uint64_t n) = 0;
  uint64_t done = 0;  // points of the current chunk decoded so far (for error messages)
};

std::unique_ptr<ChunkDecoder> make_pointwise_decoder(const std::vector<Item>& items, uint32_t record_length);
std::unique_ptr<ChunkDecoder> make_layered_decoder(const std::vector<Item>& items, uint32_t record_length);

}  // namespace dsmplan::laz::detail
