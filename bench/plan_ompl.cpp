// dsmplan's probabilistic roadmap (dsmplan/plan.hpp) against OMPL's PRM
// (ompl::geometric::PRM, OMPL 1.5.2 from Debian 12) on the same samples, the same edges and an
// exact collision check on both sides.
//
// Sources:
//   - Adolf & Hirschmueller, "Meshing and Simplification of High Resolution Urban Surface Data
//     for UAV Path Planning", Section 5 (PRM over the mesh, 2 m safety distance).
//   - Kavraki, Svestka, Latombe, Overmars, "Probabilistic roadmaps for path planning in
//     high-dimensional configuration spaces", IEEE T-RA 12(4), 1996.
//   - Sucan, Moll, Kavraki, "The Open Motion Planning Library", IEEE RAM 19(4), 2012; the API of
//     /usr/include/ompl-1.5 (PRM.h: addMilestone, constructSolution, setConnectionStrategy;
//     base/MotionValidator.h; geometric/PathSimplifier.h).
//   - The Planner Arena log format: OMPL's Benchmark::saveResultsToStream
//     (src/ompl/tools/benchmark/src/Benchmark.cpp) and the reader readBenchmarkLog() of
//     scripts/ompl_benchmark_statistics.py (github.com/ompl/ompl). Debian ships neither the
//     script nor ompl-demos, so the bench re-reads its own log with the same token rules
//     (check_arena_log below).
//   - Embree 3 point queries (rtcPointQuery, Embree 3.13 API manual): Wald et al., "Embree: a
//     kernel framework for efficient CPU ray tracing", ACM TOG 33(4), 2014.
//
// Meshes: the NRW DOM1 tile (1000 x 1000 cells at 1 m, EPSG:25832) as the XY-3 mesh, and the
// same real tile resampled by GDAL (GDALWarp, bilinear) to 0.64 m cells, 1562 x 1562, about
// the size of the paper's Berlin-Mitte section (about 4.9 M triangles).
//
// Per mesh:
//   - dsmplan: build_roadmap() on both cores (threads = 0) and query_roadmap() over 4 waypoints
//     30 m above ground (3 legs).
//   - OMPL (bench/ompl_baseline.hpp, shared with the whole-process baseline bench_ompl_plan):
//     RealVectorStateSpace(3) bounded by the footprint and [lowest vertex, highest vertex +
//     max_agl]; an exact StateValidityChecker and MotionValidator; a PRM subclass that is given
//     every Halton candidate build_roadmap() draws (same function, re-implemented and checked
//     equal to Roadmap::nodes, with each checker's own ground()), checks its validity through
//     OMPL's SpaceInformation and adds the valid ones with OMPL's addMilestone(), whose
//     connection strategy returns every earlier milestone closer than max_edge (nearestR of
//     OMPL's nearest-neighbour structure, the fastest of those OMPL offers: kFairestNN). Its
//     roadmap is compared with dsmplan's edge for edge. Query per leg: the two waypoints
//     validated and added by addMilestone(), then constructSolution() (OMPL's
//     boost::astar_search over its graph) when they share a component; that is what
//     PRM::solve() does on an existing roadmap, without its thread that keeps growing the
//     roadmap with random samples while it looks for a solution. One run (the query milestones
//     stay in the graph). Then PathSimplifier::simplifyMax.
//   - Two exact checkers for OMPL: (i) dsmplan's ClearanceIndex (segment_clear), (ii) an Embree
//     3 BVH over the triangles (Embree's default build quality), queried by spheres covering the
//     capsule of the segment, each candidate measured with dsmplan::segment_triangle_distance
//     (exact), its ground() a ray cast. (ii) is exact: it must give the same samples and edges
//     as (i), which the bench checks.
//   - Timing: argv[1] (at least 5, 5 by default) paired, interleaved rounds, each a roadmap of
//     dsmplan, of OMPL + ClearanceIndex and of OMPL + Embree in turn, so that all three meet the
//     shared machine in the same state (its speed drifts by tens of percent over seconds); the
//     load average at each round's start is printed. Figures are the median with min-max over
//     the rounds, ratios OMPL / dsmplan per round. dsmplan's query: the median of as many runs.
// Bars (exit code 0 only when both pass), on the 0.64 m mesh: dsmplan's roadmap >= 5x faster
// than OMPL's PRM with the faster exact checker (median of the paired ratios), at equal samples
// and edges; dsmplan's 3-leg query <= 10 ms (median). Results also go to
// out/bench/plan_ompl.log in OMPL's benchmark log format. Measurements: bench/README.md,
// "Planning as a whole process against OMPL". dsmplan's roadmap proves most candidate
// pairs clear from its samples' clearance bounds without an exact check (plan.hpp, "Edges");
// OMPL checks every pair. The printed phase times re-do dsmplan's phases without the
// certificates, on one thread, for comparison with OMPL's profile.
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "ompl_baseline.hpp"

