// The ground a ceiling counts from, and the exact greatest height of a segment above it: a
// cell-by-cell walk of the segment (Amanatides & Woo, "A Fast Voxel Traversal Algorithm for Ray
// Tracing", Eurographics 1987) over ground that is constant on each cell. See ground.hpp.
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/huge_pages.hpp"
#include "dsmplan/ground.hpp"

namespace dsmplan {

GroundGrid::GroundGrid(Grid ground) : grid_(std::move(ground)) {
  if (std::any_of(grid_.z.begin(), grid_.z.end(), [](float z) { return std::isnan(z); })) {
    hole_.resize(grid_.z.size());  // a bit a cell: a city's DSM can hold 1e8 cells
    for (size_t i = 0; i < hole_.size(); ++i) hole_[i] = std::isnan(grid_.z[i]);
  }
  fill_holes_from_rim(grid_, RimHeight::lowest);
  if (std::none_of(grid_.z.begin(), grid_.z.end(), [](float z) { return !std::isnan(z); })) {
    grid_ = Grid();
    return;
  }
  block_cols_ = (grid_.width + block - 1) / block;
  block_rows_ = (grid_.height + block - 1) / block;
  block_low_.assign(static_cast<size_t>(block_cols_) * block_rows_, INFINITY);
  for (int row = 0; row < grid_.height; ++row)
    for (int col = 0; col < grid_.width; ++col) {
      float& low = block_low_[static_cast<size_t>(row / block) * block_cols_ + col / block];
      low = std::min(low, grid_.at(col, row));  // NaN (a grid with no rim at all) never lowers it
    }
}

double GroundGrid::measured_at(double x, double y) const {
  int col = 0, row = 0;
  if (empty() || !grid_.cell_at(x, y, col, row) || was_hole(grid_.index(col, row))) return NAN;
  return grid_.at(col, row);
}

double GroundGrid::spread_at(double x, double y) const {
  int col = 0, row = 0;
  if (empty() || !grid_.cell_at(x, y, col, row)) return NAN;
  double low = INFINITY, high = -INFINITY;
  for (int r = std::max(0, row - 1); r <= std::min(grid_.height - 1, row + 1); ++r)
    for (int c = std::max(0, col - 1); c <= std::min(grid_.width - 1, col + 1); ++c)
      low = std::min(low, cell_ground(c, r)), high = std::max(high, cell_ground(c, r));
  return (high - low) / 2;
}

namespace {
// The largest float <= v (v finite): std::nextafter's step down by the bits, since a call to
// the library for every candidate cost a tenth of the floor's time.
inline float float_at_most(double v) {
  float f = static_cast<float>(v);
  if (f > v) {
    uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    bits = f > 0 ? bits - 1 : f < 0 ? bits + 1 : 0x80000001u;  // 0: the negative subnormal nearest it
    std::memcpy(&f, &bits, sizeof f);
  }
  return f;
}
}  // namespace

GroundGrid GroundGrid::floor_of(const Mesh& mesh, double cell) {
  if (!(cell > 0) || !std::isfinite(cell)) throw ArgumentError("cell", "must be a positive number");
  if (mesh.triangles.empty()) return {};
  struct Box {
    double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY;
  };
  const Box box = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, mesh.triangles.size()), Box{},
      [&](const tbb::blocked_range<size_t>& range, Box b) {
        for (size_t k = range.begin(); k != range.end(); ++k)
          for (uint32_t i : mesh.triangles[k]) {
            const Vertex& v = mesh.vertices[i];
            b.xmin = std::min(b.xmin, v.x), b.xmax = std::max(b.xmax, v.x);
            b.ymin = std::min(b.ymin, v.y), b.ymax = std::max(b.ymax, v.y);
          }
        return b;
      },
      [](const Box& a, const Box& b) {
        return Box{std::min(a.xmin, b.xmin), std::min(a.ymin, b.ymin), std::max(a.xmax, b.xmax),
                   std::max(a.ymax, b.ymax)};
      });
  const double xmin = box.xmin, ymin = box.ymin, xmax = box.xmax, ymax = box.ymax;
  const double wcells = std::floor((xmax - xmin) / cell) + 1, hcells = std::floor((ymax - ymin) / cell) + 1;
  if (!(wcells * hcells <= 4e8)) throw ArgumentError("cell", "gives more than 4e8 cells over the mesh");
  Grid floor(static_cast<int>(wcells), static_cast<int>(hcells), xmin, ymax, cell, cell);
  floor.crs = mesh.crs;
  // The lowest candidate of each cell, each rounded down to float first (rounding is monotone, so
  // the least rounded candidate is the least candidate rounded): the grid itself is the
  // working array, no second one of doubles. Parallel over triangles; a cell two triangles
  // share keeps the lower by an atomic minimum.
  std::fill(floor.z.begin(), floor.z.end(), INFINITY);
  float* const z = floor.z.data();
  const int width = floor.width;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh.triangles.size()), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t k = range.begin(); k != range.end(); ++k) {
      const Triangle& t = mesh.triangles[k];
      const Vertex &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
      const double lowest = std::min({a.z, b.z, c.z});
      // The plane z = a.z + gx (x - a.x) + gy (y - a.y), when the triangle has one.
      const double ux = b.x - a.x, uy = b.y - a.y, vx = c.x - a.x, vy = c.y - a.y;
      const double det = ux * vy - uy * vx;
      const bool planar = std::abs(det) > 1e-12 * (ux * ux + uy * uy + vx * vx + vy * vy);
      const double gx = planar ? ((b.z - a.z) * vy - (c.z - a.z) * uy) / det : 0;
      const double gy = planar ? ((c.z - a.z) * ux - (b.z - a.z) * vx) / det : 0;
      const double bx0 = std::min({a.x, b.x, c.x}), bx1 = std::max({a.x, b.x, c.x});
      const double by0 = std::min({a.y, b.y, c.y}), by1 = std::max({a.y, b.y, c.y});
      const int c0 = std::max(0, static_cast<int>(std::floor((bx0 - xmin) / cell)));
      const int c1 = std::min(floor.width - 1, static_cast<int>(std::floor((bx1 - xmin) / cell)));
      const int r0 = std::max(0, static_cast<int>(std::floor((ymax - by1) / cell)));
      const int r1 = std::min(floor.height - 1, static_cast<int>(std::floor((ymax - by0) / cell)));
      for (int row = r0; row <= r1; ++row) {
        // The plane is linear: over the rectangle where the cell meets the box, least at a
        // corner; its y part is the row's.
        const double y1 = std::min(by1, ymax - row * cell), y0 = std::max(by0, ymax - (row + 1) * cell);
        const double low_y = std::min(gy * (y0 - a.y), gy * (y1 - a.y));
        float* const line = z + static_cast<size_t>(row) * width;
        for (int col = c0; col <= c1; ++col) {
          double value = lowest;
          if (planar) {
            const double x0 = std::max(bx0, xmin + col * cell), x1 = std::min(bx1, xmin + (col + 1) * cell);
            value = std::max(value, a.z + std::min(gx * (x0 - a.x), gx * (x1 - a.x)) + low_y);
          }
          const float rounded = float_at_most(value);
          std::atomic_ref<float> slot(line[col]);
          float seen = slot.load(std::memory_order_relaxed);
          while (rounded < seen && !slot.compare_exchange_weak(seen, rounded, std::memory_order_relaxed)) {
          }
        }
      }
    }
  });
  for (float& z : floor.z)
    if (z == INFINITY) z = floor.nodata;  // no triangle: a hole, filled from its rim below
  return GroundGrid(std::move(floor));
}

