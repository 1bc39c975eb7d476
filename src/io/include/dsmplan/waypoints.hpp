// dsmplan/waypoints.hpp: the waypoint files `dsmplan plan` reads (CSV in the mesh's CRS,
// GeoJSON in WGS 84). Errors: InputError naming the file, the line, feature or byte, and why.
#pragma once

#include <string>
#include <vector>

#include "dsmplan/core.hpp"

namespace dsmplan {

/// Waypoints from a CSV file: one "x,y,z" line each, in the mesh's CRS (blanks around the
/// numbers allowed). Empty lines and lines starting with '#' are skipped; a first line that is
/// not numbers (e.g. "x,y,z") is a header. Throws InputError(path, "line N", ...) for any other
/// line that is not three finite numbers, and InputError(path) for a missing file. `agl`, when
/// given, is set to whether the header's third column is named "agl" (heights above the ground,
/// FlightQuery::heights) rather than z.
std::vector<Point3> read_waypoints_csv(const std::string& path, bool* agl = nullptr);

/// Waypoints from GeoJSON (RFC 7946): a FeatureCollection of Point features (one waypoint each,
/// in order; MultiPoint and LineString features give theirs in order), a Feature, or a bare
/// geometry. Positions are [longitude, latitude, height] in WGS 84 degrees and metres; the height
/// is required. InputError(path, "feature N[, position K]" or "byte N", why) otherwise.
std::vector<Point3> read_waypoints_geojson(const std::string& path);

/// read_waypoints_geojson() of bytes already in memory (a request's body), `name` standing for
/// the file in the errors: InputError(name, ...).
std::vector<Point3> parse_waypoints_geojson(const std::string& bytes, const std::string& name);

/// A route of a routes file (`dsmplan plan --routes`): its id and its waypoints, in order.
struct Route {
  std::string id;
  std::vector<Point3> waypoints;
};

/// Routes from CSV: "route,x,y,z" lines, the id any text without a comma, x, y, z in the mesh's
/// CRS; a first line that is not such (e.g. "route,x,y,z") is a header, '#' lines and empty ones
/// are skipped. A route's rows are its waypoints in order; routes come in the order of their first
/// row. InputError(path, "line N", ...) for another line, InputError(path) for no route. `agl`,
/// when given, is set to whether the header's fourth column is named "agl" (read_waypoints_csv()).
std::vector<Route> read_routes_csv(const std::string& path, bool* agl = nullptr);

/// Routes from GeoJSON (RFC 7946): a FeatureCollection of LineString (or MultiPoint) features, one
/// route each, its id the feature's properties.id, else its id member, else "route N"; positions
/// [longitude, latitude, height] in WGS 84 as read_waypoints_geojson(). InputError(path, "feature
/// N[, position K]" or "byte N", why) otherwise, and for two routes with one id.
std::vector<Route> read_routes_geojson(const std::string& path);

}  // namespace dsmplan
