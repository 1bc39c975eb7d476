// dsmplan/picture_job.hpp: `dsmplan render` and `dsmplan profile` as library functions (the
// drawing itself is picture.hpp's): read the DSM, mesh and path, draw, write the PNG, report.
// Errors and reports as tools.hpp.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "dsmplan/picture.hpp"
#include "dsmplan/tools.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

/// No-fly zone files to draw (`--no-fly`), read as `dsmplan plan` reads them: read_airspace()
/// (airspace_io.hpp) into the DSM's CRS, AMSL and WGS 84 limits through `vertical`, and which
/// restrictions block (empty: PROHIBITED and REQ_AUTHORISATION). A bad file is the reader's
/// InputError naming it.
struct ZoneFiles {
  std::vector<std::string> files;
  std::vector<std::string> blocking;
  VerticalOptions vertical;  ///< --vertical-crs, --allow-approximate-vertical
};

// ---- dsmplan render -------------------------------------------------------------------------

struct RenderJobOptions {
  std::string dsm;                  ///< DSM raster: the ground of every panel
  std::vector<std::string> meshes;  ///< one panel each (.ply, .obj, .off, in the DSM's CRS)
  std::vector<std::string> titles;  ///< per panel; missing ones are the mesh (or DSM) file names
  std::string output;               ///< .png
  ReadRasterOptions read;
  std::optional<double> resolution;  ///< resample the DSM (median) to this cell size first
  /// window, zoom, edges, scale bar, north arrow (title: per panel); its lines, markers and zones
  /// (in memory, in the DSM's CRS) are drawn with the files' (over their lines and markers).
  RenderOptions render;
  std::shared_ptr<const Grid> dsm_grid;  ///< the DSM in memory: drawn instead of reading `dsm` (its name)
  std::vector<std::string> paths;        ///< path CSVs (x,y,z as `dsmplan plan` writes them), drawn on every panel
  std::string waypoints;  ///< waypoint CSV (x,y,z, or x,y,agl above the DSM): numbered discs on every panel
  std::string roadmap;    ///< roadmap file (`dsmplan plan --roadmap`): its edges, thin, under the paths
  ZoneFiles no_fly;       ///< zones drawn on every panel (RenderOptions::zones), under the paths
};

struct RenderReport {
  std::string output;
  int width = 0, height = 0;  ///< of the whole picture, pixels
  size_t panels = 0;
  Window window;    ///< the area drawn (--window, else the DSM's outer cell edges), CRS units
  double zoom = 0;  ///< pixels per cell (--zoom)
};

/// The paper's Figures 3 and 6-8: one hillshaded panel per mesh with its edges drawn (and the
/// roadmap, paths and waypoints over it when given), side by
/// side (8 pixels apart), or one panel of the DSM alone when there is no mesh; written as a PNG
/// atomically. Checks before reading: the output ends in .png, --res, the window and the zoom
/// (ArgumentError), at most one title per panel ("--title"). A mesh whose header names an EPSG
/// code other than the DSM's, or that lies wholly outside the DSM, is an InputError naming it.
RenderReport render_job(const RenderJobOptions& options, const Progress& progress = {});
/// Keys: output, width, height, panels, window ([xmin, ymin, xmax, ymax]), zoom.
Json to_json(const RenderReport& report);

// ---- dsmplan profile ------------------------------------------------------------------------

struct ProfileJobOptions {
  std::string dsm;        ///< DSM raster: the silhouette under the path
  std::string path;       ///< path CSV (x,y,z as `dsmplan plan` writes them), in the DSM's CRS
  std::string output;     ///< .png
  std::string dtm;        ///< terrain raster (optional): the ground of the ceiling, a brown line
  std::string waypoints;  ///< waypoint CSV (optional; x,y,agl above the DTM, else the DSM): numbered markers
  /// size, title (empty: "PATH over DSM"), safety, max_agl; its waypoints (used when `waypoints`
  /// is empty) and zones (drawn with `no_fly`'s) in memory
  ProfileOptions profile;
  ZoneFiles no_fly;  ///< zones over the section (ProfileOptions::zones), AGL over the DTM, else the DSM
  /// In memory, as the caller has them: the path (then `path` is only its name, for the title),
  /// the DSM and the DTM (drawn instead of reading `dsm` and `dtm`, their names).
  std::vector<Point3> path_points;
  std::shared_ptr<const Grid> dsm_grid, dtm_grid;
};

struct ProfileReport {
  std::string output;
  int width = 0, height = 0;
  double length = 0;                                         ///< the path's x,y length
  double min_above_dsm = NAN, min_above_dsm_at = NAN;        ///< least height above the DSM cell below, where
  double max_above_ground = NAN, max_above_ground_at = NAN;  ///< greatest above the ground, where
  /// Least height above the lowest clear height (the height that keeps `safety` from the DSM's
  /// columns: negative where the path comes nearer), every half cell along the path, and where;
  /// NaN with a safety of 0 or no DSM cell within it.
  double min_above_lowest_clear = NAN, min_above_lowest_clear_at = NAN;
  bool ground_is_dtm = false;
  double max_agl = 0;  ///< the ceiling above the ground
};

/// The height profile of a path (render_profile()) as a PNG, written atomically. Refused before
/// anything is written: an output not named .png (ArgumentError); a path with fewer than two
/// points or a point outside the DSM's extent, a DSM in degrees, a DTM whose EPSG code differs
/// from the DSM's or that does not overlap the DSM (InputError naming the file). Only the DSM's
/// and DTM's windows around the path are read, so the DSM may be a city's VRT mosaic.
ProfileReport profile_job(const ProfileJobOptions& options, const Progress& progress = {});
/// One line: "PROFILE.png: path 659.2 m long, least 3.82 m above the DSM below it (at 587.9 m),
/// at most 25.60 m above the DSM (at 294.8 m), ceiling DSM + 30 m kept with 4.40 m to spare"
/// ("EXCEEDED by X m" when the path rises above the ceiling).
std::string to_text(const ProfileReport& report);
/// output, width, height, length_m, min_above_dsm_m (and _at_m), min_above_lowest_clear_m (and
/// _at_m; null without), max_above_ground_m (and _at_m), ground ("dtm" or "dsm"), max_agl_m.
Json to_json(const ProfileReport& report);

}  // namespace dsmplan
