// What every benchmark shares: the real tile, wall-clock timing, the lines that say which
// machine and how loaded it was (timings on a shared machine mean little without them), and the
// project's way of reporting a figure: repeated runs, and for a comparison paired, interleaved runs
// (A B A B ...), summarised by the median with its min-max, never by the best run. A ratio is the
// median of the per-pair ratios (each pair met the machine in one state), not the ratio of two
// medians.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace bench {

/// The NRW DOM1 tile: 1000 x 1000 cells at 1 m, EPSG:25832.
inline const std::string tile = DSMPLAN_DATA_DIR "/nrw-dom1/dom1_32_356_5699_1_nw_2020.tif";

constexpr double never = std::numeric_limits<double>::infinity();  ///< start value of a minimum

inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Wall seconds of fn().
template <class F>
double timed(F&& fn) {
  const auto start = std::chrono::steady_clock::now();
  fn();
  return seconds_since(start);
}

/// The figures of repeated runs (seconds, rates, ratios), in the order they were taken.
struct Samples {
  std::vector<double> values;

  void add(double value) { values.push_back(value); }
  size_t size() const { return values.size(); }
  bool empty() const { return values.empty(); }
  /// The middle value; of an even count, the mean of the two middle ones.
  double median() const {
    if (values.empty()) throw std::logic_error("median of no samples");
    std::vector<double> v = values;
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  }
  double min() const { return *std::min_element(values.begin(), values.end()); }
  double max() const { return *std::max_element(values.begin(), values.end()); }
  /// "median (min-max)" with printf's `format` for each number, e.g. "%.3f".
  std::string text(const char* format = "%.3f", double scale = 1) const {
    char m[64], lo[64], hi[64];
    std::snprintf(m, sizeof m, format, scale * median());
    std::snprintf(lo, sizeof lo, format, scale * min());
    std::snprintf(hi, sizeof hi, format, scale * max());
    return std::string(m) + " (" + lo + "-" + hi + ")";
  }
};

/// Pair by pair, numerator[i] / denominator[i]: the ratios of paired, interleaved runs.
inline Samples ratios(const Samples& numerator, const Samples& denominator) {
  if (numerator.size() != denominator.size()) throw std::logic_error("ratios of unpaired samples");
  Samples out;
  for (size_t i = 0; i < numerator.size(); ++i) out.add(numerator.values[i] / denominator.values[i]);
  return out;
}

/// Pair by pair, count / seconds[i]: rates from seconds.
inline Samples rates(double count, const Samples& seconds) {
  Samples out;
  for (double s : seconds.values) out.add(count / s);
  return out;
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

/// The 1-minute load average at the start of each pair or round, printed as "lo-hi".
struct LoadLog {
  Samples loads;
  void note() {
    try {
      loads.add(std::stod(load_average()));
    } catch (const std::exception&) {
    }
  }
  std::string text() const {
    if (loads.empty()) return "unknown";
    char out[64];
    std::snprintf(out, sizeof out, "%.2f-%.2f", loads.min(), loads.max());
    return out;
  }
};

inline std::string cpu_model() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "unknown";
}

}  // namespace bench
