// The bounded mode: greedy insertion (Garland & Heckbert, "Fast Polygonal Approximation of
// Terrains and Height Fields", CMU-CS-95-181, 1995, algorithm III: Delaunay triangulation,
// incremental insertion with Lawson flips, per-triangle candidates in a heap), run per tile.
// Tile borders are simplified first as polylines (Douglas & Peucker 1973 with the vertical
// error as the measure), so every tile starts from the very border vertices its neighbours
// use: the seams are watertight by construction. A cell centre on a border lies on a border
// edge, where the tile's surface is the polyline's, so the polyline's bound holds there.
//
// Exactness: vertices are lattice points (col, row), so orientation and in-circle tests are
// exact integer arithmetic (__int128 for in-circle), and a candidate on an edge is recognised
// exactly. Heights are doubles; the bound is kept with a 1 micrometre margin so the certified
// error, computed afterwards from CRS coordinates, stays within it despite rounding.
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <queue>
#include <string>
#include <vector>

#include "dsmplan/simplify.hpp"

namespace dsmplan {

namespace {

constexpr int32_t no_twin = -1;
constexpr double rounding_margin = 1e-6;
// A new vertex need not sit on its target: it keeps the current surface's height where that is
// within this fraction of the bound, so refining one spot disturbs the fit around it less.
// Measured on the NRW tile (conservative, E = 0.4 m): 0 -> 435,769 vertices, 0.3 -> 432,053,
// 0.4 -> 431,853, 0.6 -> 433,884, 0.9 -> 454,795.
constexpr double keep_fraction = 0.4;
// Small tiles are faster (small heaps stay in cache) and, measured, even keep fewer vertices:
// the pre-simplified seams give greedy insertion straight lines it would not find itself.
// NRW tile, conservative E = 0.4 m, 2 cores: tile 16 -> 427,629 vertices in 0.29 s, 64 ->
// 430,674 in 0.31 s, 256 -> 431,853 in 0.38 s, 512 -> 432,077 in 0.52 s, one tile 432,302.
// 64 keeps the seams few enough not to show in the mesh.
constexpr int default_tile_size = 64;

struct Point {
  int32_t x, y;  // col, row
};

int64_t orient(Point a, Point b, Point c) {
  return int64_t(b.x - a.x) * (c.y - a.y) - int64_t(b.y - a.y) * (c.x - a.x);
}

// > 0 when d lies inside the circle through a, b, c (orient(a, b, c) > 0).
bool in_circle(Point a, Point b, Point c, Point d) {
  const int64_t adx = a.x - d.x, ady = a.y - d.y, bdx = b.x - d.x, bdy = b.y - d.y, cdx = c.x - d.x, cdy = c.y - d.y;
  using Wide = __int128;
  const Wide det = Wide(adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) +
                   Wide(bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy) +
                   Wide(cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady);
  return det > 0;
}

int64_t floor_div(int64_t a, int64_t b) {
  const int64_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}
int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

// Heights to fit: the DSM plus a lift (E/2 in conservative mode), NaN where there is no data.
struct Target {
  const Grid& grid;
  double lift;
  double bound;  // the two-sided bound to keep around the target, margin included

  double at(int col, int row) const { return double(grid.z[grid.index(col, row)]) + lift; }
  bool valid(int col, int row) const { return !std::isnan(grid.z[grid.index(col, row)]); }

  // Height for a vertex at a nodata cell (tile corners only): the nearest valid cell's, found
  // in growing square rings; the corner then has no bound of its own.
  double at_or_nearest(int col, int row) const {
    if (valid(col, row)) return at(col, row);
    for (int r = 1; r < std::max(grid.width, grid.height); ++r) {
      for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx) {
          if (std::max(std::abs(dx), std::abs(dy)) != r) continue;
          const int c = col + dx, w = row + dy;
          if (c >= 0 && w >= 0 && c < grid.width && w < grid.height && valid(c, w)) return at(c, w);
        }
      }
    }
    return lift;  // no valid cell at all: the caller refuses such grids before
  }
};

// One tile's Delaunay triangulation, filled by greedy insertion.
class TileTriangulation {
public:
  TileTriangulation(const Target& target, int x0, int y0, int x1, int y1)
      : target_(target), x0_(x0), y0_(y0), x1_(x1), y1_(y1) {
    // Urban tiles keep up to half their cells; growing the arrays costs more than the address space.
    const size_t cells = size_t(x1 - x0 + 1) * size_t(y1 - y0 + 1);
    point_.reserve(cells / 2);
    height_.reserve(cells / 2);
    corner_.reserve(3 * cells);
    twin_.reserve(3 * cells);
    stamp_.reserve(cells);
    candidate_.reserve(cells);
  }

