// Table 1 of Adolf & Hirschmueller, "Meshing and Simplification of High Resolution Urban Surface
// Data for UAV Path Planning" (Section 3), redone on a real DSM, plus the speed and memory bars.
//
// Measured on the NRW DOM1 tile (1000 x 1000 cells at 1 m, EPSG:25832):
//   1. Table 1: the XY-3 Delaunay mesh without simplification at x/y resolution 1-4 m (median
//      resampling, z step 0.1 m): vertices, faces, binary PLY size and seconds per stage, in
//      process through the library, printed beside the paper's three Berlin sections.
//   2. Speed bar: the real CLI, GeoTIFF -> mesh -> binary PLY end to end, must be >= 5x faster
//      than CGAL's incremental Delaunay_triangulation_2 (Projection_traits_xy_3, range insert,
//      which spatially sorts first: CGAL's fastest path) on the same points.
//   3. Memory bar: the CLI's peak RSS must stay <= 150 bytes per DSM cell.
//   4. For information: the same pipeline in process, and triangulate_xy3 alone, against CGAL.
// Timing (bench/bench_kit.hpp): the bars' variants run in interleaved rounds (CGAL, CLI, in
// process, CGAL, CLI, ...; at least 5), and every ratio is the median of the per-round ratios with
// its min-max; Table 1's seconds are medians over `runs` runs with the total's min-max; the
// 1-minute load average is printed at every round. Never a best-of.
//   build/bench/bench_table1 [ROUNDS = 7]
// Exit code 0 when both bars pass (judged on the medians), 1 when one is missed (or anything fails).
#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Projection_traits_xy_3.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/tools.hpp"

extern char** environ;

namespace fs = std::filesystem;
using namespace dsmplan;
using namespace bench;

