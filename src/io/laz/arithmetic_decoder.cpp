// Adaptive models of the LASzip arithmetic coder and its integer decompressor, written for dsmplan
// from the LASzip reference (github.com/LASzip/LASzip at ac3e9e9f: src/arithmeticmodel.cpp,
// src/integercompressor.cpp, src/laszip_common_v2.hpp) and A. Said, "Introduction to Arithmetic
// Coding Theory and Practice", HP Labs HPL-2004-76. The update schedules and scalings must match
// the encoder's exactly, or every symbol after the first update decodes wrong.
#include <algorithm>

#include "laz_private.hpp"

namespace dsmplan::laz::detail {

namespace {
constexpr uint32_t kBitLengthShift = 13, kBitMaxCount = 1u << kBitLengthShift;
constexpr uint32_t kSymbolLengthShift = 15, kSymbolMaxCount = 1u << kSymbolLengthShift;
}  // namespace

void BitModel::update() {
  if ((bit_count += update_cycle) > kBitMaxCount) {
    bit_count = (bit_count + 1) >> 1;
    bit_0_count = (bit_0_count + 1) >> 1;
    if (bit_0_count == bit_count) ++bit_count;
  }
  const uint32_t scale = 0x80000000u / bit_count;
  bit_0_prob = (bit_0_count * scale) >> (31 - kBitLengthShift);
  update_cycle = (5 * update_cycle) >> 2;
  if (update_cycle > 64) update_cycle = 64;
  bits_until_update = update_cycle;
}

void SymbolModel::init(uint32_t n) {
  symbols = n;
  last_symbol = n - 1;
  // Twice the smallest power of two >= the symbols, at least 64 entries (see laz_private.hpp).
  uint32_t table_bits = 5;
  while (symbols > (1u << table_bits)) ++table_bits;
  ++table_bits;
  table_size = 1u << table_bits;
  table_shift = kSymbolLengthShift - table_bits;
  block_.assign(2 * symbols + table_size + 2 + 4, 0);  // table: + 4, see update()
  reset();
}

void SymbolModel::reset() {
  total_count = 0;
  update_cycle = symbols;
  std::fill_n(symbol_count(), symbols, uint16_t{1});
  update();
  symbols_until_update = update_cycle = (symbols + 6) >> 1;
}

void SymbolModel::update() {
  if ((total_count += update_cycle) > kSymbolMaxCount) {
    total_count = 0;
    uint16_t* count = symbol_count();
    for (uint32_t k = 0; k < symbols; ++k) total_count += (count[k] = static_cast<uint16_t>((count[k] + 1) >> 1));
  }
  const uint32_t scale = 0x80000000u / total_count;
  uint32_t sum = 0;
  uint16_t* distribution = this->distribution();
  const uint16_t* symbol_count = this->symbol_count();
  uint16_t* table = decoder_table();  // 4 entries more than the decoder reads (see init)
  // Entries s+1 .. w go to symbol k-1. Four entries are written whether or not all of them do
  // (most symbols take zero to four): one past w is written again by the symbol it belongs to,
  // or by the fill after the last symbol, later than here; cheaper than a branch per entry.
  uint32_t s = 0;
  for (uint32_t k = 0; k < symbols; ++k) {
    distribution[k] = static_cast<uint16_t>((scale * sum) >> (31 - kSymbolLengthShift));
    sum += symbol_count[k];
    const uint32_t w = distribution[k] >> table_shift;  // < table_size
    table[s + 1] = table[s + 2] = table[s + 3] = table[s + 4] = static_cast<uint16_t>(k - 1);
    for (uint32_t i = s + 5; i <= w; ++i) table[i] = static_cast<uint16_t>(k - 1);
    s = std::max(s, w);
  }
  table[0] = 0;
  while (s <= table_size) table[++s] = static_cast<uint16_t>(symbols - 1);
  update_cycle = (5 * update_cycle) >> 2;
  const uint32_t max_cycle = (symbols + 6) << 3;
  if (update_cycle > max_cycle) update_cycle = max_cycle;
  symbols_until_update = update_cycle;
}

IntegerDecompressor::IntegerDecompressor(uint32_t bits, uint32_t contexts, uint32_t bits_high, uint32_t range)
    : bits_high_(bits_high) {
  if (range) {
    corr_range_ = range;
    while (range) {
      range >>= 1;
      ++corr_bits_;
    }
    if (corr_range_ == (1u << (corr_bits_ - 1))) --corr_bits_;
    corr_min_ = -static_cast<int32_t>(corr_range_ / 2);
  } else if (bits && bits < 32) {
    corr_bits_ = bits;
    corr_range_ = 1u << bits;
    corr_min_ = -static_cast<int32_t>(corr_range_ / 2);
  } else {
    corr_bits_ = 32;
    corr_range_ = 0;
    corr_min_ = INT32_MIN;
  }
  k_models_.resize(contexts);
  corrector_models_.resize(corr_bits_);
}

}  // namespace dsmplan::laz::detail
