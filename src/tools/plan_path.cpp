// dsmplan plan: a collision-free path through waypoints over an obstacle mesh, by the paper's
// planner (Adolf & Hirschmueller, Section 5: a Halton PRM with a 2 m safety distance), with the
// path's clearance measured afresh on the written points.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>

#include "core/mapped_file.hpp"
#include "core/text.hpp"
#include "dsmplan/columns.hpp"
#include "dsmplan/corridor.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/point_io.hpp"
#include "dsmplan/roadmap_file.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/wgs84.hpp"
#include "dsmplan/wpml.hpp"
#include "tools/job_parts.hpp"
#include "tools/mission_parts.hpp"
#include "tools/report_json.hpp"

namespace dsmplan {

namespace {

std::string lower_extension(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  const size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  return lower_case(path.substr(dot + 1));
}

void take_planner_figures(const PlanResult& result, PlanReport& report) {
  report.roadmap_nodes = result.roadmap_nodes;
  report.roadmap_edges = result.roadmap_edges;
  report.seconds_roadmap = result.seconds_roadmap;
  report.seconds_query = result.seconds_query;
  report.seconds_smooth = result.seconds_smooth;
  report.refined_samples = result.refined_samples;
}

bool is_geojson(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == "geojson" || ext == "json";
}

// The index kept in `path` when it exists and was built from `input_hash`; std::nullopt when the
// file is missing or stale (then built and written anew); InputError when it is no index file or
// is damaged, so a file the user named by mistake is never overwritten.
std::optional<ClearanceIndex> open_kept_index(const std::string& path, uint64_t input_hash,
                                              ClearanceIndex::Source* source) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::nullopt;
  return ClearanceIndex::open(path, input_hash, {}, source);
}

// A raster that must share the mesh's CRS and lie under the flight: InputError naming it otherwise.
Grid read_companion(const std::string& path, const char* what, const Crs& mesh_crs, double xmin, double ymin,
                    double xmax, double ymax) {
  Grid grid = read_raster(path);
  if (grid.crs.epsg && mesh_crs.epsg && grid.crs.epsg != mesh_crs.epsg)
    throw InputError(path, "",
                     std::string("the ") + what + "'s CRS is EPSG:" + std::to_string(grid.crs.epsg) +
                         ", the mesh's EPSG:" + std::to_string(mesh_crs.epsg));
  if (!(grid.x1() > xmin && grid.x0 < xmax && grid.y0 > ymin && grid.y1() < ymax))
    throw InputError(path, "",
                     std::string("the ") + what + " (x " + two_decimals(grid.x0) + " to " + two_decimals(grid.x1()) +
                         ", y " + two_decimals(grid.y1()) + " to " + two_decimals(grid.y0) +
                         ") does not overlap the mesh (x " + two_decimals(xmin) + " to " + two_decimals(xmax) + ", y " +
                         two_decimals(ymin) + " to " + two_decimals(ymax) + ")");
  // The DSM's columns are what the path is checked against: where the mesh reaches beyond them,
  // a path could fly unchecked (the terrain only bounds the ceiling, and beyond it nothing flies).
  const double hx = grid.cell_x / 2 + 1e-9, hy = grid.cell_y / 2 + 1e-9;
  if (std::string(what) == "DSM" &&
      !(grid.x0 <= xmin + hx && grid.x1() >= xmax - hx && grid.y1() <= ymin + hy && grid.y0 >= ymax - hy))
    throw InputError(path, "",
                     "the DSM (x " + two_decimals(grid.x0) + " to " + two_decimals(grid.x1()) + ", y " +
                         two_decimals(grid.y1()) + " to " + two_decimals(grid.y0) + ") does not cover the mesh (x " +
                         two_decimals(xmin) + " to " + two_decimals(xmax) + ", y " + two_decimals(ymin) + " to " +
                         two_decimals(ymax) + "): a path there would go unchecked");
  return grid;
}

// InputError naming every waypoint of `problems` in one line (the first is the place), when any.
void refuse_waypoints(const std::string& file, const std::vector<PlanResult::Invalid>& problems) {
  if (problems.empty()) return;
  throw InputError(file, "waypoint " + std::to_string(problems.front().waypoint + 1), waypoint_problems(problems));
}

// Every waypoint closer than the safety distance to the DSM's columns, with the column that
// stands nearest, refused before any work on the mesh (the mesh would only refuse it later,
// after it is indexed).
void refuse_near_columns(const std::vector<Point3>& waypoints, const Grid& columns, const PlanJobOptions& options) {
  std::vector<PlanResult::Invalid> problems;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    const NearestColumn c = nearest_column(columns, waypoints[i], options.plan.safety);
    if (!c.found || c.distance >= options.plan.safety) continue;
    const std::string where =
        "the column at x " + two_decimals(c.x) + ", y " + two_decimals(c.y) + " (top " + two_decimals(c.top) + " m)";
    problems.push_back({i, c.distance <= 0
                               ? "inside the DSM (under its surface): in " + where
                               : "closer than the safety distance to the DSM: " + two_decimals(c.distance) +
                                     " m from " + where + ", --safety " + two_decimals(options.plan.safety)});
  }
  refuse_waypoints(options.waypoints, problems);
}

