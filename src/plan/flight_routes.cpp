// plan_routes(): the paper's planner as it is meant, multi-query (Adolf & Hirschmueller, Section
// 5; Kavraki, Svestka, Latombe & Overmars 1996): one roadmap over the area, built once, and every
// route a query against it, planned in parallel and verified as plan_flight() verifies.
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <utility>

#include "core/stopwatch.hpp"
#include "core/text.hpp"
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

// One route; with `budget` > 0 under a stop token of its own that ends `budget` seconds from now
// or when the run's does.
RouteResult plan_one(const FlightArea& area, FlightQuery query, double budget) {
  const std::shared_ptr<const StopToken> run_stop = query.options.stop;
  if (budget > 0)
    query.options.stop = std::make_shared<const StopToken>(
        StopToken::Clock::now() +
            std::chrono::duration_cast<StopToken::Clock::duration>(std::chrono::duration<double>(budget)),
        run_stop);
  RouteResult out;
  try {
    FlightAttempt attempt = attempt_flight(area, query);
    out.solved = attempt.solved;
    if (!attempt.solved) {
      const MissionSite* site = attempt.plan.site ? &*attempt.plan.site : nullptr;
      const FailureInWords words = failure_in_words(attempt.failure, site, query.waypoints.size());
      out.place = words.place, out.why = words.why;
      out.failure = route_failure(attempt.failure, site, query.waypoints.size());
    }
    out.plan = std::move(attempt.plan);
  } catch (const Cancelled& cancelled) {
    if (budget <= 0 || (run_stop && run_stop->stop_requested())) throw;  // the whole run was given up on
    out.why = "past the route's time budget of " + short_number(budget) + " s (--route-budget)" +
              (cancelled.stage().empty() ? "" : ", stopped while " + cancelled.stage());
    out.failure.code = "route_budget";
  } catch (const DataFault& fault) {  // its home or landing: not the others'
    out.why = fault.what();
    out.failure.code = fault.field() == "--end" ? "end_refused" : "home_refused";
    out.failure.nearest = fault.nearest();
  } catch (const Error& error) {  // this route's own refusal (its terrain): not the others'
    out.why = error.what();
    out.failure.code = "refused";
  }
  return out;
}

}  // namespace

void check_route_budget(double seconds) {
  if (!(seconds >= 0 && seconds <= 3600))
    throw ArgumentError("route_budget", "must lie in [0, 3600] s, got " + short_number(seconds));
}

RoutesPlan plan_routes(const FlightArea& area, const std::vector<std::vector<Point3>>& routes,
                       const FlightQuery& common, const Progress& progress, double route_budget) {
  check_plan_options(common.options);
  check_route_budget(route_budget);
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
  if (route_budget > 0) {  // what the routes share is made on no route's time
    const PlanOptions plan = area.planner_options(common.options);
    if (plan.planner == PlannerKind::prm) shared.get(area.roadmap_key(), plan);
    if (plan.planner == PlannerKind::free_space)
      area.free_airspace(common.options.safety, plan.max_agl, common.options.stop.get());
  }
  std::atomic<size_t> done{0};
  std::mutex reporting;
  tbb::parallel_for(size_t(0), routes.size(), [&](size_t r) {
    FlightQuery mine = query;
    mine.waypoints = routes[r];
    out.routes[r] = plan_one(area, std::move(mine), route_budget);
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
