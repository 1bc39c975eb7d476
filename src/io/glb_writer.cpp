// GLB: the binary container of glTF 2.0 (The Khronos Group, "glTF 2.0 Specification",
// https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html; sections 3.5 Buffers, 3.6
// Accessors, 3.7.2 Meshes, 3.5.3 Node transformations, 4.4 GLB File Format), built with tinygltf.
// glTF positions are float32 and its up axis is +y; dsmplan's meshes are doubles in a z-up
// CRS, so the positions are stored relative to a recorded origin and a root node rotates the
// scene upright. The layout is documented with write_mesh() in dsmplan/export.hpp.
#include "io/glb_writer.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace dsmplan {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;

constexpr int kArrayBuffer = 34962;         // bufferView.target for vertex attributes
constexpr int kElementArrayBuffer = 34963;  // bufferView.target for indices

constexpr const char* kAxes =
    "positions and the mesh node's translation are in the CRS's axes (x east, y north, z up; CRS units); "
    "the root node rotates them by -90 degrees about x into glTF's y-up frame (glTF x = east, y = up, z = south)";

template <typename T>
void append_bytes(std::vector<unsigned char>& out, const T* data, size_t count) {
  const size_t at = out.size();
  out.resize(at + count * sizeof(T));
  std::memcpy(out.data() + at, data, count * sizeof(T));
}

tinygltf::Value string_value(const std::string& text) { return tinygltf::Value(text); }

// asset.extras: what a GIS reader needs to put the mesh back where it belongs.
tinygltf::Value extras(const Crs& crs, const std::array<double, 3>& origin) {
  tinygltf::Value::Object crs_object;
  if (!crs.name.empty()) crs_object["name"] = string_value(crs.name);
  if (crs.epsg) crs_object["epsg"] = tinygltf::Value(crs.epsg);
  if (!crs.wkt.empty()) crs_object["wkt"] = string_value(crs.wkt);
  tinygltf::Value::Object vertical;
  if (!crs.vertical_name.empty()) vertical["name"] = string_value(crs.vertical_name);
  if (!crs.vertical_unit.empty()) vertical["unit"] = string_value(crs.vertical_unit);
  tinygltf::Value::Array origin_array;
  for (double v : origin) origin_array.emplace_back(v);
  tinygltf::Value::Object all;
  // An empty object would come out as null: leave out what is not known instead.
  if (!crs_object.empty()) all["crs"] = tinygltf::Value(std::move(crs_object));
  if (!vertical.empty()) all["vertical"] = tinygltf::Value(std::move(vertical));
  all["origin"] = tinygltf::Value(std::move(origin_array));
  all["axes"] = string_value(kAxes);
  all["positions"] = string_value("float32, vertex minus origin");
  return tinygltf::Value(std::move(all));
}

}  // namespace

