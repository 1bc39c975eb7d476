// bench_stereo_satellite [ROUNDS=5]: the satellite rows of the stereo benchmark on their own
// (bench/stereo_satellite.hpp).
#include <algorithm>
#include <cstdlib>

#include "stereo_satellite.hpp"

int main(int argc, char** argv) { return run_satellite_stereo_bench(argc > 1 ? std::max(1, std::atoi(argv[1])) : 5); }
