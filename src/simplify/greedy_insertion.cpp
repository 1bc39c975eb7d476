// The bounded mode: greedy insertion (Garland & Heckbert, "Fast Polygonal Approximation of
// Terrains and Height Fields", CMU-CS-95-181, 1995, algorithm III: Delaunay triangulation,
// incremental insertion with Lawson flips, per-triangle candidates in a heap), run per tile.
// Tile borders are simplified first as polylines (Douglas & Peucker 1973 with the vertical
// error as the measure), so every tile starts from the very border vertices its neighbours
// use: the seams are watertight by construction. A cell centre on a border lies on a border
// edge, where the tile's surface is the polyline's, so the polyline's bound holds there.
// Tiles are made in blocks read as windows of a GridSource (out of core); each tile border is
// simplified by both tiles from its own cells, so no block needs another's results, and one
// pass numbers the vertices at first use, carrying the ids on the seams from block to block.
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
#include <future>
#include <limits>
#include <memory>
#include <mutex>
#include <queue>
#include <string>
#include <vector>

#include "core/text.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/simplify_streamed.hpp"

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
// 24 (issue 37: against hmm, fewer vertices on both cities): NRW 428,457 vertices and 3.89 G
// instructions against 64's 430,674 and 4.24 G (callgrind of dsmplan simplify); Delft (AHN3,
// 1 m, holes filled) 32,770 against 32,990, where hmm keeps 32,847 (16: 32,803; 32: 32,907).
// What smaller tiles cost is seams: a tile's border is a polyline every tile takes as it is,
// so a flat field keeps a vertex at every tile corner (1 in 576 cells at 24) that a larger
// tile would not; urban surfaces need far more than that anyway.
constexpr int default_tile_size = 24;

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

// Heights to fit, the DSM plus a lift (E/2 in conservative mode), NaN where there is no data;
// over a window of the grid (col0, row0, width x height), addressed by the grid's (col, row).
struct Target {
  const float* z;
  int col0, row0, width, height;
  double lift;
  double bound;  // the two-sided bound to keep around the target, margin included
  int reach;     // how far at_or_nearest() looks: the window extends this far around its block

  size_t index(int col, int row) const { return static_cast<size_t>(row - row0) * width + (col - col0); }
  double at(int col, int row) const { return double(z[index(col, row)]) + lift; }
  bool valid(int col, int row) const { return !std::isnan(z[index(col, row)]); }
  bool inside(int col, int row) const {
    return col >= col0 && row >= row0 && col < col0 + width && row < row0 + height;
  }
  const float* row_heights(int row) const { return z + static_cast<size_t>(row - row0) * width; }

