// dsmplan/simplify_streamed.hpp: stage 3's bounded mode (simplify.hpp) out of core, block by
// block from a GridSource into a MeshSink, for DSMs larger than memory and for the MPI farm.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/simplify.hpp"

namespace dsmplan {

// ---- the bounded mode out of core: blocks, streamed ----------------------------------------
//
// simplify_bounded() works block by block: a block is block_tiles x block_tiles tiles, read
// from a GridSource as one window (the block plus a margin of one tile, for the heights of tile
// corners that lie on nodata). Every tile border is simplified from the cells on that border
// alone, so a block computes exactly the borders its neighbours compute: blocks, like tiles,
// meet watertight, with no cracks and no T-junctions, and each can be made anywhere (another
// thread, another MPI rank) in any order. Vertices are then numbered in one pass in block order
// and, inside a block, in tile order, each at its first use; the numbering carries the shared
// seams from block to block in two rows of ids. So the mesh is the same, bit for bit, whether
// the grid was in memory, read window by window from a VRT mosaic, or farmed out to processes.
// Memory: O(block cells + grid width): the whole process peaked at 192 MB on a 10,000 x 10,000
// mosaic (bench_city), whatever the grid's height; the mesh goes to a MeshSink as it is made.

/// How a grid is cut: tile borders at columns xs and rows ys (cell indices, first 0, last
/// width - 1 or height - 1), blocks of `block_tiles` tiles a side.
struct BoundedLayout {
  std::vector<int> xs, ys;
  int tile = 0, block_tiles = 0;
  size_t blocks_x = 0, blocks_y = 0;
  size_t blocks() const { return blocks_x * blocks_y; }
};
/// The layout simplify_bounded() uses for a width x height grid. Throws ArgumentError for a bad
/// option or fewer than 2 x 2 cells.
BoundedLayout bounded_layout(int width, int height, const BoundedSimplifyOptions& options);

/// One block's triangles before numbering, tile by tile: three corners a triangle, each a cell
/// (col, row of the whole grid) and the vertex's height; counter-clockwise from above. With the
/// certified error of the block's cells (certify() on each tile) and its count of valid cells.
struct BoundedTile {
  std::vector<int32_t> cols, rows;
  std::vector<double> heights;
};
struct BoundedBlock {
  size_t index = 0;
  std::vector<BoundedTile> tiles;
  VerticalError error;
  size_t valid_cells = 0;
};

/// Makes block `index` of `layout` (row-major over blocks), reading its window from `dsm`;
/// tiles on `threads` threads (0: every core). The result does not depend on `threads`.
BoundedBlock simplify_bounded_block(GridSource& dsm, const BoundedLayout& layout, size_t index,
                                    const BoundedSimplifyOptions& options);

/// Numbers the blocks' vertices and passes them on; blocks must come in index order.
class BoundedAssembler {
public:
  BoundedAssembler(const Grid& frame, const BoundedLayout& layout, MeshSink& sink);
  void add(const BoundedBlock& block);
  size_t vertices() const { return next_id_; }
  size_t triangles() const { return triangles_; }

private:
  const Grid& frame_;
  const BoundedLayout& layout_;
  MeshSink& sink_;
  size_t expected_ = 0, next_id_ = 0, triangles_ = 0;
  std::vector<uint32_t> seam_above_, seam_below_, seam_left_, ids_;
  std::vector<Vertex> vertices_;
  std::vector<Triangle> triangles_out_;
};

struct BoundedStreamResult {
  size_t vertices = 0, triangles = 0, valid_cells = 0, blocks = 0;
  VerticalError error;  ///< certify() of every block's tiles, merged: the whole mesh's
};

/// The bounded mode over a GridSource, into a MeshSink, block by block (see above). The next
/// block is read while the current one is made. Throws what simplify_bounded() throws, and
/// ArgumentError when no cell is valid (found at the end: the sink has then had everything).
BoundedStreamResult simplify_bounded(GridSource& dsm, const BoundedSimplifyOptions& options, MeshSink& sink,
                                     const Progress& progress = {});

}  // namespace dsmplan