  // Starts from the tile's rectangle and its border vertices (ordered along each side).
  void start(const std::vector<Point>& border) {
    const uint32_t a = add_vertex({x0_, y0_}), b = add_vertex({x1_, y0_}), c = add_vertex({x1_, y1_}),
                   d = add_vertex({x0_, y1_});
    add_triangle(a, b, c);
    add_triangle(a, c, d);
    link(2, 3);
    // Rescanning the tile-wide triangles after every border point would cost (border points) x
    // (tile cells); one scan of the finished border triangulation is enough.
    scanning_ = false;
    for (const Point& p : border) {
      if ((p.x == x0_ || p.x == x1_) && (p.y == y0_ || p.y == y1_)) continue;  // a corner
      insert_on_border(p);
    }
    scanning_ = true;
    for (uint32_t t = 0; t < triangles(); ++t) rescan(t);
  }

  void fill() {
    while (!heap_.empty()) {
      const Entry top = heap_.top();
      heap_.pop();
      if (top.stamp != stamp_[top.triangle]) continue;  // the triangle changed since
      insert(top.triangle, candidate_[top.triangle]);
    }
  }

  uint32_t triangles() const { return static_cast<uint32_t>(corner_.size() / 3); }
  std::vector<Point>& points() { return point_; }
  std::vector<double>& heights() { return height_; }
  std::vector<uint32_t>& corners() { return corner_; }

private:
  struct Entry {
    float error;
    uint32_t triangle, stamp;
    bool operator<(const Entry& other) const { return error < other.error; }
  };

  static uint32_t next(uint32_t e) { return e % 3 == 2 ? e - 2 : e + 1; }
  static uint32_t prev(uint32_t e) { return e % 3 == 0 ? e + 2 : e - 1; }

  uint32_t add_vertex(Point p) {
    point_.push_back(p);
    height_.push_back(target_.at_or_nearest(p.x, p.y));
    return static_cast<uint32_t>(point_.size() - 1);
  }
  uint32_t add_triangle(uint32_t a, uint32_t b, uint32_t c) {
    corner_.insert(corner_.end(), {a, b, c});
    twin_.insert(twin_.end(), {no_twin, no_twin, no_twin});
    stamp_.push_back(0);
    candidate_.push_back({0, 0});
    return triangles() - 1;
  }
  void set_triangle(uint32_t t, uint32_t a, uint32_t b, uint32_t c) {
    corner_[3 * t] = a;
    corner_[3 * t + 1] = b;
    corner_[3 * t + 2] = c;
  }
  void link(int32_t e, int32_t f) {
    twin_[e] = f;
    if (f != no_twin) twin_[f] = e;
  }

  double plane_at(uint32_t t, Point p) const {
    const Point a = point_[corner_[3 * t]], b = point_[corner_[3 * t + 1]], c = point_[corner_[3 * t + 2]];
    const double za = height_[corner_[3 * t]], zb = height_[corner_[3 * t + 1]], zc = height_[corner_[3 * t + 2]];
    const double det = static_cast<double>(orient(a, b, c));
    const double gx = ((zb - za) * (c.y - a.y) - (zc - za) * (b.y - a.y)) / det;
    const double gy = ((zc - za) * (b.x - a.x) - (zb - za) * (c.x - a.x)) / det;
    return za + gx * (p.x - a.x) + gy * (p.y - a.y);
  }

  // A border point lies on exactly one boundary edge (one without twin).
  void insert_on_border(Point p) {
    const uint32_t v = add_vertex(p);
    for (uint32_t e = 0; e < corner_.size(); ++e) {
      if (twin_[e] != no_twin) continue;
      const Point a = point_[corner_[e]], b = point_[corner_[next(e)]];
      if (orient(a, b, p) != 0) continue;
      if (std::min(a.x, b.x) <= p.x && p.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= p.y &&
          p.y <= std::max(a.y, b.y)) {
        split_edge(e, v);
        return;
      }
    }
  }

