// The height profile of a planned path: distance along the path (x) against height (y).
//
// Why: a path over a 2.5D obstacle surface must keep two limits in height, and a picture from
// above (render_view) shows neither. Below, the planner keeps `safety` from every obstacle; above,
// the flight volume ends at ground + max_agl (the planner's top, and the legal ceiling of small
// drones, 120 m in the EU's open category). In profile both show at a glance: the path (magenta)
// with its +-safety band must stay clear of the grey silhouette of the DSM under it, and under
// the red dashed ceiling.
//
// What is drawn is exact, not resampled: the path's x,y projection is cut at every boundary of
// the DSM's cells that it crosses (and, separately, of the DTM's), so each piece lies over one
// cell and the silhouette is the DSM's cells as they are: a building is a step as wide as the
// path's run over it. Heights are linear along each straight piece of the path, so its least
// height above a cell and its greatest above the ground are found at the pieces' ends.
//
// Pure computation: no GDAL, no files. Canvas, lines and text: picture/canvas.hpp.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "core/text.hpp"
#include "dsmplan/picture.hpp"
#include "picture/canvas.hpp"
#include "picture/zones.hpp"

namespace dsmplan {

namespace {

using namespace draw;

constexpr double kMaxSide = 30000;
constexpr double kMaxPixels = double(1 << 26);

constexpr Rgb kSilhouette{0.66f, 0.66f, 0.66f};
constexpr Rgb kTerrain{0.55f, 0.32f, 0.10f};      // brown
constexpr Rgb kCeiling{0.86f, 0.08f, 0.08f};      // red
constexpr Rgb kLowestClear{0.10f, 0.20f, 0.60f};  // dark blue
constexpr Rgb kPath{1.0f, 0.0f, 1.0f};            // #ff00ff, as the 3D viewer's tube
constexpr Rgb kGridLine{0.90f, 0.90f, 0.90f};
constexpr Rgb kWaypoint{1.0f, 210 / 255.0f, 0.0f};  // render_view's waypoint yellow
constexpr Rgb kOutline{0.1f, 0.1f, 0.1f};
constexpr float kBandAlpha = 0.25f;

void check_grid(const Grid& grid, const char* name) {
  if (grid.width <= 0 || grid.height <= 0 || grid.z.size() != grid.cells() || !(grid.cell_x > 0) ||
      !(grid.cell_y > 0) || !std::isfinite(grid.x0) || !std::isfinite(grid.y0)) {
    throw ArgumentError(name, "is not a grid with cells");
  }
}

// Calls visit(k, t0, t1, z) for the pieces of segment k (path[k] to path[k + 1]) that lie over
// one cell of `grid` each, in order; t is the fraction along the segment, z the cell's height
// (NaN: nodata or outside the grid). A segment without x,y length is one piece over its cell.
template <class Visit>
void walk_cells(const std::vector<Point3>& path, const Grid& grid, Visit&& visit) {
  std::vector<double> cuts;
  for (size_t k = 0; k + 1 < path.size(); ++k) {
    const Point3 &p = path[k], &q = path[k + 1];
    const double dx = q[0] - p[0], dy = q[1] - p[1];
    if (dx == 0 && dy == 0) {
      visit(k, 0.0, 1.0, grid.height_at(p[0], p[1]));
      continue;
    }
    cuts.assign({0.0, 1.0});
    if (dx != 0) {  // the lines x = x0 + i cell_x between the ends, inside the grid
      const double a = std::max(0.0, std::ceil((std::min(p[0], q[0]) - grid.x0) / grid.cell_x));
      const double b = std::min(double(grid.width), std::floor((std::max(p[0], q[0]) - grid.x0) / grid.cell_x));
      for (double i = a; i <= b; ++i) {
        const double t = (grid.x0 + i * grid.cell_x - p[0]) / dx;
        if (t > 0 && t < 1) cuts.push_back(t);
      }
    }
    if (dy != 0) {  // the lines y = y0 - j cell_y
      const double a = std::max(0.0, std::ceil((grid.y0 - std::max(p[1], q[1])) / grid.cell_y));
      const double b = std::min(double(grid.height), std::floor((grid.y0 - std::min(p[1], q[1])) / grid.cell_y));
      for (double j = a; j <= b; ++j) {
        const double t = (grid.y0 - j * grid.cell_y - p[1]) / dy;
        if (t > 0 && t < 1) cuts.push_back(t);
      }
    }
    std::sort(cuts.begin(), cuts.end());
    for (size_t i = 1; i < cuts.size(); ++i) {
      const double t0 = cuts[i - 1], t1 = cuts[i];
      if (!(t1 > t0)) continue;
      const double tm = 0.5 * (t0 + t1);  // inside the piece: away from every boundary
      visit(k, t0, t1, grid.height_at(p[0] + tm * dx, p[1] + tm * dy));
    }
  }
}

void add_step(std::vector<ProfileStep>& steps, double from, double to, float z) {
  if (!(to > from)) return;
  if (!steps.empty() && steps.back().to == from &&
      (steps.back().z == z || (std::isnan(steps.back().z) && std::isnan(z)))) {
    steps.back().to = to;
    return;
  }
  steps.push_back({from, to, z});
}

}  // namespace

PathProfile profile_path(const std::vector<Point3>& path, const Grid& dsm, const Grid* dtm) {
  if (path.size() < 2) throw ArgumentError("path", "needs at least two points");
  for (size_t i = 0; i < path.size(); ++i)
    if (!(std::isfinite(path[i][0]) && std::isfinite(path[i][1]) && std::isfinite(path[i][2])))
      throw ArgumentError("path", "point " + std::to_string(i + 1) + " is not finite");
  check_grid(dsm, "DSM");
  if (dtm) check_grid(*dtm, "DTM");

  PathProfile out;
  out.distance.resize(path.size());
  for (size_t k = 1; k < path.size(); ++k)
    out.distance[k] = out.distance[k - 1] + std::hypot(path[k][0] - path[k - 1][0], path[k][1] - path[k - 1][1]);
  out.length = out.distance.back();
  const std::vector<double>& d = out.distance;
  // Exactly the point's own values at the ends, so that pieces of neighbouring segments meet.
  auto distance_at = [&](size_t k, double t) { return t == 1 ? d[k + 1] : d[k] + t * (d[k + 1] - d[k]); };
  auto height_of_path = [&](size_t k, double t) {
    return t == 1 ? path[k + 1][2] : path[k][2] + t * (path[k + 1][2] - path[k][2]);
  };

  auto note_dsm = [&](size_t k, double t0, double t1, float z) {
    add_step(out.dsm, distance_at(k, t0), distance_at(k, t1), z);
    if (std::isnan(z)) return;
    for (double t : {t0, t1}) {
      const double above = height_of_path(k, t) - z;
      if (!(above >= out.min_above_dsm)) out.min_above_dsm = above, out.min_above_dsm_at = distance_at(k, t);
      if (!dtm && !(above <= out.max_above_ground))
        out.max_above_ground = above, out.max_above_ground_at = distance_at(k, t);
    }
  };
  walk_cells(path, dsm, note_dsm);
  if (dtm) {
    auto note_dtm = [&](size_t k, double t0, double t1, float z) {
      add_step(out.dtm, distance_at(k, t0), distance_at(k, t1), z);
      if (std::isnan(z)) return;
      for (double t : {t0, t1}) {
        const double above = height_of_path(k, t) - z;
        if (!(above <= out.max_above_ground)) out.max_above_ground = above, out.max_above_ground_at = distance_at(k, t);
      }
    };
    walk_cells(path, *dtm, note_dtm);
  }
  return out;
}

// ---- the picture ------------------------------------------------------------------------------

namespace {

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

// Ticks: the multiples of `step` in [lo, hi].
std::vector<double> ticks(double lo, double hi, double step) {
  std::vector<double> out;
  for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + 1e-9 * step; ++k) out.push_back(k * step);
  return out;
}

// A polyline drawn dashed: `on` pixels drawn, `off` left, along its length (the pattern runs on
// across the polyline's corners).
void draw_dashed(Canvas& canvas, const std::vector<std::array<double, 2>>& points, Rgb colour, double width, double on,
                 double off) {
  double phase = 0;  // position within the current period
  for (size_t k = 1; k < points.size(); ++k) {
    const double x0 = points[k - 1][0], y0 = points[k - 1][1], x1 = points[k][0], y1 = points[k][1];
    const double length = std::hypot(x1 - x0, y1 - y0);
    double s = 0;
    while (s < length) {
      const bool drawing = phase < on;
      const double run = std::min(length - s, drawing ? on - phase : on + off - phase);
      if (drawing && run > 0) {
        const double a = s / length, b = (s + run) / length;
        draw_line(canvas, x0 + a * (x1 - x0), y0 + a * (y1 - y0), x0 + b * (x1 - x0), y0 + b * (y1 - y0), colour, 1,
                  width);
      }
      s += run;
      phase += run;
      if (phase >= on + off - 1e-9) phase = 0;
    }
  }
}

// Steps as polylines in pixels: flat over each step, risers where neighbouring steps touch; a
// step without height breaks the line.
std::vector<std::vector<std::array<double, 2>>> step_lines(const std::vector<ProfileStep>& steps, double offset,
                                                           const auto& px, const auto& py) {
  std::vector<std::vector<std::array<double, 2>>> lines;
  const ProfileStep* previous = nullptr;
  for (const ProfileStep& step : steps) {
    if (std::isnan(step.z)) {
      previous = nullptr;
      continue;
    }
    if (!previous || previous->to != step.from) lines.emplace_back();
    lines.back().push_back({px(step.from), py(step.z + offset)});
    lines.back().push_back({px(step.to), py(step.z + offset)});
    previous = &step;
  }
  return lines;
}

// Pixel rows [top, bottom) of a column filled with fractional coverage at both ends.
void fill_column(Canvas& canvas, int x, double top, double bottom, Rgb colour, float alpha) {
  top = std::max(top, 0.0);
  bottom = std::min(bottom, double(canvas.height()));
  for (int y = static_cast<int>(std::floor(top)); y < bottom; ++y) {
    const double cover = std::min(bottom, y + 1.0) - std::max(top, double(y));
    if (cover > 0) canvas.blend(x, y, colour, static_cast<float>(alpha * cover));
  }
}

struct LegendEntry {
  enum Kind { Fill, Line, Dashed, Dotted, Band, Disc, Zone } kind;
  Rgb colour;
  std::string label;
  double width = 1;  ///< of a line, pixels
};

}  // namespace

