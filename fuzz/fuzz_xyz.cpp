// libFuzzer target: dsmplan::read_xyz on arbitrary bytes (a file named *.xyz).
#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return dsmplan_fuzz::run(data, size, ".xyz", [](const std::string& p) { (void)dsmplan::read_xyz(p); });
}
