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
//     30 m above ground (3 legs); best of 5 repetitions each (argv[1] sets another count). The
//     timed roadmaps alternate with OMPL's (ClearanceIndex checker), one of each in turn, so
//     that both see the shared machine in the same state: its speed drifts by tens of percent
//     over seconds, which one block of runs after the other turned into ratios from 2.9x to 5x.
//   - OMPL: RealVectorStateSpace(3) bounded by the footprint and [lowest vertex, highest vertex
//     + max_agl]; an exact StateValidityChecker and MotionValidator; a PRM subclass that is
//     given every Halton candidate build_roadmap() draws (same function, re-implemented here
//     and checked equal to Roadmap::nodes), checks its validity through OMPL's
//     SpaceInformation and adds the valid ones with OMPL's addMilestone(), whose connection
//     strategy returns every earlier milestone closer than max_edge (nearestR of OMPL's default
//     nearest-neighbour structure). Its roadmap is compared with dsmplan's edge for edge.
//     Query per leg: the two waypoints validated and added by addMilestone(), then
//     constructSolution() (OMPL's boost::astar_search over its graph) when they share a
//     component; that is what PRM::solve() does on an existing roadmap, without its thread that
//     keeps growing the roadmap with random samples while it looks for a solution. One run
//     (the query milestones stay in the graph). Then PathSimplifier::simplifyMax.
//   - Two exact checkers for OMPL: (i) dsmplan's ClearanceIndex (segment_clear), (ii) an Embree
//     3 BVH over the triangles, queried by spheres covering the capsule of the segment, each
//     candidate measured with dsmplan::segment_triangle_distance (exact). (ii) is exact: it
//     must give the same edges as (i), which the bench checks.
// Bars (exit code 0 only when both pass), on the 0.64 m mesh: dsmplan's roadmap >= 5x faster
// than OMPL's PRM with the faster exact checker, at equal samples and edges; dsmplan's 3-leg
// query <= 10 ms. Results also go to out/bench/plan_ompl.log in OMPL's benchmark log format.
//
// Measured (2-core AMD EPYC VM, load about 1.3, best of 5 alternating; every OMPL roadmap had
// dsmplan's samples and edges, every query solved; three runs gave 5.5x, 5.6x and 5.5x):
//   mesh     OMPL checker     roadmap s dsmplan / OMPL   query ms dsmplan / OMPL
//   1 m      ClearanceIndex   0.020 / 0.12  (5.9x)       2.3 / 7.9
//   1 m      Embree 3         0.020 / 0.19  (9.6x)       2.3 / 6.8
//   0.64 m   ClearanceIndex   0.022 / 0.12  (5.5x)       2.2 / 6.7
//   0.64 m   Embree 3         0.022 / 0.23  (10.4x)      2.2 / 7.0
// Both bars pass. dsmplan's roadmap proves 83 % of the candidate pairs clear from its samples'
// clearance bounds without an exact check (plan.hpp, "Edges"); OMPL checks every pair with the
// same checker. Every speed-up of the checker (the index's blocks and triangle balls) speeds
// OMPL's side as much: it took OMPL from 0.20 s to 0.12 s here. What is left of dsmplan's time
// is the uncertified checks near the ground and roofs (about half), the sampling (ground(),
// batched with prefetching, about a quarter) and the pairs; the printed phase times below re-do
// the phases without the certificates, on one thread, for comparison with OMPL's profile.
#include <gdal_utils.h>
#include <ompl/base/MotionValidator.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/StateValidityChecker.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/prm/PRM.h>
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

#ifdef DSMPLAN_HAVE_EMBREE
#include <embree3/rtcore.h>
#endif

#include "bench_kit.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "plan/prm_parts.hpp"

