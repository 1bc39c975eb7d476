// Table 3 of Adolf & Hirschmueller, "Meshing and Simplification of High Resolution Urban Surface
// Data for UAV Path Planning" (Section 5), redone on a real DSM: planning on the original and on
// the simplified meshes, and the planner at very low altitude.
//
// Measured on the NRW DOM1 tile (1000 x 1000 cells at 1 m, EPSG:25832):
//   1. Table 3: at 1, 2, 3, 4 m (median resampling, as Tables 1 and 2), the XY-3 mesh
//      ("original"), the paper's simplification variant two (dz = 0.4 m) and the bounded
//      conservative mode (E = 0.4 m). Each mesh is written as PLY and read back; "load" is reading
//      it plus building the ClearanceIndex, "roadmap" build_roadmap(), "planning"
//      query_roadmap() (connecting the waypoints, A*, shortcuts and spline: the paper's planning
//      column includes the waypoint connection too). Default planner options (spacing 20 m, edges
//      up to 34.5 m, max_agl 120 m, safety 2 m), as the paper's. Four waypoints, widely spread
//      (near the tile's corners: south-west, north-east, north-west, south-east, three legs of
//      0.9-1.3 km), each 5 m above a street: chosen automatically and deterministically on the
//      1 m original (see street_point()), at each mesh 5 m above that mesh's surface.
//      Beside them the paper's Table 3 (its numbers as constants below): the change the
//      simplified mesh makes to each time, and the speed-up over the paper's times.
//   2. Very low altitude: the same waypoints with max_agl 30 m (and 20, 15, 10 m) on the 1 m original
//      and the bounded mesh: legs solved with and without the query-time refinement of
//      dsmplan/plan.hpp, times, path length, samples the refinement added.
// A benchmark, not a test: times are the median of three runs (the roadmap and planning), noisy on a
// shared machine. Exit code 0 when every leg of every row with refinement is solved, else 1.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/simplify.hpp"
#include "street_point.hpp"

using namespace dsmplan;
using namespace bench;

