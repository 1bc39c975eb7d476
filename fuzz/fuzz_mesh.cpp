// libFuzzer target: dsmplan::read_mesh on arbitrary bytes (a file named *.obj: PLY and OFF are told by their first
// line, the rest is read as OBJ).
#include "dsmplan/export.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return dsmplan_fuzz::run(data, size, ".obj", [](const std::string& p) { (void)dsmplan::read_mesh(p); });
}
