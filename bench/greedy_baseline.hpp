// A textbook greedy-insertion terrain simplifier, written for bench_table2 as an independent
// yardstick for simplify_bounded(): Garland & Heckbert, "Fast Polygonal Approximation of
// Terrains and Height Fields", CMU-CS-95-181, 1995, algorithm III (Delaunay triangulation,
// one candidate per triangle, a heap of candidates, the worst cell inserted first).
//
// Deliberately plain: single-threaded, CGAL's Delaunay_triangulation_2 for the triangulation,
// vertices at the DSM's own heights, two-sided bound only, no tiling and no shared code with
// src/simplify. Its figures are therefore what "greedy insertion" means without any of the
// library's engineering, and its output is judged by the same certify() as the library's.
#pragma once

#include <cstddef>

#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"

namespace bench {

struct GreedyBaselineResult {
  dsmplan::Mesh mesh;     ///< vertices at cell centres (CRS), triangles counter-clockwise from above
  size_t candidates = 0;  ///< heap entries pushed (the work done, for the record)
  size_t stale = 0;       ///< of them, popped after their triangle was gone
};

/// Greedy insertion until every valid cell centre of `dsm` is within `max_error` (> 0) of the
/// mesh, two-sided. Starts from the four corner cells, which must be valid (throws
/// std::invalid_argument otherwise, and for max_error <= 0). Nodata cells are ignored.
GreedyBaselineResult greedy_insertion_baseline(const dsmplan::Grid& dsm, double max_error);

}  // namespace bench
