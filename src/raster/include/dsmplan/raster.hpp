// dsmplan/raster.hpp: stage 1, the DSM in.
//
// A Grid is a north-up height raster: cell (col, row) covers
//   x in [x0 + col*cell_x, x0 + (col+1)*cell_x),  y in (y0 - (row+1)*cell_y, y0 - row*cell_y]
// and its height stands for the cell centre. Heights are in the vertical unit of the CRS
// (metres for every dataset dsmplan ships with); NaN marks nodata, which becomes a hole.
//
// Sources:
//   read_raster()  any single-band GDAL raster (GeoTIFF, VRT mosaic, ESRI ASCII grid, ...):
//                  raster_io.hpp, with CRSs, units and GeoTIFF output;
//   read_las(), read_xyz() + grid_points()  point clouds gridded with the median (or max) per cell,
//                  the fusion rule of Adolf & Hirschmueller, Section 2: points.hpp.
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

}  // namespace dsmplan
