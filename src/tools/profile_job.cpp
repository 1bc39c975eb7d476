// dsmplan profile: a planned path's height profile (render_profile(), src/picture/profile.cpp) as
// a PNG, and one line saying how close it comes to the DSM below and to the ceiling above.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/text.hpp"
#include "dsmplan/columns.hpp"
#include "dsmplan/flight.hpp"
#include "dsmplan/ground.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/picture_job.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/tools.hpp"
#include "tools/job_parts.hpp"

namespace dsmplan {

namespace {

std::string file_name(const std::string& path) { return std::filesystem::path(path).filename().string(); }

std::string extent(const Grid& frame) {
  char text[160];
  std::snprintf(text, sizeof text, "%.10g,%.10g,%.10g,%.10g", frame.x0, frame.y1(), frame.x1(), frame.y0);
  return text;
}

// The cells [c0, c1) x [r0, r1) of `frame` that hold the box, one more on each side, clipped;
// false when none do.
bool cells_around(const Grid& frame, double xmin, double ymin, double xmax, double ymax, int& c0, int& r0, int& c1,
                  int& r1) {
  auto col = [&](double x) { return std::floor((x - frame.x0) / frame.cell_x); };
  auto row = [&](double y) { return std::floor((frame.y0 - y) / frame.cell_y); };
  const double a = std::max(0.0, col(xmin) - 1), b = std::min(double(frame.width), col(xmax) + 2);
  const double c = std::max(0.0, row(ymax) - 1), d = std::min(double(frame.height), row(ymin) + 2);
  if (!(a < b && c < d)) return false;
  c0 = static_cast<int>(a), c1 = static_cast<int>(b), r0 = static_cast<int>(c), r1 = static_cast<int>(d);
  return true;
}

// Where along the path (x,y distance from its start) segment k (1-based) comes highest above the
// ground: sampled every tenth of a cell; the height itself is measured exactly (measure_path()).
double highest_point_at(const std::vector<Point3>& path, const GroundGrid& ground, size_t k,
                        const std::vector<double>& distance) {
  const Point3 &p = path[k - 1], &q = path[k];
  const double cell = std::min(ground.grid().cell_x, ground.grid().cell_y);
  const double length = std::hypot(q[0] - p[0], q[1] - p[1]);
  const int steps = std::max(1, static_cast<int>(std::ceil(length / (cell / 10))));
  double best = -INFINITY, at = 0;
  for (int i = 0; i <= steps; ++i) {
    const double t = double(i) / steps;
    const double above =
        ground.height_above({p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), p[2] + t * (q[2] - p[2])});
    if (above > best) best = above, at = t;
  }
  return distance[k - 1] + at * (distance[k] - distance[k - 1]);
}

}  // namespace

