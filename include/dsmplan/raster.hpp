// dsmplan/raster.hpp: stage 1, the DSM in.
//
// A Grid is a north-up height raster: cell (col, row) covers
//   x in [x0 + col*cell_x, x0 + (col+1)*cell_x),  y in (y0 - (row+1)*cell_y, y0 - row*cell_y]
// and its height stands for the cell centre. Heights are in the vertical unit of the CRS
// (metres for every dataset dsmplan ships with); NaN marks nodata, which becomes a hole.
//
// Sources:
//   read_raster()  any single-band GDAL raster (GeoTIFF, VRT mosaic, ESRI ASCII grid, ...);
//   read_las(), read_xyz() + grid_points()  point clouds gridded with the median (or max) per cell,
//                  the fusion rule of Adolf & Hirschmueller, Section 2.
// Transforms (all O(cells), no GDAL involved):
//   resample()     block aggregation to a coarser resolution (median by default, max conservative);
//   quantize_height()  the vertical resolution of Table 1 (0.1 m steps).
//
// Errors: InputError naming the file and place (cell, line, byte offset); see core.hpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"

namespace dsmplan {

struct Grid {
  int width = 0, height = 0;      ///< columns, rows
  double x0 = 0, y0 = 0;          ///< top-left corner of cell (0, 0), CRS units
  double cell_x = 1, cell_y = 1;  ///< cell size along x and y, > 0 (rows run south)
  std::vector<float> z;           ///< row-major heights, NaN = nodata
  Crs crs;

  static constexpr float nodata = std::numeric_limits<float>::quiet_NaN();

  Grid() = default;
  Grid(int w, int h, double x0_, double y0_, double cx, double cy)
      : width(w),
        height(h),
        x0(x0_),
        y0(y0_),
        cell_x(cx),
        cell_y(cy),
        z(static_cast<size_t>(w) * static_cast<size_t>(h), nodata) {}

