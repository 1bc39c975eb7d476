// The XY-3 Delaunay mesh (Adolf & Hirschmueller, Section 3) of a raster larger than memory: the
// grid is meshed band by band, each band's window widened by a halo of rows so that it decides
// every triangle it keeps exactly as the whole grid would (see "Out of core" in dsmplan/mesh.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include "dsmplan/mesh.hpp"

namespace dsmplan {

MeshStreamResult triangulate_xy3(GridSource& dsm, MeshSink& sink, const MeshOptions& options,
                                 const Progress& progress) {
  const Grid& frame = dsm.frame();
  const double max_edge = max_edge_length(frame, options);
  if (!std::isfinite(max_edge)) throw ArgumentError("max_edge", "must be finite to mesh a raster band by band");
  // Circumradius of a lattice triangle with edges <= L: abc / (4 area) <= L^3 / (4 * cell_x cell_y / 2).
  const double radius = std::pow(max_edge, 3) / (2 * frame.cell_x * frame.cell_y);
  // In rows, as doubles first: --max-edge 1e6 over 1 m cells asks for a halo of 1e18 rows, beyond
  // an int (fuzz_pipeline); more rows than the grid has is the whole grid.
  const auto rows = [&](double count) { return count < frame.height ? static_cast<int>(count) : frame.height; };
  const int halo = rows(std::ceil((max_edge + 2 * radius) / frame.cell_y) + 2);
  const int band =
      std::max(rows(options.band_rows > 0 ? options.band_rows : 256), rows(std::ceil(max_edge / frame.cell_y) + 1));
  MeshStreamResult result;
  std::vector<uint64_t> valid_before{0};  // valid cells in the rows above row r, for r <= rows read
  std::vector<Triangle> pending;          // a band's triangles wait for the next band's vertices
  for (int r0 = 0; r0 < frame.height; r0 += band) {
    const int r1 = std::min(frame.height, r0 + band);
    const int w0 = std::max(0, r0 - halo), w1 = std::min(frame.height, r1 + halo);
    const Grid window = read_window(dsm, 0, w0, frame.width, w1 - w0);
    for (int row = static_cast<int>(valid_before.size()) - 1; row < w1; ++row) {
      const float* z = window.z.data() + window.index(0, row - w0);
      valid_before.push_back(valid_before.back() +
                             std::count_if(z, z + frame.width, [](float h) { return !std::isnan(h); }));
    }
    if (valid_before[w1] >= std::numeric_limits<uint32_t>::max())
      throw ArgumentError("grid", "too many valid cells for 32-bit vertex indices");
    const Mesh local = triangulate_xy3(window, options);
    const uint64_t base = valid_before[w0];
    // The band's own vertices, at the whole grid's cell centres; each window vertex's row.
    std::vector<int> row_of(local.vertices.size());
    std::vector<Vertex> vertices;
    for (int row = w0, id = 0; row < w1; ++row) {
      for (int col = 0; col < frame.width; ++col) {
        if (std::isnan(window.at(col, row - w0))) continue;
        row_of[id] = row;
        if (row >= r0 && row < r1) vertices.push_back({frame.center_x(col), frame.center_y(row), local.vertices[id].z});
        ++id;
      }
    }
    std::vector<Triangle> kept;
    for (const Triangle& t : local.triangles) {
      const int top = std::min({row_of[t[0]], row_of[t[1]], row_of[t[2]]});
      if (top < r0 || top >= r1) continue;  // another band's
      kept.push_back(
          {static_cast<uint32_t>(base + t[0]), static_cast<uint32_t>(base + t[1]), static_cast<uint32_t>(base + t[2])});
    }
    sink.append(vertices, pending);
    result.vertices += vertices.size();
    result.triangles += kept.size();
    pending = std::move(kept);
    ++result.bands;
    report(progress, double(r1) / frame.height);
  }
  sink.append({}, pending);
  result.valid_cells = valid_before[frame.height];
  return result;
}

}  // namespace dsmplan
