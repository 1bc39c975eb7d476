// Pieces every tool job shares: stage timing (Stopwatch), the refusal of CRSs in degrees and of
// empty meshes, and the memory figures of the up-front refusal of inputs too big for the machine.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "core/stopwatch.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/export.hpp"

namespace dsmplan {

/// Appends ("total", sum of the stages) to a report's stage seconds.
inline void add_total(std::vector<std::pair<std::string, double>>& seconds) {
  double total = 0;
  for (const auto& [stage, value] : seconds) total += value;
  seconds.emplace_back("total", total);
}

/// Memory a job needs per DSM cell on top of the 4-byte height, for the up-front refusal of
/// inputs too big for the machine. Peak resident memory above `dsmplan info`'s on the 1000 x 1000
/// NRW tile, rounded up: the mesh ~55 B (a vertex of three doubles, two triangles of three
/// indices, a vertex number per cell); the paper's simplification ~240 B (the mesh, its neighbour
/// lists and the CGAL triangulation of the survivors); the bounded mode ~35 B (tiles of it).
constexpr double kMeshBytesPerCell = 64, kPaperSimplifyBytesPerCell = 256, kBoundedBytesPerCell = 48;

/// Cells of a width x height grid of cell_x x cell_y resampled to `resolution` (ceil(extent/res)
/// per axis, as resample() makes them), as a double so that a tiny --res cannot overflow.
inline double resampled_cells(int width, int height, double cell_x, double cell_y, double resolution) {
  return std::ceil(width * cell_x / resolution) * std::ceil(height * cell_y / resolution);
}

/// True when `path` names a mesh file by its extension (what mesh_format_for() accepts).
inline bool is_mesh_file(const std::string& path) {
  try {
    mesh_format_for(path);
    return true;
  } catch (const ArgumentError&) {
    return false;
  }
}

/// A number as a user would type it ("0.25", not "0.250000").
inline std::string short_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

/// A mesh with no triangle is no obstacle model (and every planner would fly through it):
/// InputError naming the DSM `path` and its size when a job's mesh came out empty.
inline void require_triangles(size_t triangles, int width, int height, const std::string& path) {
  if (triangles > 0) return;
  throw InputError(path, "",
                   std::to_string(width) + " x " + std::to_string(height) +
                       " cells give no triangle: a mesh needs three valid cells, not in a line, within --max-edge of each other");
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
