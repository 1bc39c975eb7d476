// dsmplan/export.hpp: stage 5, results out: mesh files (and the text-file helpers the other
// writers share). Pictures are in picture.hpp, WGS 84 and 3D Tiles in wgs84.hpp, paths and
// drone missions in mission.hpp.
//
// Meshes are written with coordinates in the mesh's CRS, as doubles (binary PLY) or as
// shortest round-trip decimal text (OBJ, OFF), so nothing is lost to float32. Every file says
// its CRS and vertical reference in header comments:
//   PLY:  "comment crs_name ...", "comment crs_epsg N", "comment crs_wkt <single-line WKT2>",
//         "comment vertical ..." ("unknown" when the source did not say)
//   OBJ/OFF: the same lines behind '#'.
// GLB (binary glTF 2.0, for viewers and the web) is the exception: glTF positions are float32,
// so they are stored relative to an origin that the file records as doubles (see write_mesh).
// Writing is atomic: a temporary file in the target folder is renamed into place when complete;
// on any error nothing is left behind and OutputError names the file and the reason.
//
// read_mesh() reads those files back (and the usual variants other tools write) with the CRS.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/mesh.hpp"

namespace dsmplan {

enum class MeshFormat { Ply, Obj, Off, Glb };

/// The format for a file name by its extension (.ply, .obj, .off, .glb, case-insensitive);
/// ArgumentError naming the extension otherwise.
MeshFormat mesh_format_for(const std::string& path);

/// The format named `name` ("ply", "obj", "off", "glb", case-insensitive), as GDAL's `--of`
/// names a driver; ArgumentError(option, ...) listing the names otherwise.
MeshFormat parse_mesh_format(const std::string& name, const std::string& option = "--of");
/// "ply", "obj", "off" or "glb".
const char* to_string(MeshFormat format);

/// Writes `mesh` to `path` in `format`, whatever the path's extension:
///   PLY  binary little-endian, double x,y,z and uint32 indices; O(vertices + triangles), streaming;
///   OBJ, OFF  text, shortest round-trip decimals; streaming;
///   GLB  binary glTF 2.0 (Khronos, https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html),
///        written with tinygltf, laid out as follows.
///        - Origin: the centre of the vertices' bounding box rounded to whole CRS units (as the
///          ClearanceIndex does), so vertex - origin is exact in double for coordinates on the
///          CRS's usual decimal grid.
///        - Positions: float32 POSITION accessor (min and max set) holding vertex - origin in
///          the CRS's axes (x east, y north, z up; CRS units). Each coordinate is off by at most
///          2^-24 of its local magnitude (a 1 km mesh: <= 30 micrometres).
///        - Indices: uint16 when there are at most 65535 vertices (65535 itself is the
///          primitive-restart value), else uint32; mode TRIANGLES; no normals, no material.
///        - Nodes: glTF is y-up, GIS meshes are z-up. The scene's root node "z-up to y-up" has
///          only a rotation, -90 degrees about x (quaternion [-sqrt(1/2), 0, 0, sqrt(1/2)]), so
///          viewers show the mesh upright (glTF x = east, y = up, z = south). Its one child,
///          "mesh", holds the mesh and translation = the origin as doubles, so child translation
///          + position = the vertex in the CRS, without the rotation.
///        - asset.generator "dsmplan VERSION"; asset.extras (JSON objects, fields that are not
///          known are left out): "crs" {"name", "epsg", "wkt"}, "vertical" {"name", "unit"},
///          "origin" [x, y, z] (CRS units, as the child's translation), "axes" (a sentence on
///          the above), "positions" ("float32, vertex minus origin").
///        - Triangles whose three corners are collinear or coincide once rounded to float32
///          (exact test) would have no area: they are left out, and the count is returned. This
///          is stricter than the Khronos validator, which flags only triangles naming a vertex
///          twice (ACCESSOR_INDEX_TRIANGLE_DEGENERATE). dsmplan's meshes of real data have none
///          (the tests check that); a mesh with no triangle left is written as the nodes alone,
///          without buffers. ArgumentError("mesh") when a triangle names a missing vertex.
///        The whole file is built in memory (about 3 x its size: 12 bytes a vertex, 6 or 12
///        bytes a triangle) before it is written; O(vertices + triangles).
/// Atomic; OutputError on failure. Returns the number of triangles left out (0 but for GLB).
size_t write_mesh(const Mesh& mesh, const std::string& path, MeshFormat format, const Progress& progress = {});

class AtomicFile;

/// A binary PLY written block by block as a MeshSink, for meshes larger than memory (the
/// streamed bounded mode): the same file write_mesh() writes for MeshFormat::Ply. Vertices go
/// straight to the file, face records to a scratch file beside it, appended by finish(); the
/// header's two counts are written last into fixed-width fields (the numbers, then spaces, as
/// PLY's whitespace-separated header allows). Memory: one block. Atomic: nothing appears at
/// `path` before finish(); destroyed without finish(), both temporary files are removed.
/// OutputError on any failure.
class PlyStreamWriter : public MeshSink {
public:
  PlyStreamWriter(const std::string& path, const Crs& crs);
  ~PlyStreamWriter() override;
  void append(const std::vector<Vertex>& vertices, const std::vector<Triangle>& triangles) override;
  void finish();

private:
  std::string header(size_t vertices, size_t faces) const;
  std::unique_ptr<AtomicFile> file_, faces_;
  Crs crs_;
  size_t vertices_ = 0, faces_count_ = 0;
  std::vector<char> records_;
};

/// Writes `text` to `path` atomically (temporary file + rename). OutputError on failure.
void write_text_file(const std::string& path, const std::string& text);
/// write_text_file(), the last part of a result of several files (a mesh and its tileset.json,
/// outputs and their --stats): when it fails, the parts written before it (`written`; empty
/// names skipped) are removed too, then the error is rethrown. All or nothing.
void write_text_file_or_remove(const std::string& path, const std::string& text,
                               const std::vector<std::string>& written);

/// OutputError now when `path` could not be written (its temporary file is created next to it
/// and removed): for a second output written after the main one (--stats), so that a bad path
/// fails before the main output exists rather than after, leaving half of the outputs.
void check_writable(const std::string& path);

// ---- mesh files in ------------------------------------------------------------------------

/// Reads a triangle mesh written by write_mesh() or by another tool, in the mesh's own
/// coordinates. The format comes from the content (a PLY file starts with "ply", an OFF file
/// with "OFF"), else from the extension (.ply, .off), else it is read as OBJ:
///   PLY  ascii, binary_little_endian or binary_big_endian 1.0; vertex properties x, y, z as
///        float or double (others, lists too, are skipped); a face list "vertex_indices" (or
///        "vertex_index") with any integer count and index types (other face properties and
///        other elements are skipped);
///   OBJ  "v x y z [...]" and "f" with "v", "v/vt", "v/vt/vn" or "v//vn" words, 1-based or
///        negative (relative) indices; groups, materials, "vt", "vn", lines and points are ignored;
///   OFF  plain "OFF", a "vertices faces [edges]" line, "x y z" lines, "3 a b c [colour]" lines.
/// Vertices and triangles come in file order, indices unchanged, coordinates exactly as stored
/// (float properties widen to double exactly). GLB files are not read (InputError at "header":
/// glTF positions are float32, so use the PLY for further work). The CRS comes from the "crs_name", "crs_epsg",
/// "crs_wkt" and "vertical NAME (UNIT)" comments write_mesh() puts in the header ("unknown" gives
/// an empty field); `definition` is the WKT, else "EPSG:n"; `geographic` is read from the WKT's
/// first CRS keyword. A file without those comments gives an unknown CRS.
/// Throws InputError(path, place, problem), place "header", "line N" or "byte N", for: a missing
/// or unreadable file, anything that does not parse, a face that is not a triangle or names a
/// vertex twice, an index out of range, a coordinate that is NaN or infinite, more than 2^32-1
/// vertices, and a header that declares more records than the file can hold or fewer than it
/// holds (checked before anything is reserved). Memory O(file size + mesh), time O(file size).
Mesh read_mesh(const std::string& path, const Progress& progress = {});

/// The CRS read_mesh() would give, without the vertices and triangles: for a PLY file only its
/// header is read and checked (O(header)); other formats are read whole. Same errors as
/// read_mesh() for what it reads. A GLB (which read_mesh() does not read) gives the CRS its
/// asset.extras name (write_glb()'s `crs` and `vertical`), from its JSON chunk alone; unknown
/// without them; InputError for a JSON chunk that is missing, cut short or not JSON.
Crs read_mesh_crs(const std::string& path);

}  // namespace dsmplan
