// A terrain (DTM) that stands above the surface (DSM) it should lie under: a vertical datum
// mismatch, refused before anything is counted from it (ground.hpp, "A terrain that disagrees
// with its surface").
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/text.hpp"
#include "dsmplan/ground.hpp"

namespace dsmplan {

namespace {

constexpr int kLattice = 512;  // cells compared per axis at most

std::string percent(double share) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f %%", 100 * share);
  return text;
}

}  // namespace

std::optional<TerrainProblem> terrain_above_surface(const GroundGrid& terrain,
                                                    const std::function<double(double, double)>& surface_z,
                                                    const std::vector<NamedPlace>& places,
                                                    const std::string& surface_name) {
  if (terrain.empty()) return std::nullopt;
  const Grid& grid = terrain.grid();
  const std::string same_datum =
      ": are both in the same vertical datum? Every height counted from this terrain would be that much wrong (a "
      "mission's relative altitudes too low, below the path that was checked; --max-agl too lenient)";
  for (const NamedPlace& place : places) {
    const double above = terrain.measured_at(place.x, place.y) - surface_z(place.x, place.y);
    if (above > kTerrainAboveSurfaceM)  // false for NaN: nothing known there to compare
      return TerrainProblem{place.name, "the terrain stands " + two_decimals(above) + " m above " + surface_name +
                                            " there (x " + two_decimals(place.x) + ", y " + two_decimals(place.y) +
                                            "), more than the " + two_decimals(kTerrainAboveSurfaceM) +
                                            " m two surveys may differ by" + same_datum};
  }
  const int col_step = std::max(1, (grid.width + kLattice - 1) / kLattice);
  const int row_step = std::max(1, (grid.height + kLattice - 1) / kLattice);
  std::vector<double> excess;
  for (int row = row_step / 2; row < grid.height; row += row_step)
    for (int col = col_step / 2; col < grid.width; col += col_step) {
      if (terrain.was_hole(grid.index(col, row))) continue;
      const double x = grid.center_x(col), y = grid.center_y(row);
      const double above = grid.at(col, row) - surface_z(x, y);
      if (!std::isnan(above)) excess.push_back(above);
    }
  if (excess.empty()) return std::nullopt;
  const size_t high = std::count_if(excess.begin(), excess.end(), [](double e) { return e > kTerrainAboveSurfaceM; });
  const double share = double(high) / excess.size();
  if (share <= kTerrainAboveShare) return std::nullopt;
  std::nth_element(excess.begin(), excess.begin() + excess.size() / 2, excess.end());
  return TerrainProblem{"", "the terrain stands more than " + two_decimals(kTerrainAboveSurfaceM) + " m above " +
                                surface_name + " on " + percent(share) + " of the " + std::to_string(excess.size()) +
                                " cells compared (at most " + percent(kTerrainAboveShare) + " may: water, slopes), " +
                                "by " + two_decimals(excess[excess.size() / 2]) + " m in the median" + same_datum};
}

}  // namespace dsmplan