using namespace dsmplan;
using namespace bench;
namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace {

const PlanOptions plan_options{};  // the CLI's defaults: safety 2, spacing 20, max_edge 34.5, max_agl 120
int repetitions = 5;               // best of: argv[1], 5 by default

// ---- the samples: build_roadmap()'s Halton candidates, re-generated ----------------------

// The roadmap's own Halton sequence (src/plan/prm_parts.hpp); run_mesh() checks the kept
// candidates equal Roadmap::nodes bit for bit.
using detail::halton;

// Every candidate build_roadmap() draws, before dropping; NaN z where no triangle covers (x, y).
std::vector<Point3> halton_candidates(const ClearanceIndex& index, const PlanOptions& o) {
  const ClearanceIndex::Footprint& e = index.footprint();
  const double wx = e.xmax - e.xmin, wy = e.ymax - e.ymin;
  const auto n = static_cast<size_t>(std::round(wx * wy * o.max_agl / std::pow(o.spacing, 3)));
  std::vector<Point3> out(n);
  for (size_t i = 0; i < n; ++i) {
    const double x = e.xmin + halton(i + 1, 2) * wx, y = e.ymin + halton(i + 1, 3) * wy;
    // From the surface to the ceiling over the mesh's floor, as build_roadmap() places them.
    const double g = index.ground(x, y), top = o.max_agl - index.floor().height_above({x, y, 0});
    out[i] = {x, y, std::isnan(g) || !(top > g) ? NAN : g + halton(i + 1, 5) * (top - g)};
  }
  return out;
}

// ---- exact checkers ------------------------------------------------------------------------

// What OMPL's validity checker and motion validator ask; both implementations are exact.
class Checker {
public:
  virtual ~Checker() = default;
  virtual const char* name() const = 0;
  virtual bool segment_clear(const Point3& p, const Point3& q) const = 0;
  bool point_clear(const Point3& p) const { return segment_clear(p, p); }
};

class IndexChecker : public Checker {
public:
  explicit IndexChecker(const ClearanceIndex& index) : index_(index) {}
  const char* name() const override { return "ClearanceIndex"; }
  bool segment_clear(const Point3& p, const Point3& q) const override {
    return index_.segment_clear(p, q, plan_options.safety);
  }

private:
  const ClearanceIndex& index_;
};

#ifdef DSMPLAN_HAVE_EMBREE
// Embree 3 BVH (float triangles in the index's local frame) as a broad phase, the exact
// segment-triangle distance in doubles as the narrow phase. Embree's point query visits every
// primitive whose bounds meet a sphere; a capsule (segment grown by d) is covered by k spheres
// centred on k equal pieces of the segment, radius = half a piece + d: a point within d of
// the segment is within d of its closest segment point, which is within half a piece of a
// piece's centre. The radius gets a margin (1 cm) for the floats of the BVH, far above their
// rounding at a few hundred metres, so no triangle within d can be missed. A triangle is then
// decided as ClearanceIndex decides (sqrt of the exact squared distance < d: blocked), so both
// checkers must agree on every query; the bench checks it on every roadmap edge.
class EmbreeChecker : public Checker {
public:
  EmbreeChecker(const Mesh& mesh, const Point3& origin) : origin_(origin) {
    device_ = rtcNewDevice(nullptr);
    scene_ = rtcNewScene(device_);
    // Default (medium) build quality: HIGH took 2.5x longer to build (4.8 s vs 1.9 s at 1 m) and
    // answered point queries no faster (5.6 us each, measured apart).
    RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), mesh.vertices.size()));
    auto* t = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(uint32_t), mesh.triangles.size()));
    local_.resize(mesh.vertices.size());
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
      const Vertex& x = mesh.vertices[i];
      local_[i] = {x.x - origin[0], x.y - origin[1], x.z - origin[2]};
      for (int k = 0; k < 3; ++k) v[3 * i + k] = static_cast<float>(local_[i][k]);
    }
    tris_ = mesh.triangles;
    for (size_t i = 0; i < tris_.size(); ++i)
      for (int k = 0; k < 3; ++k) t[3 * i + k] = tris_[i][k];
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene_);
  }
  ~EmbreeChecker() override {
    rtcReleaseScene(scene_);
    rtcReleaseDevice(device_);
  }
  EmbreeChecker(const EmbreeChecker&) = delete;
  EmbreeChecker& operator=(const EmbreeChecker&) = delete;

  const char* name() const override { return "Embree 3"; }

  bool segment_clear(const Point3& pw, const Point3& qw) const override {
    const double d = plan_options.safety;
    Query query{this,
                {pw[0] - origin_[0], pw[1] - origin_[1], pw[2] - origin_[2]},
                {qw[0] - origin_[0], qw[1] - origin_[1], qw[2] - origin_[2]},
                d,
                false};
    const Point3 &p = query.p, &q = query.q;
    const double length =
        std::sqrt((q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) + (q[2] - p[2]) * (q[2] - p[2]));
    // Pieces of about 2d: fewer spheres cost more traversals, longer ones a fatter cover.
    const int pieces = std::max(1, static_cast<int>(std::ceil(length / (2 * d))));
    const double radius = length / (2 * pieces) + d + 0.01;
    for (int i = 0; i < pieces && !query.blocked; ++i) {
      const double s = (i + 0.5) / pieces;
      RTCPointQuery sphere;
      sphere.x = static_cast<float>(p[0] + s * (q[0] - p[0]));
      sphere.y = static_cast<float>(p[1] + s * (q[1] - p[1]));
      sphere.z = static_cast<float>(p[2] + s * (q[2] - p[2]));
      sphere.time = 0;
      sphere.radius = static_cast<float>(radius);
      RTCPointQueryContext context;
      rtcInitPointQueryContext(&context);
      rtcPointQuery(scene_, &sphere, &context, &EmbreeChecker::visit, &query);
    }
    return !query.blocked;
  }