  // Height for a vertex at a nodata cell (tile corners only): the nearest valid cell's within
  // `reach`, found in growing square rings; the corner then has no bound of its own. Looking no
  // farther than the block's margin keeps every block's answer the same as its neighbours'.
  // With no valid cell that near, the corner's triangles lie over nodata (dropped) or get
  // refined down to the bound where they reach valid cells.
  double at_or_nearest(int col, int row) const {
    if (valid(col, row)) return at(col, row);
    for (int r = 1; r <= reach; ++r) {
      for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx) {
          if (std::max(std::abs(dx), std::abs(dy)) != r) continue;
          const int c = col + dx, w = row + dy;
          if (inside(c, w) && valid(c, w)) return at(c, w);
        }
      }
    }
    return lift;
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
      const float* heights = target_.row_heights(row);
      const double base = za + gy * (row - a.y) - gx * a.x + (-target_.lift);
      for (int64_t col = lo; col <= hi; ++col) {
        const double error = std::abs(base + gx * double(col) - heights[col - target_.col0]);
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

constexpr uint32_t no_id = std::numeric_limits<uint32_t>::max();
constexpr int default_block_tiles = 42;  // blocks of about 1,000 cells a side, as 16 tiles of 64 were

// A block's cells: tile columns [ti0, ti1) and rows [tj0, tj1), cells [cx0, cx1] x [ry0, ry1].
struct BlockSpan {
  size_t ti0, ti1, tj0, tj1;
  int cx0, cx1, ry0, ry1;
};

BlockSpan block_span(const BoundedLayout& layout, size_t index) {
  const size_t tiles_x = layout.xs.size() - 1, tiles_y = layout.ys.size() - 1, b = layout.block_tiles;
  const size_t bi = index % layout.blocks_x, bj = index / layout.blocks_x;
  BlockSpan span{bi * b, std::min(bi * b + b, tiles_x), bj * b, std::min(bj * b + b, tiles_y), 0, 0, 0, 0};
  span.cx0 = layout.xs[span.ti0];
  span.cx1 = layout.xs[span.ti1];
  span.ry0 = layout.ys[span.tj0];
  span.ry1 = layout.ys[span.tj1];
  return span;
}

// The heights a block needs: its cells and a margin of `reach` cells, clipped to the grid.
struct BlockWindow {
  size_t index = 0;
  int col0 = 0, row0 = 0, width = 0, height = 0;
  std::vector<float> z;
};

BlockWindow read_block_window(GridSource& dsm, const BoundedLayout& layout, size_t index) {
  const Grid& frame = dsm.frame();
  const BlockSpan span = block_span(layout, index);
  BlockWindow window;
  window.index = index;
  window.col0 = std::max(0, span.cx0 - layout.tile);
  window.row0 = std::max(0, span.ry0 - layout.tile);
  window.width = std::min(frame.width - 1, span.cx1 + layout.tile) - window.col0 + 1;
  window.height = std::min(frame.height - 1, span.ry1 + layout.tile) - window.row0 + 1;
  window.z.resize(static_cast<size_t>(window.width) * window.height);
  dsm.read(window.col0, window.row0, window.width, window.height, window.z.data());
  return window;
}

// One tile's part of a block: kept triangles (3 corners each, counter-clockwise in the CRS) and
// the certified error of the tile's own cells (half-open: a border cell is its lower tile's,
// except on the grid's last row and column).
struct TilePart {
  BoundedTile triangles;
  VerticalError error;
  size_t valid_cells = 0;
};

TilePart make_tile(const Grid& frame, const Target& target, const BoundedLayout& layout, size_t i, size_t j,
                   bool has_nodata) {
  const int x0 = layout.xs[i], x1 = layout.xs[i + 1], y0 = layout.ys[j], y1 = layout.ys[j + 1];
  // The four sides, each simplified from its own cells only: the neighbour computes the same.
  std::vector<Point> border;
  simplify_polyline(target, {x0, y0}, {x1, y0}, border);
  simplify_polyline(target, {x1, y0}, {x1, y1}, border);
  simplify_polyline(target, {x0, y1}, {x1, y1}, border);
  simplify_polyline(target, {x0, y0}, {x0, y1}, border);
  TileTriangulation triangulation(target, x0, y0, x1, y1);
  triangulation.start(border);
  triangulation.fill();
  const auto& points = triangulation.points();
  const auto& corners = triangulation.corners();
  TilePart part;
  BoundedTile& kept = part.triangles;
  kept.cols.reserve(corners.size());
  kept.rows.reserve(corners.size());
  kept.heights.reserve(corners.size());
  for (size_t k = 0; k < corners.size(); k += 3) {
    const std::array<Point, 3> p{points[corners[k]], points[corners[k + 1]], points[corners[k + 2]]};
    if (has_nodata && over_nodata_only(target, p)) continue;
    // Counter-clockwise in (col, row), whose rows run south: reversed for the CRS.
    for (int m : {0, 2, 1}) {
      kept.cols.push_back(p[m].x);
      kept.rows.push_back(p[m].y);
      kept.heights.push_back(triangulation.heights()[corners[k + m]]);
    }
  }
  // The certified error, by certify() on the tile's triangles in CRS coordinates: the same
  // measure as for any mesh, not the insertion's own bookkeeping.
  const int cols = x1 - x0 + (x1 == frame.width - 1), rows = y1 - y0 + (y1 == frame.height - 1);
  Grid cells(cols, rows, frame.x0 + x0 * frame.cell_x, frame.y0 - y0 * frame.cell_y, frame.cell_x, frame.cell_y);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const float z = target.z[target.index(x0 + c, y0 + r)];
      cells.z[cells.index(c, r)] = z;
      part.valid_cells += !std::isnan(z);
    }
  }
  Mesh mesh;
  const size_t n = kept.cols.size();
  mesh.vertices.reserve(n);
  for (size_t k = 0; k < n; ++k)
    mesh.vertices.push_back({frame.center_x(kept.cols[k]), frame.center_y(kept.rows[k]), kept.heights[k]});
  mesh.triangles.reserve(n / 3);
  for (uint32_t k = 0; k < n; k += 3) mesh.triangles.push_back({k, k + 1, k + 2});
  part.error = certify(mesh, cells);
  return part;
}

