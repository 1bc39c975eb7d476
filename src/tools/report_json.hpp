// JSON pieces every tool report shares.
#pragma once

#include "dsmplan/tools.hpp"

namespace dsmplan {

/// {name, epsg, wkt}, null where unknown.
Json crs_json(const Crs& crs);
/// {name, unit} of the vertical reference, null where unknown.
Json vertical_json(const Crs& crs);
/// {stage: seconds, ...} in the order the stages ran.
Json seconds_json(const std::vector<std::pair<std::string, double>>& seconds);
/// {path, max_placement_error_m, heights} of --3dtiles, null without.
Json tileset_report_json(const std::optional<TilesetReport>& tileset);
/// Heights are stored as float32: the shortest decimal of that float (109.18, not 109.18000030517578).
double as_stored(double height);

}  // namespace dsmplan