namespace {

constexpr int runs = 3;           // the median of, for the roadmap and the planning
constexpr double agl_street = 5;  // waypoints above the street, m

// ---- the paper's Table 3 -------------------------------------------------------------------
// Original mesh: seconds; simplified: the change in per cent. Single-threaded, 32-bit, Pentium
// Core 2. "Mitte" (1750 x 1400 m) used 40 m spacing, Potsdamer (500 x 650 m) and Reichstag
// (500 x 300 m) 20 m; our tile is 1000 x 1000 m.
struct PaperRow {
  const char* section;
  int res;
  double load, load_change, roadmap, roadmap_change, planning, planning_change;
};
constexpr PaperRow paper[] = {
    {"Mitte", 1, 96.10, -61, 122.50, -88, 5.33, -18},   {"Mitte", 2, 33.66, -46, 36.10, -27, 3.87, -19},
    {"Mitte", 3, 17.48, -36, 25.76, -11, 3.28, -32},    {"Mitte", 4, 10.86, -28, 19.50, -13, 3.58, -8},
    {"Potsdamer", 1, 8.94, -69, 46.59, -36, 2.92, -25}, {"Potsdamer", 2, 3.33, -56, 33.63, -10, 2.95, -20},
    {"Potsdamer", 3, 1.78, -41, 32.70, -5, 2.97, -14},  {"Potsdamer", 4, 1.14, -40, 28.28, -2, 2.53, -27},
    {"Reichstag", 1, 2.77, -75, 7.56, -74, 0.69, -42},  {"Reichstag", 2, 1.06, -60, 3.75, -41, 0.50, -6},
    {"Reichstag", 3, 0.56, -60, 2.86, -41, 0.54, -19},  {"Reichstag", 4, 0.39, -45, 3.19, -4, 0.46, -18},
};

// ---- waypoints -----------------------------------------------------------------------------

// A point near (x, y) on a street (scenario::street_point, tests/street_point.hpp), x, y and
// the ground.
Point3 street_point(const ClearanceIndex& index, double x, double y) {
  const auto p = scenario::street_point(index, x, y, [](const Point3&) { return true; });
  if (!p) throw std::runtime_error("no street within 100 m of " + std::to_string(x) + ", " + std::to_string(y));
  return *p;
}

// Near the corners, 60 m in: south-west, north-east, north-west, south-east.
std::vector<Point3> street_points(const ClearanceIndex& index) {
  const ClearanceIndex::Footprint& e = index.footprint();
  const double in = 60;
  return {street_point(index, e.xmin + in, e.ymin + in), street_point(index, e.xmax - in, e.ymax - in),
          street_point(index, e.xmin + in, e.ymax - in), street_point(index, e.xmax - in, e.ymin + in)};
}

// The waypoints on one mesh: agl_street above its own surface.
std::vector<Point3> waypoints_on(const ClearanceIndex& index, const std::vector<Point3>& streets) {
  std::vector<Point3> out;
  for (const Point3& s : streets) out.push_back({s[0], s[1], index.ground(s[0], s[1]) + agl_street});
  return out;
}

// ---- 1. Table 3 ------------------------------------------------------------------------------

struct Row {
  std::string mesh;
  int res = 0;
  size_t vertices = 0, triangles = 0;
  double read = 0, index = 0, roadmap = never, planning = never, length = 0;
  size_t nodes = 0, edges = 0, refined = 0;
  PlanStatus status = PlanStatus::NoPath;
  std::string why;
};

// The median of a few runs (issue 19: no best-of figures).
double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? never : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

Row measure(const std::string& name, int res, const Mesh& built, const std::vector<Point3>& streets,
            const PlanOptions& options) {
  Row row;
  row.mesh = name;
  row.res = res;
  const std::string ply = "/tmp/bench_table3_" + std::to_string(getpid()) + ".ply";
  write_mesh(built, ply, MeshFormat::Ply);
  auto start = std::chrono::steady_clock::now();
  const Mesh mesh = read_mesh(ply);
  row.read = seconds_since(start);
  std::remove(ply.c_str());
  start = std::chrono::steady_clock::now();
  const ClearanceIndex index(mesh);
  row.index = seconds_since(start);
  row.vertices = mesh.vertices.size();
  row.triangles = mesh.triangles.size();
  const std::vector<Point3> waypoints = waypoints_on(index, streets);
  std::vector<double> roadmaps, plannings;
  for (int run = 0; run < runs; ++run) {
    start = std::chrono::steady_clock::now();
    const Roadmap map = build_roadmap(index, options);
    roadmaps.push_back(seconds_since(start));
    row.roadmap = median_of(roadmaps);
    start = std::chrono::steady_clock::now();
    const PlanResult result = query_roadmap(map, index, waypoints, options);
    plannings.push_back(seconds_since(start));
    row.planning = median_of(plannings);
    row.status = result.status;
    row.why = result.status == PlanStatus::Solved ? "" : result.place() + ": " + result.reason;
    row.length = path_length(result.path);
    row.nodes = map.nodes.size();
    row.edges = map.edges();
    row.refined = result.refined_samples;
  }
  return row;
}

double change(double simplified, double original) { return 100 * (simplified / original - 1); }

void print_table3(const std::vector<Row>& rows) {
  std::printf(
      "Table 3 on the NRW tile: 4 street waypoints (5 m above ground), defaults (spacing 20 m, max edge 34.5 m, "
      "max_agl 120 m, safety 2 m), all cores; seconds (roadmap, planning: median of %d)\n\n",
      runs);
  std::printf(
      "| res m | mesh | vertices | triangles | read s | index s | load s | roadmap s | planning s | nodes | edges | "
      "path m | solved |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    std::printf("| %d | %s | %s | %s | %.3f | %.3f | %.3f | %.3f | %.4f | %s | %s | %.0f | %s |\n", r.res,
                r.mesh.c_str(), grouped(r.vertices).c_str(), grouped(r.triangles).c_str(), r.read, r.index,
                r.read + r.index, r.roadmap, r.planning, grouped(r.nodes).c_str(), grouped(r.edges).c_str(), r.length,
                r.status == PlanStatus::Solved ? "3/3" : r.why.c_str());

  std::printf(
      "\nChange the simplified mesh makes (vs the original at the same resolution), ours beside the paper's "
      "(load / roadmap / planning, per cent)\n\n");
  std::printf(
      "| res m | ours, variant two | ours, bounded E=0.4 | paper Mitte | paper Potsdamer | paper Reichstag |\n"
      "|---|---|---|---|---|---|\n");
  for (size_t k = 0; k + 2 < rows.size(); k += 3) {
    const Row &o = rows[k], &v = rows[k + 1], &b = rows[k + 2];
    std::printf("| %d | %+.0f / %+.0f / %+.0f | %+.0f / %+.0f / %+.0f |", o.res,
                change(v.read + v.index, o.read + o.index), change(v.roadmap, o.roadmap),
                change(v.planning, o.planning), change(b.read + b.index, o.read + o.index),
                change(b.roadmap, o.roadmap), change(b.planning, o.planning));
    for (const PaperRow& p : paper)
      if (p.res == o.res) std::printf(" %+.0f / %+.0f / %+.0f |", p.load_change, p.roadmap_change, p.planning_change);
    std::printf("\n");
  }

  std::printf(
      "\nSpeed-up over the paper (its seconds / ours, original and simplified mesh; the paper's simplified times "
      "are its original times with its change applied). Potsdamer is the paper's section with the same spacing and "
      "dense streets; our tile has 3.1x its area and 3.6x its triangles at 1 m (Mitte: 2.45 km2, 40 m spacing).\n\n");
  std::printf(
      "| res m | mesh | load: Potsdamer / ours | roadmap | planning | load: Mitte / ours | roadmap | planning |\n"
      "|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows) {
    const bool simplified = r.mesh != "original";
    std::printf("| %d | %s |", r.res, r.mesh.c_str());
    for (const char* section : {"Potsdamer", "Mitte"})
      for (const PaperRow& p : paper)
        if (p.res == r.res && std::string(p.section) == section) {
          auto paper_time = [&](double t, double c) { return simplified ? t * (1 + c / 100) : t; };
          std::printf(" %.0fx | %.0fx | %.0fx |", paper_time(p.load, p.load_change) / (r.read + r.index),
                      paper_time(p.roadmap, p.roadmap_change) / r.roadmap,
                      paper_time(p.planning, p.planning_change) / r.planning);
        }
    std::printf("\n");
  }
}

// ---- 2. very low altitude ----------------------------------------------------------------------

struct LowRow {
  std::string mesh;
  double agl = 0;
  bool refine = true;
  int legs_solved = 0, legs = 0;
  double roadmap = never, query = never, length = 0;  // query: all legs, with smoothing
  size_t nodes = 0, refined = 0, lattice = 0;
  int rounds = 0;
};

LowRow low_row(const std::string& name, const ClearanceIndex& index, const std::vector<Point3>& waypoints, double agl,
               bool refine) {
  LowRow row;
  row.mesh = name;
  row.agl = agl;
  row.refine = refine;
  PlanOptions options;
  options.max_agl = agl;
  if (!refine) options.refine_rounds = 0;
  std::vector<double> roadmaps, queries;
  for (int run = 0; run < runs; ++run) {
    auto start = std::chrono::steady_clock::now();
    const Roadmap map = build_roadmap(index, options);
    roadmaps.push_back(seconds_since(start));
    row.roadmap = median_of(roadmaps);
    row.nodes = map.nodes.size();
    // Leg by leg, so a failing leg does not hide the others.
    double query = 0, length = 0;
    int solved = 0, rounds = 0;
    size_t refined = 0, lattice = 0;
    for (size_t k = 0; k + 1 < waypoints.size(); ++k) {
      start = std::chrono::steady_clock::now();
      const PlanResult r = query_roadmap(map, index, {waypoints[k], waypoints[k + 1]}, options);
      query += seconds_since(start);
      if (r.status == PlanStatus::Solved) ++solved, length += path_length(r.path);
      refined += r.refined_samples;
      lattice += r.lattice_nodes;
      rounds += r.refine_rounds;
    }
    queries.push_back(query);
    row.query = median_of(queries);
    row.legs_solved = solved, row.legs = static_cast<int>(waypoints.size()) - 1;
    row.length = length, row.refined = refined, row.rounds = rounds;
    row.lattice = lattice;
    if (query > 2) break;  // slow: once is enough
  }
  return row;
}

void print_low(const std::vector<LowRow>& rows) {
  std::printf(
      "\nVery low altitude: the same 4 street waypoints, spacing 20 m, max edge 34.5 m, safety 2 m; legs queried one "
      "by one; seconds median of %d (of 1 when the query takes over 2 s); path m = sum over the solved legs\n\n",
      runs);
  std::printf(
      "| mesh | max_agl m | refinement | legs solved | roadmap s | query s (all legs) | total s | roadmap nodes | "
      "lattice nodes | samples added | rounds | path m |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const LowRow& r : rows)
    std::printf("| %s | %.0f | %s | %d/%d | %.4f | %.4f | %.4f | %s | %s | %s | %d | %.0f |\n", r.mesh.c_str(), r.agl,
                r.refine ? "on" : "off", r.legs_solved, r.legs, r.roadmap, r.query, r.roadmap + r.query,
                grouped(r.nodes).c_str(), grouped(r.lattice).c_str(), grouped(r.refined).c_str(), r.rounds, r.length);
}

// only_low: section 2 alone (bench_table3 --low), for working on the very-low-altitude planner.
int run(bool only_low) {
  const auto start = std::chrono::steady_clock::now();
  std::printf("machine: %ld cores (nproc), %s, load average %s at the start\n", sysconf(_SC_NPROCESSORS_ONLN),
              cpu_model().c_str(), load_average().c_str());
  std::printf("tile:    %s\n\n", tile.c_str());
  const Grid dsm = read_raster(tile);
  const Mesh xy3_1m = triangulate_xy3(dsm);
  std::vector<Point3> streets;
  {
    const ClearanceIndex index(xy3_1m);
    streets = street_points(index);
    const ClearanceIndex::Footprint& e = index.footprint();
    std::printf("waypoints (x, y from the tile's south-west corner; street ground z), 5 m above each mesh:\n");
    for (const Point3& s : streets) std::printf("  %.0f, %.0f  ground %.1f m\n", s[0] - e.xmin, s[1] - e.ymin, s[2]);
    std::printf("\n");
  }

  BoundedSimplifyOptions bounded;
  bounded.max_error = 0.4;
  bounded.conservative = true;
  PaperSimplifyOptions variant_two;  // variant two, dz 0.4 m, dco 1e-5 m
  const PlanOptions defaults;

  std::vector<Row> rows;
  bool ok = true;
  Mesh bounded_1m;
  if (only_low) bounded_1m = simplify_bounded(dsm, bounded);
  for (int res : {1, 2, 3, 4}) {
    if (only_low) break;
    const Grid grid = res == 1 ? Grid{} : resample(dsm, res, Resampling::Median);
    const Grid& g = res == 1 ? dsm : grid;
    const Mesh original = res == 1 ? Mesh{} : triangulate_xy3(g);
    const Mesh& o = res == 1 ? xy3_1m : original;
    rows.push_back(measure("original", res, o, streets, defaults));
    rows.push_back(measure("variant two dz=0.4", res, simplify_paper(o, variant_two).mesh, streets, defaults));
    Mesh b = simplify_bounded(g, bounded);
    rows.push_back(measure("bounded E=0.4", res, b, streets, defaults));
    if (res == 1) bounded_1m = std::move(b);
  }
  for (const Row& r : rows) ok = ok && r.status == PlanStatus::Solved;
  if (!only_low) print_table3(rows);

  std::vector<LowRow> low;
  for (const auto& [name, mesh] : {std::pair<const char*, const Mesh*>{"original 1 m", &xy3_1m},
                                   std::pair<const char*, const Mesh*>{"bounded E=0.4, 1 m", &bounded_1m}}) {
    const ClearanceIndex index(*mesh);
    const std::vector<Point3> waypoints = waypoints_on(index, streets);
    for (double agl : {30.0, 20.0, 15.0, 10.0})
      for (bool refine : {false, true}) {
        low.push_back(low_row(name, index, waypoints, agl, refine));
        if (refine) ok = ok && low.back().legs_solved == low.back().legs;
      }
  }
  print_low(low);
  std::printf("\nevery leg of every row (refinement on) solved: %s\nbenchmark wall time %.0f s\n", ok ? "yes" : "NO",
              seconds_since(start));
  return ok ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  const bool only_low = argc == 2 && std::string(argv[1]) == "--low";
  if (argc > 2 || (argc == 2 && !only_low)) {
    std::fprintf(stderr, "usage: bench_table3 [--low]\n");
    return 2;
  }
  try {
    return run(only_low);
  } catch (const std::exception& error) {
    std::fflush(stdout);
    std::fprintf(stderr, "bench_table3: %s\n", error.what());
    return 1;
  }
}
