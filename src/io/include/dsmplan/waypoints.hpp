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
/// line that is not three finite numbers, and InputError(path) for a missing file.
std::vector<Point3> read_waypoints_csv(const std::string& path);

/// Waypoints from GeoJSON (RFC 7946): a FeatureCollection of Point features (one waypoint each,
/// in order; MultiPoint and LineString features give theirs in order), a Feature, or a bare
/// geometry. Positions are [longitude, latitude, height] in WGS 84 degrees and metres; the height
/// is required. InputError(path, "feature N[, position K]" or "byte N", why) otherwise.
std::vector<Point3> read_waypoints_geojson(const std::string& path);

/// read_waypoints_geojson() of bytes already in memory (a request's body), `name` standing for
/// the file in the errors: InputError(name, ...).
std::vector<Point3> parse_waypoints_geojson(const std::string& bytes, const std::string& name);

}  // namespace dsmplan