// InputError naming every waypoint above the ceiling (in the planner's words), before any work.
void refuse_above_ceiling(const std::vector<Point3>& waypoints, const GroundGrid& ground,
                          const PlanJobOptions& options) {
  std::vector<PlanResult::Invalid> problems;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    const double above = ground.height_above(waypoints[i]);
    if (above <= options.plan.max_agl) continue;
    problems.push_back({i, std::isinf(above)
                               ? "outside the ground's extent (no ground below it to count --max-agl from)"
                               : "above the ceiling: " + two_decimals(above) + " m above the ground, --max-agl " +
                                     two_decimals(options.plan.max_agl)});
  }
  refuse_waypoints(options.waypoints, problems);
}

// The written path held to both limits once more, measured on its own: clearance to the DSM's
// columns (holes as high as their rim) at least the safety distance, less 1 cm for the
// rounding of what is written; height above the ground at most max_agl, plus 5 cm. A path
// planned as above always passes: failing is a bug, and nothing is written.
void verify_limits(const std::vector<Point3>& path, const Grid* columns, const GroundGrid& ground,
                   const PlanJobOptions& options, double cap, PlanReport& report, const std::string& place) {
  report.max_agl_m = -INFINITY;
  size_t worst_agl = 0, worst_columns = 0;
  for (size_t k = 1; k < path.size(); ++k) {
    const double above = ground.max_height_above(path[k - 1], path[k]);
    if (above > report.max_agl_m) report.max_agl_m = above, worst_agl = k;
  }
  if (columns) {
    report.min_clearance_dsm_m = cap;
    for (size_t k = 1; k < path.size(); ++k) {
      const double d =
          column_clearance(*columns, path[k - 1], path[k], report.min_clearance_dsm_m);  // up to the least so far
      if (d < report.min_clearance_dsm_m) report.min_clearance_dsm_m = d, worst_columns = k;
    }
    report.dsm_tolerance_m = 0.01;
    if (!(report.min_clearance_dsm_m >= options.plan.safety - report.dsm_tolerance_m))
      throw InputError(place, "",
                       "the path passes " + two_decimals(report.min_clearance_dsm_m) +
                           " m from the DSM's columns (segment " + std::to_string(worst_columns) +
                           "), closer than --safety " + two_decimals(options.plan.safety) +
                           ": a bug, please report it; nothing written");
  }
  if (!(report.max_agl_m <= options.plan.max_agl + 0.05))
    throw InputError(place, "",
                     "the path rises " + two_decimals(report.max_agl_m) + " m above the ground (segment " +
                         std::to_string(worst_agl) + "), above --max-agl " + two_decimals(options.plan.max_agl) +
                         ": a bug, please report it; nothing written");
}

// InputError naming `terrain_path` (and the surface) when the terrain stands above the surface it
// should lie under (terrain_above_surface()): at a waypoint, home, the landing, or over the cells.
void refuse_terrain_above(const GroundGrid& terrain, const std::function<double(double, double)>& surface_z,
                          const std::vector<Point3>& waypoints, const detail::MissionSite* site,
                          const std::string& terrain_path, const std::string& surface_name) {
  std::vector<NamedPlace> places;
  if (site) places.push_back({"home", site->home[0], site->home[1]});
  for (size_t i = 0; i < waypoints.size(); ++i)
    places.push_back({"waypoint " + std::to_string(i + 1), waypoints[i][0], waypoints[i][1]});
  if (site && site->end == MissionEnd::land) places.push_back({"the landing", site->land[0], site->land[1]});
  if (const auto problem = terrain_above_surface(terrain, surface_z, places, surface_name))
    throw InputError(terrain_path, problem->place, problem->problem);
}

}  // namespace

