// The waypoint files of dsmplan plan (dsmplan/waypoints.hpp): CSV in the mesh's CRS and GeoJSON
// in WGS 84, the latter parsed by nlohmann-json (RFC 8259), its structure as RFC 7946 defines it.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/json_parse.hpp"
#include "core/text.hpp"
#include "dsmplan/waypoints.hpp"

namespace dsmplan {

namespace {

using Json = nlohmann::ordered_json;

std::string trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

// Three comma-separated finite numbers, or false.
bool parse_point(const std::string& line, Point3& p) {
  size_t begin = 0;
  for (int k = 0; k < 3; ++k) {
    const size_t end = k < 2 ? line.find(',', begin) : line.size();
    if (end == std::string::npos) return false;
    const std::string field = trim(line.substr(begin, end - begin));
    const char* first = field.data() + (field.size() > 1 && field[0] == '+' ? 1 : 0);
    const auto [ptr, ec] = std::from_chars(first, field.data() + field.size(), p[k]);
    if (field.empty() || ec != std::errc() || ptr != field.data() + field.size() || !std::isfinite(p[k])) return false;
    begin = end + 1;
  }
  return true;
}

// A JSON value for a message: scalars and flat arrays as JSON, cut at 80 characters; anything
// nested by its kind only (dumping it recurses as deep as it nests: 100,000 deep overflowed the stack).
std::string brief(const Json& v) {
  const bool flat =
      !v.is_structured() || std::none_of(v.begin(), v.end(), [](const Json& e) { return e.is_structured(); });
  if (!flat) return v.is_array() ? "an array of arrays" : "an object";
  const std::string text = v.dump();
  return text.size() > 80 ? text.substr(0, 77) + "..." : text;
}

// One position of a GeoJSON geometry as longitude, latitude, height, or a reason it is not.
std::string position(const Json& p, Point3& out) {
  if (!p.is_array()) return "a position must be an array [longitude, latitude, height]";
  if (p.size() < 3) return "a waypoint needs a height: [longitude, latitude, height], got " + brief(p);
  for (int k = 0; k < 3; ++k) {
    if (!p[k].is_number()) return "coordinates must be numbers, got " + brief(p);
    out[k] = p[k].get<double>();
    if (!std::isfinite(out[k])) return "coordinates must be finite";
  }
  if (std::abs(out[0]) > 180 || std::abs(out[1]) > 90)
    return "not longitude, latitude in degrees (RFC 7946 GeoJSON is WGS 84): " + brief(p);
  return {};
}

// A waypoint file is read whole, but never more than this: a file that never ends (/dev/zero,
// a pipe) or one that is no waypoint list stops here. 100,000 waypoints of "x,y,z" with
// centimetres take about 3 MB as CSV, 10 MB as GeoJSON.
constexpr size_t kMaxWaypointBytes = 64u << 20;
constexpr size_t kMaxWaypoints = 100000;

std::string read_waypoint_bytes(const std::string& path) {
  require_input_file(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open the waypoint file");
  std::string bytes;
  char chunk[1 << 16];
  while (bytes.size() <= kMaxWaypointBytes && in.read(chunk, sizeof chunk).gcount() > 0)
    bytes.append(chunk, static_cast<size_t>(in.gcount()));
  if (in.bad()) throw InputError(path, "", "cannot read the waypoint file");
  if (bytes.size() > kMaxWaypointBytes)
    throw InputError(path, "", "more than 64 MB: not a waypoint list (at most 100000 waypoints a mission)");
  return bytes;
}

void check_count(const std::string& path, size_t count) {
  if (count > kMaxWaypoints)
    throw InputError(path, "", std::to_string(count) + " waypoints: at most 100000 a file (split it into several)");
}

// Whether a CSV header's column `k` (0-based) is named "agl": heights above the ground.
bool column_is_agl(const std::string& header, int k) {
  std::istringstream columns(header);
  std::string column;
  for (int i = 0; std::getline(columns, column, ','); ++i)
    if (i == k) return lower_case(trim(column)) == "agl";
  return false;
}

}  // namespace

std::vector<Point3> read_waypoints_csv(const std::string& path, bool* agl) {
  if (agl) *agl = false;
  std::istringstream in(read_waypoint_bytes(path));
  std::vector<Point3> points;
  std::string line;
  bool first = true;
  for (size_t number = 1; std::getline(in, line); ++number) {
    const std::string text = trim(line);
    if (text.empty() || text[0] == '#') continue;
    Point3 p;
    if (parse_point(text, p)) {
      points.push_back(p);
    } else if (!first || std::any_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); })) {
      throw InputError(path, "line " + std::to_string(number),
                       "expected 'x,y,z' (three numbers), got '" + text.substr(0, 60) + "'");
    } else if (agl) {  // the header: "x,y,agl" gives heights above the ground
      *agl = column_is_agl(text, 2);
    }
    first = false;
  }
  check_count(path, points.size());
  return points;
}

