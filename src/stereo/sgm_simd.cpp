// The per-row kernels of Semi-Global Matching (H. Hirschmüller, "Stereo Processing by Semiglobal
// Matching and Mutual Information", IEEE PAMI 30(2), 2008): the Census cost (Zabih & Woodfill,
// ECCV 1994) fused with the path recurrence (eq. 13) in saturated 16-bit integers, and the
// winner-takes-all search of both images (sec. 3.4), in the manner of the SIMD SGM of
// Gehrig & Rabe ("Real-time semi-global matching on the CPU", CVPR Workshops 2010) and
// Spangenberg et al. ("Large scale semi-global matching on the CPU", IEEE IV 2014).
//
// sgm_kernels.inc is compiled four times: for SSE2 (the x86-64 baseline), inside a
// target("avx2") region for AVX2, for AVX2 whose Hamming distances use AVX-512's VPOPCNTQ
// (AVX512VL + AVX512_VPOPCNTDQ: a third fewer instructions per pixel and disparity), and for
// AVX-512BW with 32 lanes (half the instructions again, where D16 is a multiple of 32; other
// rows take the 256-bit kernel); best_simd() picks the best one the CPU has at run time. All
// compute the same integers (tests/stereo_test.cpp checks them against each other and a scalar
// reference).
// Everything instruction-set specific has internal linkage, so no AVX2 copy of a shared inline
// function can be picked by the linker for the baseline code.
//
// Popcount without a popcount instruction: SSE2 by the bit-parallel sums of Wegner/Knuth
// (TAOCP 7.1.3), AVX2 by the nibble table of Muła, Kurz and Lemire ("Faster population counts
// using AVX2 instructions", The Computer Journal 61(1), 2018); both end with PSADBW.
#include <immintrin.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>

#include "stereo/sgm_parts.hpp"

namespace dsmplan::stereo {

namespace {

namespace sse2 {

using vec = __m128i;
constexpr int lanes = 8;
inline vec loadu(const std::int16_t* p) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); }
inline void storeu(std::int16_t* p, vec v) { _mm_storeu_si128(reinterpret_cast<__m128i*>(p), v); }
inline void stream(std::int16_t* p, vec v) { _mm_stream_si128(reinterpret_cast<__m128i*>(p), v); }
inline vec set1(std::int16_t v) { return _mm_set1_epi16(v); }
inline vec adds(vec a, vec b) { return _mm_adds_epi16(a, b); }
inline vec subs(vec a, vec b) { return _mm_subs_epi16(a, b); }
inline vec add(vec a, vec b) { return _mm_add_epi16(a, b); }
inline vec vmin(vec a, vec b) { return _mm_min_epi16(a, b); }
inline vec vand(vec a, vec b) { return _mm_and_si128(a, b); }
inline vec vandnot(vec a, vec b) { return _mm_andnot_si128(a, b); }
inline vec vor(vec a, vec b) { return _mm_or_si128(a, b); }
inline vec select_gt(vec a, vec b, vec if_greater, vec otherwise) {
  const vec greater = _mm_cmpgt_epi16(a, b);
  return _mm_or_si128(_mm_and_si128(greater, if_greater), _mm_andnot_si128(greater, otherwise));
}
inline vec iota() { return _mm_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7); }
inline int first_equal(vec a, vec b) {
  const int mask = _mm_movemask_epi8(_mm_cmpeq_epi16(a, b));
  return mask ? std::countr_zero(static_cast<unsigned>(mask)) / 2 : -1;
}
inline std::int16_t hmin(vec v) {
  v = _mm_min_epi16(v, _mm_srli_si128(v, 8));
  v = _mm_min_epi16(v, _mm_srli_si128(v, 4));
  v = _mm_min_epi16(v, _mm_srli_si128(v, 2));
  return static_cast<std::int16_t>(_mm_cvtsi128_si32(v));
}
// Two 64-bit Hamming distances, one per 64-bit lane.
inline vec popcount2(vec census, const std::uint64_t* words) {
  vec v = _mm_xor_si128(census, _mm_loadu_si128(reinterpret_cast<const __m128i*>(words)));
  v = _mm_sub_epi64(v, _mm_and_si128(_mm_srli_epi64(v, 1), _mm_set1_epi8(0x55)));
  v = _mm_add_epi64(_mm_and_si128(v, _mm_set1_epi8(0x33)), _mm_and_si128(_mm_srli_epi64(v, 2), _mm_set1_epi8(0x33)));
  v = _mm_and_si128(_mm_add_epi64(v, _mm_srli_epi64(v, 4)), _mm_set1_epi8(0x0f));
  return _mm_sad_epu8(v, _mm_setzero_si128());
}
inline vec popcounts(std::uint64_t census, const std::uint64_t* words) {
  const vec c = _mm_set1_epi64x(static_cast<long long>(census));
  const vec ab = _mm_packs_epi32(popcount2(c, words), popcount2(c, words + 2));
  const vec cd = _mm_packs_epi32(popcount2(c, words + 4), popcount2(c, words + 6));
  return _mm_packs_epi32(ab, cd);
}

