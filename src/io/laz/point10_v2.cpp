// LASzip's point-wise compression (compressors 1 and 2: point formats 0-5 of LAS 1.0-1.4), items
// POINT10, GPSTIME11, RGB12 and BYTE at version 2, written for dsmplan from the reference
// implementation's decoder (github.com/LASzip/LASzip at ac3e9e9f: src/lasreaditemcompressed_v2.cpp,
// src/laszip_common_v2.hpp, src/lasreadpoint.cpp). A chunk is its first point as raw record bytes,
// then one arithmetic-coded stream in which every later point's items follow one another.
#include <array>
#include <cstring>

#include "laz_private.hpp"

namespace dsmplan::laz::detail {

namespace {

// Contexts by (number of returns, return number), "completed" for files that number returns
// from 0 or swap the two fields (laszip_common_v2.hpp).
constexpr uint8_t kReturnMap[8][8] = {{15, 14, 13, 12, 11, 10, 9, 8},  {14, 0, 1, 3, 6, 10, 10, 9},
                                      {13, 1, 2, 4, 7, 11, 11, 10},    {12, 3, 4, 5, 8, 12, 12, 11},
                                      {11, 6, 7, 8, 9, 13, 13, 12},    {10, 10, 11, 12, 13, 14, 14, 13},
                                      {9, 10, 11, 12, 13, 14, 15, 14}, {8, 9, 10, 11, 12, 13, 14, 15}};
constexpr uint8_t kReturnLevel[8][8] = {{0, 1, 2, 3, 4, 5, 6, 7}, {1, 0, 1, 2, 3, 4, 5, 6}, {2, 1, 0, 1, 2, 3, 4, 5},
                                        {3, 2, 1, 0, 1, 2, 3, 4}, {4, 3, 2, 1, 0, 1, 2, 3}, {5, 4, 3, 2, 1, 0, 1, 2},
                                        {6, 5, 4, 3, 2, 1, 0, 1}, {7, 6, 5, 4, 3, 2, 1, 0}};

// A model that exists only once its context has occurred (most of the 256 never do).
SymbolModel& lazy(std::unique_ptr<SymbolModel>& slot) {
  if (!slot) slot = std::make_unique<SymbolModel>(256);
  return *slot;
}

class ItemDecoder {
public:
  virtual ~ItemDecoder() = default;
  virtual void decode(ArithmeticDecoder& decoder, uint8_t* out) = 0;
};

class Point10 final : public ItemDecoder {
public:
  explicit Point10(const uint8_t* first) {
    std::memcpy(last_, first, 20);
    last_[12] = last_[13] = 0;  // the intensity is predicted from per-return history, not the first point
  }

