// Pictures of a DSM and its mesh seen from above, as the paper's Figures 6 and 7. The ground is
// Horn's hillshade (B. K. P. Horn, "Hill shading and the reflectance map", Proc. IEEE 69(1),
// 1981; the 3x3 slope weights and the sun of GDAL's gdaldem hillshade: azimuth 315, altitude 45)
// tinted by height; mesh edges are anti-aliased by the distance of each pixel centre to the line.
// The canvas, lines and text (the public-domain 8x8 VGA font) are picture/canvas.hpp's, shared with
// the height profile (profile.cpp). Pure computation: no GDAL, no files.
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "dsmplan/picture.hpp"
#include "picture/canvas.hpp"
#include "picture/zones.hpp"

namespace dsmplan {

namespace {

using namespace draw;  // canvas, lines, text: picture/canvas.hpp

constexpr double kMaxSide = 30000;
constexpr double kMaxPixels = double(1 << 26);

constexpr Rgb kNodata{0.72f, 0.83f, 0.95f};   // pale blue: holes are often water, and no ground is blue
constexpr Rgb kOutside{0.93f, 0.93f, 0.93f};  // beyond the grid: no data was ever there
constexpr Rgb kEdge{0.05f, 0.06f, 0.14f};

// Light hypsometric tint, low to high: green ground, sand, terracotta roofs. Pale, so the
// hillshade carries the shapes and dark edges stay visible on every colour.
Rgb height_tint(float t) {
  static constexpr std::array<Rgb, 4> stops{
      {{0.74f, 0.84f, 0.68f}, {0.90f, 0.88f, 0.74f}, {0.96f, 0.83f, 0.68f}, {0.97f, 0.74f, 0.66f}}};
  const float x = std::clamp(t, 0.0f, 1.0f) * (stops.size() - 1);
  const size_t i = std::min(static_cast<size_t>(x), stops.size() - 2);
  return mix(stops[i], stops[i + 1], x - static_cast<float>(i));
}

// ---- the view -----------------------------------------------------------------------------

// Where the picture lies: CRS window and the scale, pixels per CRS unit on both axes.
struct View {
  Window window;
  double scale = 1;
  int width = 0, height = 0;
  double px(double x) const { return (x - window.xmin) * scale; }
  double py(double y) const { return (window.ymax - y) * scale; }
};

View make_view(const Grid& dsm, const RenderOptions& options) {
  if (!(options.pixels_per_cell > 0 && std::isfinite(options.pixels_per_cell))) {
    throw ArgumentError("pixels_per_cell", "pixels per cell must be a positive number");
  }
  if (dsm.width <= 0 || dsm.height <= 0 || dsm.z.size() != dsm.cells() || !(dsm.cell_x > 0) || !(dsm.cell_y > 0)) {
    throw ArgumentError("DSM", "is not a grid with cells");
  }
  View view;
  view.window = options.window.value_or(Window{dsm.x0, dsm.y1(), dsm.x1(), dsm.y0});
  const Window& w = view.window;
  auto text = [](double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.10g", v);
    return std::string(buffer);
  };
  if (!(std::isfinite(w.xmin) && std::isfinite(w.ymin) && std::isfinite(w.xmax) && std::isfinite(w.ymax)) ||
      !(w.xmin < w.xmax && w.ymin < w.ymax)) {
    throw ArgumentError("window", "must be xmin,ymin,xmax,ymax with xmin < xmax and ymin < ymax");
  }
  if (!(w.xmin < dsm.x1() && w.xmax > dsm.x0 && w.ymin < dsm.y0 && w.ymax > dsm.y1())) {
    throw ArgumentError("window", text(w.xmin) + "," + text(w.ymin) + "," + text(w.xmax) + "," + text(w.ymax) +
                                      " lies outside the DSM (" + text(dsm.x0) + "," + text(dsm.y1()) + "," +
                                      text(dsm.x1()) + "," + text(dsm.y0) + ")");
  }
  view.scale = options.pixels_per_cell / dsm.cell_x;
  const double width = (w.xmax - w.xmin) * view.scale, height = (w.ymax - w.ymin) * view.scale;
  if (!(width <= kMaxSide && height <= kMaxSide && width * height <= kMaxPixels)) {
    throw ArgumentError("pixels_per_cell", "the picture would be " + text(std::round(width)) + " x " +
                                               text(std::round(height)) + " pixels; use a smaller zoom or window");
  }
  view.width = std::max(1, static_cast<int>(std::lround(width)));
  view.height = std::max(1, static_cast<int>(std::lround(height)));
  return view;
}

// Cells [c0, c1] x [r0, r1] of the grid: the window's, one more on each side, clipped.
struct CellRange {
  int c0, r0, c1, r1;
  int columns() const { return c1 - c0 + 1; }
};

CellRange cells_under(const Grid& dsm, const Window& w) {
  auto clamp_col = [&](double v) { return static_cast<int>(std::clamp(v, 0.0, dsm.width - 1.0)); };
  auto clamp_row = [&](double v) { return static_cast<int>(std::clamp(v, 0.0, dsm.height - 1.0)); };
  return {clamp_col(std::floor((w.xmin - dsm.x0) / dsm.cell_x) - 1),
          clamp_row(std::floor((dsm.y0 - w.ymax) / dsm.cell_y) - 1),
          clamp_col(std::floor((w.xmax - dsm.x0) / dsm.cell_x) + 1),
          clamp_row(std::floor((dsm.y0 - w.ymin) / dsm.cell_y) + 1)};
}

// The tint spreads over the 2nd-98th percentiles: a chimney or a crane does not wash out the town.
std::pair<float, float> height_range(const Grid& dsm, const CellRange& range) {
  std::vector<float> heights;
  const size_t cells = static_cast<size_t>(range.columns()) * (range.r1 - range.r0 + 1);
  const size_t stride = std::max<size_t>(1, cells / 200000);  // a sample is enough for percentiles
  size_t k = 0;
  for (int r = range.r0; r <= range.r1; ++r)
    for (int c = range.c0; c <= range.c1; ++c, ++k)
      if (k % stride == 0 && dsm.valid(c, r)) heights.push_back(dsm.at(c, r));
  if (heights.empty()) return {0.0f, 1.0f};
  auto percentile = [&](double p) {
    auto it = heights.begin() + static_cast<ptrdiff_t>(p * (heights.size() - 1));
    std::nth_element(heights.begin(), it, heights.end());
    return *it;
  };
  const float lo = percentile(0.02), hi = percentile(0.98);
  return {lo, hi > lo + 1e-3f ? hi : lo + 1.0f};
}

// Colour of every cell in `range`: tint by height times Horn's hillshade. NaN red = nodata.
std::vector<Rgb> shade_cells(const Grid& dsm, const CellRange& range) {
  const auto [lo, hi] = height_range(dsm, range);
  constexpr double kAzimuth = 315 * std::numbers::pi / 180, kAltitude = 45 * std::numbers::pi / 180;
  // Towards the sun: east, north, up.
  const double sx = std::sin(kAzimuth) * std::cos(kAltitude), sy = std::cos(kAzimuth) * std::cos(kAltitude);
  const double sz = std::sin(kAltitude);
  std::vector<Rgb> colours(static_cast<size_t>(range.columns()) * (range.r1 - range.r0 + 1));
  for (int r = range.r0; r <= range.r1; ++r)
    for (int c = range.c0; c <= range.c1; ++c) {
      Rgb& out = colours[static_cast<size_t>(r - range.r0) * range.columns() + (c - range.c0)];
      const float e = dsm.at(c, r);
      if (std::isnan(e)) {
        out = {NAN, 0, 0};
        continue;
      }
      // A neighbour beyond the grid or in a hole stands in as the centre: flat towards it.
      auto z = [&](int dc, int dr) -> double {
        const int cc = c + dc, rr = r + dr;
        if (cc < 0 || rr < 0 || cc >= dsm.width || rr >= dsm.height || !dsm.valid(cc, rr)) return e;
        return dsm.at(cc, rr);
      };
      const double dzdx =
          ((z(1, -1) + 2 * z(1, 0) + z(1, 1)) - (z(-1, -1) + 2 * z(-1, 0) + z(-1, 1))) / (8 * dsm.cell_x);
      const double dzdy =
          ((z(-1, -1) + 2 * z(0, -1) + z(1, -1)) - (z(-1, 1) + 2 * z(0, 1) + z(1, 1))) / (8 * dsm.cell_y);
      const double shade = std::max(0.0, (-dzdx * sx - dzdy * sy + sz) / std::sqrt(dzdx * dzdx + dzdy * dzdy + 1));
      // Flat ground (shade sin 45 = 0.71) comes out at 0.85 of its tint; slopes to the sun brighter.
      const auto light = static_cast<float>(0.25 + 0.85 * shade);
      out = scaled(height_tint((e - lo) / (hi - lo)), light);
    }
  return colours;
}

void draw_ground(Canvas& canvas, const Grid& dsm, const View& view) {
  const CellRange range = cells_under(dsm, view.window);
  const std::vector<Rgb> colours = shade_cells(dsm, range);
  auto colour = [&](int c, int r) -> const Rgb& {
    return colours[static_cast<size_t>(r - range.r0) * range.columns() + (c - range.c0)];
  };
  // Per column: the cell under the pixel centre and the fractional position between centres.
  std::vector<int> under_col(view.width), left_col(view.width);
  std::vector<float> across(view.width);
  for (int i = 0; i < view.width; ++i) {
    const double u = (view.window.xmin + (i + 0.5) / view.scale - dsm.x0) / dsm.cell_x;
    under_col[i] = static_cast<int>(std::floor(u));
    left_col[i] = static_cast<int>(std::floor(u - 0.5));
    across[i] = static_cast<float>(u - 0.5 - left_col[i]);
  }
  for (int j = 0; j < view.height; ++j) {
    const double v = (dsm.y0 - (view.window.ymax - (j + 0.5) / view.scale)) / dsm.cell_y;
    const int under_row = static_cast<int>(std::floor(v));
    const int top_row = static_cast<int>(std::floor(v - 0.5));
    const auto down = static_cast<float>(v - 0.5 - top_row);
    for (int i = 0; i < view.width; ++i) {
      const int c = under_col[i];
      if (c < 0 || c >= dsm.width || under_row < 0 || under_row >= dsm.height) {
        canvas.set(i, j, kOutside);
        continue;
      }
      if (!dsm.valid(c, under_row)) {
        canvas.set(i, j, kNodata);
        continue;
      }
      // Bilinear between the four nearest centres, over those that have data.
      Rgb sum{0, 0, 0};
      float weight = 0;
      for (int dr = 0; dr < 2; ++dr)
        for (int dc = 0; dc < 2; ++dc) {
          const int cc = left_col[i] + dc, rr = top_row + dr;
          if (cc < range.c0 || cc > range.c1 || rr < range.r0 || rr > range.r1) continue;
          const Rgb& k = colour(cc, rr);
          if (std::isnan(k.r)) continue;
          const float w = (dc ? across[i] : 1 - across[i]) * (dr ? down : 1 - down);
          sum = {sum.r + k.r * w, sum.g + k.g * w, sum.b + k.b * w};
          weight += w;
        }
      canvas.set(i, j, weight > 0 ? scaled(sum, 1 / weight) : colour(c, under_row));
    }
  }
}

void draw_edges(Canvas& canvas, const Grid& dsm, const Mesh& mesh, const View& view) {
  const size_t n = mesh.vertices.size();
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    for (uint32_t index : mesh.triangles[t])
      if (index >= n) {
        throw ArgumentError("mesh", "triangle " + std::to_string(t) + " names vertex " + std::to_string(index) +
                                        " of " + std::to_string(n));
      }
  // Each edge once: a shared edge drawn twice would come out darker than a border edge.
  std::vector<uint64_t> edges;
  for (const Triangle& t : mesh.triangles) {
    double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
    for (uint32_t index : t) {
      const Vertex& v = mesh.vertices[index];
      xmin = std::min(xmin, v.x), xmax = std::max(xmax, v.x), ymin = std::min(ymin, v.y), ymax = std::max(ymax, v.y);
    }
    if (!(view.px(xmax) >= -2 && view.px(xmin) <= view.width + 2 && view.py(ymin) >= -2 &&
          view.py(ymax) <= view.height + 2)) {
      continue;  // off the picture, or not finite
    }
    for (int k = 0; k < 3; ++k) {
      const uint64_t a = t[k], b = t[(k + 1) % 3];
      edges.push_back(std::min(a, b) << 32 | std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  // Lines darken in proportion to the ink they lay down. Long edges (a coarse mesh, or a close
  // zoom) are drawn dark; short ones lighter, and where the lines would cover most of the picture
  // (a full-resolution mesh seen from afar) lighter still, so the ground stays readable.
  std::vector<float> lengths;
  double ink = 0;  // pixels covered by 1-pixel lines, inside the picture
  for (size_t i = 0; i < edges.size(); ++i) {
    const Vertex &a = mesh.vertices[edges[i] >> 32], &b = mesh.vertices[edges[i] & 0xffffffffu];
    double x0 = view.px(a.x), y0 = view.py(a.y), x1 = view.px(b.x), y1 = view.py(b.y);
    if (i % std::max<size_t>(1, edges.size() / 1000) == 0)
      lengths.push_back(static_cast<float>(std::hypot(x1 - x0, y1 - y0)));
    if (clip(x0, y0, x1, y1, 0, 0, view.width, view.height)) ink += std::hypot(x1 - x0, y1 - y0);
  }
  float alpha = 0.85f;
  if (!lengths.empty()) {
    std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
    alpha = std::clamp(0.1f * lengths[lengths.size() / 2], 0.35f, 0.85f);
    const double coverage = ink / (static_cast<double>(view.width) * view.height);
    alpha = std::min(alpha, static_cast<float>(std::max(0.12, 0.45 / coverage)));
  }
  // Vertices of a grid mesh sit on cell centres, which at an even zoom fall on pixel corners: a
  // one-pixel line there smears over two half-dark pixels. Moving the lines by less than half a
  // pixel puts cell centres on pixel centres, and the lines come out crisp.
  auto snap = [](double cell_centre_px) {
    const double off = cell_centre_px - std::floor(cell_centre_px);
    return 0.5 - off;
  };
  const double shift_x = snap(view.px(dsm.center_x(0))), shift_y = snap(view.py(dsm.center_y(0)));
  for (uint64_t edge : edges) {
    const Vertex &a = mesh.vertices[edge >> 32], &b = mesh.vertices[edge & 0xffffffffu];
    draw_line(canvas, view.px(a.x) + shift_x, view.py(a.y) + shift_y, view.px(b.x) + shift_x, view.py(b.y) + shift_y,
              kEdge, alpha, 1.0);
  }
}

// ---- decorations ----------------------------------------------------------------------------

std::string metres(double length) {
  if (length == 0) length = 0;  // -0 reads "0 m", not "-0 m"
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g m", length);
  return buffer;
}

// ---- the furniture: title, north arrow, scale bar, height legend ------------------------------
//
// Each measures its box, then is drawn into it; the layout places the boxes in the corners
// (title top-left, north arrow top-right, scale bar and legend the bottom corners, on the side
// that covers fewer waypoints), draws them over the map, and places the waypoints' numbers where
// they meet neither the furniture nor each other.

struct Box {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // [x0, x1) x [y0, y1)
  bool empty() const { return x1 <= x0 || y1 <= y0; }
  bool meets(const Box& o) const { return !empty() && !o.empty() && x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }
  bool inside(int width, int height) const { return x0 >= 0 && y0 >= 0 && x1 <= width && y1 <= height; }
};

struct ScaleBar {
  int bar = 0;
  std::string label;
};

ScaleBar measure_scale_bar(const View& view) {
  // The longest 1, 2 or 5 x 10^k that takes at most a quarter of the width.
  const double target = 0.25 * view.width / view.scale;
  const double power = std::pow(10.0, std::floor(std::log10(target)));
  const double step = target / power >= 5 ? 5 : target / power >= 2 ? 2 : 1;
  const double length = step * power;
  return {static_cast<int>(std::lround(length * view.scale)), metres(length)};
}

Box scale_bar_size(const ScaleBar& bar, int s) {
  const int pad = 4 * s;
  return {0, 0, std::max(bar.bar, text_width(bar.label, s)) + 2 * pad, pad + kGlyph * s + 2 * s + 4 * s + pad};
}

void draw_scale_bar(Canvas& canvas, const ScaleBar& scale, const Box& box, int s) {
  const int pad = 4 * s, bar_height = 4 * s;
  canvas.fill(box.x0, box.y0, box.x1, box.y1, kPaper, 1);
  draw_text(canvas, box.x0 + pad, box.y0 + pad, scale.label, kInk, s);
  const int by = box.y0 + pad + kGlyph * s + 2 * s, bx = box.x0 + pad, bar = scale.bar;
  // Four alternating quarters in a dark frame, like a map's.
  canvas.fill(bx, by, bx + bar, by + bar_height, kInk, 1);
  for (int q = 1; q < 4; q += 2) {
    const int a = bx + bar * q / 4, b = bx + bar * (q + 1) / 4;
    canvas.fill(a, by + 1, b - (q == 3 ? 1 : 0), by + bar_height - 1, kPaper, 1);
  }
}

// The heights of the cells under the picture, lowest to highest (every valid cell), and the
// tint's ends: the legend's ramp runs over the whole range, each height in the colour the map
// gives it (one colour below the tint's low end and above its high end: heights_range()).
struct Legend {
  float lowest = 0, highest = 1, tint_low = 0, tint_high = 1;
  std::string low, high;  // lowest and highest, in metres to a decimal
};

Legend make_legend(const Grid& dsm, const CellRange& range) {
  Legend legend;
  std::tie(legend.tint_low, legend.tint_high) = height_range(dsm, range);
  float lo = INFINITY, hi = -INFINITY;
  for (int r = range.r0; r <= range.r1; ++r)
    for (int c = range.c0; c <= range.c1; ++c)
      if (dsm.valid(c, r)) lo = std::min(lo, dsm.at(c, r)), hi = std::max(hi, dsm.at(c, r));
  if (!(lo <= hi)) lo = legend.tint_low, hi = legend.tint_high;  // no valid cell: the tint's own range
  legend.lowest = lo, legend.highest = hi;
  // Rounded outwards, so the labels bound every height shown.
  legend.low = metres(std::floor(lo * 10) / 10), legend.high = metres(std::ceil(hi * 10) / 10);
  return legend;
}

Box legend_size(const Legend& legend, int s) {
  const int pad = 4 * s, ramp = 64 * s;
  const int width = std::max({ramp, text_width("height", s), text_width(legend.low + " " + legend.high, s)});
  return {0, 0, width + 2 * pad, pad + kGlyph * s + 2 * s + 6 * s + 2 * s + kGlyph * s + pad};
}

// The tint of flat ground from the low end to the high one, as the map shows it.
void draw_legend(Canvas& canvas, const Legend& legend, const Box& box, int s) {
  const int pad = 4 * s;
  canvas.fill(box.x0, box.y0, box.x1, box.y1, kPaper, 1);
  draw_text(canvas, box.x0 + pad, box.y0 + pad, "height", kInk, s);
  const int x0 = box.x0 + pad, x1 = box.x1 - pad, y0 = box.y0 + pad + kGlyph * s + 2 * s, y1 = y0 + 6 * s;
  for (int x = x0; x < x1; ++x) {
    const float t = x1 - x0 > 1 ? static_cast<float>(x - x0) / (x1 - x0 - 1) : 0;
    const float height = legend.lowest + t * (legend.highest - legend.lowest);
    const float tint = (height - legend.tint_low) / (legend.tint_high - legend.tint_low);
    canvas.fill(x, y0, x + 1, y1, scaled(height_tint(tint), 0.85f), 1);
  }
  const int text_y = y1 + 2 * s;
  draw_text(canvas, x0, text_y, legend.low, kInk, s);
  draw_text(canvas, x1 - text_width(legend.high, s), text_y, legend.high, kInk, s);
}

// ---- the coordinate grid: faint lines every round step of the CRS, labelled at the edges ------

constexpr float kGridAlpha = 0.3f;  // seen on every tint, under the paths and the edges' weight

struct GridLine {
  bool vertical = true;  // a line of constant x
  double at = 0;         // its pixel column or row
  std::string label;
};

std::vector<GridLine> grid_lines(const View& view) {
  const Window& w = view.window;
  const double step = nice_step(std::max(w.xmax - w.xmin, w.ymax - w.ymin), 5);
  std::vector<GridLine> lines;
  for (double x = std::ceil(w.xmin / step) * step; x < w.xmax; x += step)
    lines.push_back({true, view.px(x), tick_label(x, step)});
  for (double y = std::ceil(w.ymin / step) * step; y < w.ymax; y += step)
    lines.push_back({false, view.py(y), tick_label(y, step)});
  return lines;
}

void draw_grid_lines(Canvas& canvas, const View& view, const std::vector<GridLine>& lines) {
  for (const GridLine& line : lines) {
    if (line.vertical)
      draw_line(canvas, line.at, 0, line.at, view.height, kInk, kGridAlpha, 1.0);
    else
      draw_line(canvas, 0, line.at, view.width, line.at, kInk, kGridAlpha, 1.0);
  }
}

// Each line's label on a light box centred on it: x along the top edge (else the bottom), y
// along the left (else the right), where it stays in the picture and meets none of `taken`
// (which it joins); a line with no such place is left unlabelled.
void draw_grid_labels(Canvas& canvas, const View& view, const std::vector<GridLine>& lines, int s,
                      std::vector<Box>& taken, std::vector<ImageRegion>& regions) {
  const int pad = s, edge = 2 * s;
  for (const GridLine& line : lines) {
    const int w = text_width(line.label, s) + 2 * pad, h = kGlyph * s + 2 * pad;
    const int centre = static_cast<int>(std::lround(line.at));
    const std::array<Box, 2> places =
        line.vertical
            ? std::array<Box, 2>{Box{centre - w / 2, edge, centre - w / 2 + w, edge + h},
                                 Box{centre - w / 2, view.height - edge - h, centre - w / 2 + w, view.height - edge}}
            : std::array<Box, 2>{Box{edge, centre - h / 2, edge + w, centre - h / 2 + h},
                                 Box{view.width - edge - w, centre - h / 2, view.width - edge, centre - h / 2 + h}};
    const auto free = [&](const Box& box) {
      return box.inside(view.width, view.height) &&
             std::none_of(taken.begin(), taken.end(), [&](const Box& t) { return box.meets(t); });
    };
    const auto found = std::find_if(places.begin(), places.end(), free);
    if (found == places.end()) continue;
    const Box box = *found;
    canvas.fill(box.x0, box.y0, box.x1, box.y1, kPaper, 1);
    draw_text(canvas, box.x0 + pad, box.y0 + pad, line.label, kInk, s);
    taken.push_back(box);
    regions.push_back({(line.vertical ? "x " : "y ") + line.label, box.x0, box.y0, box.x1, box.y1});
  }
}

Box north_arrow_size(int s) {
  const int pad = 4 * s;
  return {0, 0, 10 * s + 2 * pad, pad + kGlyph * s + 2 * s + 16 * s + pad};
}

void draw_north_arrow(Canvas& canvas, const Box& box, int s) {
  const int pad = 4 * s, arrow_w = 10 * s, arrow_h = 16 * s;
  canvas.fill(box.x0, box.y0, box.x1, box.y1, kPaper, 1);
  const double cx = (box.x0 + box.x1) / 2.0;
  draw_text(canvas, static_cast<int>(std::lround(cx - kGlyph * s / 2.0 + s / 2.0)), box.y0 + pad, "N", kInk, s);
  const double top = box.y0 + pad + kGlyph * s + 2 * s, bottom = top + arrow_h, notch = bottom - arrow_h * 0.3;
  // The classic half-dark arrow: sun from the north-west lights its right half.
  fill_triangle(canvas, {cx, top, cx - arrow_w / 2.0, bottom, cx, notch}, kInk);
  fill_triangle(canvas, {cx, top, cx, notch, cx + arrow_w / 2.0, bottom}, Rgb{0.55f, 0.55f, 0.55f});
}

// The title's text shortened to `room` pixels ("..."), and its box; an empty box when nothing fits.
std::pair<std::string, Box> fit_title(std::string title, int& s, int room) {
  const int pad = 4 * s;
  if (text_width(title, s) + 2 * pad > room && s > 1) s = 1;
  const int fits = (room - 2 * pad) / (kGlyph * s);
  if (fits < 4) return {"", {}};
  if (static_cast<int>(title.size()) > fits) title = title.substr(0, fits - 3) + "...";
  return {title, {0, 0, text_width(title, s) + 2 * (4 * s), kGlyph * s + 2 * (4 * s)}};
}

void draw_title(Canvas& canvas, const std::string& title, const Box& box, int s) {
  canvas.fill(box.x0, box.y0, box.x1, box.y1, kPaper, 1);
  draw_text(canvas, box.x0 + 4 * s, box.y0 + 4 * s, title, kInk, s);
}

}  // namespace

Window parse_window(const std::string& text) {
  double v[4];
  size_t start = 0;
  for (int k = 0; k < 4; ++k) {
    const size_t comma = text.find(',', start);
    if ((k < 3) != (comma != std::string::npos)) break;
    std::string part = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    part.erase(0, part.find_first_not_of(" \t"));
    part.erase(part.find_last_not_of(" \t") + 1);
    const char* end = part.data() + part.size();
    auto [stop, ec] = std::from_chars(part.data(), end, v[k]);
    if (part.empty() || ec != std::errc() || stop != end) break;
    if (k == 3) return {v[0], v[1], v[2], v[3]};
    start = comma + 1;
  }
  throw ArgumentError("window", "expected four numbers xmin,ymin,xmax,ymax, got '" + text.substr(0, 80) + "'");
}

// ---- layers: paths, roadmaps, waypoints --------------------------------------------------------

namespace {

void check_layers(const RenderOptions& options) {
  for (const LineLayer& layer : options.lines)
    if (!(layer.width > 0 && layer.width <= 100) || !(layer.alpha >= 0 && layer.alpha <= 1))
      throw ArgumentError("layer", "line width must be in (0, 100] pixels and alpha in [0, 1]");
  for (const MarkerLayer& layer : options.markers)
    if (!(layer.radius > 0 && layer.radius <= 100))
      throw ArgumentError("layer", "marker radius must be in (0, 100] pixels");
}

void draw_lines(Canvas& canvas, const View& view, const LineLayer& layer) {
  // Halo first, under every segment of the layer, so crossings of the layer stay unbroken.
  for (int pass = layer.halo ? 0 : 1; pass < 2; ++pass) {
    const Rgb colour = pass == 0 ? Rgb{1, 1, 1} : rgb(layer.colour);
    const double width = pass == 0 ? layer.width + 2 : layer.width;
    for (const auto& line : layer.polylines)
      for (size_t k = 1; k < line.size(); ++k) {
        double x0 = view.px(line[k - 1][0]), y0 = view.py(line[k - 1][1]);
        double x1 = view.px(line[k][0]), y1 = view.py(line[k][1]);
        if (!(std::isfinite(x0) && std::isfinite(y0) && std::isfinite(x1) && std::isfinite(y1))) continue;
        if (clip(x0, y0, x1, y1, -width, -width, view.width + width, view.height + width))
          draw_line(canvas, x0, y0, x1, y1, colour, layer.alpha, width);
      }
  }
}

void draw_markers(Canvas& canvas, const View& view, const MarkerLayer& layer) {
  for (const Point3& p : layer.points) {
    const double cx = view.px(p[0]), cy = view.py(p[1]), r = layer.radius;
    if (!(cx > -r && cy > -r && cx < view.width + r && cy < view.height + r)) continue;
    // Outlined dark: visible on light and dark ground alike.
    draw_disc(canvas, cx, cy, r, rgb(layer.colour), Rgb{0.1f, 0.1f, 0.1f});
  }
}

Box disc_box(const View& view, const Point3& p, double r) {
  const double cx = view.px(p[0]), cy = view.py(p[1]);
  return {static_cast<int>(std::floor(cx - r)), static_cast<int>(std::floor(cy - r)),
          static_cast<int>(std::ceil(cx + r)) + 1, static_cast<int>(std::ceil(cy + r)) + 1};
}

// The numbers of the markers, each at the first of eight places around its disc that stays in
// the picture and meets no furniture, no other number and no other disc; failing that, the place
// that meets the fewest (furniture counting most). Greedy in marker order: O(markers^2).
void draw_labels(Canvas& canvas, const View& view, const RenderOptions& options, const std::vector<Box>& furniture,
                 int s, std::vector<ImageRegion>& regions) {
  std::vector<Box> discs, placed;
  for (const MarkerLayer& layer : options.markers)
    for (const Point3& p : layer.points) discs.push_back(disc_box(view, p, layer.radius));
  size_t disc = 0;
  for (const MarkerLayer& layer : options.markers) {
    for (size_t i = 0; i < layer.points.size(); ++i, ++disc) {
      const Box& d = discs[disc];
      const double cx = view.px(layer.points[i][0]), cy = view.py(layer.points[i][1]);
      if (!layer.numbered || !(cx >= 0 && cy >= 0 && cx < view.width && cy < view.height)) continue;
      // Under a box the disc is hidden, and so is its number.
      const Box centre{static_cast<int>(cx), static_cast<int>(cy), static_cast<int>(cx) + 1, static_cast<int>(cy) + 1};
      if (std::any_of(furniture.begin(), furniture.end(), [&](const Box& f) { return f.meets(centre); })) continue;
      const std::string text = std::to_string(i + 1);
      const int w = text_width(text, s), h = kGlyph * s, gap = 2;
      const int mx = (d.x0 + d.x1) / 2 - w / 2, my = (d.y0 + d.y1) / 2 - h / 2;
      const std::array<std::pair<int, int>, 8> at{{{d.x1 + gap, my},
                                                   {d.x0 - gap - w, my},
                                                   {mx, d.y0 - gap - h},
                                                   {mx, d.y1 + gap},
                                                   {d.x1 + gap, d.y0 - gap - h},
                                                   {d.x0 - gap - w, d.y0 - gap - h},
                                                   {d.x1 + gap, d.y1 + gap},
                                                   {d.x0 - gap - w, d.y1 + gap}}};
      Box best;
      int best_cost = INT32_MAX;
      for (const auto& [x, y] : at) {
        const Box label{x, y, x + w, y + h};
        int cost = label.inside(view.width, view.height) ? 0 : 1000;
        for (const Box& f : furniture) cost += label.meets(f) ? 100 : 0;
        for (const Box& o : placed) cost += label.meets(o) ? 10 : 0;
        for (size_t k = 0; k < discs.size(); ++k) cost += k != disc && label.meets(discs[k]) ? 1 : 0;
        if (cost < best_cost) best = label, best_cost = cost;
        if (cost == 0) break;
      }
      // A halo: readable on any ground.
      canvas.fill(best.x0 - 1, best.y0 - 1, best.x1 + 1, best.y1 + 1, kPaper, 0.7f);
      draw_text(canvas, best.x0, best.y0, text, Rgb{0.1f, 0.1f, 0.1f}, s);
      placed.push_back(best);
      regions.push_back({"label " + text, best.x0, best.y0, best.x1, best.y1});
    }
  }
}

}  // namespace

Image render_view(const Grid& dsm, const Mesh* mesh, const RenderOptions& options) {
  const View view = make_view(dsm, options);
  check_layers(options);
  Canvas canvas(view.width, view.height);
  draw_ground(canvas, dsm, view);
  if (mesh && options.edges) draw_edges(canvas, dsm, *mesh, view);
  std::vector<ImageRegion> zone_regions;
  if (!options.zones.zones.empty()) {
    for (const AirspaceZone& zone : options.zones.zones) check_zone(zone);
    const int zone_scale = std::clamp(std::min(view.width, view.height) / 280, 1, 4);
    draw_zones_above(
        canvas, options.zones,
        [&](double x, double y) {
          return std::array<double, 2>{view.px(x), view.py(y)};
        },
        zone_scale, zone_regions);
  }
  const std::vector<GridLine> grid = options.grid ? grid_lines(view) : std::vector<GridLine>{};
  draw_grid_lines(canvas, view, grid);  // under the paths and the markers
  for (const LineLayer& layer : options.lines) draw_lines(canvas, view, layer);
  for (const MarkerLayer& layer : options.markers) draw_markers(canvas, view, layer);

  // Furniture grows with the picture so it stays readable, and is left out when it does not fit.
  int s = std::clamp(std::min(view.width, view.height) / 280, 1, 4);
  const int margin = 6 * s;
  std::vector<ImageRegion> regions;
  std::vector<Box> furniture;
  const auto place = [&](Box size, bool right, bool bottom) {
    const int w = size.x1, h = size.y1;
    Box box{right ? view.width - margin - w : margin, bottom ? view.height - margin - h : margin, 0, 0};
    box.x1 = box.x0 + w, box.y1 = box.y0 + h;
    return box;
  };
  const auto fits = [&](const Box& box) {
    if (!box.inside(view.width, view.height)) return false;
    for (const Box& f : furniture)
      if (box.meets(f)) return false;
    return true;
  };
  std::vector<Box> discs;
  for (const MarkerLayer& layer : options.markers)
    for (const Point3& p : layer.points) discs.push_back(disc_box(view, p, layer.radius));
  const auto covered = [&](const Box& box) {
    return std::count_if(discs.begin(), discs.end(), [&](const Box& d) { return box.meets(d); });
  };

  if (options.north_arrow) {
    const Box box = place(north_arrow_size(s), true, false);
    if (fits(box))
      draw_north_arrow(canvas, box, s), furniture.push_back(box),
          regions.push_back({"north arrow", box.x0, box.y0, box.x1, box.y1});
  }
  if (!options.title.empty()) {
    int title_s = s;
    const int room = (furniture.empty() ? view.width : furniture.back().x0) - margin - 2 * s;
    const auto [text, size] = fit_title(options.title, title_s, room);
    const Box box = place(size, false, false);
    if (!text.empty() && fits(box))
      draw_title(canvas, text, box, title_s), furniture.push_back(box),
          regions.push_back({"title", box.x0, box.y0, box.x1, box.y1});
  }
  // The scale bar and the legend share the bottom corners: the arrangement covering fewer waypoints.
  const bool scale_bar = options.scale_bar && !dsm.crs.geographic;
  const ScaleBar bar = measure_scale_bar(view);
  const Legend legend = make_legend(dsm, cells_under(dsm, view.window));
  const Box bar_left = place(scale_bar_size(bar, s), false, true),
            bar_right = place(scale_bar_size(bar, s), true, true);
  const Box legend_right = place(legend_size(legend, s), true, true),
            legend_left = place(legend_size(legend, s), false, true);
  const bool swap = (scale_bar ? covered(bar_right) : 0) + (options.legend ? covered(legend_left) : 0) <
                    (scale_bar ? covered(bar_left) : 0) + (options.legend ? covered(legend_right) : 0);
  if (scale_bar && bar.bar >= 8) {
    const Box box = swap ? bar_right : bar_left;
    if (fits(box))
      draw_scale_bar(canvas, bar, box, s), furniture.push_back(box),
          regions.push_back({"scale bar", box.x0, box.y0, box.x1, box.y1});
  }
  if (options.legend) {
    const Box box = swap ? legend_left : legend_right;
    if (fits(box))
      draw_legend(canvas, legend, box, s), furniture.push_back(box),
          regions.push_back({"legend", box.x0, box.y0, box.x1, box.y1});
  }
  draw_grid_labels(canvas, view, grid, s, furniture, regions);
  const int label_scale = std::clamp(std::min(view.width, view.height) / 280, 1, 4);
  draw_labels(canvas, view, options, furniture, label_scale, regions);
  Image image = canvas.take();
  regions.insert(regions.end(), zone_regions.begin(), zone_regions.end());
  image.regions = std::move(regions);
  return image;
}

Image side_by_side(const std::vector<Image>& panels, int gap) {
  if (panels.empty()) throw ArgumentError("panels", "no picture to put side by side");
  if (gap < 0) throw ArgumentError("gap", "must be >= 0");
  int64_t width = static_cast<int64_t>(gap) * (static_cast<int64_t>(panels.size()) - 1);
  int height = 0;
  for (const Image& panel : panels) {
    if (panel.width <= 0 || panel.height <= 0 ||
        panel.rgb.size() != static_cast<size_t>(panel.width) * panel.height * 3) {
      throw ArgumentError("panels", "a panel's pixel array does not match its size");
    }
    width += panel.width;
    height = std::max(height, panel.height);
  }
  if (width > kMaxSide * 4 || static_cast<double>(width) * height > kMaxPixels * 4) {
    throw ArgumentError("panels", "together they are too large for one picture");
  }
  Image out;
  out.width = static_cast<int>(width);
  out.height = height;
  out.rgb.assign(static_cast<size_t>(out.width) * height * 3, 255);
  int left = 0;
  for (const Image& panel : panels) {
    const size_t row_bytes = static_cast<size_t>(panel.width) * 3;
    for (int r = 0; r < panel.height; ++r) {
      std::copy_n(panel.rgb.begin() + static_cast<ptrdiff_t>(r * row_bytes), row_bytes,
                  out.rgb.begin() + static_cast<ptrdiff_t>((static_cast<size_t>(r) * out.width + left) * 3));
    }
    for (ImageRegion region : panel.regions) {
      region.x0 += left, region.x1 += left;
      out.regions.push_back(region);
    }
    left += panel.width + gap;
  }
  return out;
}

}  // namespace dsmplan