namespace {

constexpr int runs = 5;               // Table 1: in-process runs per resolution
constexpr int min_rounds = 5;         // the bars: interleaved rounds, at least
constexpr double speed_bar = 5.0;     // CGAL seconds / our end-to-end seconds (median of the rounds), at least
constexpr double memory_bar = 150.0;  // peak RSS bytes per DSM cell, at most

// A scratch folder under /tmp, removed with everything in it when the benchmark ends.
struct TempDir {
  fs::path path;
  TempDir() {
    std::string name = (fs::temp_directory_path() / "dsmplan-bench-XXXXXX").string();
    if (!mkdtemp(name.data())) throw std::runtime_error("cannot create a temporary folder under /tmp");
    path = name;
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
};

// ---- 1. Table 1 -----------------------------------------------------------------------------

struct Row {
  double res = 0;
  size_t vertices = 0, faces = 0, bytes = 0;
  // Each stage over `runs` runs; printed as medians, so the total can differ from the stages' sum.
  Samples read, resample, triangulate, write, total;
};

// The seconds of one stage in a mesh report.
double stage_seconds(const MeshReport& report, const char* name) {
  for (const auto& [stage, seconds] : report.seconds)
    if (stage == name) return seconds;
  throw std::runtime_error(std::string("mesh report lacks stage ") + name);
}

// The same job as `dsmplan mesh TILE --res RES -o OUT.ply`, in process, through the library.
Row mesh_in_process(double res, const fs::path& out, LoadLog& loads) {
  Row row{res};
  MeshJobOptions job;
  job.input = tile;
  job.output = out.string();
  job.resolution = res;
  for (int run = 0; run < runs; ++run) {
    loads.note();
    const MeshReport report = mesh_dsm(job);
    row.read.add(stage_seconds(report, "read"));
    row.resample.add(report.resampling ? stage_seconds(report, "resample") : 0.0);  // "-" when none
    row.triangulate.add(stage_seconds(report, "triangulate"));
    row.write.add(stage_seconds(report, "write"));
    row.total.add(stage_seconds(report, "total"));
    row.vertices = report.vertices;
    row.faces = report.faces;
    row.bytes = report.file_bytes;
  }
  fs::remove(out);
  return row;
}

// The paper's Table 1 (Berlin, 7 cm DSM downsampled; vertical resolution 0.1 m).
struct PaperRow {
  const char* section;
  int res;
  size_t vertices, faces, megabytes;
};
constexpr PaperRow paper[] = {
    {"Mitte", 1, 2450000, 4893702, 730}, {"Mitte", 2, 612500, 1221852, 182},   {"Mitte", 3, 272728, 543356, 81},
    {"Mitte", 4, 153300, 305026, 45},    {"Potsdamer", 1, 276051, 550000, 80}, {"Potsdamer", 2, 69000, 136950, 20},
    {"Potsdamer", 3, 30728, 60756, 9},   {"Potsdamer", 4, 17250, 33976, 5},    {"Reichstag", 1, 113176, 225000, 33},
    {"Reichstag", 2, 28388, 56100, 8},   {"Reichstag", 3, 12600, 24750, 4},    {"Reichstag", 4, 7144, 13950, 2},
};

void print_table1(const std::vector<Row>& rows, const LoadLog& loads) {
  std::printf("Table 1: XY-3 Delaunay mesh without simplification, z step 0.1 m, binary PLY (MB = 10^6 bytes)\n");
  std::printf("ours: NRW DOM1 tile 1 x 1 km, median resampling; seconds: the median of %d runs per stage, the\n", runs);
  std::printf("total's min-max beside it; load average %s at the runs' starts\n\n", loads.text().c_str());
  std::printf("%-4s %-16s %10s %10s %8s %5s | %6s %7s %7s %6s %21s\n", "res", "data", "vertices", "faces", "size MB",
              "f/v", "read", "resamp", "triang", "write", "total (min-max)");
  for (const Row& row : rows) {
    char resample[16] = "-";
    if (row.resample.median() > 0) std::snprintf(resample, sizeof resample, "%.3f", row.resample.median());
    std::printf("%-4s %-16s %10s %10s %8.1f %5.2f | %6.3f %7s %7.3f %6.3f %21s\n",
                (std::to_string(static_cast<int>(row.res)) + " m").c_str(), "ours NRW tile",
                grouped(row.vertices).c_str(), grouped(row.faces).c_str(), row.bytes / 1e6,
                static_cast<double>(row.faces) / row.vertices, row.read.median(), resample, row.triangulate.median(),
                row.write.median(), row.total.text().c_str());
    for (const PaperRow& p : paper) {
      if (p.res != static_cast<int>(row.res)) continue;
      std::printf("%-4s %-16s %10s %10s %8zu %5.2f |\n", "", ("paper " + std::string(p.section)).c_str(),
                  grouped(p.vertices).c_str(), grouped(p.faces).c_str(), p.megabytes,
                  static_cast<double>(p.faces) / p.vertices);
    }
  }
}

// ---- 2./3. The bars: CGAL against the CLI end to end ---------------------------------------

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Xy3 = CGAL::Delaunay_triangulation_2<CGAL::Projection_traits_xy_3<Kernel>>;

// The valid cell centres as CGAL points: x,y in the CRS, z the height.
std::vector<Kernel::Point_3> cell_centres(const Grid& dsm) {
  std::vector<Kernel::Point_3> points;
  points.reserve(dsm.cells());
  for (int row = 0; row < dsm.height; ++row) {
    for (int col = 0; col < dsm.width; ++col) {
      if (dsm.valid(col, row)) points.emplace_back(dsm.center_x(col), dsm.center_y(row), dsm.at(col, row));
    }
  }
  return points;
}

// CPU seconds of this thread so far.
double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

// Wall seconds of one Xy3::insert(begin, end) (one thread), its CPU seconds in cpu; the face
// count says it built the same triangulation.
double cgal_once(const std::vector<Kernel::Point_3>& points, size_t& faces, double& cpu) {
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = thread_cpu_seconds();
  Xy3 dt;
  dt.insert(points.begin(), points.end());
  const double seconds = seconds_since(start);
  cpu = thread_cpu_seconds() - cpu_start;
  faces = dt.number_of_faces();
  return seconds;
}

long own_peak_kib() {
  rusage self{};
  getrusage(RUSAGE_SELF, &self);
  return self.ru_maxrss;  // Linux: KiB
}

// Spawns `dsmplan mesh TILE -o OUT -q`, waits with wait4(); returns wall seconds, sets peak_kib
// and cpu (user + system seconds of all its threads).
double cli_once(const fs::path& out, long& peak_kib, double& cpu) {
  const std::string cli = DSMPLAN_CLI, output = out.string();
  std::vector<const char*> argv{cli.c_str(), "mesh", tile.c_str(), "-o", output.c_str(), "-q", nullptr};
  fs::remove(out);
  pid_t pid = 0;
  const auto start = std::chrono::steady_clock::now();
  if (const int error = posix_spawn(&pid, cli.c_str(), nullptr, nullptr, const_cast<char**>(argv.data()), environ)) {
    throw std::runtime_error("cannot start " + cli + ": " + std::strerror(error));
  }
  int status = 0;
  rusage usage{};
  if (wait4(pid, &status, 0, &usage) != pid) throw std::runtime_error("wait4 failed");
  const double seconds = seconds_since(start);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) throw std::runtime_error(cli + " mesh failed");
  if (!fs::exists(out)) throw std::runtime_error(cli + " mesh wrote no " + output);
  fs::remove(out);
  peak_kib = usage.ru_maxrss;  // Linux: KiB
  cpu = usage.ru_utime.tv_sec + 1e-6 * usage.ru_utime.tv_usec + usage.ru_stime.tv_sec + 1e-6 * usage.ru_stime.tv_usec;
  return seconds;
}

struct Bars {
  size_t cells = 0, cgal_faces = 0;
  Samples cgal, cli, in_process, triangulate;  // seconds, one per round, in the rounds' order
  Samples cgal_cpu, cli_cpu;                   // CPU seconds (all threads) of the same runs
  LoadLog loads;                               // at the start of every round
  long cli_peak_kib = 0;                       // from the first CLI run, see measure_bars
  long own_kib = 0;                            // our peak RSS at that run: the floor of what it can show
};

// Linux carries the spawning process's peak RSS over into the child's ru_maxrss (exec records
// the high-water mark of the address space it replaces, which after posix_spawn's vfork is
// ours). So the CLI's peak RSS is taken from a first, untimed run made while we are still small,
// before any mesh or CGAL work. After that every round runs CGAL, the CLI and the same job in
// process once each, in turn, so load from other processes on the machine hits all of them alike.
Bars measure_bars(const fs::path& out, int rounds) {
  Bars bars;
  bars.own_kib = own_peak_kib();
  double cpu = 0;
  cli_once(out, bars.cli_peak_kib, cpu);
  const Grid dsm = read_raster(tile);
  bars.cells = dsm.cells();
  const std::vector<Kernel::Point_3> points = cell_centres(dsm);
  MeshJobOptions job;
  job.input = tile;
  job.output = out.string();
  for (int round = 0; round < rounds; ++round) {
    bars.loads.note();
    bars.cgal.add(cgal_once(points, bars.cgal_faces, cpu));
    bars.cgal_cpu.add(cpu);
    long ignored = 0;
    bars.cli.add(cli_once(out, ignored, cpu));
    bars.cli_cpu.add(cpu);
    const MeshReport report = mesh_dsm(job);
    bars.in_process.add(stage_seconds(report, "total"));
    bars.triangulate.add(stage_seconds(report, "triangulate"));
    fs::remove(out);
  }
  return bars;
}

int run(int rounds) {
  const TempDir temp;
  std::printf("machine: %ld cores (nproc), %s, load average %s at the start\n", sysconf(_SC_NPROCESSORS_ONLN),
              cpu_model().c_str(), load_average().c_str());
  std::printf("tile:    %s\n\n", tile.c_str());

  const Bars bars = measure_bars(temp.path / "out.ply", rounds);  // first, while we are small
  std::vector<Row> rows;
  LoadLog table_loads;
  for (double res : {1.0, 2.0, 3.0, 4.0}) rows.push_back(mesh_in_process(res, temp.path / "table1.ply", table_loads));
  print_table1(rows, table_loads);

  const Samples speedups = ratios(bars.cgal, bars.cli);
  const double speedup = speedups.median();
  const double bytes_per_cell = bars.cli_peak_kib * 1024.0 / bars.cells;
  const bool speed_ok = speedup >= speed_bar, memory_ok = bytes_per_cell <= memory_bar;

  std::printf("\nBars: %s cells at 1 m; %d interleaved rounds (CGAL, CLI, in process), load average %s at the\n",
              grouped(bars.cells).c_str(), rounds, bars.loads.text().c_str());
  std::printf("rounds' starts, %s after; seconds: median (min-max) over the rounds; ratio: CGAL / it, the median\n",
              load_average().c_str());
  std::printf(
      "of the per-round ratios (min-max); the bar is judged on that median. CLI RSS from a first, untimed run\n");
  std::printf("%-52s %21s %21s %8s\n", "", "seconds", "ratio", "bar");
  std::printf("%-52s %21s\n", ("CGAL DT2<xy3>.insert(range), " + grouped(bars.cgal_faces) + " faces").c_str(),
              bars.cgal.text().c_str());
  std::printf("%-52s %21s\n", "the same, CPU seconds (one thread)", bars.cgal_cpu.text().c_str());
  std::printf("%-52s %21s %21s   >= %gx  %s\n", "dsmplan mesh CLI, GeoTIFF -> binary PLY, wall",
              bars.cli.text().c_str(), speedups.text("%.2f").c_str(), speed_bar, speed_ok ? "PASS" : "FAIL");
  std::printf("%-52s %21s %21s %8s  (info)\n", "the same, CPU seconds (user + sys, all threads)",
              bars.cli_cpu.text().c_str(), ratios(bars.cgal_cpu, bars.cli_cpu).text("%.2f").c_str(), "");
  std::printf("%-52s %21s %21.1f   <= %-4g %s\n",
              ("CLI peak RSS " + std::to_string(bars.cli_peak_kib / 1024) + " MiB, bytes per cell").c_str(), "",
              bytes_per_cell, memory_bar, memory_ok ? "PASS" : "FAIL");
  // A reading at our own floor would only say "at most this": the child's peak is hidden.
  if (bars.cli_peak_kib <= bars.own_kib) {
    std::printf("  (not above the benchmark's own %ld MiB: an upper bound only)\n", bars.own_kib / 1024);
  }
  std::printf("%-52s %21s %21s %8s  (info)\n", "same pipeline in process (no process start-up)",
              bars.in_process.text().c_str(), ratios(bars.cgal, bars.in_process).text("%.2f").c_str(), "");
  std::printf("%-52s %21s %21s %8s  (info)\n", "triangulate_xy3 alone, in process", bars.triangulate.text().c_str(),
              ratios(bars.cgal, bars.triangulate).text("%.2f").c_str(), "");

  if (!speed_ok || !memory_ok) std::printf("\n");
  if (!speed_ok) {
    std::printf("FAIL: end to end is only %.2fx faster than CGAL in the median of the rounds (bar: %gx)\n", speedup,
                speed_bar);
  }
  if (!memory_ok) std::printf("FAIL: peak RSS is %.1f bytes per cell (bar: %g)\n", bytes_per_cell, memory_bar);
  return speed_ok && memory_ok ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const int rounds = argc > 1 ? std::max(min_rounds, std::atoi(argv[1])) : 7;
    return run(rounds);
  } catch (const std::exception& error) {
    std::fflush(stdout);
    std::fprintf(stderr, "bench_table1: %s\n", error.what());
    return 1;
  }
}