using namespace dsmplan;
using namespace bench;
namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace {

using namespace bench::baseline;

const PlanOptions plan_options{};  // the CLI's defaults: safety 2, spacing 20, max_edge 34.5, max_agl 120
int repetitions = 5;               // paired rounds: argv[1], 5 by default (at least 5)

// ---- measurements --------------------------------------------------------------------------

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? NAN : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
double lowest(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }
double highest(const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); }
// "median (min-max)" with `digits` decimals
std::string spread(const std::vector<double>& v, int digits) {
  char b[96];
  std::snprintf(b, sizeof b, "%.*f (%.*f-%.*f)", digits, median(v), digits, lowest(v), digits, highest(v));
  return b;
}
std::vector<double> ratios(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> out;
  for (size_t k = 0; k < a.size(); ++k) out.push_back(a[k] / b[k]);
  return out;
}

struct OmplRun {
  std::string checker;
  bool same_candidates = false;  // its ground() gave build_roadmap's candidates, bit for bit
  size_t samples = 0, edges = 0;
  bool same_edges = false;        // OMPL's edge set equals dsmplan's
  std::vector<double> roadmap_s;  // one per round, paired with MeshRow::roadmap_s
  double query_ms = 0, simplify_ms = 0;
  double length = NAN, simplified = NAN;
  bool solved = false;
  Profile profile;                          // of a run of its own with timers
  double solve_ms = 0, solve_length = NAN;  // PRM::solve() per leg, for information
  bool solve_solved = false;
  size_t solve_added = 0;  // random milestones solve() added besides the waypoints
};

struct MeshRow {
  std::string name;
  double cell = 0;
  size_t triangles = 0;
  double index_s = 0;
  size_t candidates = 0, samples = 0, edges = 0;
  bool same_nodes = false;
  std::vector<double> roadmap_s, query_ms;  // every round / repetition
  std::vector<std::string> loads;           // the 1-minute load average at each round's start
  std::vector<double> roadmap1_s;           // on one thread, for the profile
  // build_roadmap's phases re-done here on one thread (profile): Halton candidates with ground()
  // and point_clear(); the candidate pairs from its grid of max_edge cells; segment_clear() on them.
  double sample_s = 0, ground_s = 0, pairs_s = 0, checks_s = 0;  // ground_s: Halton + ground() part
  size_t pairs = 0;
  double length = NAN, raw_length = NAN;
  bool solved = false;
  std::vector<OmplRun> ompl;
};

// One OMPL side of a round: its checker, space and candidates (from its own ground()).
struct OmplSide {
  const Checker* checker;
  Profile profile;
  ob::SpaceInformationPtr si;
  std::vector<Point3> candidates;
  OmplRun run;
};

// A fresh PRM given every candidate; seconds.
double build_ompl(OmplSide& side, std::shared_ptr<GivenSamplesPRM>& prm) {
  prm.reset();
  prm = std::make_shared<GivenSamplesPRM>(side.si, plan_options.max_edge, side.profile);
  prm->setProblemDefinition(std::make_shared<ob::ProblemDefinition>(side.si));  // its path-length objective
  prm->setup();
  const auto start = Clock::now();
  add_candidates(side.si, *prm, side.candidates);
  return since(start);
}

