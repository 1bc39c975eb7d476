// Pieces every tool job shares: stage timing (Stopwatch), the refusal of CRSs in degrees and of
// empty meshes, and the memory figures of the up-front refusal of inputs too big for the machine.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/stopwatch.hpp"
#include "core/text.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/picture_job.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

/// A picture's waypoint CSV (render, profile, view) read as `dsmplan plan` reads it: x,y,z in the
/// CRS, or, when its header names the third column "agl", heights above the ground `ground_of`
/// gives (the DTM, else the DSM, as plan counts them: waypoints_in_crs()), asked only then,
/// turned into the CRS's. InputError naming the file: an agl file whose `ground_of` gives null
/// (the message says `give_ground`, e.g. "give --dtm or --dsm"), a waypoint over no ground, and
/// every error of read_waypoints_csv().
std::vector<Point3> read_picture_waypoints(const std::string& path, const std::function<const Grid*()>& ground_of,
                                           const std::string& ground_name, const std::string& give_ground);

/// Appends ("total", sum of the stages) to a report's stage seconds.
inline void add_total(std::vector<std::pair<std::string, double>>& seconds) {
  double total = 0;
  for (const auto& [stage, value] : seconds) total += value;
  seconds.emplace_back("total", total);
}

/// Memory a job needs per DSM cell on top of the 4-byte height, for the up-front refusal of
/// inputs too big for the machine. Peak resident memory above `dsmplan info`'s on the 1000 x 1000
/// NRW tile, rounded up: the mesh ~55 B (a vertex of three doubles, two triangles of three
/// indices, a vertex number per cell); the paper's simplification ~240 B (the mesh, its neighbour
/// lists and the CGAL triangulation of the survivors); the bounded mode ~35 B (tiles of it).
constexpr double kMeshBytesPerCell = 64, kPaperSimplifyBytesPerCell = 256, kBoundedBytesPerCell = 48;

/// Cells of a width x height grid of cell_x x cell_y resampled to `resolution` (ceil(extent/res)
/// per axis, as resample() makes them), as a double so that a tiny --res cannot overflow.
inline double resampled_cells(int width, int height, double cell_x, double cell_y, double resolution) {
  return std::ceil(width * cell_x / resolution) * std::ceil(height * cell_y / resolution);
}

/// True when `path` names a mesh file by its extension (what mesh_format_for() accepts).
inline bool is_mesh_file(const std::string& path) {
  try {
    mesh_format_for(path);
    return true;
  } catch (const ArgumentError&) {
    return false;
  }
}

/// A mesh with no triangle is no obstacle model (and every planner would fly through it):
/// InputError naming the DSM `path` and its size when a job's mesh came out empty.
inline void require_triangles(size_t triangles, int width, int height, const std::string& path) {
  if (triangles > 0) return;
  throw InputError(
      path, "",
      std::to_string(width) + " x " + std::to_string(height) +
          " cells give no triangle: a mesh needs three valid cells, not in a line, within --max-edge of each other");
}

// ---- --3dtiles (tileset_beside.cpp) ----

/// Before the work: ArgumentError("--3dtiles") unless the output is a GLB; OutputError when
/// tileset_path_for(output) cannot be written. Nothing without `tileset`.
void check_tileset_request(bool tileset, MeshFormat format, const std::string& output);

/// With `tileset`, the transform to WGS 84 ellipsoidal heights the tileset needs, built as soon as
/// the CRS is known so that an unknown vertical reference is refused before the work
/// (Wgs84Transform's ArgumentError("--vertical-crs")); none without.
std::optional<Wgs84Transform> tileset_heights(bool tileset, const Crs& crs, const VerticalOptions& vertical);

/// write_mesh(), and with `heights` the tileset.json beside it (`report` filled); when the tileset
/// cannot be written, the mesh file is removed again. Returns write_mesh()'s dropped triangles.
size_t write_mesh_output(const Mesh& mesh, const std::string& output, MeshFormat format,
                         const std::optional<Wgs84Transform>& heights, std::optional<TilesetReport>& report,
                         const Progress& progress);

// ---- pictures (render_job.cpp, profile_job.cpp) ----

/// ArgumentError(flag, or the output when no flag) unless `output` ends in .png; OutputError when
/// it cannot be written. Before any work.
void check_png_output(const std::string& output, const std::string& flag);
/// render_job() and profile_job() up to the picture, nothing written: a caller that writes other
/// files of the same run draws first, so a refusal leaves nothing behind (`dsmplan plan --render`).
std::pair<Image, RenderReport> render_picture(const RenderJobOptions& options, const Progress& progress = {});
std::pair<Image, ProfileReport> profile_picture(const ProfileJobOptions& options, const Progress& progress = {});

// ---- no-fly zones in pictures (zone_files.cpp) ----

/// The zones of every file of `files` (read_airspace()) in `crs`, in order, with which
/// restrictions block; empty without files (the pictures then are as without zones).
ZoneLayer read_zone_layer(const ZoneFiles& files, const Crs& crs);

/// The zones of `files` as `dsmplan view` hands them to its page (view_zones.cpp): JSON
/// {"zones": [{caption, label, restriction, blocks, rings: [[[x, y], ...], ...] in the GLB's
/// CRS, floor and ceiling: {reference: "ground" | "crs" | "unlimited", height}}]}. InputError
/// when the GLB names no CRS, and the reader's for a bad file.
std::string view_zones_json(const ZoneFiles& files, const std::string& glb);

/// The zones (as the plan read them, in its CRS) as a KML path carries them (kml_zones.cpp):
/// named, their corners in WGS 84 through `to_msl` (the path's transformation), AGL limits
/// relative to the ground, CRS heights above mean sea level; empty without zones.
std::vector<KmlZone> kml_zones_of(const ZoneLayer& layer, const Wgs84Transform& to_msl);

/// The zones a mission's flat geofence can carry (fence_zones.cpp): the blocking ones whose rings
/// the path as flown (`flown`, CRS) keeps out of seen from above, every ring a keep-out area in
/// WGS 84 longitude, latitude; the others named in `left_out` with why.
struct KeepOut {
  std::vector<std::vector<std::array<double, 2>>> areas;
  size_t zones = 0;                                           ///< zones whose rings are in `areas`
  std::vector<std::pair<std::string, std::string>> left_out;  ///< zone caption, why
};
KeepOut keep_out_areas(const ZoneLayer& zones, const std::vector<Point3>& flown, const Wgs84Transform& to_wgs84);

}  // namespace dsmplan
