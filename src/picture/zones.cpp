// No-fly zones in pictures (ZoneLayer, picture.hpp): from above, each zone's area tinted, its
// rings outlined and its name; in the height profile, the part of the section each zone covers,
// floor to ceiling. The area is the rings by the even-odd rule, as airspace.hpp defines it; the
// path is cut exactly where it crosses a ring (segment intersection), so a span starts and ends
// where the zone does. Pure computation: no GDAL, no files.
#include "picture/zones.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace dsmplan {

std::string zone_caption(const AirspaceZone& zone, size_t index) {
  if (!zone.name.empty()) return zone.name;
  if (!zone.id.empty()) return zone.id;
  return "zone " + std::to_string(index + 1);
}

namespace draw {

namespace {

constexpr float kAreaAlpha = 0.15f;

using Ring = std::vector<std::array<double, 2>>;

double cross(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }

// The x where each ring edge crosses the horizontal line at y (half-open in y: a corner counts once).
std::vector<double> crossings(const std::vector<Ring>& rings, double y) {
  std::vector<double> xs;
  for (const Ring& ring : rings)
    for (size_t k = 0; k < ring.size(); ++k) {
      const auto& a = ring[k];
      const auto& b = ring[(k + 1) % ring.size()];
      if ((a[1] <= y) != (b[1] <= y)) xs.push_back(a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]));
    }
  std::sort(xs.begin(), xs.end());
  return xs;
}

// The pixels whose centres lie in the area (even-odd), tinted.
void fill_area(Canvas& canvas, const std::vector<Ring>& rings, double ymin, double ymax, Rgb colour) {
  const int y0 = std::max(0, static_cast<int>(std::floor(ymin)));
  const int y1 = std::min(canvas.height() - 1, static_cast<int>(std::ceil(ymax)));
  for (int y = y0; y <= y1; ++y) {
    const std::vector<double> xs = crossings(rings, y + 0.5);
    for (size_t j = 0; j + 1 < xs.size(); j += 2) {
      const int a = std::max(0, static_cast<int>(std::ceil(xs[j] - 0.5)));
      const int b = std::min(canvas.width(), static_cast<int>(std::ceil(xs[j + 1] - 0.5)));
      for (int x = a; x < b; ++x) canvas.blend(x, y, colour, kAreaAlpha);
    }
  }
}

// A caption in `colour` on a light box centred on (cx, cy), kept inside the canvas; moved down
// (then up) past the boxes already `placed`, so that no name covers another.
ImageRegion draw_caption(Canvas& canvas, const std::string& text, double cx, double cy, Rgb colour, int s,
                         const std::vector<ImageRegion>& placed = {}) {
  const int w = text_width(text, s) + 4 * s, h = kGlyph * s + 4 * s;
  const int x = std::clamp(static_cast<int>(std::lround(cx - w / 2.0)), 0, std::max(0, canvas.width() - w));
  const int centred = std::clamp(static_cast<int>(std::lround(cy - h / 2.0)), 0, std::max(0, canvas.height() - h));
  const auto meets = [&](int y) {
    return std::any_of(placed.begin(), placed.end(),
                       [&](const ImageRegion& r) { return x < r.x1 && r.x0 < x + w && y < r.y1 && r.y0 < y + h; });
  };
  int y = centred;
  for (int step = 1; meets(y) && step <= 2 * static_cast<int>(placed.size()); ++step) {
    const int moved = centred + ((step + 1) / 2) * (h + 1) * (step % 2 ? 1 : -1);
    if (moved >= 0 && moved + h <= canvas.height()) y = moved;
  }
  canvas.fill(x, y, x + w, y + h, kPaper, 0.8f);
  draw_text(canvas, x + 2 * s, y + 2 * s, text, colour, s);
  return {"zone " + text, x, y, x + w, y + h};
}

}  // namespace

Rgb zone_colour(const AirspaceZone& zone, const AirspaceOptions& airspace) {
  return rgb(zone_blocks(zone, airspace) ? kZoneBlocking : kZoneOther);
}

bool area_contains(const AirspaceZone& zone, double x, double y) {
  bool inside = false;
  for (const auto& ring : zone.rings)
    for (size_t k = 0; k < ring.size(); ++k) {
      const auto& a = ring[k];
      const auto& b = ring[(k + 1) % ring.size()];
      if ((a[1] <= y) != (b[1] <= y) && x < a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0])) inside = !inside;
    }
  return inside;
}

