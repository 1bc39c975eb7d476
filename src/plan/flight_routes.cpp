// plan_routes(): the paper's planner as it is meant, multi-query (Adolf & Hirschmueller, Section
// 5; Kavraki, Svestka, Latombe & Overmars 1996): one roadmap over the area, built once, and every
// route a query against it, planned in parallel and verified as plan_flight() verifies.
#include <tbb/parallel_for.h>

#include <atomic>
#include <mutex>
#include <utility>

#include "core/stopwatch.hpp"
#include "dsmplan/flight.hpp"

namespace dsmplan {

namespace {

// The roadmap every route shares: the store's, else built by the first route that asks (all ask
// with the same options: the routes share the query's) and kept for the others.
struct SharedRoadmap {
  SharedRoadmap(FlightStore store, const FlightArea& flight_area) : kept(std::move(store)), area(flight_area) {}

  FlightStore kept;
  const FlightArea& area;
  std::once_flag made;
  std::shared_ptr<const Roadmap> map;
  double seconds = 0;
  bool reused = false;

  std::shared_ptr<const Roadmap> get(uint64_t key, const PlanOptions& plan) {
    std::call_once(made, [&] {
      Stopwatch clock;
      if (kept.kept_roadmap) map = kept.kept_roadmap(key, plan);
      reused = map != nullptr;
      if (!map) {
        map = std::make_shared<const Roadmap>(build_roadmap(area.index(), plan));
        if (kept.keep_roadmap) kept.keep_roadmap(*map, key, plan);
      }
      seconds = clock.lap();
    });
    return map;
  }
};

RouteResult plan_one(const FlightArea& area, const FlightQuery& query) {
  RouteResult out;
  try {
    FlightAttempt attempt = attempt_flight(area, query);
    out.solved = attempt.solved;
    if (!attempt.solved) {
      const MissionSite* site = attempt.plan.site ? &*attempt.plan.site : nullptr;
      const FailureInWords words = failure_in_words(attempt.failure, site, query.waypoints.size());
      out.place = words.place, out.why = words.why;
    }
    out.plan = std::move(attempt.plan);
  } catch (const Cancelled&) {
    throw;                        // the whole run was given up on, not this route
  } catch (const Error& error) {  // this route's own refusal (its home, its terrain): not the others'
    out.why = error.what();
  }
  return out;
}

}  // namespace

RoutesPlan plan_routes(const FlightArea& area, const std::vector<std::vector<Point3>>& routes,
                       const FlightQuery& common, const Progress& progress) {
  check_plan_options(common.options);
  RoutesPlan out;
  out.routes.resize(routes.size());
  Stopwatch clock;
  area.index();  // before the threads: built once, and its time is not a route's
  out.seconds_index = clock.lap();
  SharedRoadmap shared(common.store, area);
  FlightQuery query = common;
  if (common.options.planner == PlannerKind::prm)  // RRT-Connect grows its trees per query
    query.store.kept_roadmap = [&shared](uint64_t key, const PlanOptions& plan) { return shared.get(key, plan); };
  query.store.keep_roadmap = nullptr;
  std::atomic<size_t> done{0};
  std::mutex reporting;
  tbb::parallel_for(size_t(0), routes.size(), [&](size_t r) {
    FlightQuery mine = query;
    mine.waypoints = routes[r];
    out.routes[r] = plan_one(area, mine);
    const size_t finished = ++done;
    if (progress && (finished % 64 == 0 || finished == routes.size())) {
      const std::lock_guard<std::mutex> lock(reporting);
      report(progress, double(finished) / double(routes.size()));
    }
  });
  out.seconds_roadmap = shared.seconds;
  out.roadmap_reused = shared.reused;
  if (shared.map) out.roadmap_nodes = shared.map->nodes.size(), out.roadmap_edges = shared.map->edges();
  out.seconds = clock.lap() + out.seconds_index;
  return out;
}

}  // namespace dsmplan
