// Shared by the fuzz targets: every dsmplan parser reads a file path, so each input is written to
// one per-process file in /dev/shm (RAM; reused for every run) and the reader called on that.
// A dsmplan::Error is the expected answer to bad input; anything else that escapes (another
// exception, a crash, a sanitizer report, a leak, a timeout) is a finding.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "dsmplan/core.hpp"

namespace dsmplan_fuzz {

inline std::string scratch_dir() {
  if (const char* dir = std::getenv("DSMPLAN_FUZZ_TMP")) return dir;
  return ::access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
}

/// The input as a file named ".../dsmplan-fuzz-<pid><extension>"; the same path every call.
inline const std::string& write_input(const uint8_t* data, size_t size, const char* extension) {
  static const std::string path = [&] {
    std::string p = scratch_dir() + "/dsmplan-fuzz-" + std::to_string(::getpid()) + extension;
    static std::string for_exit;
    for_exit = p;
    std::atexit([] { std::remove(for_exit.c_str()); });
    return p;
  }();
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) {
    std::perror(path.c_str());
    std::abort();  // not a finding of the reader: the fuzzer's own scratch file failed
  }
  return path;
}

/// Runs read(path) on the input and swallows dsmplan::Error only (printed when the environment
/// has DSMPLAN_FUZZ_VERBOSE, e.g. to see which seeds are read and which refused).
template <class Read>
int run(const uint8_t* data, size_t size, const char* extension, Read read) {
  const std::string& path = write_input(data, size, extension);
  try {
    read(path);
  } catch (const dsmplan::Error& e) {
    static const bool verbose = std::getenv("DSMPLAN_FUZZ_VERBOSE") != nullptr;  // to check seeds
    if (verbose) std::fprintf(stderr, "refused: %s\n", e.what());
  }
  return 0;
}

}  // namespace dsmplan_fuzz
