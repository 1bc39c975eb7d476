// Reads a DSM, meshes and simplifies it with the installed dsmplan, and prints what it got.
#include <cstdio>
#include <dsmplan/mesh.hpp>
#include <dsmplan/raster.hpp>
#include <dsmplan/raster_io.hpp>
#include <dsmplan/simplify.hpp>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  try {
    const dsmplan::Grid dsm = dsmplan::read_raster(argv[1]);
    const dsmplan::Mesh mesh = dsmplan::triangulate_xy3(dsm);
    const dsmplan::VerticalError error = dsmplan::certify(mesh, dsm);
    std::printf("%d %d %zu %zu %.6f\n", dsm.width, dsm.height, mesh.vertices.size(), mesh.triangles.size(),
                error.max_above);
  } catch (const dsmplan::Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
