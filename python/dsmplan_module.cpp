// The Python module `dsmplan` (pybind11): the library's stages on numpy arrays, for GIS people
// who script. A contract (issue 18), documented in docs/python.md and python/dsmplan.pyi:
//   dsm = dsmplan.read_dsm(path)        .heights (rows x columns float32, nodata NaN; a read-only view of the DSM's
//                                       own memory), .transform (GDAL geotransform), .crs (WKT)
//   mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)   the bounded mode;
//                                       .vertices N x 3 float64, .faces M x 3 uint32 (views of
//                                       the mesh), .certified {max_above_m, max_below_m, rms_m}
//   mesh = dsmplan.mesh(dsm)            the XY-3 mesh of the paper's Section 3
//   dsm = dsmplan.Dsm(heights, transform, crs)   from a numpy array, rasterio's convention
//   flight = dsmplan.plan(mesh, waypoints, dsm=dsm, dtm=dtm, safety=2.0, max_agl=120.0, ...)
//                                       the plan stage's plan_flight() (src/plan/include/dsmplan/
//                                       flight.hpp): .path K x 3 float64, CRS; .report (the figures of
//                                       `dsmplan plan --stats`); .write(path) every path and mission format
//   mesh.write(path)                    .ply, .obj, .off or .glb by the extension
//   dsm = dsmplan.grid(points, res=1.0, classes=[2], fill_holes=30)   LAS/LAZ/XYZ to a DSM in memory,
//                                       grid_point_files() of `dsmplan grid`; dsm.write(path): write_dsm()
//   dsmplan.plan_routes(mesh, routes, ...)   many routes over one roadmap (plan_routes())
//   dsmplan.render(dsm, output, ...), dsmplan.profile(dsm, path, output, ...)   PNGs by render_job()
//                                       and profile_job() (files, a Dsm, a Flight as flown), returning
//                                       the report of `--json` as a dict
//   dsm = dsmplan.stereo(images, res=1) or dsmplan.stereo(cameras=path_or_dict, res=0.5) or
//         dsmplan.stereo(colmap=model_dir, centres=csv, crs="EPSG:25832", res=1)          `dsmplan
//                                       stereo`: stereo_job_for()'s rules, then stereo_job() or
//                                       satellite_stereo_job(); a Dsm, or with output= the file and
//                                       the report of --stats as a dict
// Keyword arguments mirror the CLI's flags; an ArgumentError names the keyword argument where
// the CLI names the flag (keyword_for()). Every public name is in dsmplan.pyi beside the module,
// with the same parameters (tests/python/test_stubs.py).
// Errors are dsmplan.Error (subclasses InputError, ArgumentError, OutputError, as the C++
// hierarchy) with the library's one-line text. The long calls release the GIL.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <stdlib.h>  // mkdtemp

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "dsmplan/airspace_io.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/flight.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/picture_job.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/satellite_stereo_job.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/simplify_streamed.hpp"
#include "dsmplan/stereo_job.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/wgs84.hpp"

namespace py = pybind11;
using namespace dsmplan;

