// OMPL's PRM as the baseline of dsmplan's planner: what bench/plan_ompl.cpp (in one process, beside
// build_roadmap()) and bench/ompl_plan_process.cpp (a whole `dsmplan plan` done with OMPL and
// Embree, for bench/plan_process.sh) share: build_roadmap()'s Halton candidates re-generated, the
// exact checkers (dsmplan's ClearanceIndex, an Embree 3 BVH), OMPL's state validity checker and
// motion validator over them, and a geometric::PRM that is given those samples.
//
// Sources:
//   - Sucan, Moll, Kavraki, "The Open Motion Planning Library", IEEE RAM 19(4), 2012; the API of
//     /usr/include/ompl-1.5 (geometric/planners/prm/PRM.h: addMilestone, constructSolution,
//     setConnectionStrategy, setNearestNeighbors; base/MotionValidator.h;
//     base/StateValidityChecker.h; datastructures/NearestNeighbors*.h; tools/config/SelfConfig.h,
//     getDefaultNearestNeighbors).
//   - Embree 3.13 API manual (rtcNewScene, rtcSetNewGeometryBuffer, rtcSetSceneBuildQuality,
//     rtcPointQuery with RTCPointQueryFunction, rtcIntersect1 with RTCRayHit); Wald et al., "Embree:
//     a kernel framework for efficient CPU ray tracing", ACM TOG 33(4), 2014.
//   - dsmplan: src/plan/prm_roadmap.cpp (the candidates: Halton bases 2, 3, 5, surface to ceiling),
//     src/plan/clearance_index.cpp (ground(): the highest covering triangle, barycentric weights
//     relative to its first corner; the floor's cell), include/dsmplan/flight_space.hpp (place()).
//
// Nearest neighbours. OMPL 1.5 offers for PRM (datastructures/): NearestNeighborsGNAT (PRM's
// default: PRM declares itself multithreaded, so SelfConfig picks the thread-safe GNAT),
// GNATNoThreadSafety, SqrtApprox and Linear; all four answer nearestR exactly (SqrtApprox's
// nearestR is Linear's scan), which equal edges need. FLANN's structures need libflann-dev's
// headers (absent here) and answer approximately unless told to search everything. The bench
// measures every one (bench_ompl_plan --nn) and uses the fastest: see kFairestNN below.
#pragma once

#include <ompl/base/MotionValidator.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/StateValidityChecker.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/datastructures/NearestNeighborsGNAT.h>
#include <ompl/datastructures/NearestNeighborsGNATNoThreadSafety.h>
#include <ompl/datastructures/NearestNeighborsLinear.h>
#include <ompl/datastructures/NearestNeighborsSqrtApprox.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/planners/prm/PRM.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#ifdef DSMPLAN_HAVE_EMBREE
#include <embree3/rtcore.h>
#endif

#include <gdal_utils.h>

#include "dsmplan/ground.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "plan/prm_parts.hpp"

namespace bench::baseline {

using dsmplan::ClearanceIndex;
using dsmplan::GroundGrid;
using dsmplan::Mesh;
using dsmplan::PlanOptions;
using dsmplan::Point3;
namespace ob = ompl::base;
namespace og = ompl::geometric;

// ---- the mesh's frame, as ClearanceIndex sets it -------------------------------------------

/// The x,y box of the triangles' corners (ClearanceIndex::footprint() without a flight area).
inline ClearanceIndex::Footprint footprint_of(const Mesh& mesh) {
  ClearanceIndex::Footprint e;
  for (const dsmplan::Triangle& t : mesh.triangles)
    for (uint32_t i : t) {
      const dsmplan::Vertex& v = mesh.vertices[i];
      e.xmin = std::min(e.xmin, v.x), e.xmax = std::max(e.xmax, v.x);
      e.ymin = std::min(e.ymin, v.y), e.ymax = std::max(e.ymax, v.y);
    }
  return e;
}

/// Whole units at the middle of the vertices' box, as ClearanceIndex's origin(): ground() below
/// then computes in the same local doubles, so its heights equal ClearanceIndex::ground()'s.
inline Point3 origin_of(const Mesh& mesh) {
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (const dsmplan::Vertex& v : mesh.vertices) {
    const double c[3] = {v.x, v.y, v.z};
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], c[k]), hi[k] = std::max(hi[k], c[k]);
  }
  return {std::round(0.5 * (lo[0] + hi[0])), std::round(0.5 * (lo[1] + hi[1])), std::round(0.5 * (lo[2] + hi[2]))};
}

