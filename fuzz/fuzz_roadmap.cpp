// libFuzzer target: dsmplan::read_roadmap(path, &header) on arbitrary bytes (a *.roadmap file).
// The other overload only adds comparisons of the header against the mesh and the options.
//
// A roadmap file ends in an FNV-1a checksum of everything before it, which random mutations
// would practically never match, so the parser behind it would go unfuzzed. Every valid roadmap
// has an even size, so: inputs of even size get their last 8 bytes replaced by the right
// checksum (the fuzzer explores the header and the graph), inputs of odd size are read as they
// are (the fuzzer explores the checksum-mismatch and truncation messages).
#include <cstring>
#include <vector>

#include "dsmplan/plan.hpp"
#include "dsmplan/roadmap_file.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  if (size >= 8 && size % 2 == 0) {
    uint64_t hash = 14695981039346656037ull;  // as fnv1a() in src/io/roadmap_file.cpp
    for (size_t i = 0; i + 8 < size; ++i) hash = (hash ^ bytes[i]) * 1099511628211ull;
    std::memcpy(bytes.data() + size - 8, &hash, 8);
  }
  return dsmplan_fuzz::run(bytes.data(), bytes.size(), ".roadmap", [](const std::string& p) {
    dsmplan::RoadmapHeader header;
    (void)dsmplan::read_roadmap(p, &header);
  });
}