namespace {

// The library's memory handed out as a numpy view that cannot be written through: a mesh or DSM
// changed behind the library's back (a face naming a vertex that is not there, a height made
// infinite) would be written or planned on as if it had been checked.
py::array read_only(py::array view) {
  view.attr("setflags")(py::arg("write") = false);
  return view;
}

struct PyDsm {
  Grid grid;
};

// Runs `work` (which must not touch Python) on a thread of its own with the GIL released, while
// this thread asks Python every 50 ms whether a signal came: on Ctrl-C the work's `stop` is
// requested, the work ends within a few validity checks (core.hpp: StopToken), and the
// KeyboardInterrupt is raised here. A call from another thread than Python's main one cannot see
// Ctrl-C (Python runs its handlers there only) and just runs to its end.
template <typename Work>
auto interruptible(StopToken& stop, Work&& work) -> decltype(work()) {
  auto task = std::async(std::launch::async, std::forward<Work>(work));
  for (;;) {
    {
      py::gil_scoped_release release;
      if (task.wait_for(std::chrono::milliseconds(50)) == std::future_status::ready) break;
    }
    if (PyErr_CheckSignals() != 0) {
      py::error_already_set interrupted;  // takes Python's KeyboardInterrupt (or a handler's error)
      stop.request_stop();
      {
        py::gil_scoped_release release;
        task.wait();
      }
      throw interrupted;
    }
  }
  return task.get();  // the work's result, or its exception
}

struct PyMesh {
  Mesh mesh;
  std::optional<VerticalError> certified;  ///< simplify()'s certificate; none for mesh()
};

std::shared_ptr<PyMesh> simplify(const PyDsm& dsm, double max_error, bool conservative, bool delaunay) {
  auto out = std::make_shared<PyMesh>();
  BoundedSimplifyOptions options;
  options.max_error = max_error;
  options.conservative = conservative;
  options.delaunay = delaunay;
  {
    py::gil_scoped_release release;
    GridView view(dsm.grid);
    out->mesh.crs = dsm.grid.crs;
    MeshCollector collector(out->mesh);
    out->certified = simplify_bounded(view, options, collector).error;
  }
  return out;
}

// A flight planned by plan_flight(), with what writing it needs.
struct PyFlight {
  FlightPlan flight;
  std::vector<Point3> waypoints;
  Crs crs;
  PlanReport report;
  // What its pictures draw with it (render(), profile()): the zones, the limits, the terrain.
  ZoneLayer zones;
  double safety = 0, max_agl = 0;
  std::shared_ptr<const Grid> dtm;
};

std::vector<Point3> points_of(const py::array_t<double, py::array::c_style | py::array::forcecast>& waypoints) {
  if (waypoints.ndim() != 2 || waypoints.shape(1) != 3)
    throw ArgumentError("waypoints", "must be a K x 3 array of x, y, z in the mesh's CRS");
  std::vector<Point3> points(static_cast<size_t>(waypoints.shape(0)));
  const auto w = waypoints.unchecked<2>();
  for (size_t i = 0; i < points.size(); ++i) points[i] = {w(i, 0), w(i, 1), w(i, 2)};
  return points;
}

// A DSM from a numpy array, as rasterio hands one out: rows from the north, the affine transform
// (a, b, c, d, e, f) = (cell width, 0, west edge, 0, -cell height, north edge), a CRS as
// "EPSG:n", WKT or PROJ. The heights are copied: the array stays the caller's.
std::shared_ptr<PyDsm> dsm_from_array(py::array_t<float, py::array::c_style | py::array::forcecast> heights,
                                      const std::vector<double>& transform, const std::string& crs,
                                      std::optional<double> nodata) {
  if (heights.ndim() != 2 || heights.shape(0) < 1 || heights.shape(1) < 1)
    throw ArgumentError("heights", "must be a rows x columns array");
  if (transform.size() < 6)
    throw ArgumentError("transform",
                        "must be the affine (a, b, c, d, e, f) of rasterio: cell width, 0, west, 0, "
                        "-cell height, north");
  const auto [a, b, c, d, e, f] =
      std::array{transform[0], transform[1], transform[2], transform[3], transform[4], transform[5]};
  if (b != 0 || d != 0) throw ArgumentError("transform", "is rotated or sheared; dsmplan needs north-up cells");
  if (!(a > 0 && e < 0 && std::isfinite(a) && std::isfinite(e) && std::isfinite(c) && std::isfinite(f)))
    throw ArgumentError("transform",
                        "needs a positive cell width a, a negative e (rows from the north) and a "
                        "finite corner");
  auto out = std::make_shared<PyDsm>();
  Grid& g = out->grid;
  g.width = static_cast<int>(heights.shape(1));
  g.height = static_cast<int>(heights.shape(0));
  g.x0 = c, g.y0 = f, g.cell_x = a, g.cell_y = -e;
  g.z.assign(heights.data(), heights.data() + heights.size());
  for (float& z : g.z)
    if (!std::isfinite(z) || (nodata && z == float(*nodata))) z = NAN;
  g.crs.definition = crs;
  if (!crs.empty()) resolve_crs(g.crs);
  return out;
}

// The zone files into the flight's data, in its mesh's CRS, and which restrictions block.
void read_zones(FlightData& data, const std::vector<std::string>& no_fly,
                const std::optional<std::vector<std::string>>& blocking, const VerticalOptions& vertical) {
  if (blocking) data.airspace.blocking = *blocking;
  check_airspace_options(data.airspace);  // before the files are read, as the CLI
  for (const std::string& file : no_fly) {
    const std::vector<AirspaceZone> zones = read_airspace(file, data.mesh->crs, vertical);
    data.no_fly.insert(data.no_fly.end(), zones.begin(), zones.end());
  }
}

// The data and limits plan() and plan_routes() take alike. The data are shared with the Python
// objects, not copied: the arrays handed out are read-only.
void share_data(FlightData& data, const std::shared_ptr<PyMesh>& mesh, const std::shared_ptr<PyDsm>& dsm,
                const std::shared_ptr<PyDsm>& dtm) {
  if (!mesh) throw ArgumentError("mesh", "must be a Mesh (dsmplan.simplify() or dsmplan.mesh()), got None");
  data.mesh = std::shared_ptr<const Mesh>(mesh, &mesh->mesh);
  if (dsm) data.dsm = std::shared_ptr<const Grid>(dsm, &dsm->grid);
  if (dtm) data.dtm = std::shared_ptr<const Grid>(dtm, &dtm->grid);
}
void set_limits(FlightQuery& query, double safety, double max_agl, double spacing, const std::string& planner,
                double snap, const std::string& waypoint_heights, const std::string& objective,
                std::optional<double> no_fly_buffer) {
  query.options.safety = safety;
  query.options.no_fly_buffer = no_fly_buffer.value_or(NAN);
  query.options.max_agl = max_agl;
  query.options.spacing = spacing;
  query.options.planner = parse_planner(planner);
  query.options.objective = parse_objective(objective);
  query.snap = snap;
  query.heights = parse_waypoint_heights(waypoint_heights);
}

// A planned flight as a Flight, with what its pictures draw with it.
std::shared_ptr<PyFlight> flight_of(FlightPlan plan, const Crs& crs, ZoneLayer zones, std::shared_ptr<const Grid> dtm,
                                    double safety, double max_agl) {
  auto out = std::make_shared<PyFlight>();
  out->flight = std::move(plan);
  out->waypoints = out->flight.waypoints;  // in the CRS, snapped
  out->crs = crs;
  static_cast<FlightReport&>(out->report) = out->flight.report;
  out->zones = std::move(zones);
  out->safety = safety, out->max_agl = max_agl;
  out->dtm = std::move(dtm);
  return out;
}

std::shared_ptr<PyFlight> plan(const std::shared_ptr<PyMesh>& mesh,
                               py::array_t<double, py::array::c_style | py::array::forcecast> waypoints,
                               const std::shared_ptr<PyDsm>& dsm, const std::shared_ptr<PyDsm>& dtm, double safety,
                               double max_agl, double spacing, const std::string& planner, bool mission,
                               std::optional<std::array<double, 2>> home, std::optional<std::string> end,
                               const std::string& vertical_crs, const std::vector<std::string>& no_fly,
                               std::optional<std::vector<std::string>> no_fly_blocking, bool allow_approximate_vertical,
                               double snap, const std::string& waypoint_heights, const std::string& objective,
                               std::optional<double> no_fly_buffer) {
  FlightRequest request;
  request.waypoints = points_of(waypoints);
  request.names = {"mesh", "waypoints", "dsm", "dtm"};
  set_limits(request, safety, max_agl, spacing, planner, snap, waypoint_heights, objective, no_fly_buffer);
  share_data(request, mesh, dsm, dtm);
  if (!mission && (home || end)) throw ArgumentError("home", "home and end belong to a mission (mission=True)");
  const auto stop = std::make_shared<StopToken>();
  request.options.stop = stop;
  FlightPlan planned = interruptible(*stop, [&] {
    require_projected(mesh->mesh.crs, "mesh", centre_of(mesh->mesh));  // as `dsmplan plan` does
    read_zones(request, no_fly, no_fly_blocking, VerticalOptions{vertical_crs, allow_approximate_vertical});
    std::optional<Wgs84Transform> to_msl;
    if (mission) {
      MissionEnds ends;
      if (home) ends.home = *home;
      if (end) ends.end = parse_mission_end(*end);
      ends.from_lonlat = [&](double lon, double lat) {
        if (!to_msl)
          to_msl.emplace(mesh->mesh.crs, HeightReference::MeanSeaLevel, VerticalOptions{vertical_crs, false});
        return to_msl->from_wgs84({lon, lat, 0});
      };
      request.mission = ends;
    }
    return plan_flight(request);
  });
  return flight_of(std::move(planned), mesh->mesh.crs, {request.no_fly, request.airspace}, request.dtm, safety,
                   max_agl);
}

// Many routes over one area, one roadmap (plan_routes(), flight.hpp): a Flight a route, or for a
// route without a path the InputError it would raise, not raised.
py::list plan_routes_of(const std::shared_ptr<PyMesh>& mesh,
                        const std::vector<py::array_t<double, py::array::c_style | py::array::forcecast>>& routes,
                        const std::shared_ptr<PyDsm>& dsm, const std::shared_ptr<PyDsm>& dtm, double safety,
                        double max_agl, double spacing, const std::string& planner,
                        const std::vector<std::string>& no_fly, std::optional<std::vector<std::string>> no_fly_blocking,
                        const std::string& vertical_crs, bool allow_approximate_vertical, double snap,
                        const std::string& waypoint_heights, const std::string& objective,
                        std::optional<double> no_fly_buffer, double route_budget) {
  FlightData data;
  data.names = {"mesh", "routes", "dsm", "dtm"};
  share_data(data, mesh, dsm, dtm);
  FlightQuery common;
  set_limits(common, safety, max_agl, spacing, planner, snap, waypoint_heights, objective, no_fly_buffer);
  std::vector<std::vector<Point3>> points;
  for (const auto& route : routes) points.push_back(points_of(route));
  std::shared_ptr<const Grid> terrain = data.dtm;
  ZoneLayer zones;
  const auto stop = std::make_shared<StopToken>();
  common.options.stop = stop;
  RoutesPlan planned = interruptible(*stop, [&] {
    require_projected(mesh->mesh.crs, "mesh", centre_of(mesh->mesh));
    read_zones(data, no_fly, no_fly_blocking, VerticalOptions{vertical_crs, allow_approximate_vertical});
    zones = {data.no_fly, data.airspace};
    const FlightArea area(std::move(data));
    return plan_routes(area, points, common, {}, route_budget);
  });
  const py::object input_error = py::module_::import("dsmplan").attr("InputError");
  py::list out;
  for (RouteResult& route : planned.routes) {
    if (!route.solved) {
      // The RouteFailure as attributes, as `plan --routes` writes its "failure" object.
      py::object error = input_error(route.reason());
      const RouteFailure& f = route.failure;
      error.attr("code") = f.code;
      error.attr("waypoint") = f.waypoint ? py::object(py::int_(*f.waypoint)) : py::none();
      error.attr("leg") = f.leg ? py::object(py::make_tuple((*f.leg)[0], (*f.leg)[1])) : py::none();
      error.attr("nearest_valid_point") =
          f.nearest ? py::object(py::make_tuple((*f.nearest)[0], (*f.nearest)[1], (*f.nearest)[2])) : py::none();
      out.append(error);
      continue;
    }
    out.append(flight_of(std::move(route.plan), mesh->mesh.crs, zones, terrain, safety, max_agl));
  }
  return out;
}

// The keyword argument that sets the library's `field`: `names` first (the library's field names
// where the keyword differs), then a flag as its keyword ("--max-agl" -> "max_agl", "POINTS" ->
// "points"), else the field as it is. Only the name changes: the checks and their words are the
// library's.
std::string keyword_for(const std::string& field, const std::map<std::string, std::string>& names) {
  if (const auto found = names.find(field); found != names.end()) return found->second;
  std::string keyword = field;
  if (keyword.rfind("--", 0) == 0) {
    keyword = keyword.substr(2);
    for (char& c : keyword)
      if (c == '-') c = '_';
  } else if (!keyword.empty() &&
             std::all_of(keyword.begin(), keyword.end(), [](unsigned char c) { return c >= 'A' && c <= 'Z'; })) {
    for (char& c : keyword) c = static_cast<char>(c - 'A' + 'a');
  }
  return keyword;
}

template <class Call>
auto naming_keywords(const std::map<std::string, std::string>& names, Call&& call) {
  try {
    return call();
  } catch (const ArgumentError& error) {
    throw ArgumentError(keyword_for(error.field(), names), error.problem());
  } catch (const DataFault& fault) {
    throw DataFault(keyword_for(fault.field(), names), fault.problem(), fault.nearest());
  }
}

// One path or a sequence of them (a str is one path, not a sequence of letters).
std::vector<std::string> paths_of(const py::object& given, const char* name) {
  if (given.is_none()) return {};
  if (py::isinstance<py::str>(given)) return {given.cast<std::string>()};
  try {
    return given.cast<std::vector<std::string>>();
  } catch (const py::cast_error&) {
    throw ArgumentError(name, "must be a path (str) or a list of paths");
  }
}

py::object json_dict(const Json& json) { return py::module_::import("json").attr("loads")(json.dump()); }

std::shared_ptr<PyDsm> grid(const py::object& points, double res, const std::string& crs, const std::string& fusion,
                            const std::vector<int>& classes, std::optional<std::vector<int>> drop_classes,
                            bool keep_all_classes, double fill_holes) {
  // Where the library's field differs from the keyword argument (the CLI's flag, as Python).
  static const std::map<std::string, std::string> names = {
      {"resolution", "res"}, {"keep_classes", "classes"}, {"max_distance", "fill_holes"}};
  return naming_keywords(names, [&] {
    GridOptions options;
    options.inputs = paths_of(points, "points");
    options.crs = crs;
    options.grid.resolution = res;
    options.grid.fusion = parse_fusion(fusion);
    options.classes = classes;
    options.drop_classes = drop_classes;
    options.keep_all_classes = keep_all_classes;
    options.fill_distance = fill_holes;
    auto out = std::make_shared<PyDsm>();
    py::gil_scoped_release release;
    out->grid = grid_point_files(options);
    return out;
  });
}

// A raster given as a file path or as a Dsm in memory: `name` the file, or "DSM" ("DTM") for one
// in memory (the pictures' titles name it); `grid` set for one in memory.
void raster_of(const py::object& given, const char* keyword, std::string& name, std::shared_ptr<const Grid>& grid) {
  if (given.is_none()) return;
  if (py::isinstance<PyDsm>(given)) {
    auto dsm = given.cast<std::shared_ptr<PyDsm>>();
    grid = std::shared_ptr<const Grid>(dsm, &dsm->grid);
    name = keyword == std::string("dtm") ? "DTM" : "DSM";
    return;
  }
  try {
    name = given.cast<std::string>();
  } catch (const py::cast_error&) {
    throw ArgumentError(keyword, "must be a raster file's path (str) or a Dsm");
  }
}

// Waypoints to draw: a CSV's path, or a K x 3 array (then `points`).
void waypoints_of(const py::object& given, std::string& file, std::vector<Point3>& points) {
  if (given.is_none()) return;
  if (py::isinstance<py::str>(given)) {
    file = given.cast<std::string>();
    return;
  }
  points = points_of(given.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>());
}

// Paths to draw: CSV paths and Flights, alone or in a list.
void paths_and_flights(const py::object& given, std::vector<std::string>& files,
                       std::vector<std::shared_ptr<PyFlight>>& flights) {
  if (given.is_none()) return;
  const auto add = [&](const py::handle& one) {
    if (py::isinstance<PyFlight>(one))
      flights.push_back(one.cast<std::shared_ptr<PyFlight>>());
    else if (py::isinstance<py::str>(one))
      files.push_back(one.cast<std::string>());
    else
      throw ArgumentError("paths", "must be a path CSV (str), a Flight, or a list of them");
  };
  if (py::isinstance<py::str>(given) || py::isinstance<PyFlight>(given)) return add(given);
  for (const py::handle& one : given) add(one);
}

// Zone files to draw, read as plan() reads them.
ZoneFiles zone_files(const std::vector<std::string>& no_fly, std::optional<std::vector<std::string>> blocking,
                     const std::string& vertical_crs, bool allow_approximate_vertical) {
  if (blocking) check_airspace_options({*blocking});  // [] too: ZoneFiles reads an empty list as the default
  return {no_fly, blocking.value_or(std::vector<std::string>{}), {vertical_crs, allow_approximate_vertical}};
}

py::object render(const py::object& dsm, const std::string& output, const py::object& meshes, const py::object& titles,
                  const py::object& paths, const py::object& waypoints, std::optional<std::string> roadmap,
                  std::optional<std::array<double, 4>> window, double zoom, bool edges, std::optional<double> res,
                  int band, const std::string& crs, const std::vector<std::string>& no_fly,
                  std::optional<std::vector<std::string>> no_fly_blocking, const std::string& vertical_crs,
                  bool allow_approximate_vertical) {
  static const std::map<std::string, std::string> names = {
      {"--title", "titles"}, {"pixels_per_cell", "zoom"}, {"resolution", "res"}};
  return naming_keywords(names, [&] {
    RenderJobOptions options;
    raster_of(dsm, "dsm", options.dsm, options.dsm_grid);
    options.output = output;
    options.meshes = paths_of(meshes, "meshes");
    options.titles = paths_of(titles, "titles");
    std::vector<std::shared_ptr<PyFlight>> flights;
    paths_and_flights(paths, options.paths, flights);
    std::vector<Point3> points;
    waypoints_of(waypoints, options.waypoints, points);
    options.roadmap = roadmap.value_or("");
    if (window) options.render.window = Window{(*window)[0], (*window)[1], (*window)[2], (*window)[3]};
    options.render.pixels_per_cell = zoom;
    options.render.edges = edges;
    options.resolution = res;
    options.read.band = band;
    options.read.assign_crs = crs;
    options.no_fly = zone_files(no_fly, no_fly_blocking, vertical_crs, allow_approximate_vertical);
    // A Flight is drawn as flown, with its waypoints (unless others are given) and its zones (the
    // first Flight's: flights planned together share them).
    for (const auto& flight : flights) {
      LineLayer line;
      line.polylines.push_back(flown_path(flight->flight));
      options.render.lines.push_back(std::move(line));
      if (waypoints.is_none()) options.render.markers.push_back(MarkerLayer{flight->waypoints});
    }
    if (!flights.empty() && no_fly.empty()) options.render.zones = flights.front()->zones;
    if (!points.empty()) options.render.markers.push_back(MarkerLayer{points});
    std::vector<NamedFile> inputs = {{"waypoints", options.waypoints}, {"roadmap", options.roadmap}};
    if (!options.dsm_grid) inputs.push_back({"dsm", options.dsm});
    for (const std::string& mesh : options.meshes) inputs.push_back({"meshes", mesh});
    for (const std::string& path : options.paths) inputs.push_back({"paths", path});
    RenderReport report;
    {
      py::gil_scoped_release release;
      refuse_overwrites(inputs, {{"output", options.output}});
      report = render_job(options);
    }
    return json_dict(to_json(report));
  });
}

py::object profile(const py::object& dsm, const py::object& path, const std::string& output, const py::object& dtm,
                   const py::object& waypoints, std::optional<double> safety, std::optional<double> max_agl,
                   const std::string& title, int width, int height, const std::vector<std::string>& no_fly,
                   std::optional<std::vector<std::string>> no_fly_blocking, const std::string& vertical_crs,
                   bool allow_approximate_vertical) {
  return naming_keywords({}, [&] {
    ProfileJobOptions options;
    raster_of(dsm, "dsm", options.dsm, options.dsm_grid);
    raster_of(dtm, "dtm", options.dtm, options.dtm_grid);
    options.output = output;
    waypoints_of(waypoints, options.waypoints, options.profile.waypoints);
    options.profile.safety = safety.value_or(2.0);
    options.profile.max_agl = max_agl.value_or(120.0);
    options.profile.title = title;
    options.profile.width = width;
    options.profile.height = height;
    options.no_fly = zone_files(no_fly, no_fly_blocking, vertical_crs, allow_approximate_vertical);
    if (py::isinstance<PyFlight>(path)) {  // as flown, with what it was planned with
      const auto flight = path.cast<std::shared_ptr<PyFlight>>();
      options.path = "flight";
      options.path_points = flown_path(flight->flight);
      if (waypoints.is_none()) options.profile.waypoints = flight->waypoints;
      if (no_fly.empty()) options.profile.zones = flight->zones;
      if (dtm.is_none() && flight->dtm) options.dtm = "DTM", options.dtm_grid = flight->dtm;
      options.profile.safety = safety.value_or(flight->safety);
      options.profile.max_agl = max_agl.value_or(flight->max_agl);
    } else if (py::isinstance<py::str>(path)) {
      options.path = path.cast<std::string>();
    } else {
      throw ArgumentError("path", "must be a path CSV (str) or a Flight");
    }
    std::vector<NamedFile> inputs{{"waypoints", options.waypoints}};
    if (!options.dsm_grid) inputs.push_back({"dsm", options.dsm});
    if (!options.dtm_grid) inputs.push_back({"dtm", options.dtm});
    if (options.path_points.empty()) inputs.push_back({"path", options.path});
    ProfileReport report;
    {
      py::gil_scoped_release release;
      refuse_overwrites(inputs, {{"output", options.output}});
      report = profile_job(options);
    }
    return json_dict(to_json(report));
  });
}

// A private folder (mode 0700) in $TMPDIR or /tmp, removed with what is in it when done.
class TempFolder {
public:
  TempFolder() {
    std::string pattern = (std::filesystem::temp_directory_path() / "dsmplan-stereo-XXXXXX").string();
    if (!mkdtemp(pattern.data()))
      throw OutputError(pattern, std::string("cannot make a temporary folder: ") + std::strerror(errno));
    folder_ = pattern;
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  ~TempFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(folder_, ignored);
  }
  std::string path(const char* name) const { return (folder_ / name).string(); }

private:
  std::filesystem::path folder_;
};

// CAMERAS.json from a dict in its schema: serialised by Python's json (NaN and infinity refused:
// JSON has none) into `path`, for the library's own reader and its checks. A relative image path
// is made absolute against the current directory (a file's are relative to its folder; a dict has
// none). The caller's dict is left as it was.
void write_cameras_dict(const py::dict& cameras, const std::string& path) {
  py::module_ json = py::module_::import("json");
  py::object copy;
  try {
    copy = json.attr("loads")(json.attr("dumps")(cameras, py::arg("allow_nan") = false));
  } catch (py::error_already_set& error) {
    throw ArgumentError("cameras", std::string("is not a dict JSON can hold: ") + error.what());
  }
  if (py::isinstance<py::dict>(copy) && copy.contains("cameras") && py::isinstance<py::list>(copy["cameras"])) {
    for (py::handle camera : copy["cameras"]) {
      if (!py::isinstance<py::dict>(camera) || !camera.contains("image") || !py::isinstance<py::str>(camera["image"]))
        continue;  // the reader names what is wrong with it
      const std::filesystem::path image = camera["image"].cast<std::string>();
      if (image.is_relative()) camera["image"] = std::filesystem::absolute(image).lexically_normal().string();
    }
  }
  const std::string text = json.attr("dumps")(copy).cast<std::string>();
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) throw OutputError(path, "cannot be written");
}

