// What every benchmark shares: the real tile, wall-clock timing, and the lines that say which
// machine and how loaded it was (timings on a shared machine mean little without them).
#pragma once

#include <chrono>
#include <cstddef>
#include <fstream>
#include <limits>
#include <string>

namespace bench {

/// The NRW DOM1 tile: 1000 x 1000 cells at 1 m, EPSG:25832.
inline const std::string tile = DSMPLAN_DATA_DIR "/nrw-dom1/dom1_32_356_5699_1_nw_2020.tif";

constexpr double never = std::numeric_limits<double>::infinity();  ///< start value of a best-of

inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// 1234567 -> "1,234,567"
inline std::string grouped(size_t n) {
  std::string digits = std::to_string(n), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

/// The 1-minute load average.
inline std::string load_average() {
  std::ifstream loadavg("/proc/loadavg");
  std::string one_minute;
  return loadavg >> one_minute ? one_minute : "unknown";
}

inline std::string cpu_model() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "unknown";
}

}  // namespace bench
