// Ortho-projection of stereo points into the DSM grid and the median per cell: the fusion of
// H. Hirschmüller's pipeline as the seed paper describes it (F. Adolf and H. Hirschmüller,
// "Meshing and Simplification of High Resolution Urban Surface Data for UAV Path Planning",
// Section 2: "all pixels of all depth images are reconstructed and projected into a
// geo-referenced, orthographic DSM. The redundancy is removed by using the median of depth
// values for each cell"). Cells nothing fell into stay nodata.
//
// Bounded memory by external sorting (sorted runs spilled to disk, then one k-way merge; D. E.
// Knuth, The Art of Computer Programming, vol. 3, Section 5.4.1): the median needs a cell's
// heights together, and sorting (cell, height) keys brings them together in order.
#include <fcntl.h>
#include <tbb/parallel_sort.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <queue>

#include "core/text.hpp"
#include "dsmplan/median_fusion.hpp"
#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {
namespace {

// float bits -> unsigned bits in the same order as the floats (negatives have every bit flipped,
// the others only the sign bit), and back.
std::uint32_t ordered_bits(float z) {
  const auto u = std::bit_cast<std::uint32_t>(z);
  return u & 0x80000000u ? ~u : u | 0x80000000u;
}
float from_ordered_bits(std::uint32_t u) { return std::bit_cast<float>(u & 0x80000000u ? u & 0x7fffffffu : ~u); }

// Calls emit(cell, median) for each cell in a stream of keys sorted ascending (next() returns
// false at the end). A cell's heights arrive in ascending order.
template <class Next, class Emit>
void medians_of_sorted(Next&& next, Emit&& emit) {
  std::vector<float> heights;
  std::uint64_t key = 0, cell = ~std::uint64_t{0};
  auto flush = [&] {
    if (heights.empty()) return;
    const std::size_t n = heights.size(), m = n / 2;
    emit(cell, n % 2 ? heights[m] : 0.5f * (heights[m - 1] + heights[m]));
    heights.clear();
  };
  while (next(key)) {
    if (key >> 32 != cell) flush(), cell = key >> 32;
    heights.push_back(from_ordered_bits(static_cast<std::uint32_t>(key)));
  }
  flush();
}

std::string temp_directory(const std::string& wanted) {
  if (!wanted.empty()) return wanted;
  const char* env = std::getenv("TMPDIR");
  return env && *env ? env : "/tmp";
}

}  // namespace

MedianFusion::MedianFusion(const Grid& grid, const MedianFusionOptions& options) : options_(options) {
  if (static_cast<std::uint64_t>(grid.width) * static_cast<std::uint64_t>(grid.height) > (std::uint64_t{1} << 32))
    throw ArgumentError("grid", "has more than 2^32 cells");
  if (options.memory_bytes < (std::size_t{1} << 16)) throw ArgumentError("memory_bytes", "must be at least 64 KiB");
  geometry_.width = grid.width, geometry_.height = grid.height;
  geometry_.x0 = grid.x0, geometry_.y0 = grid.y0, geometry_.cell_x = grid.cell_x, geometry_.cell_y = grid.cell_y;
  capacity_ = options.memory_bytes / sizeof(std::uint64_t);
}

MedianFusion::~MedianFusion() {
  if (file_ >= 0) ::close(file_);
}

void MedianFusion::add(std::span<const std::array<double, 3>> points) {
  for (const auto& p : points) {
    int col, row;
    if (!std::isfinite(p[2]) || !geometry_.cell_at(p[0], p[1], col, row)) continue;
    // Grow by doubling, but never past the budget (a doubling near it would hold 1.5 budgets).
    if (keys_.size() == keys_.capacity()) {
      if (keys_.size() == capacity_) spill();
      keys_.reserve(std::min(capacity_, std::max<std::size_t>(4096, 2 * keys_.capacity())));
    }
    keys_.push_back(geometry_.index(col, row) << 32 | ordered_bits(static_cast<float>(p[2])));
    ++points_;
  }
}

void MedianFusion::spill() {
  if (file_ < 0) {
    file_dir_ = temp_directory(options_.temp_dir);
    std::string name = file_dir_ + "/dsmplan-fusion-XXXXXX";
    file_ = ::mkstemp(name.data());
    if (file_ < 0)
      throw OutputError(file_dir_, std::string("cannot create a temporary file for the fusion's points (") +
                                       std::strerror(errno) + ")");
    ::unlink(name.c_str());  // anonymous from now on: gone when closed, whatever happens
  }
  tbb::parallel_sort(keys_.begin(), keys_.end());
  const std::uint64_t offset = runs_.empty() ? 0 : runs_.back().offset + runs_.back().count;
  const char* data = reinterpret_cast<const char*>(keys_.data());
  std::size_t bytes = keys_.size() * sizeof(std::uint64_t), done = 0;
  while (done < bytes) {
    const ssize_t n = ::pwrite(file_, data + done, bytes - done, static_cast<off_t>(offset * 8 + done));
    if (n <= 0)
      throw OutputError(file_dir_, std::string("cannot write the fusion's points to a temporary file (") +
                                       std::strerror(n < 0 ? errno : ENOSPC) + ")");
    done += static_cast<std::size_t>(n);
  }
  runs_.push_back({offset, keys_.size()});
  ++runs_written_;
  keys_.clear();
}