PlanReport plan_job(const PlanJobOptions& options, const Progress& progress) {
  // The format: --of, else the extension (as GDAL's newer command line chooses).
  std::string out_ext = lower_case(options.format.empty() ? lower_extension(options.output) : options.format);
  if (out_ext == "json") out_ext = "geojson";
  const bool geojson_out = out_ext == "geojson";
  // Missions and KML state heights above mean sea level (EGM96); GeoJSON above the ellipsoid.
  const bool msl_out = out_ext == "plan" || out_ext == "waypoints" || out_ext == "kmz" || out_ext == "kml";
  if (!options.format.empty() && out_ext != "csv" && !geojson_out && !msl_out)
    throw ArgumentError("--of",
                        "unknown path format '" + options.format + "' (use csv, geojson, plan, waypoints, kmz or kml)");
  if (out_ext != "csv" && !geojson_out && !msl_out)
    throw ArgumentError("-o",
                        "the path is written as .csv (x,y,z in the mesh's CRS), .geojson (WGS 84), .plan "
                        "(QGroundControl), .waypoints (QGC WPL 110), .kmz (DJI WPML) or .kml, got '" +
                            options.output + "'");
  // Missions take off from home and end (MissionJobOptions); the other formats are the path alone.
  const bool mission_out = out_ext == "plan" || out_ext == "waypoints" || out_ext == "kmz";
  if (!mission_out && (!std::isnan(options.mission.home[0]) || !std::isnan(options.mission.home[1])))
    throw ArgumentError("--home", "applies to missions (.plan, .waypoints, .kmz), not to a ." + out_ext + " path");
  if (options.mission.format.extrude && out_ext != "kml")
    throw ArgumentError("--extrude", "applies to .kml paths, not to a ." + out_ext + " path");
  if (!mission_out && options.mission.end)
    throw ArgumentError("--end", "applies to missions (.plan, .waypoints, .kmz), not to a ." + out_ext + " path");
  if (mission_out)
    for (const auto& [flag, speed] : {std::pair{"--speed", options.mission.format.speed},
                                      std::pair{"--hover-speed", options.mission.format.hover_speed}})
      if (!(speed > 0 && speed <= 100))
        throw ArgumentError(flag, "must lie in (0, 100] m/s, got " + two_decimals(speed));
  check_plan_options(options.plan);
  check_writable(options.output);  // a missing folder is known now, not after the planning
  if (!options.roadmap.empty() && options.plan.planner != PlannerKind::prm)
    throw ArgumentError("--roadmap", "only the prm planner keeps a roadmap; rrtconnect grows its trees per query");
  PlanReport report;
  report.planner = options.plan.planner == PlannerKind::prm ? "prm" : "rrtconnect";
  report.mesh = options.mesh;
  report.waypoints = options.waypoints;
  report.output = options.output;

  const bool geo_in = is_geojson(options.waypoints);
  const std::vector<Point3> read_points =
      geo_in ? read_waypoints_geojson(options.waypoints) : read_waypoints_csv(options.waypoints);
  report.waypoint_count = read_points.size();
  if (read_points.size() < 2)
    throw InputError(options.waypoints, "",
                     "a path needs at least two waypoints, the file has " + std::to_string(read_points.size()));

  Stopwatch clock, reading;
  double seconds_reading = 0;  // of the files, within seconds_load
  // A DSM (raster, VRT mosaic) instead of a mesh: planned along a corridor, window by window.
  const bool corridor = !is_mesh_file(options.mesh);
  std::unique_ptr<GridSource> city;
  Mesh mesh;
  // A kept index (--index) that fits the mesh file: without --dsm nothing joins the mesh, so the
  // file's hash names the index and only the mesh's header (its CRS) is read; the vertices and
  // triangles are in the index already.
  std::optional<ClearanceIndex> kept;
  ClearanceIndex::Source kept_source;
  uint64_t mesh_file_hash = 0;
  if (corridor && !options.index.empty())
    throw ArgumentError("--index", "a DSM input is planned window by window along a corridor; no index is kept");
  if (!corridor && !options.index.empty()) {
    reading.lap();
    mesh_file_hash = file_content_hash(options.mesh);
    if (options.dsm.empty()) kept = open_kept_index(options.index, mesh_file_hash, &kept_source);
    if (kept) mesh.crs = read_mesh_crs(options.mesh);
    seconds_reading += reading.lap();
  }
  if (corridor) {
    if (!options.roadmap.empty())
      throw ArgumentError("--roadmap", "a DSM input is planned window by window along a corridor; no roadmap is kept");
    if (!options.dsm.empty())
      throw ArgumentError("--dsm", "the input " + options.mesh + " is the DSM already; its columns are checked");
    city = open_raster(options.mesh);
    mesh.crs = city->frame().crs;
  } else if (!kept) {
    reading.lap();
    mesh = read_mesh(options.mesh, sub_progress(progress, 0, 0.2));
    seconds_reading += reading.lap();
    if (mesh.triangles.empty()) throw InputError(options.mesh, "", "the mesh has no triangles");
  }
  // A kept index was saved only after this very file (its CRS comments are in the bytes that
  // name the index) passed the check: it is not asked again, which would cost PROJ's database
  // (5-7 ms, a tenth of such a run).
  if (!kept) require_projected(mesh.crs, options.mesh, corridor ? centre_of(city->frame()) : centre_of(mesh));
  std::optional<Wgs84Transform> wgs84;
  if (geo_in || geojson_out) {
    wgs84.emplace(mesh.crs, HeightReference::Ellipsoid, options.vertical);
    report.transformation = wgs84->description();
  }
  // Made before planning, so that an unknown or approximate vertical reference stops the run early.
  std::optional<Wgs84Transform> to_msl;
  if (msl_out) {
    to_msl.emplace(mesh.crs, HeightReference::MeanSeaLevel, options.vertical);
    report.transformation += (report.transformation.empty() ? "" : "; path by: ") + to_msl->description();
  }
  std::vector<Point3> waypoints = read_points;
  if (geo_in)
    for (Point3& p : waypoints) p = wgs84->from_wgs84(p);
  PlanResult result;
  // A mission's home, takeoff and landing, and the waypoints with the legs they add.
  detail::MissionSite site;
  std::vector<Point3> route = waypoints;
  const auto from_lonlat = [&](double lon, double lat) { return to_msl->from_wgs84({lon, lat, 0}); };
  const auto failure_place = [&](const PlanResult& r) {
    return mission_out ? detail::mission_place(r, site, waypoints.size()) : r.place();
  };
  // Why the planner refused, every invalid waypoint named as the user numbers them.
  const auto failure_problems = [&](const PlanResult& r) {
    return r.problems([&](size_t k) {
      PlanResult other = r;
      other.waypoint = k;
      return failure_place(other);
    });
  };
  if (corridor) {
    CorridorOptions along = options.corridor;
    if (!options.dtm.empty()) {
      const Grid& frame = city->frame();
      along.terrain = std::make_shared<GroundGrid>(
          read_companion(options.dtm, "DTM", mesh.crs, frame.x0, frame.y1(), frame.x1(), frame.y0));
    }
    report.ground = options.dtm.empty() ? "dsm" : "dtm";
    // A mission flies straight from item to item (see below): dropped before measuring.
    if (mission_out) {
      along.finish_piece = [](const std::vector<Point3>& path) { return drop_straight_points(path, 0.01); };
      const auto ground_z = [&](double x, double y) {
        if (along.terrain) return -along.terrain->height_above({x, y, 0});
        int col = 0, row = 0;
        if (!city->frame().cell_at(x, y, col, row)) return double(NAN);
        return double(read_window(*city, col, row, 1, 1).z[0]);
      };
      site = detail::mission_site(options.mission, waypoints, ground_z, from_lonlat);
      report.home_ground = report.ground;
      if (along.terrain) {
        report.home_ground_uncertainty_m = along.terrain->spread_at(site.home[0], site.home[1]);
      } else {  // the DSM's 3 x 3 cells around home (mission_site() found home on it)
        const Grid& frame = city->frame();
        int col = 0, row = 0;
        frame.cell_at(site.home[0], site.home[1], col, row);
        const int c0 = std::max(0, col - 1), r0 = std::max(0, row - 1);
        const GroundGrid around(
            read_window(*city, c0, r0, std::min(frame.width, col + 2) - c0, std::min(frame.height, row + 2) - r0));
        report.home_ground_uncertainty_m = around.spread_at(site.home[0], site.home[1]);
      }
    }
    if (along.terrain) {
      // The DSM a row at a time: the comparison walks its lattice row by row.
      const Grid& frame = city->frame();
      std::vector<float> heights(frame.width);
      int row_read = -1;
      const auto surface_z = [&](double x, double y) {
        int col = 0, row = 0;
        if (!frame.cell_at(x, y, col, row)) return double(NAN);
        if (row != row_read) city->read(0, row, frame.width, 1, heights.data()), row_read = row;
        return double(heights[col]);
      };
      refuse_terrain_above(*along.terrain, surface_z, waypoints, mission_out ? &site : nullptr, options.dtm,
                           "the DSM " + options.mesh);
    }
    if (mission_out) {
      detail::check_vertical_legs_in(*city, site, waypoints, options.plan.safety);
      route = detail::route_waypoints(waypoints, site);
    }
    report.seconds_load = clock.lap();
    const CorridorResult planned = plan_corridor(*city, route, options.plan, along, sub_progress(progress, 0, 0.95));
    result = planned.plan;
    report.seconds_load += planned.seconds_windows;
    take_planner_figures(result, report);
    report.corridor_windows = planned.windows;
    report.corridor_largest_window_cells = planned.largest_window_cells;
    if (result.status != PlanStatus::Solved)
      throw InputError(options.waypoints, failure_place(result), failure_problems(result));
    report.path_points = result.path.size();
    report.path_length_m = path_length(result.path);
    report.min_clearance_m = planned.min_clearance_m;
    // The windows' meshes enclose the columns (plan_corridor()): held to the same limits as --dsm below.
    report.min_clearance_dsm_m = planned.min_clearance_dsm_m;
    report.mesh_max_below_dsm_m = planned.mesh_error.max_below;
    report.safety_margin_m = planned.safety_margin_m;
    report.dsm_tolerance_m = 0.01;
    report.max_agl_m = planned.max_agl_m;
    if (!(report.min_clearance_dsm_m >= options.plan.safety - report.dsm_tolerance_m))
      throw InputError(options.mesh, "",
                       "the path comes within " + two_decimals(report.min_clearance_dsm_m) +
                           " m of the DSM's columns, less than --safety; a bug, please report it; nothing written");
    if (!(report.max_agl_m <= options.plan.max_agl + 0.05))
      throw InputError(options.mesh, "",
                       "the path rises " + two_decimals(report.max_agl_m) +
                           " m above the ground, above --max-agl; a bug, please report it; nothing written");
  } else {
    PlanOptions plan = options.plan;
    double half_diagonal = INFINITY;
    // The DSM's columns, holes as high as their rim: what the path must keep `safety` from
    // (columns.hpp, "holding a mesh plan to the DSM's columns").
    Grid columns;
    double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY;
    if (kept) {  // the mesh was not read: the extent of its triangles
      const ClearanceIndex::Footprint& f = kept->footprint();
      xmin = f.xmin, ymin = f.ymin, xmax = f.xmax, ymax = f.ymax;
    } else {
      for (const Vertex& v : mesh.vertices)
        xmin = std::min(xmin, v.x), ymin = std::min(ymin, v.y), xmax = std::max(xmax, v.x), ymax = std::max(ymax, v.y);
    }
    uint64_t dsm_fingerprint = 0;  // what else the index is built over: the DSM's holes' columns
    if (!options.dsm.empty()) {
      reading.lap();
      Grid dsm = read_companion(options.dsm, "DSM", mesh.crs, xmin, ymin, xmax, ymax);
      seconds_reading += reading.lap();
      columns = dsm;
      fill_holes_from_rim(columns, RimHeight::highest);
      // A waypoint above the ceiling is refused now, before the work on the mesh.
      plan.ground = std::make_shared<GroundGrid>(dsm);
      dsm_fingerprint = plan.ground->fingerprint();
      if (options.dtm.empty()) refuse_above_ceiling(waypoints, *plan.ground, options);
      refuse_near_columns(waypoints, columns, options);
      // The valid cells' columns against the mesh; the holes' are added to it whole below.
      ColumnError above;
      VerticalError below;
      report.safety_margin_m = column_margin(mesh, dsm, &above, &below);
      report.mesh_max_below_dsm_m = below.max_below;
      report.column_max_above_mesh_m = above.max_below;
      half_diagonal = std::hypot(dsm.cell_x, dsm.cell_y) / 2;
      plan.safety += report.safety_margin_m;
      // The holes' columns join the obstacles: a mesh has voids there.
      const Mesh holes = hole_columns(dsm, columns);
      const uint32_t offset = static_cast<uint32_t>(mesh.vertices.size());
      mesh.vertices.insert(mesh.vertices.end(), holes.vertices.begin(), holes.vertices.end());
      for (Triangle t : holes.triangles) mesh.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
    }
    if (!options.dtm.empty()) {
      reading.lap();
      Grid dtm = read_companion(options.dtm, "DTM", mesh.crs, xmin, ymin, xmax, ymax);
      seconds_reading += reading.lap();
      plan.ground = std::make_shared<GroundGrid>(std::move(dtm));
      refuse_above_ceiling(waypoints, *plan.ground, options);
    }
    // With --dsm the index is named by the mesh file and the DSM together (their holes' columns
    // joined the mesh); without, it was opened above already, if it fits.
    const uint64_t index_hash = mesh_file_hash ^ (dsm_fingerprint * 0x9E3779B97F4A7C15ull);
    if (!options.index.empty() && !options.dsm.empty()) {
      reading.lap();
      kept = open_kept_index(options.index, index_hash, &kept_source);
      seconds_reading += reading.lap();
    }
    report.index_reused = kept.has_value();
    // Roadmap files are keyed by the mesh's own fingerprint; a kept index holds it.
    const auto fingerprint_of_mesh = [&] { return kept ? kept_source.mesh_fingerprint : mesh_fingerprint(mesh); };
    const ClearanceIndex index = kept ? *kept : ClearanceIndex(mesh);
    if (!options.index.empty() && !kept) index.save(options.index, {index_hash, fingerprint_of_mesh()});
    report.ground = !options.dtm.empty() ? "dtm" : !options.dsm.empty() ? "dsm" : "mesh floor";
    // What a mission's straight items and vertical legs are held to: the DSM's columns when known,
    // else the mesh; the ceiling over the ground in use.
    const GroundGrid& ground = plan.ground ? *plan.ground : index.floor();
    detail::FlightLimits limits;
    limits.columns = options.dsm.empty() ? nullptr : &columns;
    limits.mesh = &index;
    limits.ground = &ground;
    limits.safety = options.plan.safety;
    limits.max_agl = options.plan.max_agl;
    if (mission_out) {
      const auto ground_z = [&](double x, double y) { return -ground.height_above({x, y, 0}); };
      site = detail::mission_site(options.mission, waypoints, ground_z, from_lonlat);
      report.home_ground = report.ground;
      report.home_ground_uncertainty_m = ground.spread_at(site.home[0], site.home[1]);
    }
    if (!options.dtm.empty()) {
      const auto surface_z = [&](double x, double y) {
        return options.dsm.empty() ? index.ground(x, y) : double(columns.height_at(x, y));
      };
      refuse_terrain_above(*plan.ground, surface_z, waypoints, mission_out ? &site : nullptr, options.dtm,
                           (options.dsm.empty() ? "the mesh " + options.mesh : "the DSM " + options.dsm));
    }
    if (mission_out) {
      const auto dsm_z = [&](double x, double y) {
        return options.dsm.empty() ? NAN : double(columns.height_at(x, y));
      };
      detail::check_vertical_legs(site, waypoints, limits, dsm_z);
      route = detail::route_waypoints(waypoints, site);
    }
    report.seconds_load = clock.lap();
    report.seconds_read = seconds_reading;

    // A roadmap file is reused when it exists (and fits this mesh, ground and options), else made.
    if (!options.roadmap.empty()) {
      const uint64_t fingerprint = fingerprint_of_mesh() ^ (plan.ground ? plan.ground->fingerprint() : 0);
      Roadmap map;
      require_input_file(options.roadmap);  // before asking whether it can be opened: a FIFO would wait
      if (std::ifstream(options.roadmap).good()) {
        map = read_roadmap(options.roadmap, fingerprint, plan);
        report.roadmap_reused = true;
      } else {
        map = build_roadmap(index, plan, sub_progress(progress, 0.2, 0.9));
        write_roadmap(options.roadmap, map, fingerprint, plan);
      }
      const double seconds_roadmap = clock.lap();
      result = query_roadmap(map, index, route, plan);
      result.seconds_roadmap = report.roadmap_reused ? 0 : seconds_roadmap;
      report.seconds_load += report.roadmap_reused ? seconds_roadmap : 0;
      report.seconds_read += report.roadmap_reused ? seconds_roadmap : 0;
    } else {
      result = plan_path(index, route, plan, sub_progress(progress, 0.2, 0.9));
    }
    take_planner_figures(result, report);
    if (result.status != PlanStatus::Solved) {
      std::string why = failure_problems(result);
      // Worth a word only when the mesh does not fit its DSM (more than a conservative mesh needs).
      if (report.safety_margin_m > half_diagonal + 1e-9)
        why += " (on the mesh the safety distance is --safety " + two_decimals(options.plan.safety) + " widened by " +
               two_decimals(report.safety_margin_m) + " m, as far as the DSM's columns may lie inside this mesh; a " +
               "conservative mesh of the DSM itself needs half a cell diagonal)";
      throw InputError(options.waypoints, failure_place(result), why);
    }
    // A mission flies straight from item to item: as few items as keep the limits on those lines
    // (before the clearance below is measured on them).
    if (mission_out) result.path = detail::fewest_straight_legs(result.path, route, limits);

    report.path_points = result.path.size();
    report.path_length_m = path_length(result.path);
    // Measured on their own, not taken from the planner: the numbers a user checks the path by.
    const double cap = options.plan.safety + options.plan.max_agl;
    report.min_clearance_m = cap;
    for (size_t k = 1; k < result.path.size(); ++k)
      // Measured up to the least so far: the same minimum, without searching 100 m around every segment.
      report.min_clearance_m = index.clearance(result.path[k - 1], result.path[k], report.min_clearance_m);
    verify_limits(result.path, options.dsm.empty() ? nullptr : &columns, plan.ground ? *plan.ground : index.floor(),
                  options, cap, report, options.dsm.empty() ? options.mesh : options.dsm);
  }
  dsmplan::report(progress, 0.95);

  if (out_ext == "csv") {
    write_text_file(options.output, path_to_csv(result.path));
  } else if (msl_out) {
    std::vector<Point3> lonlatamsl, marks;
    for (const Point3& p : result.path) lonlatamsl.push_back(to_msl->to_wgs84(p));
    if (mission_out) {
      Mission mission;
      mission.home = to_msl->to_wgs84(site.home);
      mission.route = lonlatamsl;
      mission.route.front() = to_msl->to_wgs84(site.takeoff_top);  // exactly above home
      mission.end = site.end;
      if (site.end == MissionEnd::land) mission.land = to_msl->to_wgs84(site.land);
      report.mission_items = 2 + (mission.route.size() - 1) + (site.end == MissionEnd::none ? 0 : 1);
      report.home = site.home;
      report.takeoff_height_m = site.takeoff_top[2] - site.home[2];
      report.mission_end = site.end == MissionEnd::rtl ? "rtl" : site.end == MissionEnd::land ? "land" : "none";
      if (out_ext == "kmz")
        write_wpml_kmz(mission, options.mission.format, options.output);
      else
        write_text_file(options.output, out_ext == "plan" ? mission_to_qgc_plan(mission, options.mission.format)
                                                          : mission_to_qgc_wpl(mission, options.mission.format));
    } else {
      for (const Point3& p : waypoints) marks.push_back(to_msl->to_wgs84(p));
      MissionOptions kml = options.mission.format;
      kml.description =
          "dsmplan path from " + mesh.crs.name + "; heights above mean sea level (EGM96) by: " + to_msl->description();
      write_text_file(options.output, path_to_kml(lonlatamsl, marks, kml));
    }
  } else {
    std::vector<Point3> lonlath;
    lonlath.reserve(result.path.size());
    for (const Point3& p : result.path) lonlath.push_back(wgs84->to_wgs84(p));
    Json properties{{"crs_source", mesh.crs.name},
                    {"transformation", report.transformation},
                    {"height", "metres above the WGS 84 ellipsoid"},
                    {"safety_m", options.plan.safety},
                    {"path_length_m", report.path_length_m},
                    {"min_clearance_m", report.min_clearance_m}};
    write_text_file(options.output, path_to_geojson(lonlath, properties.dump()));
  }
  dsmplan::report(progress, 1);
  return report;
}

