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
// Timing (bench/bench_kit.hpp): the methods compared run in interleaved rounds (each round runs
// every one of them once, in turn; at least 5 rounds); a figure is the median with its min-max, a
// ratio the median of the per-round ratios, and the 1-minute load average at the rounds' starts is
// printed. Never a best-of. The speed bar is judged on the median.
//   build/bench/bench_table2 [FIGURE.png = bench_table2_fig.png] [ROUNDS = 5]
// Exit code 0 when every bar passes, 1 when one is missed (or anything fails).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
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

constexpr int min_rounds = 5;        // interleaved rounds, at least (argv[2], default 5)
constexpr double bar_error = 0.4;    // E of the bars, metres
constexpr double bar_seconds = 0.5;  // at most, wall, for simplify_bounded alone (median of the rounds)
// Greedy insertion by an external Garland-Heckbert tool on this tile, two-sided at E/2 = 0.2 m:
// the size figure the bounded mode was specified against.
constexpr size_t external_gh_vertices = 435856;

// One variant of a comparison: run(first) does the work once (and keeps its result when `first`);
// seconds collects its wall time, one per round.
struct Variant {
  std::function<void(bool first)> run;
  Samples seconds;
};

// Interleaved rounds: every round runs every variant once, in turn (A B C A B C ...), so that a
// change of the machine's load hits all of them alike; the load is noted at every round's start.
void interleave(const std::vector<Variant*>& variants, int rounds, LoadLog& loads) {
  for (int round = 0; round < rounds; ++round) {
    loads.note();
    for (Variant* v : variants) v->seconds.add(timed([&] { v->run(round == 0); }));
  }
}

double max_abs(const VerticalError& error) { return std::max(error.max_above, error.max_below); }

// ---- 1. Table 2 -----------------------------------------------------------------------------

struct PaperRun {
  int res = 0;
  PaperVariant variant = PaperVariant::Two;
  size_t in = 0, out = 0, coplanar = 0, colinear = 0, faces = 0;
  Samples search, triangulate;  // per stage, one per round
  Variant timing;
  VerticalError error;
  Mesh mesh;  // kept for the figure
};

