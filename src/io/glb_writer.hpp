// The GLB writer behind write_mesh(..., MeshFormat::Glb): see dsmplan/export.hpp for the layout.
#pragma once

#include <cstddef>

#include "core/atomic_file.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"

namespace dsmplan {

/// Writes `mesh` as GLB into `file` (not committed); returns the triangles left out as
/// degenerate in float32.
size_t write_glb(const Mesh& mesh, AtomicFile& file, const Progress& progress);

}  // namespace dsmplan
