// free_airspace(): the free airspace over solid columns at their own resolution (free_airspace.hpp),
// and mesh_columns(), the columns that enclose a 2.5D mesh.
//
// The floor of a cell is max over the cells k within `safety` of h_k + sqrt(s^2 - d^2), d the
// least distance between the two closed squares: the function falls with d, so its largest over
// the cell's square is reached at the least distance. For cells of one grid that distance depends
// on the offset alone (cell_x * max(|dc| - 1, 0), cell_y * max(|dr| - 1, 0)), so the floor is a
// max-plus convolution with a fixed stencil: O(cells x stencil), rows in parallel.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/text.hpp"
#include "dsmplan/free_airspace.hpp"

namespace dsmplan {

namespace {

constexpr float kRoom = 0.01f;  // m: floors raised, tops lowered, for the exact checks' rounding
// Column comparisons the floors may cost (cells x stencil), refused beyond before any is made: about
// 3 s on one core of the bench machine (1.5 ns each). The stencil grows with the safety distance
// squared: the NRW tile's million cells allow --safety 24 m at 1 m cells, the crop's 49 m.
constexpr double kMaxComparisons = 2e9;

struct Offset {
  int dc, dr;
  float rise;  // sqrt(s^2 - d^2)
};

std::vector<Offset> stencil(double safety, double cell_x, double cell_y) {
  std::vector<Offset> out;
  const int reach_c = static_cast<int>(std::ceil(safety / cell_x)) + 1;
  const int reach_r = static_cast<int>(std::ceil(safety / cell_y)) + 1;
  for (int dr = -reach_r; dr <= reach_r; ++dr)
    for (int dc = -reach_c; dc <= reach_c; ++dc) {
      const double dx = cell_x * std::max(std::abs(dc) - 1, 0), dy = cell_y * std::max(std::abs(dr) - 1, 0);
      const double d2 = dx * dx + dy * dy;
      if (d2 < safety * safety || (std::abs(dc) <= 1 && std::abs(dr) <= 1))
        out.push_back({dc, dr, static_cast<float>(std::sqrt(std::max(0.0, safety * safety - d2)))});
    }
  // Largest rise first: the nearest cells decide most floors, and the rest are skipped by bound.
  std::stable_sort(out.begin(), out.end(), [](const Offset& a, const Offset& b) { return a.rise > b.rise; });
  return out;
}

// The least ground touching the closed rectangle [xa, xb] x [yb, ya] (y up), or -inf when part of
// it lies beyond the ground's raster (unknown ground: nothing flies there).
double lowest_ground(const Grid& g, double xa, double xb, double ya, double yb) {
  constexpr double e = 1e-9;
  const double ua = (xa - g.x0) / g.cell_x, ub = (xb - g.x0) / g.cell_x;
  const double va = (g.y0 - ya) / g.cell_y, vb = (g.y0 - yb) / g.cell_y;
  const int c0 = static_cast<int>(std::floor(ua - e)), c1 = static_cast<int>(std::floor(ub + e));
  const int r0 = static_cast<int>(std::floor(va - e)), r1 = static_cast<int>(std::floor(vb + e));
  if (c0 < 0 || r0 < 0 || c1 >= g.width || r1 >= g.height) return -INFINITY;
  double low = INFINITY;
  for (int r = r0; r <= r1; ++r)
    for (int c = c0; c <= c1; ++c) low = std::min(low, double(g.at(c, r)));
  return std::isnan(low) ? -INFINITY : low;
}

// Labels the connected regions of open cells (8 neighbours, FreeAirspace::joined()), breadth first.
void label_regions(FreeAirspace& air) {
  const Grid& f = air.floor;
  const size_t n = f.cells();
  air.region.assign(n, FreeAirspace::kClosed);
  std::vector<uint8_t> open(n, 0);
  for (size_t i = 0; i < n; ++i) open[i] = f.z[i] <= air.top[i];
  std::vector<uint32_t> queue;
  for (size_t start = 0; start < n; ++start) {
    if (!open[start] || air.region[start] != FreeAirspace::kClosed) continue;
    const uint32_t label = static_cast<uint32_t>(air.region_cells.size());
    queue.assign(1, static_cast<uint32_t>(start));
    air.region[start] = label;
    for (size_t head = 0; head < queue.size(); ++head) {
      const uint32_t i = queue[head];
      const int col = static_cast<int>(i % f.width), row = static_cast<int>(i / f.width);
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) {
          const int c = col + dc, r = row + dr;
          if ((!dc && !dr) || c < 0 || r < 0 || c >= f.width || r >= f.height) continue;
          const size_t j = f.index(c, r);
          if (!open[j] || air.region[j] != FreeAirspace::kClosed || !air.joined(i, j)) continue;
          air.region[j] = label;
          queue.push_back(static_cast<uint32_t>(j));
        }
    }
    air.region_cells.push_back(static_cast<uint32_t>(queue.size()));
  }
}

}  // namespace

size_t FreeAirspace::memory_bytes() const {
  return floor.z.size() * sizeof(float) + top.size() * sizeof(float) + region.size() * sizeof(uint32_t) +
         region_cells.size() * sizeof(uint32_t);
}

