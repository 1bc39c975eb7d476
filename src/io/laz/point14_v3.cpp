// LASzip's layered chunked compression of LAS 1.4 points (compressor 3: point formats 6-10),
// items POINT14, RGB14, RGBNIR14 and BYTE14 at version 3, written for dsmplan from the reference
// implementation's decoder (github.com/LASzip/LASzip at ac3e9e9f: src/lasreaditemcompressed_v3.cpp,
// src/laszip_common_v3.hpp, src/lasreadpoint.cpp) and its specification of the layout
// (design/specification.rst, "LASzip for LAS 1.4 (native extension)"). A chunk is its first point
// as raw record bytes, the chunk's point count, the byte size of every layer, then the layers:
// each field group (x/y and returns, z, classification, flags, intensity, ...) is its own
// arithmetic-coded stream, and an empty layer means the field never changes within the chunk.
// Every item keeps one set of models per scanner channel (four "contexts"), switched by the
// POINT14 item.
#include <array>
#include <cstring>

#include "laz_private.hpp"

namespace dsmplan::laz::detail {

namespace {

// (number of returns, return number) to 6 contexts, and to 8 penetration levels
// (laszip_common_v3.hpp: number_return_map_6ctx, number_return_level_8ctx).
constexpr uint8_t kReturnMap6[16][16] = {
    {0, 1, 2, 3, 4, 5, 3, 4, 4, 5, 5, 5, 5, 5, 5, 5}, {1, 0, 1, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3},
    {2, 1, 2, 4, 4, 4, 4, 4, 4, 4, 4, 3, 3, 3, 3, 3}, {3, 3, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {3, 3, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {4, 3, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4},
    {5, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 4, 4, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5}};
constexpr uint8_t kReturnLevel8[16][16] = {
    {0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7, 7, 7, 7, 7}, {1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7, 7, 7, 7},
    {2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7, 7, 7}, {3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7, 7},
    {4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7}, {5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7},
    {6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7}, {7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7},
    {7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7}, {7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6},
    {7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5}, {7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4},
    {7, 7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3}, {7, 7, 7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2},
    {7, 7, 7, 7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1}, {7, 7, 7, 7, 7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0}};

SymbolModel& lazy(std::unique_ptr<SymbolModel>& slot, uint32_t symbols) {
  if (!slot) slot = std::make_unique<SymbolModel>(symbols);
  return *slot;
}

// The fields of a format 6 record that the coder predicts (the legacy fields of LASzip's
// in-memory point follow from these and are not part of the record).
struct Point14 {
  int32_t x, y, z;
  uint16_t intensity;
  uint8_t return_number, number_of_returns;
  uint8_t classification_flags, scanner_channel, scan_direction, edge_of_flight_line;
  uint8_t classification, user_data;
  int16_t scan_angle;
  uint16_t point_source;
  uint64_t gps_time_bits;
  bool gps_time_change;

  static Point14 parse(const uint8_t* r) {
    Point14 p{};
    p.x = static_cast<int32_t>(load_u32(r));
    p.y = static_cast<int32_t>(load_u32(r + 4));
    p.z = static_cast<int32_t>(load_u32(r + 8));
    p.intensity = load_u16(r + 12);
    p.return_number = r[14] & 15;
    p.number_of_returns = r[14] >> 4;
    p.classification_flags = r[15] & 15;
    p.scanner_channel = (r[15] >> 4) & 3;
    p.scan_direction = (r[15] >> 6) & 1;
    p.edge_of_flight_line = r[15] >> 7;
    p.classification = r[16];
    p.user_data = r[17];
    p.scan_angle = static_cast<int16_t>(load_u16(r + 18));
    p.point_source = load_u16(r + 20);
    p.gps_time_bits = load_u64(r + 22);
    return p;
  }
  void write(uint8_t* r) const {
    store_u32(r, static_cast<uint32_t>(x));
    store_u32(r + 4, static_cast<uint32_t>(y));
    store_u32(r + 8, static_cast<uint32_t>(z));
    store_u16(r + 12, intensity);
    r[14] = static_cast<uint8_t>(return_number | number_of_returns << 4);
    r[15] = static_cast<uint8_t>(classification_flags | scanner_channel << 4 | scan_direction << 6 |
                                 edge_of_flight_line << 7);
    r[16] = classification;
    r[17] = user_data;
    store_u16(r + 18, static_cast<uint16_t>(scan_angle));
    store_u16(r + 20, point_source);
    store_u64(r + 22, gps_time_bits);
  }
};

// One arithmetic-coded layer: `changed` is false when the layer is empty (the field is constant).
struct Layer {
  uint32_t bytes = 0;
  bool changed = false;
  ArithmeticDecoder decoder;
};

struct Point14Context {
  explicit Point14Context(const Point14& from) : last(from), gps(3, from.gps_time_bits) {
    last.gps_time_change = false;
    for (auto& z : last_z) z = from.z;
    for (auto& i : last_intensity) i = from.intensity;
  }
  Point14 last;
  uint16_t last_intensity[8];
  Median5 x_steps[12], y_steps[12];
  int32_t last_z[8];
  std::array<SymbolModel, 8> changed_values = {SymbolModel(128), SymbolModel(128), SymbolModel(128), SymbolModel(128),
                                               SymbolModel(128), SymbolModel(128), SymbolModel(128), SymbolModel(128)};
  SymbolModel scanner_channel{3};
  std::unique_ptr<SymbolModel> number_of_returns[16], return_number[16];
  SymbolModel return_number_gps_same{13};
  IntegerDecompressor dx{32, 2}, dy{32, 22}, z{32, 20};
  std::unique_ptr<SymbolModel> classification[64], flags[64], user_data[64];
  IntegerDecompressor intensity{16, 4}, scan_angle{16, 2}, point_source{16};
  GpsTimeState gps;
};

class Point14Item {
public:
  static constexpr int kLayers = 9;  // xy+returns, z, classification, flags, intensity, angle, user, source, time
  Layer layers[kLayers];

  void begin(const uint8_t* first) {
    for (auto& c : contexts_) c.reset();
    const Point14 p = Point14::parse(first);
    current_ = p.scanner_channel;
    contexts_[current_] = std::make_unique<Point14Context>(p);
  }
  uint32_t context() const { return current_; }

  void decode(uint8_t* out) {
    Point14Context* c = contexts_[current_].get();
    ArithmeticDecoder& xy = layers[0].decoder;
    const Point14& before = c->last;
    const uint32_t lpr = (before.return_number == 1 ? 1u : 0u) +
                         (before.return_number >= before.number_of_returns ? 2u : 0u) +
                         (before.gps_time_change ? 4u : 0u);
    const uint32_t changed = xy.decode_symbol(c->changed_values[lpr]);
    if (changed & 64) {
      const uint32_t channel = (current_ + xy.decode_symbol(c->scanner_channel) + 1) % 4;
      if (!contexts_[channel]) contexts_[channel] = std::make_unique<Point14Context>(c->last);
      current_ = channel;
      c = contexts_[current_].get();
      c->last.scanner_channel = static_cast<uint8_t>(channel);
    }
    Point14& p = c->last;
    const bool point_source_change = changed & 32, gps_time_change = changed & 16, scan_angle_change = changed & 8;
    const uint32_t last_n = p.number_of_returns, last_r = p.return_number;
    uint32_t n = last_n;
    if (changed & 4) {
      n = xy.decode_symbol(lazy(c->number_of_returns[last_n], 16));
      p.number_of_returns = static_cast<uint8_t>(n);
    }
    uint32_t r = last_r;
    switch (changed & 3) {
      case 1:
        r = (last_r + 1) % 16;
        break;
      case 2:
        r = (last_r + 15) % 16;
        break;
      case 3:
        if (gps_time_change)
          r = xy.decode_symbol(lazy(c->return_number[last_r], 16));
        else
          r = (last_r + xy.decode_symbol(c->return_number_gps_same) + 2) % 16;
        break;
      default:
        break;
    }
    p.return_number = static_cast<uint8_t>(r);
    const uint32_t m = kReturnMap6[n][r], l = kReturnLevel8[n][r];
    const uint32_t cpr = (r == 1 ? 2u : 0u) + (r >= n ? 1u : 0u);  // first? last?

    const uint32_t steps = (m << 1) | (gps_time_change ? 1u : 0u);
    const int32_t dx = c->dx.decompress(xy, c->x_steps[steps].get(), n == 1);
    p.x = static_cast<int32_t>(static_cast<uint32_t>(p.x) + static_cast<uint32_t>(dx));
    c->x_steps[steps].add(dx);
    uint32_t k = c->dx.k();
    const int32_t dy = c->dy.decompress(xy, c->y_steps[steps].get(), (n == 1) + (k < 20 ? k & ~1u : 20));
    p.y = static_cast<int32_t>(static_cast<uint32_t>(p.y) + static_cast<uint32_t>(dy));
    c->y_steps[steps].add(dy);

    if (layers[1].changed) {
      k = (c->dx.k() + c->dy.k()) / 2;
      p.z = c->last_z[l] = c->z.decompress(layers[1].decoder, c->last_z[l], (n == 1) + (k < 18 ? k & ~1u : 18));
    }
    if (layers[2].changed) {
      const uint32_t context = ((p.classification & 0x1Fu) << 1) + (cpr == 3 ? 1u : 0u);
      p.classification = static_cast<uint8_t>(layers[2].decoder.decode_symbol(lazy(c->classification[context], 256)));
    }
    if (layers[3].changed) {
      const uint32_t last_flags = p.edge_of_flight_line << 5 | p.scan_direction << 4 | p.classification_flags;
      const uint32_t flags = layers[3].decoder.decode_symbol(lazy(c->flags[last_flags], 64));
      p.edge_of_flight_line = (flags >> 5) & 1;
      p.scan_direction = (flags >> 4) & 1;
      p.classification_flags = flags & 15;
    }
    if (layers[4].changed) {
      const uint32_t slot = (cpr << 1) | (gps_time_change ? 1u : 0u);
      p.intensity = c->last_intensity[slot] =
          static_cast<uint16_t>(c->intensity.decompress(layers[4].decoder, c->last_intensity[slot], cpr));
    }
    if (layers[5].changed && scan_angle_change)
      p.scan_angle = static_cast<int16_t>(c->scan_angle.decompress(layers[5].decoder, p.scan_angle, gps_time_change));
    if (layers[6].changed)
      p.user_data = static_cast<uint8_t>(layers[6].decoder.decode_symbol(lazy(c->user_data[p.user_data / 4], 256)));
    if (layers[7].changed && point_source_change)
      p.point_source = static_cast<uint16_t>(c->point_source.decompress(layers[7].decoder, p.point_source));
    if (layers[8].changed && gps_time_change) p.gps_time_bits = c->gps.decode(layers[8].decoder);
    p.write(out);
    p.gps_time_change = gps_time_change;
  }

private:
  std::unique_ptr<Point14Context> contexts_[4];
  uint32_t current_ = 0;
};

// RGB14 / RGBNIR14 (nir = true): models and last colours per scanner channel, following POINT14's.
class RgbNirItem {
public:
  RgbNirItem(bool nir) : nir_(nir) {}
  Layer layers[2];  // RGB, NIR
  int layer_count() const { return nir_ ? 2 : 1; }

  void begin(const uint8_t* first, uint32_t context) {
    for (auto& c : contexts_) c.reset();
    uint16_t last[4] = {};
    for (int i = 0; i < (nir_ ? 4 : 3); ++i) last[i] = load_u16(first + 2 * i);
    current_ = context;
    contexts_[current_] = std::make_unique<Context>(last);
  }

  void decode(uint8_t* out, uint32_t context) {
    if (context != current_) {
      if (!contexts_[context]) contexts_[context] = std::make_unique<Context>(contexts_[current_]->last);
      current_ = context;
    }
    Context& c = *contexts_[current_];
    if (layers[0].changed) {
      uint16_t rgb[3];
      decode_rgb(layers[0].decoder, c.rgb, c.last, rgb);
      std::memcpy(c.last, rgb, sizeof rgb);
    }
    if (nir_ && layers[1].changed) {
      ArithmeticDecoder& d = layers[1].decoder;
      const uint32_t used = d.decode_symbol(c.nir_used);
      uint32_t value = (used & 1) ? (d.decode_symbol(c.nir_diff[0]) + (c.last[3] & 0xFF)) & 0xFF : c.last[3] & 0xFF;
      value |= (used & 2) ? ((d.decode_symbol(c.nir_diff[1]) + (c.last[3] >> 8)) & 0xFF) << 8 : c.last[3] & 0xFF00;
      c.last[3] = static_cast<uint16_t>(value);
    }
    for (int i = 0; i < (nir_ ? 4 : 3); ++i) store_u16(out + 2 * i, c.last[i]);
  }

private:
  struct Context {
    explicit Context(const uint16_t from[4]) { std::memcpy(last, from, sizeof last); }
    uint16_t last[4];
    RgbModels rgb;
    SymbolModel nir_used{4};
    SymbolModel nir_diff[2] = {SymbolModel(256), SymbolModel(256)};
  };
  bool nir_;
  std::unique_ptr<Context> contexts_[4];
  uint32_t current_ = 0;
};

// BYTE14: one layer per extra byte.
class Byte14Item {
public:
  explicit Byte14Item(uint32_t count) : layers(count) {}
  std::vector<Layer> layers;

  void begin(const uint8_t* first, uint32_t context) {
    for (auto& c : contexts_) c.reset();
    current_ = context;
    contexts_[current_] = std::make_unique<Context>(first, layers.size());
  }

  void decode(uint8_t* out, uint32_t context) {
    if (context != current_) {
      if (!contexts_[context])
        contexts_[context] = std::make_unique<Context>(contexts_[current_]->last.data(), layers.size());
      current_ = context;
    }
    Context& c = *contexts_[current_];
    for (size_t i = 0; i < layers.size(); ++i) {
      if (layers[i].changed) c.last[i] = static_cast<uint8_t>(c.last[i] + layers[i].decoder.decode_symbol(c.models[i]));
      out[i] = c.last[i];
    }
  }

private:
  struct Context {
    Context(const uint8_t* from, size_t count) : last(from, from + count) {
      models.reserve(count);
      for (size_t i = 0; i < count; ++i) models.emplace_back(256);
    }
    std::vector<uint8_t> last;
    std::vector<SymbolModel> models;
  };
  std::unique_ptr<Context> contexts_[4];
  uint32_t current_ = 0;
};

class LayeredDecoder final : public ChunkDecoder {
public:
  LayeredDecoder(const std::vector<Item>& items, uint32_t record_length) : record_length_(record_length) {
    uint32_t offset = 0;
    for (const Item& it : items) {
      if (it.type == kPoint14) {
        point_offset_ = offset;
      } else if (it.type == kRgb14 || it.type == kRgbNir14) {
        rgb_ = std::make_unique<RgbNirItem>(it.type == kRgbNir14);
        rgb_offset_ = offset;
      } else {  // kByte14
        bytes_ = std::make_unique<Byte14Item>(it.size);
        bytes_offset_ = offset;
      }
      offset += it.size;
    }
    for (auto& layer : point_.layers) all_layers_.push_back(&layer);
    if (rgb_)
      for (int i = 0; i < rgb_->layer_count(); ++i) all_layers_.push_back(&rgb_->layers[i]);
    if (bytes_)
      for (auto& layer : bytes_->layers) all_layers_.push_back(&layer);
  }

  void begin(const ChunkInput& input) override {
    input_ = input;
    done = 0;
    if (input.count == 0) return;
    const uint64_t header = uint64_t{record_length_} + 4 + 4 * all_layers_.size();
    if (input.size < header)
      throw CorruptStream{"the chunk has " + std::to_string(input.size) + " bytes, less than the " +
                          std::to_string(header) + " of its first point and layer table"};
    const uint8_t* p = input.bytes + record_length_;
    const uint32_t count = load_u32(p);
    // LASzip writes the chunk's point count here; its specification's text says "remaining"
    // points (one fewer): either is taken, anything else is a lie.
    if (count != input.count && uint64_t{count} + 1 != input.count)
      throw CorruptStream{"the chunk says it holds " + std::to_string(count) + " points, the chunk table " +
                          std::to_string(input.count)};
    p += 4;
    uint64_t total = 0;
    for (Layer* layer : all_layers_) {
      layer->bytes = load_u32(p);
      p += 4;
      total += layer->bytes;
    }
    if (header + total > input.size)
      throw CorruptStream{"its layers add up to " + std::to_string(header + total) + " bytes, but the chunk has " +
                          std::to_string(input.size) + " (truncated chunk or lying layer sizes)"};
    const uint8_t* layer_bytes = input.bytes + header;
    for (Layer* layer : all_layers_) {
      layer->changed = layer->bytes > 0;
      if (layer->changed) layer->decoder.start(layer_bytes, layer_bytes + layer->bytes);
      layer_bytes += layer->bytes;
    }
    // The x/y layer is always coded when the chunk has more than its first point.
    if (input.count > 1 && !point_.layers[0].changed) throw CorruptStream{"its x/y layer is empty"};
    point_.begin(input.bytes + point_offset_);
    if (rgb_) rgb_->begin(input.bytes + rgb_offset_, point_.context());
    if (bytes_) bytes_->begin(input.bytes + bytes_offset_, point_.context());
  }

  void next(uint8_t* out, uint64_t n) override {
    for (uint64_t i = 0; i < n; ++i, out += record_length_) {
      if (done == 0) {
        std::memcpy(out, input_.bytes, record_length_);
      } else {
        point_.decode(out + point_offset_);
        if (rgb_) rgb_->decode(out + rgb_offset_, point_.context());
        if (bytes_) bytes_->decode(out + bytes_offset_, point_.context());
        for (const Layer* layer : all_layers_)
          if (layer->changed && layer->decoder.overrun() > 0)
            throw CorruptStream{
                "a layer's compressed data ends before the point does (truncated chunk or lying "
                "layer sizes)"};
      }
      ++done;
    }
    // As in the point-wise chunks, a layer that is not used up exactly betrays a lying count.
    if (done == input_.count && input_.count > 1)
      for (const Layer* layer : all_layers_)
        if (layer->changed && layer->decoder.remaining() > 0)
          throw CorruptStream{std::to_string(layer->decoder.remaining()) +
                              " bytes of a layer are left after the chunk's last point (a point count or layer "
                              "size that lies)"};
  }

private:
  uint32_t record_length_;
  ChunkInput input_{};
  Point14Item point_;
  std::unique_ptr<RgbNirItem> rgb_;
  std::unique_ptr<Byte14Item> bytes_;
  uint32_t point_offset_ = 0, rgb_offset_ = 0, bytes_offset_ = 0;
  std::vector<Layer*> all_layers_;
};

}  // namespace

std::unique_ptr<ChunkDecoder> make_layered_decoder(const std::vector<Item>& items, uint32_t record_length) {
  return std::make_unique<LayeredDecoder>(items, record_length);
}

}  // namespace dsmplan::laz::detail