private:
  struct Query {
    const EmbreeChecker* self;
    Point3 p, q;
    double d;
    bool blocked;
  };
  static bool visit(RTCPointQueryFunctionArguments* args) {
    auto* query = static_cast<Query*>(args->userPtr);
    if (query->blocked) return false;
    const auto& t = query->self->tris_[args->primID];
    const auto& v = query->self->local_;
    if (std::sqrt(segment_triangle_squared_distance(query->p, query->q, v[t[0]], v[t[1]], v[t[2]])) < query->d) {
      query->blocked = true;
      args->query->radius = 0;  // nothing more to learn: shrink the sphere so traversal ends
      return true;
    }
    return false;
  }

  Point3 origin_;
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<Point3> local_;
  std::vector<Triangle> tris_;
};
#endif

// ---- OMPL glue -----------------------------------------------------------------------------

// Where OMPL's roadmap time goes (the profile of the bar): wall time inside the validity
// checker, the motion validator and the nearest-neighbour search. Only in a run of its own
// (`on`), so the timed runs carry no clock reads (about 20 ns each, 300,000 a roadmap).
struct Profile {
  bool on = false;
  double valid_s = 0, motion_s = 0, near_s = 0, total_s = 0;
  size_t motions = 0;
};
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

Point3 to_point(const ob::State* s) {
  const auto* r = s->as<ob::RealVectorStateSpace::StateType>();
  return {r->values[0], r->values[1], r->values[2]};
}

// A state is valid where dsmplan's planner would accept it: over a triangle, not under the
// surface, and at least `safety` from the mesh. The height of the surface comes from
// ClearanceIndex::ground() with either checker (it is the flight volume, not a collision test),
// as build_roadmap() takes it.
class Validity : public ob::StateValidityChecker {
public:
  Validity(const ob::SpaceInformationPtr& si, const ClearanceIndex& index, const Checker& checker, Profile& profile)
      : ob::StateValidityChecker(si), index_(index), checker_(checker), profile_(profile) {}
  bool isValid(const ob::State* s) const override {
    const auto start = profile_.on ? Clock::now() : Clock::time_point{};
    const Point3 p = to_point(s);
    const double g = index_.ground(p[0], p[1]);
    const bool ok = !std::isnan(g) && p[2] >= g && index_.floor().height_above(p) <= plan_options.max_agl &&
                    checker_.point_clear(p);
    if (profile_.on) profile_.valid_s += since(start);
    return ok;
  }

private:
  const ClearanceIndex& index_;
  const Checker& checker_;
  Profile& profile_;
};

// Exact: the whole straight motion, not states along it at a resolution.
class Motion : public ob::MotionValidator {
public:
  Motion(const ob::SpaceInformationPtr& si, const ClearanceIndex& index, const Checker& checker, Profile& profile)
      : ob::MotionValidator(si), index_(index), checker_(checker), profile_(profile) {}
  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const auto start = profile_.on ? Clock::now() : Clock::time_point{};
    // The ceiling over the whole motion, as dsmplan's roadmap keeps it (plan.hpp, FlightSpace).
    const bool ok = index_.floor().below_ceiling(to_point(s1), to_point(s2), plan_options.max_agl) &&
                    checker_.segment_clear(to_point(s1), to_point(s2));
    if (profile_.on) profile_.motion_s += since(start), ++profile_.motions;
    (ok ? valid_ : invalid_)++;
    return ok;
  }
  // PRM never asks for the last valid state; answering the start (fraction 0) is conservative.
  bool checkMotion(const ob::State* s1, const ob::State* s2, std::pair<ob::State*, double>& last) const override {
    if (checkMotion(s1, s2)) return true;
    if (last.first) si_->copyState(last.first, s1);
    last.second = 0;
    return false;
  }

