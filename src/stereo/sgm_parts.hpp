// The parts of Semi-Global Matching (H. Hirschmüller, "Stereo Processing by Semiglobal Matching
// and Mutual Information", IEEE PAMI 30(2), 2008) as dsmplan splits them, one source file each:
//   census_cost.cpp       the Census transform (Zabih & Woodfill, ECCV 1994) and the Hamming cost
//   sgm_aggregate.cpp     the two sweeps over the image that sum the 8 (or 4) paths, and a scalar
//                         reference of the recurrence for the tests
//   sgm_simd.cpp          the per-row kernels (cost, path step, winners) for SSE2, AVX2, AVX-512
//   disparity_refine.cpp  sub-pixel step, right image's disparity, left-right check
//   speckle_filter.cpp    the removal of small segments
//   sgm_match.cpp         sgm_match(): checks, bands of rows, the steps in order
// Private to src/stereo and the tests.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "dsmplan/stereo.hpp"

namespace dsmplan::stereo {

// ---- census_cost.cpp -------------------------------------------------------------------------

/// The image's pixels as 16-bit values, width x height, contiguous.
std::vector<std::uint16_t> to_u16(const ImageView& image, int row0, int rows);

/// Census transform of a width x height image: per pixel, one bit per window pixel other than the
/// centre, in row-major window order (the first neighbour is the most significant of the
/// census_width * census_height - 1 bits), set where the neighbour is darker than the centre.
/// Window coordinates are clamped to the image. Rows in parallel (TBB).
std::vector<std::uint64_t> census_transform(const std::uint16_t* pixels, int width, int height, int census_width,
                                            int census_height);

/// The cost volume of the whole image, plainly (for the tests): W x H x D, d fastest;
/// popcount(census_left(x) ^ census_right(x - d)), or `out_of_view_cost` when x - d is outside.
std::vector<std::int16_t> cost_volume_reference(const std::uint64_t* census_left, const std::uint64_t* census_right,
                                                int width, int height, int min_disparity, int num_disparities,
                                                int out_of_view_cost);

// ---- the matching problem as the kernels see it ------------------------------------------------

constexpr int block = 16;         ///< disparities per step of the kernels (D is padded to a multiple)
constexpr int widest_lanes = 32;  ///< int16 lanes of the widest kernels (AVX-512)
inline int padded_disparities(int num_disparities) { return (num_disparities + block - 1) / block * block; }
/// Values of the path buffers beyond either end of the disparity range: "infinite" (saturating).
constexpr std::int16_t infinite_cost = 0x7fff;

struct Problem {
  int width = 0, height = 0;
  const std::uint64_t* census_left = nullptr;   ///< W x H
  const std::uint64_t* census_right = nullptr;  ///< W x H
  const std::uint16_t* intensity = nullptr;     ///< the left image, W x H, for the P2 adaptation
  int min_disparity = 0, num_disparities = 1;
  int out_of_view_cost = 0;  ///< cost of a disparity that leaves the right image: the census bits
  int pad_cost = 0;          ///< cost of the padding disparities D..D16-1 (never chosen, see .cpp)
  int p1 = 1;
  std::vector<std::int16_t> p2_by_step;  ///< P2 for an intensity step |I(p) - I(p-r)| (index)
  bool diagonals = true;                 ///< 8 paths; else 4
};

/// Fills p2_by_step and the derived costs of `problem` from the options (the formula of stereo.hpp).
void set_penalties(Problem& problem, const SgmOptions& options, int census_bits, double intensity_unit,
                   unsigned largest_intensity);
/// The P2 of stereo.hpp for one intensity step, computed directly (the tests' oracle).
int adapted_p2(const SgmOptions& options, double intensity_unit, unsigned step);

// ---- sgm_aggregate.cpp -----------------------------------------------------------------------

enum class Simd { sse2, avx2, avx2_vpopcnt, avx512 };
/// AVX-512 (BW + VPOPCNTDQ), AVX2 with VPOPCNTQ, AVX2, SSE2: the best this CPU has. AVX-512 rows
/// whose D16 is not a multiple of 32 go to the AVX2 + VPOPCNTQ kernels (same integers).
Simd best_simd();
const char* simd_name(Simd simd);

/// Receives the finished sums S of row y: W x D16 values, pixel-major (the D16 - D padding
/// disparities hold large values). Called once per row, from either sweep's thread, never
/// for two rows at once from the same thread; it must not start TBB work (see the .cpp).
using RowSink = std::function<void(int y, const std::int16_t* sums)>;

/// The stored half sums, the one large buffer (2 bytes per pixel and disparity): taken from the
/// kernel directly (mmap) and in huge pages where Linux offers them (transparent huge pages on
/// madvise), neither zeroed by the library nor faulted in 4 kB at a time. SgmMatcher keeps it
/// between calls, as OpenCV's StereoSGBM keeps its buffer: the kernel's zeroing of 600 MB of new
/// pages costs as much as the aggregation on Aloe (1282 x 1110 x 224).
class LargeBuffer {
public:
  explicit LargeBuffer(std::size_t count);  ///< int16 values, not initialised
  ~LargeBuffer();
  LargeBuffer(const LargeBuffer&) = delete;
  LargeBuffer& operator=(const LargeBuffer&) = delete;
  std::int16_t* data() { return data_; }
  std::size_t size() const { return bytes_ / sizeof(std::int16_t); }

private:
  std::size_t bytes_;
  std::int16_t* data_ = nullptr;
};

/// Both sweeps; `concurrent` runs them on two threads (results identical either way). `storage`
/// is reused when large enough, else replaced.
void aggregate(const Problem& problem, Simd simd, bool concurrent, const RowSink& sink,
               std::unique_ptr<LargeBuffer>& storage);

/// Every path's recurrence written out plainly over the whole image with int arithmetic, from a
/// cost volume (W x H x D, as cost_volume_reference): S, W x H x D. For the tests.
std::vector<std::int32_t> aggregate_reference(const Problem& problem, const std::vector<std::int16_t>& costs,
                                              const SgmOptions& options, double intensity_unit);

// ---- sgm_simd.cpp: the kernels ---------------------------------------------------------------

/// One row of one sweep.
struct SweepRow {
  int width = 0, d16 = 0, num_disparities = 0;
  int min_disparity = 0, out_of_view_cost = 0, pad_cost = 0, p1 = 0;
  bool forward = true;  ///< x ascending (top-down sweep) or descending (bottom-up)
  bool diagonals = true;
  bool first_row = true;                            ///< no row before: the vertical paths start here
  const std::uint64_t* census_left = nullptr;       ///< this row, W
  const std::uint64_t* right_reversed = nullptr;    ///< right census of this row, x = W-1-t at [t]
  const std::uint16_t* intensity = nullptr;         ///< this row, W
  const std::uint16_t* intensity_before = nullptr;  ///< the row the vertical paths come from
  const std::int16_t* p2_by_step = nullptr;
  /// Path buffers of the vertical directions (straight, diagonal A from x - step, diagonal B
  /// from x + step): the previous row's L, read, and this row's, written; each W pixels of
  /// stride path_stride(d16), the values at offset path_offset, one more path_offset of
  /// infinite values after the last pixel. Minima per pixel beside them.
  const std::int16_t* before[3] = {};
  std::int16_t* now[3] = {};
  const std::int16_t* before_min[3] = {};
  std::int16_t* now_min[3] = {};
  std::int16_t* along[2] = {};               ///< two pixels' L of the path along the row (ping-pong)
  const std::int16_t* zero_pixel = nullptr;  ///< a path buffer pixel of zeros: where a path starts
  /// out: W x d16; where other_half is null, aligned to the widest vector (64 bytes) and written
  /// with non-temporal stores
  std::int16_t* sums = nullptr;
  /// The other sweep's half sums of this row (W x d16), added to `sums` as they are written; or
  /// null (this sweep is the first at the row).
  const std::int16_t* other_half = nullptr;
};
/// Where a pixel's values start in the path buffers (int16): beyond the values at -1 and D16 that
/// the recurrence reads (infinite), this puts them on 64-byte boundaries (in 64-byte aligned
/// buffers, D16 a multiple of 32), so the widest kernel's loads and stores of L each touch one
/// cache line.
constexpr int path_offset = 32;
inline int path_stride(int d16) { return d16 + path_offset; }

void sweep_row(const SweepRow& row, Simd simd);
/// The cost of one pixel as the kernels compute it (d16 values, padding included), for the tests.
void cost_pixel(const SweepRow& row, int x, std::int16_t* out, Simd simd);

/// Winners of one row of sums: best[x] = the least-cost disparity index k of left pixel x, and
/// for the right image best_right[j] with j = W - 1 - x_right - min_disparity (see .cpp),
/// right_cost and best_right of size W + d16, filled by the kernel.
void winners_row(const std::int16_t* sums, int width, int d16, int num_disparities, std::int32_t* best,
                 std::int16_t* right_cost, std::int16_t* best_right, Simd simd);

// ---- disparity_refine.cpp --------------------------------------------------------------------

/// Turns one row's winners into disparities (sub-pixel when asked): left (W) and right (W, may be
/// null); NaN where the match leaves the other image.
void refine_row(const std::int16_t* sums, int width, int d16, int num_disparities, int min_disparity, bool subpixel,
                const std::int32_t* best, const std::int16_t* right_cost, const std::int16_t* best_right, float* left,
                float* right);

/// left_right_check() of stereo.hpp on one row (W values each): sgm_match() checks each row as
/// soon as both its disparities are known, on the sweeps' threads.
std::size_t left_right_check_row(float* left, const float* right, int width, double max_difference);

}  // namespace dsmplan::stereo
