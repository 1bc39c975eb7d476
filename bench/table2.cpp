// Table 2 of Adolf & Hirschmueller, "Meshing and Simplification of High Resolution Urban Surface
// Data for UAV Path Planning" (Section 4), redone on a real DSM, and the bounded mode of
// dsmplan/simplify.hpp measured against it and against a textbook greedy insertion (Garland &
// Heckbert, CMU-CS-95-181, 1995; bench/greedy_baseline.hpp).
//
// Measured on the NRW DOM1 tile (1000 x 1000 cells at 1 m, EPSG:25832):
//   1. Table 2: simplify_paper(), variants one and two (dz 0.4 m, dco 1e-5 m), on the XY-3 mesh
//      of Table 1 (median resampling to 1-4 m, z step 0.1 m), printed beside the paper's three
//      Berlin sections, with the error certify() measures against the resampled DSM (before
//      quantization): the paper gives no error figure, this is what its tolerances amount to.
//   2. Equal bound E in {0.1, 0.4, 1.0} m at 1 m: the paper's variant two with dz = E, the bounded
//      mode (two-sided, conservative, single global Delaunay) and the greedy-insertion baseline,
//      every output judged by the same certify().
//   3. The bars, for the bounded conservative mode at E = 0.4 m with default options: speed
//      (<= 0.5 s wall), size (no more vertices than greedy insertion at the same band width,
//      i.e. two-sided at E/2), and its certificate (nothing below the DSM, nothing above by
//      more than E).
//   4. A figure like the paper's Figures 6/7: one block, variant one / variant two / bounded
//      conservative side by side with their edges, to argv[1] (default bench_table2_fig.png).
// A benchmark, not a test: timings are best of several runs and still noisy on a shared
// machine. Exit code 0 when every bar passes, 1 when one is missed (or anything fails).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/simplify.hpp"
#include "greedy_baseline.hpp"

using namespace dsmplan;
using namespace bench;