private:
  const ClearanceIndex& index_;
  const Checker& checker_;
  Profile& profile_;
};

// OMPL's PRM fed with given samples: addMilestone() (protected) connects each to every earlier
// milestone closer than max_edge, through OMPL's nearest-neighbour structure and its motion
// validator; queries use addMilestone() and constructSolution() as PRM::solve() does.
class GivenSamplesPRM : public og::PRM {
public:
  GivenSamplesPRM(const ob::SpaceInformationPtr& si, Profile& profile) : og::PRM(si), profile_(profile) {
    const double reach = plan_options.max_edge, reach2 = reach * reach;
    // nearestR's radius is a little larger, then dsmplan's own test (squared distance strictly
    // below max_edge^2, same doubles) decides, so the candidate pairs are the same to the bit.
    setConnectionStrategy([this, reach, reach2](const Vertex v) -> const std::vector<Vertex>& {
      const auto start = profile_.on ? Clock::now() : Clock::time_point{};
      nn_->nearestR(v, reach * (1 + 1e-9), found_);
      if (profile_.on) profile_.near_s += since(start);
      const Point3 p = to_point(stateProperty_[v]);
      neighbours_.clear();
      for (Vertex u : found_) {
        if (u == v) continue;
        const Point3 q = to_point(stateProperty_[u]);
        const double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        if (dx * dx + dy * dy + dz * dz < reach2) neighbours_.push_back(u);
      }
      return neighbours_;
    });
  }

  Vertex add(const ob::State* s) { return addMilestone(si_->cloneState(s)); }

  // One leg: nullptr when there is no roadmap path between the two states.
  std::shared_ptr<og::PathGeometric> leg(const ob::State* a, const ob::State* b) {
    const Vertex s = add(a), g = add(b);
    if (!sameComponent(s, g)) return nullptr;
    return std::static_pointer_cast<og::PathGeometric>(constructSolution(s, g));
  }

private:
  Profile& profile_;
  std::vector<Vertex> found_, neighbours_;
};

// ---- measurements --------------------------------------------------------------------------

struct OmplRun {
  std::string checker;
  size_t samples = 0, edges = 0;
  bool same_edges = false;  // OMPL's edge set equals dsmplan's
  double roadmap_s = 0, query_ms = 0, simplify_ms = 0;
  double length = NAN, simplified = NAN;
  bool solved = false;
  Profile profile;                          // of the fastest roadmap
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
  std::vector<double> roadmap_s, query_ms;  // every repetition
  double roadmap1_s = INFINITY;             // best on one thread, for the profile
  // build_roadmap's phases re-done here on one thread (profile): Halton candidates with ground()
  // and point_clear(); the candidate pairs from its grid of max_edge cells; segment_clear() on them.
  double sample_s = 0, ground_s = 0, pairs_s = 0, checks_s = 0;  // ground_s: Halton + ground() part
  size_t pairs = 0;
  double length = NAN, raw_length = NAN;
  bool solved = false;
  std::vector<OmplRun> ompl;
};

