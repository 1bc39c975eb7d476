// A path's clearance to the raw DSM taken as solid columns: each valid cell a box over its
// square from below up to its height, the most literal reading of a height raster (no
// interpolation, so no triangulation can hide a chimney between cell centres). The distance
// from a segment to a box is the minimum of a convex piecewise quadratic in the segment's
// parameter, found exactly on each piece (the closest-point formulation of Ericson, Real-Time
// Collision Detection, 2005, ch. 5.1, with the pieces where each coordinate enters or leaves
// the box's slab).
#include <algorithm>
#include <array>
#include <cmath>

#include "dsmplan/columns.hpp"
#include "dsmplan/plan.hpp"

namespace dsmplan {

namespace {

// Squared distance from p + t*d, t in [0, 1], to the box lo <= x <= hi (lo or hi may be infinite).
double segment_box_squared(const Point3& p, const Point3& d, const Point3& lo, const Point3& hi) {
  std::array<double, 8> breaks;
  int n = 0;
  breaks[n++] = 0;
  breaks[n++] = 1;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) continue;
    for (double bound : {lo[k], hi[k]}) {
      const double t = (bound - p[k]) / d[k];
      if (t > 0 && t < 1) breaks[n++] = t;
    }
  }
  for (int i = 1; i < n; ++i)  // at most 8: insertion sort
    for (int j = i; j > 0 && breaks[j - 1] > breaks[j]; --j) std::swap(breaks[j - 1], breaks[j]);
  double best = INFINITY;
  for (int i = 0; i + 1 < n; ++i) {
    const double ta = breaks[i], tb = breaks[i + 1], tm = 0.5 * (ta + tb);
    // On this piece each coordinate is below, inside or above its slab throughout: the squared
    // distance is sum (a_k + b_k t)^2 over the coordinates outside.
    double ab = 0, bb = 0;
    std::array<double, 3> a{}, b{};
    for (int k = 0; k < 3; ++k) {
      const double s = p[k] + tm * d[k];
      const double bound = s < lo[k] ? lo[k] : s > hi[k] ? hi[k] : NAN;
      if (std::isnan(bound)) continue;
      a[k] = p[k] - bound;
      b[k] = d[k];
      ab += a[k] * b[k];
      bb += b[k] * b[k];
    }
    const double t = bb > 0 ? std::clamp(-ab / bb, ta, tb) : ta;
    double f = 0;
    for (int k = 0; k < 3; ++k) f += (a[k] + b[k] * t) * (a[k] + b[k] * t);
    best = std::min(best, std::max(f, 0.0));
  }
  return best;
}

// The cells whose squares may meet the box [xmin - r, xmax + r] x [ymin - r, ymax + r], clamped
// to the grid (none when c0 > c1 or r0 > r1). Indices clamped as doubles first: a place far off
// the grid is billions of cells away, beyond an int (fuzz_pipeline).
struct CellWindow {
  int c0, c1, r0, r1;
};
CellWindow cells_near(const Grid& dsm, double xmin, double ymin, double xmax, double ymax, double r) {
  const auto cell = [](double v, int count) {
    return static_cast<int>(std::clamp(std::floor(v), -1.0, double(count)));
  };
  return {std::max(0, cell((xmin - r - dsm.x0) / dsm.cell_x, dsm.width)),
          std::min(dsm.width - 1, cell((xmax + r - dsm.x0) / dsm.cell_x, dsm.width)),
          std::max(0, cell((dsm.y0 - (ymax + r)) / dsm.cell_y, dsm.height)),
          std::min(dsm.height - 1, cell((dsm.y0 - (ymin - r)) / dsm.cell_y, dsm.height))};
}

}  // namespace