namespace {

// The picture's options and the output, before any file is read (render_profile() checks them again).
void check_profile_options(const ProfileJobOptions& options) {
  check_png_output(options.output, "");
  const ProfileOptions& picture = options.profile;
  if (picture.width < 240 || picture.height < 160 || picture.width > 30000 || picture.height > 30000)
    throw ArgumentError(picture.width < 240 || picture.width > 30000 ? "--width" : "--height",
                        "the picture must be 240 x 160 to 30000 x 30000 pixels");
  if (!(picture.safety >= 0 && picture.safety <= 1000))
    throw ArgumentError("--safety", "must be from 0 to 1000, got " + short_number(picture.safety));
  if (!(picture.max_agl > 0 && std::isfinite(picture.max_agl)))
    throw ArgumentError("--max-agl", "must be positive and finite");
}

struct Box {
  double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY;
};

// The path's x,y box; InputError naming the first point outside the DSM.
Box path_box(const std::vector<Point3>& path, const Grid& frame, const std::string& path_file) {
  Box box;
  for (size_t i = 0; i < path.size(); ++i) {
    const Point3& p = path[i];
    if (!(p[0] >= frame.x0 && p[0] <= frame.x1() && p[1] >= frame.y1() && p[1] <= frame.y0)) {
      char where[96];
      std::snprintf(where, sizeof where, "%.10g,%.10g", p[0], p[1]);
      throw InputError(
          path_file, "point " + std::to_string(i + 1),
          std::string(where) + " lies outside the DSM (" + extent(frame) + "); is the path in the DSM's CRS?");
    }
    box.xmin = std::min(box.xmin, p[0]), box.xmax = std::max(box.xmax, p[0]);
    box.ymin = std::min(box.ymin, p[1]), box.ymax = std::max(box.ymax, p[1]);
  }
  return box;
}

// The DTM's cells under the path (opened, checked against the DSM's frame before any cell is read).
struct TerrainWindow {
  std::unique_ptr<GridSource> source;
  int c0 = 0, r0 = 0, c1 = 0, r1 = 0;
};
TerrainWindow open_terrain(const std::string& dtm, const std::shared_ptr<const Grid>& in_memory, const Grid& frame,
                           const Box& box) {
  TerrainWindow w;
  w.source = in_memory ? std::make_unique<GridView>(*in_memory) : open_raster(dtm);
  const Grid& terrain = w.source->frame();
  if (terrain.crs.epsg && frame.crs.epsg && terrain.crs.epsg != frame.crs.epsg)
    throw InputError(dtm, "",
                     "its CRS is EPSG:" + std::to_string(terrain.crs.epsg) + ", the DSM's is EPSG:" +
                         std::to_string(frame.crs.epsg) + "; reproject it to the DSM's first (gdalwarp -t_srs)");
  if (!(terrain.x0 < frame.x1() && terrain.x1() > frame.x0 && terrain.y1() < frame.y0 && terrain.y0 > frame.y1()))
    throw InputError(dtm, "", "does not overlap the DSM: it covers " + extent(terrain) + ", the DSM " + extent(frame));
  if (!cells_around(terrain, box.xmin, box.ymin, box.xmax, box.ymax, w.c0, w.r0, w.c1, w.r1))
    throw InputError(dtm, "", "has no cell under the path (it covers " + extent(terrain) + ")");
  return w;
}

// The ceiling drawn over a terrain in another datum than the DSM would be drawn where it is not.
void check_terrain(const Grid& dtm, const Grid& dsm, const std::vector<Point3>& path,
                   const ProfileJobOptions& options) {
  std::vector<NamedPlace> places;
  for (size_t i = 0; i < path.size(); ++i) places.push_back({"point " + std::to_string(i + 1), path[i][0], path[i][1]});
  const auto surface_z = [&](double x, double y) { return double(dsm.height_at(x, y)); };
  if (const auto problem = terrain_above_surface(GroundGrid(dtm), surface_z, places, "the DSM " + options.dsm))
    throw InputError(options.dtm, problem->place, problem->problem);
}

ProfileReport report_of(const Image& image, const PathProfile& profile, const ProfileJobOptions& options,
                        bool ground_is_dtm) {
  ProfileReport result;
  result.output = options.output;
  result.width = image.width;
  result.height = image.height;
  result.length = profile.length;
  result.min_above_dsm = profile.min_above_dsm;
  result.min_above_dsm_at = profile.min_above_dsm_at;
  result.max_above_ground = profile.max_above_ground;
  result.max_above_ground_at = profile.max_above_ground_at;
  result.ground_is_dtm = ground_is_dtm;
  result.max_agl = options.profile.max_agl;
  return result;
}

// The free airspace's floor under the path (lowest_clear_height(), the plan stage's rule) every
// half cell along its x,y projection and at each of its points: (distance, height), -infinity
// (no column within the safety) as NaN, a gap in the line; and the path's least height above it
// at those places, and where. Empty for a safety of 0.
struct LowestClear {
  std::vector<std::array<double, 2>> line;
  double least_above = NAN, least_above_at = NAN;
};
LowestClear lowest_clear_along(const std::vector<Point3>& path, const Grid& dsm, double safety) {
  LowestClear out;
  if (!(safety > 0)) return out;
  const double step = 0.5 * std::min(dsm.cell_x, dsm.cell_y);
  double walked = 0;
  const auto add = [&](const Point3& p, double at) {
    const double z = lowest_clear_height(dsm, p[0], p[1], safety);
    out.line.push_back({at, std::isfinite(z) ? z : NAN});
    if (std::isfinite(z) && !(p[2] - z >= out.least_above)) out.least_above = p[2] - z, out.least_above_at = at;
  };
  for (size_t k = 0; k + 1 < path.size(); ++k) {
    const Point3 &a = path[k], &b = path[k + 1];
    const double leg = std::hypot(b[0] - a[0], b[1] - a[1]);
    const int pieces = std::max(1, static_cast<int>(std::ceil(leg / step)));
    for (int i = 0; i < pieces; ++i) {
      const double t = double(i) / pieces;
      add({a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])}, walked + t * leg);
    }
    walked += leg;
  }
  add(path.back(), walked);
  return out;
}

}  // namespace