std::vector<Point3> read_waypoints_geojson(const std::string& path) {
  return parse_waypoints_geojson(read_waypoint_bytes(path), path);
}

std::vector<Point3> parse_waypoints_geojson(const std::string& bytes, const std::string& path) {
  if (bytes.size() > kMaxWaypointBytes)
    throw InputError(path, "", "more than 64 MB: not a waypoint list (at most 100000 waypoints a mission)");
  Json doc;
  try {
    doc = parse_json_strict<Json>(bytes);
  } catch (const Json::parse_error& e) {
    throw InputError(path, "byte " + std::to_string(e.byte), "not JSON");
  } catch (const Json::out_of_range&) {  // e.g. 1e400: valid JSON, but no double holds it (found by fuzzing)
    throw InputError(path, "", "a number beyond the range of a double");
  } catch (const DuplicateJsonKey& twice) {
    throw InputError(path, "", "the key " + shown(twice.key) + " twice in one object: which one is meant is not said");
  }
  std::vector<Point3> points;
  // The positions of one geometry: a Point gives one waypoint, MultiPoint and LineString theirs in order.
  auto take = [&](const Json& geometry, const std::string& place) {
    if (!geometry.is_object() || !geometry.contains("type") || !geometry.contains("coordinates"))
      throw InputError(path, place, "expected a geometry with 'type' and 'coordinates'");
    const std::string type = geometry["type"].is_string() ? geometry["type"].get<std::string>() : "";
    const Json& c = geometry["coordinates"];
    std::vector<const Json*> positions;
    if (type == "Point") {
      positions.push_back(&c);
    } else if ((type == "MultiPoint" || type == "LineString") && c.is_array()) {
      for (const Json& p : c) positions.push_back(&p);
    } else {
      throw InputError(path, place, "waypoints are Point, MultiPoint or LineString geometries, got '" + type + "'");
    }
    for (size_t k = 0; k < positions.size(); ++k) {
      Point3 p;
      const std::string problem = position(*positions[k], p);
      if (!problem.empty())
        throw InputError(path, place + (positions.size() > 1 ? ", position " + std::to_string(k + 1) : ""), problem);
      points.push_back(p);
    }
  };
  const std::string type =
      doc.is_object() && doc.contains("type") && doc["type"].is_string() ? doc["type"].get<std::string>() : "";
  if (type == "FeatureCollection") {
    if (!doc.contains("features") || !doc["features"].is_array())
      throw InputError(path, "", "a FeatureCollection needs a 'features' array");
    for (size_t i = 0; i < doc["features"].size(); ++i) {
      const Json& f = doc["features"][i];
      if (!f.is_object() || !f.contains("geometry"))
        throw InputError(path, "feature " + std::to_string(i + 1), "has no geometry");
      take(f["geometry"], "feature " + std::to_string(i + 1));
    }
  } else if (type == "Feature") {
    if (!doc.contains("geometry")) throw InputError(path, "", "the Feature has no geometry");
    take(doc["geometry"], "geometry");
  } else if (!type.empty()) {
    take(doc, "geometry");
  } else {
    throw InputError(path, "", "not GeoJSON (no 'type' member)");
  }
  check_count(path, points.size());
  return points;
}

// ---- routes: many flights in one file --------------------------------------------------------

namespace {

// The route named `id`, made at its first row: routes keep the order of their first rows.
// A route's id as every output shows it (visible_text(): control characters and bytes that are
// not UTF-8 as "\x1b"), at most kMaxRouteId bytes: it names the route's file in a folder, and a
// longer name fails only when that file is written, after the others.
constexpr size_t kMaxRouteId = 200;

std::vector<Point3>& route_named(std::vector<Route>& routes, std::map<std::string, size_t>& index,
                                 const std::string& raw, const std::string& path, const std::string& place) {
  const std::string id = visible_text(raw);
  if (id.size() > kMaxRouteId)
    throw InputError(path, place,
                     "a route id of " + std::to_string(id.size()) + " bytes; at most " + std::to_string(kMaxRouteId) +
                         " (it names the route's file): " + shown(id));
  const auto [it, added] = index.emplace(id, routes.size());
  if (added) routes.push_back({id, {}});
  return routes[it->second].waypoints;
}

}  // namespace

