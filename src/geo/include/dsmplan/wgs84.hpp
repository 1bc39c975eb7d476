// dsmplan/wgs84.hpp: stage 5, results out: coordinates in WGS 84 and meshes on the globe (PROJ; in
// the library dsmplan_geo).
#pragma once

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"

namespace dsmplan {

// ---- WGS 84: longitude, latitude, height (PROJ; in the library dsmplan_geo) --------------
//
// Coordinates leave dsmplan in WGS 84 for GeoJSON (RFC 7946: longitude, latitude, height above
// the ellipsoid) and drone missions (height above mean sea level, EGM96). The horizontal part
// is exact; the vertical part needs the data's vertical reference (from a compound CRS, a 3D CRS
// whose third axis is the ellipsoidal height, or VerticalOptions::vertical_crs) and a geoid grid
// PROJ has. Where PROJ has only a "ballpark"
// operation (heights copied across datums: for Germany's DHHN2016 without the GCG2016 grid,
// about 47 m wrong), or the reference is unknown, construction fails unless
// allow_approximate_vertical; then the heights are taken as EGM96 heights (EPSG:5773) and go
// through PROJ's EGM96 grid: off by the difference between their datum and EGM96 (typically under
// 1 m), never by the geoid's height. description() names the operation used, and the tools print it.

enum class HeightReference {
  Ellipsoid,    ///< WGS 84 ellipsoidal height (EPSG:4979), GeoJSON's
  MeanSeaLevel  ///< EGM96 height (EPSG:5773), what ground stations call AMSL
};

struct VerticalOptions {
  /// The heights' vertical CRS when the data does not say (e.g. "EPSG:7837"); a geographic 3D CRS
  /// ("EPSG:4979") says they are ellipsoidal heights of its datum (which must be the data's).
  std::string vertical_crs;
  bool allow_approximate_vertical = false;  ///< take heights of an unknown or grid-less datum as EGM96 heights
};

class Wgs84Transform {
public:
  /// From `crs` (+ the vertical reference) to WGS 84 longitude, latitude (degrees) and the
  /// height `target`. `area` (west, south, east, north in degrees, NaN = anywhere) picks the
  /// operation valid there. Throws ArgumentError("--vertical-crs") when the vertical reference
  /// is unknown or only approximately transformable and that is not allowed;
  /// ArgumentError("crs") when PROJ cannot read the CRS or has no transformation.
  Wgs84Transform(const Crs& crs, HeightReference target, const VerticalOptions& options = {},
                 const std::array<double, 4>& area = {NAN, NAN, NAN, NAN});
  ~Wgs84Transform();
  Wgs84Transform(Wgs84Transform&&) noexcept;
  /// x, y only: from `crs`'s horizontal CRS to WGS 84 longitude, latitude (EPSG:4326), by the
  /// best operation PROJ knows there, heights passed through untouched. For placing zones and
  /// other outlines: about 20 ms to build where a transform with heights takes 80-100 ms (PROJ
  /// searches the vertical operations too), and it needs no vertical reference.
  static Wgs84Transform horizontal_only(const Crs& crs, const std::array<double, 4>& area = {NAN, NAN, NAN, NAN});

  /// x, y, z in the CRS to longitude, latitude, height. ArgumentError("crs") when PROJ fails.
  Point3 to_wgs84(const Point3& p) const { return apply(p, true); }
  /// The inverse: longitude, latitude, height to x, y, z in the CRS.
  Point3 from_wgs84(const Point3& p) const { return apply(p, false); }
  /// from_wgs84() in place for many points at once (proj_trans_generic); a point PROJ cannot
  /// transform becomes NaN, NaN, NaN instead of throwing.
  void from_wgs84(std::vector<Point3>& points) const;
  /// PROJ's name of the operation, e.g. "UTM zone 32N to ETRS89 + ...", then "; heights from
  /// <the data's vertical CRS> to <EGM96 height (mean sea level) | WGS 84 ellipsoidal height>"
  /// (PROJ's name omits a vertical step that is the identity); says when heights are approximate
  /// or copied.
  const std::string& description() const { return description_; }
  bool approximate_heights() const { return approximate_; }

private:
  Wgs84Transform() = default;
  Point3 apply(const Point3& p, bool forward) const;
  struct State;
  // Shared, not unique: its deleter is fixed where State is defined, so code that cannot see
  // State (the dsmplan binary's stubs, gdal_stubs.cpp) can still move and destroy the object.
  std::shared_ptr<State> state_;
  std::string description_;
  bool approximate_ = false;
};

// ---- 3D Tiles: a GLB placed on the globe (in the library dsmplan_geo) ---------------------
//
// A 3D Tiles 1.1 tileset (OGC 22-025r4, "3D Tiles Specification 1.1") of one tile whose content
// is a GLB of write_mesh(): what CesiumJS and other globe viewers open. The GLB keeps its
// coordinates (the mesh's CRS, z up; the viewer undoes its root node's y-up turn, as the
// specification's "glTF up-axis" section says); the tile's `transform` maps those coordinates
// to Earth-centred, Earth-fixed ones (EPSG:4978, metres). A projected CRS is not a local
// east-north-up frame (grid convergence, scale factor, the Earth's curvature), so the transform
// is the affine map that fits PROJ's exact transform best (least squares) over the mesh's
// bounding box, and its largest departure from PROJ's, measured on a lattice through the box,
// is reported and bounded.

/// The largest departure from PROJ's transform a tileset may have: the mesh's own default
/// height step (--zstep 0.1 m). Reached by a mesh about 2.2 km across (the sagitta, (d/2)^2 / 2R).
constexpr double kTilesetMaxPlacementError = 0.1;

struct TilesetPlacement {
  std::array<double, 16> transform{};  ///< column-major 4x4: CRS x, y, z (metres) to ECEF
  std::array<double, 12> box{};        ///< boundingVolume.box in CRS coordinates: centre, 3 half-axes
  double max_error_m = 0;              ///< largest |affine - PROJ| over a 9 x 9 x 3 lattice of the box
  std::string heights;                 ///< the operation used (Wgs84Transform::description())
};

/// Fits the tile transform for `mesh` (its bounding box) through `to_ellipsoid` (a Wgs84Transform
/// to HeightReference::Ellipsoid; WGS 84 geodetic to ECEF in closed form). Throws
/// ArgumentError("--3dtiles") for a mesh without vertices, or when max_error_m would exceed
/// kTilesetMaxPlacementError (the message gives the mesh's size and asks for smaller tiles);
/// ArgumentError("crs") when PROJ cannot transform a corner. O(vertices) + 319 transforms.
TilesetPlacement place_on_globe(const Mesh& mesh, const Wgs84Transform& to_ellipsoid);

/// tileset.json text: asset.version "1.1", one root tile (refine ADD, geometricError 0) with the
/// placement's transform and box and `content.uri` (the GLB's name relative to the tileset),
/// tileset geometricError the box's diagonal; asset.extras names the CRS, the height operation
/// and max_error_m.
std::string tileset_json(const TilesetPlacement& placement, const std::string& content_uri, const Crs& crs);

}  // namespace dsmplan