Image render_profile(const std::vector<Point3>& path, const Grid& dsm, const Grid* dtm, const ProfileOptions& options) {
  const int W = options.width, H = options.height;
  if (W < 240 || H < 160)
    throw ArgumentError(W < 240 ? "--width" : "--height", "the picture must be at least 240 x 160 pixels");
  if (W > kMaxSide || H > kMaxSide || double(W) * H > kMaxPixels)
    throw ArgumentError(W > kMaxSide ? "--width" : "--height",
                        "the picture must be at most 30000 pixels a side and 2^26 in all");
  if (!(options.safety >= 0 && options.safety <= 1000))
    throw ArgumentError("safety", "must be from 0 to 1000, got " + short_number(options.safety));
  if (!(options.max_agl > 0 && std::isfinite(options.max_agl)))
    throw ArgumentError("max_agl", "must be positive and finite");
  const bool fixed_axis = !std::isnan(options.z_min) || !std::isnan(options.z_max);
  if (fixed_axis && !(std::isfinite(options.z_min) && std::isfinite(options.z_max) && options.z_min < options.z_max))
    throw ArgumentError("height axis", "needs both ends, finite, bottom below top");
  for (const Point3& w : options.waypoints)
    if (!(std::isfinite(w[0]) && std::isfinite(w[1]) && std::isfinite(w[2])))
      throw ArgumentError("waypoints", "a waypoint is not finite");

  const PathProfile profile = profile_path(path, dsm, dtm);
  if (!(profile.length > 0)) throw ArgumentError("path", "has no x,y length: there is nothing to draw along it");
  const std::vector<ProfileStep>& ground = dtm ? profile.dtm : profile.dsm;
  const double safety = options.safety, max_agl = options.max_agl;
  // Each zone's part of the section, floor to ceiling over the ground's steps.
  std::vector<std::vector<ZonePiece>> zone_parts;
  bool blocking_zone = false, other_zone = false;
  for (const AirspaceZone& zone : options.zones.zones) {
    check_zone(zone);
    zone_parts.push_back(zone_pieces(zone, zone_spans(zone, path, profile.distance), ground));
    (zone_blocks(zone, options.zones.airspace) ? blocking_zone : other_zone) = true;
  }

  // ---- sizes: text and marks grow with the picture ----
  const int s = std::clamp(std::min(W / 600, H / 250), 1, 4);
  const int pad = 8 * s, glyph = kGlyph * s, tick = 5 * s;
  const double marker_radius = 3 + 2 * s;
  const double line_width = 1.5 * s + 0.5, path_width = 2 * s + 1;

  // ---- the legend, laid out first: it sets the bottom margin ----
  std::vector<LegendEntry> legend;
  legend.push_back({LegendEntry::Fill, kSilhouette, "DSM under the path"});
  if (dtm) legend.push_back({LegendEntry::Line, kTerrain, "terrain (DTM)", line_width});
  legend.push_back({LegendEntry::Dashed, kCeiling,
                    std::string("ceiling: ") + (dtm ? "DTM" : "DSM") + " + " + number(max_agl) + " m", line_width});
  legend.push_back({LegendEntry::Line, kPath, "path", path_width});
  if (safety > 0) legend.push_back({LegendEntry::Band, kPath, "safety +/-" + number(safety) + " m", path_width});
  const bool lowest_clear = std::any_of(options.lowest_clear.begin(), options.lowest_clear.end(),
                                        [](const std::array<double, 2>& p) { return std::isfinite(p[1]); });
  if (lowest_clear)
    legend.push_back(
        {LegendEntry::Dotted, kLowestClear, "lowest clear height (" + number(safety) + " m from the DSM)", line_width});
  if (!options.waypoints.empty()) legend.push_back({LegendEntry::Disc, kWaypoint, "waypoints"});
  if (blocking_zone) legend.push_back({LegendEntry::Zone, rgb(kZoneBlocking), "no-fly zone", line_width});
  if (other_zone) legend.push_back({LegendEntry::Zone, rgb(kZoneOther), "zone, not blocking", line_width});
  const int swatch = 26 * s, swatch_gap = 6 * s, entry_gap = 22 * s, row_height = glyph + 8 * s;
  std::vector<std::vector<size_t>> rows(1);
  std::vector<int> row_widths(1, 0);
  for (size_t i = 0; i < legend.size(); ++i) {
    const int w = swatch + swatch_gap + text_width(legend[i].label, s);
    if (!rows.back().empty() && row_widths.back() + entry_gap + w > W - 2 * pad)
      rows.emplace_back(), row_widths.push_back(0);
    row_widths.back() += (rows.back().empty() ? 0 : entry_gap) + w;
    rows.back().push_back(i);
  }

  // ---- vertical layout ----
  std::string title = options.title;
  int title_scale = text_width(title, 2 * s) <= W - 2 * pad ? 2 * s : s;
  const int fits = (W - 2 * pad) / (kGlyph * title_scale);
  if (static_cast<int>(title.size()) > fits) title = title.substr(0, std::max(0, fits - 3)) + "...";
  // Below the title, room for the numbers of waypoints near the top of the plot.
  const int top =
      pad + (title.empty() ? 0 : kGlyph * title_scale + pad) + (options.waypoints.empty() ? 0 : glyph + 2 * s);
  const int legend_height = static_cast<int>(rows.size()) * row_height;
  const int bottom_margin = 1 + tick + 3 * s + glyph + 8 * s + glyph + 10 * s + legend_height + pad;
  const int plot_h = H - top - bottom_margin;
  if (plot_h < 40) throw ArgumentError("height", "too small for the plot, its labels and legend");

  // ---- the height axis ----
  double lo = INFINITY, hi = -INFINITY;
  auto span = [&](double z) {
    if (std::isfinite(z)) lo = std::min(lo, z), hi = std::max(hi, z);
  };
  for (const ProfileStep& step : profile.dsm) span(step.z);
  for (const ProfileStep& step : profile.dtm) span(step.z);
  for (const ProfileStep& step : ground) span(step.z + max_agl);
  for (const Point3& p : path) span(p[2] - safety), span(p[2] + safety);
  for (const auto& p : options.lowest_clear) span(p[1]);
  if (!zone_parts.empty()) {  // the zones' limits near the flight; far higher ones leave by the top
    const double cap_lo = lo - max_agl, cap_hi = hi + max_agl;
    for (const auto& pieces : zone_parts)
      for (const ZonePiece& piece : pieces)
        for (double z : {piece.floor, piece.ceiling})
          if (z >= cap_lo && z <= cap_hi) span(z);
  }
  const double y_target = std::max(2.0, plot_h / (28.0 * s));  // labels at least ~28 s pixels apart
  double z_min, z_max, y_step;
  if (fixed_axis) {
    z_min = options.z_min, z_max = options.z_max;
    y_step = nice_step(z_max - z_min, y_target);
  } else {
    if (!(hi > lo)) lo -= 1, hi += 1;
    const double margin = 0.04 * (hi - lo);
    lo -= margin, hi += margin;
    y_step = nice_step(hi - lo, y_target);
    z_min = std::floor(lo / y_step) * y_step, z_max = std::ceil(hi / y_step) * y_step;
    y_step = nice_step(z_max - z_min, y_target);  // the rounded range may allow a finer step
    z_min = std::floor(lo / y_step) * y_step, z_max = std::ceil(hi / y_step) * y_step;
  }
  const std::vector<double> y_ticks = ticks(z_min, z_max, y_step);
  int y_label_width = 0;
  for (double v : y_ticks) y_label_width = std::max(y_label_width, text_width(tick_label(v, y_step), s));

  // ---- horizontal layout and the distance axis ----
  const double length = profile.length;
  const int left = pad + glyph + 6 * s + y_label_width + 4 * s + tick + 1;
  const int widest_x_label = text_width(tick_label(length, length >= 10 ? 1 : 0.1), s);
  const int right_margin = std::max(widest_x_label / 2, static_cast<int>(marker_radius) + 3) + pad;
  const int plot_w = W - left - right_margin;
  if (plot_w < 60) throw ArgumentError("width", "too small for the plot and its labels");
  double x_step = nice_step(length, std::max(1.0, plot_w / double(widest_x_label + 24 * s)));
  const std::vector<double> x_ticks = ticks(0, length, x_step);

  auto px = [&](double d) { return d / length * plot_w; };
  auto py = [&](double z) { return (z_max - z) / (z_max - z_min) * plot_h; };

  // ---- the plot, on its own canvas: clipped to the plot area ----
  Canvas plot(plot_w, plot_h);
  plot.fill(0, 0, plot_w, plot_h, kPaper, 1);
  for (double v : y_ticks) {
    const int row = static_cast<int>(std::floor(py(v)));
    if (row > 0 && row < plot_h - 1) plot.fill(0, row, plot_w, row + 1, kGridLine, 1);
  }
  for (double v : x_ticks) {
    const int col = static_cast<int>(std::floor(px(v)));
    if (col > 0 && col < plot_w - 1) plot.fill(col, 0, col + 1, plot_h, kGridLine, 1);
  }

  // The DSM's silhouette: the exact area of each pixel under the steps.
  {
    std::vector<float> cover(static_cast<size_t>(plot_w) * plot_h, 0.0f);
    for (const ProfileStep& step : profile.dsm) {
      if (std::isnan(step.z)) continue;
      const double x0 = px(step.from), x1 = px(step.to), yt = std::max(0.0, py(step.z));
      for (int x = std::max(0, static_cast<int>(std::floor(x0))); x < std::min(plot_w, static_cast<int>(std::ceil(x1)));
           ++x) {
        const double f = std::min(x1, x + 1.0) - std::max(x0, double(x));
        if (!(f > 0)) continue;
        for (int y = static_cast<int>(std::floor(yt)); y < plot_h; ++y)
          cover[static_cast<size_t>(y) * plot_w + x] += static_cast<float>(f * (std::min(1.0, y + 1.0 - yt)));
      }
    }
    for (int y = 0; y < plot_h; ++y)
      for (int x = 0; x < plot_w; ++x)
        plot.blend(x, y, kSilhouette, std::min(1.0f, cover[static_cast<size_t>(y) * plot_w + x]));
  }

  for (size_t i = 0; i < zone_parts.size(); ++i) {
    const AirspaceZone& zone = options.zones.zones[i];
    draw_zone_section(plot, zone_parts[i], zone_caption(zone, i), zone_colour(zone, options.zones.airspace), px, py,
                      line_width, s);
  }

  // The safety band: per column, the path's lowest and highest height over it, +-safety.
  if (safety > 0) {
    std::vector<double> zlo(plot_w, INFINITY), zhi(plot_w, -INFINITY);
    auto note = [&](int x, double z) {
      if (x >= 0 && x < plot_w) zlo[x] = std::min(zlo[x], z), zhi[x] = std::max(zhi[x], z);
    };
    for (size_t k = 0; k + 1 < path.size(); ++k) {
      const double xa = px(profile.distance[k]), xb = px(profile.distance[k + 1]);
      const double za = path[k][2], zb = path[k + 1][2];
      if (!(xb > xa)) {
        const int x = std::clamp(static_cast<int>(std::floor(xa)), 0, plot_w - 1);
        note(x, za), note(x, zb);
        continue;
      }
      for (int x = std::max(0, static_cast<int>(std::floor(xa))); x < std::min(plot_w, static_cast<int>(std::ceil(xb)));
           ++x) {
        const double a = std::max(xa, double(x)), b = std::min(xb, x + 1.0);
        note(x, za + (a - xa) / (xb - xa) * (zb - za));
        note(x, za + (b - xa) / (xb - xa) * (zb - za));
      }
    }
    for (int x = 0; x < plot_w; ++x)
      if (zlo[x] <= zhi[x]) fill_column(plot, x, py(zhi[x] + safety), py(zlo[x] - safety), kPath, kBandAlpha);
  }

  if (dtm)
    for (const auto& line : step_lines(profile.dtm, 0, px, py))
      for (size_t k = 1; k < line.size(); ++k)
        draw_line(plot, line[k - 1][0], line[k - 1][1], line[k][0], line[k][1], kTerrain, 1, line_width);
  for (const auto& line : step_lines(ground, max_agl, px, py))
    draw_dashed(plot, line, kCeiling, line_width, 9 * s, 6 * s);
  std::vector<std::array<double, 2>> clear_line;  // the lowest clear height, dotted, broken at gaps
  for (size_t k = 0; k <= options.lowest_clear.size(); ++k) {
    const bool gap = k == options.lowest_clear.size() || !std::isfinite(options.lowest_clear[k][1]);
    if (!gap) clear_line.push_back({px(options.lowest_clear[k][0]), py(options.lowest_clear[k][1])});
    if (gap && clear_line.size() > 1) draw_dashed(plot, clear_line, kLowestClear, line_width, 2 * s, 3 * s);
    if (gap) clear_line.clear();
  }
  for (size_t k = 1; k < path.size(); ++k)
    draw_line(plot, px(profile.distance[k - 1]), py(path[k - 1][2]), px(profile.distance[k]), py(path[k][2]), kPath, 1,
              path_width);

  // ---- the picture: the plot, its frame, axes, title, legend ----
  Canvas canvas(W, H);
  canvas.fill(0, 0, W, H, kPaper, 1);
  const Image plot_image = plot.take();
  for (int y = 0; y < plot_h; ++y)
    for (int x = 0; x < plot_w; ++x) {
      const uint8_t* p = plot_image.rgb.data() + (static_cast<size_t>(y) * plot_w + x) * 3;
      canvas.set(left + x, top + y, Rgb{p[0] / 255.0f, p[1] / 255.0f, p[2] / 255.0f});
    }
  const int right = left + plot_w, bottom = top + plot_h;
  canvas.fill(left - 1, top - 1, right + 1, top, kInk, 1);
  canvas.fill(left - 1, bottom, right + 1, bottom + 1, kInk, 1);
  canvas.fill(left - 1, top - 1, left, bottom + 1, kInk, 1);
  canvas.fill(right, top - 1, right + 1, bottom + 1, kInk, 1);

  // Ticks and their labels. Distance labels centred under their ticks, heights right-aligned.
  const int x_label_top = bottom + 1 + tick + 3 * s;
  for (double v : x_ticks) {
    const int col = std::min(right - 1, left + static_cast<int>(std::floor(px(v))));
    canvas.fill(col, bottom + 1, col + 1, bottom + 1 + tick, kInk, 1);
    const std::string label = tick_label(v, x_step);
    draw_text(canvas, col + 1 - text_width(label, s) / 2, x_label_top, label, kInk, s);
  }
  for (double v : y_ticks) {
    const int row = std::min(bottom - 1, top + static_cast<int>(std::floor(py(v))));
    canvas.fill(left - 1 - tick, row, left - 1, row + 1, kInk, 1);
    const std::string label = tick_label(v, y_step);
    draw_text(canvas, left - 1 - tick - 4 * s - text_width(label, s), row - glyph / 2, label, kInk, s);
  }
  const std::string x_title = "distance along the path (m)";
  const int x_title_top = x_label_top + glyph + 8 * s;
  draw_text(canvas, left + (plot_w - text_width(x_title, s)) / 2, x_title_top, x_title, kInk, s);
  std::string y_title = "height (m)";
  if (!dsm.crs.vertical_name.empty() && text_width(y_title + ", " + dsm.crs.vertical_name, s) <= plot_h)
    y_title = "height (m, " + dsm.crs.vertical_name + ")";
  draw_text_up(canvas, pad, top + (plot_h + text_width(y_title, s)) / 2, y_title, kInk, s);
  if (!title.empty()) draw_text(canvas, (W - text_width(title, title_scale)) / 2, pad, title, kInk, title_scale);

  int legend_y = x_title_top + glyph + 10 * s;
  for (size_t r = 0; r < rows.size(); ++r, legend_y += row_height) {
    int x = (W - row_widths[r]) / 2;
    const double mid = legend_y + glyph / 2.0;
    for (size_t i : rows[r]) {
      const LegendEntry& e = legend[i];
      switch (e.kind) {
        case LegendEntry::Fill:
          canvas.fill(x, legend_y, x + swatch, legend_y + glyph, e.colour, 1);
          break;
        case LegendEntry::Line:
          draw_line(canvas, x, mid, x + swatch, mid, e.colour, 1, e.width);
          break;
        case LegendEntry::Dashed:
          draw_dashed(canvas, {{double(x), mid}, {double(x + swatch), mid}}, e.colour, e.width, 9 * s, 6 * s);
          break;
        case LegendEntry::Dotted:
          draw_dashed(canvas, {{double(x), mid}, {double(x + swatch), mid}}, e.colour, e.width, 2 * s, 3 * s);
          break;
        case LegendEntry::Band:
          canvas.fill(x, legend_y - s, x + swatch, legend_y + glyph + s, e.colour, kBandAlpha);
          draw_line(canvas, x, mid, x + swatch, mid, e.colour, 1, e.width);
          break;
        case LegendEntry::Disc:
          draw_disc(canvas, x + swatch / 2.0, mid, std::min(marker_radius, glyph / 2.0), e.colour, kOutline);
          break;
        case LegendEntry::Zone:
          canvas.fill(x, legend_y, x + swatch, legend_y + glyph, e.colour, 0.2f);
          for (const auto& [ax, ay, bx, by] :
               {std::array<double, 4>{0, 0, 1, 0}, {1, 0, 1, 1}, {1, 1, 0, 1}, {0, 1, 0, 0}})
            draw_line(canvas, x + ax * swatch, legend_y + ay * glyph, x + bx * swatch, legend_y + by * glyph, e.colour,
                      1, e.width);
          break;
      }
      draw_text(canvas, x + swatch + swatch_gap, legend_y, e.label, kInk, s);
      x += swatch + swatch_gap + text_width(e.label, s) + entry_gap;
    }
  }

  // Waypoints last, on the path where it passes nearest each (3D), numbered above on a light box.
  std::vector<std::array<int, 4>> boxes;  // placed number boxes: x0, y0, x1, y1
  for (size_t i = 0; i < options.waypoints.size(); ++i) {
    const Point3& w = options.waypoints[i];
    double best = INFINITY, at = 0, z = path[0][2];
    for (size_t k = 0; k + 1 < path.size(); ++k) {
      const Point3 &a = path[k], &b = path[k + 1];
      const double dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2], len2 = dx * dx + dy * dy + dz * dz;
      const double t =
          len2 > 0 ? std::clamp(((w[0] - a[0]) * dx + (w[1] - a[1]) * dy + (w[2] - a[2]) * dz) / len2, 0.0, 1.0) : 0;
      const double dist = std::hypot(a[0] + t * dx - w[0], a[1] + t * dy - w[1], a[2] + t * dz - w[2]);
      if (dist < best)
        best = dist, at = profile.distance[k] + t * (profile.distance[k + 1] - profile.distance[k]), z = a[2] + t * dz;
    }
    const double cx = left + px(at), cy = top + py(z);
    if (!(cy > top - marker_radius && cy < bottom + marker_radius)) continue;  // off a fixed height axis
    draw_disc(canvas, cx, cy, marker_radius, kWaypoint, kOutline);
    const std::string label = std::to_string(i + 1);
    const int bw = text_width(label, s) + 4 * s, bh = glyph + 4 * s;
    int bx = std::clamp(static_cast<int>(std::lround(cx - bw / 2.0)), 0, W - bw);
    int by = static_cast<int>(std::floor(cy - marker_radius - 3 - bh));
    for (bool moved = true; moved;) {  // above any number box it would cover
      moved = false;
      for (const auto& b : boxes)
        if (bx < b[2] && bx + bw > b[0] && by < b[3] && by + bh > b[1]) by = b[1] - bh - 1, moved = true;
    }
    by = std::max(0, by);
    boxes.push_back({bx, by, bx + bw, by + bh});
    canvas.fill(bx, by, bx + bw, by + bh, kPaper, 0.85f);
    draw_text(canvas, bx + 2 * s, by + 2 * s, label, kInk, s);
  }
  return canvas.take();
}

}  // namespace dsmplan