std::string without(std::string text, const std::string& file, const std::string& name) {
  for (size_t at = text.find(file); !file.empty() && at != std::string::npos; at = text.find(file, at + name.size()))
    text.replace(at, file.size(), name);
  return text;
}

// Errors that name the temporary CAMERAS.json of a dict name the keyword argument instead.
template <class Call>
auto naming_file(const std::string& file, const std::string& name, Call&& call) {
  if (file.empty()) return call();
  try {
    return call();
  } catch (const ArgumentError& error) {
    throw ArgumentError(error.field(), without(error.problem(), file, name));
  } catch (const InputError& error) {
    throw InputError("", "", without(error.what(), file, name));
  } catch (const OutputError& error) {
    throw OutputError("", without(error.what(), file, name));
  }
}

py::object stereo(const py::object& images, const py::object& cameras, double res, std::optional<std::string> output,
                  const std::string& pairs, std::optional<std::array<double, 4>> bounds, const std::string& crs,
                  bool allow_approximate_vertical, double fusion_memory, double band_memory, const py::object& colmap,
                  const py::object& centres, const py::object& gcps, const py::object& transform,
                  const py::object& colmap_images) {
  static const std::map<std::string, std::string> names = {{"-o", "output"}, {"--images", "colmap_images"}};
  return naming_keywords(names, [&]() -> py::object {
    std::optional<TempFolder> temp;  // the dict's CAMERAS.json, the DSM returned in memory
    auto temporary = [&](const char* name) {
      if (!temp) temp.emplace();
      return temp->path(name);
    };
    StereoRequest request;
    request.images = paths_of(images, "images");
    std::string cameras_file;  // the temporary CAMERAS.json of a dict
    if (py::isinstance<py::dict>(cameras)) {
      request.cameras = cameras_file = temporary("cameras.json");
      write_cameras_dict(cameras, cameras_file);
    } else if (py::isinstance<py::str>(cameras) || py::hasattr(cameras, "__fspath__")) {
      request.cameras = py::module_::import("os").attr("fspath")(cameras).cast<std::string>();
    } else if (!cameras.is_none()) {
      throw ArgumentError("cameras", "must be a path to CAMERAS.json or a dict in its schema");
    }
    request.output = output ? *output : temporary("dsm.tif");
    request.resolution = res;
    request.pairs = pairs;
    if (bounds) {  // as --bounds takes them; %.17g: every double as it is
      char text[128];
      std::snprintf(text, sizeof text, "%.17g,%.17g,%.17g,%.17g", (*bounds)[0], (*bounds)[1], (*bounds)[2],
                    (*bounds)[3]);
      request.bounds = text;
    }
    request.crs = crs;
    // --colmap and its files: paths (str or os.PathLike) as the flags take them.
    for (auto [value, field, name] :
         {std::tuple{&colmap, &request.colmap, "colmap"}, std::tuple{&centres, &request.centres, "centres"},
          std::tuple{&gcps, &request.gcps, "gcps"}, std::tuple{&transform, &request.transform, "transform"},
          std::tuple{&colmap_images, &request.colmap_images, "colmap_images"}}) {
      if (value->is_none()) continue;
      if (!py::isinstance<py::str>(*value) && !py::hasattr(*value, "__fspath__"))
        throw ArgumentError(name, "must be a path (str or os.PathLike)");
      *field = py::module_::import("os").attr("fspath")(*value).cast<std::string>();
    }
    request.allow_approximate_vertical = allow_approximate_vertical;
    request.fusion_memory_mb = fusion_memory;
    request.band_memory_mb = band_memory;
    Json report;
    Grid dsm;
    {
      py::gil_scoped_release release;
      naming_file(cameras_file, "cameras", [&] {
        const StereoJob job = stereo_job_for(request);  // the rules of the flags, as the CLI's
        if (job.frame) {
          if (output) refuse_overwrites(stereo_job_inputs(*job.frame), {{"output", *output}});
          report = to_json(stereo_job(*job.frame));
        } else {
          if (output) refuse_overwrites(satellite_stereo_inputs(*job.satellite), {{"output", *output}});
          report = to_json(satellite_stereo_job(*job.satellite));
        }
        // The file the CLI writes, read back by the library's reader: the Dsm is what
        // read_dsm() gives of it (a satellite DSM's ellipsoidal heights included).
        if (!output) dsm = read_raster(request.output);
        return 0;
      });
    }
    if (!output) {
      auto out = std::make_shared<PyDsm>();
      out->grid = std::move(dsm);
      return py::cast(out);
    }
    if (!cameras_file.empty()) report["cameras"] = nullptr;  // a dict, not a file
    return json_dict(report);
  });
}

}  // namespace

