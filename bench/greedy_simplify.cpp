// The greedy-insertion baseline (bench/greedy_baseline.hpp: Garland & Heckbert, CMU-CS-95-181,
// 1995, algorithm III) as a whole process, the yardstick of issue 19 point 3: a DSM in, a binary
// PLY out, as `dsmplan simplify DSM --max-error E -o OUT.ply` does, so that both are timed the
// same way from outside (bench/simplify_process.sh).
//
//   greedy_simplify DSM HALF_BAND OUT.ply   two-sided bound: every valid cell within HALF_BAND
//                                           (0.2 = the band width of --max-error 0.4 --conservative)
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "dsmplan/export.hpp"
#include "dsmplan/raster_io.hpp"
#include "greedy_baseline.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: greedy_simplify DSM HALF_BAND OUT.ply\n");
    return 2;
  }
  try {
    const dsmplan::Grid dsm = dsmplan::read_raster(argv[1]);
    bench::GreedyBaselineResult result = bench::greedy_insertion_baseline(dsm, std::atof(argv[2]));
    result.mesh.crs = dsm.crs;
    dsmplan::write_mesh(result.mesh, argv[3], dsmplan::MeshFormat::Ply);
    std::printf("%zu vertices, %zu triangles\n", result.mesh.vertices.size(), result.mesh.triangles.size());
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "greedy_simplify: %s\n", error.what());
    return 1;
  }
}
