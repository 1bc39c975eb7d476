// keep_out_areas(): the no-fly zones a QGroundControl plan's geofence carries (`dsmplan plan
// --no-fly ZONES -o MISSION.plan`). A geofence is flat: QGC's polygons hold no heights, and PX4
// and ArduPilot judge a breach by the horizontal position alone. So a zone goes in only when the
// path as flown keeps out of its rings seen from above (path_meets_zone_rings(), the plan stage's
// rule); one the path passes under or over (a floor above it, a ceiling below it) or crosses
// through a hole would be breached by the planned flight itself and is left out, named in the
// report. Every ring of a zone that goes in is a polygon of its own (a hole too: kept out as well,
// the safe side). Zones that do not block (--no-fly-blocking) are left out too: the plan may
// cross them.
#include "dsmplan/airspace.hpp"
#include "tools/job_parts.hpp"

namespace dsmplan {

KeepOut keep_out_areas(const ZoneLayer& zones, const std::vector<Point3>& flown, const Wgs84Transform& to_wgs84) {
  KeepOut out;
  for (size_t i = 0; i < zones.zones.size(); ++i) {
    const AirspaceZone& zone = zones.zones[i];
    if (!zone_blocks(zone, zones.airspace) || zone.rings.empty()) continue;
    if (path_meets_zone_rings(zone, flown)) {
      out.left_out.push_back({zone_caption(zone, i), zone.rings.size() > 1
                                                         ? "the path passes over or under it, or through a hole in it"
                                                         : "the path passes over or under it"});
      continue;
    }
    for (const auto& ring : zone.rings) {
      auto& corners = out.areas.emplace_back();
      for (const auto& c : ring) {
        const Point3 lonlat = to_wgs84.to_wgs84({c[0], c[1], 0});
        corners.push_back({lonlat[0], lonlat[1]});
      }
    }
    ++out.zones;
  }
  return out;
}

}  // namespace dsmplan