  void insert(uint32_t t, Point p) {
    const double target = target_.at(p.x, p.y);
    const double slack = keep_fraction * target_.bound;
    const double current = plane_at(t, p);
    const uint32_t v = add_vertex(p);
    height_[v] = target + std::clamp(current - target, -slack, slack);
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t e = 3 * t + k;
      if (orient(point_[corner_[e]], point_[corner_[next(e)]], p) == 0) {
        split_edge(e, v);
        return;
      }
    }
    dirty_.clear();
    // (a, b, c) -> (a, b, p), (b, c, p), (c, a, p)
    const uint32_t a = corner_[3 * t], b = corner_[3 * t + 1], c = corner_[3 * t + 2];
    const int32_t ab = twin_[3 * t], bc = twin_[3 * t + 1], ca = twin_[3 * t + 2];
    set_triangle(t, a, b, v);
    const uint32_t t1 = add_triangle(b, c, v), t2 = add_triangle(c, a, v);
    link(3 * t, ab);
    link(3 * t1, bc);
    link(3 * t2, ca);
    link(3 * t + 1, 3 * t1 + 2);
    link(3 * t1 + 1, 3 * t2 + 2);
    link(3 * t2 + 1, 3 * t + 2);
    dirty_.insert(dirty_.end(), {t, t1, t2});
    legalize(3 * t);
    legalize(3 * t1);
    legalize(3 * t2);
    rescan_dirty();
  }

  // Splits half-edge e (a->b, in triangle (a, b, c)) and its twin (b->a, in (b, a, d)) at v.
  void split_edge(uint32_t e, uint32_t v) {
    dirty_.clear();
    const uint32_t t = e / 3, a = corner_[e], b = corner_[next(e)], c = corner_[prev(e)];
    const int32_t bc = twin_[next(e)], ca = twin_[prev(e)], f = twin_[e];
    set_triangle(t, c, a, v);
    const uint32_t t1 = add_triangle(b, c, v);
    link(3 * t, ca);
    link(3 * t1, bc);
    link(3 * t + 2, 3 * t1 + 1);
    dirty_.insert(dirty_.end(), {t, t1});
    if (f == no_twin) {
      twin_[3 * t + 1] = no_twin;
      twin_[3 * t1 + 2] = no_twin;
      legalize(3 * t);
      legalize(3 * t1);
    } else {
      const uint32_t u = f / 3, d = corner_[prev(f)];
      const int32_t ad = twin_[next(f)], db = twin_[prev(f)];
      set_triangle(u, a, d, v);
      const uint32_t u1 = add_triangle(d, b, v);
      link(3 * u, ad);
      link(3 * u1, db);
      link(3 * t + 1, 3 * u + 2);    // a->v with v->a
      link(3 * t1 + 2, 3 * u1 + 1);  // v->b with b->v
      link(3 * u + 1, 3 * u1 + 2);   // d->v with v->d
      dirty_.insert(dirty_.end(), {u, u1});
      legalize(3 * t);
      legalize(3 * t1);
      legalize(3 * u);
      legalize(3 * u1);
    }
    rescan_dirty();
  }

  // Lawson flips from half-edge e, whose opposite vertex in its triangle is the new point.
  void legalize(uint32_t e) {
    stack_.push_back(e);
    while (!stack_.empty()) {
      const uint32_t a = stack_.back();
      stack_.pop_back();
      const int32_t twin = twin_[a];
      if (twin == no_twin) continue;
      const uint32_t b = static_cast<uint32_t>(twin);
      const uint32_t al = next(a), ar = prev(a), bl = prev(b), br = next(b);
      const uint32_t p0 = corner_[ar], pr = corner_[a], pl = corner_[al], p1 = corner_[bl];
      if (!in_circle(point_[pr], point_[pl], point_[p0], point_[p1])) continue;
      corner_[a] = p1;
      corner_[b] = p0;
      const int32_t hbl = twin_[bl], har = twin_[ar];
      link(a, hbl);
      link(b, har);
      link(ar, bl);
      dirty_.push_back(a / 3);
      dirty_.push_back(b / 3);
      stack_.push_back(a);
      stack_.push_back(br);
    }
  }

  void rescan_dirty() {
    if (!scanning_) return;
    std::sort(dirty_.begin(), dirty_.end());
    dirty_.erase(std::unique(dirty_.begin(), dirty_.end()), dirty_.end());
    for (uint32_t t : dirty_) rescan(t);
  }

  // The cell of largest error strictly inside the tile and under triangle t; queued when it
  // breaks the bound.
  void rescan(uint32_t t) {
    ++stamp_[t];
    const Point a = point_[corner_[3 * t]], b = point_[corner_[3 * t + 1]], c = point_[corner_[3 * t + 2]];
    const double za = height_[corner_[3 * t]], zb = height_[corner_[3 * t + 1]], zc = height_[corner_[3 * t + 2]];
    const double det = static_cast<double>(orient(a, b, c));
    const double gx = ((zb - za) * (c.y - a.y) - (zc - za) * (b.y - a.y)) / det;
    const double gy = ((zc - za) * (b.x - a.x) - (zb - za) * (c.x - a.x)) / det;
    const int row_begin = std::max({std::min({a.y, b.y, c.y}), y0_ + 1});
    const int row_end = std::min({std::max({a.y, b.y, c.y}), y1_ - 1});
    const int col_min = std::max({std::min({a.x, b.x, c.x}), x0_ + 1});
    const int col_max = std::min({std::max({a.x, b.x, c.x}), x1_ - 1});
    const Point edge_from[3] = {a, b, c}, edge_to[3] = {b, c, a};
    double worst = target_.bound;
    Point worst_cell{0, 0};
    const Grid& grid = target_.grid;
    for (int row = row_begin; row <= row_end; ++row) {
      // orient(p, q, (x, row)) = A x + B >= 0 for each edge p->q.
      int64_t lo = col_min, hi = col_max;
      for (int k = 0; k < 3; ++k) {
        const Point p = edge_from[k], q = edge_to[k];
        const int64_t A = -(int64_t(q.y) - p.y);
        const int64_t B = int64_t(q.x - p.x) * (row - p.y) + int64_t(q.y - p.y) * p.x;
        if (A > 0)
          lo = std::max(lo, ceil_div(-B, A));
        else if (A < 0)
          hi = std::min(hi, floor_div(-B, A));
        else if (B < 0)
          hi = lo - 1;
      }
      if (lo > hi) continue;
      const float* heights = &grid.z[grid.index(0, row)];
      const double base = za + gy * (row - a.y) - gx * a.x + (-target_.lift);
      for (int64_t col = lo; col <= hi; ++col) {
        const double error = std::abs(base + gx * double(col) - heights[col]);
        if (error > worst) {  // false for NaN (nodata)
          worst = error;
          worst_cell = {static_cast<int32_t>(col), row};
        }
      }
    }
    if (worst > target_.bound) {
      candidate_[t] = worst_cell;
      heap_.push({static_cast<float>(worst), t, stamp_[t]});
    }
  }

  const Target& target_;
  const int x0_, y0_, x1_, y1_;
  std::vector<Point> point_;
  std::vector<double> height_;
  std::vector<uint32_t> corner_;  // 3 per triangle, orient > 0 in (col, row)
  std::vector<int32_t> twin_;     // per half-edge
  std::vector<uint32_t> stamp_;
  std::vector<Point> candidate_;
  std::priority_queue<Entry> heap_;
  std::vector<uint32_t> dirty_, stack_;
  bool scanning_ = true;
};