void draw_zones_above(Canvas& canvas, const ZoneLayer& layer,
                      const std::function<std::array<double, 2>(double, double)>& to_pixel, int s,
                      std::vector<ImageRegion>& regions) {
  struct Seen {
    std::vector<Ring> rings;
    double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;  // the outer ring's box
  };
  std::vector<Seen> seen(layer.zones.size());
  for (size_t i = 0; i < layer.zones.size(); ++i) {
    for (const auto& ring : layer.zones[i].rings) {
      Ring& pixels = seen[i].rings.emplace_back();
      for (const auto& corner : ring) pixels.push_back(to_pixel(corner[0], corner[1]));
    }
    for (const auto& p : seen[i].rings.front()) {
      seen[i].x0 = std::min(seen[i].x0, p[0]), seen[i].x1 = std::max(seen[i].x1, p[0]);
      seen[i].y0 = std::min(seen[i].y0, p[1]), seen[i].y1 = std::max(seen[i].y1, p[1]);
    }
  }
  const auto visible = [&](const Seen& z) {
    return z.x1 > -2 && z.y1 > -2 && z.x0 < canvas.width() + 2 && z.y0 < canvas.height() + 2;
  };
  // Areas, then outlines, then captions: no zone's tint covers another's line or name.
  for (size_t i = 0; i < seen.size(); ++i)
    if (visible(seen[i]))
      fill_area(canvas, seen[i].rings, seen[i].y0, seen[i].y1, zone_colour(layer.zones[i], layer.airspace));
  for (size_t i = 0; i < seen.size(); ++i) {
    if (!visible(seen[i])) continue;
    const Rgb colour = zone_colour(layer.zones[i], layer.airspace);
    for (const Ring& ring : seen[i].rings)
      for (size_t k = 0; k < ring.size(); ++k) {
        double x0 = ring[k][0], y0 = ring[k][1];
        double x1 = ring[(k + 1) % ring.size()][0], y1 = ring[(k + 1) % ring.size()][1];
        if (clip(x0, y0, x1, y1, -4, -4, canvas.width() + 4, canvas.height() + 4))
          draw_line(canvas, x0, y0, x1, y1, colour, 1, 2);
      }
  }
  for (size_t i = 0; i < seen.size(); ++i) {
    const Seen& z = seen[i];
    if (!visible(z)) continue;
    const double cx = (std::max(0.0, z.x0) + std::min(double(canvas.width()), z.x1)) / 2;
    const double cy = (std::max(0.0, z.y0) + std::min(double(canvas.height()), z.y1)) / 2;
    regions.push_back(draw_caption(canvas, zone_caption(layer.zones[i], i), cx, cy,
                                   zone_colour(layer.zones[i], layer.airspace), s, regions));
  }
}

std::vector<ZoneSpan> zone_spans(const AirspaceZone& zone, const std::vector<Point3>& path,
                                 const std::vector<double>& distance) {
  std::vector<ZoneSpan> spans;
  for (size_t k = 0; k + 1 < path.size(); ++k) {
    const Point3 &p = path[k], &q = path[k + 1];
    const double dx = q[0] - p[0], dy = q[1] - p[1];
    if (!(distance[k + 1] > distance[k])) continue;  // no x,y length: nothing to cover
    std::vector<double> ts{0, 1};
    for (const auto& ring : zone.rings)
      for (size_t e = 0; e < ring.size(); ++e) {
        const auto& c = ring[e];
        const auto& d = ring[(e + 1) % ring.size()];
        const double ex = d[0] - c[0], ey = d[1] - c[1], denom = cross(dx, dy, ex, ey);
        if (denom == 0) continue;
        const double t = cross(c[0] - p[0], c[1] - p[1], ex, ey) / denom;
        const double u = cross(c[0] - p[0], c[1] - p[1], dx, dy) / denom;
        if (t > 0 && t < 1 && u >= 0 && u <= 1) ts.push_back(t);
      }
    std::sort(ts.begin(), ts.end());
    const double length = distance[k + 1] - distance[k];
    for (size_t j = 0; j + 1 < ts.size(); ++j) {
      if (!(ts[j + 1] > ts[j])) continue;
      const double mid = (ts[j] + ts[j + 1]) / 2;
      if (!area_contains(zone, p[0] + mid * dx, p[1] + mid * dy)) continue;
      const double from = distance[k] + ts[j] * length, to = distance[k] + ts[j + 1] * length;
      if (!spans.empty() && std::abs(spans.back().to - from) <= 1e-9 * std::max(1.0, to))
        spans.back().to = to;
      else
        spans.push_back({from, to});
    }
  }
  return spans;
}

