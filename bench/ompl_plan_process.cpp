// bench_ompl_plan: what `dsmplan plan MESH --waypoints WP.csv --max-agl H -o PATH.csv` does, done with
// OMPL 1.5's geometric::PRM and an Embree 3 BVH as the exact checker: the whole-process baseline of
// bench/plan_process.sh (issue 19, point 2).
//
//   bench_ompl_plan MESH.ply --waypoints WP.csv -o PATH.csv [--max-agl H] [--checker embree|index]
//                   [--nn GNAT|GNATNoThreadSafety|SqrtApprox|Linear] [--quality low|medium|high]
//   bench_ompl_plan --make-waypoints MESH.ply HEIGHT WP.csv   (setup: the 4 waypoints of bench_plan_ompl)
//   bench_ompl_plan --resample DSM CELL OUT.tif               (setup: GDALWarp bilinear, as bench_plan_ompl)
//
// Sources: the OMPL 1.5 API (/usr/include/ompl-1.5: geometric/planners/prm/PRM.h,
// geometric/PathSimplifier.h, util/RandomNumbers.h) and the Embree 3.13 API manual, as cited in
// bench/ompl_baseline.hpp, which holds everything this shares with bench/plan_ompl.cpp.
//
// The process, in dsmplan plan's order: the waypoints (dsmplan's CSV reader), the mesh (dsmplan's
// PLY reader: generous to the baseline, it is the fast one), the Embree BVH (Embree builds it on
// every core through TBB), the mesh's floor the ceiling counts from (dsmplan's
// GroundGrid::floor_of(): part of the problem's definition), build_roadmap()'s Halton candidates
// with the surface height from an Embree ray cast, PRM given the candidates (addMilestone; every
// earlier milestone closer than max_edge through OMPL's nearestR, each pair through the exact
// motion validator, as dsmplan's edges), then per leg the two waypoints as milestones and
// constructSolution() (A* over PRM's graph), PathSimplifier::simplifyMax on each leg, the path
// written as CSV (dsmplan's path_to_csv). PlanOptions are dsmplan plan's defaults (safety 2 m,
// spacing 20 m, max_edge 34.5 m) with --max-agl. Printed: samples, edges, legs solved, length
// and the seconds of each phase, as one line of key=value pairs.
//
// Choices, measured with bench/plan_process.sh's meshes (bench/README.md, "Planning as a whole
// process"): the nearest-neighbour structure is the fastest of the four OMPL offers PRM (see
// kFairestNN in ompl_baseline.hpp); Embree's build quality is RTC_BUILD_QUALITY_LOW (a Morton-code
// build): the roadmap over its BVH is slower than over the default's (medium), but it is built
// 2-3 times as fast (1 m: 0.35 s against 0.56-0.78 s; 0.64 m: 0.58-0.82 s against 1.7-2.0 s,
// on the loaded machine), so the whole process is faster (0.64 m: 1.4-1.7 s against 2.5-3.0 s
// wall); --quality medium|high to compare. --checker index gives OMPL dsmplan's ClearanceIndex
// instead (ground, clearance and floor from it), for comparison; with --index-file F it opens the
// index dsmplan plan --index keeps (and keeps it, when F is missing), so OMPL too skips reading
// the mesh and building its checker: the fair comparison for dsmplan with a kept index.
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/mapped_file.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/roadmap_file.hpp"
#include "dsmplan/waypoints.hpp"
#include "ompl_baseline.hpp"

using namespace bench::baseline;

namespace {

double seconds(Clock::time_point& t) {
  const auto now = Clock::now();
  const double s = std::chrono::duration<double>(now - t).count();
  t = now;
  return s;
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_ompl_plan MESH.ply --waypoints WP.csv -o PATH.csv [--max-agl H] [--checker embree|index] "
               "[--index-file F] "
               "[--nn GNAT|GNATNoThreadSafety|SqrtApprox|Linear] [--quality low|medium|high]\n"
               "       bench_ompl_plan --make-waypoints MESH.ply HEIGHT WP.csv\n"
               "       bench_ompl_plan --resample DSM CELL OUT.tif\n");
  return 2;
}

