// bench_stereo: DSMs from images by dsmplan's stereo pipelines against the DSM they must give,
// with dsmplan's SGM and with OpenCV's StereoSGBM in the same pipeline (issue 16 point 3(b)).
// Each section is a function in its own file (bench_stereo.hpp, stereo_satellite.hpp). 2 threads.
// Usage: bench_stereo [ROUNDS] [frames|satellite|blocks|ranges] (timed, interleaved rounds per
// set-up, default 5; frames and satellite unless one is named; blocks, the rendered blocks of
// issue 34, and ranges, what their estimated height ranges cost the DSM, only when named).
#include <tbb/global_control.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>

#ifdef DSMPLAN_HAVE_OPENCV
#include <opencv2/core.hpp>
#endif

#include "bench_kit.hpp"
#include "bench_stereo.hpp"
#include "stereo_satellite.hpp"

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress shows when piped to a file
  const int rounds = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  const std::string only = argc > 2 ? argv[2] : "";
  constexpr int threads = 2;
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
#ifdef DSMPLAN_HAVE_OPENCV
  cv::setNumThreads(threads);
#endif
  std::printf("bench_stereo: %d threads, %s, load (1 min) %s\n", threads, bench::cpu_model().c_str(),
              bench::load_average().c_str());
  if (only == "blocks") {
    bench::block_table(rounds);
    return 0;
  }
  if (only == "ranges") {
    bench::range_cost_table();
    return 0;
  }
  if (only != "satellite") bench::frame_camera_table(rounds);
  if (only != "frames") return run_satellite_stereo_bench(rounds);
  return 0;
}