// After the rounds: one more roadmap with the profile's timers on, checked edge for edge against
// dsmplan's; then the query on it.
void finish_ompl(OmplSide& side, const Roadmap& map, const std::vector<Point3>& waypoints) {
  OmplRun& run = side.run;
  const ob::SpaceInformationPtr& si = side.si;
  std::shared_ptr<GivenSamplesPRM> prm;
  side.profile = {};
  side.profile.on = true;
  side.profile.total_s = build_ompl(side, prm);
  run.profile = side.profile;
  side.profile.on = false;
  run.samples = prm->milestoneCount();
  run.edges = prm->edgeCount();

  // Edge for edge: milestone i is Halton-kept sample i, as in dsmplan's node order.
  if (run.samples == map.nodes.size() && run.edges == map.edges()) {
    std::set<std::pair<uint32_t, uint32_t>> theirs;
    const auto& g = prm->getRoadmap();
    for (auto [it, end] = boost::edges(g); it != end; ++it) {
      auto a = static_cast<uint32_t>(boost::source(*it, g)), b = static_cast<uint32_t>(boost::target(*it, g));
      theirs.emplace(std::min(a, b), std::max(a, b));
    }
    bool same = theirs.size() == map.edges();
    for (uint32_t i = 0; same && i + 1 < map.start.size(); ++i)
      for (uint32_t k = map.start[i]; same && k < map.start[i + 1]; ++k)
        if (map.neighbour[k] > i) same = theirs.count({i, map.neighbour[k]}) == 1;
    run.same_edges = same;
  }

  // The query: 3 legs, each waypoint validated by OMPL first (as PRM::solve's input states are).
  ob::State* work = si->allocState();
  ob::State* other = si->allocState();
  std::vector<og::PathGeometric> legs;
  auto start = Clock::now();
  run.solved = true;
  for (size_t i = 0; i + 1 < waypoints.size() && run.solved; ++i) {
    set_state(work, waypoints[i]);
    set_state(other, waypoints[i + 1]);
    if (!si->isValid(work) || !si->isValid(other)) {
      run.solved = false;
      break;
    }
    auto path = prm->leg(work, other);
    if (!path)
      run.solved = false;
    else
      legs.push_back(*path);
  }
  run.query_ms = 1e3 * since(start);
  if (run.solved) {
    run.length = 0;
    for (const auto& l : legs) run.length += l.length();
    og::PathSimplifier simplifier(si);
    start = Clock::now();
    run.simplified = 0;
    for (auto& l : legs) {
      simplifier.simplifyMax(l);
      run.simplified += l.length();
    }
    run.simplify_ms = 1e3 * since(start);
  }

  // For information: the same legs through the public API, PRM::solve() on the existing roadmap
  // with clearQuery() between legs. It also runs a thread that looks for a solution while the
  // calling thread keeps adding random milestones, so it adds states and is not deterministic.
  auto pdef = prm->getProblemDefinition();
  const size_t before = prm->milestoneCount();
  start = Clock::now();
  run.solve_solved = true;
  run.solve_length = 0;
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) {
    set_state(work, waypoints[i]);
    set_state(other, waypoints[i + 1]);
    pdef->clearSolutionPaths();
    pdef->setStartAndGoalStates(work, other);  // replaces the previous start and goal
    prm->clearQuery();
    const ob::PlannerStatus status = prm->solve(ob::timedPlannerTerminationCondition(10.0));
    if (status != ob::PlannerStatus::EXACT_SOLUTION) {
      run.solve_solved = false;
      break;
    }
    run.solve_length += pdef->getSolutionPath()->length();
  }
  run.solve_ms = 1e3 * since(start);
  run.solve_added = prm->milestoneCount() - before - 2 * (waypoints.size() - 1);

  si->freeState(other);
  si->freeState(work);
}

// The candidate pairs of build_roadmap (src/plan/prm_roadmap.cpp, re-done for the profile):
// nodes sorted by their cell of a max_edge grid, the 27 cells around each node looked up by
// binary search, pairs i < j closer than max_edge. One thread.
std::vector<std::pair<uint32_t, uint32_t>> candidate_pairs(const ClearanceIndex& index,
                                                           const std::vector<Point3>& nodes, double& seconds) {
  const auto start = std::chrono::steady_clock::now();
  const ClearanceIndex::Footprint& e = index.footprint();
  const double cell = plan_options.max_edge, reach2 = cell * cell;
  double zmin = INFINITY;
  for (const Point3& p : nodes) zmin = std::min(zmin, p[2]);
  const int64_t nx = static_cast<int64_t>((e.xmax - e.xmin) / cell) + 1,
                ny = static_cast<int64_t>((e.ymax - e.ymin) / cell) + 1;
  auto coord = [&](const Point3& p, int k) {
    const double lo = k == 0 ? e.xmin : k == 1 ? e.ymin : zmin;
    return static_cast<int64_t>(std::floor((p[k] - lo) / cell));
  };
  auto key = [&](int64_t ix, int64_t iy, int64_t iz) { return (iz * ny + iy) * nx + ix; };
  std::vector<std::pair<int64_t, uint32_t>> sorted(nodes.size());
  for (size_t i = 0; i < nodes.size(); ++i)
    sorted[i] = {key(coord(nodes[i], 0), coord(nodes[i], 1), coord(nodes[i], 2)), static_cast<uint32_t>(i)};
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::pair<uint32_t, uint32_t>> out;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const Point3& p = nodes[i];
    const int64_t cx = coord(p, 0), cy = coord(p, 1), cz = coord(p, 2);
    for (int64_t z = cz - 1; z <= cz + 1; ++z)
      for (int64_t y = cy - 1; y <= cy + 1; ++y)
        for (int64_t x = cx - 1; x <= cx + 1; ++x) {
          if (x < 0 || y < 0 || z < 0 || x >= nx || y >= ny) continue;
          const int64_t k = key(x, y, z);
          for (auto it = std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(k, uint32_t{0}));
               it != sorted.end() && it->first == k; ++it) {
            const Point3& q = nodes[it->second];
            const double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
            if (it->second > i && dx * dx + dy * dy + dz * dz < reach2)
              out.emplace_back(static_cast<uint32_t>(i), it->second);
          }
        }
  }
  seconds = seconds_since(start);
  return out;
}