double GroundGrid::height_above(const Point3& p) const {
  if (empty()) return INFINITY;
  const double u = (p[0] - grid_.x0) / grid_.cell_x, v = (grid_.y0 - p[1]) / grid_.cell_y;
  if (!(u >= 0 && v >= 0 && u <= grid_.width && v <= grid_.height)) return INFINITY;
  return touching(u, v, p[2]);
}

template <class F>
bool GroundGrid::any_sample(const Point3& p, const Point3& q, F&& fn) const {
  if (empty()) return false;
  const double pu = (p[0] - grid_.x0) / grid_.cell_x, pv = (grid_.y0 - p[1]) / grid_.cell_y;
  const double du = (q[0] - p[0]) / grid_.cell_x, dv = (p[1] - q[1]) / grid_.cell_y, dz = q[2] - p[2];
  const double cells = std::ceil(std::hypot(du, dv));
  if (!(cells < 1e7)) return false;  // not finite, or absurdly long: nothing proven
  const int n = std::max(1, static_cast<int>(cells));
  for (int k = 0; k < n; ++k) {
    const double t = (k + 0.5) / n, u = pu + t * du, v = pv + t * dv;
    if (!(u >= 0 && v >= 0 && u < grid_.width && v < grid_.height)) continue;  // beyond the raster
    const int col = static_cast<int>(u), row = static_cast<int>(v);
    if (fn(p[2] + t * dz - cell_ground(col, row), col, row)) return true;
  }
  return false;
}

bool GroundGrid::dips_below(const Point3& p, const Point3& q, double height) const {
  return any_sample(p, q, [&](double above, int col, int row) {
    return above < height && (hole_.empty() || !hole_[grid_.index(col, row)]);
  });
}