  size_t cells() const { return z.size(); }
  size_t index(int col, int row) const { return static_cast<size_t>(row) * width + col; }
  float at(int col, int row) const { return z[index(col, row)]; }
  bool valid(int col, int row) const { return !std::isnan(at(col, row)); }
  double center_x(int col) const { return x0 + (col + 0.5) * cell_x; }
  double center_y(int row) const { return y0 - (row + 0.5) * cell_y; }
  double x1() const { return x0 + width * cell_x; }   ///< east edge
  double y1() const { return y0 - height * cell_y; }  ///< south edge
  /// The cell whose square holds (x, y), its west and north edges included: false outside.
  bool cell_at(double x, double y, int& col, int& row) const {
    const double c = std::floor((x - x0) / cell_x), r = std::floor((y0 - y) / cell_y);
    if (!(c >= 0 && c < width && r >= 0 && r < height)) return false;
    col = static_cast<int>(c), row = static_cast<int>(r);
    return true;
  }
  /// The height of the cell under (x, y) (cell_at()); NaN outside the grid or on nodata.
  float height_at(double x, double y) const {
    int col = 0, row = 0;
    return cell_at(x, y, col, row) ? at(col, row) : NAN;
  }
};

/// A north-up raster read by windows: how a DSM larger than memory is processed in blocks
/// (simplify_bounded()). Implementations: GridView (a Grid in memory) and open_raster() (GDAL).
class GridSource {
public:
  virtual ~GridSource() = default;
  /// Size, georeference and CRS of the whole raster; its `z` is empty.
  virtual const Grid& frame() const = 0;
  /// Heights of the window [col0, col0 + w) x [row0, row0 + h), which must lie inside the frame,
  /// row-major into `out` (w * h floats), NaN for nodata. Throws InputError naming the file and
  /// cell for an infinite height or an undeclared NaN. Not thread-safe: one reader at a time.
  virtual void read(int col0, int row0, int w, int h, float* out) = 0;
};

/// The window [col0, col0 + w) x [row0, row0 + h) of `source` as a Grid of its own: the frame's
/// cell size and CRS, its corner where the window lies. Preconditions and errors as read().
Grid read_window(GridSource& source, int col0, int row0, int w, int h);

/// A Grid in memory as a GridSource. It refers to `grid`, which must outlive it. Throws what
/// check_grid() throws: the frame and heights a reader would have refused.
class GridView : public GridSource {
public:
  explicit GridView(const Grid& grid);
  const Grid& frame() const override { return frame_; }
  void read(int col0, int row0, int w, int h, float* out) override;

private:
  const Grid& grid_;
  Grid frame_;
};

/// Counts and ranges of a grid, computed in one pass.
struct GridSummary {
  size_t cells = 0, valid = 0, nodata = 0;
  size_t holes = 0;                 ///< 4-connected regions of nodata cells
  double z_min = NAN, z_max = NAN;  ///< over valid cells; NaN when there are none
};
GridSummary summarize(const Grid& grid);

// ---- resampling ---------------------------------------------------------------------------

enum class Resampling {
  Median,  ///< median of the cells whose centres fall in the block (default; robust, the paper's fusion rule)
  Max,     ///< highest cell: conservative, never lowers an obstacle
  Mean,
  Min,
  Nearest  ///< the cell under the block centre
};
const char* to_string(Resampling);
/// Parses "median", "max", "mean", "min", "nearest"; throws ArgumentError otherwise.
Resampling parse_resampling(const std::string& name);

/// Aggregates `grid` to square cells of size `resolution` (CRS units). The output keeps the
/// input's top-left corner and covers it completely: ceil(width*cell_x/resolution) columns.
/// An output cell aggregates the valid input cells whose centres lie inside it; with none it
/// is nodata. resolution equal to the input's returns a copy. Throws ArgumentError when
/// resolution <= 0 or not finite, and what check_grid() refuses. O(input cells).
Grid resample(const Grid& grid, double resolution, Resampling method, const Progress& progress = {});

/// No projected CRS reaches farther than this from its origin (CRS units).
constexpr double kMaxCoordinate = 1e9;
/// No height on Earth is farther from its datum than this (metres): beyond it a cell is a
/// nodata sentinel nobody declared (-FLT_MAX, 1e20, ...).
constexpr double kMaxHeight = 1e5;

/// ArgumentError("DSM", ...) for a grid the stages cannot work on: a georeference that is not
/// finite, cells not positive, anything beyond kMaxCoordinate or cells finer than 1e-9 of it,
/// or a height that is infinite or beyond kMaxHeight (NaN is nodata). The readers refuse the same
/// with the file and cell named; resample(), triangulate_xy3() and simplify_bounded() call this for grids
/// made in memory. O(cells).
void check_grid(const Grid& grid);
/// Why a grid's georeference (positive cells assumed) is unusable: it reaches beyond
/// kMaxCoordinate, or its cells are finer than 1e-9 of that reach; empty when it is fine. What
/// check_grid() and the GDAL reader both test.
std::string frame_problem(const Grid& frame);

/// Rounds heights to the nearest multiple k*step of the vertical resolution (step <= 0: no
/// rounding). When 1/step is a whole number n (0.1, 0.25, 1 ...) the result is k/n, the double
/// nearest to the decimal k*step, so 0.1-steps print as 123.4, not 123.40000000000001.
class HeightQuantizer {
public:
  explicit HeightQuantizer(double step);
  double operator()(double z) const {
    if (!(step_ > 0) || !std::isfinite(z)) return z;
    return per_unit_ > 0 ? std::round(z * per_unit_) / per_unit_ : std::round(z / step_) * step_;
  }

private:
  double step_;
  double per_unit_ = 0;  ///< n when step = 1/n exactly enough, else 0
};

inline double quantize_height(double z, double step) { return HeightQuantizer(step)(z); }

// ---- point clouds ------------------------------------------------------------------------

struct PointCloud {
  std::vector<double> x, y, z;
  std::vector<uint8_t> classification;  ///< ASPRS class per point (0 when the source has none)
  Crs crs;                              ///< from the file (LAS WKT or GeoTIFF keys); may be unknown
  double min_x = INFINITY, min_y = INFINITY, min_z = INFINITY;
  double max_x = -INFINITY, max_y = -INFINITY, max_z = -INFINITY;

