// libFuzzer target: dsmplan::read_waypoints_geojson on arbitrary bytes (a file named *.geojson).
#include "dsmplan/waypoints.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return dsmplan_fuzz::run(data, size, ".geojson",
                           [](const std::string& p) { (void)dsmplan::read_waypoints_geojson(p); });
}