bool GroundGrid::rises_above(const Point3& p, const Point3& q, double height) const {
  return any_sample(p, q, [&](double above, int, int) { return above > height; });
}

double GroundGrid::max_height_above(const Point3& p, const Point3& q) const {
  if (empty()) return INFINITY;
  const Walk w(*this, p, q);
  if (!w.inside) return INFINITY;
  const int col = std::min(static_cast<int>(w.pu), grid_.width - 1),
            row = std::min(static_cast<int>(w.pv), grid_.height - 1);
  double best = std::max(
      {walk(w, 0, 1, col, row, INFINITY), touching(w.pu, w.pv, p[2]), touching(w.pu + w.du, w.pv + w.dv, q[2])});
  // Along a line between two columns (rows) of cells: the other side's cells touch it all along.
  if (w.du == 0 && w.pu == std::floor(w.pu) && col > 0 && col == static_cast<int>(w.pu))
    best = std::max(best, walk(w, 0, 1, col - 1, row, INFINITY));
  if (w.dv == 0 && w.pv == std::floor(w.pv) && row > 0 && row == static_cast<int>(w.pv))
    best = std::max(best, walk(w, 0, 1, col, row - 1, INFINITY));
  return best;
}

// The greatest z - ground over the cells whose closed square holds the point (u, v) (cell
// units): one inside a cell, two on a side, four at a corner.
double GroundGrid::touching(double u, double v, double z) const {
  const int c = std::min(static_cast<int>(u), grid_.width - 1), r = std::min(static_cast<int>(v), grid_.height - 1);
  double best = z - cell_ground(c, r);
  const bool on_u = u == std::floor(u) && u > 0 && u < grid_.width,
             on_v = v == std::floor(v) && v > 0 && v < grid_.height;
  if (on_u) best = std::max(best, z - cell_ground(c - 1, r));
  if (on_v) best = std::max(best, z - cell_ground(c, r - 1));
  if (on_u && on_v) best = std::max(best, z - cell_ground(c - 1, r - 1));
  return best;
}

GroundGrid::Walk::Walk(const GroundGrid& g, const Point3& p, const Point3& q) {
  const Grid& grid = g.grid_;
  pu = (p[0] - grid.x0) / grid.cell_x, pv = (grid.y0 - p[1]) / grid.cell_y;
  const double qu = (q[0] - grid.x0) / grid.cell_x, qv = (grid.y0 - q[1]) / grid.cell_y;
  du = qu - pu, dv = qv - pv, pz = p[2], dz = q[2] - p[2];
  auto in = [&](double u, double v) { return u >= 0 && v >= 0 && u <= grid.width && v <= grid.height; };
  inside = in(pu, pv) && in(qu, qv);  // the grid is convex: both ends inside, all inside
}

// The greatest height above the cells it crosses of the part [t0, t1] of the segment, starting
// in the cell (col, row) that holds the point at t0; as soon as it exceeds `stop`, a value above
// `stop`. Cost O(cells crossed).
double GroundGrid::walk(const Walk& w, double t0, double t1, int col, int row, double stop) const {
  auto z_at = [&](double t) { return w.pz + t * w.dz; };
  const int step_c = w.du > 0 ? 1 : -1, step_r = w.dv > 0 ? 1 : -1;
  // Parameter where the segment leaves the current cell across a column (row) line.
  auto next_u = [&] { return w.du == 0 ? INFINITY : ((w.du > 0 ? col + 1 : col) - w.pu) / w.du; };
  auto next_v = [&] { return w.dv == 0 ? INFINITY : ((w.dv > 0 ? row + 1 : row) - w.pv) / w.dv; };
  double best = -INFINITY, t = t0;
  const double steps = (std::abs(w.du) + std::abs(w.dv)) * (t1 - t0) + 4;  // a bound on the cells crossed
  for (double n = 0; n < steps; ++n) {
    const double tu = next_u(), tv = next_v(), t_next = std::min({tu, tv, t1});
    best = std::max(best, std::max(z_at(t), z_at(t_next)) - cell_ground(col, row));
    const int col_next = tu <= tv ? col + step_c : col, row_next = tv <= tu ? row + step_r : row;
    const bool col_in = col_next >= 0 && col_next < grid_.width, row_in = row_next >= 0 && row_next < grid_.height;
    if (tu == tv && tu <= t1) {  // through a corner (also at the part's end): the cells touching it only there
      if (col_in) best = std::max(best, z_at(tu) - cell_ground(col_next, row));
      if (row_in) best = std::max(best, z_at(tu) - cell_ground(col, row_next));
    }
    if (t_next >= t1 || best > stop) break;
    if (!col_in || !row_in) break;  // left at the border
    col = col_next, row = row_next, t = t_next;
  }
  return best;
}

