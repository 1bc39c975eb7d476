// A zone of airspace.hpp kept at a safety distance, as a FlightConstraint. Horizontally exact: a
// segment comes within r of the area where it meets the capsule (the points within r of a
// segment: a strip and two discs, convex, so each meets a line in one interval) of an edge, or
// where it runs inside the area; the pieces between capsules cross no edge, so the crossing
// number of one point settles each (O'Rourke, "Computational Geometry in C", 2nd ed. 1998,
// Section 7.4). Vertically, the AGL limits count from the ground's envelope within r: the
// least (greatest) ground of the cells around each cell, by the running minimum of van Herk
// ("A fast algorithm for local minimum and maximum filters on rectangular and octagonal
// kernels", Pattern Recognition Letters 13, 1992) and Gil & Werman ("Computing 2-D min, median,
// and max filters", IEEE PAMI 15, 1993): three comparisons a cell whatever the window, rows then
// columns. A piece's greatest height above an envelope is GroundGrid::max_height_above(), exact.
#include <algorithm>
#include <cmath>
#include <utility>

#include "dsmplan/airspace.hpp"
#include "plan/airspace_rings.hpp"

namespace dsmplan {

namespace {

using detail::Ring;
using detail::Xy;
using Interval = std::pair<double, double>;

// Rounding margin added to the safety distance: far above double's 1e-9 m at UTM coordinates.
constexpr double kRoundingMargin = 1e-6;

// out[i] = min(in[i .. i + w - 1]) for i in [0, in.size() - w + 1) (van Herk / Gil-Werman).
std::vector<float> running_min(const std::vector<float>& in, size_t w) {
  const size_t n = in.size();
  if (n < w) return {};
  const size_t blocks = (n + w - 1) / w, padded = blocks * w;
  std::vector<float> g(padded), h(padded);
  for (size_t i = 0; i < padded; ++i) {
    const float v = i < n ? in[i] : INFINITY;
    g[i] = i % w == 0 ? v : std::min(g[i - 1], v);
  }
  for (size_t i = padded; i-- > 0;) {
    const float v = i < n ? in[i] : INFINITY;
    h[i] = i % w == w - 1 ? v : std::min(h[i + 1], v);
  }
  std::vector<float> out(n - w + 1);
  for (size_t i = 0; i < out.size(); ++i) out[i] = std::min(h[i], g[i + w - 1]);
  return out;
}

// The least value of `ground` over the cells within kc columns and kr rows of each cell of the
// crop [c0, c1) x [r0, r1) (ground's cell indices, inside it); a window reaching beyond the
// raster gives -infinity (unknown ground). `sign` -1 takes the greatest instead, negated.
Grid envelope(const Grid& ground, int c0, int c1, int r0, int r1, int kc, int kr, float sign) {
  const int w = c1 - c0, h = r1 - r0;
  auto at = [&](int c, int r) {
    if (c < 0 || r < 0 || c >= ground.width || r >= ground.height) return -INFINITY;
    return sign * ground.z[ground.index(c, r)];
  };
  // Rows first: each row of the crop's rows +- kr, the minimum over +- kc columns.
  std::vector<float> across(static_cast<size_t>(w) * (h + 2 * kr));
  std::vector<float> line(static_cast<size_t>(w) + 2 * kc);
  for (int r = r0 - kr; r < r1 + kr; ++r) {
    for (int c = c0 - kc; c < c1 + kc; ++c) line[c - (c0 - kc)] = at(c, r);
    const std::vector<float> m = running_min(line, 2 * kc + 1);
    std::copy(m.begin(), m.end(), across.begin() + static_cast<size_t>(r - (r0 - kr)) * w);
  }
  Grid out(w, h, ground.x0 + c0 * ground.cell_x, ground.y0 - r0 * ground.cell_y, ground.cell_x, ground.cell_y);
  std::vector<float> column(static_cast<size_t>(h) + 2 * kr);
  for (int c = 0; c < w; ++c) {
    for (int r = 0; r < h + 2 * kr; ++r) column[r] = across[static_cast<size_t>(r) * w + c];
    const std::vector<float> m = running_min(column, 2 * kr + 1);
    for (int r = 0; r < h; ++r) out.z[out.index(c, r)] = m[r];
  }
  return out;
}

// The t (all reals) where base + t * dir lies in [lo, hi]; empty as lo > hi.
Interval slab(double base, double dir, double lo, double hi) {
  if (dir == 0) return base >= lo && base <= hi ? Interval{-INFINITY, INFINITY} : Interval{1, 0};
  double a = (lo - base) / dir, b = (hi - base) / dir;
  if (a > b) std::swap(a, b);
  return {a, b};
}

// The t where the line p + t d lies within r of the point c.
Interval disc(const Xy& p, const Xy& d, const Xy& c, double r) {
  const double ex = p[0] - c[0], ey = p[1] - c[1];
  const double a = d[0] * d[0] + d[1] * d[1], b = 2 * (d[0] * ex + d[1] * ey), k = ex * ex + ey * ey - r * r;
  if (a == 0) return k <= 0 ? Interval{-INFINITY, INFINITY} : Interval{1, 0};
  const double disc = b * b - 4 * a * k;
  if (disc < 0) return {1, 0};
  const double root = std::sqrt(disc);
  return {(-b - root) / (2 * a), (-b + root) / (2 * a)};
}

// The t where the line p + t d lies within r of the segment a-b: the capsule, convex, so the
// union of its strip's interval and its discs' is one interval.
Interval capsule(const Xy& p, const Xy& d, const Xy& a, const Xy& b, double r) {
  Interval best{INFINITY, -INFINITY};
  auto add = [&](const Interval& i) {
    if (i.first <= i.second) best = {std::min(best.first, i.first), std::max(best.second, i.second)};
  };
  add(disc(p, d, a, r));
  add(disc(p, d, b, r));
  const double ex = b[0] - a[0], ey = b[1] - a[1], len = std::hypot(ex, ey);
  if (len > 0) {
    const double ux = ex / len, uy = ey / len;  // along the edge, and (-uy, ux) across it
    const double px = p[0] - a[0], py = p[1] - a[1];
    const Interval along = slab(px * ux + py * uy, d[0] * ux + d[1] * uy, 0, len);
    const Interval across = slab(-px * uy + py * ux, -d[0] * uy + d[1] * ux, -r, r);
    add({std::max(along.first, across.first), std::min(along.second, across.second)});
  }
  return best;
}

}  // namespace

struct AirspaceConstraint::State {
  AirspaceZone zone;
  double safety = 0, reach = 0;
  Xy origin{};
  std::vector<Ring> rings;                                                      // open, relative to origin
  double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;  // relative, widened by reach
  double z_low = -INFINITY, z_high = INFINITY;                                  // the CRS limits widened by safety
  bool agl_floor = false, agl_ceiling = false;
  double floor_height = 0, ceiling_height = 0;  // AGL, widened by safety
  std::shared_ptr<const GroundGrid> ground;
  GroundGrid floor_envelope, ceiling_envelope;  // the lowest ground around; the highest, negated
  bool ground_known = false;

