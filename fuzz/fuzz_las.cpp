// libFuzzer target: dsmplan::read_las on arbitrary bytes (a file named *.las).
#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return dsmplan_fuzz::run(data, size, ".las", [](const std::string& p) { (void)dsmplan::read_las(p); });
}
