// libFuzzer target: dsmplan::read_airspace on arbitrary bytes (a no-fly zone file, ED-269 or
// GeoJSON), into the NRW sample's CRS with approximate heights allowed, so that AMSL and WGS84
// limits and circles go through PROJ too; then each zone's constraint is built and asked once.
#include "dsmplan/airspace_io.hpp"
#include "dsmplan/raster_io.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const dsmplan::Crs crs = [] {
    dsmplan::Crs c;
    c.definition = "EPSG:25832";
    dsmplan::resolve_crs(c);
    return c;
  }();
  static const dsmplan::VerticalOptions vertical = [] {
    dsmplan::VerticalOptions v;
    v.allow_approximate_vertical = true;
    return v;
  }();
  return dsmplan_fuzz::run(data, size, ".json", [](const std::string& p) {
    for (const dsmplan::AirspaceZone& zone : dsmplan::read_airspace(p, crs, vertical)) {
      const dsmplan::AirspaceConstraint kept(zone, 2, nullptr);
      const auto& c = zone.rings.front().front();
      (void)kept.motion_valid({c[0] - 10, c[1] - 10, 100}, {c[0] + 10, c[1] + 10, 120});
    }
  });
}