std::pair<Image, ProfileReport> profile_picture(const ProfileJobOptions& options, const Progress& progress) {
  check_profile_options(options);
  const std::vector<Point3> path = options.path_points.empty() ? read_waypoints_csv(options.path) : options.path_points;
  if (path.size() < 2) throw InputError(options.path, "", "a path needs at least two points");

  // Only the windows around the path are read: the DSM may be a whole city's mosaic.
  const std::unique_ptr<GridSource> dsm_source =
      options.dsm_grid ? std::make_unique<GridView>(*options.dsm_grid) : open_raster(options.dsm);
  const Grid& frame = dsm_source->frame();
  require_projected(frame.crs, options.dsm, centre_of(frame));
  const Box box = path_box(path, frame, options.path);
  TerrainWindow terrain_window;
  if (!options.dtm.empty() || options.dtm_grid)
    terrain_window = open_terrain(options.dtm, options.dtm_grid, frame, box);
  ZoneLayer zones = options.profile.zones;
  const ZoneLayer files = read_zone_layer(options.no_fly, frame.crs);
  zones.zones.insert(zones.zones.end(), files.zones.begin(), files.zones.end());
  if (!options.no_fly.blocking.empty()) zones.airspace = files.airspace;
  report(progress, 0.05);

  int c0 = 0, r0 = 0, c1 = 0, r1 = 0;
  const double reach = options.profile.safety;  // the columns within the safety of the path: its lowest clear height
  cells_around(frame, box.xmin - reach, box.ymin - reach, box.xmax + reach, box.ymax + reach, c0, r0, c1,
               r1);  // the path is inside: never empty
  require_memory(options.dsm, "", 4.0 * (c1 - c0) * (r1 - r0));
  const Grid dsm = read_window(*dsm_source, c0, r0, c1 - c0, r1 - r0);
  report(progress, 0.45);
  Grid dtm;
  if (const TerrainWindow& w = terrain_window; w.source) {
    require_memory(options.dtm, "", 4.0 * (w.c1 - w.c0) * (w.r1 - w.r0));
    dtm = read_window(*w.source, w.c0, w.r0, w.c1 - w.c0, w.r1 - w.r0);
    check_terrain(dtm, dsm, path, options);
  }
  report(progress, 0.8);

  ProfileOptions drawing = options.profile;
  // Heights above the ground from the DTM, else the DSM, as `dsmplan plan` counts them.
  if (!options.waypoints.empty())
    drawing.waypoints = read_picture_waypoints(
        options.waypoints, [&] { return terrain_window.source ? &dtm : &dsm; }, terrain_window.source ? "dtm" : "dsm",
        "");
  const LowestClear clear = lowest_clear_along(path, dsm, options.profile.safety);
  drawing.lowest_clear = clear.line;
  drawing.zones = std::move(zones);
  if (drawing.title.empty())
    drawing.title = "Height profile: " + file_name(options.path) + " over " + file_name(options.dsm);
  const Grid* terrain = terrain_window.source ? &dtm : nullptr;
  Image image = render_profile(path, dsm, terrain, drawing);
  PathProfile profile = profile_path(path, dsm, terrain);
  // The height above ground is the plan stage's measure (measure_path()), the one `dsmplan plan`
  // verifies and reports: the same figure for the same path, whichever command says it.
  const GroundGrid ground(terrain ? dtm : dsm);
  const PathMeasures measured = measure_path(path, ground, nullptr, 0);
  profile.max_above_ground = std::isinf(measured.max_agl_m) ? NAN : measured.max_agl_m;
  profile.max_above_ground_at = std::isnan(profile.max_above_ground)
                                    ? NAN
                                    : highest_point_at(path, ground, measured.max_agl_segment, profile.distance);
  ProfileReport result = report_of(image, profile, options, terrain != nullptr);
  result.min_above_lowest_clear = clear.least_above;
  result.min_above_lowest_clear_at = clear.least_above_at;
  return {std::move(image), result};
}

