// libFuzzer target: the body of a `dsmplan serve` POST /v1/plan, arbitrary bytes, through
// PlanService::plan() (the request's parser and its handler: every key, format and mission, the
// planning, the answer's bytes) over a small city in memory: a 60 m x 60 m square in
// EPSG:25832 with a 20 m block in its middle, safety 2 m, ceiling 60 m. Every answer must be a
// status of the list and a JSON body; any exception, crash or sanitizer report is a finding.
#include <cstdint>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>

#include "dsmplan/mesh.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/serve.hpp"

namespace {

const dsmplan::PlanService& service() {
  static const dsmplan::PlanService* made = [] {
    dsmplan::Grid dsm(60, 60, 356300, 5699760, 1, 1);
    for (int r = 0; r < 60; ++r)
      for (int c = 0; c < 60; ++c) dsm.z[size_t(r) * 60 + c] = (r >= 20 && r < 40 && c >= 20 && c < 40) ? 130 : 110;
    dsm.crs.definition = "EPSG:25832";
    dsmplan::resolve_crs(dsm.crs);
    auto mesh = std::make_shared<dsmplan::Mesh>(dsmplan::triangulate_xy3(dsm));
    mesh->crs = dsm.crs;
    dsmplan::FlightData data;
    data.mesh = mesh;
    data.names.mesh = "city";
    data.names.waypoints = "waypoints";
    dsmplan::ServeOptions options;
    options.plan.max_agl = 60;
    options.plan.spacing = 8;
    options.plan.max_edge = 14;
    options.plan.refine_rounds = 1;
    options.vertical.allow_approximate_vertical = true;
    return new dsmplan::PlanService(options, data);
  }();
  return *made;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const auto worker = service().worker();
  const dsmplan::PlanService::Answer answer =
      service().plan(std::string(reinterpret_cast<const char*>(data), size), *worker);
  const int s = answer.status;
  if (s != 200 && s != 400 && s != 422 && s != 504) std::abort();  // 500: an internal error is a finding
  (void)nlohmann::json::parse(answer.body);                        // throws (a finding) unless JSON
  return 0;
}