// Variants one and two at one resolution, interleaved.
void run_paper(const Grid& dsm, const Mesh& mesh, int res, int rounds, LoadLog& loads, std::vector<PaperRun>& out) {
  PaperRun runs[2];
  const PaperVariant variants[2] = {PaperVariant::One, PaperVariant::Two};
  for (int k = 0; k < 2; ++k) {
    PaperRun& run = runs[k];
    run.res = res;
    run.variant = variants[k];
    run.in = mesh.vertices.size();
    run.timing.run = [&run, &mesh](bool first) {
      PaperSimplifyOptions options;
      options.variant = run.variant;
      options.dz = 0.4;
      PaperSimplifyResult r = simplify_paper(mesh, options);
      run.search.add(r.seconds_search);
      run.triangulate.add(r.seconds_triangulate);
      if (!first) return;
      run.out = r.mesh.vertices.size();
      run.faces = r.mesh.triangles.size();
      run.coplanar = r.removed_coplanar;
      run.colinear = r.removed_colinear;
      run.mesh = std::move(r.mesh);
    };
  }
  interleave({&runs[0].timing, &runs[1].timing}, rounds, loads);
  for (PaperRun& run : runs) {
    run.error = certify(run.mesh, dsm);
    run.timing.run = nullptr;  // it points at this slot, which is moved from
    out.push_back(std::move(run));
  }
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

void print_table2(const std::vector<PaperRun>& runs, int rounds, const LoadLog& loads) {
  std::printf("Table 2: one-pass simplification (Section 4), dz 0.4 m, dco 1e-5 m, on the XY-3 mesh (z step 0.1 m)\n");
  std::printf("ours: NRW DOM1 tile 1 x 1 km, median resampling; variants one and two interleaved, %d rounds per\n",
              rounds);
  std::printf("resolution (load average %s at the rounds' starts); search and triang: medians, seconds: the whole\n",
              loads.text().c_str());
  std::printf("call, median (min-max); error = certify() against the resampled DSM before quantization (m; above/\n");
  std::printf("below: mesh over/under the DSM). Paper: variant two only.\n\n");
  std::printf("%-4s %-16s %10s %10s %7s %10s %9s %10s | %6s %6s %21s | %6s %6s %6s\n", "res", "data", "in", "out",
              "red.", "co-planar", "co-linear", "faces", "search", "triang", "seconds (min-max)", "above", "below",
              "rms");
  for (const PaperRun& run : runs) {
    const std::string data = std::string("ours variant ") + (run.variant == PaperVariant::One ? "1" : "2");
    std::printf("%-4s %-16s %10s %10s %6.1f%% %10s %9s %10s | %6.3f %6.3f %21s | %6.2f %6.2f %6.3f\n",
                (std::to_string(run.res) + " m").c_str(), data.c_str(), grouped(run.in).c_str(),
                grouped(run.out).c_str(), -100.0 * (run.in - run.out) / run.in, grouped(run.coplanar).c_str(),
                grouped(run.colinear).c_str(), grouped(run.faces).c_str(), run.search.median(),
                run.triangulate.median(), run.timing.seconds.text().c_str(), run.error.max_above, run.error.max_below,
                run.error.rms);
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
  Variant timing;
  bool conservative = false;  // which guarantee "holds" checks
  Mesh mesh;                  // the first run's output, certified after the rounds
};

// The rows' guarantee against the certificate. The baseline's arithmetic runs in lattice units,
// certify()'s in CRS coordinates: 1 nm of rounding is not a miss.
const char* holds(const BoundRow& row, double bound) {
  constexpr double rounding = 1e-9;
  const bool ok = row.conservative ? row.error.max_below == 0 && row.error.max_above <= bound + rounding
                                   : max_abs(row.error) <= bound + rounding;
  return ok ? "yes" : "no";
}

void bounded_row(BoundRow& row, const std::string& method, const Grid& dsm, const BoundedSimplifyOptions& options) {
  row.method = method;
  row.conservative = options.conservative;
  row.timing.run = [&row, &dsm, options](bool first) {
    Mesh mesh = simplify_bounded(dsm, options);
    if (first) row.mesh = std::move(mesh);
  };
}

void paper_row(BoundRow& row, const Mesh& xy3, double dz) {
  row.method = "paper variant 2, dz = E";
  row.timing.run = [&row, &xy3, dz](bool first) {
    PaperSimplifyOptions options;
    options.dz = dz;
    PaperSimplifyResult result = simplify_paper(xy3, options);
    if (first) row.mesh = std::move(result.mesh);
  };
}

void baseline_row(BoundRow& row, const Grid& dsm, double bound) {
  row.method = "greedy baseline (GH), two-sided";
  row.timing.run = [&row, &dsm, bound](bool first) {
    bench::GreedyBaselineResult result = bench::greedy_insertion_baseline(dsm, bound);
    if (first) row.mesh = std::move(result.mesh);
  };
}

void certify_row(BoundRow& row, const Grid& dsm) {
  row.vertices = row.mesh.vertices.size();
  row.faces = row.mesh.triangles.size();
  row.error = certify(row.mesh, dsm);
}

// One bound E: the six methods of the table (and at the bars' E the bars' two extra variants),
// every method once per round, in turn. Rows are held by unique_ptr: the variants' closures point
// at them.
struct BoundTable {
  double bound = 0;
  size_t cells = 0;
  int rounds = 0;
  LoadLog loads;
  std::vector<std::unique_ptr<BoundRow>> rows;  // the table's six
  size_t reference = 2;                         // the row the ratios are against: bounded conservative, tiled
};

void print_bound_tables(const std::vector<BoundTable>& tables) {
  std::printf(
      "\nEqual bound E at 1 m: every output certified by certify() against the DSM (m); seconds wall, median\n");
  std::printf("(min-max) of interleaved rounds (every method once per round, in turn); \"x conservative\": this\n");
  std::printf("method's seconds / the bounded conservative tiled mode's in the same round, median (min-max).\n");
  std::printf("\"holds\": two-sided |error| <= E, conservative 0 <= error <= E. The paper's variant simplifies the\n");
  std::printf("XY-3 mesh (z step 0.1 m) and guarantees no bound; the bounded mode and the baseline (single-\n");
  std::printf("threaded, CGAL Delaunay, DSM heights) work on the DSM itself.\n");
  for (const BoundTable& table : tables) {
    std::printf("\nE = %.1f m, whole tile (%s cells), %d rounds, load average %s at the rounds' starts\n", table.bound,
                grouped(table.cells).c_str(), table.rounds, table.loads.text().c_str());
    std::printf("  %-38s %10s %10s %8s %8s %8s %7s %5s | %21s %21s\n", "method", "vertices", "faces", "max|err|",
                "above", "below", "rms", "holds", "seconds (min-max)", "x conservative");
    const Samples& reference = table.rows[table.reference]->timing.seconds;
    for (const auto& row : table.rows) {
      std::printf("  %-38s %10s %10s %8.3f %8.3f %8.3f %7.3f %5s | %21s %21s\n", row->method.c_str(),
                  grouped(row->vertices).c_str(), grouped(row->faces).c_str(), max_abs(row->error),
                  row->error.max_above, row->error.max_below, row->error.rms, holds(*row, table.bound),
                  row->timing.seconds.text().c_str(), ratios(row->timing.seconds, reference).text("%.2f").c_str());
    }
  }
}

// ---- 3. The bars ----------------------------------------------------------------------------

struct Bars {
  const BoundRow* tiled = nullptr;   // conservative at bar_error, default options: the table's row
  const BoundRow* global = nullptr;  // the same with delaunay = true: the table's row
  BoundRow single_thread;            // the same with threads = 1
  BoundRow baseline_half;            // the baseline two-sided at bar_error / 2
  Samples certify_seconds;
};

BoundTable bound_table(const Grid& dsm, const Mesh& xy3, double bound, int rounds, Bars* bars) {
  BoundTable table;
  table.bound = bound;
  table.cells = dsm.cells();
  table.rounds = rounds;
  for (int k = 0; k < 6; ++k) table.rows.push_back(std::make_unique<BoundRow>());
  BoundedSimplifyOptions options;
  options.max_error = bound;
  paper_row(*table.rows[0], xy3, bound);
  bounded_row(*table.rows[1], "bounded two-sided, tiled", dsm, options);
  options.conservative = true;
  bounded_row(*table.rows[2], bars ? "bounded conservative, tiled (default)" : "bounded conservative, tiled", dsm,
              options);
  options.delaunay = true;
  options.conservative = false;
  bounded_row(*table.rows[3], "bounded two-sided, delaunay = true", dsm, options);
  options.conservative = true;
  bounded_row(*table.rows[4], "bounded conservative, delaunay = true", dsm, options);
  baseline_row(*table.rows[5], dsm, bound);
  std::vector<Variant*> variants;
  for (const auto& row : table.rows) variants.push_back(&row->timing);
  if (bars) {
    BoundedSimplifyOptions one_thread;
    one_thread.max_error = bound;
    one_thread.conservative = true;
    one_thread.threads = 1;
    bounded_row(bars->single_thread, "bounded conservative, threads = 1", dsm, one_thread);
    baseline_row(bars->baseline_half, dsm, bound / 2);
    variants.push_back(&bars->single_thread.timing);
    variants.push_back(&bars->baseline_half.timing);
  }
  interleave(variants, rounds, table.loads);
  for (const auto& row : table.rows) certify_row(*row, dsm);
  if (bars) {
    certify_row(bars->single_thread, dsm);
    certify_row(bars->baseline_half, dsm);
    bars->tiled = table.rows[2].get();
    bars->global = table.rows[4].get();
    for (int k = 0; k < rounds; ++k) bars->certify_seconds.add(timed([&] { certify(bars->tiled->mesh, dsm); }));
  }
  return table;
}

bool print_bars(const Bars& bars, const LoadLog& loads) {
  const BoundRow& tiled = *bars.tiled;
  const Samples& seconds = tiled.timing.seconds;
  const bool speed_ok = seconds.median() <= bar_seconds;
  const bool size_ok = tiled.vertices <= bars.baseline_half.vertices;
  const bool certificate_ok = tiled.error.max_below == 0 && tiled.error.max_above <= bar_error;
  std::printf("\nBars: simplify_bounded conservative, E = %.1f m, default options (tiled, all cores), 1 m tile;\n",
              bar_error);
  std::printf("%zu interleaved rounds with the E = %.1f m table's methods, threads = 1 and the baseline at E/2 (load\n",
              seconds.size(), bar_error);
  std::printf("average %s at the rounds' starts); medians (min-max), ratios per round\n", loads.text().c_str());
  std::printf("(i)   speed: %s s wall, the simplify_bounded call alone (bar: median <= %.1f s)   %s\n",
              seconds.text().c_str(), bar_seconds, speed_ok ? "PASS" : "MISS");
  std::printf("      certify() of its output, for information: %s s\n", bars.certify_seconds.text().c_str());
  std::printf("(ii)  size: %s vertices <= %s of the greedy baseline two-sided at E/2 = %.1f m   %s\n",
              grouped(tiled.vertices).c_str(), grouped(bars.baseline_half.vertices).c_str(), bar_error / 2,
              size_ok ? "PASS" : "MISS");
  std::printf("      (baseline certified max|err| %.3f m in %s s; reference: an external GH tool on this tile at\n",
              max_abs(bars.baseline_half.error), bars.baseline_half.timing.seconds.text().c_str());
  std::printf("      0.2 m, %s vertices: ours is %.1f%% of it)\n", grouped(external_gh_vertices).c_str(),
              100.0 * tiled.vertices / external_gh_vertices);
  std::printf("(iii) certificate: max_below %.3g m == 0 and max_above %.6f m <= %.1f m   %s\n", tiled.error.max_below,
              tiled.error.max_above, bar_error, certificate_ok ? "PASS" : "MISS");
  std::printf("      (%s cells measured, %s valid cells uncovered, rms %.3f m)\n", grouped(tiled.error.cells).c_str(),
              grouped(tiled.error.uncovered).c_str(), tiled.error.rms);
  std::printf("speed-up of tiled (threads = 0, %ld cores), its seconds against the other's in the same round:\n",
              sysconf(_SC_NPROCESSORS_ONLN));
  std::printf("  %sx vs threads = 1 (%s s, %s vertices)\n",
              ratios(bars.single_thread.timing.seconds, seconds).text("%.2f").c_str(),
              bars.single_thread.timing.seconds.text().c_str(), grouped(bars.single_thread.vertices).c_str());
  std::printf("  %sx vs delaunay = true (%s s, %s vertices)\n",
              ratios(bars.global->timing.seconds, seconds).text("%.2f").c_str(),
              bars.global->timing.seconds.text().c_str(), grouped(bars.global->vertices).c_str());
  std::printf("  %sx vs the greedy baseline at E/2 (in process, one core)\n",
              ratios(bars.baseline_half.timing.seconds, seconds).text("%.2f").c_str());
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
  const int rounds = argc > 2 ? std::max(min_rounds, std::atoi(argv[2])) : min_rounds;
  const auto start = std::chrono::steady_clock::now();
  std::printf("machine: %ld cores (nproc), %s, load average %s at the start\n", sysconf(_SC_NPROCESSORS_ONLN),
              cpu_model().c_str(), load_average().c_str());
  std::printf("tile:    %s\n\n", tile.c_str());
  const Grid dsm = read_raster(tile);
  const Mesh xy3_1m = triangulate_xy3(dsm);

  // The bars' bound first: its timings are the ones that matter most, so they run while the
  // machine is fresh.
  Bars bars;
  std::vector<BoundTable> tables;
  tables.push_back(bound_table(dsm, xy3_1m, bar_error, rounds, &bars));

  std::vector<PaperRun> paper_runs;
  LoadLog paper_loads;
  for (int res : {1, 2, 3, 4}) {
    if (res == 1) {
      run_paper(dsm, xy3_1m, res, rounds, paper_loads, paper_runs);
      continue;
    }
    const Grid grid = resample(dsm, res, Resampling::Median);
    run_paper(grid, triangulate_xy3(grid), res, rounds, paper_loads, paper_runs);
  }
  print_table2(paper_runs, rounds, paper_loads);

  for (double bound : {0.1, 1.0}) tables.push_back(bound_table(dsm, xy3_1m, bound, rounds, nullptr));
  std::sort(tables.begin(), tables.end(), [](const BoundTable& a, const BoundTable& b) { return a.bound < b.bound; });
  print_bound_tables(tables);

  const LoadLog& bar_loads =
      std::find_if(tables.begin(), tables.end(), [](const BoundTable& t) { return t.bound == bar_error; })->loads;
  const bool ok = print_bars(bars, bar_loads);
  write_figure(dsm, paper_runs[0].mesh, paper_runs[1].mesh, bars.tiled->mesh, figure);
  std::printf("\nbenchmark wall time %.0f s, load average %s at the end\n", seconds_since(start),
              load_average().c_str());
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
