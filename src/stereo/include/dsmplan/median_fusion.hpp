// dsmplan/median_fusion.hpp: the fusion of the seed's pipeline (Adolf & Hirschmüller, Section 2:
// "all pixels of all depth images are reconstructed and projected into a geo-referenced,
// orthographic DSM. The redundancy is removed by using the median of depth values for each
// cell") in memory bounded whatever the scene's size.
//
// A point is kept as 8 bytes: its cell's row-major index and its height (float32, in an order-
// preserving encoding), so that sorting the keys sorts by cell, then by height. While the points
// fit in `memory_bytes` they stay in memory and finish() sorts them once. Beyond that the held
// points are sorted and spilled as a run to one anonymous temporary file (created in
// `temp_dir`, unlinked at once: nothing is left behind, even after a crash); finish() merges
// the runs (a k-way merge, each run read through its share of the budget) and takes each
// cell's median as its heights stream past. The result is the same, bit for bit, as sorting
// every point in memory (tested), and the memory is at most about `memory_bytes`.
//
// Cost: n points, M = memory_bytes / 8: O(n log M) to sort the runs (on every core), 8n bytes
// written and read once when n > M, O(n log(n / M)) to merge; O(1) memory per cell.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "dsmplan/raster.hpp"

namespace dsmplan {

struct MedianFusionOptions {
  /// Points held in memory before a run is spilled, in bytes (8 per point); 64 KiB or more
  /// (ArgumentError otherwise).
  std::size_t memory_bytes = std::size_t{1} << 30;
  /// Where spilled runs go; empty: $TMPDIR, else /tmp. OutputError naming it when it cannot
  /// hold them (missing, read-only, full).
  std::string temp_dir;
};

class MedianFusion {
public:
  /// Points will fall into `grid`'s cells (its geometry only is kept; at most 2^32 cells,
  /// ArgumentError otherwise).
  explicit MedianFusion(const Grid& grid, const MedianFusionOptions& options = {});
  ~MedianFusion();
  MedianFusion(const MedianFusion&) = delete;
  MedianFusion& operator=(const MedianFusion&) = delete;

  /// Adds points (x, y in the grid's CRS, z the height). A point outside the grid (Grid::cell_at)
  /// or with a height that is not finite is not counted. One thread at a time.
  void add(std::span<const std::array<double, 3>> points);
  /// The points that fell into the grid so far.
  std::size_t points() const { return points_; }
  /// Runs written to the temporary file (0: everything stayed in memory), finish()'s last one
  /// included.
  std::size_t runs_spilled() const { return runs_written_; }

  /// Each cell of `grid` (the geometry given at construction, ArgumentError otherwise) becomes
  /// the median of its heights (the mean of the two middle ones for an even count), nodata where
  /// none fell. Returns points(). Call once; the fusion is empty afterwards.
  std::size_t finish(Grid& grid);

private:
  struct Run {
    std::uint64_t offset, count;  // in keys
  };
  void spill();

  Grid geometry_;  // the grid's, heights left empty
  MedianFusionOptions options_;
  std::size_t capacity_;  // keys held before a spill
  std::vector<std::uint64_t> keys_;
  std::vector<Run> runs_;
  std::size_t points_ = 0, runs_written_ = 0;
  int file_ = -1;
  std::string file_dir_;
};

}  // namespace dsmplan
