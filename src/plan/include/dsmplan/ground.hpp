// dsmplan/ground.hpp: the ground a ceiling is counted from (dsmplan plan --max-agl), part of
// stage 4 (plan.hpp).
//
// A GroundGrid is a height raster read as the ground directly below: a point's height above
// ground is its z less the height of the cell whose square holds it. Which raster:
//   - the terrain, `dsmplan plan --dtm DTM` (any resolution, the DSM's CRS);
//   - else the DSM itself (`--dsm`, or a DSM planned over directly): above roofs over roofs;
//   - else, planning on a mesh alone, the mesh's floor: each cell the lowest the mesh comes over
//     it, bounded from below (floor_of()), so a height above it is never understated.
// Nodata is unknown ground: each hole takes the lowest height of its rim (fill_holes_from_rim,
// RimHeight::lowest), so a height above it is never understated either. Beyond the raster the
// ground is unknown and every height above it is infinite: nothing flies there.
//
// max_height_above(p, q) is exact, not sampled: the ground is constant over each cell, so the
// greatest height of a straight segment above it is reached where the segment enters or leaves
// a cell; the segment is walked cell by cell (Amanatides & Woo, "A Fast Voxel Traversal
// Algorithm for Ray Tracing", Eurographics 1987). Where it passes exactly through a corner, the
// two cells touching it only there are measured too, and so are the cells its ends touch and,
// along a line between cells, the cells on both sides: each cell counts as its closed square. Cost O(cells crossed).
// below_ceiling() walks the 8 x 8 blocks the segment crosses instead, settles each by its lowest ground when it can,
// and walks the cells of the others only (and the whole segment where it passes exactly through a block's corner):
// O(blocks crossed) for most segments.
// dips_below() and rises_above() are the quick refusals the planner tries before those exact
// walks: one point per cell length along the segment, each a proof when it answers.
#pragma once

#include <cstdint>

#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

class GroundGrid {
public:
  GroundGrid() = default;  ///< no ground: every height above it is infinite
  /// `ground`'s holes take the lowest height of their rim; a grid without a valid cell is no
  /// ground. O(cells).
  explicit GroundGrid(Grid ground);
  /// A lower bound of `mesh`'s surface on cells of side `cell` over the mesh's x,y box: each
  /// cell the least, over the triangles whose x,y box meets it, of the larger of the
  /// triangle's lowest corner and its plane's lowest value over that meeting rectangle.
  /// ArgumentError for cell <= 0 or not finite. O(triangles x cells each box meets).
  static GroundGrid floor_of(const Mesh& mesh, double cell);

  bool empty() const { return grid_.cells() == 0; }
  const Grid& grid() const { return grid_; }
  /// p's z less the ground of the cell below (on a side or corner of cells, the lowest of the
  /// cells it touches); +infinity beyond the raster or over no ground.
  double height_above(const Point3& p) const;
  /// The greatest height above ground of any point of the segment [p, q] (exact; see the top).
  double max_height_above(const Point3& p, const Point3& q) const;
  /// max_height_above(p, q) <= ceiling, settled by the block bound when it can be.
  bool below_ceiling(const Point3& p, const Point3& q, double ceiling) const;
  /// A lower bound of the ground within the x,y square of half-side r around (x, y), from the
  /// blocks it meets: -infinity where the square leaves the raster. A segment inside the square
  /// is below the ceiling when its higher end is at most ceiling above this. O((r / block)^2).
  double lowest_near(double x, double y, double r) const;
  /// True when a point of the segment [p, q] lies less than `height` above the ground of a cell
  /// that holds it; the cells that were holes (filled from their rim) do not count. Sampled, one
  /// point per cell length along the segment (its middle when it is shorter): true is proven by
  /// the point found, false proves nothing. O(cells crossed), no walk.
  bool dips_below(const Point3& p, const Point3& q, double height) const;
  /// True when a point of the segment [p, q] lies more than `height` above the ground of a cell
  /// that holds it (holes counted at their filled height, as max_height_above() counts them), so
  /// max_height_above(p, q) > height. Sampled like dips_below().
  bool rises_above(const Point3& p, const Point3& q, double height) const;
  /// A hash of the raster's georeference and heights (roadmap files record what they were built over).
  uint64_t fingerprint() const;
  /// True where the cell (grid().index(col, row)) was a hole, its height filled from its rim.
  bool was_hole(size_t cell) const { return !hole_.empty() && hole_[cell]; }

private:
  double cell_ground(int col, int row) const { return grid_.z[grid_.index(col, row)]; }
  struct Walk {  ///< a segment in cell units
    Walk(const GroundGrid& g, const Point3& p, const Point3& q);
    double pu, pv, du, dv, pz, dz;
    bool inside;
  };
  double walk(const Walk& w, double t0, double t1, int col, int row, double stop) const;
  double touching(double u, double v, double z) const;
  Grid grid_;
  static constexpr int block = 8;
  int block_cols_ = 0, block_rows_ = 0;
  std::vector<float> block_low_;  ///< lowest ground of each block x block cells
  std::vector<bool> hole_;        ///< where the cells were holes (a bit each); empty when none was
  /// fn(z - ground, col, row) at the samples of dips_below(); true as soon as fn is.
  template <class F>
  bool any_sample(const Point3& p, const Point3& q, F&& fn) const;
};

}  // namespace dsmplan