PYBIND11_MODULE(dsmplan, m) {
  m.doc() =
      "dsmplan: DSM to conservative obstacle mesh to collision-free drone paths.\n\n"
      "The library's stages on files and numpy arrays, with the checks and one-line errors of the "
      "`dsmplan` command line; keyword arguments mirror its flags. The reference is dsmplan.pyi beside "
      "the module; the guide is docs/python.md.";
  m.attr("__version__") = DSMPLAN_VERSION;
  // The C++ hierarchy (core.hpp): catch dsmplan.Error for all, a subclass for one kind.
  auto error = py::register_exception<Error>(m, "Error");
  error.attr("__doc__") = "Every error dsmplan raises, with the library's one-line text (the command line's words).";
  py::register_exception<InputError>(m, "InputError", error.ptr()).attr("__doc__") =
      "A file or data that cannot be used: missing, damaged, in feet, no path through it, "
      "a waypoint under a roof; the text names the file and the place.";
  py::register_exception<ArgumentError>(m, "ArgumentError", error.ptr()).attr("__doc__") =
      "An argument out of range or contradicting another; the text starts with the keyword "
      "argument's name (the CLI shows the flag).";
  py::register_exception<OutputError>(m, "OutputError", error.ptr()).attr("__doc__") =
      "A file that could not be written (nothing is left half-written).";

  py::class_<PyDsm, std::shared_ptr<PyDsm>>(
      m, "Dsm", "A DSM raster in memory: read_dsm(), grid(), or a numpy array (Dsm(heights, transform, crs)).")
      .def(py::init(&dsm_from_array), py::arg("heights").none(false), py::arg("transform"), py::arg("crs") = "",
           py::arg("nodata") = py::none(),
           "A DSM from a numpy array, as rasterio holds one. The heights are copied.\n\n"
           "heights: rows x columns array (row 0 north); NaN, infinite or `nodata` heights are holes.\n"
           "transform: rasterio's affine (a, b, c, d, e, f) = (cell width, 0, west, 0, -cell height, north).\n"
           "crs: \"EPSG:n\", WKT or PROJ (empty: unknown; plan() and write() then refuse the DSM).\n"
           "nodata: the height that marks a hole, or None.")
      .def_property_readonly(
          "heights",
          [](py::object self) {
            PyDsm& dsm = self.cast<PyDsm&>();
            const Grid& g = dsm.grid;
            return read_only(
                py::array_t<float>({py::ssize_t(g.height), py::ssize_t(g.width)},
                                   {py::ssize_t(g.width) * py::ssize_t(sizeof(float)), py::ssize_t(sizeof(float))},
                                   dsm.grid.z.data(), self));
          },
          "rows x columns float32 heights (row 0 north), nodata as NaN; a read-only view of the DSM's memory "
          "(copy it to change it)")
      .def_property_readonly(
          "transform",
          [](const PyDsm& d) {
            const Grid& g = d.grid;
            return py::make_tuple(g.x0, g.cell_x, 0.0, g.y0, 0.0, -g.cell_y);
          },
          "GDAL geotransform (x0, cell_x, 0, y0, 0, -cell_y)")
      .def_property_readonly(
          "crs", [](const PyDsm& d) { return d.grid.crs.wkt.empty() ? d.grid.crs.definition : d.grid.crs.wkt; },
          "the CRS as WKT (empty when unknown)")
      .def(
          "write",
          [](const PyDsm& dsm, const std::string& path) {
            py::gil_scoped_release release;
            write_dsm(dsm.grid, path);
          },
          py::arg("path"),
          "Writes the DSM as `dsmplan grid` does: a Float32 GeoTIFF (DEFLATE, nodata -9999), atomically.\n\n"
          "path: .tif or .tiff. A DSM dsmplan could not read back is refused before anything is written: "
          "no CRS, x, y or heights not in metres, no valid cell (ArgumentError).");

  py::class_<PyMesh, std::shared_ptr<PyMesh>>(m, "Mesh", "A triangle mesh in the DSM's CRS: mesh() or simplify().")
      .def_property_readonly(
          "vertices",
          [](py::object self) {
            Mesh& mesh = self.cast<PyMesh&>().mesh;
            return read_only(py::array_t<double>({py::ssize_t(mesh.vertices.size()), py::ssize_t{3}},
                                                 {py::ssize_t(sizeof(Vertex)), py::ssize_t(sizeof(double))},
                                                 reinterpret_cast<double*>(mesh.vertices.data()), self));
          },
          "N x 3 float64 x, y, z (a read-only view of the mesh)")
      .def_property_readonly(
          "faces",
          [](py::object self) {
            Mesh& mesh = self.cast<PyMesh&>().mesh;
            return read_only(py::array_t<uint32_t>({py::ssize_t(mesh.triangles.size()), py::ssize_t{3}},
                                                   {py::ssize_t(sizeof(Triangle)), py::ssize_t(sizeof(uint32_t))},
                                                   reinterpret_cast<uint32_t*>(mesh.triangles.data()), self));
          },
          "M x 3 vertex indices, counter-clockwise from above (a read-only view of the mesh)")
      .def_property_readonly(
          "certified",
          [](const PyMesh& m) -> py::object {
            if (!m.certified) return py::none();
            py::dict d;
            d["max_above_m"] = m.certified->max_above;
            d["max_below_m"] = m.certified->max_below;
            d["rms_m"] = m.certified->rms;
            d["cells"] = m.certified->cells;
            return d;
          },
          "simplify()'s certified error against the DSM at every valid cell (max_above_m, max_below_m, rms_m, "
          "cells); None for mesh()")
      .def(
          "write",
          [](const PyMesh& m, const std::string& path) {
            py::gil_scoped_release release;
            write_mesh(m.mesh, path, mesh_format_for(path));
          },
          py::arg("path"),
          "Writes the mesh with its CRS, atomically.\n\n"
          "path: .ply, .obj, .off or .glb (the format by the extension).");

  m.def(
      "read_dsm",
      [](const std::string& path) {
        auto dsm = std::make_shared<PyDsm>();
        py::gil_scoped_release release;
        dsm->grid = read_raster(path);
        return dsm;
      },
      py::arg("path"),
      "Reads a DSM raster.\n\n"
      "path: any GDAL raster or VRT, with a CRS, x, y and heights in metres.");
  m.def("grid", &grid, py::arg("points").none(false), py::arg("res"), py::kw_only(), py::arg("crs") = "",
        py::arg("fusion") = "median", py::arg("classes") = std::vector<int>{}, py::arg("drop_classes") = py::none(),
        py::arg("keep_all_classes") = false, py::arg("fill_holes") = 0.0,
        "Point clouds to a DSM in memory, as `dsmplan grid` (the same library function, grid_point_files()): "
        "one height per cell, the median of its points; cells without points are holes (NaN).\n\n"
        "points: a LAS, LAZ (1.0-1.4) or XYZ file, or a list of them, all in one CRS.\n"
        "res: cell size in CRS units (metres), > 0 (--res).\n"
        "crs: the points' CRS (\"EPSG:7415\", WKT, PROJ), overriding the files'; needed when they state none.\n"
        "fusion: the height per cell, \"median\" or \"max\".\n"
        "classes: keep only these ASPRS classes (e.g. [2]: ground, a DTM); noise too when listed.\n"
        "drop_classes: ASPRS classes to drop (None or empty: 7 and 18, noise).\n"
        "keep_all_classes: keep every class, noise included (not with `classes`).\n"
        "fill_holes: > 0: fill holes up to this distance (CRS units) from data, by GDAL's FillNodata.");
  m.def(
      "mesh",
      [](const PyDsm& dsm, double zstep) {
        auto out = std::make_shared<PyMesh>();
        MeshOptions options;
        options.zstep = zstep;
        py::gil_scoped_release release;
        out->mesh = triangulate_xy3(dsm.grid, options);
        return out;
      },
      py::arg("dsm").none(false), py::arg("zstep") = 0.1,
      "The XY-3 Delaunay mesh of the DSM (the paper's Section 3), as `dsmplan mesh`.\n\n"
      "dsm: the Dsm to mesh.\n"
      "zstep: heights rounded to steps of this size (0 keeps them).");
  m.def("simplify", &simplify, py::arg("dsm").none(false), py::arg("max_error") = 0.4, py::arg("conservative") = true,
        py::arg("delaunay") = false,
        "The bounded simplification of `dsmplan simplify --max-error`, its error certified cell by cell "
        "(Mesh.certified).\n\n"
        "dsm: the Dsm to simplify.\n"
        "max_error: the largest vertical distance between mesh and DSM at any valid cell (0.001 to 10000).\n"
        "conservative: True: 0 <= mesh - DSM <= max_error (never below an obstacle); False: |mesh - DSM| <= "
        "max_error.\n"
        "delaunay: make the triangulation Delaunay (a few more triangles).");
  py::class_<PyFlight, std::shared_ptr<PyFlight>>(m, "Flight", "A path planned and verified by plan().")
      .def_property_readonly(
          "path",
          [](py::object self) {
            std::vector<Point3>& path = self.cast<PyFlight&>().flight.path;
            return read_only(py::array_t<double>({py::ssize_t(path.size()), py::ssize_t{3}},
                                                 {py::ssize_t(sizeof(Point3)), py::ssize_t(sizeof(double))},
                                                 path.empty() ? nullptr : path[0].data(), self));
          },
          "K x 3 float64 x, y, z in the mesh's CRS, through every waypoint (a read-only view)")
      .def_property_readonly(
          "report", [](const PyFlight& f) { return json_dict(to_json(f.report)); },
          "The figures of `dsmplan plan --stats` as a dict: path_length_m, min_clearance_m, min_clearance_dsm_m "
          "(with a DSM), max_agl_m, ground, the mission's home and takeoff, ...")
      .def(
          "write",
          [](PyFlight& f, const std::string& path, const std::string& format, const std::string& firmware,
             const std::string& altitude_frame, double speed, const std::string& vertical_crs,
             bool allow_approximate_vertical, const std::string& drone) {
            PlanJobOptions options;
            options.output = path;
            options.format = format;
            options.vertical = {vertical_crs, allow_approximate_vertical};
            MissionOptions& m = options.mission.format;
            m.speed = m.hover_speed = speed;
            m.firmware = parse_firmware(firmware);
            m.drone = parse_drone(drone);
            m.altitude_frame = parse_altitude_frame(altitude_frame);
            py::gil_scoped_release release;
            write_flight(f.flight, f.waypoints, f.crs, f.zones, options, f.report);
          },
          py::arg("path"), py::arg("format") = "", py::arg("firmware") = "generic",
          py::arg("altitude_frame") = "relative", py::arg("speed") = 5.0, py::arg("vertical_crs") = "",
          py::arg("allow_approximate_vertical") = false, py::arg("drone") = "m3e",
          "Writes the path as `dsmplan plan -o` does, atomically.\n\n"
          "path: .csv (x,y,z in the CRS), .geojson (WGS 84), .kml; a flight planned with mission=True also "
          ".plan (QGroundControl), .waypoints (ArduPilot), .kmz (DJI WPML).\n"
          "format: the format's name when the extension does not say it (as --of).\n"
          "firmware: missions: px4, ardupilot or generic.\n"
          "drone: .kmz: the DJI aircraft (m350, m300, m30, m30t, m3e, m3t, m3m, m3d, m3td).\n"
          "altitude_frame: missions: relative (to home) or amsl.\n"
          "speed: missions: the cruise and hover speed, m/s.\n"
          "vertical_crs: the heights' vertical CRS when the mesh's CRS has none (e.g. \"EPSG:7837\").\n"
          "allow_approximate_vertical: take heights of an unknown or grid-less vertical datum as EGM96 "
          "(about 1 m off).");
  m.def("plan", &plan, py::arg("mesh").none(false), py::arg("waypoints").none(false), py::arg("dsm") = nullptr,
        py::arg("dtm") = nullptr, py::arg("safety") = 2.0, py::arg("max_agl") = 120.0, py::arg("spacing") = 20.0,
        py::arg("planner") = "prm", py::arg("mission") = false, py::arg("home") = py::none(),
        py::arg("end") = py::none(), py::arg("vertical_crs") = "", py::arg("no_fly") = std::vector<std::string>{},
        py::arg("no_fly_blocking") = py::none(), py::arg("allow_approximate_vertical") = false, py::arg("snap") = 0.0,
        py::arg("waypoint_heights") = "crs", py::arg("objective") = "low", py::arg("no_fly_buffer") = py::none(),
        "A collision-free path through the waypoints by the plan stage's plan_flight(), with every check of "
        "`dsmplan plan`; returns a Flight. Raises InputError when there is no path, naming the waypoint.\n\n"
        "mesh: the obstacle Mesh (simplify(..., conservative=True)), in metres.\n"
        "waypoints: K x 3 array of x, y, z in the mesh's CRS; refused under the surface, too near it or above "
        "the ceiling.\n"
        "dsm: a Dsm whose cells are kept `safety` away from as solid columns (holes as high as their rim).\n"
        "dtm: a Dsm of the terrain: the ground of the ceiling (refused where it stands above the DSM).\n"
        "safety: the least distance from the mesh (and the DSM's columns), metres.\n"
        "max_agl: the ceiling above the ground (the DTM, else the DSM, else the mesh's floor), metres.\n"
        "spacing: the roadmap's sample spacing, metres.\n"
        "planner: \"prm\", \"rrtconnect\" or \"freespace\" (the free airspace's cells: low paths, a proof "
        "when none exists).\n"
        "mission: plan a mission: a takeoff from `home` and the `end`, written as .plan, .waypoints, .kmz.\n"
        "home: missions: x, y in the CRS or lon, lat in degrees (default: under the first waypoint).\n"
        "end: missions: \"rtl\", \"land\" or \"none\".\n"
        "vertical_crs: the heights' vertical CRS when the mesh's CRS has none, for a home given in lon, lat "
        "and the zones' AMSL and WGS 84 limits.\n"
        "no_fly: files of no-fly zones (EUROCAE ED-269 JSON or GeoJSON), kept `safety` away from; a waypoint, "
        "home or landing inside one is refused.\n"
        "no_fly_blocking: the restrictions that block (default PROHIBITED and REQ_AUTHORISATION).\n"
        "allow_approximate_vertical: take heights of an unknown or grid-less vertical datum as EGM96 (about "
        "1 m off) for the zones' limits.\n"
        "snap: metres (0: off, at most 50): a refused waypoint moved to the nearest valid point within it, "
        "straight up first; each move in Flight.report[\"snapped\"].\n"
        "waypoint_heights: \"crs\" (z in the mesh's CRS) or \"agl\" (z above the ground: the DTM, else the "
        "DSM, else the mesh's floor).\n"
        "objective: freespace only: \"low\" (climb only where it pays) or \"shortest\" (over low roofs where "
        "shorter).\n"
        "no_fly_buffer: metres kept from the no-fly zones that block, apart from `safety` (None: `safety`).");
  m.def("plan_routes", &plan_routes_of, py::arg("mesh").none(false), py::arg("routes").none(false), py::kw_only(),
        py::arg("dsm") = nullptr, py::arg("dtm") = nullptr, py::arg("safety") = 2.0, py::arg("max_agl") = 120.0,
        py::arg("spacing") = 20.0, py::arg("planner") = "prm", py::arg("no_fly") = std::vector<std::string>{},
        py::arg("no_fly_blocking") = py::none(), py::arg("vertical_crs") = "",
        py::arg("allow_approximate_vertical") = false, py::arg("snap") = 0.0, py::arg("waypoint_heights") = "crs",
        py::arg("objective") = "low", py::arg("no_fly_buffer") = py::none(), py::arg("route_budget") = 0.0,
        "Many routes over one roadmap, as `dsmplan plan --routes` (the same library function, plan_routes()): the "
        "roadmap built once, every route a query against it, in parallel, each held to every rule of plan() and "
        "verified. Returns a list in the routes' order: a Flight for a route with a path, else the InputError "
        "plan() would raise for it (returned, not raised: one route stops no other).\n\n"
        "mesh: the obstacle Mesh, in metres.\n"
        "routes: a list of K x 3 arrays of x, y, z in the mesh's CRS, one a route.\n"
        "dsm: a Dsm kept `safety` away from as solid columns, as plan().\n"
        "dtm: a Dsm of the terrain, the ceiling's ground, as plan().\n"
        "safety: the least distance from the mesh (and the DSM's columns), metres.\n"
        "max_agl: the ceiling above the ground, metres.\n"
        "spacing: the roadmap's sample spacing, metres.\n"
        "planner: \"prm\" (one roadmap for all), \"rrtconnect\" (trees per route) or \"freespace\" (one "
        "free airspace for all).\n"
        "no_fly: files of no-fly zones (ED-269 JSON or GeoJSON), as plan().\n"
        "no_fly_blocking: the restrictions that block (default PROHIBITED and REQ_AUTHORISATION).\n"
        "vertical_crs: the heights' vertical CRS for the zones' AMSL and WGS 84 limits, as plan().\n"
        "allow_approximate_vertical: take heights of an unknown or grid-less vertical datum as EGM96.\n"
        "snap: metres (0: off): a refused waypoint moved to the nearest valid point within it, as plan().\n"
        "waypoint_heights: \"crs\" or \"agl\" (z above the ground), as plan().\n"
        "objective: freespace only: \"low\" or \"shortest\", as plan().\n"
        "no_fly_buffer: metres kept from the no-fly zones that block (None: `safety`), as plan().\n"
        "route_budget: each route's own time limit in seconds (0: none); a route past it fails (code "
        "\"route_budget\") and the others go on.\n"
        "A route without a path: its InputError has code, waypoint, leg (from, to; 0 the takeoff above home) "
        "and nearest_valid_point (x, y, z or None), as `plan --routes` writes its \"failure\".");
  m.def("render", &render, py::arg("dsm").none(false), py::arg("output"), py::kw_only(), py::arg("meshes") = py::none(),
        py::arg("titles") = py::none(), py::arg("paths") = py::none(), py::arg("waypoints") = py::none(),
        py::arg("roadmap") = py::none(), py::arg("window") = py::none(), py::arg("zoom") = 4.0, py::arg("edges") = true,
        py::arg("res") = py::none(), py::arg("band") = 1, py::arg("crs") = "",
        py::arg("no_fly") = std::vector<std::string>{}, py::arg("no_fly_blocking") = py::none(),
        py::arg("vertical_crs") = "", py::arg("allow_approximate_vertical") = false,
        "The DSM from above, hillshaded, one panel per mesh with its edges drawn, as `dsmplan render` (the same "
        "library function, render_job()); returns the report of `dsmplan render --json` as a dict (output, "
        "width, height, panels, window, zoom).\n\n"
        "dsm: the DSM raster file, or a Dsm.\n"
        "output: the picture, .png (written atomically).\n"
        "meshes: a mesh file (.ply, .obj, .off, in the DSM's CRS) or a list of them: one panel each (--mesh).\n"
        "titles: a title or a list of them, one per panel (default: the file names, \"DSM\" for a Dsm) (--title).\n"
        "paths: a path CSV, a Flight, or a list of them, drawn on every panel (--path); a Flight as flown (home "
        "legs included), with its waypoints (unless `waypoints` is given) and its zones (unless `no_fly` is).\n"
        "waypoints: a waypoint CSV or a K x 3 array: numbered discs.\n"
        "roadmap: a roadmap file (`dsmplan plan --roadmap`): its edges, thin.\n"
        "window: (xmin, ymin, xmax, ymax) in the CRS: the area to draw (default: all).\n"
        "zoom: pixels per DSM cell.\n"
        "edges: draw the meshes' edges (False: --no-edges).\n"
        "res: resample the DSM (median) to this cell size first.\n"
        "band: the raster band to read.\n"
        "crs: the DSM's CRS, overriding what the file states.\n"
        "no_fly: files of no-fly zones (ED-269 JSON or GeoJSON) to draw, read as plan() reads them.\n"
        "no_fly_blocking: the restrictions drawn as blocking (default PROHIBITED and REQ_AUTHORISATION).\n"
        "vertical_crs: the heights' vertical CRS for the zones' AMSL limits when the DSM's CRS has none.\n"
        "allow_approximate_vertical: take heights of an unknown or grid-less vertical datum as EGM96.");
  m.def("profile", &profile, py::arg("dsm").none(false), py::arg("path").none(false), py::arg("output"), py::kw_only(),
        py::arg("dtm") = py::none(), py::arg("waypoints") = py::none(), py::arg("safety") = py::none(),
        py::arg("max_agl") = py::none(), py::arg("title") = "", py::arg("width") = 1200, py::arg("height") = 500,
        py::arg("no_fly") = std::vector<std::string>{}, py::arg("no_fly_blocking") = py::none(),
        py::arg("vertical_crs") = "", py::arg("allow_approximate_vertical") = false,
        "A path's height profile over the DSM below it, the terrain and the ceiling, as `dsmplan profile` (the "
        "same library function, profile_job()); returns the report of `dsmplan profile --json` as a dict "
        "(length_m, min_above_dsm_m, min_above_lowest_clear_m, max_above_ground_m, ground, max_agl_m, ...), "
        "measured as plan() "
        "verifies.\n\n"
        "dsm: the DSM the path was planned over: a raster file, or a Dsm.\n"
        "path: the path CSV (Flight.write(\"path.csv\")), in the DSM's CRS, or a Flight: drawn as flown (home "
        "legs included) with its waypoints, zones, DTM, safety and ceiling unless given here.\n"
        "output: the picture, .png (written atomically).\n"
        "dtm: the terrain, a raster file or a Dsm: the ground of the ceiling (default: the Flight's, else the "
        "DSM).\n"
        "waypoints: a waypoint CSV or a K x 3 array: numbered markers on the path.\n"
        "safety: the half-height of the band drawn around the path, metres (default: the Flight's, else 2).\n"
        "max_agl: the ceiling above the ground, metres (default: the Flight's, else 120).\n"
        "title: the title (default: the path's and the DSM's names).\n"
        "width: the picture's width, pixels (240 to 30000).\n"
        "height: the picture's height, pixels (160 to 30000).\n"
        "no_fly: files of no-fly zones (ED-269 JSON or GeoJSON) to draw over the section.\n"
        "no_fly_blocking: the restrictions drawn as blocking (default PROHIBITED and REQ_AUTHORISATION).\n"
        "vertical_crs: the heights' vertical CRS for the zones' AMSL limits when the DSM's CRS has none.\n"
        "allow_approximate_vertical: take heights of an unknown or grid-less vertical datum as EGM96.");
  m.def("stereo", &stereo, py::arg("images") = py::none(), py::kw_only(), py::arg("cameras") = py::none(),
        py::arg("res"), py::arg("output") = py::none(), py::arg("pairs") = "auto", py::arg("bounds") = py::none(),
        py::arg("crs") = "", py::arg("allow_approximate_vertical") = false, py::arg("fusion_memory") = 1024.0,
        py::arg("band_memory") = 1024.0, py::arg("colmap") = py::none(), py::arg("centres") = py::none(),
        py::arg("gcps") = py::none(), py::arg("transform") = py::none(), py::arg("colmap_images") = py::none(),
        "A DSM from images, as `dsmplan stereo` (the same library functions: stereo_job_for()'s rules of the "
        "flags, then stereo_job() for frame cameras or satellite_stereo_job() for satellite images): "
        "rectification, SGM, triangulation, the median per cell. Give either `images` or `cameras`. Returns "
        "the Dsm (holes NaN) when `output` is None, else writes the GeoTIFF and returns the report of "
        "`dsmplan stereo --stats` as a dict.\n\n"
        "images: satellite images with RPC cameras (TIFF tags, _RPC.TXT, .RPB or an OSSIM .geom beside them), "
        "two or more (IMAGES).\n"
        "cameras: frame cameras with known poses: the path of a CAMERAS.json, or a dict in its schema "
        "({\"crs\": ..., \"height_range\": [lo, hi], \"cameras\": [{\"image\", \"width\", \"height\", \"fx\", "
        "\"fy\", \"cx\", \"cy\", \"distortion\", \"rotation\", \"center\"}, ...]}), checked by the same reader. "
        "A file's relative image paths are relative to its folder, a dict's to the current directory; errors "
        "in a dict name `cameras`, and the report's \"cameras\" is None.\n"
        "res: cell size, metres (--res).\n"
        "output: the GeoTIFF to write (.tif), atomically; None: the DSM is returned in memory (written to a "
        "private temporary folder, read back and removed).\n"
        "pairs: frame cameras: \"auto\" (overlap and base-to-height ratio) or pairs like \"0-1,1-2\".\n"
        "bounds: (x0, y0, x1, y1) of the DSM in its CRS (default: the pairs' overlap).\n"
        "crs: satellite images: the output CRS, projected in metres (default: WGS 84 / UTM of the scene, "
        "heights above the WGS 84 ellipsoid).\n"
        "allow_approximate_vertical: satellite images with a compound `crs` whose geoid grid PROJ lacks: "
        "heights through EGM96 (about 1 m off) instead of refusing.\n"
        "fusion_memory: MB for the points before the fusion spills sorted runs to $TMPDIR (or /tmp), "
        "[0.0625, 1e9).\n"
        "band_memory: frame cameras: MB for one band of a pair's rectified images and matching, [1, 1e9).\n"
        "colmap: a COLMAP text model's folder (cameras.txt, images.txt) instead of `cameras` (--colmap); needs "
        "`crs` (the CRS of the centres or points and of the DSM) and `centres`, `gcps` or `transform`.\n"
        "centres: with colmap: a CSV of image,x,y,z (the cameras' centres in `crs`), or \"exif\" for the "
        "images' EXIF GPS (--centres).\n"
        "gcps: with colmap: a CSV of ground control points, header x,y,z,image,u,v (--gcps).\n"
        "transform: with colmap: the model -> `crs` similarity's file (--transform).\n"
        "colmap_images: with colmap: the images' folder (--images; default: the model's project.ini, else "
        "images/ beside the model).");
}