MeshRow run_mesh(const std::string& name, double cell, const Mesh& mesh) {
  MeshRow row;
  row.name = name, row.cell = cell, row.triangles = mesh.triangles.size();
  auto start = std::chrono::steady_clock::now();
  const ClearanceIndex index(mesh);
  row.index_s = seconds_since(start);

  // The roadmap, built once untimed (a warm-up, as OMPL's first run below is).
  const Roadmap map = build_roadmap(index, plan_options);
  row.samples = map.nodes.size(), row.edges = map.edges();
  PlanOptions one_thread = plan_options;
  one_thread.threads = 1;
  for (int rep = 0; rep < repetitions; ++rep) {
    start = std::chrono::steady_clock::now();
    const Roadmap built = build_roadmap(index, one_thread);
    row.roadmap1_s.push_back(seconds_since(start));
  }

  // The samples re-generated here (one thread), and checked equal to build_roadmap's.
  const GroundGrid& floor = index.floor();
  const IndexChecker index_checker(index, plan_options.safety);
  start = std::chrono::steady_clock::now();
  const std::vector<Point3> candidates = halton_candidates(index.footprint(), index_checker, floor, plan_options);
  row.ground_s = seconds_since(start);
  std::vector<Point3> kept;
  for (const Point3& c : candidates)
    if (!std::isnan(c[2]) && index.point_clear(c, plan_options.safety)) kept.push_back(c);
  row.sample_s = seconds_since(start);
  row.candidates = candidates.size();
  row.same_nodes = kept == map.nodes;
  {
    const std::vector<std::pair<uint32_t, uint32_t>> found = candidate_pairs(index, map.nodes, row.pairs_s);
    row.pairs = found.size();
    start = std::chrono::steady_clock::now();
    size_t clear = 0;
    for (const auto& [i, j] : found)
      clear += index.floor().below_ceiling(map.nodes[i], map.nodes[j], plan_options.max_agl) &&
               index.segment_clear(map.nodes[i], map.nodes[j], plan_options.safety);
    row.checks_s = seconds_since(start);
    if (clear != map.edges()) std::printf("  re-done phases give %zu edges, not %zu\n", clear, map.edges());
  }

  const std::vector<Point3> waypoints = make_waypoints(index, 30, plan_options.safety);
  PlanResult result;
  for (int rep = 0; rep < repetitions; ++rep) {
    start = std::chrono::steady_clock::now();
    result = query_roadmap(map, index, waypoints, plan_options);
    row.query_ms.push_back(1e3 * seconds_since(start));
  }
  row.solved = result.status == PlanStatus::Solved;
  if (row.solved)
    row.length = path_length(result.path), row.raw_length = path_length(result.raw_path);
  else
    std::printf("  dsmplan query failed at %s: %s\n", result.place().c_str(), result.reason.c_str());

  std::printf("%s: %s triangles, index %.2f s; dsmplan roadmap %s samples (of %s candidates), %s edges\n", name.c_str(),
              grouped(row.triangles).c_str(), row.index_s, grouped(row.samples).c_str(),
              grouped(row.candidates).c_str(), grouped(row.edges).c_str());
  std::fflush(stdout);

  // OMPL's sides: its space over each checker, the candidates from that checker's ground().
  double zmin = INFINITY, zmax = -INFINITY;
  for (const Vertex& v : mesh.vertices) zmin = std::min(zmin, v.z), zmax = std::max(zmax, v.z);
  std::vector<std::unique_ptr<OmplSide>> sides;
  auto add_side = [&](const Checker& checker) {
    auto side = std::make_unique<OmplSide>();
    side->checker = &checker;
    side->run.checker = checker.name();
    side->si = make_space(index.footprint(), zmin, zmax, checker, floor, plan_options.max_agl, side->profile);
    side->candidates = halton_candidates(index.footprint(), checker, floor, plan_options);
    side->run.same_candidates = side->candidates.size() == candidates.size();
    for (size_t i = 0; side->run.same_candidates && i < candidates.size(); ++i)
      for (int k = 0; k < 3; ++k)
        if (!(side->candidates[i][k] == candidates[i][k] ||
              (std::isnan(side->candidates[i][k]) && std::isnan(candidates[i][k]))))
          side->run.same_candidates = false;
    sides.push_back(std::move(side));
  };
  add_side(index_checker);
#ifdef DSMPLAN_HAVE_EMBREE
  start = std::chrono::steady_clock::now();
  const EmbreeChecker embree(mesh, index.origin(), plan_options.safety);
  std::printf("  Embree BVH built in %.2f s\n", seconds_since(start));
  add_side(embree);
#endif
  // Paired, interleaved rounds: dsmplan, OMPL + ClearanceIndex, OMPL + Embree, dsmplan, ...: each
  // round meets the shared machine in one state (its speed drifts by tens of percent over seconds).
  for (int rep = 0; rep < repetitions; ++rep) {
    row.loads.push_back(load_average());
    start = std::chrono::steady_clock::now();
    const Roadmap built = build_roadmap(index, plan_options);
    row.roadmap_s.push_back(seconds_since(start));
    if (built.neighbour != map.neighbour) std::printf("  build_roadmap gave another roadmap on a repetition\n");
    for (auto& side : sides) {
      std::shared_ptr<GivenSamplesPRM> prm;
      side->run.roadmap_s.push_back(build_ompl(*side, prm));
    }
  }
  for (auto& side : sides) {
    finish_ompl(*side, map, waypoints);
    row.ompl.push_back(side->run);
  }
  std::printf(
      "  dsmplan build_roadmap: %s s on %u threads, %s s on 1; its phases re-done on 1 thread: samples %.3f s "
      "(Halton + ground() %.3f s, point_clear %.3f s), %s candidate pairs %.3f s, their segment_clear %.3f s\n",
      spread(row.roadmap_s, 3).c_str(), std::max(1u, std::thread::hardware_concurrency()),
      spread(row.roadmap1_s, 3).c_str(), row.sample_s, row.ground_s, row.sample_s - row.ground_s,
      grouped(row.pairs).c_str(), row.pairs_s, row.checks_s);
  for (const OmplRun& r : row.ompl) {
    const Profile& p = r.profile;
    std::printf(
        "  OMPL PRM + %s (%s): candidates from its ground() the same as build_roadmap's: %s; %s milestones, %s "
        "edges, same edges as dsmplan: %s; roadmap %s s; a run with timers %.3f s = validity %.3f s + %s motions "
        "%.3f s + nearestR %.3f s + the rest (graph, clone, disjoint sets) %.3f s\n",
        r.checker.c_str(), nn_name(kFairestNN), r.same_candidates ? "yes" : "NO", grouped(r.samples).c_str(),
        grouped(r.edges).c_str(), r.same_edges ? "yes" : "NO", spread(r.roadmap_s, 3).c_str(), p.total_s, p.valid_s,
        grouped(p.motions).c_str(), p.motion_s, p.near_s, p.total_s - p.valid_s - p.motion_s - p.near_s);
    std::printf(
        "    PRM::solve() per leg on that roadmap (information): %.1f ms, %s, length %.0f m, %zu random "
        "milestones added\n",
        r.solve_ms, r.solve_solved ? "solved" : "NOT solved", r.solve_length, r.solve_added);
  }
  std::fflush(stdout);
  return row;
}