namespace {

constexpr int fast_runs = 3;         // best of this many for a run that is fast...
constexpr double slow_run = 3.0;     // ...and a single run for one that takes longer (seconds)
constexpr int bar_runs = 5;          // the speed bar: best of this many, always
constexpr double bar_error = 0.4;    // E of the bars, metres
constexpr double bar_seconds = 0.5;  // at most, wall, for simplify_bounded alone
// Greedy insertion by an external Garland-Heckbert tool on this tile, two-sided at E/2 = 0.2 m:
// the size figure the bounded mode was specified against.
constexpr size_t external_gh_vertices = 435856;

// Result of fn() with its best wall time: up to `max_runs` runs, only one when it is slow.
template <class F>
auto best_of(F&& fn, int max_runs, double& seconds, int& runs, double slow = slow_run) {
  seconds = never;
  runs = 0;
  for (;;) {
    const auto start = std::chrono::steady_clock::now();
    auto result = fn();
    const double took = seconds_since(start);
    seconds = std::min(seconds, took);
    if (++runs >= max_runs || took > slow) return result;
  }
}

double max_abs(const VerticalError& error) { return std::max(error.max_above, error.max_below); }

// ---- 1. Table 2 -----------------------------------------------------------------------------

struct PaperRun {
  int res = 0;
  PaperVariant variant = PaperVariant::Two;
  size_t in = 0, out = 0, coplanar = 0, colinear = 0, faces = 0;
  double search = never, triangulate = never;  // best of the runs, per stage
  int runs = 0;
  VerticalError error;
  Mesh mesh;  // kept for the figure
};

PaperRun run_paper(const Grid& dsm, const Mesh& mesh, int res, PaperVariant variant, double dz) {
  PaperRun run;
  run.res = res;
  run.variant = variant;
  run.in = mesh.vertices.size();
  PaperSimplifyOptions options;
  options.variant = variant;
  options.dz = dz;
  double ignored = 0;
  PaperSimplifyResult result = best_of(
      [&] {
        PaperSimplifyResult r = simplify_paper(mesh, options);
        run.search = std::min(run.search, r.seconds_search);
        run.triangulate = std::min(run.triangulate, r.seconds_triangulate);
        return r;
      },
      fast_runs, ignored, run.runs);
  run.out = result.mesh.vertices.size();
  run.faces = result.mesh.triangles.size();
  run.coplanar = result.removed_coplanar;
  run.colinear = result.removed_colinear;
  run.error = certify(result.mesh, dsm);
  run.mesh = std::move(result.mesh);
  return run;
}

// The paper's Table 2 (variant two only; Berlin, 7 cm DSM downsampled, z step 0.1 m), with the
// input vertex counts of its Table 1. Mitte's rows do not add up (in = out + co-planar, the
// co-linear ones missing); they are printed as published.
struct PaperRow {
  const char* section;
  int res;
  size_t in, out;
  int percent;  // as printed
  size_t coplanar, colinear;
};
constexpr PaperRow paper[] = {
    {"Mitte", 1, 2450000, 944873, -62, 1505127, 24284}, {"Mitte", 2, 612500, 338182, -45, 268247, 6071},
    {"Mitte", 3, 272728, 177749, -35, 92552, 2427},     {"Mitte", 4, 153300, 109757, -29, 42301, 1242},
    {"Potsdamer", 1, 276051, 86448, -69, 187893, 1710}, {"Potsdamer", 2, 69000, 33151, -52, 35109, 740},
    {"Potsdamer", 3, 30728, 17981, -41, 12410, 337},    {"Potsdamer", 4, 17250, 11303, -35, 5769, 178},
    {"Reichstag", 1, 113176, 27163, -76, 85615, 398},   {"Reichstag", 2, 28388, 10770, -62, 17510, 108},
    {"Reichstag", 3, 12600, 5855, -53, 6619, 126},      {"Reichstag", 4, 7144, 3692, -48, 3382, 70},
};

void print_table2(const std::vector<PaperRun>& runs) {
  std::printf("Table 2: one-pass simplification (Section 4), dz 0.4 m, dco 1e-5 m, on the XY-3 mesh (z step 0.1 m)\n");
  std::printf("ours: NRW DOM1 tile 1 x 1 km, median resampling; seconds best of up to %d; error = certify() against\n",
              fast_runs);
  std::printf(
      "the resampled DSM before quantization (m; above/below: mesh over/under the DSM). Paper: variant two only.\n\n");
  std::printf("%-4s %-16s %10s %10s %7s %10s %9s %10s | %6s %6s | %6s %6s %6s\n", "res", "data", "in", "out", "red.",
              "co-planar", "co-linear", "faces", "search", "triang", "above", "below", "rms");
  for (const PaperRun& run : runs) {
    const std::string data = std::string("ours variant ") + (run.variant == PaperVariant::One ? "1" : "2");
    std::printf("%-4s %-16s %10s %10s %6.1f%% %10s %9s %10s | %6.3f %6.3f | %6.2f %6.2f %6.3f\n",
                (std::to_string(run.res) + " m").c_str(), data.c_str(), grouped(run.in).c_str(),
                grouped(run.out).c_str(), -100.0 * (run.in - run.out) / run.in, grouped(run.coplanar).c_str(),
                grouped(run.colinear).c_str(), grouped(run.faces).c_str(), run.search, run.triangulate,
                run.error.max_above, run.error.max_below, run.error.rms);
    if (run.variant != PaperVariant::Two) continue;
    for (const PaperRow& p : paper) {
      if (p.res != run.res) continue;
      std::printf("%-4s %-16s %10s %10s %6d%% %10s %9s\n", "", ("paper " + std::string(p.section)).c_str(),
                  grouped(p.in).c_str(), grouped(p.out).c_str(), p.percent, grouped(p.coplanar).c_str(),
                  grouped(p.colinear).c_str());
    }
  }
}

// ---- 2. Equal bound -------------------------------------------------------------------------

struct BoundRow {
  std::string method;
  size_t vertices = 0, faces = 0;
  VerticalError error;
  double seconds = never;
  int runs = 0;
  bool conservative = false;  // which guarantee "holds" checks
};

// The rows' guarantee against the certificate. The baseline's arithmetic runs in lattice units,
// certify()'s in CRS coordinates: 1 nm of rounding is not a miss.
const char* holds(const BoundRow& row, double bound) {
  constexpr double rounding = 1e-9;
  const bool ok = row.conservative ? row.error.max_below == 0 && row.error.max_above <= bound + rounding
                                   : max_abs(row.error) <= bound + rounding;
  return ok ? "yes" : "no";
}

BoundRow bounded_row(const std::string& method, const Grid& dsm, const BoundedSimplifyOptions& options) {
  BoundRow row;
  row.method = method;
  row.conservative = options.conservative;
  const Mesh mesh = best_of([&] { return simplify_bounded(dsm, options); }, fast_runs, row.seconds, row.runs);
  row.vertices = mesh.vertices.size();
  row.faces = mesh.triangles.size();
  row.error = certify(mesh, dsm);
  return row;
}

BoundRow paper_row(const Grid& dsm, const Mesh& xy3, double dz) {
  BoundRow row;
  row.method = "paper variant 2, dz = E";
  PaperSimplifyOptions options;
  options.dz = dz;
  const PaperSimplifyResult result =
      best_of([&] { return simplify_paper(xy3, options); }, fast_runs, row.seconds, row.runs);
  row.vertices = result.mesh.vertices.size();
  row.faces = result.mesh.triangles.size();
  row.error = certify(result.mesh, dsm);
  return row;
}

BoundRow baseline_row(const Grid& dsm, double bound) {
  BoundRow row;
  row.method = "greedy baseline (GH), two-sided";
  const bench::GreedyBaselineResult result =
      best_of([&] { return bench::greedy_insertion_baseline(dsm, bound); }, fast_runs, row.seconds, row.runs);
  row.vertices = result.mesh.vertices.size();
  row.faces = result.mesh.triangles.size();
  row.error = certify(result.mesh, dsm);
  return row;
}

struct BoundTable {
  double bound = 0;
  size_t cells = 0;
  std::vector<BoundRow> rows;
};

void print_bound_tables(const std::vector<BoundTable>& tables) {
  std::printf(
      "\nEqual bound E at 1 m: every output certified by certify() against the DSM (m); seconds wall, best of\n");
  std::printf("up to %d (one run when over %.0f s). \"holds\": two-sided |error| <= E, conservative 0 <= error <= E.\n",
              fast_runs, slow_run);
  std::printf(
      "The paper's variant simplifies the XY-3 mesh (z step 0.1 m) and guarantees no bound; the bounded mode\n");
  std::printf("and the baseline (single-threaded, CGAL Delaunay, DSM heights) work on the DSM itself.\n");
  for (const BoundTable& table : tables) {
    std::printf("\nE = %.1f m, whole tile (%s cells)\n", table.bound, grouped(table.cells).c_str());
    std::printf("  %-38s %10s %10s %8s %8s %8s %7s %5s | %8s %4s\n", "method", "vertices", "faces", "max|err|", "above",
                "below", "rms", "holds", "seconds", "runs");
    for (const BoundRow& row : table.rows) {
      std::printf("  %-38s %10s %10s %8.3f %8.3f %8.3f %7.3f %5s | %8.3f %4d\n", row.method.c_str(),
                  grouped(row.vertices).c_str(), grouped(row.faces).c_str(), max_abs(row.error), row.error.max_above,
                  row.error.max_below, row.error.rms, holds(row, table.bound), row.seconds, row.runs);
    }
  }
}

// ---- 3. The bars ----------------------------------------------------------------------------

struct Bars {
  BoundRow tiled, single_thread, global;  // conservative at bar_error: default, threads=1, delaunay
  BoundRow baseline_half;                 // the baseline two-sided at bar_error / 2
  double certify_seconds = never;
  Mesh mesh;  // the tiled output, for the figure
};

Bars measure_bars(const Grid& dsm) {
  Bars bars;
  BoundedSimplifyOptions options;
  options.max_error = bar_error;
  options.conservative = true;
  // The speed bar is best of bar_runs, however long a run takes: it is the figure the bar judges.
  Mesh mesh =
      best_of([&] { return simplify_bounded(dsm, options); }, bar_runs, bars.tiled.seconds, bars.tiled.runs, never);
  bars.tiled.method = "bounded conservative, tiled (default)";
  bars.tiled.conservative = true;
  bars.tiled.vertices = mesh.vertices.size();
  bars.tiled.faces = mesh.triangles.size();
  int runs = 0;
  bars.tiled.error = best_of([&] { return certify(mesh, dsm); }, fast_runs, bars.certify_seconds, runs);
  bars.mesh = std::move(mesh);

  BoundedSimplifyOptions one_thread = options;
  one_thread.threads = 1;
  bars.single_thread = bounded_row("bounded conservative, threads = 1", dsm, one_thread);
  BoundedSimplifyOptions global = options;
  global.delaunay = true;
  bars.global = bounded_row("bounded conservative, delaunay = true", dsm, global);
  bars.baseline_half = baseline_row(dsm, bar_error / 2);
  return bars;
}

bool print_bars(const Bars& bars) {
  const BoundRow& tiled = bars.tiled;
  const bool speed_ok = tiled.seconds <= bar_seconds;
  const bool size_ok = tiled.vertices <= bars.baseline_half.vertices;
  const bool certificate_ok = tiled.error.max_below == 0 && tiled.error.max_above <= bar_error;
  std::printf("\nBars: simplify_bounded conservative, E = %.1f m, default options (tiled, all cores), 1 m tile\n",
              bar_error);
  std::printf("(i)   speed: %.3f s wall, best of %d, the simplify_bounded call alone (bar <= %.1f s)   %s\n",
              tiled.seconds, tiled.runs, bar_seconds, speed_ok ? "PASS" : "MISS");
  std::printf("      certify() of its output, for information: %.3f s (best of %d)\n", bars.certify_seconds, fast_runs);
  std::printf("(ii)  size: %s vertices <= %s of the greedy baseline two-sided at E/2 = %.1f m   %s\n",
              grouped(tiled.vertices).c_str(), grouped(bars.baseline_half.vertices).c_str(), bar_error / 2,
              size_ok ? "PASS" : "MISS");
  std::printf("      (baseline certified max|err| %.3f m in %.2f s; reference: an external GH tool on this tile at\n",
              max_abs(bars.baseline_half.error), bars.baseline_half.seconds);
  std::printf("      0.2 m, %s vertices: ours is %.1f%% of it)\n", grouped(external_gh_vertices).c_str(),
              100.0 * tiled.vertices / external_gh_vertices);
  std::printf("(iii) certificate: max_below %.3g m == 0 and max_above %.6f m <= %.1f m   %s\n", tiled.error.max_below,
              tiled.error.max_above, bar_error, certificate_ok ? "PASS" : "MISS");
  std::printf("      (%s cells measured, %s valid cells uncovered, rms %.3f m)\n", grouped(tiled.error.cells).c_str(),
              grouped(tiled.error.uncovered).c_str(), tiled.error.rms);
  std::printf("speed-up of tiled (threads = 0, %ld cores): %.2fx vs threads = 1 (%.3f s, %s vertices), %.2fx vs\n",
              sysconf(_SC_NPROCESSORS_ONLN), bars.single_thread.seconds / tiled.seconds, bars.single_thread.seconds,
              grouped(bars.single_thread.vertices).c_str(), bars.global.seconds / tiled.seconds);
  std::printf("delaunay = true (%.3f s, %s vertices)\n", bars.global.seconds, grouped(bars.global.vertices).c_str());
  return speed_ok && size_ok && certificate_ok;
}

// ---- 4. The figure ---------------------------------------------------------------------------

// Figures 6/7 of the paper show single blocks up close: here 150 x 150 m of large flat-roofed
// buildings with courtyards, street trees and a street canyon (picked from a hillshade of the
// tile), where the difference between the variants and the bounded mode is plain to see.
constexpr Window figure_window{356625, 5699325, 356775, 5699475};

// Panels of the paper's two variants at 1 m and the bar's bounded conservative mesh, each on the
// 1 m DSM with its triangle edges; the vertex counts are the whole tile's.
void write_figure(const Grid& dsm, const Mesh& one, const Mesh& two, const Mesh& bounded, const std::string& path) {
  RenderOptions options;
  options.window = figure_window;
  options.pixels_per_cell = 4;
  std::vector<Image> panels;
  for (const auto& [mesh, title] : {std::pair{&one, std::string("paper variant one, dz 0.4 m")},
                                    {&two, std::string("paper variant two, dz 0.4 m")},
                                    {&bounded, std::string("bounded conservative, E 0.4 m")}}) {
    options.title = title + ", " + grouped(mesh->vertices.size()) + " vertices";
    options.scale_bar = options.north_arrow = mesh == &one;  // once is enough
    panels.push_back(render_view(dsm, mesh, options));
  }
  write_png(side_by_side(panels), path);
  std::printf(
      "\nfigure: %s (%.0f x %.0f m at E %.0f-%.0f, N %.0f-%.0f; 1 m tile; vertex counts are the whole tile's)\n",
      path.c_str(), figure_window.xmax - figure_window.xmin, figure_window.ymax - figure_window.ymin,
      figure_window.xmin, figure_window.xmax, figure_window.ymin, figure_window.ymax);
}

int run(int argc, char** argv) {
  const std::string figure = argc > 1 ? argv[1] : "bench_table2_fig.png";
  const auto start = std::chrono::steady_clock::now();
  std::printf("machine: %ld cores (nproc), %s, load average %s at the start\n", sysconf(_SC_NPROCESSORS_ONLN),
              cpu_model().c_str(), load_average().c_str());
  std::printf("tile:    %s\n\n", tile.c_str());
  const Grid dsm = read_raster(tile);

  // 3 first: its timings are the ones that matter most, so they run while the machine is fresh.
  const Bars bars = measure_bars(dsm);

  std::vector<PaperRun> paper_runs;
  Mesh xy3_1m;
  for (int res : {1, 2, 3, 4}) {
    const Grid grid = res == 1 ? dsm : resample(dsm, res, Resampling::Median);
    Mesh mesh = triangulate_xy3(grid);
    for (PaperVariant variant : {PaperVariant::One, PaperVariant::Two}) {
      paper_runs.push_back(run_paper(grid, mesh, res, variant, 0.4));
    }
    if (res == 1) xy3_1m = std::move(mesh);
  }
  print_table2(paper_runs);

  std::vector<BoundTable> tables;
  for (double bound : {0.1, 0.4, 1.0}) {
    BoundTable table;
    table.bound = bound;
    table.cells = dsm.cells();
    const Grid& grid = dsm;
    const Mesh& xy3 = xy3_1m;
    BoundedSimplifyOptions options;
    options.max_error = bound;
    table.rows.push_back(paper_row(grid, xy3, bound));
    table.rows.push_back(bounded_row("bounded two-sided, tiled", grid, options));
    options.conservative = true;
    if (bound == bar_error) {
      table.rows.push_back(bars.tiled);
    } else {
      table.rows.push_back(bounded_row("bounded conservative, tiled", grid, options));
    }
    options.delaunay = true;
    options.conservative = false;
    table.rows.push_back(bounded_row("bounded two-sided, delaunay = true", grid, options));
    options.conservative = true;
    if (bound == bar_error) {
      table.rows.push_back(bars.global);
    } else {
      table.rows.push_back(bounded_row("bounded conservative, delaunay = true", grid, options));
    }
    table.rows.push_back(baseline_row(grid, bound));
    tables.push_back(std::move(table));
  }
  print_bound_tables(tables);

  const bool ok = print_bars(bars);
  write_figure(dsm, paper_runs[0].mesh, paper_runs[1].mesh, bars.mesh, figure);
  std::printf("\nbenchmark wall time %.0f s\n", seconds_since(start));
  return ok ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& error) {
    std::fflush(stdout);
    std::fprintf(stderr, "bench_table2: %s\n", error.what());
    return 1;
  }
}