BoundedBlock make_block(const Grid& frame, const BlockWindow& window, const BoundedLayout& layout,
                        const BoundedSimplifyOptions& options) {
  const double half = options.max_error / 2;
  const Target target{window.z.data(),
                      window.col0,
                      window.row0,
                      window.width,
                      window.height,
                      options.conservative ? half : 0.0,
                      (options.conservative ? half : options.max_error) - rounding_margin,
                      layout.tile};
  const bool has_nodata = std::any_of(window.z.begin(), window.z.end(), [](float z) { return std::isnan(z); });
  const BlockSpan span = block_span(layout, window.index);
  const size_t tiles_x = span.ti1 - span.ti0, tiles = tiles_x * (span.tj1 - span.tj0);
  std::vector<TilePart> parts(tiles);
  const bool serial = options.delaunay || options.threads == 1;
  tbb::task_arena arena(serial ? 1 : options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(
        size_t(0), tiles,
        [&](size_t t) {
          parts[t] = make_tile(frame, target, layout, span.ti0 + t % tiles_x, span.tj0 + t / tiles_x, has_nodata);
        },
        tbb::simple_partitioner());
  });
  BoundedBlock block;
  block.index = window.index;
  block.tiles.reserve(tiles);
  for (TilePart& part : parts) {
    block.tiles.push_back(std::move(part.triangles));
    block.error.merge(part.error);
    block.valid_cells += part.valid_cells;
  }
  return block;
}

}  // namespace

void check_bounded_options(const BoundedSimplifyOptions& options) {
  // Below a millimetre the float heights' own rounding (7.6e-6 m at 100 m) is as large as the
  // bound: insertion would chase rounding, cell after cell, instead of ending.
  if (!(options.max_error >= 1e-3) || !(options.max_error <= 1e4)) {
    throw ArgumentError("max_error",
                        "must be from 0.001 to 10000 (vertical units), got " + short_number(options.max_error));
  }
  if (options.tile_size < 0) throw ArgumentError("tile_size", "must be >= 0 (0: automatic)");
  if (options.block_tiles < 0) throw ArgumentError("block_tiles", "must be >= 0 (0: automatic)");
}

BoundedLayout bounded_layout(int width, int height, const BoundedSimplifyOptions& options) {
  check_bounded_options(options);
  if (width < 2 || height < 2) throw ArgumentError("DSM", "needs at least 2 x 2 cells to triangulate");
  BoundedLayout layout;
  layout.tile = options.delaunay ? std::max(width, height)
                                 : std::max(2, options.tile_size ? options.tile_size : default_tile_size);
  layout.block_tiles = options.delaunay ? 1 : options.block_tiles ? options.block_tiles : default_block_tiles;
  layout.xs = split_points(width - 1, layout.tile);
  layout.ys = split_points(height - 1, layout.tile);
  layout.blocks_x = (layout.xs.size() - 1 + layout.block_tiles - 1) / layout.block_tiles;
  layout.blocks_y = (layout.ys.size() - 1 + layout.block_tiles - 1) / layout.block_tiles;
  return layout;
}

BoundedBlock simplify_bounded_block(GridSource& dsm, const BoundedLayout& layout, size_t index,
                                    const BoundedSimplifyOptions& options) {
  return make_block(dsm.frame(), read_block_window(dsm, layout, index), layout, options);
}

BoundedAssembler::BoundedAssembler(const Grid& frame, const BoundedLayout& layout, MeshSink& sink)
    : frame_(frame),
      layout_(layout),
      sink_(sink),
      seam_above_(frame.width, no_id),
      seam_below_(frame.width, no_id),
      seam_left_(frame.height, no_id) {}