/// The mesh's floor the ceiling counts from without a DSM or DTM (ClearanceIndex::floor()):
/// GroundGrid::floor_of() on the cell ClearanceIndex chooses (a quarter of its automatic bucket).
/// Part of the problem (what --max-agl means), so the baseline computes it with dsmplan's code.
inline GroundGrid floor_of(const Mesh& mesh) {
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  for (const dsmplan::Vertex& v : mesh.vertices)
    lo[0] = std::min(lo[0], v.x), lo[1] = std::min(lo[1], v.y), hi[0] = std::max(hi[0], v.x),
    hi[1] = std::max(hi[1], v.y);
  const double wx = hi[0] - lo[0], wy = hi[1] - lo[1];
  const double tris = static_cast<double>(mesh.triangles.size());
  double cell = std::sqrt(32.0 * std::max(wx * wy, 1e-12) / tris);
  if (!(cell > 0)) cell = 1;
  const double max_buckets = std::min(4.0 * tris + 16, 5e8);
  constexpr double shift = 0.30901699437494745;
  while ((std::floor(wx / cell + shift) + 1) * (std::floor(wy / cell + shift) + 1) > max_buckets) cell *= 1.5;
  return GroundGrid::floor_of(mesh, std::max(cell / 4, std::sqrt(std::max(wx * wy, 1e-12) / 5e7)));
}

// ---- exact checkers --------------------------------------------------------------------------

/// What OMPL's validity checker and motion validator ask: the surface's height (the flight
/// volume's bottom, where samples are drawn from) and clearance; both implementations are exact.
class Checker {
public:
  virtual ~Checker() = default;
  virtual const char* name() const = 0;
  /// The mesh's height at (x, y): the highest covering triangle; NaN where none covers.
  virtual double ground(double x, double y) const = 0;
  virtual bool segment_clear(const Point3& p, const Point3& q) const = 0;
  bool point_clear(const Point3& p) const { return segment_clear(p, p); }
};

class IndexChecker : public Checker {
public:
  IndexChecker(const ClearanceIndex& index, double safety) : index_(index), safety_(safety) {}
  const char* name() const override { return "ClearanceIndex"; }
  double ground(double x, double y) const override { return index_.ground(x, y); }
  bool segment_clear(const Point3& p, const Point3& q) const override { return index_.segment_clear(p, q, safety_); }

private:
  const ClearanceIndex& index_;
  double safety_;
};

