// Block aggregation to a coarser x/y resolution, as Adolf & Hirschmueller (Section 2, Table 1)
// downsample their 7 cm DSM to 1-4 m. Median is the default (robust, the fusion rule of their
// Section 2); max is the conservative choice: an obstacle is never lowered.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/text.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

const char* to_string(Resampling method) {
  switch (method) {
    case Resampling::Median:
      return "median";
    case Resampling::Max:
      return "max";
    case Resampling::Mean:
      return "mean";
    case Resampling::Min:
      return "min";
    case Resampling::Nearest:
      return "nearest";
  }
  return "?";
}

Resampling parse_resampling(const std::string& name) {
  for (Resampling method :
       {Resampling::Median, Resampling::Max, Resampling::Mean, Resampling::Min, Resampling::Nearest}) {
    if (name == to_string(method)) return method;
  }
  require_choice("resampling", name, {"median", "max", "mean", "min", "nearest"});
  return Resampling::Median;  // not reached: require_choice() threw
}

namespace {

// For each input column (or row), the output block its centre falls in.
std::vector<int> block_of(int count, double cell, double resolution) {
  std::vector<int> block(count);
  for (int i = 0; i < count; ++i) block[i] = static_cast<int>(std::floor((i + 0.5) * cell / resolution));
  return block;
}

// [first, last) input indices per block, from a non-decreasing block_of table.
std::vector<std::pair<int, int>> ranges_of(const std::vector<int>& block, int blocks) {
  std::vector<std::pair<int, int>> ranges(blocks, {0, 0});
  for (int i = 0; i < static_cast<int>(block.size()); ++i) {
    auto& range = ranges[block[i]];
    if (range.first == range.second) range.first = i;
    range.second = i + 1;
  }
  return ranges;
}

float aggregate(std::vector<float>& values, Resampling method, float nearest) {
  switch (method) {
    case Resampling::Max:
      return *std::max_element(values.begin(), values.end());
    case Resampling::Min:
      return *std::min_element(values.begin(), values.end());
    case Resampling::Mean: {
      double sum = 0;
      for (float v : values) sum += v;
      return static_cast<float>(sum / values.size());
    }
    case Resampling::Nearest:
      return nearest;
    case Resampling::Median: {
      const size_t half = values.size() / 2;
      std::nth_element(values.begin(), values.begin() + half, values.end());
      const float upper = values[half];
      if (values.size() % 2) return upper;
      const float lower = *std::max_element(values.begin(), values.begin() + half);
      return static_cast<float>((static_cast<double>(lower) + upper) / 2);
    }
  }
  return NAN;
}

}  // namespace

Grid resample(const Grid& grid, double resolution, Resampling method, const Progress& progress) {
  if (!(resolution > 0) || !std::isfinite(resolution)) {
    throw ArgumentError("resolution", "must be a positive number of CRS units, got " + short_number(resolution));
  }
  // A grid made in memory may have any georeference: cells of 5e-324 make (i + 0.5) * cell round
  // onto the next block, past the last one (fuzz_pipeline). The readers refuse the same.
  check_grid(grid);
  const double finest = std::max(grid.cell_x, grid.cell_y);
  if (resolution < finest * (1 - 1e-9)) {
    throw ArgumentError("resolution", std::to_string(resolution) + " is finer than the DSM's cells (" +
                                          std::to_string(finest) + "); resampling only aggregates");
  }
  const double extent = std::max(grid.width * grid.cell_x, grid.height * grid.cell_y);
  if (resolution > extent)
    throw ArgumentError("resolution", short_number(resolution) + " is coarser than the whole raster (" +
                                          short_number(extent) + " CRS units across): one cell, no surface");
  if (resolution == grid.cell_x && resolution == grid.cell_y) {
    report(progress, 1);
    return grid;
  }
  // At least one cell: a resolution far coarser than the extent (1e300) rounds the count to 0.
  const int width = std::max(1, static_cast<int>(std::ceil(grid.width * grid.cell_x / resolution - 1e-9)));
  const int height = std::max(1, static_cast<int>(std::ceil(grid.height * grid.cell_y / resolution - 1e-9)));
  Grid out(width, height, grid.x0, grid.y0, resolution, resolution);
  out.crs = grid.crs;
  const auto cols = ranges_of(block_of(grid.width, grid.cell_x, resolution), width);
  const auto rows = ranges_of(block_of(grid.height, grid.cell_y, resolution), height);

  std::vector<float> values;
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      values.clear();
      float nearest = NAN;
      double nearest_distance = INFINITY;
      const double centre_x = (col + 0.5) * resolution, centre_y = (row + 0.5) * resolution;
      for (int r = rows[row].first; r < rows[row].second; ++r) {
        for (int c = cols[col].first; c < cols[col].second; ++c) {
          const float z = grid.at(c, r);
          if (std::isnan(z)) continue;
          values.push_back(z);
          const double dx = (c + 0.5) * grid.cell_x - centre_x, dy = (r + 0.5) * grid.cell_y - centre_y;
          if (dx * dx + dy * dy < nearest_distance) {
            nearest_distance = dx * dx + dy * dy;
            nearest = z;
          }
        }
      }
      if (!values.empty()) out.z[out.index(col, row)] = aggregate(values, method, nearest);
    }
    if (row % 64 == 0) report(progress, static_cast<double>(row) / height);
  }
  report(progress, 1);
  return out;
}

}  // namespace dsmplan
