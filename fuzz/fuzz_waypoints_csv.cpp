// libFuzzer target: dsmplan::read_waypoints_csv on arbitrary bytes (a file named *.csv).
#include "dsmplan/waypoints.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return dsmplan_fuzz::run(data, size, ".csv", [](const std::string& p) { (void)dsmplan::read_waypoints_csv(p); });
}
