// dsmplan serve: the roadmaps kept in memory (Kavraki et al. 1996's multi-query roadmap, built
// once and queried by every request with the same options). query_roadmap() takes a roadmap as
// const and refines a failed leg in a copy of its own (prm_query.cpp, Refinement), so one roadmap
// answers every worker at once.
#include <algorithm>

#include "tools/serve_parts.hpp"

namespace dsmplan {

namespace {

bool same_options(double safety, double spacing, double max_edge, double max_agl,
                  const std::vector<std::shared_ptr<const FlightConstraint>>& constraints, const PlanOptions& o) {
  return safety == o.safety && spacing == o.spacing && max_edge == o.max_edge && max_agl == o.max_agl &&
         constraints == o.constraints;
}

}  // namespace

void RoadmapShelf::pin(uint64_t key, const PlanOptions& options, std::shared_ptr<const Roadmap> map) {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.push_back({key, options.safety, options.spacing, options.max_edge, options.max_agl, options.constraints,
                      std::move(map), ++clock_, true});
}

std::shared_ptr<const Roadmap> RoadmapShelf::find(uint64_t key, const PlanOptions& options) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (Entry& e : entries_)
    if (e.key == key && same_options(e.safety, e.spacing, e.max_edge, e.max_agl, e.constraints, options)) {
      e.used = ++clock_;
      return e.map;
    }
  return nullptr;
}

void RoadmapShelf::keep(const Roadmap& map, uint64_t key, const PlanOptions& options) {
  auto copy = std::make_shared<const Roadmap>(map);
  std::lock_guard<std::mutex> lock(mutex_);
  for (const Entry& e : entries_)  // two requests built the same one at once
    if (e.key == key && same_options(e.safety, e.spacing, e.max_edge, e.max_agl, e.constraints, options)) return;
  const auto unpinned = [](const Entry& e) { return !e.pinned; };
  if (static_cast<size_t>(std::count_if(entries_.begin(), entries_.end(), unpinned)) >= capacity_) {
    auto oldest = entries_.end();
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (!it->pinned && (oldest == entries_.end() || it->used < oldest->used)) oldest = it;
    if (oldest != entries_.end()) entries_.erase(oldest);
  }
  if (capacity_ > 0)
    entries_.push_back({key, options.safety, options.spacing, options.max_edge, options.max_agl, options.constraints,
                        std::move(copy), ++clock_, false});
}

FlightStore RoadmapShelf::store() {
  FlightStore store;
  store.kept_roadmap = [this](uint64_t key, const PlanOptions& options) { return find(key, options); };
  store.keep_roadmap = [this](const Roadmap& map, uint64_t key, const PlanOptions& options) {
    keep(map, key, options);
  };
  return store;
}

}  // namespace dsmplan
