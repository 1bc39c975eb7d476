// keep_out_areas(): the no-fly zones a QGroundControl plan's geofence carries (`dsmplan plan
// --no-fly ZONES -o MISSION.plan`). A geofence is flat: QGC's polygons hold no heights, and PX4
// and ArduPilot judge a breach by the horizontal position alone. So a zone goes in only when the
// path as flown keeps out of its outer ring seen from above; one the path passes under or over
// (a floor above it, a ceiling below it) or crosses through a hole would be breached by the
// planned flight itself and is left out, named in the report. Every ring of a zone that goes in
// is a polygon of its own (a hole too: kept out as well, the safe side). Zones that do not block
// (--no-fly-blocking) are left out too: the plan may cross them.
#include <algorithm>

#include "dsmplan/airspace.hpp"
#include "tools/job_parts.hpp"

namespace dsmplan {

namespace {

using Xy = std::array<double, 2>;

double cross(const Xy& o, const Xy& a, const Xy& b) {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

// Closed segments [a, b] and [c, d] share a point (touching counts).
bool meet(const Xy& a, const Xy& b, const Xy& c, const Xy& d) {
  const double d1 = cross(c, d, a), d2 = cross(c, d, b), d3 = cross(a, b, c), d4 = cross(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  const auto on = [](const Xy& p, const Xy& q, const Xy& r, double side) {  // r on [p, q], collinear
    return side == 0 && std::min(p[0], q[0]) <= r[0] && r[0] <= std::max(p[0], q[0]) && std::min(p[1], q[1]) <= r[1] &&
           r[1] <= std::max(p[1], q[1]);
  };
  return on(c, d, a, d1) || on(c, d, b, d2) || on(a, b, c, d3) || on(a, b, d, d4);
}

// Even-odd, as QGC tests a coordinate (QGCMapPolygon::containsCoordinate, Qt::OddEvenFill).
bool inside(const std::vector<Xy>& ring, const Xy& p) {
  bool in = false;
  for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
    if ((ring[i][1] > p[1]) != (ring[j][1] > p[1]) &&
        p[0] < ring[j][0] + (p[1] - ring[j][1]) * (ring[i][0] - ring[j][0]) / (ring[i][1] - ring[j][1]))
      in = !in;
  return in;
}

// The flown path, seen from above, meets the ring or its inside.
bool enters(const std::vector<Xy>& ring, const std::vector<Point3>& path) {
  for (const Point3& p : path)
    if (inside(ring, {p[0], p[1]})) return true;
  for (size_t k = 1; k < path.size(); ++k)
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
      if (meet({path[k - 1][0], path[k - 1][1]}, {path[k][0], path[k][1]}, ring[j], ring[i])) return true;
  return false;
}

}  // namespace

KeepOut keep_out_areas(const ZoneLayer& zones, const std::vector<Point3>& flown, const Wgs84Transform& to_wgs84) {
  KeepOut out;
  for (size_t i = 0; i < zones.zones.size(); ++i) {
    const AirspaceZone& zone = zones.zones[i];
    if (!zone_blocks(zone, zones.airspace) || zone.rings.empty()) continue;
    // Each ring by itself (an outer one, or a hole, which the fence then keeps out too): a path
    // through a hole enters the hole's ring, and the zone is left out.
    const bool entered = std::any_of(zone.rings.begin(), zone.rings.end(),
                                     [&](const std::vector<Xy>& ring) { return enters(ring, flown); });
    if (entered) {
      out.left_out.push_back({zone_caption(zone, i), zone.rings.size() > 1
                                                         ? "the path passes over or under it, or through a hole in it"
                                                         : "the path passes over or under it"});
      continue;
    }
    for (const std::vector<Xy>& ring : zone.rings) {
      auto& corners = out.areas.emplace_back();
      for (const Xy& c : ring) {
        const Point3 lonlat = to_wgs84.to_wgs84({c[0], c[1], 0});
        corners.push_back({lonlat[0], lonlat[1]});
      }
    }
    ++out.zones;
  }
  return out;
}

}  // namespace dsmplan