double best(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

// 4 waypoints (3 legs) ~30 m above the ground near the corners and the middle of the tile,
// raised 5 m at a time until clear.
std::vector<Point3> make_waypoints(const ClearanceIndex& index) {
  const ClearanceIndex::Footprint& e = index.footprint();
  const double fractions[4][2] = {{0.1, 0.1}, {0.9, 0.2}, {0.55, 0.5}, {0.15, 0.9}};
  std::vector<Point3> out;
  for (const auto& f : fractions) {
    const double x = e.xmin + f[0] * (e.xmax - e.xmin), y = e.ymin + f[1] * (e.ymax - e.ymin);
    Point3 p{x, y, index.ground(x, y) + 30};
    while (!index.point_clear(p, plan_options.safety)) p[2] += 5;
    out.push_back(p);
  }
  return out;
}

OmplRun run_ompl(const ClearanceIndex& index, const Mesh& mesh, const Checker& checker,
                 const std::vector<Point3>& candidates, const Roadmap& map, const std::vector<Point3>& waypoints,
                 const std::function<void()>& before_each_timed_run = {}) {
  OmplRun run;
  run.checker = checker.name();
  double zmin = INFINITY, zmax = -INFINITY;
  for (const Vertex& v : mesh.vertices) zmin = std::min(zmin, v.z), zmax = std::max(zmax, v.z);
  auto space = std::make_shared<ob::RealVectorStateSpace>(3);
  ob::RealVectorBounds bounds(3);
  const ClearanceIndex::Footprint& e = index.footprint();
  bounds.setLow(0, e.xmin), bounds.setHigh(0, e.xmax);
  bounds.setLow(1, e.ymin), bounds.setHigh(1, e.ymax);
  bounds.setLow(2, zmin), bounds.setHigh(2, zmax + plan_options.max_agl);
  space->setBounds(bounds);
  Profile profile;
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker(std::make_shared<Validity>(si, index, checker, profile));
  si->setMotionValidator(std::make_shared<Motion>(si, index, checker, profile));
  si->setup();
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);  // PRM takes its path-length objective from it

  ob::State* work = si->allocState();
  auto set = [&](ob::State* s, const Point3& p) {
    auto* r = s->as<ob::RealVectorStateSpace::StateType>();
    r->values[0] = p[0], r->values[1] = p[1], r->values[2] = p[2];
  };

  // The roadmap: every candidate through OMPL's validity check, the valid ones as milestones.
  // Best of as many as dsmplan, a fresh planner each time, then one more with the profile's
  // timers on; the last one answers the queries.
  std::shared_ptr<GivenSamplesPRM> prm;
  run.roadmap_s = INFINITY;
  for (int rep = 0; rep <= repetitions; ++rep) {
    prm.reset();
    profile = {};
    profile.on = rep == repetitions;
    prm = std::make_shared<GivenSamplesPRM>(si, profile);
    prm->setProblemDefinition(pdef);
    prm->setup();
    if (!profile.on && before_each_timed_run) before_each_timed_run();
    const auto start = Clock::now();
    for (const Point3& c : candidates) {
      if (std::isnan(c[2])) continue;  // no triangle under it (build_roadmap drops it the same way)
      set(work, c);
      if (si->isValid(work)) prm->add(work);
    }
    const double s = since(start);
    if (profile.on)
      run.profile = profile, run.profile.total_s = s;
    else
      run.roadmap_s = std::min(run.roadmap_s, s);
  }
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
  ob::State* other = si->allocState();
  std::vector<og::PathGeometric> legs;
  auto start = Clock::now();
  run.solved = true;
  for (size_t i = 0; i + 1 < waypoints.size() && run.solved; ++i) {
    set(work, waypoints[i]);
    set(other, waypoints[i + 1]);
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
  const size_t before = prm->milestoneCount();
  start = Clock::now();
  run.solve_solved = true;
  run.solve_length = 0;
  for (size_t i = 0; i + 1 < waypoints.size(); ++i) {
    set(work, waypoints[i]);
    set(other, waypoints[i + 1]);
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
  return run;
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

  // The roadmap, built once untimed (a warm-up, as OMPL's first run below is); the timed
  // builds alternate with OMPL's runs (time_dsmplan).
  const Roadmap map = build_roadmap(index, plan_options);
  auto time_dsmplan = [&] {
    const auto begin = std::chrono::steady_clock::now();
    const Roadmap built = build_roadmap(index, plan_options);
    row.roadmap_s.push_back(seconds_since(begin));
    if (built.neighbour != map.neighbour) std::printf("  build_roadmap gave another roadmap on a repetition\n");
  };
  row.samples = map.nodes.size(), row.edges = map.edges();
  PlanOptions one_thread = plan_options;
  one_thread.threads = 1;
  for (int rep = 0; rep < repetitions; ++rep) {
    start = std::chrono::steady_clock::now();
    const Roadmap built = build_roadmap(index, one_thread);
    row.roadmap1_s = std::min(row.roadmap1_s, seconds_since(start));
  }

  // The samples re-generated here (one thread), and checked equal to build_roadmap's.
  start = std::chrono::steady_clock::now();
  const std::vector<Point3> candidates = halton_candidates(index, plan_options);
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

  const std::vector<Point3> waypoints = make_waypoints(index);
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

  {
    const IndexChecker checker(index);
    row.ompl.push_back(run_ompl(index, mesh, checker, candidates, map, waypoints, time_dsmplan));
  }
#ifdef DSMPLAN_HAVE_EMBREE
  {
    start = std::chrono::steady_clock::now();
    const EmbreeChecker checker(mesh, index.origin());
    std::printf("  Embree BVH built in %.2f s\n", seconds_since(start));
    row.ompl.push_back(run_ompl(index, mesh, checker, candidates, map, waypoints));
  }
#endif
  std::printf(
      "  dsmplan build_roadmap: %.3f s on %u threads, %.3f s on 1; its phases re-done on 1 thread: samples %.3f s "
      "(Halton + ground() %.3f s, point_clear %.3f s), %s candidate pairs %.3f s, their segment_clear %.3f s\n",
      best(row.roadmap_s), std::max(1u, std::thread::hardware_concurrency()), row.roadmap1_s, row.sample_s,
      row.ground_s, row.sample_s - row.ground_s, grouped(row.pairs).c_str(), row.pairs_s, row.checks_s);
  for (const OmplRun& r : row.ompl) {
    const Profile& p = r.profile;
    std::printf(
        "  OMPL PRM + %s: %s milestones, %s edges, same edges as dsmplan: %s; roadmap %.3f s; a run with timers "
        "%.3f s = validity %.3f s + %s motions %.3f s + nearestR %.3f s + the rest (graph, clone, disjoint sets) "
        "%.3f s\n",
        r.checker.c_str(), grouped(r.samples).c_str(), grouped(r.edges).c_str(), r.same_edges ? "yes" : "NO",
        r.roadmap_s, p.total_s, p.valid_s, grouped(p.motions).c_str(), p.motion_s, p.near_s,
        p.total_s - p.valid_s - p.motion_s - p.near_s);
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
  GDALAllRegister();
  GDALDatasetH source = GDALOpen(tile.c_str(), GA_ReadOnly);
  if (!source) throw std::runtime_error("cannot open " + tile);
  double gt[6];
  GDALGetGeoTransform(source, gt);
  const int cells = static_cast<int>(std::floor(GDALGetRasterXSize(source) * gt[1] / cell));
  const double x0 = gt[0], y0 = gt[3], extent = cells * cell;
  auto text = [](double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.6f", v);
    return std::string(b);
  };
  std::vector<std::string> args = {"-of",
                                   "GTiff",
                                   "-r",
                                   "bilinear",
                                   "-ot",
                                   "Float32",
                                   "-tr",
                                   text(cell),
                                   text(cell),
                                   "-te",
                                   text(x0),
                                   text(y0 - extent),
                                   text(x0 + extent),
                                   text(y0)};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  GDALWarpAppOptions* options = GDALWarpAppOptionsNew(argv.data(), nullptr);
  const std::string path = "/vsimem/plan_ompl_resampled.tif";
  int error = 0;
  GDALDatasetH out = GDALWarp(path.c_str(), nullptr, 1, &source, options, &error);
  GDALWarpAppOptionsFree(options);
  if (!out || error) throw std::runtime_error("GDALWarp failed");
  GDALClose(out);
  GDALClose(source);
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
  for (const MeshRow& r : rows) runs += r.ompl.size();
  header("geometric_PRM", "implementation = ompl::geometric::PRM, given samples, nearestR(max_edge) connection", runs);
  for (const MeshRow& r : rows)
    for (const OmplRun& o : r.ompl)
      line({o.checker == "Embree 3" ? "1" : "0", std::to_string(o.edges), std::to_string(o.samples), num(r.cell),
            std::to_string(r.triangles), num(o.query_ms / 1e3), num(o.roadmap_s), num(o.simplified), num(o.length),
            o.solved ? "1" : "0", o.solved ? status_exact : status_timeout, "1", num(o.roadmap_s + o.query_ms / 1e3)});
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
  if (argc > 1) repetitions = std::max(1, std::atoi(argv[1]));
  ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  // OMPL's nearest-neighbour structure (GNAT) picks its pivots at random: with a fixed seed
  // its runs are the same from one benchmark to the next (seeds 1 to 4 gave the same times).
  ompl::RNG::setSeed(1);
  const auto begin = std::chrono::steady_clock::now();
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  std::printf("dsmplan PRM vs OMPL %s PRM; %s, %u cores, load %s\n", OMPL_VERSION_STRING, cpu_model().c_str(), cores,
              load_average().c_str());
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
      "\nRoadmap: best of %d for both, dsmplan's runs alternating with OMPL's (ClearanceIndex) runs (dsmplan with TBB "
      "on %u cores; OMPL's PRM adds milestones on one thread).\n"
      "Query: dsmplan best of %d; OMPL one run (its query milestones stay in its graph).\n"
      "Query: 4 waypoints 30 m above ground, 3 legs; dsmplan = query_roadmap (validate, connect, A*, shortcut, "
      "spline); OMPL = validate, addMilestone both ends, constructSolution per leg.\n"
      "Length: dsmplan smoothed (raw A*) / OMPL raw (after simplifyMax); ratios dsmplan/OMPL.\n\n",
      repetitions, cores, repetitions);
  std::printf(
      "| mesh | OMPL checker | samples | edges dsmplan / OMPL | roadmap s dsmplan | OMPL | ratio | query ms dsmplan | "
      "OMPL | ratio | length m dsmplan (raw) | OMPL (simplified) | ratio raw/raw | smoothed/simplified |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  bool consistent = true;
  for (const MeshRow& r : rows) {
    consistent = consistent && r.same_nodes && r.solved;
    for (const OmplRun& o : r.ompl) {
      consistent = consistent && o.same_edges && o.samples == r.samples && o.solved;
      std::printf(
          "| %s (%s tri) | %s | %s | %s / %s%s | %.3f | %.2f | %.1fx | %.2f | %.2f | %.1fx | %.0f (%.0f) | %.0f (%.0f) "
          "| %.3f | %.3f |\n",
          r.name.c_str(), grouped(r.triangles).c_str(), o.checker.c_str(), grouped(r.samples).c_str(),
          grouped(r.edges).c_str(), grouped(o.edges).c_str(), o.same_edges ? " (same)" : " (DIFFER)", best(r.roadmap_s),
          o.roadmap_s, o.roadmap_s / best(r.roadmap_s), best(r.query_ms), o.query_ms, o.query_ms / best(r.query_ms),
          r.length, r.raw_length, o.length, o.simplified, r.raw_length / o.length, r.length / o.simplified);
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

  // Bars on the 0.64 m mesh.
  const MeshRow& big = rows.back();
  double fastest = INFINITY;
  std::string fastest_name;
  for (const OmplRun& o : big.ompl)
    if (o.same_edges && o.roadmap_s < fastest) fastest = o.roadmap_s, fastest_name = o.checker;
  const double speedup = fastest / best(big.roadmap_s);
  const bool bar_roadmap = consistent && speedup >= 5;
  const bool bar_query = big.solved && best(big.query_ms) <= 10;
  // Where OMPL's time goes, for comparison with dsmplan's phases printed above.
  const Profile* shared = nullptr;
  for (const OmplRun& o : big.ompl)
    if (o.checker == fastest_name) shared = &o.profile;
  if (shared) {
    const double checks = shared->valid_s + shared->motion_s, share = checks / shared->total_s;
    std::printf(
        "\n0.64 m, OMPL + %s: %.0f %% of its roadmap time (%.3f s of %.3f s in the run with timers) are exact "
        "checks (%.3f s validity, %.3f s segments); dsmplan on 1 thread %.3f s, on %u %.3f s (load %s)\n",
        fastest_name.c_str(), 100 * share, checks, shared->total_s, shared->valid_s, shared->motion_s, big.roadmap1_s,
        cores, best(big.roadmap_s), load_average().c_str());
  }
  std::printf("\nsame samples and edges everywhere, every query solved: %s\n", consistent ? "yes" : "NO");
  std::printf("bar 1, 0.64 m: dsmplan roadmap %.3f s vs OMPL PRM (%s) %.2f s = %.1fx (>= 5x): %s\n",
              best(big.roadmap_s), fastest_name.c_str(), fastest, speedup, bar_roadmap ? "PASS" : "FAIL");
  std::printf("bar 2, 0.64 m: dsmplan 3-leg query %.2f ms (<= 10 ms): %s\n", best(big.query_ms),
              bar_query ? "PASS" : "FAIL");
  std::printf("total %.0f s\n", seconds_since(begin));
  return bar_roadmap && bar_query && problem.empty() ? 0 : 1;
}