double column_clearance(const Grid& dsm, const Point3& p_, const Point3& q_, double max_d) {
  for (double v : p_)
    if (!std::isfinite(v)) throw ArgumentError("path", "a point is not finite");
  for (double v : q_)
    if (!std::isfinite(v)) throw ArgumentError("path", "a point is not finite");
  if (!(max_d >= 0)) throw ArgumentError("max_d", "must be >= 0");
  if (dsm.cells() == 0) return max_d;
  // Local coordinates around the segment's start: UTM northings lose digits otherwise.
  const Point3 origin = p_;
  const Point3 p{0, 0, 0}, d{q_[0] - p_[0], q_[1] - p_[1], q_[2] - p_[2]};
  const double zlow = std::min(p_[2], q_[2]);
  const double xmin = std::min(p_[0], q_[0]), xmax = std::max(p_[0], q_[0]);
  const double ymin = std::min(p_[1], q_[1]), ymax = std::max(p_[1], q_[1]);
  double best2 = max_d * max_d;
  // Search the cells within r of the segment's box, r doubling: a cell outside lies more than
  // r away, so once the best is within r it is the answer.
  for (double r = std::min(max_d, 2 * std::max(dsm.cell_x, dsm.cell_y));; r = std::min(max_d, 2 * r)) {
    const CellWindow w = cells_near(dsm, xmin, ymin, xmax, ymax, r);
    for (int row = w.r0; row <= w.r1; ++row)
      for (int col = w.c0; col <= w.c1; ++col) {
        const float h = dsm.at(col, row);
        if (std::isnan(h)) continue;
        const double below = zlow - h;  // the segment is at least this far above the column
        if (below > 0 && below * below >= best2) continue;
        const double bx = dsm.x0 + col * dsm.cell_x - origin[0], by = dsm.y0 - (row + 1) * dsm.cell_y - origin[1];
        const Point3 lo{bx, by, -INFINITY}, hi{bx + dsm.cell_x, by + dsm.cell_y, h - origin[2]};
        best2 = std::min(best2, segment_box_squared(p, d, lo, hi));
      }
    if (best2 <= r * r || r >= max_d) break;
  }
  return std::min(max_d, std::sqrt(best2));
}

NearestColumn nearest_column(const Grid& dsm, const Point3& p, double max_d) {
  NearestColumn nearest;
  if (dsm.cells() == 0 || !(max_d >= 0)) return nearest;
  double best = max_d;
  const CellWindow w = cells_near(dsm, p[0], p[1], p[0], p[1], max_d);
  for (int row = w.r0; row <= w.r1; ++row)
    for (int col = w.c0; col <= w.c1; ++col) {
      const float h = dsm.at(col, row);
      if (std::isnan(h)) continue;
      const double x0 = dsm.x0 + col * dsm.cell_x, y1 = dsm.y0 - row * dsm.cell_y;
      const double dx = std::max({x0 - p[0], 0.0, p[0] - (x0 + dsm.cell_x)});
      const double dy = std::max({(y1 - dsm.cell_y) - p[1], 0.0, p[1] - y1});
      const double dz = std::max(0.0, p[2] - h);
      const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (d < best || (!nearest.found && d <= best))
        best = d, nearest = {true, d, x0 + dsm.cell_x / 2, y1 - dsm.cell_y / 2, h};
    }
  return nearest;
}

double lowest_clear_height(const Grid& dsm, double x, double y, double safety) {
  if (!std::isfinite(x) || !std::isfinite(y)) throw ArgumentError("place", "x and y must be finite numbers");
  if (!(safety >= 0) || !std::isfinite(safety)) throw ArgumentError("safety", "must be a finite number >= 0");
  double lowest = -INFINITY;
  if (dsm.cells() == 0) return lowest;
  const CellWindow w = cells_near(dsm, x, y, x, y, safety);
  for (int row = w.r0; row <= w.r1; ++row)
    for (int col = w.c0; col <= w.c1; ++col) {
      const float h = dsm.at(col, row);
      if (std::isnan(h) || h + safety <= lowest) continue;
      const double x0 = dsm.x0 + col * dsm.cell_x, y1 = dsm.y0 - row * dsm.cell_y;
      const double dx = std::max({x0 - x, 0.0, x - (x0 + dsm.cell_x)});
      const double dy = std::max({(y1 - dsm.cell_y) - y, 0.0, y - y1});
      const double d2 = dx * dx + dy * dy;
      if (d2 <= safety * safety) lowest = std::max(lowest, h + std::sqrt(safety * safety - d2));
    }
  return lowest;
}

}  // namespace dsmplan