#ifdef DSMPLAN_HAVE_EMBREE
// Embree 3 BVH (float triangles in the mesh's local frame) as a broad phase, the exact
// segment-triangle distance in doubles as the narrow phase. Embree's point query visits every
// primitive whose bounds meet a sphere; a capsule (segment grown by d) is covered by k spheres
// centred on k equal pieces of the segment, radius = half a piece + d: a point within d of
// the segment is within d of its closest segment point, which is within half a piece of a
// piece's centre. The radius gets a margin (1 cm) for the floats of the BVH, far above their
// rounding at a few hundred metres, so no triangle within d can be missed. A triangle is then
// decided as ClearanceIndex decides (sqrt of the exact squared distance < d: blocked), so both
// checkers agree on every query; bench_plan_ompl checks it on every roadmap edge.
// The ground is a ray cast down from above the mesh (rtcIntersect1): its first hit is the
// highest triangle there, whose height at (x, y) is then computed in doubles as
// ClearanceIndex::ground() computes it (bench_plan_ompl checks the candidates are the same).
class EmbreeChecker : public Checker {
public:
  /// quality: RTC_BUILD_QUALITY_LOW (Morton), MEDIUM (Embree's default) or HIGH.
  EmbreeChecker(const Mesh& mesh, const Point3& origin, double safety,
                RTCBuildQuality quality = RTC_BUILD_QUALITY_MEDIUM)
      : origin_(origin), safety_(safety) {
    device_ = rtcNewDevice(nullptr);
    scene_ = rtcNewScene(device_);
    rtcSetSceneBuildQuality(scene_, quality);
    RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geometry, quality);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), mesh.vertices.size()));
    auto* t = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(uint32_t), mesh.triangles.size()));
    local_.resize(mesh.vertices.size());
    top_ = -INFINITY;
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
      const dsmplan::Vertex& x = mesh.vertices[i];
      local_[i] = {x.x - origin[0], x.y - origin[1], x.z - origin[2]};
      top_ = std::max(top_, local_[i][2]);
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

  double ground(double x, double y) const override {
    const double X = x - origin_[0], Y = y - origin_[1];
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit hit;
    hit.ray.org_x = static_cast<float>(X), hit.ray.org_y = static_cast<float>(Y);
    hit.ray.org_z = static_cast<float>(top_ + 1);
    hit.ray.dir_x = 0, hit.ray.dir_y = 0, hit.ray.dir_z = -1;
    hit.ray.tnear = 0, hit.ray.tfar = INFINITY, hit.ray.time = 0;
    hit.ray.mask = ~0u, hit.ray.id = 0, hit.ray.flags = 0;
    hit.hit.geomID = RTC_INVALID_GEOMETRY_ID, hit.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &context, &hit);
    if (hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return NAN;
    // The hit triangle's plane at (X, Y) in doubles, with ClearanceIndex::ground()'s formula.
    const auto& t = tris_[hit.hit.primID];
    const Point3 &A = local_[t[0]], &B = local_[t[1]], &C = local_[t[2]];
    const double du1 = B[0] - A[0], dv1 = B[1] - A[1], du2 = C[0] - A[0], dv2 = C[1] - A[1];
    const double area2 = du1 * dv2 - du2 * dv1;
    if (!(std::abs(area2) > 0)) return NAN;
    const double pu = X - A[0], pv = Y - A[1];
    const double w1 = pu * dv2 - du2 * pv, w2 = du1 * pv - pu * dv1, w0 = area2 - w1 - w2;
    return (w0 * A[2] + w1 * B[2] + w2 * C[2]) / area2 + origin_[2];
  }

  bool segment_clear(const Point3& pw, const Point3& qw) const override {
    const double d = safety_;
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
    if (std::sqrt(dsmplan::segment_triangle_squared_distance(query->p, query->q, v[t[0]], v[t[1]], v[t[2]])) <
        query->d) {
      query->blocked = true;
      args->query->radius = 0;  // nothing more to learn: shrink the sphere so traversal ends
      return true;
    }
    return false;
  }

  Point3 origin_;
  double safety_;
  double top_ = 0;
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<Point3> local_;
  std::vector<dsmplan::Triangle> tris_;
};
#endif

// ---- the samples: build_roadmap()'s Halton candidates, re-generated ----------------------

/// Every candidate build_roadmap() draws, before dropping; NaN z where no triangle covers (x, y)
/// or there is no room under the ceiling. The same doubles as build_roadmap()'s (bench_plan_ompl
/// checks the kept ones equal Roadmap::nodes bit for bit).
inline std::vector<Point3> halton_candidates(const ClearanceIndex::Footprint& e, const Checker& surface,
                                             const GroundGrid& floor, const PlanOptions& o) {
  using dsmplan::detail::halton;
  const double wx = e.xmax - e.xmin, wy = e.ymax - e.ymin;
  const auto n = static_cast<size_t>(std::round(wx * wy * o.max_agl / std::pow(o.spacing, 3)));
  std::vector<Point3> out(n);
  for (size_t i = 0; i < n; ++i) {
    const double x = e.xmin + halton(i + 1, 2) * wx, y = e.ymin + halton(i + 1, 3) * wy;
    // From the surface to the ceiling over the mesh's floor, as build_roadmap() places them.
    const double g = surface.ground(x, y), top = o.max_agl - floor.height_above({x, y, 0});
    out[i] = {x, y, std::isnan(g) || !(top > g) ? NAN : g + halton(i + 1, 5) * (top - g)};
  }
  return out;
}

// ---- OMPL glue -----------------------------------------------------------------------------

/// Where OMPL's roadmap time goes: wall time inside the validity checker, the motion validator
/// and the nearest-neighbour search. Only in a run of its own (`on`), so timed runs carry no
/// clock reads (about 20 ns each, 300,000 a roadmap).
struct Profile {
  bool on = false;
  double valid_s = 0, motion_s = 0, near_s = 0, total_s = 0;
  size_t motions = 0;
};
using Clock = std::chrono::steady_clock;
inline double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