// The 0.64 m mesh: the real tile resampled by GDAL's warper (bilinear) to 1562 x 1562 cells
// of 0.64 m from the tile's top-left corner (999.68 m of its 1000 m), through an in-memory
// GeoTIFF read back by the library's own reader.
Grid resampled_tile(double cell) {
  const std::string path = "/vsimem/plan_ompl_resampled.tif";
  warp_bilinear(tile, cell, path);
  Grid grid = read_raster(path);
  VSIUnlink(path.c_str());
  return grid;
}

// ---- Planner Arena log ---------------------------------------------------------------------

std::string host_name() {
  char b[256] = "unknown";
  gethostname(b, sizeof b - 1);
  return b;
}

std::string num(double v) {
  if (!std::isfinite(v)) return "nan";
  char b[64];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

// One experiment, two planners; one run per repetition (dsmplan) or per checker (OMPL), a run
// per mesh, told apart by the "mesh cell" property; the checker as an enum as OMPL's "status".
void write_arena_log(const std::string& path, const std::vector<MeshRow>& rows, double total_s) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream out(path);
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S", std::gmtime(&now));
  out << "OMPL version " << OMPL_VERSION_STRING << "\n";
  out << "Experiment dsmplan_plan_ompl\n";
  out << "Running on " << host_name() << "\n";
  out << "Starting at " << date << "\n";
  out << "<<<|\nNRW DOM1 tile dom1_32_356_5699_1_nw_2020 (EPSG:25832) as XY-3 meshes at 1 m and, resampled by "
         "GDALWarp bilinear, 0.64 m; PlanOptions defaults (safety 2, spacing 20, max_edge 34.5, max_agl 120); "
         "same Halton samples and edges for both planners; 4 waypoints 30 m above ground, 3 legs\n|>>>\n";
  out << "<<<|\n"
      << cpu_model() << ", " << std::thread::hardware_concurrency() << " cores, load " << load_average() << "\n|>>>\n";
  out << "0 is the random seed\n";
  out << "10 seconds per run\n";  // the limit PRM::solve() is given per leg
  out << "0 MB per run\n";
  out << "-1 runs per planner\n";
  out << num(total_s) << " seconds spent to collect the data\n";
  out << "2 enum types\n";
  out << "status|Unknown status|Invalid start|Invalid goal|Unrecognized goal type|Timeout|Approximate "
         "solution|Exact solution|Crash|Abort\n";
  out << "checker|dsmplan ClearanceIndex|Embree 3\n";
  out << "2 planners\n";
  const std::vector<std::string> props = {"checker ENUM",
                                          "graph motions INTEGER",
                                          "graph states INTEGER",
                                          "mesh cell REAL",
                                          "mesh triangles INTEGER",
                                          "query time REAL",
                                          "roadmap time REAL",
                                          "simplified solution length REAL",
                                          "solution length REAL",
                                          "solved BOOLEAN",
                                          "status ENUM",
                                          "threads INTEGER",
                                          "time REAL"};
  auto header = [&](const char* planner, const std::string& common, size_t runs) {
    out << planner << "\n1 common properties\n" << common << "\n" << props.size() << " properties for each run\n";
    for (const std::string& p : props) out << p << "\n";
    out << runs << " runs\n";
  };
  auto line = [&](const std::vector<std::string>& values) {
    for (const std::string& v : values) out << v << "; ";
    out << "\n";
  };
  const std::string status_exact = "6", status_timeout = "4";
  size_t runs = 0;
  for (const MeshRow& r : rows) runs += r.roadmap_s.size();
  header("dsmplan_PRM", "implementation = dsmplan build_roadmap + query_roadmap (TBB, all cores)", runs);
  for (const MeshRow& r : rows)
    for (size_t k = 0; k < r.roadmap_s.size(); ++k)
      line({"0", std::to_string(r.edges), std::to_string(r.samples), num(r.cell), std::to_string(r.triangles),
            num(r.query_ms[k] / 1e3), num(r.roadmap_s[k]), num(r.length), num(r.raw_length), r.solved ? "1" : "0",
            r.solved ? status_exact : status_timeout, std::to_string(std::thread::hardware_concurrency()),
            num(r.roadmap_s[k] + r.query_ms[k] / 1e3)});
  out << ".\n";
  runs = 0;
  for (const MeshRow& r : rows)
    for (const OmplRun& o : r.ompl) runs += o.roadmap_s.size();
  header("geometric_PRM",
         std::string("implementation = ompl::geometric::PRM, given samples, nearestR(max_edge) connection, ") +
             nn_name(kFairestNN),
         runs);
  for (const MeshRow& r : rows)
    for (const OmplRun& o : r.ompl)
      for (double roadmap_s : o.roadmap_s)  // one query run: the same query time on each line
        line({o.checker == "Embree 3" ? "1" : "0", std::to_string(o.edges), std::to_string(o.samples), num(r.cell),
              std::to_string(r.triangles), num(o.query_ms / 1e3), num(roadmap_s), num(o.simplified), num(o.length),
              o.solved ? "1" : "0", o.solved ? status_exact : status_timeout, "1", num(roadmap_s + o.query_ms / 1e3)});
  out << ".\n";
}

