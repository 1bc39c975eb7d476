// dsmplan plan --render / --profile: the pictures of the flight as flown, drawn by the functions
// of `dsmplan render` and `dsmplan profile` (render_job.cpp, profile_job.cpp), so that one run
// gives the path, the mission and their pictures, and each picture is the one those commands draw
// of the written CSV.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <utility>

#include "dsmplan/picture_job.hpp"
#include "dsmplan/raster_io.hpp"
#include "tools/job_parts.hpp"
#include "tools/plan_parts.hpp"

namespace dsmplan {

namespace {

// The name the profile's title gives the path: the first CSV written, else the first output.
std::string path_name(const PlanJobOptions& options) {
  if (output_kind(options.output, options.format).ext == "csv") return options.output;
  for (const std::string& output : options.more_outputs)
    if (output_kind(output, "").ext == "csv") return output;
  return options.output;
}

std::string file_name(const std::string& path) { return std::filesystem::path(path).filename().string(); }

// The picture from above frames the flight, not the whole DSM (a city's mosaic): the box of the
// path and the waypoints widened by 15 % of its larger side (at least 30 m), in whole CRS units,
// clipped to the DSM; about 1600 pixels across its larger side, at most 4 per cell.
void frame_flight(const std::vector<Point3>& flown, const std::vector<Point3>& waypoints, const Grid& dsm,
                  RenderOptions& render) {
  Window box{INFINITY, INFINITY, -INFINITY, -INFINITY};
  for (const std::vector<Point3>* points : {&flown, &waypoints})
    for (const Point3& p : *points) {
      box.xmin = std::min(box.xmin, p[0]), box.xmax = std::max(box.xmax, p[0]);
      box.ymin = std::min(box.ymin, p[1]), box.ymax = std::max(box.ymax, p[1]);
    }
  const double margin = std::max(30.0, 0.15 * std::max(box.xmax - box.xmin, box.ymax - box.ymin));
  Window w{std::max(dsm.x0, std::floor(box.xmin - margin)), std::max(dsm.y1(), std::floor(box.ymin - margin)),
           std::min(dsm.x1(), std::ceil(box.xmax + margin)), std::min(dsm.y0, std::ceil(box.ymax + margin))};
  const double cells = std::max((w.xmax - w.xmin) / dsm.cell_x, (w.ymax - w.ymin) / dsm.cell_y);
  render.window = w;
  render.pixels_per_cell = std::clamp(std::floor(1600 / cells * 100) / 100, 0.01, 4.0);
}

}  // namespace

void check_flight_pictures(const PlanJobOptions& options, bool dsm_input) {
  for (const auto& [flag, output] :
       {std::pair{"--render", &options.render}, std::pair{"--profile", &options.profile}}) {
    if (output->empty()) continue;
    check_png_output(*output, flag);
    if (options.dsm.empty() && !dsm_input)
      throw ArgumentError(flag, "draws the flight over the DSM: give --dsm (the raster the mesh was made of)");
  }
}

FlightPictures draw_flight_pictures(const PlanJobOptions& options, const FlightPlan& flight,
                                    const std::vector<Point3>& waypoints, const PictureData& data,
                                    const Progress& progress) {
  FlightPictures pictures;
  const std::vector<Point3> flown = flown_path(flight);
  if (!options.render.empty()) {
    RenderJobOptions render;
    render.dsm = data.dsm_file;
    render.dsm_grid = data.dsm;
    render.output = options.render;
    render.titles = {file_name(path_name(options)) + " over " + file_name(data.dsm_file)};
    frame_flight(flown, waypoints, data.dsm ? *data.dsm : open_raster(data.dsm_file)->frame(), render.render);
    render.render.zones = data.zones;
    LineLayer path;
    path.polylines.push_back(flown);
    render.render.lines.push_back(std::move(path));
    render.render.markers.push_back(MarkerLayer{waypoints});
    auto [picture, report] = render_picture(render, sub_progress(progress, 0, 0.5));
    pictures.render = std::move(picture);
    pictures.render_report = report;
  }
  if (!options.profile.empty()) {
    ProfileJobOptions profile;
    profile.dsm = data.dsm_file;
    profile.dsm_grid = data.dsm;
    profile.dtm = options.dtm;
    profile.dtm_grid = data.dtm;
    profile.path = path_name(options);
    profile.path_points = flown;
    profile.output = options.profile;
    profile.profile.safety = options.plan.safety;
    profile.profile.max_agl = options.plan.max_agl;
    profile.profile.waypoints = waypoints;
    profile.profile.zones = data.zones;
    auto [picture, report] = profile_picture(profile, sub_progress(progress, 0.5, 1));
    pictures.profile = std::move(picture);
    pictures.profile_report = report;
  }
  return pictures;
}

void write_flight_pictures(const PlanJobOptions& options, const FlightPictures& pictures) {
  if (pictures.render) write_png(*pictures.render, options.render);
  if (pictures.profile) write_png(*pictures.profile, options.profile);
}

}  // namespace dsmplan