std::size_t MedianFusion::finish(Grid& grid) {
  if (grid.width != geometry_.width || grid.height != geometry_.height || grid.x0 != geometry_.x0 ||
      grid.y0 != geometry_.y0 || grid.cell_x != geometry_.cell_x || grid.cell_y != geometry_.cell_y)
    throw ArgumentError("grid", "is not the grid the fusion was made for");
  std::fill(grid.z.begin(), grid.z.end(), Grid::nodata);
  auto emit = [&](std::uint64_t cell, float z) { grid.z[cell] = z; };
  if (runs_.empty()) {
    tbb::parallel_sort(keys_.begin(), keys_.end());
    std::size_t i = 0;
    medians_of_sorted([&](std::uint64_t& key) { return i < keys_.size() ? (key = keys_[i++], true) : false; }, emit);
  } else {
    if (!keys_.empty()) spill();
    keys_ = {};  // the runs' buffers get the budget
    struct Reader {
      Run run;
      std::uint64_t next = 0;             // keys of the run read so far
      std::vector<std::uint64_t> buffer;  // keys read, not yet merged
      std::size_t at = 0;
    };
    const std::size_t share = std::max<std::size_t>(512, capacity_ / runs_.size());
    std::vector<Reader> readers(runs_.size());
    auto refill = [&](Reader& r) {
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(share, r.run.count - r.next));
      r.buffer.resize(n);
      r.at = 0;
      char* data = reinterpret_cast<char*>(r.buffer.data());
      std::size_t done = 0;
      while (done < n * 8) {
        const ssize_t got =
            ::pread(file_, data + done, n * 8 - done, static_cast<off_t>((r.run.offset + r.next) * 8 + done));
        if (got <= 0)
          throw OutputError(file_dir_, std::string("cannot read back the fusion's temporary file (") +
                                           std::strerror(got < 0 ? errno : EIO) + ")");
        done += static_cast<std::size_t>(got);
      }
      r.next += n;
      return n > 0;
    };
    using Head = std::pair<std::uint64_t, std::size_t>;  // key, reader
    std::priority_queue<Head, std::vector<Head>, std::greater<>> heads;
    for (std::size_t k = 0; k < runs_.size(); ++k) {
      readers[k].run = runs_[k];
      if (refill(readers[k])) heads.push({readers[k].buffer[0], k});
    }
    medians_of_sorted(
        [&](std::uint64_t& key) {
          if (heads.empty()) return false;
          const auto [smallest, k] = heads.top();
          heads.pop();
          key = smallest;
          Reader& r = readers[k];
          if (++r.at < r.buffer.size() || refill(r)) heads.push({r.buffer[r.at], k});
          return true;
        },
        emit);
    ::close(file_);
    file_ = -1;
    runs_.clear();
  }
  keys_ = {};
  const std::size_t n = points_;
  points_ = 0;
  return n;
}

Grid dsm_grid(const std::array<double, 4>& b, double resolution) {
  if (!(resolution > 0 && resolution <= kMaxDsmResolution))
    throw ArgumentError("resolution", "must lie in (0, " + short_number(kMaxDsmResolution) + "] CRS units, got " +
                                          short_number(resolution));
  if (!(b[2] > b[0] && b[3] > b[1])) throw ArgumentError("bounds", "must be x0,y0,x1,y1 with x0 < x1 and y0 < y1");
  const double w = std::ceil((b[2] - b[0]) / resolution - 1e-9), h = std::ceil((b[3] - b[1]) / resolution - 1e-9);
  const std::string extent = "x " + short_number(b[0]) + " to " + short_number(b[2]) + ", y " + short_number(b[1]) +
                             " to " + short_number(b[3]);
  if (w * h > 4e9)
    throw ArgumentError("bounds", extent + " at a resolution of " + short_number(resolution) + " makes " +
                                      short_number(w * h) + " cells, more than 4e9");
  Grid grid(static_cast<int>(w), static_cast<int>(h), b[0], b[3], resolution, resolution);
  // What dsmplan's readers would refuse is not written (the reader's own rule).
  if (const std::string problem = frame_problem(grid); !problem.empty())
    throw ArgumentError("bounds", extent + " at a resolution of " + short_number(resolution) + ": " + problem);
  return grid;
}

Grid footprint_grid(const std::array<double, 4>& bounds, double resolution, const std::string& cameras) {
  try {
    return dsm_grid(bounds, resolution);
  } catch (const ArgumentError& error) {
    if (error.field() == "resolution") throw;
    throw InputError(cameras, "", "the pairs' common footprint on the ground, " + error.problem());
  }
}

DsmExtent dsm_extent(const std::array<double, 4>& footprint, const std::optional<std::array<double, 4>>& bounds,
                     double resolution, const std::string& file, const std::string& footprint_name) {
  DsmExtent extent;
  if (bounds) {
    const auto& b = *bounds;
    if (b[2] <= footprint[0] || b[0] >= footprint[2] || b[3] <= footprint[1] || b[1] >= footprint[3])
      throw InputError(file, "--bounds", "lies outside every pair's " + footprint_name);
    extent.bounds = b;
    extent.grid = dsm_grid(b, resolution);
    return extent;
  }
  const double r = resolution;
  extent.bounds = {std::floor(footprint[0] / r) * r, std::floor(footprint[1] / r) * r, std::ceil(footprint[2] / r) * r,
                   std::ceil(footprint[3] / r) * r};
  extent.grid = footprint_grid(extent.bounds, resolution, file);
  return extent;
}

std::size_t fuse_median(Grid& grid, const std::vector<std::vector<Vec3>>& point_sets) {
  MedianFusion fusion(grid);
  for (const auto& set : point_sets) fusion.add(set);
  return fusion.finish(grid);
}

}  // namespace dsmplan
