// dsmplan/points.hpp: stage 1, the DSM in: point clouds (LAS, LAZ, XYZ) gridded by the median.
//
// grid_points(): point clouds (read by point_io.hpp: LAS, LAZ, XYZ) gridded with the median (or max) per
// cell, the fusion rule of Adolf & Hirschmueller, Section 2. Errors: InputError naming the
// file and place (line, byte offset); see core.hpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

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
  /// Memory the caller will hold per cell of the grid beside it (filling its holes in memory:
  /// fill_holes_bytes_per_cell()), counted in the same refusal.
  double other_bytes_per_cell = 0;
};

/// The classes `dsmplan grid` grids, from its three choices: one rule for every face (the CLI's
/// flags, Python's keyword arguments). `keep` (--classes) alone keeps exactly those classes,
/// noise too when listed; `drop` (--drop-classes; none or empty: the default 7, 18) is dropped
/// besides; `keep_all` (--keep-all-classes) keeps every class, noise included, and with `keep`
/// is an ArgumentError ("keep_classes"). Sets options.keep_classes and options.drop_classes; the
/// classes' range and a class both kept and dropped are grid_points()'s to refuse.
void choose_classes(GridPointsOptions& options, const std::vector<int>& keep,
                    const std::optional<std::vector<int>>& drop, bool keep_all);

/// Grids point clouds (all in one CRS) into one DSM. The grid is aligned to multiples of the
/// resolution and just covers the kept points; a point on a cell's west/north edge belongs to
/// that cell (up to floating-point rounding of x/resolution). At most 2^31-1 cells. Cells
/// without points are nodata (filling holes is a separate, explicit step). Throws ArgumentError
/// for resolution <= 0, a class outside 0-255 or in both keep_classes and drop_classes,
/// InputError when no point is left after filtering.
/// O(points log points-per-cell).
Grid grid_points(const std::vector<PointCloud>& clouds, const GridPointsOptions& options,
                 const Progress& progress = {});

}  // namespace dsmplan