std::vector<Route> read_routes_csv(const std::string& path, bool* agl) {
  if (agl) *agl = false;
  std::istringstream in(read_waypoint_bytes(path));
  std::vector<Route> routes;
  std::map<std::string, size_t> index;
  std::string line;
  bool first = true;
  size_t total = 0;
  for (size_t number = 1; std::getline(in, line); ++number) {
    const std::string text = trim(line);
    if (text.empty() || text[0] == '#') continue;
    const size_t comma = text.find(',');
    const std::string id = trim(text.substr(0, comma));
    Point3 p;
    if (comma != std::string::npos && !id.empty() && parse_point(text.substr(comma + 1), p)) {
      std::vector<Point3>& waypoints = route_named(routes, index, id, path, "line " + std::to_string(number));
      waypoints.push_back(p);
      check_count(path, ++total);  // the file's, as a waypoint file's: not a route's
    } else if (!first) {
      throw InputError(path, "line " + std::to_string(number),
                       "expected 'route,x,y,z' (an id and three numbers), got '" + text.substr(0, 60) + "'");
    } else if (agl) {  // the header: "route,x,y,agl" gives heights above the ground
      *agl = column_is_agl(text, 3);
    }
    first = false;
  }
  if (routes.empty()) throw InputError(path, "", "no route: expected lines of 'route,x,y,z'");
  return routes;
}

std::vector<Route> read_routes_geojson(const std::string& path) {
  const std::string bytes = read_waypoint_bytes(path);
  Json doc;
  try {
    doc = parse_json_strict<Json>(bytes);
  } catch (const Json::parse_error& e) {
    throw InputError(path, "byte " + std::to_string(e.byte), "not JSON");
  } catch (const Json::out_of_range&) {
    throw InputError(path, "", "a number beyond the range of a double");
  } catch (const DuplicateJsonKey& twice) {
    throw InputError(path, "", "the key " + shown(twice.key) + " twice in one object: which one is meant is not said");
  }
  if (!doc.is_object() || doc.value("type", Json()) != "FeatureCollection" || !doc.contains("features") ||
      !doc["features"].is_array())
    throw InputError(path, "", "routes are a GeoJSON FeatureCollection of LineString features");
  std::vector<Route> routes;
  std::map<std::string, size_t> index;
  size_t total = 0;
  for (size_t i = 0; i < doc["features"].size(); ++i) {
    const Json& f = doc["features"][i];
    const std::string place = "feature " + std::to_string(i + 1);
    const Json* geometry = f.is_object() && f.contains("geometry") ? &f["geometry"] : nullptr;
    if (!geometry || !geometry->is_object() || !geometry->contains("coordinates") ||
        !(geometry->value("type", Json()) == "LineString" || geometry->value("type", Json()) == "MultiPoint") ||
        !(*geometry)["coordinates"].is_array())
      throw InputError(path, place, "a route is a LineString (or MultiPoint) geometry");
    // Its id: properties.id, else the feature's id, else its number.
    const Json* id = f.contains("properties") && f["properties"].is_object() && f["properties"].contains("id")
                         ? &f["properties"]["id"]
                     : f.contains("id") ? &f["id"]
                                        : nullptr;
    const std::string name = !id               ? "route " + std::to_string(i + 1)
                             : id->is_string() ? id->get<std::string>()
                                               : brief(*id);
    if (index.count(visible_text(name)))
      throw InputError(path, place, "a second route with the id '" + visible_text(name) + "'");
    std::vector<Point3>& waypoints = route_named(routes, index, name, path, place);
    const Json& c = (*geometry)["coordinates"];
    for (size_t k = 0; k < c.size(); ++k) {
      Point3 p;
      const std::string problem = position(c[k], p);
      if (!problem.empty()) throw InputError(path, place + ", position " + std::to_string(k + 1), problem);
      waypoints.push_back(p);
      check_count(path, ++total);
    }
  }
  if (routes.empty()) throw InputError(path, "", "no route: the FeatureCollection has no feature");
  return routes;
}

}  // namespace dsmplan
