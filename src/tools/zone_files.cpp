// The no-fly zone files a picture draws (`dsmplan render/profile --no-fly`), read as `dsmplan
// plan` reads them (read_airspace(), airspace_io.hpp).
#include "dsmplan/airspace_io.hpp"
#include "tools/job_parts.hpp"

namespace dsmplan {

ZoneLayer read_zone_layer(const ZoneFiles& files, const Crs& crs) {
  ZoneLayer layer;
  if (!files.blocking.empty()) layer.airspace.blocking = files.blocking;
  check_airspace_options(layer.airspace);  // before the files are read: a typo is the first thing said
  for (const std::string& file : files.files) {
    std::vector<AirspaceZone> zones = read_airspace(file, crs, files.vertical);
    layer.zones.insert(layer.zones.end(), zones.begin(), zones.end());
  }
  return layer;
}

}  // namespace dsmplan
