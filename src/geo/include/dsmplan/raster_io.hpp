// dsmplan/raster_io.hpp: stage 1, the DSM in: rasters read and written through GDAL, CRSs and units
// through GDAL/PROJ (the only part of the raster stage that needs them; in the library
// dsmplan_geo).
//
// Errors: InputError naming the file and place (cell, window); ArgumentError naming the option.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

// ---- GDAL I/O (the only part of this module that needs GDAL/PROJ) -------------------------

struct ReadRasterOptions {
  int band = 1;
  std::string
      assign_crs;  ///< CRS of the raster, overriding what it states ("EPSG:25832", WKT, ...), as gdal_translate -a_srs
  bool allow_no_crs = false;
  /// Describe x, y or heights in a unit other than the metre instead of refusing them (`info`).
  bool allow_other_units = false;
  /// Memory the caller will need per cell of this raster beyond the cell's 4-byte height (e.g.
  /// for the mesh it will make of it): the total is checked against the machine before reading.
  double extra_bytes_per_cell = 0;
};

/// Reads one band of any GDAL raster. Declared nodata becomes NaN. Throws InputError when the
/// file is missing or not a raster, has no cells or no valid cell, has a rotated geotransform,
/// has NaN (not declared nodata) or infinite heights (naming the first cell and its
/// coordinates), has no CRS and none is assigned, has x, y or heights in a unit other than the
/// metre (metric_problem(), units only; unless options.allow_other_units), or would need more
/// memory than the machine has (4 bytes a cell, 5 with a mask band, plus
/// options.extra_bytes_per_cell), before reading. The vertical unit is the compound CRS's, or
/// the band's unit type (GDALGetRasterUnitType) when the CRS has none or it is not metres. O(cells).
Grid read_raster(const std::string& path, const ReadRasterOptions& options = {}, const Progress& progress = {});

/// The metadata item by which a GeoTIFF with a 2D projected CRS says its heights are above its
/// datum's ellipsoid: GDAL 3.6 keeps no 3D projected CRS in GeoTIFF keys, so dsmplan's
/// satellite DSMs state "EPSG:4979 (heights above the WGS 84 ellipsoid)" or "heights above the
/// <datum> ellipsoid" here, and open_raster() and read_raster() read such a raster's CRS as
/// made three-dimensional (easting, northing, ellipsoidal height), as dsmplan wrote it.
constexpr const char* kEllipsoidalHeightsKey = "VERTICAL_CRS";

/// Opens one band of any GDAL raster for reading by windows (GridSource), with the checks of
/// read_raster() that need no cells (file, band, geotransform, CRS) done here and the per-cell
/// ones (NaN, infinity) done on each window read. Memory: GDAL's block cache only, whatever the
/// raster's size. VRT mosaics are read through, window by window.
std::unique_ptr<GridSource> open_raster(const std::string& path, const ReadRasterOptions& options = {});

/// The files GDAL reads to read the raster `path` (GDALDataset::GetFileList(): the file itself,
/// and for a VRT mosaic its sources); empty when GDAL cannot open it (quietly: the raster's
/// reader says what is wrong with it). Call require_input_file() first: GDAL would wait forever
/// on a FIFO.
std::vector<std::string> raster_file_list(const std::string& path);

/// Fills `crs.name`, `crs.epsg`, `crs.wkt` and the vertical fields from `crs.definition`
/// (PROJ via GDAL's OGRSpatialReference). Throws ArgumentError when it cannot be parsed.
void resolve_crs(Crs& crs);

// ---- progress on a terminal ----------------------------------------------------------------

/// One step of GDAL's terminal progress ("0...10...20...30...40...50...60...70...80...90...100 -
/// done." on stdout, as the GDAL utilities print it) at `fraction` (0..1). False when the user
/// asked to stop (never, today).
bool print_terminal_progress(double fraction);

// ---- units: dsmplan measures in metres ----------------------------------------------------

/// Metres per `unit`, a unit's name or abbreviation as CRSs and raster bands spell it ("metre",
/// "m", "ft", "foot", "US survey foot", "ftUS", "us-ft", ... and every linear unit of PROJ's
/// database; case, '_' and '-' do not matter); 0 when it names no known length unit.
double unit_metres(const std::string& unit);

/// Fills what `crs` does not say yet of its units from its WKT (or definition) and names:
/// geographic, linear_unit, linear_unit_m (and the vertical ones of a compound CRS), and
/// vertical_unit_m from vertical_unit. For a Crs read from a mesh header (name, EPSG, WKT).
void resolve_units(Crs& crs);

/// "EPSG:326zz" (north) or "EPSG:327zz" (south): the WGS 84 / UTM zone holding the point (x, y)
/// of `crs`, zone = floor((longitude + 180) / 6) + 1. Empty when it cannot be transformed.
std::string utm_epsg_at(const Crs& crs, double x, double y);

/// The most a projected CRS's scale factor may depart from 1 at the data (0.5 %): UTM inside its
/// zone (0.9996 to 1.001) passes, Web Mercator (1.6 at 51 N) does not.
constexpr double kMaxScaleDeparture = 0.005;

/// Why dsmplan cannot measure in `crs`: x, y must be metres of a projected CRS, heights metres
/// (or of unknown unit), and unless `units_only`, the CRS neither geocentric nor one whose
/// scale factor at (centre_x, centre_y) departs from 1 by more than kMaxScaleDeparture (PROJ's
/// meridional and parallel scales: a safety distance in its metres must be one on the ground).
/// Empty when they are; otherwise one line for InputError(path, "", ...)
/// naming the unit and a way out, e.g. "CRS 'NAD83 / Virginia North (ftUS)' has horizontal unit
/// US survey foot (0.3048006 m): dsmplan measures in metres; reproject first, e.g. gdalwarp
/// -t_srs EPSG:32618 dsm_ft.tif dsm_m.tif". The example's UTM zone is that of (centre_x,
/// centre_y), the data's centre in `crs`; the example suits `path` by its extension (gdalwarp
/// for rasters, PDAL for point clouds, remaking a mesh from its DSM). `units_only`: a geographic
/// CRS passes (its degrees are the caller's to refuse). Never converts: refusing is the choice.
std::string metric_problem(const Crs& crs, const std::string& path, double centre_x, double centre_y,
                           bool units_only = false);

/// Writes a Float32 GeoTIFF (DEFLATE, tiled, nodata -9999). Atomic: temp file + rename.
/// Holds at most geotiff_buffer_bytes() beside the grid.
void write_geotiff(const Grid& grid, const std::string& path, const Progress& progress = {});
/// The memory GDAL's block cache may take while writing: GDAL_CACHEMAX, capped at an eighth of
/// machine_memory_bytes() (so under ulimit -v too).
double geotiff_buffer_bytes();

/// GDAL's FillNodata (inverse-distance interpolation) for holes up to `max_distance` cells
/// from valid data. Holes farther away stay holes. All in memory (GDAL's work rasters too:
/// its default writes _PID_fill_*_work.tif files to the current folder or CPL_TMPDIR, which an
/// interrupted run left behind and a read-only folder refused): fill_holes_bytes_per_cell()
/// beside the grid.
void fill_holes(Grid& grid, double max_distance, const Progress& progress = {});
/// The memory fill_holes() takes beside the grid, per cell: its copy and GDAL's two work
/// rasters (4 bytes a cell each).
constexpr double fill_holes_bytes_per_cell() { return 12; }

}  // namespace dsmplan
