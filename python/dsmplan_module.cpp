// The Python module `dsmplan` (pybind11): the library's stages on numpy arrays, for GIS people
// who script. A contract (issue 18), documented in the README's "Python" section:
//   dsm = dsmplan.read_dsm(path)        .heights (rows x columns float32, nodata NaN; a read-only view of the DSM's
//                                       own memory), .transform (GDAL geotransform), .crs (WKT)
//   mesh = dsmplan.simplify(dsm, max_error=0.4, conservative=True)   the bounded mode;
//                                       .vertices N x 3 float64, .faces M x 3 uint32 (views of
//                                       the mesh), .certified {max_above_m, max_below_m, rms_m}
//   mesh = dsmplan.mesh(dsm)            the XY-3 mesh of the paper's Section 3
//   path = dsmplan.plan(mesh, waypoints, safety=2.0, max_agl=120.0)   K x 3 float64, CRS
//   mesh.write(path)                    .ply, .obj, .off or .glb by the extension
// Errors are dsmplan.Error with the library's one-line text. The long calls release the GIL.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/export.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/simplify_streamed.hpp"

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

py::array_t<double> plan(const PyMesh& mesh, py::array_t<double, py::array::c_style | py::array::forcecast> waypoints,
                         double safety, double max_agl, double spacing) {
  if (waypoints.ndim() != 2 || waypoints.shape(1) != 3)
    throw ArgumentError("waypoints", "must be a K x 3 array of x, y, z in the mesh's CRS");
  std::vector<Point3> points(static_cast<size_t>(waypoints.shape(0)));
  const auto w = waypoints.unchecked<2>();
  for (size_t i = 0; i < points.size(); ++i) points[i] = {w(i, 0), w(i, 1), w(i, 2)};
  PlanOptions options;
  options.safety = safety;
  options.max_agl = max_agl;
  options.spacing = spacing;
  auto path = std::make_unique<std::vector<Point3>>();
  {
    py::gil_scoped_release release;
    check_plan_options(options);
    const ClearanceIndex index(mesh.mesh);
    PlanResult result = plan_path(index, points, options);
    if (result.status != PlanStatus::Solved) throw InputError("waypoints", result.place(), result.problems());
    *path = std::move(result.path);
  }
  // The path's own memory, owned by the array from here on: no copy.
  std::vector<Point3>* data = path.release();
  py::capsule owner(data, [](void* p) { delete static_cast<std::vector<Point3>*>(p); });
  return py::array_t<double>({static_cast<py::ssize_t>(data->size()), py::ssize_t{3}},
                             {py::ssize_t(sizeof(Point3)), py::ssize_t(sizeof(double))},
                             data->empty() ? nullptr : (*data)[0].data(), owner);
}

}  // namespace

PYBIND11_MODULE(dsmplan, m) {
  m.doc() = "dsmplan: DSM to conservative obstacle mesh to collision-free drone paths";
  m.attr("__version__") = DSMPLAN_VERSION;
  py::register_exception<Error>(m, "Error");

  py::class_<PyDsm, std::shared_ptr<PyDsm>>(m, "Dsm", "A DSM raster in memory (read_dsm())")
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
  m.def("plan", &plan, py::arg("mesh"), py::arg("waypoints"), py::arg("safety") = 2.0, py::arg("max_agl") = 120.0,
        py::arg("spacing") = 20.0,
        "A collision-free path through the waypoints (K x 3, the mesh's CRS): every point at least `safety` "
        "from the mesh and at most `max_agl` above its floor. Raises dsmplan.Error when there is none.");
}
