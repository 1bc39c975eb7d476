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
#include <functional>
#include <optional>
#include <string>
#include <vector>

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
  /// The height of the cell under (x, y) as measured: NaN where it was a hole, beyond the raster,
  /// or over no ground.
  double measured_at(double x, double y) const;
  /// Half the range of the ground over the 3 x 3 cells around the one under (x, y): how far its
  /// height moves when the place is off by a cell (a position fix's error, a cell's size). NaN
  /// beyond the raster or over no ground.
  double spread_at(double x, double y) const;
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

// ---- A terrain that disagrees with its surface ------------------------------------------------
//
// A DTM is the ground under the DSM: nowhere above it but by the noise of two surveys. A DTM in
// another vertical datum than the DSM (or one whose offset was lost) stands above it everywhere
// by the datums' difference, and every height counted from it (the ceiling, a mission's relative
// altitudes) puts the drone that much lower than the path that was checked. So such a pair is
// refused, not flown: at any place the user named (home, a waypoint, the landing) the terrain may
// stand at most kTerrainAboveSurfaceM above the surface, and over their common extent it may do
// so on at most kTerrainAboveShare of the cells (water, which a DTM bridges and a DSM does not,
// and the cells of a coarse DTM on a slope).

/// The most the terrain may stand above the surface at one place, metres.
constexpr double kTerrainAboveSurfaceM = 1.0;
/// The largest share of the compared cells where it may stand higher than that.
constexpr double kTerrainAboveShare = 0.05;

/// A place the user named, where the terrain is compared with the surface.
struct NamedPlace {
  std::string name;  ///< e.g. "waypoint 2", "home"
  double x = 0, y = 0;
};

/// Where and why a terrain cannot be the ground under a surface.
struct TerrainProblem {
  std::string place;    ///< a NamedPlace's name, or empty for the share of the cells
  std::string problem;  ///< one line, naming `surface_name`
};

/// Compares `terrain` (its cells that were holes left out) with the surface `surface_z(x, y)`
/// (metres; NaN where unknown, which is not compared) at `places`, then at the centres of at
/// most 512 x 512 of the terrain's cells (a lattice, row by row from the north: `surface_z` may
/// keep the row it read last). `surface_name` names the surface in the problem ("the DSM
/// dsm.tif"). std::nullopt when the terrain lies below the surface within the limits above.
/// O(places + 512^2) calls of surface_z.
std::optional<TerrainProblem> terrain_above_surface(const GroundGrid& terrain,
                                                    const std::function<double(double, double)>& surface_z,
                                                    const std::vector<NamedPlace>& places,
                                                    const std::string& surface_name);

}  // namespace dsmplan
