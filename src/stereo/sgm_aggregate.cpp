// Semi-Global Matching's aggregation (H. Hirschmüller, "Stereo Processing by Semiglobal Matching
// and Mutual Information", IEEE PAMI 30(2), 2008, sec. 3.3 and the two-pass order of sec. 3.5 /
// Fig. 6, as in Hirschmüller's and OpenCV's implementations): a top-down sweep (paths from the
// left, top-left, top and top-right) and a bottom-up sweep (the other four), each summing its
// paths per row. The two sweeps run at the same time from both ends of the image; a row's half
// sum is stored by whichever sweep reaches it first, and the second one adds its own half to it
// as it computes it, and hands the row on (RowSink). With one thread the top-down sweep stores
// every row and the bottom-up one finishes them; the sums are the same integers either way.
//
// Why no waiting can deadlock: a sweep claims a row (atomic counter) before computing it, and the
// second one only waits for a row whose first claimer is computing it right now, on another
// thread (the kernels and the sink start no TBB work, so neither sweep can be suspended under the
// other on one thread).
//
// The padding disparities D..D16-1 (the kernels work on 16 at a time) cost pad_cost =
// out_of_view_cost + 2 P2 + 1: their L is then >= pad_cost, so L + P1 exceeds what any real
// disparity can get from min_k L + P2 (<= out_of_view_cost + 2 P2): they never change a real
// disparity's value, nor the minima, nor win.
#include <sys/mman.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <new>
#include <thread>
#include <vector>

#include "stereo/sgm_parts.hpp"

