// dsmplan serve: a POST /v1/plan body (JSON) read into the options of the `dsmplan plan` run it
// stands for, held within the server's bounds; every refusal names the request's key.
#include <cmath>
#include <map>
#include <string>

#include "core/json_parse.hpp"
#include "core/text.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/waypoints.hpp"
#include "tools/serve_parts.hpp"

namespace dsmplan {

namespace {

constexpr int kMaxDepth = 32;
constexpr size_t kMaxWaypoints = 100000;  // as the waypoint files (waypoints.hpp)

// The deepest nesting of arrays and objects outside strings: refused before the parser, whose
// recursion a body of a million '[' would otherwise take down.
int nesting(const std::string& body) {
  int depth = 0, deepest = 0;
  bool in_string = false;
  for (size_t i = 0; i < body.size(); ++i) {
    const char c = body[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

double number(const Json& value, const std::string& key) {
  if (!value.is_number()) throw ArgumentError(key, "must be a number, got " + value.dump().substr(0, 40));
  const double x = value.get<double>();
  if (!std::isfinite(x)) throw ArgumentError(key, "must be finite");
  return x;
}

std::string text(const Json& value, const std::string& key) {
  if (!value.is_string()) throw ArgumentError(key, "must be a string, got " + value.dump().substr(0, 40));
  return value.get<std::string>();
}

// [[x, y, z], ...] in the mesh's CRS, or GeoJSON in WGS 84 (read as `dsmplan plan` reads a
// .geojson file).
void read_waypoints(const Json& value, PlanRequest& request) {
  if (value.is_object()) {
    request.geojson = true;
    try {
      request.waypoints = parse_waypoints_geojson(value.dump(), "waypoints");
    } catch (const InputError& e) {  // "waypoints: feature 2: ...": a bad request, not a flight refused
      const std::string message = e.what();
      throw ArgumentError("waypoints", message.substr(message.find(": ") + 2));
    }
  } else if (value.is_array()) {
    if (value.size() > kMaxWaypoints)
      throw ArgumentError("waypoints", std::to_string(value.size()) + " waypoints: at most 100000 a request");
    for (size_t i = 0; i < value.size(); ++i) {
      const Json& p = value[i];
      const std::string key = "waypoints[" + std::to_string(i) + "]";
      if (!p.is_array() || p.size() != 3) throw ArgumentError(key, "must be [x, y, z] in the mesh's CRS");
      // Each coordinate named by its own place: "waypoints[3][2]" is the fourth waypoint's z.
      request.waypoints.push_back({number(p[0], key + "[0]"), number(p[1], key + "[1]"), number(p[2], key + "[2]")});
    }
  } else {
    throw ArgumentError("waypoints", "must be [[x, y, z], ...] in the mesh's CRS or a GeoJSON object in WGS 84");
  }
  if (request.waypoints.size() < 2)
    throw ArgumentError("waypoints",
                        "a path needs at least two waypoints, got " + std::to_string(request.waypoints.size()));
}

void read_mission(const Json& value, MissionJobOptions& mission) {
  if (!value.is_object())
    throw ArgumentError("mission", "must be an object: home, end, altitude_frame, firmware, drone, speed");
  bool hover_given = false;
  for (const auto& [key, item] : value.items()) {
    const std::string name = "mission." + key;
    if (key == "home") {
      if (!item.is_array() || item.size() != 2)
        throw ArgumentError(name, "must be [x, y] in the mesh's CRS or [lon, lat] in degrees");
      mission.home = {number(item[0], name), number(item[1], name)};
    } else if (key == "end") {
      mission.end = parse_mission_end(text(item, name));
    } else if (key == "altitude_frame") {
      mission.format.altitude_frame = parse_altitude_frame(text(item, name));
    } else if (key == "firmware") {
      mission.format.firmware = parse_firmware(text(item, name));
    } else if (key == "drone") {
      mission.format.drone = parse_drone(text(item, name));
    } else if (key == "speed") {
      mission.format.speed = number(item, name);
    } else if (key == "hover_speed") {
      mission.format.hover_speed = number(item, name);
      hover_given = true;
    } else {
      throw ArgumentError(name, "unknown key (home, end, altitude_frame, firmware, drone, speed, hover_speed)");
    }
  }
  if (!hover_given) mission.format.hover_speed = mission.format.speed;  // as `dsmplan plan --hover-speed`
}

// safety, no_fly_buffer and max_agl within the server's bounds: never less distance from the
// obstacles or the zones, never a higher ceiling.
void read_limits(const Json& doc, const PlanOptions& server, PlanOptions& plan) {
  if (doc.contains("safety")) {
    plan.safety = number(doc["safety"], "safety");
    if (plan.safety < server.safety)
      throw ArgumentError("safety", "must be at least " + short_number(server.safety) + " m, the server's least, got " +
                                        short_number(plan.safety));
  }
  if (doc.contains("no_fly_buffer")) {
    plan.no_fly_buffer = number(doc["no_fly_buffer"], "no_fly_buffer");
    if (plan.no_fly_buffer < zone_keep_distance(server))
      throw ArgumentError("no_fly_buffer", "must be at least " + short_number(zone_keep_distance(server)) +
                                               " m, the server's least, got " + short_number(plan.no_fly_buffer));
  }
  if (doc.contains("max_agl")) {
    plan.max_agl = number(doc["max_agl"], "max_agl");
    if (!(plan.max_agl > 0 && plan.max_agl <= server.max_agl))
      throw ArgumentError("max_agl", "must lie in (0, " + short_number(server.max_agl) +
                                         "] m, the server's ceiling, got " + short_number(plan.max_agl));
  }
}

}  // namespace

std::string request_key(const std::string& field) {
  static const std::map<std::string, std::string> keys{{"--of", "format"},
                                                       {"-o", "format"},
                                                       {"--home", "mission.home"},
                                                       {"--end", "mission.end"},
                                                       {"end", "mission.end"},
                                                       {"firmware", "mission.firmware"},
                                                       {"drone", "mission.drone"},
                                                       {"altitude_frame", "mission.altitude_frame"},
                                                       {"--speed", "mission.speed"},
                                                       {"--hover-speed", "mission.hover_speed"},
                                                       {"--extrude", "extrude"},
                                                       {"--safety", "safety"},
                                                       {"--no-fly-buffer", "no_fly_buffer"},
                                                       {"--max-agl", "max_agl"},
                                                       {"--seed", "seed"},
                                                       {"snap", "snap_m"}};
  const auto it = keys.find(field);
  return it == keys.end() ? field : it->second;
}

PlanRequest parse_plan_request(const std::string& body, const ServeOptions& server, const std::string& default_format) {
  if (nesting(body) > kMaxDepth) throw ArgumentError("body", "nested deeper than 32 arrays or objects");
  Json doc;
  try {
    doc = parse_json_strict<Json>(body);
  } catch (const Json::parse_error& e) {
    throw ArgumentError("body", "not JSON (byte " + std::to_string(e.byte) + ")");
  } catch (const Json::exception&) {  // e.g. 1e400: valid JSON, but no double holds it
    throw ArgumentError("body", "a number beyond the range of a double");
  } catch (const DuplicateJsonKey& twice) {
    throw ArgumentError(twice.key, "given twice: which one is meant is not said");
  }
  if (!doc.is_object()) throw ArgumentError("body", "must be a JSON object with 'waypoints'");
  PlanRequest request;
  PlanJobOptions& job = request.job;
  job.plan = server.plan;
  job.plan.threads = 1;  // a worker plans on its own thread; the pool is the parallelism
  job.vertical = server.vertical;
  job.format = default_format;
  if (!doc.contains("waypoints")) throw ArgumentError("waypoints", "missing: [[x, y, z], ...] or GeoJSON");
  for (const auto& [key, value] : doc.items()) {
    if (key == "waypoints") {
      read_waypoints(value, request);
    } else if (key == "planner") {
      job.plan.planner = parse_planner(text(value, key));
    } else if (key == "objective") {
      job.plan.objective = parse_objective(text(value, key));
    } else if (key == "seed") {
      if (!value.is_number_unsigned()) throw ArgumentError("seed", "must be an integer >= 0");
      job.plan.seed = value.get<uint64_t>();
    } else if (key == "format") {
      job.format = lower_case(text(value, key));
    } else if (key == "stats") {
      if (!value.is_boolean()) throw ArgumentError("stats", "must be true or false");
      request.stats = value.get<bool>();
    } else if (key == "extrude") {
      if (!value.is_boolean()) throw ArgumentError("extrude", "must be true or false");
      job.mission.format.extrude = value.get<bool>();
    } else if (key == "mission") {
      read_mission(value, job.mission);
    } else if (key == "snap_m") {
      job.snap = number(value, key);
    } else if (key == "waypoint_heights") {
      job.waypoint_heights = text(value, key);
      parse_waypoint_heights(job.waypoint_heights);  // refused now, naming the key
    } else if (key != "safety" && key != "max_agl" && key != "no_fly_buffer") {
      throw ArgumentError(
          key,
          "unknown key (waypoints, safety, max_agl, no_fly_buffer, planner, objective, seed, format, stats, "
          "mission, extrude, snap_m, waypoint_heights)");
    }
  }
  read_limits(doc, server.plan, job.plan);
  job.output = "path." + job.format;
  return request;
}

}  // namespace dsmplan
