// Many waypoints (issue 21, "scale of inputs"): `dsmplan plan` as a whole job (plan_job():
// reading the mesh and the DSM, the roadmap, 10^4 legs, the checks of the written path against
// the mesh and the DSM's columns, writing) on the NRW tile's conservative bounded mesh, with
// 10,000 waypoints on a serpentine over the whole tile, 10 m apart in rows 9.5 m apart, 172 m high (4 m over the
// tile's highest point, at most about 80 m above the ground).
//
// Prints every run's seconds and their median with min-max (no best-of), and the machine's load.
// Exit code 0 when every run solved the mission.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/simplify.hpp"

using namespace dsmplan;
using namespace bench;

int main() {
  constexpr int runs = 5, count = 10000;
  const std::filesystem::path folder =
      std::filesystem::temp_directory_path() / ("dsmplan_bench_waypoints_" + std::to_string(::getpid()));
  std::filesystem::create_directories(folder);
  std::printf("machine: %ld cores (nproc), %s, load average %s at the start\n", sysconf(_SC_NPROCESSORS_ONLN),
              cpu_model().c_str(), load_average().c_str());
  const Grid dsm = read_raster(tile);
  BoundedSimplifyOptions bounded;
  bounded.conservative = true;
  const std::string mesh = (folder / "tile.ply").string(), waypoints = (folder / "waypoints.csv").string();
  write_mesh(simplify_bounded(dsm, bounded), mesh, MeshFormat::Ply);
  {
    std::ofstream out(waypoints);
    out << "x,y,z\n";
    for (int n = 0; n < count; ++n) {
      const int row = n / 98, step = n % 98, col = row % 2 ? 97 - step : step;
      out << dsm.x0 + 10 + 10 * col << ',' << dsm.y0 - 990 + 9.5 * row << ",172\n";
    }
  }
  PlanJobOptions options;
  options.mesh = mesh;
  options.waypoints = waypoints;
  options.output = (folder / "path.csv").string();
  options.dsm = tile;
  std::vector<double> seconds;
  bool solved = true;
  for (int run = 0; run < runs; ++run) {
    const auto start = std::chrono::steady_clock::now();
    try {
      const PlanReport report = plan_job(options);
      seconds.push_back(seconds_since(start));
      std::printf("run %d: %.2f s (%zu waypoints, %zu path points, %.0f m)\n", run + 1, seconds.back(),
                  report.waypoint_count, report.path_points, report.path_length_m);
    } catch (const std::exception& error) {
      std::printf("run %d: failed: %s\n", run + 1, error.what());
      solved = false;
    }
  }
  std::filesystem::remove_all(folder);
  if (seconds.empty()) return 1;
  std::sort(seconds.begin(), seconds.end());
  std::printf("\n| waypoints | runs | seconds, median (min-max) |\n|---|---|---|\n| %d | %zu | %.2f (%.2f-%.2f) |\n",
              count, seconds.size(), seconds[seconds.size() / 2], seconds.front(), seconds.back());
  std::printf("load average %s at the end\n", load_average().c_str());
  return solved ? 0 : 1;
}