inline Point3 to_point(const ob::State* s) {
  const auto* r = s->as<ob::RealVectorStateSpace::StateType>();
  return {r->values[0], r->values[1], r->values[2]};
}
inline void set_state(ob::State* s, const Point3& p) {
  auto* r = s->as<ob::RealVectorStateSpace::StateType>();
  r->values[0] = p[0], r->values[1] = p[1], r->values[2] = p[2];
}

/// A state is valid where dsmplan's planner would accept it: over a triangle, not under the
/// surface, under the ceiling and at least `safety` from the mesh.
class Validity : public ob::StateValidityChecker {
public:
  Validity(const ob::SpaceInformationPtr& si, const Checker& checker, const GroundGrid& floor, double max_agl,
           Profile& profile)
      : ob::StateValidityChecker(si), checker_(checker), floor_(floor), max_agl_(max_agl), profile_(profile) {}
  bool isValid(const ob::State* s) const override {
    const auto start = profile_.on ? Clock::now() : Clock::time_point{};
    const Point3 p = to_point(s);
    const double g = checker_.ground(p[0], p[1]);
    const bool ok = !std::isnan(g) && p[2] >= g && floor_.height_above(p) <= max_agl_ && checker_.point_clear(p);
    if (profile_.on) profile_.valid_s += since(start);
    return ok;
  }

private:
  const Checker& checker_;
  const GroundGrid& floor_;
  double max_agl_;
  Profile& profile_;
};

/// Exact: the whole straight motion, not states along it at a resolution; the ceiling over the
/// whole motion first, as dsmplan's roadmap keeps it (flight_space.hpp).
class Motion : public ob::MotionValidator {
public:
  Motion(const ob::SpaceInformationPtr& si, const Checker& checker, const GroundGrid& floor, double max_agl,
         Profile& profile)
      : ob::MotionValidator(si), checker_(checker), floor_(floor), max_agl_(max_agl), profile_(profile) {}
  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const auto start = profile_.on ? Clock::now() : Clock::time_point{};
    const Point3 p = to_point(s1), q = to_point(s2);
    const bool ok = floor_.below_ceiling(p, q, max_agl_) && checker_.segment_clear(p, q);
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
  const Checker& checker_;
  const GroundGrid& floor_;
  double max_agl_;
  Profile& profile_;
};

/// RealVectorStateSpace(3) bounded by the footprint and [zmin, zmax + max_agl], with the exact
/// validity checker and motion validator over `checker`.
inline ob::SpaceInformationPtr make_space(const ClearanceIndex::Footprint& e, double zmin, double zmax,
                                          const Checker& checker, const GroundGrid& floor, double max_agl,
                                          Profile& profile) {
  auto space = std::make_shared<ob::RealVectorStateSpace>(3);
  ob::RealVectorBounds bounds(3);
  bounds.setLow(0, e.xmin), bounds.setHigh(0, e.xmax);
  bounds.setLow(1, e.ymin), bounds.setHigh(1, e.ymax);
  bounds.setLow(2, zmin), bounds.setHigh(2, zmax + max_agl);
  space->setBounds(bounds);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker(std::make_shared<Validity>(si, checker, floor, max_agl, profile));
  si->setMotionValidator(std::make_shared<Motion>(si, checker, floor, max_agl, profile));
  si->setup();
  return si;
}

/// OMPL's nearest-neighbour structures that answer nearestR exactly (see the top).
enum class NN { gnat, gnat_no_thread_safety, sqrt_approx, linear };
inline const char* nn_name(NN nn) {
  switch (nn) {
    case NN::gnat:
      return "GNAT";
    case NN::gnat_no_thread_safety:
      return "GNATNoThreadSafety";
    case NN::sqrt_approx:
      return "SqrtApprox";
    case NN::linear:
      return "Linear";
  }
  return "?";
}
inline NN nn_named(const std::string& name) {
  for (NN nn : {NN::gnat, NN::gnat_no_thread_safety, NN::sqrt_approx, NN::linear})
    if (name == nn_name(nn)) return nn;
  throw std::invalid_argument("unknown nearest-neighbour structure '" + name +
                              "' (GNAT, GNATNoThreadSafety, SqrtApprox, Linear)");
}
/// The fastest for this roadmap, measured (bench/README.md, "Planning as a whole process against OMPL"):
/// GNAT, PRM's own default, and GNATNoThreadSafety tie (7 paired runs of bench_ompl_plan on the
/// 1 m mesh: roadmap time GNAT / GNATNoThreadSafety median 0.99, 0.80-1.08); SqrtApprox and
/// Linear scan every milestone per nearestR and take 2.5-3 times as long (1.29-1.45 s against
/// 0.33-0.54 s). So GNAT: what PRM uses when nothing is chosen, and no slower than any other.
constexpr NN kFairestNN = NN::gnat;

