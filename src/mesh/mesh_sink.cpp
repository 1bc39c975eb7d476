// Meshes delivered block by block (MeshSink), collected into one Mesh.
#include "dsmplan/mesh.hpp"

namespace dsmplan {

void MeshCollector::append(const std::vector<Vertex>& vertices, const std::vector<Triangle>& triangles) {
  mesh_.vertices.insert(mesh_.vertices.end(), vertices.begin(), vertices.end());
  mesh_.triangles.insert(mesh_.triangles.end(), triangles.begin(), triangles.end());
}

}  // namespace dsmplan