ProfileReport profile_job(const ProfileJobOptions& options, const Progress& progress) {
  const auto [image, result] = profile_picture(options, sub_progress(progress, 0, 0.95));
  write_png(image, options.output);
  report(progress, 1);
  return result;
}

std::string to_text(const ProfileReport& r) {
  const char* ground = r.ground_is_dtm ? "DTM" : "DSM";
  char below[128], above[160];
  if (std::isfinite(r.min_above_dsm)) {
    // Within half a centimetre of zero it reads "0.00", not "-0.00".
    const double least = std::abs(r.min_above_dsm) < 0.005 ? 0.0 : r.min_above_dsm;
    std::snprintf(below, sizeof below, "least %.2f m above the DSM below it (at %.1f m)", least, r.min_above_dsm_at);
  } else {
    std::snprintf(below, sizeof below, "no DSM data under it");
  }
  if (std::isfinite(r.max_above_ground)) {
    const double spare = r.max_agl - r.max_above_ground;
    std::snprintf(above, sizeof above, "at most %.2f m above the %s (at %.1f m), ceiling %s + %g m %s %.2f m%s",
                  r.max_above_ground, ground, r.max_above_ground_at, ground, r.max_agl,
                  spare >= 0 ? "kept with" : "EXCEEDED by", std::abs(spare), spare >= 0 ? " to spare" : "");
  } else {
    std::snprintf(above, sizeof above, "no %s data under it: ceiling %s + %g m not known there", ground, ground,
                  r.max_agl);
  }
  char line[512];
  std::snprintf(line, sizeof line, "%s: path %.1f m along the ground, %s, %s\n", r.output.c_str(), r.length, below,
                above);
  return line;
}

Json to_json(const ProfileReport& r) {
  const auto number = [](double v) { return std::isnan(v) ? Json() : Json(v); };
  return {{"output", r.output},
          {"width", r.width},
          {"height", r.height},
          {"length_m", r.length},
          {"min_above_dsm_m", number(r.min_above_dsm)},
          {"min_above_dsm_at_m", number(r.min_above_dsm_at)},
          {"min_above_lowest_clear_m", number(r.min_above_lowest_clear)},
          {"min_above_lowest_clear_at_m", number(r.min_above_lowest_clear_at)},
          {"max_above_ground_m", number(r.max_above_ground)},
          {"max_above_ground_at_m", number(r.max_above_ground_at)},
          {"ground", r.ground_is_dtm ? "dtm" : "dsm"},
          {"max_agl_m", number(r.max_agl)}};
}

}  // namespace dsmplan