/// OMPL's PRM fed with given samples: addMilestone() (protected) connects each to every earlier
/// milestone closer than max_edge, through the chosen nearest-neighbour structure and the motion
/// validator; queries use addMilestone() and constructSolution() as PRM::solve() does.
class GivenSamplesPRM : public og::PRM {
public:
  GivenSamplesPRM(const ob::SpaceInformationPtr& si, double max_edge, Profile& profile, NN nn = kFairestNN)
      : og::PRM(si), profile_(profile) {
    // Before the connection strategy: setNearestNeighbors() resets it.
    switch (nn) {
      case NN::gnat:
        setNearestNeighbors<ompl::NearestNeighborsGNAT>();
        break;
      case NN::gnat_no_thread_safety:
        setNearestNeighbors<ompl::NearestNeighborsGNATNoThreadSafety>();
        break;
      case NN::sqrt_approx:
        setNearestNeighbors<ompl::NearestNeighborsSqrtApprox>();
        break;
      case NN::linear:
        setNearestNeighbors<ompl::NearestNeighborsLinear>();
        break;
    }
    // PRM::setup() gives only its own default structure a distance function.
    nn_->setDistanceFunction([this](const Vertex a, const Vertex b) { return distanceFunction(a, b); });
    const double reach = max_edge, reach2 = reach * reach;
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

  /// One leg: nullptr when there is no roadmap path between the two states.
  std::shared_ptr<og::PathGeometric> leg(const ob::State* a, const ob::State* b) {
    const Vertex s = add(a), g = add(b);
    if (!sameComponent(s, g)) return nullptr;
    return std::static_pointer_cast<og::PathGeometric>(constructSolution(s, g));
  }

private:
  Profile& profile_;
  std::vector<Vertex> found_, neighbours_;
};

/// The roadmap: every candidate through OMPL's validity check, the valid ones as milestones.
inline void add_candidates(const ob::SpaceInformationPtr& si, GivenSamplesPRM& prm,
                           const std::vector<Point3>& candidates) {
  ob::State* work = si->allocState();
  for (const Point3& c : candidates) {
    if (std::isnan(c[2])) continue;  // no triangle under it, or no room (build_roadmap drops it the same way)
    set_state(work, c);
    if (si->isValid(work)) prm.add(work);
  }
  si->freeState(work);
}

// ---- the problem (untimed setup) ---------------------------------------------------------

/// 4 waypoints (3 legs) `height` above the ground near the corners and the middle of the mesh,
/// raised 5 m at a time until `safety` from the mesh.
inline std::vector<Point3> make_waypoints(const ClearanceIndex& index, double height, double safety) {
  const ClearanceIndex::Footprint& e = index.footprint();
  const double fractions[4][2] = {{0.1, 0.1}, {0.9, 0.2}, {0.55, 0.5}, {0.15, 0.9}};
  std::vector<Point3> out;
  for (const auto& f : fractions) {
    const double x = e.xmin + f[0] * (e.xmax - e.xmin), y = e.ymin + f[1] * (e.ymax - e.ymin);
    Point3 p{x, y, index.ground(x, y) + height};
    while (!index.point_clear(p, safety)) p[2] += 5;
    out.push_back(p);
  }
  return out;
}

/// `source` resampled by GDAL's warper (bilinear, Float32) to cells of `cell` from its top-left
/// corner (as many whole cells as fit its width: 1562 x 1562 of 0.64 m for the NRW tile), written
/// as a GeoTIFF to `path` (a file, or /vsimem/...).
inline void warp_bilinear(const std::string& source_path, double cell, const std::string& path) {
  GDALAllRegister();
  GDALDatasetH source = GDALOpen(source_path.c_str(), GA_ReadOnly);
  if (!source) throw std::runtime_error("cannot open " + source_path);
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
  int error = 0;
  GDALDatasetH out = GDALWarp(path.c_str(), nullptr, 1, &source, options, &error);
  GDALWarpAppOptionsFree(options);
  if (!out || error) throw std::runtime_error("GDALWarp failed");
  GDALClose(out);
  GDALClose(source);
}

}  // namespace bench::baseline
