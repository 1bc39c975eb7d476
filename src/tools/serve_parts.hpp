// The parts of `dsmplan serve` its source files share: a request's body read into the options of
// `dsmplan plan` (serve_request.cpp), the roadmaps kept in memory (serve_roadmaps.cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "dsmplan/flight.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/serve.hpp"

namespace dsmplan {

/// A POST /v1/plan body read: the waypoints (in WGS 84 when `geojson`), and the options of the
/// `dsmplan plan` run it stands for (plan, format, mission), within the server's bounds.
struct PlanRequest {
  std::vector<Point3> waypoints;
  bool geojson = false;  ///< waypoints are longitude, latitude, ellipsoidal height
  PlanJobOptions job;    ///< job.plan, job.format (its output's name is the format), job.mission
  bool stats = true;     ///< answer the figures of --stats too
};

/// ArgumentError(key, why) naming the request's key ("safety", "mission.home", "waypoints") for a
/// body that is not a JSON object of the keys docs/commands.md lists, a value of the wrong type, or
/// one beyond the server's bounds (`server`). Nesting deeper than 32 is refused before parsing.
/// A request without "format" asks for `default_format` (PlanService: geojson when the server
/// knows the heights above the WGS 84 ellipsoid, else csv).
PlanRequest parse_plan_request(const std::string& body, const ServeOptions& server,
                               const std::string& default_format = "geojson");

/// The request's key for a field the library's errors name by `dsmplan plan`'s flag ("--home"
/// -> "mission.home"); the field itself when it has none.
std::string request_key(const std::string& field);

/// The 504's words: "past the request's time budget of B s (--budget), stopped while STAGE".
std::string budget_message(double budget_seconds, const std::string& stage);

/// The roadmaps in memory: the server's own (pinned), and a few built for requests with another
/// safety or ceiling, the least recently used dropped past `capacity`. Thread-safe.
class RoadmapShelf {
public:
  explicit RoadmapShelf(size_t capacity) : capacity_(capacity) {}
  void pin(uint64_t key, const PlanOptions& options, std::shared_ptr<const Roadmap> map);
  std::shared_ptr<const Roadmap> find(uint64_t key, const PlanOptions& options);
  void keep(const Roadmap& map, uint64_t key, const PlanOptions& options);
  /// kept_roadmap and keep_roadmap over this shelf.
  FlightStore store();

private:
  struct Entry {
    uint64_t key;
    double safety, spacing, max_edge, max_agl;
    std::vector<std::shared_ptr<const FlightConstraint>> constraints;  ///< the same objects: the same rules
    std::shared_ptr<const Roadmap> map;
    uint64_t used;
    bool pinned;
  };
  std::mutex mutex_;
  std::vector<Entry> entries_;
  size_t capacity_;
  uint64_t clock_ = 0;
};

}  // namespace dsmplan
