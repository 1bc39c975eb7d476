// A zone of airspace.hpp: its checks, its name in messages, which restrictions block, and the
// point test a waypoint fails (the area by the crossing number, airspace_rings.hpp; the limits
// against the ground's cells under the point).
#include <algorithm>
#include <cmath>

#include "core/text.hpp"
#include "dsmplan/airspace.hpp"
#include "plan/airspace_rings.hpp"

namespace dsmplan {

std::string zone_label(const AirspaceZone& zone) {
  // Shown as visible_text(): a name with ESC or BEL in it must not reach a terminal raw.
  const std::string name = visible_text(zone.name), id = visible_text(zone.id);
  std::string label = "zone";
  if (!name.empty()) label += " '" + name + "'";
  if (!id.empty()) label += name.empty() ? " '" + id + "'" : " (" + id + ")";
  if (!zone.source_file.empty()) label += " of " + visible_text(zone.source_file);
  return label;
}

void check_zone(const AirspaceZone& zone) {
  auto refuse = [&](const std::string& problem) { throw ArgumentError("no_fly", zone_label(zone) + ": " + problem); };
  if (zone.rings.empty()) refuse("has no ring");
  for (size_t k = 0; k < zone.rings.size(); ++k) {
    const detail::Ring ring = detail::open_ring(zone.rings[k]);
    if (ring.size() < 3)
      refuse("ring " + std::to_string(k + 1) + " has " + std::to_string(ring.size()) + " corners, at least 3 needed");
    for (const auto& c : ring)
      if (!std::isfinite(c[0]) || !std::isfinite(c[1]))
        refuse("ring " + std::to_string(k + 1) + " has a corner that is not finite");
  }
  for (const ZoneLimit* limit : {&zone.lower, &zone.upper})
    if (limit->reference != ZoneLimit::Reference::unlimited && !std::isfinite(limit->height))
      refuse("a limit that is not finite");
  if (zone.lower.reference != ZoneLimit::Reference::unlimited && zone.lower.reference == zone.upper.reference &&
      zone.lower.height > zone.upper.height)
    refuse("its lower limit lies above its upper limit");
}

const std::vector<std::string>& zone_restrictions() {
  static const std::vector<std::string> names{"PROHIBITED", "REQ_AUTHORISATION", "CONDITIONAL", "NO_RESTRICTION"};
  return names;
}

void check_airspace_options(const AirspaceOptions& options) {
  if (options.blocking == std::vector<std::string>{kNoZoneBlocks}) return;  // said on purpose
  if (options.blocking.empty())
    throw ArgumentError("no_fly_blocking", "names no restriction; give one or more of " +
                                               choice_list(zone_restrictions()) + ", or " + kNoZoneBlocks +
                                               " to draw the zones without avoiding any");
  std::vector<std::string> names = zone_restrictions();
  names.push_back(kNoZoneBlocks);
  for (const std::string& name : options.blocking) {
    require_choice("no_fly_blocking", name, names);
    if (name == kNoZoneBlocks)
      throw ArgumentError("no_fly_blocking", std::string(kNoZoneBlocks) + " stands alone: no zone blocks");
  }
}

bool zone_blocks(const AirspaceZone& zone, const AirspaceOptions& options) {
  check_airspace_options(options);
  return std::find(options.blocking.begin(), options.blocking.end(), zone.restriction) != options.blocking.end();
}

namespace {

// The lowest and highest ground of the cells whose closed square holds (x, y); false where the
// ground is unknown (no ground, beyond its raster).
bool ground_under(const GroundGrid* ground, double x, double y, double& low, double& high) {
  if (ground == nullptr || ground->empty()) return false;
  const Grid& g = ground->grid();
  const double u = (x - g.x0) / g.cell_x, v = (g.y0 - y) / g.cell_y;
  if (!(u >= 0 && v >= 0 && u <= g.width && v <= g.height)) return false;
  const int c1 = std::min(static_cast<int>(u), g.width - 1), r1 = std::min(static_cast<int>(v), g.height - 1);
  const int c0 = u == std::floor(u) && u > 0 ? static_cast<int>(u) - 1 : c1;
  const int r0 = v == std::floor(v) && v > 0 ? static_cast<int>(v) - 1 : r1;
  low = INFINITY, high = -INFINITY;
  for (int r = r0; r <= r1; ++r)
    for (int c = c0; c <= c1; ++c) {
      const double z = g.z[g.index(c, r)];
      low = std::min(low, z), high = std::max(high, z);
    }
  return std::isfinite(low) && std::isfinite(high);
}

}  // namespace

bool zone_contains(const AirspaceZone& zone, const Point3& p, const GroundGrid* ground) {
  std::vector<detail::Ring> rings;
  for (const auto& ring : zone.rings) rings.push_back(detail::open_ring(ring));
  if (!detail::inside_rings(rings, {p[0], p[1]})) return false;
  double low = 0, high = 0;
  const bool known = ground_under(ground, p[0], p[1], low, high);
  switch (zone.lower.reference) {
    case ZoneLimit::Reference::unlimited:
      break;
    case ZoneLimit::Reference::crs:
      if (p[2] < zone.lower.height) return false;
      break;
    case ZoneLimit::Reference::above_ground:  // unknown ground: the floor reaches down without end
      if (known && p[2] - low < zone.lower.height) return false;
      break;
  }
  switch (zone.upper.reference) {
    case ZoneLimit::Reference::unlimited:
      break;
    case ZoneLimit::Reference::crs:
      if (p[2] > zone.upper.height) return false;
      break;
    case ZoneLimit::Reference::above_ground:
      if (known && p[2] - high > zone.upper.height) return false;
      break;
  }
  return true;
}

bool path_meets_zone_rings(const AirspaceZone& zone, const std::vector<Point3>& path) {
  for (const auto& corners : zone.rings) {
    const std::vector<detail::Ring> ring{detail::open_ring(corners)};
    for (const Point3& p : path)
      if (detail::inside_rings(ring, {p[0], p[1]})) return true;
    const detail::Ring& edges = ring.front();
    for (size_t k = 1; k < path.size(); ++k)
      for (size_t i = 0, j = edges.size() - 1; i < edges.size(); j = i++)
        if (detail::segments_meet({path[k - 1][0], path[k - 1][1]}, {path[k][0], path[k][1]}, edges[j], edges[i]))
          return true;
  }
  return false;
}

}  // namespace dsmplan
