// The no-fly zones a KML path carries (`dsmplan plan --no-fly ... -o PATH.kml`): the files read
// again as the plan read them (read_airspace()), each corner to WGS 84 through the path's own
// transformation, heights as KML states them (path_to_kml(), mission.hpp): AGL limits relative
// to the ground, CRS heights above mean sea level (EGM96), as the path.
#include "dsmplan/airspace_io.hpp"
#include "dsmplan/mission.hpp"
#include "tools/job_parts.hpp"

namespace dsmplan {

namespace {

KmlZone::Altitude kml_altitude(const ZoneLimit& limit, bool floor) {
  switch (limit.reference) {
    case ZoneLimit::Reference::unlimited:
      return floor ? KmlZone::Altitude::ground : KmlZone::Altitude::none;
    case ZoneLimit::Reference::above_ground:
      return floor && limit.height <= 0 ? KmlZone::Altitude::ground : KmlZone::Altitude::relative;
    case ZoneLimit::Reference::crs:
      return KmlZone::Altitude::absolute;
  }
  return KmlZone::Altitude::none;
}

std::string limit_text(const ZoneLimit& limit, bool floor) {
  switch (limit.reference) {
    case ZoneLimit::Reference::unlimited:
      return floor ? "the ground" : "unlimited";
    case ZoneLimit::Reference::above_ground:
      return short_number(limit.height) + " m above the ground";
    case ZoneLimit::Reference::crs:
      return short_number(limit.height) + " m in the DSM's heights";
  }
  return "";
}

// A limit's height at corner (x, y) in its KML mode: AGL as it is, a CRS height to EGM96.
double kml_height(const ZoneLimit& limit, double x, double y, const Wgs84Transform& to_msl) {
  if (limit.reference == ZoneLimit::Reference::above_ground) return limit.height;
  if (limit.reference == ZoneLimit::Reference::crs) return to_msl.to_wgs84({x, y, limit.height})[2];
  return 0;
}

}  // namespace

std::vector<KmlZone> kml_zones_of(const ZoneLayer& layer, const Wgs84Transform& to_msl) {
  std::vector<KmlZone> out;
  for (size_t i = 0; i < layer.zones.size(); ++i) {
    const AirspaceZone& zone = layer.zones[i];
    KmlZone kml;
    kml.name = zone_caption(zone, i);
    kml.description = (zone.restriction.empty() ? std::string("zone") : zone.restriction) + " from " +
                      limit_text(zone.lower, true) + " to " + limit_text(zone.upper, false) + "; " + zone_label(zone);
    kml.blocking = zone_blocks(zone, layer.airspace);
    kml.floor = kml_altitude(zone.lower, true);
    kml.ceiling = kml_altitude(zone.upper, false);
    for (const auto& ring : zone.rings) {
      auto& corners = kml.rings.emplace_back();
      // A closing corner equal to the first is left out: path_to_kml() closes every ring.
      const size_t n = ring.size() > 1 && ring.front() == ring.back() ? ring.size() - 1 : ring.size();
      for (size_t k = 0; k < n; ++k) {
        const auto [x, y] = ring[k];
        const Point3 lonlat = to_msl.to_wgs84({x, y, 0});
        corners.push_back(
            {lonlat[0], lonlat[1], kml_height(zone.lower, x, y, to_msl), kml_height(zone.upper, x, y, to_msl)});
      }
    }
    out.push_back(std::move(kml));
  }
  return out;
}

}  // namespace dsmplan