  bool near_area(const Xy& p) const {  // relative
    return detail::inside_rings(rings, p) || detail::distance_to_edges(rings, p) <= reach;
  }
  // The AGL limits over the piece a-b (CRS): can a point of it lie between them?
  bool within_agl(const Point3& a, const Point3& b) const {
    if (!ground_known) return true;  // unknown ground: the floor reaches down, the ceiling up
    if (agl_floor && floor_envelope.max_height_above(a, b) < floor_height) return false;
    if (agl_ceiling && -ceiling_envelope.max_height_above({a[0], a[1], -a[2]}, {b[0], b[1], -b[2]}) > ceiling_height)
      return false;
    return true;
  }
};

AirspaceConstraint::AirspaceConstraint(AirspaceZone zone, double safety, std::shared_ptr<const GroundGrid> ground,
                                       const std::array<double, 4>* asked) {
  check_zone(zone);
  if (!(safety >= 0) || !std::isfinite(safety)) throw ArgumentError("safety", "must be a number >= 0");
  auto s = std::make_unique<State>();
  s->safety = safety;
  s->reach = safety + kRoundingMargin;
  s->origin = zone.rings.front().front();
  for (const auto& ring : zone.rings) {
    Ring open = detail::open_ring(ring);
    for (Xy& c : open) {
      c = {c[0] - s->origin[0], c[1] - s->origin[1]};
      s->xmin = std::min(s->xmin, c[0]), s->xmax = std::max(s->xmax, c[0]);
      s->ymin = std::min(s->ymin, c[1]), s->ymax = std::max(s->ymax, c[1]);
    }
    s->rings.push_back(std::move(open));
  }
  s->xmin -= s->reach, s->ymin -= s->reach, s->xmax += s->reach, s->ymax += s->reach;
  using R = ZoneLimit::Reference;
  if (zone.lower.reference == R::crs) s->z_low = zone.lower.height - s->reach;
  if (zone.upper.reference == R::crs) s->z_high = zone.upper.height + s->reach;
  s->agl_floor = zone.lower.reference == R::above_ground;
  s->agl_ceiling = zone.upper.reference == R::above_ground;
  s->floor_height = zone.lower.height - s->reach;
  s->ceiling_height = zone.upper.height + s->reach;
  s->ground = std::move(ground);
  if ((s->agl_floor || s->agl_ceiling) && s->ground && !s->ground->empty()) {
    const Grid& g = s->ground->grid();
    // The crop: the cells the zone's box widened by reach touches, and one more around; the
    // window: reach, plus two cells (a point on a cell's side touches the cell beyond).
    double x0 = s->xmin + s->origin[0], x1 = s->xmax + s->origin[0];
    double y0 = s->ymin + s->origin[1], y1 = s->ymax + s->origin[1];
    if (asked) {  // only where it will be asked: the box holds every point, so no window reaches past it by more
      x0 = std::max(x0, (*asked)[0] - s->reach), y0 = std::max(y0, (*asked)[1] - s->reach);
      x1 = std::min(x1, (*asked)[2] + s->reach), y1 = std::min(y1, (*asked)[3] + s->reach);
    }
    const double c0 = std::max(0.0, std::floor((x0 - g.x0) / g.cell_x) - 1);
    const double c1 = std::min(double(g.width), std::floor((x1 - g.x0) / g.cell_x) + 2);
    const double r0 = std::max(0.0, std::floor((g.y0 - y1) / g.cell_y) - 1);
    const double r1 = std::min(double(g.height), std::floor((g.y0 - y0) / g.cell_y) + 2);
    const int kc = static_cast<int>(std::floor(s->reach / g.cell_x)) + 2;
    const int kr = static_cast<int>(std::floor(s->reach / g.cell_y)) + 2;
    s->ground_known = true;
    if (c0 < c1 && r0 < r1) {  // else the zone lies beyond the raster: the envelopes stay empty, unknown
      const int ci0 = static_cast<int>(c0), ci1 = static_cast<int>(c1);
      const int ri0 = static_cast<int>(r0), ri1 = static_cast<int>(r1);
      if (s->agl_floor) s->floor_envelope = GroundGrid(envelope(g, ci0, ci1, ri0, ri1, kc, kr, 1));
      if (s->agl_ceiling) s->ceiling_envelope = GroundGrid(envelope(g, ci0, ci1, ri0, ri1, kc, kr, -1));
    }
  }
  s->zone = std::move(zone);
  state_ = std::move(s);
}

AirspaceConstraint::~AirspaceConstraint() = default;

const AirspaceZone& AirspaceConstraint::zone() const { return state_->zone; }
double AirspaceConstraint::safety() const { return state_->safety; }
std::array<double, 4> AirspaceConstraint::box() const {
  const State& s = *state_;
  return {s.xmin + s.origin[0], s.ymin + s.origin[1], s.xmax + s.origin[0], s.ymax + s.origin[1]};
}
std::string AirspaceConstraint::name() const { return "no-fly " + zone_label(state_->zone); }

bool AirspaceConstraint::state_valid(const Point3& p) const {
  const State& s = *state_;
  if (p[2] < s.z_low || p[2] > s.z_high) return true;
  const Xy r{p[0] - s.origin[0], p[1] - s.origin[1]};
  if (r[0] < s.xmin || r[0] > s.xmax || r[1] < s.ymin || r[1] > s.ymax || !s.near_area(r)) return true;
  return !s.within_agl(p, p);
}

bool AirspaceConstraint::motion_valid(const Point3& p, const Point3& q) const {
  const State& s = *state_;
  // The part within the CRS limits: t in [t0, t1].
  const Interval band = slab(p[2], q[2] - p[2], s.z_low, s.z_high);
  const double t0 = std::max(0.0, band.first), t1 = std::min(1.0, band.second);
  if (!(t0 <= t1)) return true;
  const Xy a{p[0] - s.origin[0], p[1] - s.origin[1]}, d{q[0] - p[0], q[1] - p[1]};
  auto xy = [&](double t) { return Xy{a[0] + t * d[0], a[1] + t * d[1]}; };
  const Xy e0 = xy(t0), e1 = xy(t1);
  if (std::max(e0[0], e1[0]) < s.xmin || std::min(e0[0], e1[0]) > s.xmax || std::max(e0[1], e1[1]) < s.ymin ||
      std::min(e0[1], e1[1]) > s.ymax)
    return true;
  // The pieces of [t0, t1] over the area widened by reach.
  std::vector<Interval> pieces;
  if (d[0] == 0 && d[1] == 0) {
    if (s.near_area(a)) pieces.push_back({t0, t1});
  } else {
    std::vector<Interval> near;
    for (const Ring& ring : s.rings)
      for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
        const Interval c = capsule(a, d, ring[j], ring[i], s.reach);
        const double lo = std::max(t0, c.first), hi = std::min(t1, c.second);
        if (lo <= hi) near.push_back({lo, hi});
      }
    std::sort(near.begin(), near.end());
    // Between capsules no edge is crossed: each gap is inside the area or outside as a whole.
    double from = t0;
    auto gap = [&](double lo, double hi) {
      if (hi > lo && detail::inside_rings(s.rings, xy((lo + hi) / 2))) pieces.push_back({lo, hi});
    };
    for (const Interval& c : near) {
      gap(from, c.first);
      pieces.push_back(c);
      from = std::max(from, c.second);
    }
    gap(from, t1);
    std::sort(pieces.begin(), pieces.end());
  }
  auto at = [&](double t) {
    return Point3{p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), p[2] + t * (q[2] - p[2])};
  };
  for (size_t k = 0; k < pieces.size();) {
    Interval merged = pieces[k++];
    while (k < pieces.size() && pieces[k].first <= merged.second)
      merged.second = std::max(merged.second, pieces[k++].second);
    if (s.within_agl(at(merged.first), at(merged.second))) return false;
  }
  return true;
}

std::vector<std::shared_ptr<const FlightConstraint>> airspace_constraints(const std::vector<AirspaceZone>& zones,
                                                                          double safety,
                                                                          std::shared_ptr<const GroundGrid> ground,
                                                                          const AirspaceOptions& options) {
  std::vector<std::shared_ptr<const AirspaceConstraint>> blocking;
  for (const AirspaceZone& zone : zones)
    if (zone_blocks(zone, options)) blocking.push_back(std::make_shared<AirspaceConstraint>(zone, safety, ground));
  if (blocking.size() >= kZoneSetFrom) return {std::make_shared<ZoneSet>(std::move(blocking))};
  return {blocking.begin(), blocking.end()};
}

}  // namespace dsmplan