  void decode(ArithmeticDecoder& d, uint8_t* out) override {
    const uint32_t changed = d.decode_symbol(changed_values_);
    if (changed) {
      if (changed & 32) last_[14] = static_cast<uint8_t>(d.decode_symbol(lazy(return_flags_[last_[14]])));
    }
    const uint32_t r = last_[14] & 7, n = (last_[14] >> 3) & 7;
    const uint32_t m = kReturnMap[n][r], l = kReturnLevel[n][r];
    if (changed) {
      if (changed & 16) {
        last_intensity_[m] = static_cast<uint16_t>(intensity_.decompress(d, last_intensity_[m], m < 3 ? m : 3));
        store_u16(last_ + 12, last_intensity_[m]);
      } else {
        store_u16(last_ + 12, last_intensity_[m]);
      }
      if (changed & 8) last_[15] = static_cast<uint8_t>(d.decode_symbol(lazy(classification_[last_[15]])));
      if (changed & 4) {
        const uint32_t delta = d.decode_symbol(scan_angle_rank_[(last_[14] >> 6) & 1]);
        last_[16] = static_cast<uint8_t>(delta + last_[16]);
      }
      if (changed & 2) last_[17] = static_cast<uint8_t>(d.decode_symbol(lazy(user_data_[last_[17]])));
      if (changed & 1) store_u16(last_ + 18, static_cast<uint32_t>(point_source_.decompress(d, load_u16(last_ + 18))));
    }

    const int32_t dx = dx_.decompress(d, x_steps_[m].get(), n == 1);
    store_u32(last_, load_u32(last_) + static_cast<uint32_t>(dx));
    x_steps_[m].add(dx);
    uint32_t k = dx_.k();
    const int32_t dy = dy_.decompress(d, y_steps_[m].get(), (n == 1) + (k < 20 ? k & ~1u : 20));
    store_u32(last_ + 4, load_u32(last_ + 4) + static_cast<uint32_t>(dy));
    y_steps_[m].add(dy);
    k = (dx_.k() + dy_.k()) / 2;
    last_height_[l] = z_.decompress(d, last_height_[l], (n == 1) + (k < 18 ? k & ~1u : 18));
    store_u32(last_ + 8, static_cast<uint32_t>(last_height_[l]));
    std::memcpy(out, last_, 20);
  }

private:
  uint8_t last_[20];
  uint16_t last_intensity_[16] = {};
  int32_t last_height_[8] = {};
  Median5 x_steps_[16], y_steps_[16];
  SymbolModel changed_values_{64};
  IntegerDecompressor intensity_{16, 4};
  SymbolModel scan_angle_rank_[2] = {SymbolModel(256), SymbolModel(256)};
  IntegerDecompressor point_source_{16};
  std::unique_ptr<SymbolModel> return_flags_[256], classification_[256], user_data_[256];
  IntegerDecompressor dx_{32, 2}, dy_{32, 22}, z_{32, 20};
};

class GpsTime11 final : public ItemDecoder {
public:
  explicit GpsTime11(const uint8_t* first) : state_(2, load_u64(first)) {}
  void decode(ArithmeticDecoder& d, uint8_t* out) override { store_u64(out, state_.decode(d)); }

private:
  GpsTimeState state_;
};

class Rgb12 final : public ItemDecoder {
public:
  explicit Rgb12(const uint8_t* first) {
    for (int i = 0; i < 3; ++i) last_[i] = load_u16(first + 2 * i);
  }
  void decode(ArithmeticDecoder& d, uint8_t* out) override {
    uint16_t rgb[3];
    decode_rgb(d, models_, last_, rgb);
    for (int i = 0; i < 3; ++i) store_u16(out + 2 * i, last_[i] = rgb[i]);
  }

private:
  uint16_t last_[3];
  RgbModels models_;
};

class Bytes final : public ItemDecoder {
public:
  Bytes(const uint8_t* first, uint32_t count) : last_(first, first + count) {
    models_.reserve(count);
    for (uint32_t i = 0; i < count; ++i) models_.emplace_back(256);
  }
  void decode(ArithmeticDecoder& d, uint8_t* out) override {
    for (size_t i = 0; i < last_.size(); ++i)
      out[i] = last_[i] = static_cast<uint8_t>(last_[i] + d.decode_symbol(models_[i]));
  }

private:
  std::vector<uint8_t> last_;
  std::vector<SymbolModel> models_;
};

class PointwiseDecoder final : public ChunkDecoder {
public:
  PointwiseDecoder(std::vector<Item> items, uint32_t record_length)
      : items_(std::move(items)), record_length_(record_length) {}

  void begin(const ChunkInput& input) override {
    input_ = input;
    done = 0;
    if (input.count == 0) return;
    if (input.size < record_length_)
      throw CorruptStream{"the chunk has " + std::to_string(input.size) + " bytes, less than its first point's " +
                          std::to_string(record_length_)};
    // Every chunk starts afresh: new models, predictions from its first point.
    decoders_.clear();
    const uint8_t* item = input.bytes;
    for (const Item& it : items_) {
      switch (it.type) {
        case kPoint10:
          decoders_.push_back(std::make_unique<Point10>(item));
          break;
        case kGpsTime11:
          decoders_.push_back(std::make_unique<GpsTime11>(item));
          break;
        case kRgb12:
          decoders_.push_back(std::make_unique<Rgb12>(item));
          break;
        default:
          decoders_.push_back(std::make_unique<Bytes>(item, it.size));
          break;  // kByte
      }
      item += it.size;
    }
    decoder_.start(input.bytes + record_length_, input.bytes + input.size);
  }

