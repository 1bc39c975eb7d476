// LAZ in (issue 20, point 3): points per second of dsmplan's LAZ decoder on one and on two
// cores, beside reading the same points from the plain LAS, on the two Delft AHN3 crops
// (848,942 points of format 1, LASzip-compressed in 50,000-point chunks).
//
// Paired, interleaved rounds: every round runs every variant once, in the same order, so that a
// change of the machine's load hits all of them alike; the table gives the median over the rounds
// with its min-max, and each round's 1-minute load average is printed (/proc/loadavg); the speed-up
// of two cores over one is the median (min-max) of the per-round ratios. Never a best-of.
//   build/bench/bench_laz [ROUNDS=7]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <string>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/laz.hpp"
#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"

namespace {

const std::vector<std::string> kCrops = {"ahn3_cropped_1", "ahn3_cropped_2"};

std::string path(const std::string& crop, const std::string& extension) {
  return DSMPLAN_DATA_DIR "/delft-ahn3/" + crop + extension;
}

// Decoded records through a sink that touches every byte (so that nothing is optimised away).
size_t records(const std::string& extension, int threads) {
  size_t points = 0;
  unsigned checksum = 0;
  for (const auto& crop : kCrops)
    dsmplan::laz::read_laz_records(path(crop, extension),
                                   [&](const uint8_t* r, size_t n) {
                                     points += n;
                                     for (size_t i = 0; i < n; ++i) checksum += r[i * 28 + 8];  // z's low byte
                                   },
                                   {threads});
  if (checksum == 1) std::puts("");
  return points;
}

size_t cloud(const std::string& extension) {
  size_t points = 0;
  for (const auto& crop : kCrops) points += dsmplan::read_las(path(crop, extension)).x.size();
  return points;
}

struct Variant {
  std::string name;
  std::function<size_t()> run;
  std::vector<double> rates;      // points per wall-clock second, one per round
  std::vector<double> cpu_rates;  // points per CPU second (all threads), one per round
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::max(5, std::atoi(argv[1])) : 7;
  std::vector<Variant> variants = {
      {"LAZ records, 1 core", [] { return records(".laz", 1); }, {}, {}},
      {"LAZ records, 2 cores", [] { return records(".laz", 2); }, {}, {}},
      {"LAS records (plain read)", [] { return records(".las", 1); }, {}, {}},
      {"read_las(.laz) to a PointCloud, 2 cores", [] { return cloud(".laz"); }, {}, {}},
      {"read_las(.las) to a PointCloud", [] { return cloud(".las"); }, {}, {}},
  };
  std::printf("CPU: %s\n", bench::cpu_model().c_str());
  for (auto& v : variants) v.run();  // warm the page cache
  size_t points = 0;
  for (int round = 1; round <= rounds; ++round) {
    std::printf("round %d: load average %s\n", round, bench::load_average().c_str());
    for (auto& v : variants) {
      const auto start = std::chrono::steady_clock::now();
      const std::clock_t cpu_start = std::clock();
      points = v.run();
      v.rates.push_back(static_cast<double>(points) / bench::seconds_since(start));
      v.cpu_rates.push_back(static_cast<double>(points) * CLOCKS_PER_SEC /
                            static_cast<double>(std::clock() - cpu_start));
    }
  }
  std::printf("\n%s points (both Delft crops), %d rounds\n\n", bench::grouped(points).c_str(), rounds);
  // On a loaded machine the wall clock measures the others too; the CPU time (of all this
  // process's threads) says what the work itself costs.
  std::printf("| variant | median M points/s | min-max | median M points per CPU-second |\n");
  std::printf("|---|---:|---:|---:|\n");
  for (auto& v : variants) {
    const auto [low, high] = std::minmax_element(v.rates.begin(), v.rates.end());
    std::printf("| %s | %.2f | %.2f-%.2f | %.2f |\n", v.name.c_str(), median(v.rates) / 1e6, *low / 1e6, *high / 1e6,
                median(v.cpu_rates) / 1e6);
  }
  bench::Samples one, two;
  for (double r : variants[0].rates) one.add(r);
  for (double r : variants[1].rates) two.add(r);
  std::printf("\nLAZ records, 2 cores / 1 core, per round: %sx (median, min-max)\n",
              bench::ratios(two, one).text("%.2f").c_str());
  std::printf("load average after: %s\n", bench::load_average().c_str());
  return 0;
}
