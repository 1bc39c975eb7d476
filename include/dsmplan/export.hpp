// dsmplan/export.hpp: stage 5, results out.
//
// Meshes are written with coordinates in the mesh's CRS, as doubles (binary PLY) or as
// shortest round-trip decimal text (OBJ, OFF), so nothing is lost to float32. Every file says
// its CRS and vertical reference in header comments:
//   PLY:  "comment crs_name ...", "comment crs_epsg N", "comment crs_wkt <single-line WKT2>",
//         "comment vertical ..." ("unknown" when the source did not say)
//   OBJ/OFF: the same lines behind '#'.
// Writing is atomic: a temporary file in the target folder is renamed into place when complete;
// on any error nothing is left behind and OutputError names the file and the reason.
#pragma once

#include <string>

#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"

namespace dsmplan {

enum class MeshFormat { Ply, Obj, Off };

/// The format for a file name by its extension (.ply, .obj, .off, case-insensitive);
/// ArgumentError naming the extension otherwise.
MeshFormat mesh_format_for(const std::string& path);

/// Writes `mesh` to `path` in `format` (binary little-endian PLY with double x,y,z and
/// uint32 indices; OBJ and OFF as text). O(vertices + triangles), streaming.
void write_mesh(const Mesh& mesh, const std::string& path, MeshFormat format, const Progress& progress = {});

/// Writes `text` to `path` atomically (temporary file + rename). OutputError on failure.
void write_text_file(const std::string& path, const std::string& text);

}  // namespace dsmplan
