// The Python module `dsmplan` (pybind11): the library's stages on numpy arrays, for GIS people
// who script. A contract (issue 18), documented in the README's "Python" section:
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
// Errors are dsmplan.Error (subclasses InputError, ArgumentError, OutputError, as the C++
// hierarchy) with the library's one-line text. The long calls release the GIL.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/export.hpp"
#include "dsmplan/flight.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/simplify_streamed.hpp"
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

// What every face checks of a mesh before planning on it: metres on the ground (metric_problem()).
void require_metric(const Mesh& mesh) {
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  for (const Vertex& v : mesh.vertices)
    x0 = std::min(x0, v.x), x1 = std::max(x1, v.x), y0 = std::min(y0, v.y), y1 = std::max(y1, v.y);
  const std::string problem = metric_problem(mesh.crs, "mesh", (x0 + x1) / 2, (y0 + y1) / 2);
  if (!problem.empty()) throw InputError("mesh", "", problem);
}

std::shared_ptr<PyFlight> plan(const std::shared_ptr<PyMesh>& mesh,
                               py::array_t<double, py::array::c_style | py::array::forcecast> waypoints,
                               const std::shared_ptr<PyDsm>& dsm, const std::shared_ptr<PyDsm>& dtm, double safety,
                               double max_agl, double spacing, const std::string& planner, bool mission,
                               std::optional<std::array<double, 2>> home, std::optional<std::string> end,
                               const std::string& vertical_crs) {
  FlightRequest request;
  request.waypoints = points_of(waypoints);
  request.names = {"mesh", "waypoints", "dsm", "dtm"};
  request.options.safety = safety;
  request.options.max_agl = max_agl;
  request.options.spacing = spacing;
  if (planner != "prm" && planner != "rrtconnect")
    throw ArgumentError("planner", "must be prm or rrtconnect, got '" + planner + "'");
  request.options.planner = planner == "rrtconnect" ? PlannerKind::rrt_connect : PlannerKind::prm;
  // Shared with the Python objects, not copied: the arrays handed out are read-only.
  request.mesh = std::shared_ptr<const Mesh>(mesh, &mesh->mesh);
  if (dsm) request.dsm = std::shared_ptr<const Grid>(dsm, &dsm->grid);
  if (dtm) request.dtm = std::shared_ptr<const Grid>(dtm, &dtm->grid);
  if (!mission && (home || end)) throw ArgumentError("home", "home and end belong to a mission (mission=True)");
  auto out = std::make_shared<PyFlight>();
  out->crs = mesh->mesh.crs;
  {
    py::gil_scoped_release release;
    require_metric(mesh->mesh);
    std::optional<Wgs84Transform> to_msl;
    if (mission) {
      MissionEnds ends;
      if (home) ends.home = *home;
      if (end) {
        if (*end != "rtl" && *end != "land" && *end != "none")
          throw ArgumentError("end", "must be rtl, land or none, got '" + *end + "'");
        ends.end = *end == "rtl" ? MissionEnd::rtl : *end == "land" ? MissionEnd::land : MissionEnd::none;
      }
      ends.from_lonlat = [&](double lon, double lat) {
        if (!to_msl) to_msl.emplace(out->crs, HeightReference::MeanSeaLevel, VerticalOptions{vertical_crs, false});
        return to_msl->from_wgs84({lon, lat, 0});
      };
      request.mission = ends;
    }
    out->flight = plan_flight(request);
  }
  out->waypoints = request.waypoints;
  static_cast<FlightReport&>(out->report) = out->flight.report;
  return out;
}

}  // namespace