// Reads the log back with the rules of readBenchmarkLog() in ompl_benchmark_statistics.py:
// optional "<lib> version <v>", "Experiment <name>", "Running on <host>", "Starting at <date>",
// the <<<| setup |>>> block, an optional second block (cpu info), "<seed> ... random seed",
// "<t> seconds per run", "<m> MB per run", optional "<n> runs per planner", "<t> ... collect the
// data", optional "<n> enum types" and as many enum lines, "<n> planners"; per planner its name,
// "<n> common properties" and their lines, "<n> properties for each run" and their names (last
// token the SQL type), "<n> runs" lines of values each ended by "; ", then ".". Returns the
// problem, or "" when it parses and every run has one value per property.
std::string check_arena_log(const std::string& path) {
  std::ifstream in(path);
  std::string l;
  auto next = [&]() -> bool { return static_cast<bool>(std::getline(in, l)); };
  auto tokens = [&]() {
    std::istringstream s(l);
    std::vector<std::string> t;
    for (std::string w; s >> w;) t.push_back(w);
    return t;
  };
  auto ends = [&](const std::vector<std::string>& t, const std::vector<std::string>& tail) {
    if (t.size() < tail.size()) return false;
    return std::equal(tail.begin(), tail.end(), t.end() - tail.size());
  };
  if (!next()) return "empty";
  if (tokens().size() > 1 && tokens()[1] == "version" && !next()) return "ends after version";
  if (tokens().empty() || tokens()[0] != "Experiment") return "no Experiment line";
  if (!next() || tokens().empty() || tokens()[0] != "Running") return "no Running on line";
  if (!next() || l.rfind("Starting", 0) != 0) return "no Starting at line";
  for (int block = 0; block < 2; ++block) {
    const std::streampos mark = in.tellg();
    if (!next()) return "ends in the header";
    if (l.rfind("<<<|", 0) != 0) {
      if (block == 0) return "no <<<| setup block";
      in.seekg(mark);
      break;
    }
    while (next() && l.rfind("|>>>", 0) != 0) {
    }
    if (!in) return "unterminated <<<| block";
  }
  if (!next() || !ends(tokens(), {"random", "seed"})) return "no random seed line";
  if (!next() || !ends(tokens(), {"seconds", "per", "run"})) return "no seconds per run line";
  if (!next() || !ends(tokens(), {"MB", "per", "run"})) return "no MB per run line";
  if (!next()) return "ends early";
  if (ends(tokens(), {"runs", "per", "planner"}) && !next()) return "ends early";
  if (!ends(tokens(), {"collect", "the", "data"})) return "no total time line";
  if (!next()) return "ends early";
  if (tokens().size() >= 2 && tokens()[tokens().size() - 2] == "enum") {
    const int enums = std::stoi(tokens()[0]);
    for (int i = 0; i < enums; ++i)
      if (!next() || l.find('|') == std::string::npos) return "bad enum line";
    if (!next()) return "ends early";
  }
  if (!ends(tokens(), {"planners"})) return "no planner count";
  const int planners = std::stoi(tokens()[0]);
  for (int p = 0; p < planners; ++p) {
    if (!next() || l.empty()) return "no planner name";
    if (!next()) return "no common properties";
    const int common = std::stoi(tokens()[0]);
    for (int i = 0; i < common; ++i)
      if (!next()) return "short common properties";
    if (!next() || !ends(tokens(), {"properties", "for", "each", "run"})) return "no property count";
    const int properties = std::stoi(tokens()[0]);
    for (int i = 0; i < properties; ++i) {
      if (!next() || tokens().size() < 2) return "bad property line: " + l;
      const std::string type = tokens().back();
      if (type != "REAL" && type != "INTEGER" && type != "BOOLEAN" && type != "ENUM") return "bad type: " + l;
    }
    if (!next() || !ends(tokens(), {"runs"})) return "no run count";
    const int runs = std::stoi(tokens()[0]);
    for (int r = 0; r < runs; ++r) {
      if (!next()) return "missing run";
      size_t fields = 0;
      for (size_t at = 0; (at = l.find("; ", at)) != std::string::npos; at += 2) ++fields;
      if (static_cast<int>(fields) != properties) return "run with " + std::to_string(fields) + " values: " + l;
    }
    if (!next() || l != ".") return "no . after the runs";
  }
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1) repetitions = std::max(5, std::atoi(argv[1]));
  ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  // OMPL's nearest-neighbour structure (GNAT) picks its pivots at random: with a fixed seed
  // its runs are the same from one benchmark to the next (seeds 1 to 4 gave the same times).
  ompl::RNG::setSeed(1);
  const auto begin = std::chrono::steady_clock::now();
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  std::printf("dsmplan PRM vs OMPL %s PRM (%s); %s, %u cores, load %s\n", OMPL_VERSION_STRING, nn_name(kFairestNN),
              cpu_model().c_str(), cores, load_average().c_str());
  std::printf("PlanOptions defaults: safety %.1f m, spacing %.0f m, max_edge %.1f m, max_agl %.0f m\n\n",
              plan_options.safety, plan_options.spacing, plan_options.max_edge, plan_options.max_agl);

  std::vector<MeshRow> rows;
  {
    const Mesh mesh = triangulate_xy3(read_raster(tile));
    rows.push_back(run_mesh("NRW 1 m", 1.0, mesh));
  }
  {
    const auto start = std::chrono::steady_clock::now();
    const Grid grid = resampled_tile(0.64);
    const Mesh mesh = triangulate_xy3(grid);
    std::printf("0.64 m: real tile resampled by GDALWarp (bilinear) to %d x %d cells, meshed in %.1f s\n", grid.width,
                grid.height, seconds_since(start));
    rows.push_back(run_mesh("NRW 0.64 m", 0.64, mesh));
  }

  std::printf(
      "\nRoadmap: median (min-max) of %d paired, interleaved rounds (dsmplan, OMPL + ClearanceIndex, OMPL + Embree, "
      "dsmplan, ...); the ratio is OMPL / dsmplan per round. dsmplan with TBB on %u cores; OMPL's PRM adds milestones "
      "on one thread.\n"
      "Query: dsmplan median of %d; OMPL one run (its query milestones stay in its graph).\n"
      "Query: 4 waypoints 30 m above ground, 3 legs; dsmplan = query_roadmap (validate, connect, A*, shortcut, "
      "spline); OMPL = validate, addMilestone both ends, constructSolution per leg.\n"
      "Length: dsmplan smoothed (raw A*) / OMPL raw (after simplifyMax); ratios dsmplan/OMPL.\n\n",
      repetitions, cores, repetitions);
  for (const MeshRow& r : rows) {
    std::printf("%s: load average at each round's start:", r.name.c_str());
    for (const std::string& l : r.loads) std::printf(" %s", l.c_str());
    std::printf("\n");
  }
  std::printf(
      "\n| mesh | OMPL checker | samples | edges dsmplan / OMPL | roadmap s dsmplan | OMPL | ratio OMPL/dsmplan | "
      "query ms dsmplan | OMPL | length m dsmplan (raw) | OMPL raw (simplified) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  bool consistent = true;
  for (const MeshRow& r : rows) {
    consistent = consistent && r.same_nodes && r.solved;
    for (const OmplRun& o : r.ompl) {
      consistent = consistent && o.same_candidates && o.same_edges && o.samples == r.samples && o.solved;
      std::printf("| %s (%s tri) | %s | %s | %s / %s%s | %s | %s | %sx | %s | %.2f | %.0f (%.0f) | %.0f (%.0f) |\n",
                  r.name.c_str(), grouped(r.triangles).c_str(), o.checker.c_str(), grouped(r.samples).c_str(),
                  grouped(r.edges).c_str(), grouped(o.edges).c_str(), o.same_edges ? " (same)" : " (DIFFER)",
                  spread(r.roadmap_s, 3).c_str(), spread(o.roadmap_s, 3).c_str(),
                  spread(ratios(o.roadmap_s, r.roadmap_s), 1).c_str(), spread(r.query_ms, 2).c_str(), o.query_ms,
                  r.length, r.raw_length, o.length, o.simplified);
    }
  }
  for (const MeshRow& r : rows)
    for (const OmplRun& o : r.ompl)
      std::printf("%s, %s: OMPL simplifyMax %.1f ms\n", r.name.c_str(), o.checker.c_str(), o.simplify_ms);

  const std::string log = DSMPLAN_OUT_DIR "/plan_ompl.log";
  write_arena_log(log, rows, seconds_since(begin));
  std::string problem = check_arena_log(log);
  std::printf("\nPlanner Arena log: %s (%s)\n", log.c_str(),
              problem.empty() ? "re-read with ompl_benchmark_statistics.py's rules: OK" : problem.c_str());
  // Debian's ompl-demos installs OMPL's own reader as /usr/bin/ompl_benchmark_statistics: when
  // it is there, let it turn the log into an SQLite database too.
  if (std::system("command -v ompl_benchmark_statistics >/dev/null 2>&1") == 0) {
    const std::string db = DSMPLAN_OUT_DIR "/plan_ompl.db";
    std::filesystem::remove(db);
    const int rc = std::system(("ompl_benchmark_statistics '" + log + "' -d '" + db + "' >/dev/null 2>&1").c_str());
    std::printf("ompl_benchmark_statistics -> %s: %s\n", db.c_str(), rc == 0 ? "OK" : "FAILED");
    if (rc != 0) problem = "ompl_benchmark_statistics failed";
  } else {
    std::printf("(ompl_benchmark_statistics, from Debian's ompl-demos, not installed: only the built-in check)\n");
  }

  // Bars on the 0.64 m mesh, against the checker with the lower median roadmap time.
  const MeshRow& big = rows.back();
  const OmplRun* fastest = nullptr;
  for (const OmplRun& o : big.ompl)
    if (o.same_edges && (!fastest || median(o.roadmap_s) < median(fastest->roadmap_s))) fastest = &o;
  const std::vector<double> speedup = fastest ? ratios(fastest->roadmap_s, big.roadmap_s) : std::vector<double>{0};
  const bool bar_roadmap = consistent && fastest && median(speedup) >= 5;
  const bool bar_query = big.solved && median(big.query_ms) <= 10;
  // Where OMPL's time goes, for comparison with dsmplan's phases printed above.
  if (fastest) {
    const Profile& p = fastest->profile;
    const double checks = p.valid_s + p.motion_s, share = checks / p.total_s;
    std::printf(
        "\n0.64 m, OMPL + %s: %.0f %% of its roadmap time (%.3f s of %.3f s in the run with timers) are exact "
        "checks (%.3f s validity, %.3f s segments); dsmplan on 1 thread %s s, on %u %s s (load %s)\n",
        fastest->checker.c_str(), 100 * share, checks, p.total_s, p.valid_s, p.motion_s,
        spread(big.roadmap1_s, 3).c_str(), cores, spread(big.roadmap_s, 3).c_str(), load_average().c_str());
  }
  std::printf("\nsame samples and edges everywhere, every query solved: %s\n", consistent ? "yes" : "NO");
  std::printf(
      "bar 1, 0.64 m: dsmplan roadmap %s s vs OMPL PRM (%s) %s s = %sx, median (min-max) of paired rounds "
      "(>= 5x): %s\n",
      spread(big.roadmap_s, 3).c_str(), fastest ? fastest->checker.c_str() : "none",
      fastest ? spread(fastest->roadmap_s, 3).c_str() : "-", spread(speedup, 1).c_str(), bar_roadmap ? "PASS" : "FAIL");
  std::printf("bar 2, 0.64 m: dsmplan 3-leg query %s ms (<= 10 ms): %s\n", spread(big.query_ms, 2).c_str(),
              bar_query ? "PASS" : "FAIL");
  std::printf("total %.0f s\n", seconds_since(begin));
  return bar_roadmap && bar_query && problem.empty() ? 0 : 1;
}