std::shared_ptr<const FreeAirspace> free_airspace(const Grid& columns, const GroundGrid& ground, double safety,
                                                  double max_agl, const StopToken* stop) {
  if (!(safety >= 0 && std::isfinite(safety)))
    throw ArgumentError("--safety", "must be a finite number >= 0, got " + std::to_string(safety));
  if (!(max_agl > 0)) throw ArgumentError("--max-agl", "must be a number > 0");
  auto air = std::make_shared<FreeAirspace>();
  air->safety = safety;
  air->max_agl = max_agl;
  Grid& f = air->floor;
  f = Grid(columns.width, columns.height, columns.x0, columns.y0, columns.cell_x, columns.cell_y);
  f.crs = columns.crs;
  air->top.assign(f.cells(), -INFINITY);
  const std::vector<Offset> offsets = stencil(safety, columns.cell_x, columns.cell_y);
  if (const double work = double(columns.cells()) * offsets.size(); work > kMaxComparisons)
    throw ArgumentError("--safety", short_number(safety) + " m over " + std::to_string(columns.cells()) +
                                        " cells costs the free airspace " + short_number(work / 1e9) +
                                        " billion column comparisons, more than the " +
                                        short_number(kMaxComparisons / 1e9) +
                                        " billion a plan may cost; lower --safety or plan with --planner prm");
  const Grid* ground_grid = ground.empty() ? nullptr : &ground.grid();
  tbb::parallel_for(tbb::blocked_range<int>(0, columns.height, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int row = rows.begin(); row < rows.end(); ++row)
      for (int col = (check_stop(stop), 0); col < columns.width; ++col) {
        const size_t i = f.index(col, row);
        if (col == 0 || row == 0 || col == columns.width - 1 || row == columns.height - 1) continue;  // edge: closed
        float high = -INFINITY;
        bool unknown = false;
        for (const Offset& o : offsets) {
          const int c = col + o.dc, r = row + o.dr;
          if (c < 0 || r < 0 || c >= columns.width || r >= columns.height) continue;  // beyond: no column
          const float h = columns.at(c, r);
          if (std::isnan(h)) {
            unknown = unknown || (std::abs(o.dc) <= 1 && std::abs(o.dr) <= 1);
            continue;
          }
          high = std::max(high, h + o.rise);
        }
        if (unknown || !std::isfinite(high)) continue;
        f.z[i] = high + kRoom;
        if (!ground_grid) continue;
        const double xa = columns.x0 + col * columns.cell_x, ya = columns.y0 - row * columns.cell_y;
        const double low = lowest_ground(*ground_grid, xa, xa + columns.cell_x, ya, ya - columns.cell_y);
        air->top[i] = static_cast<float>(low + max_agl) - kRoom;
      }
  });
  check_stop(stop);
  label_regions(*air);
  return air;
}

Grid mesh_columns(const Mesh& mesh, const Grid& like) {
  Grid out(like.width, like.height, like.x0, like.y0, like.cell_x, like.cell_y);
  out.crs = like.crs;
  for (const Triangle& t : mesh.triangles) {
    const Vertex &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    const double xmin = std::min({a.x, b.x, c.x}), xmax = std::max({a.x, b.x, c.x});
    const double ymin = std::min({a.y, b.y, c.y}), ymax = std::max({a.y, b.y, c.y});
    const double zmax = std::max({a.z, b.z, c.z});
    // The plane z = p + q x + r y (none for a triangle seen edge-on: its highest corner then).
    const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
    const double vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
    const double det = ux * vy - uy * vx;
    const bool flat = std::abs(det) < 1e-12;
    const double q = flat ? 0 : (uz * vy - uy * vz) / det, r = flat ? 0 : (ux * vz - uz * vx) / det;
    const double p = a.z - q * a.x - r * a.y;
    const int c0 = std::max(0, static_cast<int>(std::floor((xmin - like.x0) / like.cell_x)));
    const int c1 = std::min(like.width - 1, static_cast<int>(std::floor((xmax - like.x0) / like.cell_x)));
    const int r0 = std::max(0, static_cast<int>(std::floor((like.y0 - ymax) / like.cell_y)));
    const int r1 = std::min(like.height - 1, static_cast<int>(std::floor((like.y0 - ymin) / like.cell_y)));
    for (int row = r0; row <= r1; ++row)
      for (int col = c0; col <= c1; ++col) {
        // The part of the cell the triangle's box meets; the plane's largest there is at a corner.
        const double x0 = std::max(xmin, like.x0 + col * like.cell_x);
        const double x1 = std::min(xmax, like.x0 + (col + 1) * like.cell_x);
        const double y1 = std::min(ymax, like.y0 - row * like.cell_y);
        const double y0 = std::max(ymin, like.y0 - (row + 1) * like.cell_y);
        double high = zmax;
        if (!flat) high = std::min(high, p + std::max(q * x0, q * x1) + std::max(r * y0, r * y1));
        float& z = out.z[out.index(col, row)];
        if (std::isnan(z) || high > z) z = static_cast<float>(std::nextafter(high, INFINITY));
      }
  }
  return out;
}

}  // namespace dsmplan
