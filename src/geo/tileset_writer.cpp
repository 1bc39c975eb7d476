// 3D Tiles 1.1 for a GLB of write_mesh(): the tile transform that puts the mesh's projected
// coordinates on the globe, and the tileset.json around it. Follows OGC 22-025r4 ("3D Tiles
// Specification 1.1": 5.2 Coordinate reference system, 5.4 Tile transforms, 5.5 glTF up-axis,
// 5.6 Bounding volumes, 6 Tilesets); WGS 84 geodetic to ECEF from NIMA TR8350.2 (2000), 4.1.
// A projected CRS differs from a local east-north-up frame by the grid convergence, the scale
// factor and the Earth's curvature; an affine transform takes the first two exactly and leaves
// the curvature's sagitta, about d^2 / 8R across a mesh d wide. So it is fitted to PROJ's exact
// transform by least squares, measured against it, and refused past kTilesetMaxPlacementError.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>

#include "core/text.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

namespace {

using Eigen::Vector3d;

// WGS 84 (NIMA TR8350.2, table 3.1): semi-major axis and flattening.
constexpr double kWgs84A = 6378137.0;
constexpr double kWgs84F = 1.0 / 298.257223563;

Vector3d geodetic_to_ecef(const Point3& lonlath) {
  const double e2 = kWgs84F * (2 - kWgs84F);
  const double lon = lonlath[0] * M_PI / 180, lat = lonlath[1] * M_PI / 180, h = lonlath[2];
  const double n = kWgs84A / std::sqrt(1 - e2 * std::sin(lat) * std::sin(lat));
  return {(n + h) * std::cos(lat) * std::cos(lon), (n + h) * std::cos(lat) * std::sin(lon),
          (n * (1 - e2) + h) * std::sin(lat)};
}

// Points of a steps[0] x steps[1] x steps[2] lattice through the box lo..hi, corners included.
template <typename Visit>
void lattice(const Vector3d& lo, const Vector3d& hi, const std::array<int, 3>& steps, Visit visit) {
  for (int i = 0; i < steps[0]; ++i)
    for (int j = 0; j < steps[1]; ++j)
      for (int k = 0; k < steps[2]; ++k) {
        const Vector3d t(double(i) / (steps[0] - 1), double(j) / (steps[1] - 1), double(k) / (steps[2] - 1));
        visit(Vector3d(lo + (hi - lo).cwiseProduct(t)));
      }
}

}  // namespace

TilesetPlacement place_on_globe(const Mesh& mesh, const Wgs84Transform& to_ellipsoid) {
  if (mesh.vertices.empty()) throw ArgumentError("tileset", "the mesh has no vertex to place");
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Vector3d lo(kInf, kInf, kInf), hi(-kInf, -kInf, -kInf);
  for (const Vertex& v : mesh.vertices) {
    lo = lo.cwiseMin(Vector3d(v.x, v.y, v.z));
    hi = hi.cwiseMax(Vector3d(v.x, v.y, v.z));
  }
  // A flat or thin mesh still spans a box: the fit needs every axis, a viewer a volume.
  const Vector3d centre = 0.5 * (lo + hi);
  const Vector3d half = (0.5 * (hi - lo)).cwiseMax(Vector3d(1, 1, 1));
  lo = centre - half;
  hi = centre + half;

  const auto exact = [&](const Vector3d& p) { return geodetic_to_ecef(to_ellipsoid.to_wgs84({p.x(), p.y(), p.z()})); };
  const Vector3d centre_ecef = exact(centre);

  // Least squares: ecef(p) - ecef(centre) ~ A (p - centre) + b, relative to the centre so that
  // the normal equations are well conditioned.
  constexpr std::array<int, 3> kFitSteps{5, 5, 3};
  Eigen::MatrixXd design(kFitSteps[0] * kFitSteps[1] * kFitSteps[2], 4);
  Eigen::MatrixXd target(design.rows(), 3);
  Eigen::Index row = 0;
  lattice(lo, hi, kFitSteps, [&](const Vector3d& p) {
    design.row(row) << (p - centre).transpose(), 1.0;
    target.row(row) = (exact(p) - centre_ecef).transpose();
    ++row;
  });
  const Eigen::MatrixXd solution = design.colPivHouseholderQr().solve(target);  // 4 x 3
  const Eigen::Matrix3d linear = solution.topRows(3).transpose();
  const Vector3d offset = solution.row(3).transpose();

  TilesetPlacement placement;
  placement.heights = to_ellipsoid.description();
  lattice(lo, hi, {9, 9, 3}, [&](const Vector3d& p) {
    const Vector3d affine = centre_ecef + offset + linear * (p - centre);
    placement.max_error_m = std::max(placement.max_error_m, (affine - exact(p)).norm());
  });
  if (!(placement.max_error_m <= kTilesetMaxPlacementError)) {
    const Vector3d size = hi - lo;
    throw ArgumentError("tileset", "the mesh spans " + short_number(size.x()) + " x " + short_number(size.y()) +
                                       " m: one tile transform would place it up to " +
                                       short_number(placement.max_error_m) + " m from PROJ's position (at most " +
                                       short_number(kTilesetMaxPlacementError) +
                                       " m), the Earth curves beneath it; write tiles of about 2 km or less");
  }
  // x_ecef = A x + (centre_ecef + b - A centre), as a column-major 4x4.
  const Vector3d translation = centre_ecef + offset - linear * centre;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) placement.transform[4 * c + r] = linear(r, c);
  for (int r = 0; r < 3; ++r) placement.transform[12 + r] = translation[r];
  placement.transform[15] = 1;
  placement.box = {centre.x(), centre.y(), centre.z(), half.x(), 0, 0, 0, half.y(), 0, 0, 0, half.z()};
  return placement;
}

std::string tileset_json(const TilesetPlacement& placement, const std::string& content_uri, const Crs& crs) {
  using Json = nlohmann::ordered_json;
  const double diagonal = 2 * std::sqrt(placement.box[3] * placement.box[3] + placement.box[7] * placement.box[7] +
                                        placement.box[11] * placement.box[11]);
  Json extras = {{"generator", "dsmplan " DSMPLAN_VERSION},
                 {"content_crs", crs.name.empty() ? crs.definition : crs.name},
                 {"content_axes",
                  "the GLB's positions in content_crs (x east, y north, z up) once its y-up root turn "
                  "is undone; transform: to ECEF (EPSG:4978)"},
                 {"heights", placement.heights},
                 {"max_placement_error_m", placement.max_error_m}};
  if (crs.epsg) extras["content_epsg"] = crs.epsg;
  Json root = {{"boundingVolume", {{"box", placement.box}}},
               {"geometricError", 0},
               {"refine", "ADD"},
               {"transform", placement.transform},
               {"content", {{"uri", content_uri}}}};
  const Json tileset = {
      {"asset", {{"version", "1.1"}, {"extras", extras}}}, {"geometricError", diagonal}, {"root", root}};
  return tileset.dump(2) + "\n";
}

}  // namespace dsmplan