  void next(uint8_t* out, uint64_t n) override {
    for (uint64_t i = 0; i < n; ++i, out += record_length_) {
      if (done == 0) {
        std::memcpy(out, input_.bytes, record_length_);
      } else {
        uint8_t* item = out;
        for (size_t j = 0; j < decoders_.size(); ++j) {
          decoders_[j]->decode(decoder_, item);
          item += items_[j].size;
        }
        if (decoder_.overrun() > 0)
          throw CorruptStream{"the compressed data ends before the point does (truncated chunk or lying chunk table)"};
      }
      ++done;
    }
    // LASzip's encoder ends a stream so that its decoder stops exactly at the last byte: bytes
    // left over mean the chunk holds more points than the table or header says.
    if (done == input_.count && input_.count > 1 && decoder_.remaining() > 0)
      throw CorruptStream{std::to_string(decoder_.remaining()) +
                          " compressed bytes are left after the chunk's last point (a point count or chunk size "
                          "that lies)"};
  }

private:
  std::vector<Item> items_;
  uint32_t record_length_;
  ChunkInput input_{};
  std::vector<std::unique_ptr<ItemDecoder>> decoders_;
  ArithmeticDecoder decoder_;
};

}  // namespace

GpsTimeState::GpsTimeState(int version, uint64_t first_time_bits)
    : version_(version), multi_(version == 2 ? 516 : 515), zero_diff_(version == 2 ? 6 : 5) {
  last_time_[0] = first_time_bits;
}

uint64_t GpsTimeState::decode(ArithmeticDecoder& d) {
  // Codes of the multiplier model: 500 the largest multiple, down to -10; then (v2) "unchanged",
  // "full 64-bit time", and switches to one of the other three sequences.
  constexpr int32_t kMulti = 500, kMultiMinus = -10;
  const int32_t unchanged = version_ == 2 ? kMulti - kMultiMinus + 1 : -1;  // v3 has no such code
  const int32_t code_full = version_ == 2 ? kMulti - kMultiMinus + 2 : kMulti - kMultiMinus + 1;
  auto full_time = [&] {
    next_ = (next_ + 1) & 3;
    const auto high = static_cast<uint32_t>(diff_.decompress(d, static_cast<int32_t>(last_time_[last_] >> 32), 8));
    last_time_[next_] = uint64_t{high} << 32 | d.read_int();
    last_ = next_;
    last_diff_[last_] = 0;
    extreme_count_[last_] = 0;
  };
  auto add = [&](int32_t diff) { last_time_[last_] += static_cast<uint64_t>(static_cast<int64_t>(diff)); };
  auto times = [](int32_t a, int32_t b) {  // the encoder's 32-bit product, wrapping as it does
    return static_cast<int32_t>(static_cast<uint32_t>(a) * static_cast<uint32_t>(b));
  };
  auto extreme = [&](int32_t diff) {
    if (++extreme_count_[last_] > 3) {
      last_diff_[last_] = diff;
      extreme_count_[last_] = 0;
    }
  };

  // A switch to another sequence decodes that sequence's next time; a valid stream never
  // switches twice in a row, a corrupt one must not loop.
  for (int switches = 0; switches < 8; ++switches) {
    if (last_diff_[last_] == 0) {
      int32_t multi = static_cast<int32_t>(d.decode_symbol(zero_diff_));
      if (version_ == 2) {
        if (multi == 0) return last_time_[last_];
        --multi;  // from here on the v2 codes are the v3 codes plus one
      }
      if (multi == 0) {
        last_diff_[last_] = diff_.decompress(d, 0, 0);
        add(last_diff_[last_]);
        extreme_count_[last_] = 0;
      } else if (multi == 1) {
        full_time();
      } else {
        last_ = (last_ + static_cast<uint32_t>(multi) - 1) & 3;
        continue;
      }
      return last_time_[last_];
    }

    const int32_t multi = static_cast<int32_t>(d.decode_symbol(multi_));
    const int32_t last_diff = last_diff_[last_];
    if (multi == 1) {
      add(diff_.decompress(d, last_diff, 1));
      extreme_count_[last_] = 0;
    } else if (multi == unchanged) {
    } else if (multi < code_full) {
      int32_t diff;
      if (multi == 0) {
        diff = diff_.decompress(d, 0, 7);
        extreme(diff);
      } else if (multi < kMulti) {
        diff = diff_.decompress(d, times(multi, last_diff), multi < 10 ? 2 : 3);
      } else if (multi == kMulti) {
        diff = diff_.decompress(d, times(kMulti, last_diff), 4);
        extreme(diff);
      } else {
        const int32_t negative = kMulti - multi;
        if (negative > kMultiMinus) {
          diff = diff_.decompress(d, times(negative, last_diff), 5);
        } else {
          diff = diff_.decompress(d, times(kMultiMinus, last_diff), 6);
          extreme(diff);
        }
      }
      add(diff);
    } else if (multi == code_full) {
      full_time();
    } else {
      last_ = (last_ + static_cast<uint32_t>(multi - code_full)) & 3;
      continue;
    }
    return last_time_[last_];
  }
  throw CorruptStream{"the GPS time code switches sequences without end"};
}

void decode_rgb(ArithmeticDecoder& d, RgbModels& m, const uint16_t last[3], uint16_t out[3]) {
  auto clamp = [](int v) { return v <= 0 ? 0 : v >= 255 ? 255 : v; };
  auto fold = [](uint32_t v) { return static_cast<uint16_t>(v & 0xFF); };
  const uint32_t used = d.decode_symbol(m.byte_used);
  out[0] = (used & 1) ? fold(d.decode_symbol(m.diff[0]) + (last[0] & 0xFF)) : static_cast<uint16_t>(last[0] & 0xFF);
  out[0] |= (used & 2) ? static_cast<uint16_t>(fold(d.decode_symbol(m.diff[1]) + (last[0] >> 8)) << 8)
                       : static_cast<uint16_t>(last[0] & 0xFF00);
  if (!(used & 64)) {  // grey: green and blue equal red
    out[1] = out[2] = out[0];
    return;
  }
  int diff = (out[0] & 0xFF) - (last[0] & 0xFF);
  out[1] = (used & 4) ? fold(d.decode_symbol(m.diff[2]) + clamp(diff + (last[1] & 0xFF)))
                      : static_cast<uint16_t>(last[1] & 0xFF);
  if (used & 16) {
    diff = (diff + ((out[1] & 0xFF) - (last[1] & 0xFF))) / 2;
    out[2] = fold(d.decode_symbol(m.diff[4]) + clamp(diff + (last[2] & 0xFF)));
  } else {
    out[2] = static_cast<uint16_t>(last[2] & 0xFF);
  }
  diff = (out[0] >> 8) - (last[0] >> 8);
  out[1] |= (used & 8) ? static_cast<uint16_t>(fold(d.decode_symbol(m.diff[3]) + clamp(diff + (last[1] >> 8))) << 8)
                       : static_cast<uint16_t>(last[1] & 0xFF00);
  if (used & 32) {
    diff = (diff + ((out[1] >> 8) - (last[1] >> 8))) / 2;
    out[2] |= static_cast<uint16_t>(fold(d.decode_symbol(m.diff[5]) + clamp(diff + (last[2] >> 8))) << 8);
  } else {
    out[2] |= static_cast<uint16_t>(last[2] & 0xFF00);
  }
}

std::unique_ptr<ChunkDecoder> make_pointwise_decoder(const std::vector<Item>& items, uint32_t record_length) {
  return std::make_unique<PointwiseDecoder>(items, record_length);
}

}  // namespace dsmplan::laz::detail
