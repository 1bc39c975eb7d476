// JSON pieces every tool report shares.
#include "tools/report_json.hpp"

#include <charconv>
#include <cstdlib>

namespace dsmplan {

namespace {
Json text_or_null(const std::string& text) { return text.empty() ? Json(nullptr) : Json(text); }
}  // namespace

Json crs_json(const Crs& crs) {
  return {{"name", text_or_null(crs.name)},
          {"epsg", crs.epsg ? Json(crs.epsg) : Json(nullptr)},
          {"wkt", text_or_null(crs.wkt)}};
}

Json vertical_json(const Crs& crs) {
  return {{"name", text_or_null(crs.vertical_name)}, {"unit", text_or_null(crs.vertical_unit)}};
}

Json seconds_json(const std::vector<std::pair<std::string, double>>& seconds) {
  Json json = Json::object();
  for (const auto& [stage, value] : seconds) json[stage] = value;
  return json;
}

double as_stored(double height) {
  char text[32];
  auto [end, ec] = std::to_chars(text, text + sizeof text - 1, static_cast<float>(height));
  *end = '\0';
  return std::strtod(text, nullptr);
}

Json tileset_report_json(const std::optional<TilesetReport>& tileset) {
  if (!tileset) return nullptr;
  return {{"path", tileset->path},
          {"max_placement_error_m", tileset->max_placement_error_m},
          {"heights", tileset->heights}};
}

}  // namespace dsmplan
