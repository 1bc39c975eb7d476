// dsmplan render: pictures like the paper's Figures 6 and 7 (a crop from above, hillshaded, the
// mesh's edges drawn; several meshes side by side), as one PNG.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "core/text.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/picture_job.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/roadmap_file.hpp"
#include "dsmplan/tools.hpp"
#include "tools/job_parts.hpp"

namespace dsmplan {

namespace {

std::string file_name(const std::string& path) { return std::filesystem::path(path).filename().string(); }

// A mesh drawn over the wrong DSM would look plausible and mean nothing: refuse what surely is.
void check_mesh_fits(const Mesh& mesh, const std::string& path, const Grid& dsm) {
  if (mesh.crs.epsg && dsm.crs.epsg && mesh.crs.epsg != dsm.crs.epsg) {
    throw InputError(
        path, "",
        "its CRS is EPSG:" + std::to_string(mesh.crs.epsg) + ", the DSM's is EPSG:" + std::to_string(dsm.crs.epsg));
  }
  if (mesh.vertices.empty()) return;
  double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
  for (const Vertex& v : mesh.vertices) {
    xmin = std::min(xmin, v.x), xmax = std::max(xmax, v.x), ymin = std::min(ymin, v.y), ymax = std::max(ymax, v.y);
  }
  if (xmax < dsm.x0 || xmin > dsm.x1() || ymax < dsm.y1() || ymin > dsm.y0) {
    throw InputError(path, "", "the mesh lies wholly outside the DSM; is it in the DSM's CRS?");
  }
}

}  // namespace

void check_png_output(const std::string& output, const std::string& flag) {
  const std::string extension = lower_case(std::filesystem::path(output).extension().string());
  if (extension != ".png")
    throw ArgumentError(flag.empty() ? output : flag,
                        "the picture is written as PNG: name it .png, got '" + output + "'");
  check_writable(output);  // a missing folder is known now, not after the drawing
}

namespace {

// Everything that can be checked is checked before the long work starts.
void check_render_options(const RenderJobOptions& options, size_t panels) {
  check_png_output(options.output, "");
  if (options.resolution && !(*options.resolution > 0 && std::isfinite(*options.resolution)))
    throw ArgumentError("--res", "must be a positive number of CRS units");
  if (!(options.render.pixels_per_cell > 0 && std::isfinite(options.render.pixels_per_cell)))
    throw ArgumentError("--zoom", "pixels per cell must be a positive number");
  if (const auto& w = options.render.window) {
    if (!(std::isfinite(w->xmin) && std::isfinite(w->ymin) && std::isfinite(w->xmax) && std::isfinite(w->ymax)) ||
        !(w->xmin < w->xmax && w->ymin < w->ymax))
      throw ArgumentError("--window", "must be xmin,ymin,xmax,ymax with xmin < xmax and ymin < ymax");
  }
  if (options.titles.size() > panels)
    throw ArgumentError("--title", std::to_string(options.titles.size()) + " titles for " + std::to_string(panels) +
                                       (panels == 1 ? " panel" : " panels"));
}

}  // namespace

std::pair<Image, RenderReport> render_picture(const RenderJobOptions& options, const Progress& progress) {
  const size_t panels = std::max<size_t>(1, options.meshes.size());
  check_render_options(options, panels);
  Grid dsm =
      options.dsm_grid ? *options.dsm_grid : read_raster(options.dsm, options.read, sub_progress(progress, 0, 0.25));
  // Heights above the ground are measured from the DSM as read, as `dsmplan plan` counts them without a DTM.
  const std::vector<Point3> waypoints = options.waypoints.empty()
                                            ? std::vector<Point3>{}
                                            : read_picture_waypoints(
                                                  options.waypoints, [&] { return &dsm; }, "dsm", "");
  if (options.resolution && (*options.resolution != dsm.cell_x || *options.resolution != dsm.cell_y)) {
    dsm = resample(dsm, *options.resolution, Resampling::Median, sub_progress(progress, 0.25, 0.3));
  }

  // Layers, read before any drawing so a bad file costs nothing: roadmap under paths under waypoints.
  // The caller's own layers (in memory) go over the files'.
  RenderOptions layered = options.render;
  layered.lines.clear(), layered.markers.clear();
  const ZoneLayer files = read_zone_layer(options.no_fly, dsm.crs);
  layered.zones.zones.insert(layered.zones.zones.end(), files.zones.begin(), files.zones.end());
  if (!options.no_fly.blocking.empty()) layered.zones.airspace = files.airspace;
  if (!options.roadmap.empty()) {
    const Roadmap map = read_roadmap(options.roadmap, nullptr);
    LineLayer edges;
    edges.colour = {40, 90, 200};
    edges.width = 1;
    edges.alpha = 0.25f;
    edges.halo = false;
    for (uint32_t i = 0; i < map.nodes.size(); ++i)
      for (uint32_t k = map.start[i]; k < map.start[i + 1]; ++k)
        if (map.neighbour[k] > i) edges.polylines.push_back({map.nodes[i], map.nodes[map.neighbour[k]]});
    layered.lines.push_back(std::move(edges));
  }
  for (const std::string& path : options.paths) {
    LineLayer line;
    line.polylines.push_back(read_waypoints_csv(path));
    if (line.polylines.back().size() < 2) throw InputError(path, "", "a path needs at least two points");
    layered.lines.push_back(std::move(line));
  }
  if (!options.waypoints.empty()) layered.markers.push_back(MarkerLayer{waypoints});
  layered.lines.insert(layered.lines.end(), options.render.lines.begin(), options.render.lines.end());
  layered.markers.insert(layered.markers.end(), options.render.markers.begin(), options.render.markers.end());

  std::vector<Image> images;
  for (size_t i = 0; i < panels; ++i) {
    const double begin = 0.3 + 0.6 * i / panels, end = 0.3 + 0.6 * (i + 1) / panels;
    RenderOptions render = layered;
    if (options.meshes.empty()) {
      render.title = i < options.titles.size() ? options.titles[i] : file_name(options.dsm);
      images.push_back(render_view(dsm, nullptr, render));
    } else {
      const std::string& path = options.meshes[i];
      const Mesh mesh = read_mesh(path, sub_progress(progress, begin, (begin + end) / 2));
      check_mesh_fits(mesh, path, dsm);
      render.title = i < options.titles.size() ? options.titles[i] : file_name(path);
      images.push_back(render_view(dsm, &mesh, render));
    }
    report(progress, end);
  }
  Image picture = images.size() == 1 ? std::move(images.front()) : side_by_side(images);
  RenderReport result;
  result.output = options.output;
  result.width = picture.width;
  result.height = picture.height;
  result.panels = panels;
  result.window = options.render.window.value_or(Window{dsm.x0, dsm.y1(), dsm.x1(), dsm.y0});
  result.zoom = options.render.pixels_per_cell;
  return {std::move(picture), result};
}

RenderReport render_job(const RenderJobOptions& options, const Progress& progress) {
  const auto [picture, result] = render_picture(options, sub_progress(progress, 0, 0.95));
  write_png(picture, options.output);
  report(progress, 1);
  return result;
}

Json to_json(const RenderReport& report) {
  const Window& w = report.window;
  return {{"output", report.output},
          {"width", report.width},
          {"height", report.height},
          {"panels", report.panels},
          {"window", {w.xmin, w.ymin, w.xmax, w.ymax}},
          {"zoom", report.zoom}};
}

}  // namespace dsmplan
