// ZoneSet (airspace.hpp): many zones behind a uniform grid of their boxes, so that a check costs
// what the zones near it cost. A motion visits the cells its x, y segment crosses (the grid
// traversal of Amanatides & Woo, "A fast voxel traversal algorithm for ray tracing",
// Eurographics 1987); every zone whose box the segment meets is listed in one of them (a box is
// listed in every cell it overlaps, widened by a millimetre against rounding), so the zones
// asked are a superset of those that can refuse, and the answers are the members' own.
#include <algorithm>
#include <cmath>

#include "dsmplan/airspace.hpp"

namespace dsmplan {

namespace {

constexpr double kWiden = 1e-3;  // metres a box is widened by when listed
constexpr int kMaxCells = 1024;  // a side of the grid, at most

}  // namespace

struct ZoneSet::Grid {
  std::vector<std::shared_ptr<const AirspaceConstraint>> zones;
  double x0 = 0, y0 = 0, cell = 1;
  int nx = 0, ny = 0;
  std::vector<uint32_t> start, members;  // cell k's zones: members[start[k], start[k + 1])

  // The zones of the cells the segment a-b crosses, ascending, each once.
  void near(const Point3& a, const Point3& b, std::vector<uint32_t>& out) const {
    out.clear();
    if (nx == 0) return;
    // Clipped to the grid (Liang-Barsky): t in [t0, t1].
    double ua = (a[0] - x0) / cell, va = (a[1] - y0) / cell, ub = (b[0] - x0) / cell, vb = (b[1] - y0) / cell;
    double t0 = 0, t1 = 1;
    const double d[2] = {ub - ua, vb - va}, from[2] = {ua, va}, size[2] = {double(nx), double(ny)};
    for (int k = 0; k < 2; ++k) {
      if (d[k] == 0) {
        if (from[k] < 0 || from[k] > size[k]) return;
        continue;
      }
      double lo = (0 - from[k]) / d[k], hi = (size[k] - from[k]) / d[k];
      if (lo > hi) std::swap(lo, hi);
      t0 = std::max(t0, lo), t1 = std::min(t1, hi);
    }
    if (!(t0 <= t1)) return;
    const double su = ua + t0 * d[0], sv = va + t0 * d[1], eu = ua + t1 * d[0], ev = va + t1 * d[1];
    int cu = std::clamp(static_cast<int>(std::floor(su)), 0, nx - 1),
        cv = std::clamp(static_cast<int>(std::floor(sv)), 0, ny - 1);
    const int end_u = std::clamp(static_cast<int>(std::floor(eu)), 0, nx - 1);
    const int end_v = std::clamp(static_cast<int>(std::floor(ev)), 0, ny - 1);
    const int step_u = d[0] > 0 ? 1 : -1, step_v = d[1] > 0 ? 1 : -1;
    double next_u = d[0] != 0 ? ((d[0] > 0 ? cu + 1 : cu) - ua) / d[0] : INFINITY;
    double next_v = d[1] != 0 ? ((d[1] > 0 ? cv + 1 : cv) - va) / d[1] : INFINITY;
    const double delta_u = d[0] != 0 ? 1 / std::abs(d[0]) : INFINITY,
                 delta_v = d[1] != 0 ? 1 / std::abs(d[1]) : INFINITY;
    for (int steps = std::abs(end_u - cu) + std::abs(end_v - cv) + 2; steps > 0; --steps) {
      const size_t k = static_cast<size_t>(cv) * nx + cu;
      out.insert(out.end(), members.begin() + start[k], members.begin() + start[k + 1]);
      if (cu == end_u && cv == end_v) break;
      if (next_u < next_v) {
        if (cu == end_u) break;
        cu += step_u, next_u += delta_u;
      } else {
        if (cv == end_v) break;
        cv += step_v, next_v += delta_v;
      }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }
};

ZoneSet::ZoneSet(std::vector<std::shared_ptr<const AirspaceConstraint>> zones) : grid_(nullptr) {
  auto g = std::make_unique<Grid>();
  g->zones = std::move(zones);
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  std::vector<double> sides;
  for (const auto& zone : g->zones) {
    const std::array<double, 4> b = zone->box();
    x0 = std::min(x0, b[0]), y0 = std::min(y0, b[1]), x1 = std::max(x1, b[2]), y1 = std::max(y1, b[3]);
    sides.push_back(std::max(b[2] - b[0], b[3] - b[1]));
  }
  if (!g->zones.empty()) {
    // Cells about a zone's size (the median's), at most kMaxCells a side.
    std::nth_element(sides.begin(), sides.begin() + sides.size() / 2, sides.end());
    const double extent = std::max({x1 - x0, y1 - y0, 1e-3});
    g->cell = std::max(sides[sides.size() / 2], extent / kMaxCells);
    g->x0 = x0 - kWiden, g->y0 = y0 - kWiden;
    g->nx = std::min(kMaxCells, static_cast<int>(std::ceil((x1 - x0 + 2 * kWiden) / g->cell)) + 1);
    g->ny = std::min(kMaxCells, static_cast<int>(std::ceil((y1 - y0 + 2 * kWiden) / g->cell)) + 1);
    const auto cells_of = [&](const std::array<double, 4>& b, auto&& visit) {
      const int c0 = std::clamp(static_cast<int>(std::floor((b[0] - kWiden - g->x0) / g->cell)), 0, g->nx - 1);
      const int c1 = std::clamp(static_cast<int>(std::floor((b[2] + kWiden - g->x0) / g->cell)), 0, g->nx - 1);
      const int r0 = std::clamp(static_cast<int>(std::floor((b[1] - kWiden - g->y0) / g->cell)), 0, g->ny - 1);
      const int r1 = std::clamp(static_cast<int>(std::floor((b[3] + kWiden - g->y0) / g->cell)), 0, g->ny - 1);
      for (int r = r0; r <= r1; ++r)
        for (int c = c0; c <= c1; ++c) visit(static_cast<size_t>(r) * g->nx + c);
    };
    g->start.assign(static_cast<size_t>(g->nx) * g->ny + 1, 0);
    for (const auto& zone : g->zones) cells_of(zone->box(), [&](size_t k) { ++g->start[k + 1]; });
    for (size_t k = 1; k < g->start.size(); ++k) g->start[k] += g->start[k - 1];
    g->members.resize(g->start.back());
    std::vector<uint32_t> fill(g->start.begin(), g->start.end() - 1);
    for (uint32_t i = 0; i < g->zones.size(); ++i)
      cells_of(g->zones[i]->box(), [&](size_t k) { g->members[fill[k]++] = i; });
  }
  grid_ = std::move(g);
}

ZoneSet::~ZoneSet() = default;

const std::vector<std::shared_ptr<const AirspaceConstraint>>& ZoneSet::zones() const { return grid_->zones; }

std::string ZoneSet::name() const { return std::to_string(grid_->zones.size()) + " no-fly zones"; }

bool ZoneSet::state_valid(const Point3& p) const { return refused_by(p, p) == nullptr; }

bool ZoneSet::motion_valid(const Point3& p, const Point3& q) const { return refused_by(p, q) == nullptr; }

const FlightConstraint* ZoneSet::refused_by(const Point3& p, const Point3& q) const {
  thread_local std::vector<uint32_t> near;
  grid_->near(p, q, near);
  for (const uint32_t i : near) {
    const AirspaceConstraint& zone = *grid_->zones[i];
    if (p == q ? !zone.state_valid(p) : !zone.motion_valid(p, q)) return &zone;
  }
  return nullptr;
}

}  // namespace dsmplan
