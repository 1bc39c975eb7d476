// Pieces every tool job shares: stage timing and the refusal of DSMs in degrees.
#pragma once

#include <chrono>
#include <string>
#include <utility>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

/// Wall seconds since the previous lap (or construction).
class Stopwatch {
public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return seconds;
  }

private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

/// Appends ("total", sum of the stages) to a report's stage seconds.
inline void add_total(std::vector<std::pair<std::string, double>>& seconds) {
  double total = 0;
  for (const auto& [stage, value] : seconds) total += value;
  seconds.emplace_back("total", total);
}

/// Delaunay on degrees with heights in metres means nothing, nor does a metric safety distance:
/// InputError naming `path` unless the DSM's CRS is projected.
inline void require_projected(const Grid& dsm, const std::string& path) {
  if (!dsm.crs.geographic) return;
  throw InputError(path, "",
                   "CRS '" + dsm.crs.name +
                       "' is geographic (degrees); reproject to a projected CRS in metres first, "
                       "e.g. gdalwarp -t_srs EPSG:25832");
}

}  // namespace dsmplan
