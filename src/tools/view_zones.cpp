// The no-fly zones `dsmplan view --no-fly` draws: the files read as `dsmplan plan` reads them
// (read_zone_layer(), in the GLB's CRS), handed to the page as JSON, which builds the prisms
// (web/viewer/zones.js): the page has the mesh, the ground AGL limits stand on.
#include <nlohmann/json.hpp>

#include "dsmplan/export.hpp"
#include "tools/job_parts.hpp"

namespace dsmplan {

namespace {

nlohmann::json limit_json(const ZoneLimit& limit) {
  switch (limit.reference) {
    case ZoneLimit::Reference::above_ground:
      return {{"reference", "ground"}, {"height", limit.height}};
    case ZoneLimit::Reference::crs:
      return {{"reference", "crs"}, {"height", limit.height}};
    case ZoneLimit::Reference::unlimited:
      break;
  }
  return {{"reference", "unlimited"}};
}

}  // namespace

std::string view_zones_json(const ZoneFiles& files, const std::string& glb) {
  const Crs crs = read_mesh_crs(glb);
  // Without its CRS the zones' longitudes and latitudes have nowhere to go.
  if (!crs.known()) throw InputError(glb, "", "no CRS in asset.extras: --no-fly cannot place its zones on this mesh");
  const ZoneLayer layer = read_zone_layer(files, crs);
  nlohmann::json zones = nlohmann::json::array();
  for (size_t i = 0; i < layer.zones.size(); ++i) {
    const AirspaceZone& zone = layer.zones[i];
    nlohmann::json rings = nlohmann::json::array();
    for (const auto& ring : zone.rings) {
      // A closing corner equal to the first is left out: the page closes every ring.
      const size_t n = ring.size() > 1 && ring.front() == ring.back() ? ring.size() - 1 : ring.size();
      nlohmann::json corners = nlohmann::json::array();
      for (size_t k = 0; k < n; ++k) corners.push_back({ring[k][0], ring[k][1]});
      rings.push_back(std::move(corners));
    }
    zones.push_back({{"caption", zone_caption(zone, i)},
                     {"label", zone_label(zone)},
                     {"restriction", zone.restriction},
                     {"blocks", zone_blocks(zone, layer.airspace)},
                     {"rings", std::move(rings)},
                     {"floor", limit_json(zone.lower)},
                     {"ceiling", limit_json(zone.upper)}});
  }
  return nlohmann::json{{"zones", std::move(zones)}}.dump();
}

}  // namespace dsmplan