PYBIND11_MODULE(dsmplan, m) {
  m.doc() = "dsmplan: DSM to conservative obstacle mesh to collision-free drone paths";
  m.attr("__version__") = DSMPLAN_VERSION;
  // The C++ hierarchy (core.hpp): catch dsmplan.Error for all, a subclass for one kind.
  auto error = py::register_exception<Error>(m, "Error");
  py::register_exception<InputError>(m, "InputError", error.ptr());
  py::register_exception<ArgumentError>(m, "ArgumentError", error.ptr());
  py::register_exception<OutputError>(m, "OutputError", error.ptr());

  py::class_<PyDsm, std::shared_ptr<PyDsm>>(m, "Dsm", "A DSM raster in memory (read_dsm(), or from a numpy array)")
      .def(py::init(&dsm_from_array), py::arg("heights"), py::arg("transform"), py::arg("crs") = "",
           py::arg("nodata") = py::none(),
           "A DSM from a rows x columns array (row 0 north) with rasterio's affine transform (a, b, c, d, e, f) "
           "= (cell width, 0, west, 0, -cell height, north) and a CRS (\"EPSG:n\", WKT or PROJ); heights equal "
           "to `nodata`, NaN or infinite are holes. The heights are copied.")
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
          "the CRS as WKT (empty when unknown)");

  py::class_<PyMesh, std::shared_ptr<PyMesh>>(m, "Mesh", "A triangle mesh in the DSM's CRS")
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
          "simplify()'s certified error against the DSM at every valid cell; None for mesh()")
      .def(
          "write",
          [](const PyMesh& m, const std::string& path) {
            py::gil_scoped_release release;
            write_mesh(m.mesh, path, mesh_format_for(path));
          },
          py::arg("path"), "Writes .ply, .obj, .off or .glb (by the extension), atomically, with the CRS");

  m.def(
      "read_dsm",
      [](const std::string& path) {
        auto dsm = std::make_shared<PyDsm>();
        py::gil_scoped_release release;
        dsm->grid = read_raster(path);
        return dsm;
      },
      py::arg("path"), "Reads a DSM raster (any GDAL raster or VRT)");
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
      py::arg("dsm"), py::arg("zstep") = 0.1,
      "The XY-3 Delaunay mesh of the DSM (heights in zstep steps; 0 keeps them)");
  m.def(
      "simplify", &simplify, py::arg("dsm"), py::arg("max_error") = 0.4, py::arg("conservative") = true,
      py::arg("delaunay") = false,
      "The bounded simplification: |mesh - DSM| <= max_error (conservative: 0 <= mesh - DSM <= max_error), certified");
  py::class_<PyFlight, std::shared_ptr<PyFlight>>(m, "Flight", "A path planned and verified by plan()")
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
          "report",
          [](const PyFlight& f) { return py::module_::import("json").attr("loads")(to_json(f.report).dump()); },
          "The figures of `dsmplan plan --stats` as a dict: path_length_m, min_clearance_m, min_clearance_dsm_m "
          "(with a DSM), max_agl_m, ground, the mission's home and takeoff, ...")
      .def(
          "write",
          [](PyFlight& f, const std::string& path, const std::string& format, const std::string& firmware,
             const std::string& altitude_frame, double speed, const std::string& vertical_crs,
             bool allow_approximate_vertical) {
            PlanJobOptions options;
            options.output = path;
            options.format = format;
            options.vertical = {vertical_crs, allow_approximate_vertical};
            MissionOptions& m = options.mission.format;
            m.speed = m.hover_speed = speed;
            if (firmware != "generic" && firmware != "px4" && firmware != "ardupilot")
              throw ArgumentError("firmware", "must be px4, ardupilot or generic, got '" + firmware + "'");
            m.firmware = firmware == "px4"         ? Firmware::px4
                         : firmware == "ardupilot" ? Firmware::ardupilot
                                                   : Firmware::generic;
            if (altitude_frame != "relative" && altitude_frame != "amsl")
              throw ArgumentError("altitude_frame", "must be relative or amsl, got '" + altitude_frame + "'");
            m.altitude_frame = altitude_frame == "amsl" ? AltitudeFrame::amsl : AltitudeFrame::relative;
            py::gil_scoped_release release;
            write_flight(f.flight, f.waypoints, f.crs, options, f.report);
          },
          py::arg("path"), py::arg("format") = "", py::arg("firmware") = "generic",
          py::arg("altitude_frame") = "relative", py::arg("speed") = 5.0, py::arg("vertical_crs") = "",
          py::arg("allow_approximate_vertical") = false,
          "Writes the path as `dsmplan plan -o` does, by the extension or `format`: .csv (x,y,z in the CRS), "
          ".geojson (WGS 84), .kml; a flight planned with mission=True also as .plan, .waypoints, .kmz");
  m.def("plan", &plan, py::arg("mesh"), py::arg("waypoints"), py::arg("dsm") = nullptr, py::arg("dtm") = nullptr,
        py::arg("safety") = 2.0, py::arg("max_agl") = 120.0, py::arg("spacing") = 20.0, py::arg("planner") = "prm",
        py::arg("mission") = false, py::arg("home") = py::none(), py::arg("end") = py::none(),
        py::arg("vertical_crs") = "",
        "A collision-free path through the waypoints (K x 3, the mesh's CRS), by the plan stage's plan_flight(), "
        "with every check of `dsmplan plan`: every point at least `safety` from the mesh, and with `dsm` from its "
        "cells as solid columns; at most `max_agl` above the ground (the DTM, else the DSM, else the mesh's "
        "floor); waypoints under the surface, too near or above the ceiling refused; a DTM above the DSM "
        "refused. mission=True plans a takeoff from `home` (x, y or lon, lat; default: under the first "
        "waypoint) and the `end` (rtl, land, none). Returns a Flight; raises dsmplan.InputError when there is "
        "no path, naming the waypoint.");
}
