// --3dtiles: the tileset.json that puts a GLB of `dsmplan mesh|simplify` on the globe (3D Tiles
// 1.1, see place_on_globe() in dsmplan/export.hpp), written beside it. The two files are one
// output: the tileset is computed before the GLB is written, and a tileset that cannot be
// written takes the GLB with it.
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include "dsmplan/tools.hpp"
#include "tools/job_parts.hpp"
#include "tools/report_json.hpp"

namespace dsmplan {

std::string tileset_path_for(const std::string& output) {
  return (std::filesystem::path(output).parent_path() / "tileset.json").string();
}

void check_tileset_request(bool tileset, MeshFormat format, const std::string& output) {
  if (!tileset) return;
  if (format != MeshFormat::Glb)
    throw ArgumentError("--3dtiles", "places a GLB on the globe: write one (-o " +
                                         std::filesystem::path(output).stem().string() + ".glb, or --of glb)");
  // One tileset.json a folder: one that places another GLB (an earlier run's) is not replaced.
  const std::string path = tileset_path_for(output);
  const std::string glb = std::filesystem::path(output).filename().string();
  std::error_code ec;
  if (std::filesystem::exists(path, ec)) {
    std::string placed;
    try {
      // A tileset of one tile is a few kB: read at most 1 MB, and only of a regular file.
      if (!std::filesystem::is_regular_file(path, ec)) throw std::runtime_error("not a file");
      std::ifstream in(path, std::ios::binary);
      std::string text(1 << 20, '\0');
      in.read(text.data(), static_cast<std::streamsize>(text.size()));
      text.resize(static_cast<size_t>(in.gcount()));
      const Json tileset = Json::parse(text);
      placed = tileset.at("root").at("content").at("uri").get<std::string>();
    } catch (const std::exception&) {
      throw OutputError(path, "is not a tileset of dsmplan's; --3dtiles writes one here beside " + glb +
                                  ": move it, or write the GLB into another folder");
    }
    if (placed != glb)
      throw OutputError(path, "places " + placed + " on the globe, not " + glb +
                                  ": write this GLB into a folder of its own (one tileset.json a folder)");
  }
  check_writable(path);
}

std::optional<Wgs84Transform> tileset_heights(bool tileset, const Crs& crs, const VerticalOptions& vertical) {
  if (!tileset) return std::nullopt;
  return Wgs84Transform(crs, HeightReference::Ellipsoid, vertical);
}

size_t write_mesh_output(const Mesh& mesh, const std::string& output, MeshFormat format,
                         const std::optional<Wgs84Transform>& heights, std::optional<TilesetReport>& report,
                         const Progress& progress) {
  if (!heights) return write_mesh(mesh, output, format, progress);
  const TilesetPlacement placement = place_on_globe(mesh, *heights);
  const std::string path = tileset_path_for(output);
  const std::string uri = std::filesystem::path(output).filename().string();
  const size_t dropped = write_mesh(mesh, output, format, progress);
  write_text_file_or_remove(path, tileset_json(placement, uri, mesh.crs), {output});
  report = TilesetReport{path, placement.max_error_m, placement.heights};
  return dropped;
}

}  // namespace dsmplan