  size_t size() const { return x.size(); }
  void add(double px, double py, double pz, uint8_t cls);
};

/// Reads a LAS 1.0-1.4 file, point formats 0-10, or a LAZ file (LASzip-compressed formats 0-3
/// and 6-8, decoded by dsmplan's own decoder on all cores: dsmplan/laz.hpp) into the same points.
/// Checks the header against the file (signature, sizes, point count x record length <= file
/// size, scale factors; for LAZ the VLR and chunk table); a header that lies gives InputError
/// naming the field. CRS from the OGC WKT VLR/EVLR (record 2112) or the GeoTIFF key directory
/// (record 34735, EPSG codes only). O(points).
PointCloud read_las(const std::string& path, const Progress& progress = {});

/// Reads "x y z [class]" text lines (separators: blanks, comma, semicolon). Blank lines and
/// lines starting with '#' are skipped, as is a first line without any digit (a column header).
/// A line that does not parse gives InputError with its line number. No CRS.
PointCloud read_xyz(const std::string& path, const Progress& progress = {});

/// read_las or read_xyz by extension (.las / .xyz, .txt, .csv); InputError for anything else.
PointCloud read_points(const std::string& path, const Progress& progress = {});

enum class Fusion {
  Median,  ///< median height of the points in a cell (mean of the two middle ones when even)
  Max
};
const char* to_string(Fusion);
/// Parses "median" or "max"; throws ArgumentError otherwise.
Fusion parse_fusion(const std::string& name);

struct GridPointsOptions {
  double resolution = 1.0;  ///< cell size, CRS units, > 0
  Fusion fusion = Fusion::Median;
  std::vector<int> drop_classes = {7, 18};  ///< ASPRS low/high noise by default
  /// When not empty: only points of these ASPRS classes are gridded (e.g. {2}, ground: a DTM).
  /// A class both kept and dropped is an ArgumentError (clear drop_classes to keep noise classes).
  std::vector<int> keep_classes;
  /// Memory the caller will hold beside the grid while it lives (a writer's buffers, e.g.
  /// geotiff_buffer_bytes()), counted in the up-front refusal.
  double other_bytes = 0;
};

/// Grids point clouds (all in one CRS) into one DSM. The grid is aligned to multiples of the
/// resolution and just covers the kept points; a point on a cell's west/north edge belongs to
/// that cell (up to floating-point rounding of x/resolution). At most 2^31-1 cells. Cells
/// without points are nodata (filling holes is a separate, explicit step). Throws ArgumentError
/// for resolution <= 0, a class outside 0-255 or in both keep_classes and drop_classes,
/// InputError when no point is left after filtering.
/// O(points log points-per-cell).
Grid grid_points(const std::vector<PointCloud>& clouds, const GridPointsOptions& options,
                 const Progress& progress = {});

// ---- the DSM as solid columns --------------------------------------------------------------
//
// What dsmplan guarantees a path against (columns.hpp) is the DSM read literally: every valid cell
// a box over its whole square, from below up to its height. Nodata is unknown space.

/// Which height of its rim a nodata region takes: `highest` for obstacles (no path passes
/// through a hole lower than the hole's rim), `lowest` for the ground a ceiling counts from.
enum class RimHeight { highest, lowest };

/// Gives every 4-connected nodata region of `grid` the highest (or lowest) height of the valid
/// cells touching it, diagonals included. A grid without a valid cell stays as it is. Returns
/// the number of regions filled. O(cells).
size_t fill_holes_from_rim(Grid& grid, RimHeight rule);

/// The heights at the corners of the DSM's cells: a Grid of (width + 1) x (height + 1) "cells"
/// centred on the DSM's cell corners (its x0, y0 half a cell west and north), each the highest
/// valid cell meeting at that corner (NaN where none does). A surface on or above the
/// piecewise-linear interpolation of these corners over every cell encloses the DSM's columns;
/// simplify_bounded(column_envelope(dsm), conservative) builds such a surface, and
/// certify_columns() (simplify.hpp) measures any mesh against the columns exactly. O(cells).
Grid column_envelope(const Grid& dsm);

// ---- GDAL I/O (the only part of this module that needs GDAL/PROJ) -------------------------

struct ReadRasterOptions {
  int band = 1;
  std::string assign_crs;  ///< CRS of the raster, overriding what it states ("EPSG:25832", WKT, ...), as gdal_translate -a_srs
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

/// Opens one band of any GDAL raster for reading by windows (GridSource), with the checks of
/// read_raster() that need no cells (file, band, geotransform, CRS) done here and the per-cell
/// ones (NaN, infinity) done on each window read. Memory: GDAL's block cache only, whatever the
/// raster's size. VRT mosaics are read through, window by window.
std::unique_ptr<GridSource> open_raster(const std::string& path, const ReadRasterOptions& options = {});

/// Fills `crs.name`, `crs.epsg`, `crs.wkt` and the vertical fields from `crs.definition`
/// (PROJ via GDAL's OGRSpatialReference). Throws ArgumentError when it cannot be parsed.
void resolve_crs(Crs& crs);

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

/// Why dsmplan cannot measure in `crs`: x, y must be metres of a projected CRS, heights metres
/// (or of unknown unit). Empty when they are; otherwise one line for InputError(path, "", ...)
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
/// from valid data. Holes farther away stay holes.
void fill_holes(Grid& grid, double max_distance, const Progress& progress = {});

}  // namespace dsmplan