#include "stereo/sgm_kernels.inc"

}  // namespace sse2

}  // namespace

// ---- AVX2 ------------------------------------------------------------------------------------
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif

namespace {

namespace avx2 {

#include "stereo/sgm_avx2_ops.inc"
#include "stereo/sgm_kernels.inc"

}  // namespace avx2

void sweep_row_avx2(const SweepRow& row) { avx2::sweep_row_any(row); }
void cost_pixel_avx2(const SweepRow& row, int x, std::int16_t* out) { avx2::cost_pixel_impl(row, x, out); }
void winners_row_avx2(const std::int16_t* sums, int width, int d16, std::int32_t* best, std::int16_t* right_cost,
                      std::int16_t* best_right) {
  avx2::winners_row_impl(sums, width, d16, best, right_cost, best_right);
}

}  // namespace

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

// ---- AVX2 with AVX-512's VPOPCNTQ ------------------------------------------------------------
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,avx512vl,avx512vpopcntdq"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,avx512vl,avx512vpopcntdq")
#endif

namespace {

namespace vpopcnt {

#define DSMPLAN_SGM_VPOPCNTQ
#include "stereo/sgm_avx2_ops.inc"
#undef DSMPLAN_SGM_VPOPCNTQ
#include "stereo/sgm_kernels.inc"

}  // namespace vpopcnt

void sweep_row_vpopcnt(const SweepRow& row) { vpopcnt::sweep_row_any(row); }
void cost_pixel_vpopcnt(const SweepRow& row, int x, std::int16_t* out) { vpopcnt::cost_pixel_impl(row, x, out); }

}  // namespace

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

// ---- AVX-512 (BW + VPOPCNTDQ): 32 lanes ------------------------------------------------------
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,avx512f,avx512bw,avx512vl,avx512vpopcntdq"))), \
                             apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,avx512f,avx512bw,avx512vl,avx512vpopcntdq")
// GCC 12 takes the deliberately undefined vectors inside its own AVX-512 intrinsics for
// uninitialised variables.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace {

namespace avx512 {

#include "stereo/sgm_avx512_ops.inc"
#include "stereo/sgm_kernels.inc"

}  // namespace avx512

void sweep_row_avx512(const SweepRow& row) { avx512::sweep_row_any(row); }
void cost_pixel_avx512(const SweepRow& row, int x, std::int16_t* out) { avx512::cost_pixel_impl(row, x, out); }
void winners_row_avx512(const std::int16_t* sums, int width, int d16, std::int32_t* best, std::int16_t* right_cost,
                        std::int16_t* best_right) {
  avx512::winners_row_impl(sums, width, d16, best, right_cost, best_right);
}

}  // namespace

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif

// ---- dispatch --------------------------------------------------------------------------------

Simd best_simd() {
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl") &&
      __builtin_cpu_supports("avx512vpopcntdq"))
    return Simd::avx512;
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512vpopcntdq"))
    return Simd::avx2_vpopcnt;
  return __builtin_cpu_supports("avx2") ? Simd::avx2 : Simd::sse2;
}

const char* simd_name(Simd simd) {
  if (simd == Simd::avx512) return "AVX-512";
  return simd == Simd::avx2_vpopcnt ? "AVX2+VPOPCNTQ" : simd == Simd::avx2 ? "AVX2" : "SSE2";
}

// The AVX-512 kernels take D16 a whole vector (32) at a time; other rows go 16 at a time.
static bool whole_vectors(int d16) { return d16 % 32 == 0; }

void sweep_row(const SweepRow& row, Simd simd) {
  if (simd == Simd::avx512 && whole_vectors(row.d16)) return sweep_row_avx512(row);
  if (simd == Simd::avx2_vpopcnt || simd == Simd::avx512) return sweep_row_vpopcnt(row);
  if (simd == Simd::avx2) return sweep_row_avx2(row);
  sse2::sweep_row_any(row);
}

void cost_pixel(const SweepRow& row, int x, std::int16_t* out, Simd simd) {
  if (simd == Simd::avx512 && whole_vectors(row.d16)) return cost_pixel_avx512(row, x, out);
  if (simd == Simd::avx2_vpopcnt || simd == Simd::avx512) return cost_pixel_vpopcnt(row, x, out);
  if (simd == Simd::avx2) return cost_pixel_avx2(row, x, out);
  sse2::cost_pixel_impl(row, x, out);
}

void winners_row(const std::int16_t* sums, int width, int d16, int /*num_disparities*/, std::int32_t* best,
                 std::int16_t* right_cost, std::int16_t* best_right, Simd simd) {
  if (simd == Simd::avx512 && whole_vectors(d16))
    return winners_row_avx512(sums, width, d16, best, right_cost, best_right);
  if (simd != Simd::sse2) return winners_row_avx2(sums, width, d16, best, right_cost, best_right);
  sse2::winners_row_impl(sums, width, d16, best, right_cost, best_right);
}

}  // namespace dsmplan::stereo