// Douglas-Peucker on the cells from `from` to `to` (one row or column), vertical error.
void simplify_polyline(const Target& target, Point from, Point to, std::vector<Point>& out) {
  const int steps = std::max(std::abs(to.x - from.x), std::abs(to.y - from.y));
  const int dx = (to.x - from.x) / std::max(steps, 1), dy = (to.y - from.y) / std::max(steps, 1);
  std::vector<double> z(steps + 1);
  std::vector<bool> valid(steps + 1);
  for (int i = 0; i <= steps; ++i) {
    valid[i] = target.valid(from.x + i * dx, from.y + i * dy);
    z[i] = valid[i] ? target.at(from.x + i * dx, from.y + i * dy) : NAN;
  }
  z[0] = target.at_or_nearest(from.x, from.y);
  z[steps] = target.at_or_nearest(to.x, to.y);
  std::vector<bool> keep(steps + 1, false);
  keep[0] = keep[steps] = true;
  std::vector<std::pair<int, int>> spans{{0, steps}};
  while (!spans.empty()) {
    const auto [lo, hi] = spans.back();
    spans.pop_back();
    double worst = target.bound;
    int worst_i = -1;
    for (int i = lo + 1; i < hi; ++i) {
      if (!valid[i]) continue;
      const double line = z[lo] + (z[hi] - z[lo]) * (i - lo) / (hi - lo);
      const double error = std::abs(line - z[i]);
      if (error > worst) {
        worst = error;
        worst_i = i;
      }
    }
    if (worst_i < 0) continue;
    keep[worst_i] = true;
    spans.push_back({lo, worst_i});
    spans.push_back({worst_i, hi});
  }
  for (int i = 0; i <= steps; ++i)
    if (keep[i]) out.push_back({from.x + i * dx, from.y + i * dy});
}