Json to_json(const PlanReport& r) {
  Json j;
  j["path_length_m"] = r.path_length_m;
  j["min_clearance_m"] = r.min_clearance_m;
  j["roadmap_nodes"] = r.roadmap_nodes;
  j["roadmap_edges"] = r.roadmap_edges;
  j["seconds_load"] = r.seconds_load;
  if (r.corridor_windows == 0) {  // a corridor reads and meshes its windows as it plans
    j["seconds_read"] = r.seconds_read;
    j["seconds_index"] = r.seconds_load - r.seconds_read;
  }
  j["seconds_roadmap"] = r.seconds_roadmap;
  j["seconds_query"] = r.seconds_query;
  j["seconds_smooth"] = r.seconds_smooth;
  if (!std::isnan(r.min_clearance_dsm_m)) {
    j["min_clearance_dsm_m"] = r.min_clearance_dsm_m;
    j["dsm_tolerance_m"] = r.dsm_tolerance_m;
    j["mesh_max_below_dsm_m"] = r.mesh_max_below_dsm_m;
    j["column_max_above_mesh_m"] = r.column_max_above_mesh_m;
    j["safety_margin_m"] = r.safety_margin_m;
  }
  j["max_agl_m"] = r.max_agl_m;
  j["ground"] = r.ground;
  j["roadmap_reused"] = r.roadmap_reused;
  j["index_reused"] = r.index_reused;
  j["refined_samples"] = r.refined_samples;
  j["planner"] = r.planner;
  if (!r.transformation.empty()) j["transformation"] = r.transformation;
  if (r.mission_items) {
    j["mission_items"] = r.mission_items;
    j["home"] = {r.home[0], r.home[1], r.home[2]};
    j["home_ground"] = r.home_ground;
    j["home_ground_uncertainty_m"] = r.home_ground_uncertainty_m;
    j["takeoff_height_m"] = r.takeoff_height_m;
    j["mission_end"] = r.mission_end;
  }
  if (r.corridor_windows) {
    j["corridor_windows"] = r.corridor_windows;
    j["corridor_largest_window_cells"] = r.corridor_largest_window_cells;
  }
  return j;
}