int run(int argc, char** argv) {
  if (argc == 5 && std::string(argv[1]) == "--resample") {
    warp_bilinear(argv[2], std::atof(argv[3]), argv[4]);
    return 0;
  }
  if (argc == 5 && std::string(argv[1]) == "--make-waypoints") {
    const ClearanceIndex index(dsmplan::read_mesh(argv[2]));
    const std::vector<Point3> waypoints = make_waypoints(index, std::atof(argv[3]), PlanOptions{}.safety);
    dsmplan::write_text_file(argv[4], dsmplan::path_to_csv(waypoints));
    return 0;
  }
  std::string mesh_path, waypoints_path, output, checker_name = "embree", nn = nn_name(kFairestNN), quality = "low";
  std::string index_file;
  PlanOptions options;  // dsmplan plan's defaults
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--waypoints")
      waypoints_path = value();
    else if (a == "-o")
      output = value();
    else if (a == "--max-agl")
      options.max_agl = std::stod(value());
    else if (a == "--checker")
      checker_name = value();
    else if (a == "--nn")
      nn = value();
    else if (a == "--quality")
      quality = value();
    else if (a == "--index-file")
      index_file = value();
    else if (mesh_path.empty() && a[0] != '-')
      mesh_path = a;
    else
      return usage();
  }
  if (mesh_path.empty() || waypoints_path.empty() || output.empty() ||
      (checker_name != "embree" && checker_name != "index") || (!index_file.empty() && checker_name != "index"))
    return usage();
  const NN structure = nn_named(nn);
  ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  ompl::RNG::setSeed(1);  // GNAT's pivots and PathSimplifier's shortcuts: the same run every time

  auto clock = Clock::now();
  const std::vector<Point3> waypoints = dsmplan::read_waypoints_csv(waypoints_path);
  // --index-file: dsmplan plan --index's file, opened as dsmplan opens it (named by the mesh file's
  // hash), so that OMPL too skips reading the mesh and building the index; built and saved when
  // it is missing or stale.
  std::optional<ClearanceIndex> kept;
  if (!index_file.empty() && std::filesystem::exists(index_file))
    kept = ClearanceIndex::open(index_file, dsmplan::file_content_hash(mesh_path));
  const Mesh mesh = kept ? Mesh{} : dsmplan::read_mesh(mesh_path);
  const double read_s = seconds(clock);
  const ClearanceIndex::Footprint footprint = kept ? kept->footprint() : footprint_of(mesh);
  double zmin = INFINITY, zmax = -INFINITY;
  for (const dsmplan::Vertex& v : mesh.vertices) zmin = std::min(zmin, v.z), zmax = std::max(zmax, v.z);
  if (kept) zmin = kept->lowest_vertex(), zmax = kept->highest_vertex();
  double bvh_s = 0;  // of index_s: Embree's BVH (the rest: the floor)
  std::unique_ptr<ClearanceIndex> index;
  std::unique_ptr<Checker> checker;
  GroundGrid own_floor;
  const GroundGrid* floor = &own_floor;
  if (checker_name == "index") {
    index = std::make_unique<ClearanceIndex>(kept ? *kept : ClearanceIndex(mesh));
    if (!index_file.empty() && !kept)
      index->save(index_file, {dsmplan::file_content_hash(mesh_path), dsmplan::mesh_fingerprint(mesh)});
    checker = std::make_unique<IndexChecker>(*index, options.safety);
    floor = &index->floor();
  } else {
#ifdef DSMPLAN_HAVE_EMBREE
    const RTCBuildQuality q = quality == "low"    ? RTC_BUILD_QUALITY_LOW
                              : quality == "high" ? RTC_BUILD_QUALITY_HIGH
                                                  : RTC_BUILD_QUALITY_MEDIUM;
    checker = std::make_unique<EmbreeChecker>(mesh, origin_of(mesh), options.safety, q);
    bvh_s = seconds(clock);
    own_floor = floor_of(mesh);
#else
    throw std::runtime_error("built without Embree 3: only --checker index");
#endif
  }
  const double index_s = bvh_s + seconds(clock);

  Profile profile;
  const ob::SpaceInformationPtr si = make_space(footprint, zmin, zmax, *checker, *floor, options.max_agl, profile);
  GivenSamplesPRM prm(si, options.max_edge, profile, structure);
  prm.setProblemDefinition(std::make_shared<ob::ProblemDefinition>(si));  // its path-length objective
  prm.setup();
  add_candidates(si, prm, halton_candidates(footprint, *checker, *floor, options));
  const size_t samples = prm.milestoneCount(), edges = prm.edgeCount();
  const double roadmap_s = seconds(clock);

  // The legs, each waypoint validated first (as PRM::solve()'s input states are).
  ob::State* a = si->allocState();
  ob::State* b = si->allocState();
  std::vector<og::PathGeometric> legs;
  size_t solved = 0;
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) {
    set_state(a, waypoints[i]);
    set_state(b, waypoints[i + 1]);
    if (!si->isValid(a) || !si->isValid(b)) continue;
    if (auto path = prm.leg(a, b)) legs.push_back(*path), ++solved;
  }
  si->freeState(a);
  si->freeState(b);
  const double query_s = seconds(clock);
  og::PathSimplifier simplifier(si);
  std::vector<Point3> path;
  double length = 0;
  for (og::PathGeometric& leg : legs) {
    simplifier.simplifyMax(leg);
    length += leg.length();
    for (size_t k = path.empty() ? 0 : 1; k < leg.getStateCount(); ++k) path.push_back(to_point(leg.getState(k)));
  }
  const double simplify_s = seconds(clock);
  const bool all = solved + 1 == waypoints.size();
  if (all) dsmplan::write_text_file(output, dsmplan::path_to_csv(path));
  const double write_s = seconds(clock);
  std::printf(
      "checker=%s nn=%s samples=%zu edges=%zu legs=%zu solved=%zu length=%.1f points=%zu read_s=%.3f index_s=%.3f "
      "bvh_s=%.3f roadmap_s=%.3f query_s=%.4f simplify_s=%.4f write_s=%.4f\n",
      checker_name.c_str(), nn_name(structure), samples, edges, waypoints.size() - 1, solved, length, path.size(),
      read_s, index_s, bvh_s, roadmap_s, query_s, simplify_s, write_s);
  return all ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_ompl_plan: %s\n", e.what());
    return 2;
  }
}