// True when every cell centre under the triangle is nodata (and there is at least one): the
// hole stays open there.
bool over_nodata_only(const Target& target, const std::array<Point, 3>& p) {
  bool any_cell = false;
  const int r0 = std::min({p[0].y, p[1].y, p[2].y}), r1 = std::max({p[0].y, p[1].y, p[2].y});
  const int c0 = std::min({p[0].x, p[1].x, p[2].x}), c1 = std::max({p[0].x, p[1].x, p[2].x});
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      const Point q{c, r};
      if (orient(p[0], p[1], q) < 0 || orient(p[1], p[2], q) < 0 || orient(p[2], p[0], q) < 0) continue;
      if (target.valid(c, r)) return false;
      any_cell = true;
    }
  }
  return any_cell;
}

std::vector<int> split_points(int last, int tile) {
  const int parts = std::max(1, static_cast<int>(std::lround(double(last) / tile)));
  std::vector<int> at(parts + 1);
  for (int i = 0; i <= parts; ++i) at[i] = static_cast<int>(int64_t(i) * last / parts);
  return at;
}

}  // namespace

void check_bounded_options(const BoundedSimplifyOptions& options) {
  if (!(options.max_error > 0) || !std::isfinite(options.max_error)) {
    throw ArgumentError("--max-error", "must be a positive number, got " + std::to_string(options.max_error));
  }
  if (options.tile_size < 0) throw ArgumentError("--tile-size", "must be >= 0 (0: automatic)");
}

