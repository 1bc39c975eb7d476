// dsmplan/stereo.hpp: dense matching of a rectified image pair by Semi-Global Matching.
//
// Method (H. Hirschmüller, "Stereo Processing by Semiglobal Matching and Mutual Information",
// IEEE PAMI 30(2), 2008; section numbers below are that paper's):
//   1. Cost: the Hamming distance of Census transforms (R. Zabih and J. Woodfill,
//      "Non-parametric local transforms for computing visual correspondence", ECCV 1994) over a
//      census_width x census_height window (default 9 x 7: 62 bits; Hirschmüller & Scharstein,
//      "Evaluation of stereo matching costs on images with radiometric differences", PAMI 2009,
//      found it the most robust cost). A bit is set where the neighbour is darker than the
//      centre; the window is clamped at the image border (the border pixels are repeated).
//      A disparity whose right pixel lies outside the right image costs the maximum (the bits).
//   2. Aggregation (sec. 3.3): 8 paths (the 4 axes and the 4 diagonals), each
//      L_r(p,d) = C(p,d) + min(L_r(p-r,d), L_r(p-r,d±1) + P1, min_k L_r(p-r,k) + P2(p,r))
//                 - min_k L_r(p-r,k),
//      starting with L_r = C where p-r leaves the image, S(p,d) = sum_r L_r(p,d).
//      P2 adapts to the intensity step along the path (sec. 3.3: "P2 = P2'/|I_bp - I_bq|"), here
//      P2(p,r) = max(P1 + 1, floor(P2 / (1 + |I(p) - I(p-r)| / intensity_unit))), so the penalty
//      for a jump is lowered at image edges, where depth edges are likely.
//   3. Disparity (sec. 3.4): the d of least S(p,d) (the smallest d on ties); sub-pixel by the
//      parabola through S(d-1), S(d), S(d+1) (none at either end of the range).
//      The right image's disparity is taken from the same S along the epipolar line,
//      D_r(x) = argmin_d S((x + d, y), d) (sec. 3.4), with the same sub-pixel step.
//   4. Left-right consistency (sec. 3.4): a left pixel whose disparity differs by more than
//      lr_max_difference from the right disparity at x - round(d) is invalid.
//   5. Small segments (sec. 4.3 "peak filtering"): 4-connected regions of valid disparities whose
//      neighbours differ by at most speckle_max_difference, with fewer than speckle_min_pixels
//      pixels, are made invalid.
//
// Conventions. Images are row-major; pixel (x, y) is column x, row y. A left pixel (x, y) with
// disparity d shows the point seen at the right pixel (x - d, y); a right pixel (x, y) with
// disparity d matches the left pixel (x + d, y) (the same sign). Disparities are in pixels,
// float, NaN where invalid (occluded, mismatched, outside the other image, filtered).
// The disparity range is [min_disparity, min_disparity + num_disparities).
//
// Guarantees. The result does not depend on the number of threads nor on the instruction set
// (the SIMD kernels, AVX-512BW, AVX2 (with AVX-512's VPOPCNTQ where there) or SSE2, the best the
// CPU has, compute the same integers as a scalar reference). Costs and sums are 16-bit integers
// that cannot overflow under the limits checked on the options (P2 <= 1000).
//
// Errors: ArgumentError (dsmplan/core.hpp) naming the argument for images of different
// sizes, empty images, bit depths other than 8 and 16, a disparity range that does not fit the
// image width, options out of range; InputError ("needs about X of memory, this machine has Y")
// when even one band of rows cannot be held in memory.
//
// Complexity and memory. Time O(W·H·D) for W x H pixels and D = num_disparities (8 paths: about
// 16 saturated 16-bit operations per pixel and disparity, 8, 16 or 32 at a time). Memory, with
// D16 = D rounded up to a multiple of 16:
//   2 bytes per pixel and disparity (2·W·H·D16: the half of the paths' sum the first of the two
//   sweeps leaves for the second), plus about 28·W·(D16 + 32) bytes of row buffers, plus 28 bytes
//   per pixel (census, intensities, outputs).
// When that exceeds the memory bound (max_memory_bytes, default half the machine's memory), the
// image is matched in horizontal bands of rows that overlap by band_overlap rows above and below;
// each band keeps its central rows. Paths are then cut at the band's ends: the result can differ
// from the whole-image one near the seams, the more so the smaller the overlap.
//
// Threads. The top-down sweep (paths from left, top-left, top, top-right) and the bottom-up sweep
// (the other four) run at the same time and meet in the middle (2 threads); the census and the
// refinement run over rows on all threads of the TBB arena. threads = 1 runs the sweeps in turn.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace dsmplan {

/// A grey image in memory, not owned: 8 or 16 bits per pixel, row-major.
struct ImageView {
  const void* pixels = nullptr;
  int width = 0, height = 0;
  int bits = 8;               ///< 8 (uint8_t pixels) or 16 (uint16_t pixels)
  std::ptrdiff_t stride = 0;  ///< pixels from one row to the next; 0 means width

