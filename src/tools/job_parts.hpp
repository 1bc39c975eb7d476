// Pieces every tool job shares: stage timing (Stopwatch) and the refusal of CRSs in degrees.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/stopwatch.hpp"
#include "dsmplan/core.hpp"

namespace dsmplan {

/// Appends ("total", sum of the stages) to a report's stage seconds.
inline void add_total(std::vector<std::pair<std::string, double>>& seconds) {
  double total = 0;
  for (const auto& [stage, value] : seconds) total += value;
  seconds.emplace_back("total", total);
}

/// Delaunay on degrees with heights in metres means nothing, nor does a metric safety distance:
/// InputError naming `path` unless `crs` (of a DSM or a mesh) is projected.
inline void require_projected(const Crs& crs, const std::string& path) {
  if (!crs.geographic) return;
  throw InputError(path, "",
                   "CRS '" + crs.name +
                       "' is geographic (degrees); reproject to a projected CRS in metres first, "
                       "e.g. gdalwarp -t_srs EPSG:25832");
}

}  // namespace dsmplan