std::array<double, 2> zone_band(const AirspaceZone& zone, double ground) {
  const auto at = [&](const ZoneLimit& limit, double none) {
    switch (limit.reference) {
      case ZoneLimit::Reference::unlimited:
        return none;
      case ZoneLimit::Reference::above_ground:
        return std::isnan(ground) ? none : ground + limit.height;
      case ZoneLimit::Reference::crs:
        return limit.height;
    }
    return none;
  };
  return {at(zone.lower, -INFINITY), at(zone.upper, INFINITY)};
}

std::vector<ZonePiece> zone_pieces(const AirspaceZone& zone, const std::vector<ZoneSpan>& spans,
                                   const std::vector<ProfileStep>& ground) {
  std::vector<ZonePiece> pieces;
  for (const ZoneSpan& span : spans) {
    double at = span.from;
    bool starts = true;
    const auto add = [&](double to, double z) {
      if (!(to > at)) return;
      const auto [floor, ceiling] = zone_band(zone, z);
      pieces.push_back({at, to, floor, ceiling, starts});
      at = to, starts = false;
    };
    for (const ProfileStep& step : ground) {
      if (step.to <= at || step.from >= span.to) continue;
      if (step.from > at) add(step.from, NAN);  // a gap no step covers
      add(std::min(step.to, span.to), step.z);
    }
    add(span.to, NAN);
  }
  return pieces;
}

void draw_zone_section(Canvas& plot, const std::vector<ZonePiece>& pieces, const std::string& caption, Rgb colour,
                       const std::function<double(double)>& px, const std::function<double(double)>& py, double width,
                       int s) {
  const double above = -4, below = plot.height() + 4;  // beyond the plot: where no limit is
  const auto top = [&](const ZonePiece& p) { return std::clamp(py(p.ceiling), above, below); };
  const auto bottom = [&](const ZonePiece& p) { return std::clamp(py(p.floor), above, below); };
  for (const ZonePiece& piece : pieces) {
    const double x0 = px(piece.from), x1 = px(piece.to), y0 = top(piece), y1 = bottom(piece);
    if (!(y1 > y0)) continue;
    for (int x = std::max(0, static_cast<int>(std::floor(x0))); x < std::min(plot.width(), int(std::ceil(x1))); ++x) {
      const double f = std::min(x1, x + 1.0) - std::max(x0, double(x));
      for (int y = std::max(0, static_cast<int>(std::floor(y0))); y < std::min(double(plot.height()), y1); ++y) {
        const double cover = std::min(y1, y + 1.0) - std::max(y0, double(y));
        if (f > 0 && cover > 0) plot.blend(x, y, colour, static_cast<float>(0.2 * f * cover));
      }
    }
  }
  for (size_t i = 0; i < pieces.size(); ++i) {
    const ZonePiece& p = pieces[i];
    const double x0 = px(p.from), x1 = px(p.to);
    draw_line(plot, x0, top(p), x1, top(p), colour, 1, width);
    draw_line(plot, x0, bottom(p), x1, bottom(p), colour, 1, width);
    if (p.starts) draw_line(plot, x0, top(p), x0, bottom(p), colour, 1, width);
    const bool ends = i + 1 == pieces.size() || pieces[i + 1].starts;
    if (ends) {
      draw_line(plot, x1, top(p), x1, bottom(p), colour, 1, width);
    } else {  // risers to the next piece's floor and ceiling
      draw_line(plot, x1, top(p), x1, top(pieces[i + 1]), colour, 1, width);
      draw_line(plot, x1, bottom(p), x1, bottom(pieces[i + 1]), colour, 1, width);
    }
  }
  // The caption, once: over the widest span, just under its highest visible ceiling.
  double best = 0, cx = 0, cy = 0;
  for (size_t i = 0; i < pieces.size();) {
    size_t j = i;
    double y = INFINITY;
    while (j < pieces.size() && (j == i || !pieces[j].starts)) y = std::min(y, top(pieces[j])), ++j;
    const double x0 = std::max(0.0, px(pieces[i].from)), x1 = std::min(double(plot.width()), px(pieces[j - 1].to));
    if (x1 - x0 > best) best = x1 - x0, cx = (x0 + x1) / 2, cy = std::max(0.0, y) + 4 + kGlyph * s;
    i = j;
  }
  if (best > 0) draw_caption(plot, caption, cx, cy, colour, s);
}

}  // namespace draw
}  // namespace dsmplan