size_t write_glb(const Mesh& mesh, AtomicFile& file, const Progress& progress) {
  // The origin: whole units, so v - origin is exact for coordinates on the usual decimal grid
  // and the float32 rounding is the only loss.
  std::array<double, 3> lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                           std::numeric_limits<double>::infinity()};
  std::array<double, 3> hi{-lo[0], -lo[1], -lo[2]};
  for (const Vertex& v : mesh.vertices) {
    const double c[3] = {v.x, v.y, v.z};
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], c[k]);
      hi[k] = std::max(hi[k], c[k]);
    }
  }
  std::array<double, 3> origin{0, 0, 0};
  if (!mesh.vertices.empty())
    for (int k = 0; k < 3; ++k) origin[k] = std::round(0.5 * (lo[k] + hi[k]));

  std::vector<float> positions(3 * mesh.vertices.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vertex& v = mesh.vertices[i];
    positions[3 * i] = static_cast<float>(v.x - origin[0]);
    positions[3 * i + 1] = static_cast<float>(v.y - origin[1]);
    positions[3 * i + 2] = static_cast<float>(v.z - origin[2]);
  }
  report(progress, 0.2);

  // Triangles with no area in float32 (collinear or coincident corners, exact predicate on the
  // stored floats) are left out. The Khronos validator flags only those naming a vertex twice
  // (ACCESSOR_INDEX_TRIANGLE_DEGENERATE); three distinct but collinear floats pass it, yet have
  // no normal for a renderer, so the test here is the stricter one.
  auto point = [&](uint32_t i) {
    return Kernel::Point_3(positions[3 * size_t(i)], positions[3 * size_t(i) + 1], positions[3 * size_t(i) + 2]);
  };
  std::vector<uint32_t> indices;
  indices.reserve(3 * mesh.triangles.size());
  size_t dropped = 0;
  for (const Triangle& t : mesh.triangles) {
    for (uint32_t i : t)
      if (i >= mesh.vertices.size())
        throw ArgumentError(
            "mesh", "a triangle names vertex " + std::to_string(i) + " of " + std::to_string(mesh.vertices.size()));
    if (CGAL::collinear(point(t[0]), point(t[1]), point(t[2]))) {
      ++dropped;
      continue;
    }
    indices.insert(indices.end(), t.begin(), t.end());
  }
  report(progress, 0.5);

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "dsmplan " DSMPLAN_VERSION;
  model.asset.extras = extras(mesh.crs, origin);

  tinygltf::Node root;
  root.name = "z-up to y-up";
  root.rotation = {-std::sqrt(0.5), 0.0, 0.0, std::sqrt(0.5)};
  root.children = {1};
  tinygltf::Node child;
  child.name = "mesh";
  child.translation = {origin[0], origin[1], origin[2]};

  if (!indices.empty()) {
    // glTF accessors need count >= 1, so a mesh with no triangle left gets no mesh at all.
    tinygltf::Buffer buffer;
    append_bytes(buffer.data, positions.data(), positions.size());
    const size_t position_bytes = buffer.data.size();  // a multiple of 4: indices stay aligned
    const bool small = mesh.vertices.size() <= 65535;  // 65535 is primitive restart for uint16
    if (small) {
      std::vector<uint16_t> narrow(indices.begin(), indices.end());
      append_bytes(buffer.data, narrow.data(), narrow.size());
    } else {
      append_bytes(buffer.data, indices.data(), indices.size());
    }
    const size_t index_bytes = buffer.data.size() - position_bytes;
    model.buffers.push_back(std::move(buffer));

    tinygltf::BufferView position_view;
    position_view.buffer = 0;
    position_view.byteOffset = 0;
    position_view.byteLength = position_bytes;
    position_view.target = kArrayBuffer;
    tinygltf::BufferView index_view;
    index_view.buffer = 0;
    index_view.byteOffset = position_bytes;
    index_view.byteLength = index_bytes;
    index_view.target = kElementArrayBuffer;
    model.bufferViews = {position_view, index_view};

    // min and max of the stored floats themselves: the spec requires them, validators compare
    // them exactly, and a float widens to double (and prints) exactly.
    std::array<float, 3> fmin{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
                              std::numeric_limits<float>::infinity()};
    std::array<float, 3> fmax{-fmin[0], -fmin[1], -fmin[2]};
    for (size_t i = 0; i < positions.size(); ++i) {
      fmin[i % 3] = std::min(fmin[i % 3], positions[i]);
      fmax[i % 3] = std::max(fmax[i % 3], positions[i]);
    }
    tinygltf::Accessor position_accessor;
    position_accessor.bufferView = 0;
    position_accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    position_accessor.count = mesh.vertices.size();
    position_accessor.type = TINYGLTF_TYPE_VEC3;
    position_accessor.minValues = {fmin[0], fmin[1], fmin[2]};
    position_accessor.maxValues = {fmax[0], fmax[1], fmax[2]};
    tinygltf::Accessor index_accessor;
    index_accessor.bufferView = 1;
    index_accessor.componentType =
        small ? TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT : TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    index_accessor.count = indices.size();
    index_accessor.type = TINYGLTF_TYPE_SCALAR;
    model.accessors = {position_accessor, index_accessor};

    tinygltf::Primitive primitive;
    primitive.attributes["POSITION"] = 0;
    primitive.indices = 1;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    tinygltf::Mesh gltf_mesh;
    gltf_mesh.name = "mesh";
    gltf_mesh.primitives.push_back(primitive);
    model.meshes.push_back(std::move(gltf_mesh));
    child.mesh = 0;
  }
  model.nodes = {root, child};
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  report(progress, 0.7);

  std::ostringstream out(std::ios::binary);
  tinygltf::TinyGLTF gltf;
  if (!gltf.WriteGltfSceneToStream(&model, out, false, true) || !out) {
    throw OutputError(file.path(), "tinygltf could not serialize the GLB");
  }
  model = tinygltf::Model();  // the buffer's copy is in `out` now
  const std::string bytes = std::move(out).str();
  file.write(bytes.data(), bytes.size());
  return dropped;
}

}  // namespace dsmplan