Mesh simplify_bounded(const Grid& dsm, const BoundedSimplifyOptions& options, const Progress& progress) {
  check_bounded_options(options);
  if (dsm.width < 2 || dsm.height < 2) throw ArgumentError("DSM", "needs at least 2 x 2 cells to triangulate");
  if (std::all_of(dsm.z.begin(), dsm.z.end(), [](float z) { return std::isnan(z); }))
    throw ArgumentError("DSM", "has no valid cell");
  const double half = options.max_error / 2;
  const Target target{dsm, options.conservative ? half : 0.0,
                      (options.conservative ? half : options.max_error) - rounding_margin};

  const int tile =
      options.delaunay ? std::max(dsm.width, dsm.height) : (options.tile_size ? options.tile_size : default_tile_size);
  const std::vector<int> xs = split_points(dsm.width - 1, std::max(tile, 2));
  const std::vector<int> ys = split_points(dsm.height - 1, std::max(tile, 2));
  const size_t tiles_x = xs.size() - 1, tiles_y = ys.size() - 1;

  // Border polylines: horizontal[j][i] runs along row ys[j] over tile column i, vertical[j][i]
  // along column xs[i] over tile row j. Shared by the tiles on both sides.
  std::vector<std::vector<std::vector<Point>>> horizontal(ys.size(), std::vector<std::vector<Point>>(tiles_x));
  std::vector<std::vector<std::vector<Point>>> vertical(tiles_y, std::vector<std::vector<Point>>(xs.size()));
  for (size_t j = 0; j < ys.size(); ++j)
    for (size_t i = 0; i < tiles_x; ++i)
      simplify_polyline(target, {xs[i], ys[j]}, {xs[i + 1], ys[j]}, horizontal[j][i]);
  for (size_t j = 0; j < tiles_y; ++j)
    for (size_t i = 0; i < xs.size(); ++i)
      simplify_polyline(target, {xs[i], ys[j]}, {xs[i], ys[j + 1]}, vertical[j][i]);
  report(progress, 0.05);

  // Per cell: 1 once a kept triangle uses it, later its vertex index; and that vertex's height.
  // Tiles sharing a border write the same values there (relaxed atomics: no torn or racy writes).
  if (dsm.cells() >= std::numeric_limits<uint32_t>::max())
    throw ArgumentError("DSM", "too many cells for 32-bit vertex indices; split it into tiles");
  const bool has_nodata = std::any_of(dsm.z.begin(), dsm.z.end(), [](float z) { return std::isnan(z); });
  std::vector<uint32_t> id(dsm.cells(), 0);
  std::unique_ptr<double[]> height(new double[dsm.cells()]);
  std::vector<std::vector<Triangle>> tile_triangles(tiles_x * tiles_y);  // cell indices
  std::mutex progress_mutex;
  std::atomic<size_t> done{0};
  std::atomic<bool> cancelled{false};
  auto run_tile = [&](size_t index) {
    if (cancelled) return;
    const size_t i = index % tiles_x, j = index / tiles_x;
    std::vector<Point> border;
    for (const auto* side : {&horizontal[j][i], &vertical[j][i + 1], &horizontal[j + 1][i], &vertical[j][i]})
      border.insert(border.end(), side->begin(), side->end());
    TileTriangulation triangulation(target, xs[i], ys[j], xs[i + 1], ys[j + 1]);
    triangulation.start(border);
    triangulation.fill();
    const auto& points = triangulation.points();
    const auto& corners = triangulation.corners();
    auto& kept = tile_triangles[index];
    kept.reserve(corners.size() / 3);
    for (size_t k = 0; k < corners.size(); k += 3) {
      const std::array<Point, 3> p{points[corners[k]], points[corners[k + 1]], points[corners[k + 2]]};
      if (has_nodata && over_nodata_only(target, p)) continue;
      Triangle cells;
      for (int m = 0; m < 3; ++m) {
        cells[m] = static_cast<uint32_t>(dsm.index(p[m].x, p[m].y));
        std::atomic_ref<uint32_t>(id[cells[m]]).store(1, std::memory_order_relaxed);
        std::atomic_ref<double>(height[cells[m]])
            .store(triangulation.heights()[corners[k + m]], std::memory_order_relaxed);
      }
      // Counter-clockwise in (col, row), whose rows run south: reversed for the CRS.
      kept.push_back({cells[0], cells[2], cells[1]});
    }
    const size_t finished = ++done;
    std::lock_guard lock(progress_mutex);
    try {
      report(progress, 0.05 + 0.85 * finished / tile_triangles.size());
    } catch (const Cancelled&) {
      cancelled = true;
    }
  };
  const bool serial = options.delaunay || options.threads == 1;
  tbb::task_arena arena(serial ? 1 : options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(
        size_t(0), tile_triangles.size(), [&](size_t index) { run_tile(index); }, tbb::simple_partitioner());
  });
  if (cancelled) throw Cancelled();

  // One vertex per used cell, in row-major order (numbered by blocks of rows in parallel).
  Mesh mesh;
  mesh.crs = dsm.crs;
  const int block_rows = 16;
  const size_t blocks = (dsm.height + block_rows - 1) / block_rows;
  std::vector<uint32_t> block_first(blocks + 1, 0);
  arena.execute([&] {
    tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
      const size_t begin = dsm.index(0, int(b) * block_rows);
      const size_t end = dsm.index(0, std::min(dsm.height, int(b + 1) * block_rows));
      block_first[b + 1] = static_cast<uint32_t>(std::count(id.begin() + begin, id.begin() + end, 1u));
    });
  });
  for (size_t b = 0; b < blocks; ++b) block_first[b + 1] += block_first[b];
  mesh.vertices.resize(block_first[blocks]);
  std::vector<size_t> triangle_first(tile_triangles.size() + 1, 0);
  for (size_t t = 0; t < tile_triangles.size(); ++t)
    triangle_first[t + 1] = triangle_first[t] + tile_triangles[t].size();
  mesh.triangles.resize(triangle_first.back());
  arena.execute([&] {
    tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
      uint32_t next = block_first[b];
      for (int row = int(b) * block_rows; row < std::min(dsm.height, int(b + 1) * block_rows); ++row) {
        for (int col = 0; col < dsm.width; ++col) {
          const size_t cell = dsm.index(col, row);
          if (!id[cell]) continue;
          id[cell] = next;
          mesh.vertices[next++] = {dsm.center_x(col), dsm.center_y(row), height[cell]};
        }
      }
    });
    tbb::parallel_for(size_t(0), tile_triangles.size(), [&](size_t t) {
      Triangle* out = mesh.triangles.data() + triangle_first[t];
      for (const Triangle& cells : tile_triangles[t]) *out++ = {id[cells[0]], id[cells[1]], id[cells[2]]};
    });
  });
  report(progress, 1);
  return mesh;
}

}  // namespace dsmplan
