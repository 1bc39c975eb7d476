// Memory refused up front: a job that would need more than the machine has is an InputError with
// the figure, not a process the kernel's out-of-memory killer takes half-way through.
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "dsmplan/core.hpp"

namespace dsmplan {

double machine_memory_bytes() {
  // The machine and its container are read once (files: tens of microseconds, and a planner
  // asks at every query); the user's own limits below can change while the process runs.
  static const double machine = [] {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
    double bytes = pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : INFINITY;
    // In a container the cgroup's limit is what the kernel enforces ("max" when there is none).
    for (const char* limit_file : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
      std::ifstream in(limit_file);
      double limit = 0;
      if (in >> limit && limit > 0 && limit < bytes) bytes = limit;
    }
    return bytes;
  }();
  double bytes = machine;
  // A limit the user sets for dsmplan alone (a shared machine; or a program under
  // AddressSanitizer, whose shadow memory rules out ulimit -v).
  if (const char* limit = std::getenv("DSMPLAN_MAX_MEMORY"); limit && *limit) {
    char* end = nullptr;
    const double value = std::strtod(limit, &end);
    const std::string unit(end);
    const double scale = unit.empty()  ? 1
                         : unit == "K" ? 0x1p10
                         : unit == "M" ? 0x1p20
                         : unit == "G" ? 0x1p30
                         : unit == "T" ? 0x1p40
                                       : 0;
    if (!(value > 0) || !std::isfinite(value) || scale == 0)
      throw ArgumentError("DSMPLAN_MAX_MEMORY",
                          "must be a positive number of bytes, optionally with K, M, G or T, not '" +
                              std::string(limit).substr(0, 40) + "'");
    bytes = std::min(bytes, value * scale);
  }
  // So is a limit on the address space (ulimit -v): past it, allocation fails.
  rlimit address_space{};
  if (::getrlimit(RLIMIT_AS, &address_space) == 0 && address_space.rlim_cur != RLIM_INFINITY &&
      static_cast<double>(address_space.rlim_cur) < bytes)
    bytes = static_cast<double>(address_space.rlim_cur);
  return bytes;
}

std::string format_bytes(double bytes) {
  static const char* units[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
  int unit = 0;
  // Binary steps, as free(1) and top(1) count, so the figure matches what the user looks up.
  while (bytes >= 1024 && unit < 6) bytes /= 1024, ++unit;
  char text[32];
  std::snprintf(text, sizeof text, unit == 0 ? "%.0f %s" : bytes < 10 ? "%.1f %s" : "%.0f %s", bytes, units[unit]);
  return text;
}

std::string memory_problem(double bytes) {
  const double available = machine_memory_bytes();
  if (!(bytes > available)) return {};
  return "needs about " + format_bytes(bytes) + " of memory, this machine has " + format_bytes(available);
}

void require_memory(const std::string& file, const std::string& place, double bytes) {
  const std::string problem = memory_problem(bytes);
  if (!problem.empty()) throw InputError(file, place, problem);
}

}  // namespace dsmplan