void BoundedAssembler::add(const BoundedBlock& block) {
  if (block.index != expected_) throw Error("bounded mode: block " + std::to_string(block.index) + " out of order");
  ++expected_;
  const BlockSpan span = block_span(layout_, block.index);
  const int width = span.cx1 - span.cx0 + 1, height = span.ry1 - span.ry0 + 1;
  ids_.assign(static_cast<size_t>(width) * height, no_id);
  auto id_at = [&](int col, int row) -> uint32_t& { return ids_[size_t(row - span.ry0) * width + (col - span.cx0)]; };
  // The seams with earlier blocks: the row above (from the previous row of blocks) and the
  // column to the left (from the previous block); their shared corner may be known to only one.
  for (int col = span.cx0; col <= span.cx1; ++col) id_at(col, span.ry0) = seam_above_[col];
  for (int row = span.ry0; row <= span.ry1; ++row)
    if (seam_left_[row] != no_id) id_at(span.cx0, row) = seam_left_[row];

  size_t corners = 0;
  for (const BoundedTile& tile : block.tiles) corners += tile.cols.size();
  vertices_.clear();
  triangles_out_.resize(corners / 3);
  size_t k = 0;
  for (const BoundedTile& tile : block.tiles) {
    for (size_t c = 0; c < tile.cols.size(); ++c, ++k) {
      uint32_t& id = id_at(tile.cols[c], tile.rows[c]);
      if (id == no_id) {
        if (next_id_ >= no_id)
          throw ArgumentError("DSM", "the mesh would have 2^32 vertices or more; raise --max-error");
        id = static_cast<uint32_t>(next_id_++);
        vertices_.push_back({frame_.center_x(tile.cols[c]), frame_.center_y(tile.rows[c]), tile.heights[c]});
      }
      triangles_out_[k / 3][k % 3] = id;
    }
  }
  triangles_ += triangles_out_.size();

  for (int col = span.cx0; col <= span.cx1; ++col) seam_below_[col] = id_at(col, span.ry1);
  for (int row = span.ry0; row <= span.ry1; ++row) seam_left_[row] = id_at(span.cx1, row);
  if (block.index % layout_.blocks_x == layout_.blocks_x - 1) {  // the row of blocks is done
    std::swap(seam_above_, seam_below_);
    std::fill(seam_below_.begin(), seam_below_.end(), no_id);
    std::fill(seam_left_.begin(), seam_left_.end(), no_id);
  }
  sink_.append(vertices_, triangles_out_);
}

BoundedStreamResult simplify_bounded(GridSource& dsm, const BoundedSimplifyOptions& options, MeshSink& sink,
                                     const Progress& progress) {
  const Grid& frame = dsm.frame();
  const BoundedLayout layout = bounded_layout(frame.width, frame.height, options);
  if (std::max(frame.width, frame.height) - 1 >= (1 << 30))
    throw ArgumentError("DSM", "more than 2^30 cells a side");  // lattice products must fit 64 bits
  BoundedAssembler assembler(frame, layout, sink);
  BoundedStreamResult result;
  result.blocks = layout.blocks();
  report(progress, 0);
  // The next block's window is read while the current block is made.
  std::future<BlockWindow> next = std::async(std::launch::async, [&] { return read_block_window(dsm, layout, 0); });
  for (size_t index = 0; index < layout.blocks(); ++index) {
    BlockWindow window = next.get();
    if (index + 1 < layout.blocks())
      next = std::async(std::launch::async, [&, index] { return read_block_window(dsm, layout, index + 1); });
    const BoundedBlock block = make_block(frame, window, layout, options);
    window = BlockWindow();
    assembler.add(block);
    result.error.merge(block.error);
    result.valid_cells += block.valid_cells;
    report(progress, double(index + 1) / double(layout.blocks()));  // a pending read is waited for
  }
  if (result.valid_cells == 0) throw ArgumentError("DSM", "has no valid cell");
  result.vertices = assembler.vertices();
  result.triangles = assembler.triangles();
  return result;
}

Mesh simplify_bounded(const Grid& dsm, const BoundedSimplifyOptions& options, const Progress& progress) {
  check_bounded_options(options);
  check_grid(dsm);
  if (dsm.width < 2 || dsm.height < 2) throw ArgumentError("DSM", "needs at least 2 x 2 cells to triangulate");
  GridView view(dsm);
  Mesh mesh;
  mesh.crs = dsm.crs;
  MeshCollector collector(mesh);
  simplify_bounded(view, options, collector, progress);
  return mesh;
}

}  // namespace dsmplan