  ImageView() = default;
  ImageView(const std::uint8_t* p, int w, int h, std::ptrdiff_t row_stride = 0)
      : pixels(p), width(w), height(h), bits(8), stride(row_stride) {}
  ImageView(const std::uint16_t* p, int w, int h, std::ptrdiff_t row_stride = 0)
      : pixels(p), width(w), height(h), bits(16), stride(row_stride) {}
  std::ptrdiff_t row_pixels() const { return stride ? stride : width; }
  /// The pixel's value (no bounds check).
  unsigned at(int x, int y) const {
    const std::ptrdiff_t i = static_cast<std::ptrdiff_t>(y) * row_pixels() + x;
    return bits == 16 ? static_cast<const std::uint16_t*>(pixels)[i] : static_cast<const std::uint8_t*>(pixels)[i];
  }
};

struct SgmOptions {
  int min_disparity = 0;
  int num_disparities = 64;                 ///< D >= 1; every d in the range must satisfy |d| < width
  int census_width = 9, census_height = 7;  ///< odd, 3..15, at most 64 pixels in the window
  int paths = 8;                            ///< 8 (the axes and diagonals) or 4 (the axes only)
  /// Penalties, in census bits (a cost is 0..census_width·census_height - 1): P1 for a disparity
  /// step of 1, P2 for larger steps on a flat path. 1 <= P1 < P2 <= 1000.
  int p1 = 30, p2 = 600;  ///< chosen on Aloe (bench/README.md, "SGM (issue 16)")
  bool adapt_p2 = true;   ///< P2 divided by 1 + |intensity step| / intensity_unit (see above)
  /// Grey levels per unit of the P2 adaptation; 0: 1 for 8-bit images and, for 16-bit ones,
  /// max(1, largest pixel value of the two images / 255), so a 12-bit image acts as an 8-bit one.
  double intensity_unit = 0;
  bool subpixel = true;  ///< parabola fit; else whole pixels
  /// Largest |d_left - d_right| kept by the consistency check, in pixels; < 0 turns it off.
  double lr_max_difference = 1.0;
  /// Regions smaller than this (pixels) are removed; 0 turns the filter off.
  int speckle_min_pixels = 100;
  double speckle_max_difference = 1.0;  ///< largest step between neighbours of one region, px
  bool right_disparity = false;         ///< also return the right image's disparity
  int threads = 0;                      ///< 0: as many as the TBB arena has
  double max_memory_bytes = 0;          ///< bound for the bands; 0: half the machine's memory
  int band_overlap = 64;                ///< rows shared by neighbouring bands, each side
};

/// Disparity images, width x height, row-major, NaN = invalid.
struct Disparity {
  int width = 0, height = 0;
  std::vector<float> left;   ///< disparity of each left pixel
  std::vector<float> right;  ///< of each right pixel, when SgmOptions::right_disparity; else empty
  float at(int x, int y) const { return left[static_cast<std::size_t>(y) * width + x]; }
};

/// The disparity of a rectified pair (left, right): the steps 1-5 above.
/// Throws ArgumentError for bad images or options, InputError when out of memory (see above).
Disparity sgm_match(const ImageView& left, const ImageView& right, const SgmOptions& options = {});

/// sgm_match() for many pairs: keeps its large buffer (the 2 bytes per pixel and disparity)
/// between calls, as OpenCV's StereoSGBM does, until it is destroyed; a new buffer is taken only
/// for a larger problem. One match() at a time per object.
class SgmMatcher {
public:
  explicit SgmMatcher(const SgmOptions& options = {});
  ~SgmMatcher();
  SgmMatcher(SgmMatcher&&) noexcept;
  SgmMatcher& operator=(SgmMatcher&&) noexcept;
  Disparity match(const ImageView& left, const ImageView& right);
  const SgmOptions& options() const { return options_; }

private:
  struct Workspace;
  SgmOptions options_;
  std::unique_ptr<Workspace> workspace_;
};

/// Bytes sgm_match() needs for a W x H pair and these options, matched whole (no bands).
double sgm_memory_bytes(int width, int height, const SgmOptions& options);

/// Step 5 on its own: makes the small regions of `disparity` (width x height, NaN = invalid)
/// invalid, in place. Returns the number of pixels made invalid.
std::size_t remove_small_segments(std::vector<float>& disparity, int width, int height, int min_pixels,
                                  double max_difference);

/// Step 4 on its own: `left` loses the pixels that `right` does not confirm within
/// max_difference (both width x height, NaN = invalid). Returns the number made invalid.
std::size_t left_right_check(std::vector<float>& left, const std::vector<float>& right, int width, int height,
                             double max_difference);

}  // namespace dsmplan