namespace dsmplan::stereo {

LargeBuffer::LargeBuffer(std::size_t count) : bytes_(std::max<std::size_t>(count, 1) * sizeof(std::int16_t)) {
  void* memory = ::mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (memory == MAP_FAILED) throw std::bad_alloc();
#ifdef MADV_HUGEPAGE
  ::madvise(memory, bytes_, MADV_HUGEPAGE);  // a hint: without it the buffer works the same
#endif
  data_ = static_cast<std::int16_t*>(memory);
}

LargeBuffer::~LargeBuffer() { ::munmap(data_, bytes_); }

int adapted_p2(const SgmOptions& options, double intensity_unit, unsigned step) {
  if (!options.adapt_p2) return options.p2;
  const double p2 = std::floor(options.p2 / (1.0 + step / intensity_unit));
  return std::max(options.p1 + 1, static_cast<int>(p2));
}

void set_penalties(Problem& problem, const SgmOptions& options, int census_bits, double intensity_unit,
                   unsigned largest_intensity) {
  problem.p1 = options.p1;
  problem.out_of_view_cost = census_bits;
  problem.pad_cost = census_bits + 2 * options.p2 + 1;
  problem.diagonals = options.paths == 8;
  problem.p2_by_step.resize(static_cast<std::size_t>(largest_intensity) + 1);
  for (unsigned step = 0; step <= largest_intensity; ++step)
    problem.p2_by_step[step] = static_cast<std::int16_t>(adapted_p2(options, intensity_unit, step));
}

namespace {

// Buffers of int16 on 64-byte boundaries (a cache line, the widest vector).
struct FreeAligned {
  void operator()(std::int16_t* p) const { std::free(p); }
};
using Aligned = std::unique_ptr<std::int16_t[], FreeAligned>;

Aligned aligned_values(std::size_t count, std::int16_t value) {
  const std::size_t bytes = (count * sizeof(std::int16_t) + 63) / 64 * 64;
  Aligned buffer(static_cast<std::int16_t*>(std::aligned_alloc(64, bytes)));
  if (!buffer) throw std::bad_alloc();
  std::fill_n(buffer.get(), bytes / sizeof(std::int16_t), value);
  return buffer;
}

}  // namespace

void aggregate(const Problem& problem, Simd simd, bool concurrent, const RowSink& sink,
               std::unique_ptr<LargeBuffer>& storage) {
  const int width = problem.width, height = problem.height;
  const int d16 = padded_disparities(problem.num_disparities), stride = path_stride(d16);
  const std::size_t row_sums = static_cast<std::size_t>(width) * d16;
  if (!storage || storage->size() < row_sums * height) {
    storage.reset();  // the old one goes first: never both at once
    storage = std::make_unique<LargeBuffer>(row_sums * height);
  }
  LargeBuffer& stored = *storage;
  std::unique_ptr<std::atomic<int>[]> claims(new std::atomic<int>[height]), ready(new std::atomic<int>[height]);
  for (int y = 0; y < height; ++y) claims[y] = 0, ready[y] = 0;

  const auto sweep = [&](bool top_down) {
    const int directions = problem.diagonals ? 3 : 1;
    const std::size_t path_values = static_cast<std::size_t>(width) * stride + path_offset;
    Aligned paths[2][3];
    std::vector<std::int16_t> minima[2][3];
    for (int b = 0; b < 2; ++b)
      for (int r = 0; r < directions; ++r) {
        paths[b][r] = aligned_values(path_values, infinite_cost);
        minima[b][r].assign(width, 0);
      }
    const Aligned along[2] = {aligned_values(stride + path_offset, infinite_cost),
                              aligned_values(stride + path_offset, infinite_cost)};
    const Aligned zero_pixel = aligned_values(stride + path_offset, 0);
    const Aligned mine = aligned_values(row_sums, 0);
    // The right census of the row, reversed, with a vector of padding on both sides (the kernels
    // read whole vectors that may overlap the ends; those lanes are replaced).
    std::vector<std::uint64_t> right_reversed(static_cast<std::size_t>(width) + 2 * widest_lanes, 0);

    SweepRow row;
    row.width = width, row.d16 = d16, row.num_disparities = problem.num_disparities;
    row.min_disparity = problem.min_disparity, row.out_of_view_cost = problem.out_of_view_cost;
    row.pad_cost = problem.pad_cost, row.p1 = problem.p1;
    row.forward = top_down, row.diagonals = problem.diagonals;
    row.p2_by_step = problem.p2_by_step.data();
    row.right_reversed = right_reversed.data() + widest_lanes;
    row.along[0] = along[0].get(), row.along[1] = along[1].get();
    row.zero_pixel = zero_pixel.get();
    for (int i = 0; i < height; ++i) {
      const int y = top_down ? i : height - 1 - i;
      const std::size_t start = static_cast<std::size_t>(y) * width;
      const bool first = claims[y].fetch_add(1, std::memory_order_acq_rel) == 0;
      row.first_row = i == 0;
      row.census_left = problem.census_left + start;
      const std::uint64_t* census_right = problem.census_right + start;
      for (int t = 0; t < width; ++t) right_reversed[widest_lanes + t] = census_right[width - 1 - t];
      row.intensity = problem.intensity + start;
      row.intensity_before = i == 0 ? nullptr : problem.intensity + (top_down ? start - width : start + width);
      for (int r = 0; r < directions; ++r) {
        row.before[r] = paths[i & 1][r].get(), row.before_min[r] = minima[i & 1][r].data();
        row.now[r] = paths[(i + 1) & 1][r].get(), row.now_min[r] = minima[(i + 1) & 1][r].data();
      }
      if (first) {
        row.sums = stored.data() + row_sums * y, row.other_half = nullptr;
        sweep_row(row, simd);
        ready[y].store(1, std::memory_order_release);
      } else {
        // The kernel adds the stored half as it writes its own (one pass over the row's sums
        // instead of two); the wait is for the one row where the sweeps meet.
        while (!ready[y].load(std::memory_order_acquire)) std::this_thread::yield();
        row.sums = mine.get(), row.other_half = stored.data() + row_sums * y;
        sweep_row(row, simd);
        sink(y, mine.get());
      }
    }
  };
  if (concurrent)
    tbb::parallel_invoke([&] { sweep(true); }, [&] { sweep(false); });
  else
    sweep(true), sweep(false);
}

std::vector<std::int32_t> aggregate_reference(const Problem& problem, const std::vector<std::int16_t>& costs,
                                              const SgmOptions& options, double intensity_unit) {
  const int width = problem.width, height = problem.height, d = problem.num_disparities;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  std::vector<std::int32_t> sums(pixels * d, 0), paths(pixels * d);
  std::vector<int> directions = {1, 0, -1, 0, 0, 1, 0, -1};  // (dx, dy): the path comes from p - (dx, dy)
  if (problem.diagonals) directions.insert(directions.end(), {1, 1, -1, -1, 1, -1, -1, 1});
  for (std::size_t n = 0; n + 1 < directions.size(); n += 2) {
    const int dx = directions[n], dy = directions[n + 1];
    // Visit p - r before p: rows in the direction of dy, then columns in the direction of dx.
    for (int j = 0; j < height; ++j) {
      const int y = dy >= 0 ? j : height - 1 - j;
      for (int i = 0; i < width; ++i) {
        const int x = dx >= 0 ? i : width - 1 - i;
        const std::size_t p = static_cast<std::size_t>(y) * width + x;
        const int px = x - dx, py = y - dy;
        for (int k = 0; k < d; ++k) paths[p * d + k] = costs[p * d + k];
        if (px >= 0 && px < width && py >= 0 && py < height) {
          const std::size_t q = static_cast<std::size_t>(py) * width + px;
          const std::int32_t* before = &paths[q * d];
          const std::int32_t least = *std::min_element(before, before + d);
          const int p2 =
              adapted_p2(options, intensity_unit,
                         static_cast<unsigned>(std::abs(int(problem.intensity[p]) - int(problem.intensity[q]))));
          for (int k = 0; k < d; ++k) {
            std::int32_t best = std::min(before[k], least + p2);
            if (k > 0) best = std::min(best, before[k - 1] + problem.p1);
            if (k + 1 < d) best = std::min(best, before[k + 1] + problem.p1);
            paths[p * d + k] += best - least;
          }
        }
        for (int k = 0; k < d; ++k) sums[p * d + k] += paths[p * d + k];
      }
    }
  }
  return sums;
}

}  // namespace dsmplan::stereo
