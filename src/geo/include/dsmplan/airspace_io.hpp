// dsmplan/airspace_io.hpp: the no-fly zones authorities publish, read into the mesh's CRS
// (PROJ; in the library dsmplan_geo). What a zone is and how the planner keeps out of it:
// airspace.hpp (stage 4).
//
// read_airspace() tells the two formats apart by their shape (docs/formats.md, "No-fly zones"):
//   - EUROCAE ED-269 JSON (UAS geographical zones, as EASA's AMC to Article 15 of (EU) 2019/947
//     asks States to publish them): a top-level object with a `features` array (or the array
//     itself), each feature with `identifier`, `name`, `restriction` and a `geometry` array
//     whose items each give a `horizontalProjection` (`Polygon` with `coordinates` as GeoJSON's,
//     or `Circle` with `center` [lon, lat] and `radius`), `uomDimensions` ("M" or "FT": the
//     limits and the radius), `lowerLimit`/`upperLimit` with `lowerVerticalReference`/
//     `upperVerticalReference` ("AGL", "AMSL" or "WGS84"). One AirspaceZone per geometry item.
//   - GeoJSON (RFC 7946): a FeatureCollection of Polygon and MultiPolygon features, with the
//     properties `id`, `name`, `restriction` (default PROHIBITED), `lower`, `upper` (numbers,
//     in `uom`: "M", the default, or "FT"), `lower_ref`, `upper_ref` ("AGL", "AMSL" or "WGS84",
//     required with their limit). One AirspaceZone per polygon.
// A limit left out is unlimited: no lower limit, from below the ground; no upper, no top.
//
// Conversions, with the same operations the GeoJSON waypoints take (Wgs84Transform of
// wgs84.hpp, VerticalOptions as `dsmplan plan --vertical-crs`):
//   - longitude, latitude to the CRS exactly (the horizontal part never needs the vertical
//     reference: a file of AGL limits reads without it);
//   - feet are 0.3048 m;
//   - WGS84 heights (above the ellipsoid) through Wgs84Transform(crs, Ellipsoid, vertical), AMSL
//     heights (EGM96) through Wgs84Transform(crs, MeanSeaLevel, vertical): each limit at every
//     corner of the zone, the lower limit the least of them, the upper the greatest (the larger
//     volume); ArgumentError from those transforms when the DSM's vertical reference is unknown
//     or only approximately known (the message names the file and the zone);
//   - a circle becomes the polygon around it: the geodesic circle (WGS 84 ellipsoid, PROJ's
//     geod_direct, Karney 2013) projected, its farthest point from the centre R, and the
//     regular n-gon circumscribing the circle of radius R (1 + 1e-6), n the least from 32 to
//     1024 whose corners stand at most 5 cm beyond it.
// Bad input: InputError naming the file, the feature ("feature 3 'Prison X'", its geometry
// item or polygon when there are several) and the problem: not JSON, neither format, a missing
// or malformed field, an unknown uom, restriction or reference, a ring of fewer than 3 corners,
// a position that is not longitude, latitude in degrees, a circle without a positive radius,
// a lower limit above the upper one (same reference), a point PROJ cannot transform. At most
// 256 MB and 100,000 zones.
#pragma once

#include <string>
#include <vector>

#include "dsmplan/airspace.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

/// The zones of the ED-269 or GeoJSON file `path`, in `crs` (the mesh's), in the file's order;
/// each zone's source_file is `path`. Errors: see above.
std::vector<AirspaceZone> read_airspace(const std::string& path, const Crs& crs, const VerticalOptions& vertical = {});

}  // namespace dsmplan