std::string to_text(const PlanReport& r) {
  char buffer[512];
  std::snprintf(
      buffer, sizeof buffer,
      "%s: %zu points, %.1f m, min clearance %.2f m to the mesh%s; %s %zu nodes, %zu edges "
      "(%.2f s%s), query %.3f s, smoothing %.3f s\n",
      r.output.c_str(), r.path_points, r.path_length_m, r.min_clearance_m,
      std::isnan(r.min_clearance_dsm_m)
          ? ""
          : (", " +
             std::to_string(r.min_clearance_dsm_m).substr(0, std::to_string(r.min_clearance_dsm_m).find('.') + 3) +
             " m to the DSM's columns")
                .c_str(),
      r.planner == "prm" ? "roadmap" : "trees", r.roadmap_nodes, r.roadmap_edges, r.seconds_roadmap,
      r.roadmap_reused ? ", reused" : "", r.seconds_query, r.seconds_smooth);
  std::string text = buffer;
  if (std::isfinite(r.max_agl_m)) {
    char ceiling[160];
    std::snprintf(ceiling, sizeof ceiling, "at most %.2f m above the ground (%s) anywhere on the path\n", r.max_agl_m,
                  r.ground.c_str());
    text += ceiling;
  }
  if (r.mission_items) {
    char mission[320];
    std::snprintf(
        mission, sizeof mission,
        "mission: %zu items: takeoff at home (x %.2f, y %.2f, ground %.2f m from the %s, uncertain by %.2f m) "
        "to %.2f m above it, %zu more points, then %s\n",
        r.mission_items, r.home[0], r.home[1], r.home[2],
        r.home_ground == "mesh floor" ? "mesh floor"
        : r.home_ground == "dtm"      ? "DTM"
                                      : "DSM",
        r.home_ground_uncertainty_m, r.takeoff_height_m, r.path_points - 1, r.mission_end.c_str());
    text += mission;
  }
  if (!r.transformation.empty()) text += "heights and coordinates to WGS 84 by: " + r.transformation + "\n";
  return text;
}

}  // namespace dsmplan