bool GroundGrid::below_ceiling(const Point3& p, const Point3& q, double ceiling) const {
  if (empty()) return false;
  const Walk w(*this, p, q);
  if (!w.inside) return false;
  if (touching(w.pu, w.pv, p[2]) > ceiling || touching(w.pu + w.du, w.pv + w.dv, q[2]) > ceiling) return false;
  if ((w.du == 0 && w.pu == std::floor(w.pu)) || (w.dv == 0 && w.pv == std::floor(w.pv)))
    return max_height_above(p, q) <= ceiling;  // along a line between cells: both sides, the whole walk
  // The blocks the segment crosses, each settled by its lowest ground when it can be; the
  // cells of the others walked (the same walk as max_height_above(), one block at a time).
  int bc = std::min(static_cast<int>(w.pu), grid_.width - 1) / block;
  int br = std::min(static_cast<int>(w.pv), grid_.height - 1) / block;
  const int step_c = w.du > 0 ? 1 : -1, step_r = w.dv > 0 ? 1 : -1;
  auto z_at = [&](double t) { return w.pz + t * w.dz; };
  double t = 0;
  const double steps = (std::abs(w.du) + std::abs(w.dv)) / block + 4;
  for (double n = 0; n < steps; ++n) {
    const double tu = w.du == 0 ? INFINITY : ((w.du > 0 ? (bc + 1) * block : bc * block) - w.pu) / w.du;
    const double tv = w.dv == 0 ? INFINITY : ((w.dv > 0 ? (br + 1) * block : br * block) - w.pv) / w.dv;
    const double t_next = std::min({tu, tv, 1.0});
    if (std::max(z_at(t), z_at(t_next)) - block_low_[static_cast<size_t>(br) * block_cols_ + bc] > ceiling) {
      const double u = w.pu + t * w.du, v = w.pv + t * w.dv;
      // Where the segment enters the block: the cells its entry point touches (a corner on the
      // block's side touches a cell of the block the walk below does not step through). The
      // point is computed, so it is snapped to a line of cells within rounding: more cells,
      // never fewer.
      if (t > 0) {
        auto snap = [](double x) {
          return std::abs(x - std::round(x)) <= 1e-9 * std::max(1.0, std::abs(x)) ? std::round(x) : x;
        };
        if (touching(std::clamp(snap(u), 0.0, double(grid_.width)), std::clamp(snap(v), 0.0, double(grid_.height)),
                     z_at(t)) > ceiling)
          return false;
      }
      const int col = std::clamp(static_cast<int>(u), bc * block, std::min(bc * block + block, grid_.width) - 1);
      const int row = std::clamp(static_cast<int>(v), br * block, std::min(br * block + block, grid_.height) - 1);
      if (walk(w, t, t_next, col, row, ceiling) > ceiling) return false;
    }
    if (t_next >= 1) break;
    if (tu == tv) return max_height_above(p, q) <= ceiling;  // through a block's corner: the whole walk
    bc += tu < tv ? step_c : 0, br += tv < tu ? step_r : 0;
    if (bc < 0 || br < 0 || bc >= block_cols_ || br >= block_rows_) break;  // left at the border
    t = t_next;
  }
  return true;
}

double GroundGrid::lowest_near(double x, double y, double r) const {
  if (empty()) return -INFINITY;
  const double u0 = (x - r - grid_.x0) / grid_.cell_x, u1 = (x + r - grid_.x0) / grid_.cell_x;
  const double v0 = (grid_.y0 - y - r) / grid_.cell_y, v1 = (grid_.y0 - y + r) / grid_.cell_y;
  if (!(u0 >= 0 && v0 >= 0 && u1 <= grid_.width && v1 <= grid_.height)) return -INFINITY;
  const int b0 = static_cast<int>(u0) / block, b1 = std::min(static_cast<int>(u1), grid_.width - 1) / block;
  const int a0 = static_cast<int>(v0) / block, a1 = std::min(static_cast<int>(v1), grid_.height - 1) / block;
  float low = INFINITY;
  for (int row = a0; row <= a1; ++row)
    for (int col = b0; col <= b1; ++col) low = std::min(low, block_low_[static_cast<size_t>(row) * block_cols_ + col]);
  return low;
}

uint64_t GroundGrid::fingerprint() const {
  // FNV-1a over the georeference and the heights' bits.
  uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* data, size_t bytes) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < bytes; ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  const double frame[4] = {grid_.x0, grid_.y0, grid_.cell_x, grid_.cell_y};
  const int size[2] = {grid_.width, grid_.height};
  mix(frame, sizeof frame);
  mix(size, sizeof size);
  if (!grid_.z.empty()) mix(grid_.z.data(), grid_.z.size() * sizeof(float));
  return h;
}

}  // namespace dsmplan
