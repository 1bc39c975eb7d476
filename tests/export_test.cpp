// Export stage: mesh files read back by an independent reader (CGAL's polygon-soup I/O) must give
// exactly the mesh written, with the CRS in the header, and failed writes must leave nothing.
// read_mesh must give back exactly what write_mesh wrote and refuse broken files; pictures must
// have the promised size, change only where edges are drawn, and read back through libpng.
#include "dsmplan/export.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>
#include <gdal.h>
#include <gtest/gtest.h>
#include <ogr_api.h>
#include <ogr_spatialref.h>
#include <png.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <tuple>
#include <vector>

#include "dsmplan/airspace_io.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/mission.hpp"
#include "dsmplan/picture.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/wgs84.hpp"
#include "dsmplan/wpml.hpp"
#include "testkit.hpp"

using namespace dsmplan;

namespace {

// A real mesh with holes: the NRW crop's south-west corner with its lowest parts cut away.
Mesh real_mesh() {
  Grid grid = read_raster(testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif"));
  Grid part(120, 90, grid.x0, grid.y0, grid.cell_x, grid.cell_y);
  part.crs = grid.crs;
  for (int r = 0; r < part.height; ++r)
    for (int c = 0; c < part.width; ++c) {
      const float z = grid.at(c, r);
      part.z[part.index(c, r)] = z < 114.0f ? Grid::nodata : z;
    }
  return triangulate_xy3(part);
}

void expect_reads_back(const Mesh& mesh, const std::string& path) {
  std::vector<CGAL::Exact_predicates_inexact_constructions_kernel::Point_3> points;
  std::vector<std::vector<std::size_t>> polygons;
  ASSERT_TRUE(CGAL::IO::read_polygon_soup(path, points, polygons)) << path;
  ASSERT_EQ(points.size(), mesh.vertices.size());
  ASSERT_EQ(polygons.size(), mesh.triangles.size());
  for (size_t i = 0; i < points.size(); ++i) {
    // Exact: PLY stores doubles, the text formats shortest round-trip decimals.
    ASSERT_EQ(points[i].x(), mesh.vertices[i].x) << path << " vertex " << i;
    ASSERT_EQ(points[i].y(), mesh.vertices[i].y) << path << " vertex " << i;
    ASSERT_EQ(points[i].z(), mesh.vertices[i].z) << path << " vertex " << i;
  }
  for (size_t i = 0; i < polygons.size(); ++i) {
    ASSERT_EQ(polygons[i].size(), 3u);
    for (int k = 0; k < 3; ++k) ASSERT_EQ(polygons[i][k], mesh.triangles[i][k]) << path << " face " << i;
  }
}

}  // namespace

// ---- the programs users open the files with (Debian 12's, headless; scripts/test.sh installs them)

namespace {

bool have_program(const std::string& name) {
  return std::system(("command -v " + name + " >/dev/null 2>&1").c_str()) == 0;
}

// Runs a shell command, its output into `log`; the exit status.
int run_logged(const std::string& command, const std::string& log) {
  const int status = std::system((command + " >" + log + " 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// "element vertex N" and "element face N" of a PLY header, as the program that wrote it says.
std::pair<long, long> ply_counts(const std::string& path) {
  const std::string text = testkit::read_file(path);
  const std::string header = text.substr(0, text.find("end_header"));
  long vertices = -1, faces = -1;
  std::istringstream in(header);
  for (std::string line; std::getline(in, line);) {
    std::sscanf(line.c_str(), "element vertex %ld", &vertices);
    std::sscanf(line.c_str(), "element face %ld", &faces);
  }
  return {vertices, faces};
}

}  // namespace

TEST(OpensWhereUsersOpenIt, CloudCompareReadsEveryMeshFormatWhole) {
  if (!have_program("CloudCompare") || !have_program("xvfb-run"))
    GTEST_SKIP() << "CloudCompare or xvfb-run not installed";
  const Mesh mesh = real_mesh();
  testkit::TempDir dir;
  for (const char* name : {"mesh.ply", "mesh.obj", "mesh.off"}) {
    const std::string path = dir.path(name), out = dir.path(std::string(name) + ".cc.ply");
    write_mesh(mesh, path, mesh_format_for(path));
    // Opened and saved again as PLY by CloudCompare's command line: what it read, counted.
    const int status = run_logged(
        "xvfb-run -a CloudCompare -SILENT -NO_TIMESTAMP -O " + path + " -M_EXPORT_FMT PLY -SAVE_MESHES FILE " + out,
        dir.path("cc.log"));
    ASSERT_EQ(status, 0) << testkit::read_file(dir.path("cc.log"));
    const auto [vertices, faces] = ply_counts(out);
    EXPECT_EQ(vertices, long(mesh.vertices.size())) << name;
    EXPECT_EQ(faces, long(mesh.triangles.size())) << name;
  }
}

TEST(OpensWhereUsersOpenIt, MeshLabReadsPlyAndOffWhole) {
  if (!have_program("meshlabserver") || !have_program("xvfb-run"))
    GTEST_SKIP() << "meshlabserver or xvfb-run not installed";
  const Mesh mesh = real_mesh();
  testkit::TempDir dir;
  // Not OBJ: Debian 12's meshlabserver (2020.09) aborts on every OBJ, a three-line triangle too
  // (an assertion in vcglib's import_obj.h), whoever wrote it.
  for (const char* name : {"mesh.ply", "mesh.off"}) {
    const std::string path = dir.path(name), out = dir.path(std::string(name) + ".ml.ply");
    write_mesh(mesh, path, mesh_format_for(path));
    const int status = run_logged("xvfb-run -a meshlabserver -i " + path + " -o " + out, dir.path("ml.log"));
    ASSERT_EQ(status, 0) << testkit::read_file(dir.path("ml.log"));
    const auto [vertices, faces] = ply_counts(out);
    EXPECT_EQ(vertices, long(mesh.vertices.size())) << name;
    EXPECT_EQ(faces, long(mesh.triangles.size())) << name;
  }
}

TEST(OpensWhereUsersOpenIt, BlenderImportsTheGlbInPlace) {
  if (!have_program("blender")) GTEST_SKIP() << "blender not installed";
  const Mesh mesh = real_mesh();
  testkit::TempDir dir;
  const std::string glb = dir.path("mesh.glb");
  write_mesh(mesh, glb, MeshFormat::Glb);
  // Blender's own glTF importer; the mesh's world box (Blender is z-up, as the CRS) printed.
  testkit::write_file(
      dir.path("import.py"),
      "import numpy\n"
      "if not hasattr(numpy, 'bool'): numpy.bool = bool  # Debian 12: Blender 3.4's addon, numpy 1.24\n"
      "import bpy\n"
      "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
      "bpy.ops.import_scene.gltf(filepath='" +
          glb +
          "')\n"
          "for o in bpy.context.scene.objects:\n"
          "    if o.type != 'MESH': continue\n"
          "    w = [o.matrix_world @ v.co for v in o.data.vertices]\n"
          "    print('MESH %d %d %.3f %.3f %.3f %.3f %.3f %.3f' % (len(o.data.vertices), len(o.data.polygons),\n"
          "          min(p.x for p in w), max(p.x for p in w), min(p.y for p in w), max(p.y for p in w),\n"
          "          min(p.z for p in w), max(p.z for p in w)))\n");
  const int status = run_logged("blender -b --factory-startup --python " + dir.path("import.py"), dir.path("b.log"));
  const std::string log = testkit::read_file(dir.path("b.log"));
  ASSERT_EQ(status, 0) << log;
  const size_t at = log.find("\nMESH ");
  ASSERT_NE(at, std::string::npos) << log;
  long vertices = 0, faces = 0;
  double box[6];
  ASSERT_EQ(std::sscanf(log.c_str() + at + 1, "MESH %ld %ld %lf %lf %lf %lf %lf %lf", &vertices, &faces, &box[0],
                        &box[1], &box[2], &box[3], &box[4], &box[5]),
            8);
  EXPECT_EQ(vertices, long(mesh.vertices.size()));
  EXPECT_EQ(faces, long(mesh.triangles.size()));
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (const Vertex& v : mesh.vertices) {
    const double p[3] = {v.x, v.y, v.z};
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
  }
  // East, north and up where the CRS has them, the shape to the centimetre. Blender keeps world
  // matrices in float32: at a northing of 5.7e6 m its steps are 0.5 m, and the root node's
  // z-up-to-y-up quaternion in float32 moves heights by about 0.8 m there; hence the metre.
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(box[2 * k + 1] - box[2 * k], hi[k] - lo[k], 0.01) << "axis " << k;
    EXPECT_NEAR(box[2 * k], lo[k], 1.0) << "axis " << k;
    EXPECT_NEAR(box[2 * k + 1], hi[k], 1.0) << "axis " << k;
  }
}

TEST(MeshWriter, EveryFormatReadsBackExactly) {
  const Mesh mesh = real_mesh();
  ASSERT_GT(mesh.triangles.size(), 1000u);
  testkit::TempDir dir;
  for (const char* name : {"mesh.ply", "mesh.obj", "mesh.off"}) {
    const std::string path = dir.path(name);
    write_mesh(mesh, path, mesh_format_for(path));
    expect_reads_back(mesh, path);
  }
}

TEST(MeshWriter, HeadersCarryTheCrs) {
  const Mesh mesh = real_mesh();
  testkit::TempDir dir;
  write_mesh(mesh, dir.path("m.ply"), MeshFormat::Ply);
  const std::string ply = testkit::read_file(dir.path("m.ply"));
  const std::string header = ply.substr(0, ply.find("end_header"));
  EXPECT_NE(header.find("format binary_little_endian 1.0"), std::string::npos);
  EXPECT_NE(header.find("comment crs_epsg 25832\n"), std::string::npos);
  EXPECT_NE(header.find("comment crs_name ETRS89 / UTM zone 32N\n"), std::string::npos);
  // The WKT in pieces short enough for RPly (CloudCompare: 1,024 bytes a line) and MeshLab (512).
  EXPECT_NE(header.find("comment crs_wkt_part 1/"), std::string::npos);
  EXPECT_NE(header.find("PROJCRS[\"ETRS89 / UTM zone 32N\""), std::string::npos);
  for (size_t at = 0, end; at < header.size(); at = end + 1) {
    end = header.find('\n', at);
    if (end == std::string::npos) end = header.size();
    EXPECT_LE(end - at, 480u) << header.substr(at, 80);
  }
  EXPECT_NE(header.find("comment vertical "), std::string::npos);
  EXPECT_NE(header.find("property double x\n"), std::string::npos);
  // Size is exactly header + 24 bytes per vertex + 13 per face: nothing else was written.
  const size_t body = ply.size() - (ply.find("end_header\n") + 11);
  EXPECT_EQ(body, 24 * mesh.vertices.size() + 13 * mesh.triangles.size());

  write_mesh(mesh, dir.path("m.obj"), MeshFormat::Obj);
  EXPECT_EQ(testkit::read_file(dir.path("m.obj")).find("# generated by dsmplan"), 0u);
  EXPECT_NE(testkit::read_file(dir.path("m.obj")).find("# crs_epsg 25832\n"), std::string::npos);
}

// What dsmplan's reader would refuse is not written, whatever handed the mesh in (a C++ caller,
// Python): a face naming a vertex that is not there, a coordinate that is not finite; nor a name
// with a NUL byte (the system would write the name cut there). Each format, nothing left.
TEST(MeshWriter, RefusesWhatItsReaderWouldRefuse) {
  testkit::TempDir dir;
  Mesh base;
  base.vertices = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
  base.triangles = {{0, 1, 2}};
  Mesh out_of_range = base, not_finite = base;
  out_of_range.triangles.push_back({0, 2, 3});
  not_finite.vertices[1].z = NAN;
  for (const char* name : {"m.ply", "m.obj", "m.off", "m.glb"}) {
    EXPECT_THROW(write_mesh(out_of_range, dir.path(name), mesh_format_for(name)), ArgumentError) << name;
    EXPECT_THROW(write_mesh(not_finite, dir.path(name), mesh_format_for(name)), ArgumentError) << name;
    EXPECT_THROW(write_mesh(base, dir.path(name) + std::string(1, '\0') + ".txt", mesh_format_for(name)), OutputError)
        << name;
  }
  EXPECT_TRUE(dir.files().empty());
  write_mesh(base, dir.path("m.ply"), MeshFormat::Ply);  // the same mesh, whole, is written
  EXPECT_EQ(read_mesh(dir.path("m.ply")).triangles.size(), 1u);
}

TEST(MeshWriter, FailedWritesLeaveNothing) {
  const Mesh mesh = real_mesh();
  testkit::TempDir dir;
  EXPECT_THROW(write_mesh(mesh, dir.path("missing/m.ply"), MeshFormat::Ply), OutputError);
  EXPECT_THROW(write_mesh(mesh, dir.path(""), MeshFormat::Ply), OutputError);
  EXPECT_TRUE(dir.files().empty());
  // An existing file is replaced whole, never appended to or left half-written.
  testkit::write_file(dir.path("m.off"), "old");
  write_mesh(mesh, dir.path("m.off"), MeshFormat::Off);
  expect_reads_back(mesh, dir.path("m.off"));
  EXPECT_EQ(dir.files().size(), 1u);
}

TEST(MeshWriter, FormatByExtension) {
  EXPECT_EQ(mesh_format_for("a/b.PLY"), MeshFormat::Ply);
  EXPECT_EQ(mesh_format_for("b.obj"), MeshFormat::Obj);
  EXPECT_EQ(mesh_format_for("b.off"), MeshFormat::Off);
  EXPECT_THROW(mesh_format_for("b.xyz"), ArgumentError);
  EXPECT_THROW(mesh_format_for("noextension"), ArgumentError);
}

// ==== mesh files in =========================================================================
//
// read_mesh is checked against write_mesh on the real tile (exact round trip, CRS included),
// against files the test writes byte by byte in the variants other tools write, and against
// broken files whose fault the test knows.

namespace {

void expect_same_mesh(const Mesh& read, const Mesh& written, const std::string& what) {
  ASSERT_EQ(read.vertices.size(), written.vertices.size()) << what;
  ASSERT_EQ(read.triangles.size(), written.triangles.size()) << what;
  // Bitwise: PLY holds the doubles themselves, OBJ/OFF their shortest round-trip decimals.
  EXPECT_EQ(std::memcmp(read.vertices.data(), written.vertices.data(), written.vertices.size() * sizeof(Vertex)), 0)
      << what;
  EXPECT_TRUE(read.triangles == written.triangles) << what;
  EXPECT_EQ(read.crs.name, written.crs.name) << what;
  EXPECT_EQ(read.crs.epsg, written.crs.epsg) << what;
  EXPECT_EQ(read.crs.wkt, written.crs.wkt) << what;
  EXPECT_EQ(read.crs.vertical_name, written.crs.vertical_name) << what;
  EXPECT_EQ(read.crs.vertical_unit, written.crs.vertical_unit) << what;
  EXPECT_EQ(read.crs.geographic, written.crs.geographic) << what;
}

// The InputError for `path`: names the file, then `place` (when given), and says `problem`.
void expect_input_error(const std::string& path, const std::string& place, const std::string& problem) {
  try {
    read_mesh(path);
    ADD_FAILURE() << path << ": read without error";
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    // `place` may be a whole place ("line 12") or its kind ("line").
    if (!place.empty()) EXPECT_EQ(message.find(path + ": " + place), 0u) << message;
    EXPECT_NE(message.find(problem), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

std::string little_endian_ply(const std::string& header_body, const std::string& bytes) {
  return "ply\nformat binary_little_endian 1.0\n" + header_body + "end_header\n" + bytes;
}

template <typename T>
void append(std::string& out, T value, bool big_endian = false) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  if (big_endian) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

}  // namespace

TEST(MeshReader, RoundTripsTheRealTileInEveryFormat) {
  const Mesh mesh = real_mesh();
  ASSERT_GT(mesh.triangles.size(), 1000u);
  ASSERT_EQ(mesh.crs.epsg, 25832);
  ASSERT_FALSE(mesh.crs.wkt.empty());
  testkit::TempDir dir;
  for (const char* name : {"mesh.ply", "mesh.obj", "mesh.off"}) {
    const std::string path = dir.path(name);
    write_mesh(mesh, path, mesh_format_for(path));
    const Mesh read = read_mesh(path);
    expect_same_mesh(read, mesh, name);
    EXPECT_EQ(read.crs.definition, mesh.crs.wkt) << name;
  }
}

// The binary reader converts a PLY's records in parallel slices: a file with two bad records far
// apart, in different slices and rounds, is refused naming the first of them, at its byte, as
// the record-by-record reader names it; the same file without them reads back exactly.
TEST(MeshReader, ParallelBinaryReadNamesTheFirstBadRecord) {
  const uint32_t side = 750;  // 562,500 vertices, 1,121,002 faces: past a round of 2^20 records
  const uint64_t vertices = uint64_t(side) * side, faces = 2 * uint64_t(side - 1) * (side - 1);
  const std::string header = "element vertex " + std::to_string(vertices) +
                             "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
                             std::to_string(faces) + "\nproperty list uchar int vertex_indices\n";
  const size_t body = little_endian_ply(header, "").size();
  auto file = [&](uint64_t bad_vertex_a, uint64_t bad_vertex_b, uint64_t bad_face_a, uint64_t bad_face_b) {
    std::string bytes;
    bytes.reserve(vertices * 24 + faces * 13);
    for (uint64_t i = 0; i < vertices; ++i) {
      append(bytes, double(i % side));
      append(bytes, i == bad_vertex_a ? NAN : double(i / side));
      append(bytes, i == bad_vertex_b ? INFINITY : 0.5 * double(i % 7));
    }
    uint64_t face = 0;
    for (uint32_t r = 0; r + 1 < side; ++r)
      for (uint32_t c = 0; c + 1 < side; ++c) {
        const int32_t a = int32_t(r * side + c), b = a + 1, d = a + int32_t(side);
        for (const std::array<int32_t, 3>& t : {std::array<int32_t, 3>{a, b, d}, std::array<int32_t, 3>{b, d + 1, d}}) {
          append(bytes, uint8_t(3));
          append(bytes, face == bad_face_a ? int32_t(vertices) : t[0]);
          append(bytes, t[1]);
          append(bytes, face == bad_face_b ? t[1] : t[2]);
          ++face;
        }
      }
    return little_endian_ply(header, bytes);
  };
  testkit::TempDir dir;
  const std::string path = dir.path("big.ply");
  constexpr uint64_t none = UINT64_MAX;
  testkit::write_file(path, file(none, none, none, none));
  const Mesh good = read_mesh(path);
  ASSERT_EQ(good.vertices.size(), vertices);
  ASSERT_EQ(good.triangles.size(), faces);
  EXPECT_EQ(good.vertices[123457].x, double(123457 % side));
  EXPECT_EQ(good.vertices[vertices - 1].z, 0.5 * double((vertices - 1) % 7));
  const uint32_t corner = (side - 2) * side + side - 2;  // the last quad's first corner
  EXPECT_EQ(good.triangles[faces - 1], (Triangle{corner + 1, corner + side + 1, corner + side}));
  // A bad vertex late in the first round, an earlier one in another slice: the earlier is named.
  testkit::write_file(path, file(400'001, 37'000, none, none));
  expect_input_error(path, "byte " + std::to_string(body + 37'000 * 24),
                     "vertex 37000 has a coordinate that is not a finite number");
  // Faces: one in the second round, one in the first; then only the late one.
  const size_t faces_at = body + vertices * 24;
  testkit::write_file(path, file(none, none, 1'100'000, 20'001));
  expect_input_error(path, "byte " + std::to_string(faces_at + 20'001 * 13), "face 20001 names the same vertex twice");
  testkit::write_file(path, file(none, none, 1'100'000, none));
  expect_input_error(path, "byte " + std::to_string(faces_at + 1'100'000 * 13),
                     "face 1100000 refers to vertex " + std::to_string(vertices));
}

TEST(MeshReader, LongWktsComeBackWholeFromTheirPieces) {
  // WKTs of every length around the piece size, with blanks and commas where a cut may fall,
  // and the real tile's own WKT.
  Mesh mesh = real_mesh();
  mesh.triangles.resize(20);
  std::vector<std::string> wkts{mesh.crs.wkt};
  std::string text;
  for (int n = 0; text.size() < 2000; ++n) text += n % 7 == 0 ? "A, B ," : n % 5 == 0 ? "PARAM[\"x y\",1]," : "abc";
  for (size_t length : {1, 399, 400, 401, 799, 800, 801, 1999}) wkts.push_back(text.substr(0, length));
  wkts.push_back(std::string(1200, 'x'));  // no comma at all
  testkit::TempDir dir;
  for (const std::string& wkt : wkts) {
    if (!wkt.empty() && (wkt.back() == ' ' || wkt.front() == ' ')) continue;  // readers trim a value's ends
    mesh.crs.wkt = wkt;
    for (const char* name : {"m.ply", "m.obj", "m.off"}) {
      const std::string path = dir.path(name);
      write_mesh(mesh, path, mesh_format_for(path));
      EXPECT_EQ(read_mesh(path).crs.wkt, wkt) << name << " length " << wkt.size();
    }
  }
}

TEST(MeshReader, RoundTripsEveryShapeOfTheVerticalLine) {
  Mesh mesh = real_mesh();
  mesh.triangles.resize(50);
  testkit::TempDir dir;
  const std::pair<std::string, std::string> cases[] = {
      {"DHHN2016 height", "metre"}, {"", "metre"}, {"NAVD88 height (ftUS)", "US survey foot"}, {"", ""}};
  for (const auto& [name, unit] : cases) {
    mesh.crs.vertical_name = name;
    mesh.crs.vertical_unit = unit;
    for (const char* file : {"v.ply", "v.obj", "v.off"}) {
      write_mesh(mesh, dir.path(file), mesh_format_for(file));
      expect_same_mesh(read_mesh(dir.path(file)), mesh, std::string(file) + " vertical '" + name + "' '" + unit + "'");
    }
  }
  // A mesh without any CRS comes back without one.
  mesh.crs = Crs{};
  write_mesh(mesh, dir.path("none.obj"), MeshFormat::Obj);
  const Mesh read = read_mesh(dir.path("none.obj"));
  EXPECT_FALSE(read.crs.known());
  EXPECT_EQ(read.crs.name, "");
}

// read_mesh_crs() reads a PLY's header alone (dsmplan plan with a kept index): the CRS it gives is
// read_mesh()'s, for the real tile's long WKT and for a header whose comment says "end_header"
// before its end, with either line ending.
TEST(MeshReader, CrsFromTheHeaderAloneIsTheCrsOfTheWholeRead) {
  testkit::TempDir dir;
  Mesh mesh = real_mesh();
  mesh.triangles.resize(20);
  const std::string written = dir.path("m.ply");
  write_mesh(mesh, written, MeshFormat::Ply);
  const Crs whole = read_mesh(written).crs, head = read_mesh_crs(written);
  EXPECT_EQ(head.wkt, whole.wkt);
  EXPECT_EQ(head.epsg, whole.epsg);
  EXPECT_EQ(head.name, whole.name);
  EXPECT_EQ(head.vertical_name, whole.vertical_name);
  ASSERT_FALSE(whole.wkt.empty());
  for (const std::string eol : {"\n", "\r\n"}) {
    const std::string path = dir.path("c.ply");
    testkit::write_file(path, "ply" + eol + "format ascii 1.0" + eol + "comment the end_header line ends it" + eol +
                                  "comment crs_epsg 25832" + eol + "element vertex 3" + eol + "property float x" + eol +
                                  "property float y" + eol + "property float z" + eol + "element face 1" + eol +
                                  "property list uchar int vertex_indices" + eol + "end_header" + eol + "0 0 0" + eol +
                                  "1 0 0" + eol + "0 1 0" + eol + "3 0 1 2" + eol);
    EXPECT_EQ(read_mesh(path).crs.epsg, 25832);
    EXPECT_EQ(read_mesh_crs(path).epsg, 25832) << (eol.size() == 1 ? "LF" : "CRLF");
  }
}

// A GLB, which read_mesh() does not read, gives the CRS its asset.extras carry (dsmplan view
// --no-fly places the zones with it): the one the PLY of the same mesh gives; a GLB cut inside
// its JSON chunk is one line naming the file.
TEST(MeshReader, CrsOfAGlbIsTheCrsItWasWrittenWith) {
  testkit::TempDir dir;
  Mesh mesh = real_mesh();
  mesh.triangles.resize(20);
  write_mesh(mesh, dir.path("m.glb"), MeshFormat::Glb);
  write_mesh(mesh, dir.path("m.ply"), MeshFormat::Ply);
  const Crs glb = read_mesh_crs(dir.path("m.glb")), ply = read_mesh_crs(dir.path("m.ply"));
  ASSERT_FALSE(glb.wkt.empty());
  EXPECT_EQ(glb.wkt, ply.wkt);
  EXPECT_EQ(glb.definition, ply.definition);
  EXPECT_EQ(glb.epsg, 25832);
  EXPECT_EQ(glb.name, ply.name);
  EXPECT_EQ(glb.vertical_name, ply.vertical_name);
  EXPECT_EQ(glb.geographic, false);
  const std::string bytes = testkit::read_file(dir.path("m.glb"));
  testkit::write_file(dir.path("cut.glb"), bytes.substr(0, 40));
  try {
    read_mesh_crs(dir.path("cut.glb"));
    ADD_FAILURE() << "a cut GLB was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cut.glb: byte 20: the JSON chunk is cut short"), std::string::npos)
        << e.what();
  }
}

TEST(MeshReader, ReadsAsciiPlyWithFloatsAndExtraProperties) {
  testkit::TempDir dir;
  const std::string path = dir.path("ascii.ply");
  testkit::write_file(path,
                      "ply\r\nformat ascii 1.0\r\ncomment crs_epsg 25832\r\nelement vertex 4\r\n"
                      "property float x\r\nproperty float y\r\nproperty float z\r\nproperty uchar red\r\n"
                      "property list uchar float normals\r\n"
                      "element face 2\r\nproperty list uchar int vertex_indices\r\nproperty int flags\r\n"
                      "element edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\nend_header\r\n"
                      "0 0 1.1 255 0\r\n1 0 2 0 3 0 0 1\r\n1 1 3 7 1 0.5\r\n0.1 1 4 9 0\r\n"
                      "3 0 1 2 17\r\n3 0 2 3 -1\r\n0 1\r\n");
  const Mesh mesh = read_mesh(path);
  ASSERT_EQ(mesh.vertices.size(), 4u);
  EXPECT_EQ(mesh.vertices[0].z, static_cast<double>(1.1f)) << "a float property is the float, widened";
  EXPECT_EQ(mesh.vertices[3].x, static_cast<double>(0.1f));
  EXPECT_EQ(mesh.vertices[2].z, 3.0);
  ASSERT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.triangles[1], (Triangle{0, 2, 3}));
  EXPECT_EQ(mesh.crs.epsg, 25832);
  EXPECT_EQ(mesh.crs.definition, "EPSG:25832");
}

TEST(MeshReader, ReadsBigEndianPlyWithIntCountsAndFloats) {
  std::string body;
  const float xyz[3][3] = {{1, 2, 3}, {4, 5, 6}, {7, 8.5f, 9}};
  for (const auto& v : xyz)
    for (float c : v) append(body, c, true);
  append(body, int32_t{3}, true);
  for (uint32_t i : {0u, 1u, 2u}) append(body, i, true);
  testkit::TempDir dir;
  const std::string path = dir.path("big.ply");
  testkit::write_file(path,
                      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float32 x\nproperty float32 y\n"
                      "property float32 z\nelement face 1\nproperty list int uint32 vertex_index\nend_header\n" +
                          body);
  const Mesh mesh = read_mesh(path);
  ASSERT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.vertices[2].y, 8.5);
  ASSERT_EQ(mesh.triangles.size(), 1u);
  EXPECT_EQ(mesh.triangles[0], (Triangle{0, 1, 2}));
}

TEST(MeshReader, ReadsEveryObjFaceForm) {
  testkit::TempDir dir;
  const std::string path = dir.path("forms.obj");
  testkit::write_file(path,
                      "# crs_name ETRS89 / UTM zone 32N\nmtllib a.mtl\no part\n"
                      "v 0 0 0\nv 1 0 0\nv 1 1 0 1.0\nv 0 1 0 0.5 0.5 0.5\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n"
                      "g roof\nusemtl red\ns off\n"
                      "f 1 2 3\nf 1/1 3/3 4/2\nf 1/1/1 2/2/1 3/3/1\nf 1//1 3//1 4//1\nf -4 -3 -2 # relative\n"
                      "f 1/-3/-1 2/-2/-1 3/-1/-1\n");
  const Mesh mesh = read_mesh(path);
  ASSERT_EQ(mesh.vertices.size(), 4u);
  EXPECT_EQ(mesh.vertices[2].x, 1.0);
  const std::vector<Triangle> expected{{0, 1, 2}, {0, 2, 3}, {0, 1, 2}, {0, 2, 3}, {0, 1, 2}, {0, 1, 2}};
  EXPECT_TRUE(mesh.triangles == expected);
  EXPECT_EQ(mesh.crs.name, "ETRS89 / UTM zone 32N");
  EXPECT_EQ(mesh.crs.epsg, 0);
}

TEST(MeshReader, BrokenPlyFilesAreRefusedNamingFileAndPlace) {
  const Mesh mesh = real_mesh();
  testkit::TempDir dir;
  write_mesh(mesh, dir.path("good.ply"), MeshFormat::Ply);
  const std::string good = testkit::read_file(dir.path("good.ply"));
  const size_t body = good.find("end_header\n") + 11;
  const std::string vertices = "element vertex " + std::to_string(mesh.vertices.size()) + "\n";
  auto variant = [&](const std::string& name, std::string bytes) {
    testkit::write_file(dir.path(name), bytes);
    return dir.path(name);
  };
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string bytes = good;
    bytes.replace(bytes.find(from), from.size(), to);
    return bytes;
  };

  // A header that promises 4 billion vertices must fail before anything is reserved.
  expect_input_error(variant("lying.ply", replaced(vertices, "element vertex 4000000000\n")), "line",
                     "bytes follow the header");
  expect_input_error(variant("too_many.ply", replaced(vertices, "element vertex 99999999999\n")), "line", "32-bit");
  expect_input_error(
      variant("fewer.ply", replaced(vertices, "element vertex " + std::to_string(mesh.vertices.size() - 1) + "\n")),
      "byte", "face 0");  // the last vertex's bytes read as a face
  expect_input_error(variant("truncated.ply", good.substr(0, good.size() - 7)), "", "bytes follow the header");
  expect_input_error(variant("trailing.ply", good + "extra"), "byte", "after the last element");
  expect_input_error(variant("no_end.ply", good.substr(0, body - 11)), "header", "end_header");
  expect_input_error(variant("not_ply.ply", "solid cube\nfacet normal 0 0 1\n"), "header", "not a PLY file");
  expect_input_error(variant("keyword.ply", replaced("format binary", "fromat binary")), "line 2", "unknown header");

  // The first face's index points past the last vertex.
  std::string bytes = good;
  const size_t first_face = body + 24 * mesh.vertices.size();
  const auto beyond = static_cast<uint32_t>(mesh.vertices.size());
  std::memcpy(bytes.data() + first_face + 1, &beyond, 4);
  expect_input_error(variant("index.ply", bytes), "byte " + std::to_string(first_face), "refers to vertex");

  // A quad where a triangle should be.
  bytes = good;
  bytes[first_face] = 4;
  expect_input_error(variant("quad.ply", bytes), "byte " + std::to_string(first_face), "only triangles");

  // NaN and infinity in a coordinate: the 8th vertex's z, and the 2nd's x.
  bytes = good;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  std::memcpy(bytes.data() + body + 7 * 24 + 16, &nan, 8);
  expect_input_error(variant("nan.ply", bytes), "byte " + std::to_string(body + 7 * 24), "vertex 7");
  bytes = good;
  std::memcpy(bytes.data() + body + 24, &inf, 8);
  expect_input_error(variant("inf.ply", bytes), "byte " + std::to_string(body + 24), "not a finite number");

  expect_input_error(variant("no_z.ply", replaced("property double z\n", "property double w\n")), "line",
                     "no property z");
  expect_input_error(variant("float_index.ply", replaced("list uchar uint", "list uchar float")), "line",
                     "list of integers");
  expect_input_error(variant("ascii_short.ply",
                             "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                             "property double z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                             "0 0 0\n1 0 0\n1 1 zero\n3 0 1 2\n"),
                     "line 12", "expected a number");
}

TEST(MeshReader, BrokenObjAndOffFilesAreRefusedNamingFileAndLine) {
  testkit::TempDir dir;
  auto file = [&](const std::string& name, const std::string& text) {
    testkit::write_file(dir.path(name), text);
    return dir.path(name);
  };
  const std::string v = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
  expect_input_error(file("quad.obj", v + "f 1 2 3 4\n"), "line 5", "only triangles");
  expect_input_error(file("index.obj", v + "f 1 2 3\nf 1 2 9\n"), "line 6", "vertex 9 does not exist");
  expect_input_error(file("relative.obj", v + "f -5 -1 -2\n"), "line 5", "before the first vertex");
  expect_input_error(file("word.obj", v + "f 1 two 3\n"), "line 5", "vertex reference");
  expect_input_error(file("nan.obj", "v 0 0 0\nv 1 nan 0\n"), "line 2", "not a finite number");
  expect_input_error(file("short.obj", "v 0 0\n"), "line 1", "expected 'v x y z'");
  expect_input_error(file("twice.obj", v + "f 1 2 1\n"), "line 5", "same vertex twice");
  expect_input_error(file("binary.obj", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16)), "line 1",
                     "not a Wavefront OBJ file");

  const std::string off_v = "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
  expect_input_error(file("lying.off", "OFF\n900000000 2 0\n0 0 0\n"), "line 2", "more than the");
  expect_input_error(file("ends.off", "OFF\n4 1 0\n0.000000 0.000000 0.000000\n1.000000 0 0\n"), "line 4",
                     "after 2 of 4 vertices");
  expect_input_error(file("quad.off", off_v + "4 0 1 2 3\n3 0 1 2\n"), "line 7", "only triangles");
  expect_input_error(file("index.off", off_v + "3 0 1 2\n3 0 1 4\n"), "line 8", "refers to vertex");
  expect_input_error(file("extra.off", off_v + "3 0 1 2\n3 0 2 3\n3 1 2 3\n"), "line 9", "after the last face");
  expect_input_error(file("inf.off", "OFF\n3 0 0\n0 0 0\n1 inf 0\n1 1 0\n"), "line 4", "not a finite number");
  expect_input_error(file("coff.off", "COFF\n3 0 0\n"), "line 1", "only plain OFF");

  expect_input_error(file("empty.obj", ""), "", "empty");
  expect_input_error(dir.path("missing.ply"), "", "No such file");
  std::filesystem::create_directory(dir.path("folder.obj"));
  expect_input_error(dir.path("folder.obj"), "", "directory");
  // The same faces with a colour after the indices are plain OFF.
  const Mesh coloured = read_mesh(file("colour.off", off_v + "3 0 1 2 255 0 0\n3 0 2 3 0.5 0.5 0.5 1\n"));
  EXPECT_EQ(coloured.triangles.size(), 2u);
}

// ==== pictures ==============================================================================

namespace {

const Grid& nrw_grid() {
  static const Grid grid = read_raster(testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif"));
  return grid;
}

RenderOptions plain(std::optional<Window> window, double zoom = 4) {
  RenderOptions options;
  options.window = window;
  options.pixels_per_cell = zoom;
  options.scale_bar = options.north_arrow = options.legend = options.grid = false;
  return options;
}

const uint8_t* pixel(const Image& image, int x, int y) {
  return image.rgb.data() + (static_cast<size_t>(y) * image.width + x) * 3;
}
int brightness(const Image& image, int x, int y) {
  const uint8_t* p = pixel(image, x, y);
  return p[0] + p[1] + p[2];
}

// Distance from (px, py) to the segment a-b.
double segment_distance(double px, double py, double ax, double ay, double bx, double by) {
  const double dx = bx - ax, dy = by - ay;
  const double t = std::clamp(((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
  return std::hypot(px - (ax + t * dx), py - (ay + t * dy));
}

}  // namespace

TEST(Render, PictureSizeFollowsWindowAndZoom) {
  const Grid& grid = nrw_grid();
  const double x = grid.x0 + 150, y = grid.y0 - 200;
  Image image = render_view(grid, nullptr, plain(Window{x, y - 100, x + 150, y}));
  EXPECT_EQ(image.width, 600);
  EXPECT_EQ(image.height, 400);
  EXPECT_EQ(image.rgb.size(), 600u * 400 * 3);
  image = render_view(grid, nullptr, plain(Window{x, y - 100, x + 150, y}, 2.5));
  EXPECT_EQ(image.width, 375);
  EXPECT_EQ(image.height, 250);
  image = render_view(grid, nullptr, plain(std::nullopt, 1));  // the whole grid, one pixel per cell
  EXPECT_EQ(image.width, grid.width);
  EXPECT_EQ(image.height, grid.height);
}

TEST(Render, EdgesChangeExactlyThePixelsAlongThem) {
  const Grid& grid = nrw_grid();
  const Window window{grid.x0 + 100, grid.y0 - 160, grid.x0 + 160, grid.y0 - 100};
  // Five vertices on cell centres of the window, four triangles around the middle one.
  Mesh mesh;
  mesh.crs = grid.crs;
  const int c0 = 105, r0 = 105, c1 = 154, r1 = 154, cm = 130, rm = 128;
  for (auto [c, r] : {std::pair{c0, r0}, {c1, r0}, {c1, r1}, {c0, r1}, {cm, rm}}) {
    mesh.vertices.push_back({grid.center_x(c), grid.center_y(r), grid.at(c, r)});
  }
  mesh.triangles = {{0, 4, 1}, {1, 4, 2}, {2, 4, 3}, {3, 4, 0}};
  const RenderOptions options = plain(window, 4);
  const Image without = render_view(grid, nullptr, options);
  const Image with = render_view(grid, &mesh, options);
  ASSERT_EQ(with.width, without.width);
  ASSERT_EQ(with.height, without.height);
  auto px = [&](double x) { return (x - window.xmin) * 4; };
  auto py = [&](double y) { return (window.ymax - y) * 4; };
  std::vector<std::array<double, 4>> segments;
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const Vertex &a = mesh.vertices[t[k]], &b = mesh.vertices[t[(k + 1) % 3]];
      segments.push_back({px(a.x), py(a.y), px(b.x), py(b.y)});
    }
  size_t changed = 0, near_line = 0;
  for (int y = 0; y < with.height; ++y)
    for (int x = 0; x < with.width; ++x) {
      double nearest = INFINITY;
      for (const auto& s : segments)
        nearest = std::min(nearest, segment_distance(x + 0.5, y + 0.5, s[0], s[1], s[2], s[3]));
      const bool differs = std::memcmp(pixel(with, x, y), pixel(without, x, y), 3) != 0;
      changed += differs;
      // Lines are 1 pixel wide (coverage reaches 1 pixel from the centre line) and may move by
      // half a pixel in x and y (0.71 pixels) to sit on pixel centres.
      if (differs) EXPECT_LT(nearest, 1.75) << "pixel " << x << "," << y << " changed away from every edge";
      if (nearest < 0.25) {
        ++near_line;
        EXPECT_LT(brightness(with, x, y), brightness(without, x, y)) << "pixel " << x << "," << y << " on an edge";
      }
    }
  EXPECT_GT(changed, 800u);
  EXPECT_GT(near_line, 200u);
  // The pixel under the midpoint of the edge from the middle vertex to the north-east corner.
  const Vertex &m = mesh.vertices[4], &ne = mesh.vertices[1];
  const int mx = static_cast<int>(px((m.x + ne.x) / 2)), my = static_cast<int>(py((m.y + ne.y) / 2));
  EXPECT_LT(brightness(with, mx, my), brightness(without, mx, my) - 60);
}

TEST(Render, PathAndWaypointsAreDrawnWhereTheyAreAndNowhereElse) {
  const Grid& grid = nrw_grid();
  const Window window{grid.x0 + 100, grid.y0 - 160, grid.x0 + 160, grid.y0 - 100};
  RenderOptions options = plain(window, 4);
  const Image without = render_view(grid, nullptr, options);
  const std::vector<Point3> path{
      {grid.x0 + 105, grid.y0 - 150, 150}, {grid.x0 + 130, grid.y0 - 110, 160}, {grid.x0 + 155, grid.y0 - 140, 150}};
  LineLayer line;
  line.polylines = {path};
  options.lines.push_back(line);
  const Point3 waypoint{grid.x0 + 140, grid.y0 - 150, 150};
  options.markers.push_back(MarkerLayer{{waypoint}});
  const Image with = render_view(grid, nullptr, options);
  auto px = [&](double x) { return (x - window.xmin) * 4; };
  auto py = [&](double y) { return (window.ymax - y) * 4; };
  const double wx = px(waypoint[0]), wy = py(waypoint[1]);
  size_t path_coloured = 0;
  for (int y = 0; y < with.height; ++y)
    for (int x = 0; x < with.width; ++x) {
      double nearest = INFINITY;
      for (size_t k = 1; k < path.size(); ++k)
        nearest = std::min(nearest, segment_distance(x + 0.5, y + 0.5, px(path[k - 1][0]), py(path[k - 1][1]),
                                                     px(path[k][0]), py(path[k][1])));
      const double to_marker = std::hypot(x + 0.5 - wx, y + 0.5 - wy);
      const bool differs = std::memcmp(pixel(with, x, y), pixel(without, x, y), 3) != 0;
      // 3-pixel line with a 1-pixel halo: 2.5 pixels from the centre line, plus antialiasing;
      // the disc (radius 6 + 1.5 outline) and its number to its right.
      const bool label = x > wx && x < wx + 20 && std::abs(y + 0.5 - wy) < 6;
      if (differs) EXPECT_TRUE(nearest < 3.6 || to_marker < 8.5 || label) << "pixel " << x << "," << y;
      const uint8_t* p = pixel(with, x, y);
      if (nearest < 0.7 && to_marker > 10) {
        ++path_coloured;
        EXPECT_TRUE(p[0] > 150 && p[1] < 60 && p[2] > 80) << "pixel " << x << "," << y << " on the path is not magenta";
      }
    }
  EXPECT_GT(path_coloured, 150u);
  const uint8_t* centre = pixel(with, static_cast<int>(wx), static_cast<int>(wy));
  EXPECT_TRUE(centre[0] > 200 && centre[1] > 170 && centre[2] < 60) << "the waypoint's disc is yellow";
  LineLayer bad = line;
  bad.width = 0;
  options.lines = {bad};
  EXPECT_THROW(render_view(grid, nullptr, options), ArgumentError);
}

TEST(Render, RealMeshAndDecorationsStayInsideThePicture) {
  const Grid& grid = nrw_grid();
  const Mesh mesh = triangulate_xy3(grid);
  RenderOptions options;
  options.window = Window{grid.x0 + 150, grid.y0 - 300, grid.x0 + 300, grid.y0 - 150};
  options.title = "XY-3, 1 m \xc3\xa4";  // non-ASCII prints as '?', never out of the font
  const Image image = render_view(grid, &mesh, options);
  EXPECT_EQ(image.width, 600);
  EXPECT_EQ(image.height, 600);
  // Title box top-left, north arrow box top-right: near white there.
  EXPECT_GT(brightness(image, 14, 14), 3 * 200);
  EXPECT_GT(brightness(image, image.width - 14, 14), 3 * 200);
}

TEST(Render, FurnitureIsNeverCoveredAndNumbersAvoidItAndEachOther) {
  const Grid& grid = nrw_grid();
  RenderOptions options;
  options.window = Window{grid.x0 + 100, grid.y0 - 300, grid.x0 + 300, grid.y0 - 100};
  options.pixels_per_cell = 3;
  options.title = "furniture and numbers";
  const Image bare = render_view(grid, nullptr, options);
  std::map<std::string, ImageRegion> furniture;
  for (const ImageRegion& r : bare.regions) furniture[r.what] = r;
  for (const std::string what : {"title", "north arrow", "scale bar", "legend"})
    ASSERT_TRUE(furniture.count(what)) << what;
  const auto at = [&](double x, double y) {  // a pixel centre back in the CRS
    return Point3{options.window->xmin + (x + 0.5) / 3, options.window->ymax - (y + 0.5) / 3, 150};
  };
  // A waypoint under the middle of every box (the bottom corners then stay as they are), and a
  // tight cluster of twelve in the open.
  MarkerLayer markers;
  for (const auto& [what, r] : furniture) markers.points.push_back(at((r.x0 + r.x1) / 2.0, (r.y0 + r.y1) / 2.0));
  for (int k = 0; k < 12; ++k) markers.points.push_back(at(260 + 24 * (k % 4), 260 + 24 * (k / 4)));
  options.markers = {markers};
  const Image busy = render_view(grid, nullptr, options);
  std::vector<ImageRegion> labels;
  for (const ImageRegion& r : busy.regions) {
    EXPECT_TRUE(r.x0 >= 0 && r.y0 >= 0 && r.x1 <= busy.width && r.y1 <= busy.height) << r.what;
    if (r.what.rfind("label ", 0) == 0) {
      labels.push_back(r);
      continue;
    }
    // Nothing covers a box and nothing shows through it: its pixels are those of the bare picture.
    const ImageRegion& was = furniture.at(r.what);
    ASSERT_EQ(r.x1 - r.x0, was.x1 - was.x0) << r.what;
    for (int y = r.y0; y < r.y1; ++y)
      for (int x = r.x0; x < r.x1; ++x)
        ASSERT_EQ(std::memcmp(pixel(busy, x, y), pixel(bare, x - r.x0 + was.x0, y - r.y0 + was.y0), 3), 0)
            << r.what << " covered at " << x << "," << y;
  }
  EXPECT_EQ(labels.size(), 12u);  // the cluster's; a disc under a box is hidden, and so is its number
  const auto meets = [](const ImageRegion& a, const ImageRegion& b) {
    return a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
  };
  for (size_t i = 0; i < busy.regions.size(); ++i)
    for (size_t j = i + 1; j < busy.regions.size(); ++j)
      EXPECT_FALSE(meets(busy.regions[i], busy.regions[j]))
          << busy.regions[i].what << " meets " << busy.regions[j].what;

  // One waypoint under the legend's left end, where the (narrower) scale bar would not reach:
  // the two change corners, and the waypoint shows.
  MarkerLayer one;
  const ImageRegion &bar = furniture.at("scale bar"), &legend = furniture.at("legend");
  const int wx = legend.x0 + 8, wy = legend.y1 - 8;
  ASSERT_LT(wx + 8, busy.width - 6 * 2 - (bar.x1 - bar.x0));  // clear of the scale bar moved right
  ASSERT_GT(wx - 8, bar.x0 + (legend.x1 - legend.x0));        // and of the legend moved left
  one.points = {at(wx, wy)};
  options.markers = {one};
  options.title.clear();
  const Image moved = render_view(grid, nullptr, options);
  for (const ImageRegion& r : moved.regions)
    if (r.what == "legend") EXPECT_LT(r.x1, moved.width / 2 + 40);
  const uint8_t* p = pixel(moved, wx, wy);
  EXPECT_TRUE(p[0] > 200 && p[1] > 150 && p[2] < 80)
      << int(p[0]) << "," << int(p[1]) << "," << int(p[2]);  // the disc's yellow
}

// The coordinate grid (issue 52, point 3) read back: each label's box is centred on the pixel
// column (x) or row (y) of the coordinate it prints, and the lines drawn (the pixels that differ
// from the same picture without the grid, outside the labels and the furniture) lie on those
// columns and rows and on no others, every round step apart.
TEST(Render, GridLabelsSitOnTheLinesTheyName) {
  const Grid& grid = nrw_grid();
  RenderOptions options;
  options.window = Window{grid.x0 + 40, grid.y0 - 460, grid.x0 + 460, grid.y0 - 40};
  options.pixels_per_cell = 1.5;
  options.title = "grid";
  const double scale = options.pixels_per_cell / grid.cell_x;
  const Image with = render_view(grid, nullptr, options);
  options.grid = false;
  const Image without = render_view(grid, nullptr, options);
  ASSERT_EQ(with.width, without.width);
  std::vector<double> xs, ys;
  std::vector<ImageRegion> boxes;
  for (const ImageRegion& r : with.regions) {
    boxes.push_back(r);
    const bool is_x = r.what.rfind("x ", 0) == 0, is_y = r.what.rfind("y ", 0) == 0;
    if (!is_x && !is_y) continue;
    const double value = std::stod(r.what.substr(2));
    const double at = is_x ? (value - options.window->xmin) * scale : (options.window->ymax - value) * scale;
    EXPECT_NEAR((is_x ? r.x0 + r.x1 : r.y0 + r.y1) / 2.0, at, 1.0) << r.what;
    (is_x ? xs : ys).push_back(value);
  }
  ASSERT_GE(xs.size(), 2u);
  ASSERT_GE(ys.size(), 2u);
  std::sort(xs.begin(), xs.end());
  const double step = xs[1] - xs[0];
  EXPECT_GT(step, 0);
  for (const auto& v : {xs, ys})
    for (double value : v) EXPECT_NEAR(std::remainder(value, step), 0, 1e-9) << value;
  // Every pixel the grid changed, outside the boxes, lies within a pixel of a line every step.
  const auto in_box = [&](int x, int y) {
    return std::any_of(boxes.begin(), boxes.end(),
                       [&](const ImageRegion& r) { return x >= r.x0 && x < r.x1 && y >= r.y0 && y < r.y1; });
  };
  const auto near_line = [&](double pixel, double origin_value, bool x_axis) {
    const double value = x_axis ? options.window->xmin + pixel / scale : options.window->ymax - pixel / scale;
    return std::abs(std::remainder(value - origin_value, step)) * scale <= 1.0 + 1e-9;
  };
  size_t changed = 0;
  for (int y = 0; y < with.height; ++y)
    for (int x = 0; x < with.width; ++x) {
      if (in_box(x, y) || std::memcmp(pixel(with, x, y), pixel(without, x, y), 3) == 0) continue;
      ++changed;
      EXPECT_TRUE(near_line(x + 0.5, xs[0], true) || near_line(y + 0.5, ys[0], false)) << x << "," << y;
    }
  EXPECT_GT(changed, static_cast<size_t>(with.width));  // the lines are there
}

TEST(Render, NodataAndOutsideHaveTheirOwnColours) {
  Grid grid = nrw_grid();
  for (int r = 10; r < 20; ++r)
    for (int c = 10; c < 20; ++c) grid.z[grid.index(c, r)] = Grid::nodata;
  // A window reaching 10 m west of the grid.
  const Image image = render_view(grid, nullptr, plain(Window{grid.x0 - 10, grid.y0 - 40, grid.x0 + 30, grid.y0}, 2));
  const uint8_t* hole = pixel(image, (10 + 15) * 2, 15 * 2);
  const uint8_t* outside = pixel(image, 5 * 2, 15 * 2);
  EXPECT_GT(hole[2], hole[0] + 20) << "nodata is pale blue";
  EXPECT_EQ(outside[0], outside[2]) << "outside the grid is grey";
  EXPECT_NE(std::memcmp(hole, outside, 3), 0);
}

TEST(Render, BadWindowOrZoomIsAnArgumentError) {
  const Grid& grid = nrw_grid();
  // Wholly east of the grid; touching its edge only; inverted; not finite.
  EXPECT_THROW(render_view(grid, nullptr, plain(Window{grid.x1() + 10, grid.y1(), grid.x1() + 50, grid.y0})),
               ArgumentError);
  EXPECT_THROW(render_view(grid, nullptr, plain(Window{grid.x1(), grid.y1(), grid.x1() + 50, grid.y0})), ArgumentError);
  EXPECT_THROW(render_view(grid, nullptr, plain(Window{grid.x0 + 50, grid.y1(), grid.x0, grid.y0})), ArgumentError);
  EXPECT_THROW(render_view(grid, nullptr, plain(Window{grid.x0, grid.y1(), NAN, grid.y0})), ArgumentError);
  EXPECT_THROW(render_view(grid, nullptr, plain(std::nullopt, 0)), ArgumentError);
  EXPECT_THROW(render_view(grid, nullptr, plain(std::nullopt, 1000)), ArgumentError);  // 500000 pixels a side
  try {
    render_view(grid, nullptr, plain(Window{0, 0, 10, 10}));
    ADD_FAILURE() << "no error";
  } catch (const ArgumentError& error) {
    EXPECT_EQ(std::string(error.what()).rfind("window: ", 0), 0u) << error.what();
    EXPECT_NE(std::string(error.what()).find("outside"), std::string::npos) << error.what();
  }
  Mesh broken;
  broken.vertices = {{grid.x0 + 1, grid.y0 - 1, 0}};
  broken.triangles = {{0, 1, 2}};
  EXPECT_THROW(render_view(grid, &broken, plain(std::nullopt, 1)), ArgumentError);
}

TEST(Render, ParseWindow) {
  const Window w = parse_window("356450, 5699450,356600.5,5699600");
  EXPECT_EQ(w.xmin, 356450);
  EXPECT_EQ(w.ymin, 5699450);
  EXPECT_EQ(w.xmax, 356600.5);
  EXPECT_EQ(w.ymax, 5699600);
  for (const char* bad : {"", "1,2,3", "1,2,3,4,5", "1,2,,4", "a,b,c,d", "1;2;3;4"}) {
    EXPECT_THROW(parse_window(bad), ArgumentError) << bad;
  }
}

TEST(Render, SideBySidePlacesPanelsWithAGap) {
  Image a{2, 3, std::vector<uint8_t>(2 * 3 * 3, 10)}, b{4, 1, std::vector<uint8_t>(4 * 1 * 3, 20)};
  const Image both = side_by_side({a, b}, 5);
  EXPECT_EQ(both.width, 2 + 5 + 4);
  EXPECT_EQ(both.height, 3);
  EXPECT_EQ(pixel(both, 1, 2)[0], 10);
  EXPECT_EQ(pixel(both, 3, 0)[0], 255);  // the gap
  EXPECT_EQ(pixel(both, 7, 0)[1], 20);
  EXPECT_EQ(pixel(both, 7, 1)[1], 255);  // below the shorter panel
  EXPECT_THROW(side_by_side({}), ArgumentError);
  EXPECT_THROW(side_by_side({a}, -1), ArgumentError);
  EXPECT_THROW(side_by_side({Image{2, 2, {1, 2, 3}}}), ArgumentError);
}

TEST(Png, ReadsBackWithLibpngToTheSamePixels) {
  const Grid& grid = nrw_grid();
  const Mesh mesh = triangulate_xy3(resample(grid, 5, Resampling::Median));
  RenderOptions options;
  options.window = Window{grid.x0, grid.y0 - 100, grid.x0 + 150, grid.y0};
  options.title = "round trip";
  const Image image = render_view(grid, &mesh, options);
  testkit::TempDir dir;
  const std::string path = dir.path("view.png");
  write_png(image, path);
  EXPECT_EQ(dir.files().size(), 1u);

  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&png, path.c_str())) << png.message;
  EXPECT_EQ(png.width, static_cast<png_uint_32>(image.width));
  EXPECT_EQ(png.height, static_cast<png_uint_32>(image.height));
  EXPECT_EQ(png.format & PNG_FORMAT_FLAG_COLOR, static_cast<png_uint_32>(PNG_FORMAT_FLAG_COLOR));
  png.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(png));
  ASSERT_TRUE(png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr)) << png.message;
  EXPECT_TRUE(pixels == image.rgb);
}

TEST(Png, FailedWritesLeaveNothingAndBadImagesAreRefused) {
  const Image image{3, 2, std::vector<uint8_t>(3 * 2 * 3, 128)};
  testkit::TempDir dir;
  EXPECT_THROW(write_png(image, dir.path("missing/view.png")), OutputError);
  EXPECT_THROW(write_png(Image{}, dir.path("empty.png")), ArgumentError);
  EXPECT_THROW(write_png(Image{3, 2, {1, 2, 3}}, dir.path("short.png")), ArgumentError);
  EXPECT_TRUE(dir.files().empty());
}

// ---- the height profile of a path ------------------------------------------------------------
//
// Oracles: the test builds the ground, the building and the path, so it knows every height; the
// picture's axes are found in the picture itself (its 1-pixel dark frame) and the height axis is
// fixed by the test, so a pixel's row says its height without any of the drawing code.

namespace {

// Flat 10 m ground, 200 x 20 cells of 1 m, one 30 m building over columns 80-119 (x 1080-1120).
Grid flat_town() {
  Grid grid(200, 20, 1000, 2000, 1, 1);
  for (int r = 0; r < grid.height; ++r)
    for (int c = 0; c < grid.width; ++c) grid.z[grid.index(c, r)] = c >= 80 && c < 120 ? 30.0f : 10.0f;
  return grid;
}

// The plot's pixel rectangle [left, right) x [top, bottom), found from its dark frame: the
// longest dark runs of any row (the frame's top and bottom) and of any column (its sides).
struct Plot {
  int left = -1, top = -1, right = -1, bottom = -1;
};
bool dark(const Image& image, int x, int y) { return brightness(image, x, y) < 150; }
Plot find_plot(const Image& image) {
  Plot plot;
  std::vector<int> rows, cols;
  for (int y = 0; y < image.height; ++y) {
    int run = 0, longest = 0;
    for (int x = 0; x < image.width; ++x) longest = std::max(longest, run = dark(image, x, y) ? run + 1 : 0);
    if (longest > image.width / 2) rows.push_back(y);
  }
  for (int x = 0; x < image.width; ++x) {
    int run = 0, longest = 0;
    for (int y = 0; y < image.height; ++y) longest = std::max(longest, run = dark(image, x, y) ? run + 1 : 0);
    if (longest > image.height / 3) cols.push_back(x);
  }
  if (rows.size() != 2 || cols.size() != 2) return plot;  // a frame is two rows and two columns
  plot.top = rows[0] + 1, plot.bottom = rows[1], plot.left = cols[0] + 1, plot.right = cols[1];
  return plot;
}

bool magenta(const uint8_t* p) { return p[0] > 230 && p[1] < 40 && p[2] > 230; }
bool red(const uint8_t* p) { return p[0] > 180 && p[1] < 80 && p[2] < 80; }
bool grey(const uint8_t* p) {  // the silhouette: neutral, darker than half-way from white
  return std::abs(p[0] - p[1]) < 8 && std::abs(p[1] - p[2]) < 8 && p[0] < 212 && p[0] > 120;
}
bool brown(const uint8_t* p) { return p[0] > 110 && p[0] < 170 && p[1] > 60 && p[1] < 110 && p[2] < 60; }

// Mean row (pixel centres) of the pixels of a column that pass `is`, or NaN when none does,
// between rows y0 and y1.
template <class Is>
double mean_row(const Image& image, int x, int y0, int y1, Is is) {
  double sum = 0;
  int n = 0;
  for (int y = y0; y < y1; ++y)
    if (is(pixel(image, x, y))) sum += y + 0.5, ++n;
  return n ? sum / n : NAN;
}

}  // namespace

TEST(Profile, StepsAreTheCellsUnderThePathExactly) {
  const Grid town = flat_town();
  // Along row 10, from x 1010 to 1190 at 45 m: 70 m of ground, 40 m of building, 70 m of ground.
  const std::vector<Point3> path{{1010, 1989.5, 45}, {1100, 1989.5, 45}, {1190, 1989.5, 45}};
  const PathProfile profile = profile_path(path, town, nullptr);
  EXPECT_DOUBLE_EQ(profile.length, 180);
  ASSERT_EQ(profile.dsm.size(), 3u);
  EXPECT_EQ(profile.dsm[0].from, 0);
  EXPECT_EQ(profile.dsm[0].to, 70);
  EXPECT_EQ(profile.dsm[0].z, 10.0f);
  EXPECT_EQ(profile.dsm[1].from, 70);
  EXPECT_EQ(profile.dsm[1].to, 110);
  EXPECT_EQ(profile.dsm[1].z, 30.0f);
  EXPECT_EQ(profile.dsm[2].to, 180);
  EXPECT_DOUBLE_EQ(profile.min_above_dsm, 15);
  EXPECT_DOUBLE_EQ(profile.max_above_ground, 35);  // no DTM: the DSM is the ground

  // A diagonal path over the real sample, against a brute-force sampling of the cell under it:
  // every one of 20000 points along the path lies over the height of the step holding it.
  const Grid& grid = nrw_grid();
  const std::vector<Point3> diagonal{{grid.x0 + 3.3, grid.y0 - 7.1, 150},
                                     {grid.x0 + 250, grid.y0 - 190.7, 160},
                                     {grid.x0 + 250, grid.y0 - 400, 155},
                                     {grid.x0 + 480.2, grid.y0 - 260.9, 170}};
  const PathProfile real = profile_path(diagonal, grid, nullptr);
  ASSERT_FALSE(real.dsm.empty());
  EXPECT_EQ(real.dsm.front().from, 0);
  EXPECT_DOUBLE_EQ(real.dsm.back().to, real.length);
  for (size_t i = 1; i < real.dsm.size(); ++i) ASSERT_EQ(real.dsm[i].from, real.dsm[i - 1].to);
  double least = INFINITY;
  size_t step = 0;
  for (int k = 0; k <= 20000; ++k) {
    const double d = real.length * k / 20000;
    size_t seg = 0;
    while (seg + 2 < real.distance.size() && real.distance[seg + 1] < d) ++seg;
    const double t = (d - real.distance[seg]) / (real.distance[seg + 1] - real.distance[seg]);
    const Point3 &a = diagonal[seg], &b = diagonal[seg + 1];
    const double x = a[0] + t * (b[0] - a[0]), y = a[1] + t * (b[1] - a[1]), z = a[2] + t * (b[2] - a[2]);
    const double cx = (x - grid.x0) / grid.cell_x, cy = (grid.y0 - y) / grid.cell_y;
    if (std::abs(cx - std::round(cx)) < 1e-6 || std::abs(cy - std::round(cy)) < 1e-6) continue;  // on a boundary
    const float below = grid.at(static_cast<int>(cx), static_cast<int>(cy));
    least = std::min(least, z - below);
    while (step + 1 < real.dsm.size() && real.dsm[step].to <= d) ++step;
    if (d > real.dsm[step].from + 1e-6 && d < real.dsm[step].to - 1e-6)
      ASSERT_EQ(real.dsm[step].z, below) << "at " << d << " m";
  }
  // The exact least height is at most the sampled one, and not far below it (the samples are 3 cm apart).
  EXPECT_LE(real.min_above_dsm, least + 1e-9);
  EXPECT_GT(real.min_above_dsm, least - 0.1);

  EXPECT_THROW(profile_path({{1010, 1989.5, 45}}, town, nullptr), ArgumentError);
  EXPECT_THROW(profile_path({{1010, 1989.5, 45}, {NAN, 1989.5, 45}}, town, nullptr), ArgumentError);
}

TEST(Profile, PathSilhouetteAndCeilingSitAtTheirHeights) {
  const Grid town = flat_town();
  const std::vector<Point3> path{{1010, 1989.5, 45}, {1100, 1989.5, 45}, {1190, 1989.5, 45}};
  ProfileOptions options;
  options.width = 900, options.height = 420;
  options.title = "flat town";
  options.safety = 2, options.max_agl = 60;  // the ceiling: 70 m over the ground, 90 m over the roof
  options.z_min = 0, options.z_max = 100;
  options.waypoints = {{1100, 1989.5, 45}};
  const Image image = render_profile(path, town, nullptr, options);
  ASSERT_EQ(image.width, 900);
  ASSERT_EQ(image.height, 420);
  const Plot plot = find_plot(image);
  ASSERT_GT(plot.left, 0) << "no frame found";
  ASSERT_GT(plot.right - plot.left, 500);
  ASSERT_GT(plot.bottom - plot.top, 150);
  const double metres_per_row = 100.0 / (plot.bottom - plot.top);
  auto height = [&](double row) { return 100 - (row - plot.top) / (plot.bottom - plot.top) * 100; };
  auto distance = [&](int x) { return (x + 0.5 - plot.left) / (plot.right - plot.left) * 180; };
  auto row_of = [&](double z) { return plot.top + (100 - z) / 100 * (plot.bottom - plot.top); };
  const int wx = plot.left + (plot.right - plot.left) / 2;  // the waypoint's column: 90 m

  int path_columns = 0, ceiling_columns = 0, columns = 0;
  for (int x = plot.left; x < plot.right; ++x) {
    const double d = distance(x);
    if (d < 3 || d > 177 || std::abs(x - wx) < 12) continue;  // the ends, the waypoint's disc
    ++columns;
    // The path: magenta around 45 m, within a pixel.
    const double path_row = mean_row(image, x, plot.top, plot.bottom, magenta);
    if (!std::isnan(path_row)) {
      ++path_columns;
      EXPECT_NEAR(height(path_row), 45, metres_per_row) << "column " << x;
    }
    // The silhouette: grey from the bottom up to 30 m over the building, 10 m elsewhere.
    if (std::abs(d - 70) > 2 && std::abs(d - 110) > 2) {
      const bool roof = d > 70 && d < 110;
      int y = plot.bottom - 1;
      while (y >= plot.top && grey(pixel(image, x, y))) --y;
      ASSERT_LT(y, plot.bottom - 1) << "no silhouette at column " << x;
      EXPECT_NEAR(height(y + 1.5), roof ? 30 : 10, metres_per_row) << "column " << x;
      // The ceiling: red dashes at ground + max_agl.
      const double ceiling_row = mean_row(image, x, plot.top, plot.bottom, red);
      if (!std::isnan(ceiling_row)) {
        ++ceiling_columns;
        EXPECT_NEAR(height(ceiling_row), roof ? 90 : 70, metres_per_row) << "column " << x;
      }
    }
  }
  EXPECT_GT(path_columns, columns * 9 / 10);
  EXPECT_GT(ceiling_columns, columns / 3);  // dashed: most columns have a dash
  // The safety band: translucent magenta 2 m above the path (between the line and 47 m).
  const uint8_t* band = pixel(image, plot.left + 100, static_cast<int>(row_of(46.5)));
  EXPECT_TRUE(band[0] > 230 && band[1] > 120 && band[1] < 230 && band[2] > 230) << int(band[1]);
  // The waypoint: a yellow disc on the path at 90 m.
  const uint8_t* disc = pixel(image, wx, static_cast<int>(row_of(45)));
  EXPECT_TRUE(disc[0] > 200 && disc[1] > 170 && disc[2] < 60) << "the waypoint's disc is yellow";
  // Nothing of the plot outside the frame but the waypoint: no magenta or red above it, none
  // left or right of it.
  for (int y = 0; y < plot.top - 1; ++y)
    for (int x = 0; x < image.width; ++x)
      if (std::abs(x - wx) > 20) EXPECT_FALSE(magenta(pixel(image, x, y)) || red(pixel(image, x, y))) << x << "," << y;

  // The legend below the plot: its swatches (grey, red, magenta) with text beside them.
  int legend_top = -1;
  for (int y = plot.bottom + 1; y < image.height && legend_top < 0; ++y)
    for (int x = 0; x < image.width; ++x)
      if (magenta(pixel(image, x, y)) || red(pixel(image, x, y)) || grey(pixel(image, x, y))) {
        legend_top = y;
        break;
      }
  ASSERT_GT(legend_top, plot.bottom + 20) << "no legend under the plot's labels";
  size_t swatches[3] = {0, 0, 0}, text = 0;
  for (int y = legend_top - 4; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = pixel(image, x, y);
      swatches[0] += grey(p), swatches[1] += red(p), swatches[2] += magenta(p);
      text += dark(image, x, y);
    }
  EXPECT_GT(swatches[0], 100u);
  EXPECT_GT(swatches[1], 20u);
  EXPECT_GT(swatches[2], 40u);
  EXPECT_GT(text, 300u);  // "DSM under the path", "ceiling: DSM + 60 m", "path", ...
}

// ---- no-fly zones in pictures -----------------------------------------------------------------

namespace {

using Ring2 = std::vector<std::array<double, 2>>;

// The zones of the hand-made ED-269 file over the NRW crop, read with nlohmann-json and put into
// the DSM's CRS by GDAL's own transformer (not read_airspace()): polygons as the file gives them,
// circles as 720-gons of the file's radius around the centre (a UTM scale error of < 0.05 %).
struct OracleZone {
  std::string name;
  bool blocking = true;
  std::vector<Ring2> rings;
};
std::vector<OracleZone> oracle_zones(const std::string& file, const Grid& grid) {
  const nlohmann::json doc = nlohmann::json::parse(testkit::read_file(file));
  OGRSpatialReference wgs84, target;
  wgs84.SetWellKnownGeogCS("WGS84");
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  target.importFromEPSG(grid.crs.epsg);
  target.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> to(OGRCreateCoordinateTransformation(&wgs84, &target));
  std::vector<OracleZone> zones;
  for (const auto& feature : doc["features"]) {
    OracleZone zone;
    zone.name = feature["name"];
    const std::string restriction = feature["restriction"];
    zone.blocking = restriction == "PROHIBITED" || restriction == "REQ_AUTHORISATION";
    const auto& shape = feature["geometry"][0]["horizontalProjection"];
    if (shape["type"] == "Circle") {
      double x = shape["center"][0], y = shape["center"][1];
      to->Transform(1, &x, &y);
      const double radius = shape["radius"];
      Ring2 ring;
      for (int k = 0; k < 720; ++k)
        ring.push_back({x + radius * std::cos(k * M_PI / 360), y + radius * std::sin(k * M_PI / 360)});
      zone.rings.push_back(ring);
    } else {
      for (const auto& given : shape["coordinates"]) {
        Ring2 ring;
        for (const auto& corner : given) {
          double x = corner[0], y = corner[1];
          to->Transform(1, &x, &y);
          ring.push_back({x, y});
        }
        zone.rings.push_back(ring);
      }
    }
    zones.push_back(zone);
  }
  return zones;
}

// Distance from (x, y) to the zone's area (0 inside, by the even-odd rule over its rings).
double area_distance(const OracleZone& zone, double x, double y) {
  bool inside = false;
  double nearest = INFINITY;
  for (const Ring2& ring : zone.rings)
    for (size_t k = 0; k < ring.size(); ++k) {
      const auto& a = ring[k];
      const auto& b = ring[(k + 1) % ring.size()];
      nearest = std::min(nearest, segment_distance(x, y, a[0], a[1], b[0], b[1]));
      if ((a[1] <= y) != (b[1] <= y) && x < a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0])) inside = !inside;
    }
  return inside ? -nearest : nearest;  // negative: inside, that far from the boundary
}

}  // namespace

TEST(Render, ZonesAreDrawnInsideTheirOutlinesAndNowhereElse) {
  const Grid& grid = nrw_grid();
  const std::string file = std::string(DSMPLAN_TEST_DATA_DIR) + "/airspace/nrw_zones_ed269.json";
  VerticalOptions vertical;
  vertical.vertical_crs = "EPSG:7837";
  vertical.allow_approximate_vertical = true;
  RenderOptions options = plain(std::nullopt, 1);  // 1 pixel a metre
  const Image without = render_view(grid, nullptr, options);
  options.zones.zones = read_airspace(file, grid.crs, vertical);
  const Image with = render_view(grid, nullptr, options);
  ASSERT_EQ(with.width, without.width);
  const std::vector<OracleZone> oracle = oracle_zones(file, grid);
  ASSERT_EQ(oracle.size(), options.zones.zones.size());
  std::vector<ImageRegion> captions;
  for (const ImageRegion& r : with.regions)
    if (r.what.rfind("zone ", 0) == 0) captions.push_back(r);
  EXPECT_EQ(captions.size(), oracle.size()) << "every zone over the crop is named";
  const auto in_caption = [&](int x, int y) {
    return std::any_of(captions.begin(), captions.end(),
                       [&](const ImageRegion& r) { return x >= r.x0 && x < r.x1 && y >= r.y0 && y < r.y1; });
  };
  size_t blocking_ink = 0, other_ink = 0, tinted = 0, deep = 0;
  for (int y = 0; y < with.height; ++y)
    for (int x = 0; x < with.width; ++x) {
      const double cx = grid.x0 + x + 0.5, cy = grid.y0 - y - 0.5;
      // nearest: the least signed distance (negative inside a zone); edge: to the nearest ring.
      double nearest = INFINITY, edge = INFINITY;
      for (const OracleZone& zone : oracle) {
        const double d = area_distance(zone, cx, cy);
        nearest = std::min(nearest, d), edge = std::min(edge, std::abs(d));
      }
      const bool differs = std::memcmp(pixel(with, x, y), pixel(without, x, y), 3) != 0;
      const uint8_t* p = pixel(with, x, y);
      const bool caption = in_caption(x, y);
      // Outlines 2 pixels wide (1 each side, +1 antialiasing); the tint inside.
      if (differs && !caption) EXPECT_LT(nearest, 2.1) << "pixel " << x << "," << y << " changed outside every zone";
      if (!caption && p[0] == kZoneBlocking[0] && p[1] == kZoneBlocking[1] && p[2] == kZoneBlocking[2]) {
        ++blocking_ink;
        EXPECT_LT(edge, 1.5) << "pixel " << x << "," << y << " in the zone colour off an outline";
      }
      if (!caption && p[0] == kZoneOther[0] && p[1] == kZoneOther[1] && p[2] == kZoneOther[2]) ++other_ink;
      // Tinted towards red or amber: red gains on blue.
      const uint8_t* was = pixel(without, x, y);
      if (nearest < -3 && edge > 3 && !caption) ++deep, tinted += differs && p[0] - p[2] > was[0] - was[2];
    }
  EXPECT_GT(blocking_ink, 600u) << "the blocking zones' outlines in their colour";
  EXPECT_GT(other_ink, 100u) << "the park (no restriction) in the other colour";
  EXPECT_GT(deep, 5000u);
  EXPECT_EQ(tinted, deep) << "every pixel well inside a zone is tinted";
}

TEST(Profile, ZonesCoverTheirPartOfTheSectionFloorToCeiling) {
  const Grid town = flat_town();  // 10 m ground, a 30 m building from 80 m to 120 m along the path
  const std::vector<Point3> path{{1010, 1989.5, 45}, {1190, 1989.5, 45}};
  ProfileOptions options;
  options.width = 900, options.height = 420;
  options.safety = 0, options.max_agl = 60;
  options.z_min = 0, options.z_max = 100;
  AirspaceZone agl;  // over 30-50 m along the path: 20 to 50 m above the 10 m ground
  agl.name = "AGL";
  agl.restriction = "PROHIBITED";
  agl.rings = {{{1040, 1980}, {1060, 1980}, {1060, 1995}, {1040, 1995}}};
  agl.lower = ZoneLimit::agl(20), agl.upper = ZoneLimit::agl(50);
  AirspaceZone band;  // over 120-150 m: 70 to 80 m in the CRS, not blocking
  band.name = "BAND";
  band.restriction = "NO_RESTRICTION";
  band.rings = {{{1130, 1970}, {1160, 1970}, {1160, 2000}, {1130, 2000}}};
  band.lower = ZoneLimit::crs_height(70), band.upper = ZoneLimit::crs_height(80);
  options.zones.zones = {agl, band};
  const Image image = render_profile(path, town, nullptr, options);
  const Plot plot = find_plot(image);
  ASSERT_GT(plot.right - plot.left, 500);
  const auto column = [&](double d) { return plot.left + static_cast<int>((d / 180) * (plot.right - plot.left)); };
  const auto row = [&](double z) { return plot.top + static_cast<int>((100 - z) / 100 * (plot.bottom - plot.top)); };
  const auto reddish = [&](int x, int y) {
    const uint8_t* p = pixel(image, x, y);
    return p[0] > p[1] + 25 && p[0] > p[2] + 25 && !magenta(p);
  };
  const auto amber = [&](int x, int y) {
    const uint8_t* p = pixel(image, x, y);
    return p[0] > p[2] + 25 && p[1] > p[2] + 10 && p[0] > p[1];
  };
  // Inside each zone's part, between floor and ceiling (away from the outline, caption and path).
  for (double d : {33.0, 38.0, 47.0})
    for (double z : {32.0, 36.0, 40.0})
      EXPECT_TRUE(reddish(column(d), row(z))) << "AGL zone at " << d << " m, " << z << " m";
  for (double d : {123.0, 128.0, 147.0}) EXPECT_TRUE(amber(column(d), row(72))) << "band at " << d << " m";
  // Outside: beyond its ends, and above its ceiling or below its floor.
  for (double d : {20.0, 60.0, 100.0})
    for (double z : {35.0, 75.0}) EXPECT_FALSE(reddish(column(d), row(z)) || amber(column(d), row(z))) << d << "," << z;
  for (double z : {25.0, 64.0, 90.0}) EXPECT_FALSE(reddish(column(40), row(z))) << "AGL zone at 40 m, " << z << " m";
  for (double z : {60.0, 90.0}) EXPECT_FALSE(amber(column(140), row(z))) << "band at 140 m, " << z << " m";
}

TEST(Profile, TerrainIsTheCeilingsGroundAndItsGapsStayGaps) {
  const Grid town = flat_town();
  // A 5 m DTM at 8 m, with no data over x 1140-1160.
  Grid dtm(44, 8, 995, 2010, 5, 5);
  for (int r = 0; r < dtm.height; ++r)
    for (int c = 0; c < dtm.width; ++c) {
      const double x = dtm.center_x(c);
      dtm.z[dtm.index(c, r)] = x > 1140 && x < 1160 ? Grid::nodata : 8.0f;
    }
  const std::vector<Point3> path{{1010, 1989.5, 45}, {1190, 1989.5, 45}};
  ProfileOptions options;
  options.width = 900, options.height = 420;
  options.max_agl = 60;  // 68 m everywhere, the building too
  options.z_min = 0, options.z_max = 100;
  const Image image = render_profile(path, town, &dtm, options);
  const Plot plot = find_plot(image);
  ASSERT_GT(plot.left, 0) << "no frame found";
  const double metres_per_row = 100.0 / (plot.bottom - plot.top);
  auto height = [&](double row) { return 100 - (row - plot.top) / (plot.bottom - plot.top) * 100; };
  int brown_columns = 0, gap_columns = 0;
  for (int x = plot.left; x < plot.right; ++x) {
    const double d = (x + 0.5 - plot.left) / (plot.right - plot.left) * 180;
    if (d < 3 || d > 177) continue;
    const double terrain = mean_row(image, x, plot.top, plot.bottom, brown);
    const bool gap = d > 130 + 2 && d<150 - 2, near_gap = d> 130 - 2 && d < 150 + 2;
    if (gap) {
      ++gap_columns;
      EXPECT_TRUE(std::isnan(terrain)) << "terrain drawn over its gap at column " << x;
      EXPECT_TRUE(std::isnan(mean_row(image, x, plot.top, plot.bottom, red))) << "ceiling over the gap at " << x;
    } else if (!near_gap) {
      ASSERT_FALSE(std::isnan(terrain)) << "no terrain at column " << x;
      ++brown_columns;
      EXPECT_NEAR(height(terrain), 8, metres_per_row) << "column " << x;
      const double ceiling = mean_row(image, x, plot.top, plot.bottom, red);
      if (!std::isnan(ceiling)) EXPECT_NEAR(height(ceiling), 68, metres_per_row) << "column " << x;
    }
  }
  EXPECT_GT(brown_columns, 400);
  EXPECT_GT(gap_columns, 50);
  const PathProfile profile = profile_path(path, town, &dtm);
  EXPECT_DOUBLE_EQ(profile.max_above_ground, 37);  // 45 m over the 8 m terrain
  EXPECT_DOUBLE_EQ(profile.min_above_dsm, 15);

  // The fitted axis holds everything: the ceiling shows without a fixed axis.
  options.z_min = options.z_max = NAN;
  const Image fitted = render_profile(path, town, &dtm, options);
  const Plot fitted_plot = find_plot(fitted);
  ASSERT_GT(fitted_plot.left, 0);
  EXPECT_FALSE(std::isnan(mean_row(fitted, fitted_plot.left + 20, fitted_plot.top, fitted_plot.bottom, red)) &&
               std::isnan(mean_row(fitted, fitted_plot.left + 30, fitted_plot.top, fitted_plot.bottom, red)));
}

TEST(Profile, BadOptionsAreArgumentErrors) {
  const Grid town = flat_town();
  const std::vector<Point3> path{{1010, 1989.5, 45}, {1190, 1989.5, 45}};
  auto with = [&](auto change) {
    ProfileOptions options;
    change(options);
    return options;
  };
  EXPECT_THROW(render_profile(path, town, nullptr, with([](ProfileOptions& o) { o.width = 100; })), ArgumentError);
  EXPECT_THROW(render_profile(path, town, nullptr, with([](ProfileOptions& o) { o.height = 40000; })), ArgumentError);
  EXPECT_THROW(render_profile(path, town, nullptr, with([](ProfileOptions& o) { o.safety = -1; })), ArgumentError);
  EXPECT_THROW(render_profile(path, town, nullptr, with([](ProfileOptions& o) { o.max_agl = 0; })), ArgumentError);
  EXPECT_THROW(render_profile(path, town, nullptr, with([](ProfileOptions& o) { o.z_min = 5; })), ArgumentError);
  EXPECT_THROW(render_profile({{1010, 1989.5, 45}, {1010, 1989.5, 60}}, town, nullptr, ProfileOptions{}),
               ArgumentError);  // no x,y length
  EXPECT_NO_THROW(render_profile(path, town, nullptr, ProfileOptions{}));
}

// ---- WGS 84 through PROJ, and paths as text -----------------------------------------------
//
// Oracles: GDAL's own coordinate transformation (OGRCoordinateTransformation, traditional GIS
// axis order) for the horizontal part; the round trip for the inverse; the EGM96 grid's height
// difference is checked to be the geoid's size at Muelheim (tens of metres), not zero.

namespace {

dsmplan::Crs utm32() {
  dsmplan::Crs crs;
  crs.definition = "EPSG:25832";
  dsmplan::resolve_crs(crs);
  return crs;
}

}  // namespace

TEST(Wgs84Transform, HorizontalAgreesWithGdalAndRoundTripsWithinAMillimetre) {
  VerticalOptions egm96;
  egm96.vertical_crs = "EPSG:5773";  // EGM96 height: PROJ has its grid (egm96_15.gtx), an exact operation
  const Wgs84Transform t(utm32(), HeightReference::Ellipsoid, egm96);
  EXPECT_FALSE(t.approximate_heights()) << t.description();
  OGRSpatialReference utm, wgs;
  utm.importFromEPSG(25832);
  wgs.importFromEPSG(4326);
  wgs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> gdal(OGRCreateCoordinateTransformation(&utm, &wgs));
  ASSERT_TRUE(gdal);
  for (const Point3& p :
       {Point3{356320, 5699270, 130}, Point3{357000, 5700000, 90}, Point3{356800.25, 5699745.5, 160}}) {
    const Point3 g = t.to_wgs84(p);
    double x = p[0], y = p[1];
    ASSERT_TRUE(gdal->Transform(1, &x, &y));
    EXPECT_NEAR(g[0], x, 1e-8);  // longitude first, whatever EPSG:4326's axis order
    EXPECT_NEAR(g[1], y, 1e-8);
    EXPECT_GT(g[0], 6.9);
    EXPECT_LT(g[0], 7.0);
    // The geoid stands about 47 m above the ellipsoid here: heights must move by that much.
    EXPECT_GT(g[2] - p[2], 40);
    EXPECT_LT(g[2] - p[2], 55);
    const Point3 back = t.from_wgs84(g);
    EXPECT_LT(std::hypot(back[0] - p[0], back[1] - p[1], back[2] - p[2]), 1e-3);
  }
}

// The x, y-only transformation (zones' corners): GDAL's own 2D answer for a projected CRS and
// for the same CRS with a vertical part, the heights passed through untouched, no vertical
// reference needed.
TEST(Wgs84Transform, HorizontalOnlyAgreesWithGdalAndLeavesHeights) {
  for (const auto& [definition, epsg, point] : {std::tuple{"EPSG:25832", 25832, Point3{356800.25, 5699745.5, 160}},
                                                std::tuple{"EPSG:25832+7837", 25832, Point3{356320, 5699270, 130}},
                                                std::tuple{"EPSG:28992", 28992, Point3{84853.25, 446871.5, 12}}}) {
    dsmplan::Crs crs;
    crs.definition = definition;
    dsmplan::resolve_crs(crs);
    const Wgs84Transform t = Wgs84Transform::horizontal_only(crs);
    OGRSpatialReference from, wgs;
    from.importFromEPSG(epsg);
    wgs.importFromEPSG(4326);
    wgs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    std::unique_ptr<OGRCoordinateTransformation> gdal(OGRCreateCoordinateTransformation(&from, &wgs));
    ASSERT_TRUE(gdal);
    double x = point[0], y = point[1];
    ASSERT_TRUE(gdal->Transform(1, &x, &y));
    const Point3 g = t.to_wgs84(point);
    EXPECT_NEAR(g[0], x, 1e-8) << definition;
    EXPECT_NEAR(g[1], y, 1e-8) << definition;
    EXPECT_EQ(g[2], point[2]) << definition;
    std::vector<Point3> back{g};
    t.from_wgs84(back);
    EXPECT_LT(std::hypot(back[0][0] - point[0], back[0][1] - point[1]), 1e-3) << definition;
    EXPECT_EQ(back[0][2], point[2]) << definition;
  }
}

TEST(Wgs84Transform, UnknownOrApproximateHeightsAreRefusedUnlessAllowed) {
  try {
    Wgs84Transform(utm32(), HeightReference::Ellipsoid, {});
    ADD_FAILURE() << "unknown vertical reference accepted";
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown"), std::string::npos) << e.what();
  }
  VerticalOptions dhhn;
  dhhn.vertical_crs = "EPSG:7837";  // DHHN2016: PROJ has no GCG2016 grid here, only a ballpark
  try {
    Wgs84Transform(utm32(), HeightReference::Ellipsoid, dhhn);
    ADD_FAILURE() << "ballpark vertical accepted";
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("approximate"), std::string::npos) << e.what();
  }
  // Allowed, heights of a grid-less or unknown datum are taken as EGM96 heights and go through the
  // EGM96 grid: exactly what naming EGM96 gives, never the ballpark's copy (47 m off here).
  VerticalOptions egm96;
  egm96.vertical_crs = "EPSG:5773";
  const Wgs84Transform exact(utm32(), HeightReference::Ellipsoid, egm96);
  dhhn.allow_approximate_vertical = true;
  VerticalOptions unknown;
  unknown.allow_approximate_vertical = true;
  for (const VerticalOptions& options : {dhhn, unknown}) {
    const Wgs84Transform taken(utm32(), HeightReference::Ellipsoid, options);
    EXPECT_TRUE(taken.approximate_heights());
    EXPECT_NE(taken.description().find("taken as EGM96"), std::string::npos) << taken.description();
    EXPECT_NE(taken.description().find("under 1 m"), std::string::npos) << taken.description();
    for (const Point3& p : {Point3{356320, 5699270, 130}, Point3{357000, 5700000, 90}}) {
      const Point3 g = taken.to_wgs84(p), e = exact.to_wgs84(p);
      EXPECT_GT(g[2] - p[2], 40);  // the geoid's height, added
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(g[k], e[k], 1e-9);
      const Point3 back = taken.from_wgs84(g);
      EXPECT_LT(std::hypot(back[0] - p[0], back[1] - p[1], back[2] - p[2]), 1e-3);
    }
    const Wgs84Transform msl(utm32(), HeightReference::MeanSeaLevel, options);
    EXPECT_NEAR(msl.to_wgs84({356320, 5699270, 130})[2], 130, 1e-6);  // EGM96 to EGM96
  }
  VerticalOptions not_vertical;
  not_vertical.vertical_crs = "EPSG:4326";
  EXPECT_THROW(Wgs84Transform(utm32(), HeightReference::Ellipsoid, not_vertical), ArgumentError);
}

// ---- 3D Tiles: a GLB placed on the globe -----------------------------------------------
//
// Oracles: GDAL's coordinate transformation from the CRS + EGM96 heights to WGS 84 geocentric
// (EPSG:4978), PROJ underneath but not dsmplan's choice of operation nor its ECEF formula; and
// CesiumJS itself, loading the tileset in headless Chromium and sampling the mesh's heights.

namespace {

// x, y, EGM96 height in EPSG:25832 to ECEF (EPSG:4978), or to lon, lat, ellipsoidal height
// (EPSG:4979), through GDAL.
std::unique_ptr<OGRCoordinateTransformation> utm32_egm96_to(int epsg) {
  OGRSpatialReference from, to;
  EXPECT_EQ(from.SetFromUserInput("EPSG:25832+5773"), OGRERR_NONE);
  EXPECT_EQ(to.importFromEPSG(epsg), OGRERR_NONE);
  from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  to.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return std::unique_ptr<OGRCoordinateTransformation>(OGRCreateCoordinateTransformation(&from, &to));
}

Mesh box_mesh(double x0, double y0, double x1, double y1, double z0, double z1) {
  Mesh mesh;
  mesh.crs = utm32();
  mesh.vertices = {{x0, y0, z0}, {x1, y0, z1}, {x1, y1, z0}, {x0, y1, z1}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

std::array<double, 3> apply(const std::array<double, 16>& m, const std::array<double, 3>& p) {
  std::array<double, 3> out{};
  for (int r = 0; r < 3; ++r) out[r] = m[12 + r] + m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2];
  return out;
}

}  // namespace

TEST(Tileset, TransformAgreesWithGdalsGeocentricWithinItsStatedError) {
  VerticalOptions egm96;
  egm96.vertical_crs = "EPSG:5773";
  const Wgs84Transform heights(utm32(), HeightReference::Ellipsoid, egm96);
  const auto gdal = utm32_egm96_to(4978);
  ASSERT_TRUE(gdal);
  // The NRW tile's kilometre, from street level to the roofs.
  const Mesh mesh = box_mesh(356000, 5699000, 357000, 5700000, 60, 200);
  const TilesetPlacement placement = place_on_globe(mesh, heights);
  EXPECT_GT(placement.max_error_m, 0.001);  // the Earth curves: an affine map cannot be exact
  EXPECT_LE(placement.max_error_m, 0.05);   // (500 m)^2 / 2R is 2 cm
  double worst = 0;
  for (int i = 0; i <= 10; ++i)
    for (int j = 0; j <= 10; ++j)
      for (double z : {60.0, 131.0, 200.0}) {
        const std::array<double, 3> p{356000 + 100.0 * i, 5699000 + 100.0 * j, z};
        double x = p[0], y = p[1], h = p[2];
        ASSERT_TRUE(gdal->Transform(1, &x, &y, &h));
        const auto q = apply(placement.transform, p);
        worst = std::max(worst, std::hypot(q[0] - x, q[1] - y, q[2] - h));
      }
  EXPECT_LE(worst, placement.max_error_m + 1e-3);
  // The box: the mesh's, centred, half-axes along x, y, z.
  EXPECT_EQ(placement.box[0], 356500);
  EXPECT_EQ(placement.box[1], 5699500);
  EXPECT_EQ(placement.box[2], 130);
  EXPECT_EQ(placement.box[3], 500);
  EXPECT_EQ(placement.box[7], 500);
  EXPECT_EQ(placement.box[11], 70);
  // Up in the CRS is up on the globe: the z column is the ellipsoid's normal there.
  const auto ground = apply(placement.transform, {356500, 5699500, 0});
  const auto sky = apply(placement.transform, {356500, 5699500, 1000});
  const double lat = 51.4285 * M_PI / 180, lon = 6.9358 * M_PI / 180;
  const double normal[3] = {std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat)};
  double dot = 0;
  for (int k = 0; k < 3; ++k) dot += (sky[k] - ground[k]) / 1000 * normal[k];
  EXPECT_NEAR(dot, 1, 1e-4);
}

TEST(Tileset, MeshesTooWideForOneTransformAreRefused) {
  VerticalOptions egm96;
  egm96.vertical_crs = "EPSG:5773";
  const Wgs84Transform heights(utm32(), HeightReference::Ellipsoid, egm96);
  // 2 km fits; 8 km would be placed up to 1.3 m off (the sagitta, (4 km)^2 / 2R), and is refused.
  EXPECT_LE(place_on_globe(box_mesh(355500, 5698500, 357500, 5700500, 60, 200), heights).max_error_m,
            kTilesetMaxPlacementError);
  try {
    place_on_globe(box_mesh(353000, 5696000, 361000, 5704000, 60, 200), heights);
    ADD_FAILURE() << "an 8 km mesh was placed";
  } catch (const ArgumentError& e) {
    EXPECT_EQ(e.field(), "tileset") << e.what();
    EXPECT_NE(std::string(e.what()).find("8000 x 8000 m"), std::string::npos) << e.what();
  }
  EXPECT_THROW(place_on_globe(Mesh{}, heights), ArgumentError);
}

TEST(Tileset, JsonIsA3DTiles11TilesetOfOneTile) {
  VerticalOptions egm96;
  egm96.vertical_crs = "EPSG:5773";
  const Mesh mesh = box_mesh(356000, 5699000, 356400, 5699300, 100, 100);  // flat: still a volume
  const TilesetPlacement placement = place_on_globe(mesh, Wgs84Transform(utm32(), HeightReference::Ellipsoid, egm96));
  const auto json = nlohmann::json::parse(tileset_json(placement, "city.glb", mesh.crs));
  EXPECT_EQ(json["asset"]["version"], "1.1");
  EXPECT_EQ(json["asset"]["extras"]["content_epsg"], 25832);
  EXPECT_GT(json["geometricError"].get<double>(), 0);
  const auto& root = json["root"];
  EXPECT_EQ(root["content"]["uri"], "city.glb");
  EXPECT_EQ(root["refine"], "ADD");
  EXPECT_EQ(root["geometricError"], 0);
  ASSERT_EQ(root["transform"].size(), 16u);
  for (int k = 0; k < 16; ++k) EXPECT_EQ(root["transform"][k].get<double>(), placement.transform[k]);  // exactly
  ASSERT_EQ(root["boundingVolume"]["box"].size(), 12u);
  EXPECT_GE(root["boundingVolume"]["box"][11].get<double>(), 1);  // a flat mesh keeps a height
}

// The user's check: the tileset of `dsmplan mesh --3dtiles` opened by CesiumJS (npm, pinned by
// tests/cesium/package-lock.json; scripts/test.sh installs it) in headless Chromium: the height
// CesiumJS samples on the mesh under a vertex's lon/lat is that vertex's height above the
// ellipsoid, as GDAL computes it. A mesh off by the geoid (45 m), turned the wrong way up or
// shifted sideways by a metre (a wall sample then misses by metres) fails.
TEST(OpensWhereUsersOpenIt, CesiumPlacesThe3DTilesetWhereGdalSays) {
  const std::string cesium = DSMPLAN_CESIUM_DIR "/node_modules/cesium";
  if (!std::filesystem::exists(cesium + "/Build/Cesium/Cesium.js")) {
    ADD_FAILURE() << "CesiumJS is not installed in " DSMPLAN_CESIUM_DIR
                     ": scripts/test.sh installs it (npm ci from tests/cesium)";
    return;
  }
  testkit::TempDir dir;
  const std::string dsm = testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif");
  const testkit::CliResult glb =
      testkit::run_cli({"mesh", dsm, "--res", "2", "--zstep", "0", "-o", dir.path("city.glb"), "--3dtiles",
                        "--allow-approximate-vertical", "-q", "--json"});
  ASSERT_EQ(glb.exit_code, 0) << glb.err;
  const auto report = nlohmann::json::parse(glb.out);
  EXPECT_EQ(report["tileset"]["path"], dir.path("tileset.json"));
  EXPECT_LE(report["tileset"]["max_placement_error_m"].get<double>(), 0.02);
  ASSERT_EQ(testkit::run_cli({"mesh", dsm, "--res", "2", "--zstep", "0", "-o", dir.path("city.ply"), "-q"}).exit_code,
            0);
  const Mesh mesh = read_mesh(dir.path("city.ply"));

  // Vertices spread over the mesh, street and roof alike; the expected heights from GDAL.
  const auto gdal = utm32_egm96_to(4979);
  ASSERT_TRUE(gdal);
  nlohmann::json points = nlohmann::json::array();
  std::vector<double> expected;
  for (size_t i = mesh.vertices.size() / 97; i < mesh.vertices.size(); i += mesh.vertices.size() / 48) {
    double x = mesh.vertices[i].x, y = mesh.vertices[i].y, h = mesh.vertices[i].z;
    ASSERT_TRUE(gdal->Transform(1, &x, &y, &h));
    points.push_back({x, y});
    expected.push_back(h);
  }
  const std::string command = "node '" DSMPLAN_TESTS_DIR "/cesium/place.js' chromium '" + cesium + "' '" +
                              dir.dir().string() + "' '" + points.dump() + "' '" + dir.path("profile") + "' 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_TRUE(pipe) << command;
  std::string output;
  char buffer[4096];
  for (size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) output.append(buffer, n);
  ASSERT_EQ(::pclose(pipe), 0) << command << "\n" << output;
  const auto answer = nlohmann::json::parse(output);
  ASSERT_FALSE(answer.contains("error")) << answer.dump();
  ASSERT_EQ(answer["heights"].size(), expected.size()) << answer.dump();
  std::vector<double> misses;
  for (size_t k = 0; k < expected.size(); ++k) {
    ASSERT_FALSE(answer["heights"][k].is_null()) << "CesiumJS found no mesh under " << points[k].dump();
    misses.push_back(std::abs(answer["heights"][k].get<double>() - expected[k]));
  }
  std::sort(misses.begin(), misses.end());
  std::printf("CesiumJS vs GDAL at %zu vertices: median %.4f m, max %.4f m\n", misses.size(), misses[misses.size() / 2],
              misses.back());
  // Measured: a median of 3 mm and a maximum of 7 mm (float32 positions, CesiumJS's depth).
  EXPECT_LE(misses[misses.size() / 2], 0.03) << answer.dump();
  EXPECT_LE(misses.back(), 0.1) << answer.dump();
}

TEST(PathText, CsvReadsBackExactlyAndGeoJsonIsALineString) {
  const std::vector<Point3> path{{356320.125, 5699270.1, 130.3}, {356400, 5699300, 131}, {1.0 / 3, 2.0 / 3, 0.1}};
  std::istringstream csv(path_to_csv(path));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "x,y,z");
  for (const Point3& p : path) {
    ASSERT_TRUE(std::getline(csv, line));
    Point3 q;
    char c1, c2;
    std::istringstream(line) >> q[0] >> c1 >> q[1] >> c2 >> q[2];
    EXPECT_EQ(q, p) << line;  // shortest round-trip decimals
  }
  const auto j = nlohmann::json::parse(path_to_geojson({{6.93329, 51.4264, 177.5}, {6.9, 51.5, 180}}, "{\"a\":1}"));
  EXPECT_EQ(j["type"], "Feature");
  EXPECT_EQ(j["properties"]["a"], 1);
  EXPECT_EQ(j["geometry"]["type"], "LineString");
  ASSERT_EQ(j["geometry"]["coordinates"].size(), 2u);
  EXPECT_NEAR(j["geometry"]["coordinates"][0][0].get<double>(), 6.93329, 1e-12);
  EXPECT_NEAR(j["geometry"]["coordinates"][0][1].get<double>(), 51.4264, 1e-12);
  EXPECT_NEAR(j["geometry"]["coordinates"][0][2].get<double>(), 177.5, 1e-12);
}

// ---- drone missions and KML ---------------------------------------------------------------
//
// Oracles: golden files (tests/data/path.*) checked by hand against the formats' documentation;
// the .plan against a JSON schema written from QGC's "Plan File Format" (tests/data/
// qgc_plan.schema.json) by a small validator of the keywords it uses; the WPL read the way QGC's
// loader reads it (MissionController::_loadTextMissionFile, MissionItem::load(QTextStream&));
// the KML read back by GDAL's KML driver, an independent reader.

namespace {

std::string test_data(const std::string& name) { return std::string(DSMPLAN_TEST_DATA_DIR) + "/" + name; }

// JSON Schema (2020-12) for the keywords qgc_plan.schema.json uses: type, const, required,
// properties, items, prefixItems, minItems, maxItems, minimum, maximum. Appends "where: why" to
// `errors` for each violation.
void validate(const nlohmann::json& v, const nlohmann::json& schema, const std::string& where,
              std::vector<std::string>& errors) {
  const auto fail = [&](const std::string& why) { errors.push_back((where.empty() ? "/" : where) + ": " + why); };
  const auto has_type = [&](const std::string& t) {
    if (t == "object") return v.is_object();
    if (t == "array") return v.is_array();
    if (t == "string") return v.is_string();
    if (t == "boolean") return v.is_boolean();
    if (t == "null") return v.is_null();
    if (t == "number") return v.is_number();
    if (t == "integer")
      return v.is_number_integer() || (v.is_number_float() && std::floor(v.get<double>()) == v.get<double>());
    throw std::runtime_error("schema: unknown type " + t);
  };
  for (const auto& [key, rule] : schema.items()) {
    if (key == "type") {
      const bool ok = rule.is_string()
                          ? has_type(rule.get<std::string>())
                          : std::any_of(rule.begin(), rule.end(), [&](const auto& t) { return has_type(t); });
      if (!ok) return fail("not of type " + rule.dump());
    } else if (key == "const") {
      if (v != rule) fail("is " + v.dump() + ", not " + rule.dump());
    } else if (key == "required") {
      for (const auto& name : rule)
        if (v.is_object() && !v.contains(name.get<std::string>())) fail("misses " + name.dump());
    } else if (key == "properties") {
      for (const auto& [name, sub] : rule.items())
        if (v.is_object() && v.contains(name)) validate(v[name], sub, where + "/" + name, errors);
    } else if (key == "items") {
      const size_t first = schema.contains("prefixItems") ? schema["prefixItems"].size() : 0;
      for (size_t i = first; v.is_array() && i < v.size(); ++i)
        validate(v[i], rule, where + "/" + std::to_string(i), errors);
    } else if (key == "prefixItems") {
      for (size_t i = 0; v.is_array() && i < v.size() && i < rule.size(); ++i)
        validate(v[i], rule[i], where + "/" + std::to_string(i), errors);
    } else if (key == "minItems" || key == "maxItems") {
      if (v.is_array() && (key == "minItems" ? v.size() < rule.get<size_t>() : v.size() > rule.get<size_t>()))
        fail("has " + std::to_string(v.size()) + " items, " + key + " " + rule.dump());
    } else if (key == "minimum" || key == "maximum") {
      if (v.is_number() &&
          (key == "minimum" ? v.get<double>() < rule.get<double>() : v.get<double>() > rule.get<double>()))
        fail(v.dump() + " is outside " + key + " " + rule.dump());
    } else if (key != "$schema" && key != "$comment") {
      throw std::runtime_error("schema: keyword not implemented: " + key);
    }
  }
}

std::vector<std::string> plan_schema_errors(const nlohmann::json& plan) {
  const auto schema = nlohmann::json::parse(testkit::read_file(test_data("qgc_plan.schema.json")));
  std::vector<std::string> errors;
  validate(plan, schema, "", errors);
  return errors;
}

// Muelheim an der Ruhr (the sample's area): lon, lat, height above mean sea level.
const std::vector<Point3> kMission{
    {6.933290123, 51.426401234, 177.5}, {6.9341, 51.4269, 180.25}, {6.935, 51.4271, 179}};

struct WplItem {
  int index, current, frame, command, autocontinue;
  double param[4], latitude, longitude, altitude;
};

// As QGC reads it: the first line split at blanks must be "QGC WPL 110"; each further line split
// at tabs must have 12 fields (else "The mission file is corrupted."), read with toInt/toDouble.
std::vector<WplItem> read_wpl_as_qgc(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "QGC WPL 110");
  std::vector<WplItem> items;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    for (size_t b = 0;;) {
      const size_t e = line.find('\t', b);
      f.push_back(line.substr(b, e == std::string::npos ? std::string::npos : e - b));
      if (e == std::string::npos) break;
      b = e + 1;
    }
    EXPECT_EQ(f.size(), 12u) << line;
    if (f.size() != 12) break;
    WplItem w{};
    w.index = std::stoi(f[0]);
    w.current = std::stoi(f[1]);
    w.frame = std::stoi(f[2]);
    w.command = std::stoi(f[3]);
    for (int k = 0; k < 4; ++k) w.param[k] = std::stod(f[4 + k]);
    w.latitude = std::stod(f[8]);
    w.longitude = std::stod(f[9]);
    w.altitude = std::stod(f[10]);
    w.autocontinue = std::stoi(f[11]);
    items.push_back(w);
  }
  return items;
}

}  // namespace

// A mission over the NRW tile: home on the street, 17.25 m up to the first point, two more.
Mission sample_mission(MissionEnd end) {
  Mission mission;
  mission.home = {6.933290123, 51.426401234, 160.25};
  mission.route = {{6.933290123, 51.426401234, 177.5}, {6.9341, 51.4269, 180.25}, {6.935, 51.4271, 179}};
  mission.end = end;
  if (end == MissionEnd::land) mission.land = {6.935, 51.4271, 158};
  return mission;
}

// What the autopilots check before they fly a mission, written from their sources (not from ours):
// ArduPilot, AP_Mission::starts_with_takeoff_cmd(): from index 1 (0 is home), the first
// navigation command (id <= MAV_CMD_NAV_LAST, 95), skipping NAV_DELAY (93), is NAV_TAKEOFF (22).
bool ardupilot_starts_with_takeoff(const std::vector<WplItem>& items) {
  for (size_t i = 1; i < items.size(); ++i) {
    const int id = items[i].command;
    if (id > 95 || id == 93) continue;
    return id == 22;
  }
  return false;
}
// PX4, FeasibilityChecker::checkTakeoff(): the takeoff is the first item with a position (not
// DO_CHANGE_SPEED 178, DELAY 93, ...), its altitude above home, and (older releases) at least
// 1 m above the altitude acceptance radius (0.8 m).
bool px4_takeoff_feasible(const std::vector<WplItem>& items, double home_amsl) {
  for (size_t i = 1; i < items.size(); ++i) {
    const WplItem& item = items[i];
    if (item.command == 178 || item.command == 93 || item.command == 177) continue;
    if (item.command != 22) return false;
    const double above_home = item.frame == 3 ? item.altitude : item.altitude - home_amsl;
    return above_home - 1.0 >= 0.8;
  }
  return false;
}

TEST(MissionText, PlanMatchesTheGoldenFileAndPassesTheQgcSchema) {
  const Mission mission = sample_mission(MissionEnd::rtl);
  const std::string text = mission_to_qgc_plan(mission);
  EXPECT_EQ(text, testkit::read_file(test_data("path.plan")));
  const auto plan = nlohmann::json::parse(text);
  const auto errors = plan_schema_errors(plan);
  EXPECT_TRUE(errors.empty()) << errors.front();
  EXPECT_EQ(plan["mission"]["globalPlanAltitudeMode"], 1);  // relative to home
  EXPECT_EQ(plan["mission"]["firmwareType"], 0);
  const auto& items = plan["mission"]["items"];
  const std::vector<int> commands{22, 178, 16, 16, 20}, frames{3, 2, 3, 3, 2};
  ASSERT_EQ(items.size(), commands.size());
  for (size_t i = 0; i < items.size(); ++i) {
    EXPECT_EQ(items[i]["command"], commands[i]) << i;
    EXPECT_EQ(items[i]["frame"], frames[i]) << i;
    EXPECT_EQ(items[i]["doJumpId"], i + 1);
    EXPECT_EQ(items[i].contains("Altitude"), frames[i] == 3) << i;  // positions only, as QGC saves them
  }
  // The takeoff at home, to the first point's height above home; the points after it.
  const auto& home = plan["mission"]["plannedHomePosition"];
  EXPECT_NEAR(home[0].get<double>(), mission.home[1], 1e-12);
  EXPECT_NEAR(home[1].get<double>(), mission.home[0], 1e-12);
  EXPECT_NEAR(home[2].get<double>(), mission.home[2], 1e-12);
  for (size_t i : {0, 2, 3}) {
    const Point3& p = mission.route[i == 0 ? 0 : i - 1];
    EXPECT_NEAR(items[i]["params"][4].get<double>(), p[1], 1e-12);  // latitude first
    EXPECT_NEAR(items[i]["params"][5].get<double>(), p[0], 1e-12);
    EXPECT_NEAR(items[i]["params"][6].get<double>(), p[2] - mission.home[2], 1e-9);
    EXPECT_EQ(items[i]["Altitude"], items[i]["params"][6]);
    EXPECT_EQ(items[i]["AltitudeMode"], 1);
    EXPECT_TRUE(items[i]["params"][3].is_null());  // yaw: the vehicle's own
  }
  EXPECT_EQ(items[1]["params"][1], 5);  // m/s

  // The validator does validate: broken plans are caught.
  auto broken = plan;
  broken["fileType"] = "Mission";
  EXPECT_FALSE(plan_schema_errors(broken).empty());
  broken = plan;
  broken["mission"]["items"][2]["params"].erase(6);
  EXPECT_FALSE(plan_schema_errors(broken).empty());
  broken = plan;
  broken["mission"]["items"][0]["params"][4] = 356320.5;  // an easting where the latitude goes
  EXPECT_FALSE(plan_schema_errors(broken).empty());
  broken = plan;
  broken["mission"].erase("plannedHomePosition");
  EXPECT_FALSE(plan_schema_errors(broken).empty());
}

// Issue 52: keep-out areas are the .plan's geofence as QGC saves its own polygons: exclusion
// (inclusion false), version 1, [latitude, longitude] corners, open and clockwise by QGC's own
// test (QGCMapPolygon::verifyClockwiseWinding: the sum of (lon2 - lon1) (lat2 + lat1) over the
// edges positive), whatever the winding and closure given; the schema holds; a ring of two
// corners is refused.
TEST(MissionText, PlanCarriesKeepOutAreasAsQgcFencePolygons) {
  Mission mission = sample_mission(MissionEnd::rtl);
  const std::vector<std::array<double, 2>> anticlockwise_closed{
      {6.9330, 51.4260}, {6.9340, 51.4260}, {6.9340, 51.4266}, {6.9330, 51.4266}, {6.9330, 51.4260}};
  const std::vector<std::array<double, 2>> clockwise_open{{6.9350, 51.4280}, {6.9360, 51.4275}, {6.9350, 51.4270}};
  mission.keep_out = {anticlockwise_closed, clockwise_open};
  const auto plan = nlohmann::json::parse(mission_to_qgc_plan(mission));
  const auto errors = plan_schema_errors(plan);
  EXPECT_TRUE(errors.empty()) << errors.front();
  const auto& polygons = plan["geoFence"]["polygons"];
  ASSERT_EQ(polygons.size(), 2u);
  for (size_t z = 0; z < polygons.size(); ++z) {
    const auto& fence = polygons[z];
    EXPECT_EQ(fence["inclusion"], false);
    EXPECT_EQ(fence["version"], 1);
    const auto& corners = fence["polygon"];
    const auto& given = mission.keep_out[z];
    const size_t open = given.front() == given.back() ? given.size() - 1 : given.size();
    ASSERT_EQ(corners.size(), open) << "closed, or a corner lost";
    double turn = 0;
    for (size_t k = 0; k < corners.size(); ++k) {
      const auto &a = corners[k], &b = corners[(k + 1) % corners.size()];
      turn += (b[1].get<double>() - a[1].get<double>()) * (b[0].get<double>() + a[0].get<double>());
    }
    EXPECT_GT(turn, 0) << "not clockwise as QGC keeps it: polygon " << z;
    for (const auto& corner : given) {  // every corner given is there, latitude first
      const bool found = std::any_of(corners.begin(), corners.end(), [&](const auto& c) {
        return std::abs(c[0].template get<double>() - corner[1]) < 1e-9 &&
               std::abs(c[1].template get<double>() - corner[0]) < 1e-9;
      });
      EXPECT_TRUE(found) << corner[0] << ", " << corner[1];
    }
  }
  EXPECT_TRUE(plan["geoFence"]["circles"].empty());
  auto broken = plan;
  broken["geoFence"]["polygons"][0].erase("inclusion");
  EXPECT_FALSE(plan_schema_errors(broken).empty());
  mission.keep_out = {{{6.93, 51.42}, {6.94, 51.42}}};
  EXPECT_THROW(mission_to_qgc_plan(mission), ArgumentError);
}

TEST(MissionText, WplMatchesTheGoldenFileAndReadsAsQgcReadsIt) {
  const Mission mission = sample_mission(MissionEnd::rtl);
  const std::string text = mission_to_qgc_wpl(mission);
  EXPECT_EQ(text, testkit::read_file(test_data("path.waypoints")));
  const auto items = read_wpl_as_qgc(text);
  const std::vector<int> commands{16, 22, 178, 16, 16, 20};
  ASSERT_EQ(items.size(), commands.size());  // home first
  for (size_t i = 0; i < items.size(); ++i) {
    EXPECT_EQ(items[i].index, int(i));
    EXPECT_EQ(items[i].current, i == 0 ? 1 : 0);
    EXPECT_EQ(items[i].command, commands[i]);
    EXPECT_EQ(items[i].autocontinue, 1);
    EXPECT_LE(std::abs(items[i].latitude), 90);
  }
  // Home: absolute, as ArduPilot keeps item 0.
  EXPECT_EQ(items[0].frame, 0);
  EXPECT_NEAR(items[0].latitude, mission.home[1], 5e-10);
  EXPECT_NEAR(items[0].longitude, mission.home[0], 5e-10);
  EXPECT_NEAR(items[0].altitude, mission.home[2], 5e-4);
  for (size_t i : {1, 3, 4}) {
    const Point3& p = mission.route[i == 1 ? 0 : i - 2];
    EXPECT_EQ(items[i].frame, 3);
    EXPECT_NEAR(items[i].latitude, i == 1 ? mission.home[1] : p[1], 5e-10);
    EXPECT_NEAR(items[i].longitude, i == 1 ? mission.home[0] : p[0], 5e-10);
    EXPECT_NEAR(items[i].altitude, p[2] - mission.home[2], 5e-4);
  }
}

TEST(MissionText, EveryFirmwareFrameAndEndIsWhatArduPilotAndPx4Fly) {
  for (const MissionEnd end : {MissionEnd::rtl, MissionEnd::land, MissionEnd::none})
    for (const AltitudeFrame frame : {AltitudeFrame::relative, AltitudeFrame::amsl})
      for (const Firmware firmware : {Firmware::generic, Firmware::px4, Firmware::ardupilot}) {
        const Mission mission = sample_mission(end);
        MissionOptions options;
        options.altitude_frame = frame;
        options.firmware = firmware;
        options.speed = 3.5;
        options.hover_speed = 2;
        const auto items = read_wpl_as_qgc(mission_to_qgc_wpl(mission, options));
        EXPECT_TRUE(ardupilot_starts_with_takeoff(items));
        EXPECT_TRUE(px4_takeoff_feasible(items, mission.home[2]));
        const double base = frame == AltitudeFrame::relative ? mission.home[2] : 0;
        for (size_t i = 1; i < items.size(); ++i)
          if (items[i].command == 16 || items[i].command == 22)
            EXPECT_EQ(items[i].frame, frame == AltitudeFrame::relative ? 3 : 0);
        EXPECT_NEAR(items[1].altitude + base, mission.route[0][2], 5e-4);  // the takeoff's top
        EXPECT_EQ(items[2].param[1], 3.5);
        const WplItem& last = items.back();
        if (end == MissionEnd::rtl) EXPECT_EQ(last.command, 20);
        if (end == MissionEnd::none) EXPECT_EQ(last.command, 16);
        if (end == MissionEnd::land) {
          EXPECT_EQ(last.command, 21);
          EXPECT_NEAR(last.latitude, mission.land[1], 5e-10);
          EXPECT_NEAR(last.altitude + base, mission.land[2], 5e-4);
        }
        const auto plan = nlohmann::json::parse(mission_to_qgc_plan(mission, options));
        EXPECT_TRUE(plan_schema_errors(plan).empty());
        EXPECT_EQ(plan["mission"]["firmwareType"], firmware == Firmware::px4         ? 12
                                                   : firmware == Firmware::ardupilot ? 3
                                                                                     : 0);
        EXPECT_EQ(plan["mission"]["globalPlanAltitudeMode"], frame == AltitudeFrame::relative ? 1 : 2);
        EXPECT_EQ(plan["mission"]["cruiseSpeed"], 3.5);
        EXPECT_EQ(plan["mission"]["hoverSpeed"], 2);
      }
  // The oracles refuse what the autopilots refuse: waypoints before any takeoff, a takeoff below home.
  auto items = read_wpl_as_qgc(mission_to_qgc_wpl(sample_mission(MissionEnd::rtl)));
  std::swap(items[1], items[3]);
  EXPECT_FALSE(ardupilot_starts_with_takeoff(items));
  EXPECT_FALSE(px4_takeoff_feasible(items, 160.25));
  items = read_wpl_as_qgc(mission_to_qgc_wpl(sample_mission(MissionEnd::rtl)));
  items[1].altitude = 1.5;
  EXPECT_FALSE(px4_takeoff_feasible(items, 160.25));
}

TEST(MissionText, KmlMatchesTheGoldenFileAndGdalReadsLonLatAbsoluteAltitudes) {
  const std::vector<Point3> marks{kMission.front(), kMission.back()};
  MissionOptions options;
  options.name = "path <A&B>";
  options.description = "heights above mean sea level";
  const std::string text = path_to_kml(kMission, marks, options);
  EXPECT_EQ(text, testkit::read_file(test_data("path.kml")));
  EXPECT_NE(text.find("<name>path &lt;A&amp;B&gt;</name>"), std::string::npos);
  // Every geometry says absolute, else a viewer clamps it to the ground.
  for (const std::string tag : {"LineString", "Point"}) {
    size_t count = 0;
    for (size_t b = text.find("<" + tag + ">"); b != std::string::npos; b = text.find("<" + tag + ">", b + 1)) {
      const size_t e = text.find("</" + tag + ">", b);
      ASSERT_NE(e, std::string::npos);
      EXPECT_NE(text.substr(b, e - b).find("<altitudeMode>absolute</altitudeMode>"), std::string::npos) << tag;
      ++count;
    }
    EXPECT_EQ(count, tag == "Point" ? marks.size() : 1u);
  }

  testkit::TempDir dir;
  const std::string path = dir.path("path.kml");
  write_text_file(path, text);
  GDALAllRegister();
  GDALDatasetH ds = GDALOpenEx(path.c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr);
  ASSERT_TRUE(ds) << "GDAL cannot read the KML";
  std::vector<std::vector<Point3>> lines, points;
  for (int l = 0; l < GDALDatasetGetLayerCount(ds); ++l) {
    OGRLayerH layer = GDALDatasetGetLayer(ds, l);
    OGR_L_ResetReading(layer);
    while (OGRFeatureH feature = OGR_L_GetNextFeature(layer)) {
      OGRGeometryH g = OGR_F_GetGeometryRef(feature);
      if (g) {
        std::vector<Point3> xyz;
        for (int k = 0; k < OGR_G_GetPointCount(g); ++k)
          xyz.push_back({OGR_G_GetX(g, k), OGR_G_GetY(g, k), OGR_G_GetZ(g, k)});
        (wkbFlatten(OGR_G_GetGeometryType(g)) == wkbLineString ? lines : points).push_back(xyz);
      }
      OGR_F_Destroy(feature);
    }
  }
  GDALClose(ds);
  ASSERT_EQ(lines.size(), 1u);
  ASSERT_EQ(lines[0].size(), kMission.size());
  for (size_t i = 0; i < kMission.size(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(lines[0][i][k], kMission[i][k], 1e-9) << i << " " << k;  // x = longitude
  ASSERT_EQ(points.size(), marks.size());
  for (size_t i = 0; i < marks.size(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(points[i][0][k], marks[i][k], 1e-9);
}

TEST(MissionText, KmlStylesAndExtrusionAreWhatLibkmlReads) {
  MissionOptions options;
  options.extrude = true;
  testkit::TempDir dir;
  const std::string path = dir.path("styled.kml");
  const std::vector<Point3> line{{6.933290123, 51.426401234, 177.5}, {6.9341, 51.4269, 180.25}};
  write_text_file(path, path_to_kml(line, line, options));
  GDALAllRegister();
  const char* libkml[] = {"LIBKML", nullptr};  // libkml's own parser, not ours
  GDALDatasetH ds = GDALOpenEx(path.c_str(), GDAL_OF_VECTOR, libkml, nullptr, nullptr);
  ASSERT_TRUE(ds) << "libkml cannot read the KML";
  std::map<std::string, std::string> styles;
  if (OGRStyleTableH table = GDALDatasetGetStyleTable(ds)) {
    OGR_STBL_ResetStyleStringReading(table);
    while (const char* style = OGR_STBL_GetNextStyle(table)) styles[OGR_STBL_GetLastStyleName(table)] = style;
  }
  EXPECT_NE(styles["path"].find("PEN(c:#FF00FF"), std::string::npos) << styles["path"];  // magenta
  EXPECT_NE(styles["path"].find("w:4"), std::string::npos) << styles["path"];
  EXPECT_NE(styles["waypoint"].find("#00FFFF"), std::string::npos) << styles["waypoint"];  // cyan
  size_t features = 0;
  for (int l = 0; l < GDALDatasetGetLayerCount(ds); ++l) {
    OGRLayerH layer = GDALDatasetGetLayer(ds, l);
    while (OGRFeatureH feature = OGR_L_GetNextFeature(layer)) {
      const std::string name = OGR_F_GetFieldAsString(feature, OGR_F_GetFieldIndex(feature, "Name"));
      EXPECT_EQ(OGR_F_GetFieldAsInteger(feature, OGR_F_GetFieldIndex(feature, "extrude")), 1) << name;
      EXPECT_EQ(std::string(OGR_F_GetStyleString(feature)), name == "path" ? "@path" : "@waypoint");
      if (name != "path") EXPECT_EQ(name.rfind("waypoint ", 0), 0u) << name;
      ++features;
      OGR_F_Destroy(feature);
    }
  }
  GDALClose(ds);
  EXPECT_EQ(features, 3u);
  // Without --extrude, no wall.
  EXPECT_EQ(path_to_kml(line).find("<extrude>"), std::string::npos);
}

// Missions no autopilot can fly, with their options: every mission writer refuses each.
std::vector<std::pair<Mission, MissionOptions>> unflyable_missions() {
  std::vector<std::pair<Mission, MissionOptions>> cases;
  const auto with = [&](MissionEnd end, const std::function<void(Mission&, MissionOptions&)>& spoil) {
    Mission m = sample_mission(end);
    MissionOptions options;
    spoil(m, options);
    cases.emplace_back(m, options);
  };
  with(MissionEnd::rtl, [](Mission& m, MissionOptions&) { m.route.clear(); });
  with(MissionEnd::rtl, [](Mission& m, MissionOptions&) { m.route[1] = {356320, 5699270, 130}; });  // UTM, not degrees
  with(MissionEnd::rtl, [](Mission& m, MissionOptions&) { m.route[2][2] = NAN; });
  with(MissionEnd::rtl, [](Mission& m, MissionOptions&) { m.home[1] = INFINITY; });
  with(MissionEnd::rtl,
       [](Mission& m, MissionOptions&) { m.route[0][0] += 1e-5; });  // the takeoff's top not above home
  with(MissionEnd::rtl, [](Mission& m, MissionOptions&) { m.route[0][2] = m.home[2] + 1.9; });  // too low a takeoff
  with(MissionEnd::land, [](Mission& m, MissionOptions&) { m.land = {NAN, NAN, NAN}; });
  for (const double speed : {0.0, -1.0, 101.0, double(NAN)}) {
    with(MissionEnd::rtl, [speed](Mission&, MissionOptions& o) { o.speed = speed; });
    with(MissionEnd::rtl, [speed](Mission&, MissionOptions& o) { o.hover_speed = speed; });
  }
  return cases;
}

TEST(MissionText, RefusesWhatCannotFly) {
  for (const auto& [mission, options] : unflyable_missions()) {
    EXPECT_THROW(mission_to_qgc_plan(mission, options), ArgumentError);
    EXPECT_THROW(mission_to_qgc_wpl(mission, options), ArgumentError);
  }
  EXPECT_THROW(path_to_kml({}), ArgumentError);
}

TEST(MissionText, MeanSeaLevelRoundTripThroughTheWplTextLandsWithinAMillimetre) {
  VerticalOptions egm96;
  egm96.vertical_crs = "EPSG:5773";  // the data in EGM96 heights: exact, and the identity in height
  const Wgs84Transform t(utm32(), HeightReference::MeanSeaLevel, egm96);
  EXPECT_FALSE(t.approximate_heights()) << t.description();
  OGRSpatialReference utm, wgs;
  utm.importFromEPSG(25832);
  wgs.importFromEPSG(4326);
  wgs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> gdal(OGRCreateCoordinateTransformation(&utm, &wgs));
  ASSERT_TRUE(gdal);
  const std::vector<Point3> path{{356320, 5699270, 130}, {357000, 5700000, 90.125}, {356800.25, 5699745.5, 160.001}};
  std::vector<Point3> lonlatamsl;
  for (const Point3& p : path) {
    lonlatamsl.push_back(t.to_wgs84(p));
    double x = p[0], y = p[1];
    ASSERT_TRUE(gdal->Transform(1, &x, &y));
    EXPECT_NEAR(lonlatamsl.back()[0], x, 1e-9);
    EXPECT_NEAR(lonlatamsl.back()[1], y, 1e-9);
    EXPECT_NEAR(lonlatamsl.back()[2], p[2], 1e-6);  // EGM96 to EGM96
    const Point3 back = t.from_wgs84(lonlatamsl.back());
    EXPECT_LT(std::hypot(back[0] - p[0], back[1] - p[1], back[2] - p[2]), 1e-3);
  }
  Mission mission;
  mission.home = {lonlatamsl[0][0], lonlatamsl[0][1], lonlatamsl[0][2] - 20};
  mission.route = lonlatamsl;
  mission.end = MissionEnd::none;
  MissionOptions amsl;
  amsl.altitude_frame = AltitudeFrame::amsl;
  const auto items = read_wpl_as_qgc(mission_to_qgc_wpl(mission, amsl));
  ASSERT_EQ(items.size(), path.size() + 2);  // home, takeoff, speed, the points after the first
  for (size_t i = 0; i < path.size(); ++i) {
    const WplItem& item = items[i == 0 ? 1 : i + 2];  // the takeoff climbs to the first point
    const Point3 back = t.from_wgs84({item.longitude, item.latitude, item.altitude});
    EXPECT_LT(std::hypot(back[0] - path[i][0], back[1] - path[i][1], back[2] - path[i][2]), 1e-3) << i;
  }
}

TEST(MissionText, StraightRunsAreDroppedWithinTheTolerance) {
  // An L with points every metre, a 4 mm wobble on the first leg, and a 5 cm bump on the second.
  std::vector<Point3> path;
  for (int i = 0; i <= 20; ++i) path.push_back({double(i), (i % 2) * 0.004, 100});
  for (int i = 1; i <= 20; ++i) path.push_back({20, double(i), 100 + (i == 10 ? 0.05 : 0)});
  const auto kept = drop_straight_points(path, 0.01);
  EXPECT_EQ(kept.front(), path.front());
  EXPECT_EQ(kept.back(), path.back());
  EXPECT_LE(kept.size(), 6u);
  EXPECT_NE(std::find(kept.begin(), kept.end(), Point3{20, 10, 100.05}), kept.end());  // the bump is a turn
  // Every dropped point lies within 1 cm of the kept polyline.
  for (const Point3& p : path) {
    double best = INFINITY;
    for (size_t k = 1; k < kept.size(); ++k) {
      const Point3 &a = kept[k - 1], &b = kept[k];
      const double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ap[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
      const double t = std::clamp(
          (ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]) / (ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2]), 0.0, 1.0);
      best = std::min(best, std::hypot(ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]));
    }
    EXPECT_LE(best, 0.01 + 1e-12);
  }
  EXPECT_EQ(drop_straight_points({{0, 0, 0}, {1, 0, 0}}, 0.01).size(), 2u);
}

// ---- GLB (glTF 2.0) --------------------------------------------------------------------------
//
// Read back by parsing the container here (glTF 2.0 section 4.4: 12-byte header "glTF", version
// 2, length; a JSON chunk; a BIN chunk), independently of the tinygltf that wrote it, and
// checked by the Khronos glTF validator (npm package gltf-validator, which scripts/test.sh
// installs into build/npm from tests/gltf_validator/package-lock.json).

namespace {

struct Glb {
  nlohmann::json json;
  std::string bin;
};

uint32_t le32(const std::string& bytes, size_t at) {
  uint32_t v = 0;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

Glb parse_glb(const std::string& path) {
  const std::string bytes = testkit::read_file(path);
  Glb glb;
  EXPECT_GE(bytes.size(), 20u);
  if (bytes.size() < 20) return glb;
  EXPECT_EQ(bytes.substr(0, 4), "glTF");
  EXPECT_EQ(le32(bytes, 4), 2u);
  EXPECT_EQ(le32(bytes, 8), bytes.size());
  const uint32_t json_length = le32(bytes, 12);
  EXPECT_EQ(le32(bytes, 16), 0x4E4F534Au);  // "JSON"
  EXPECT_EQ(json_length % 4, 0u);
  glb.json = nlohmann::json::parse(bytes.substr(20, json_length));
  const size_t bin_at = 20 + size_t(json_length);
  if (bin_at < bytes.size()) {
    const uint32_t bin_length = le32(bytes, bin_at);
    EXPECT_EQ(le32(bytes, bin_at + 4), 0x004E4942u);  // "BIN\0"
    EXPECT_EQ(bin_at + 8 + bin_length, bytes.size());
    glb.bin = bytes.substr(bin_at + 8, bin_length);
  }
  return glb;
}

// The positions, translation and indices of a GLB written by write_mesh, as a Mesh in the CRS
// (translation + position, in double), so it can be compared with what was written.
struct GlbMesh {
  std::vector<std::array<float, 3>> local;
  std::array<double, 3> translation{};
  std::vector<Triangle> triangles;
};

GlbMesh glb_mesh(const Glb& glb) {
  GlbMesh out;
  const auto& j = glb.json;
  const auto& child = j["nodes"][1];
  for (int k = 0; k < 3; ++k) out.translation[k] = child["translation"][k].get<double>();
  if (!child.contains("mesh")) return out;
  const auto& primitive = j["meshes"][child["mesh"].get<int>()]["primitives"][0];
  const auto& positions = j["accessors"][primitive["attributes"]["POSITION"].get<int>()];
  const auto& indices = j["accessors"][primitive["indices"].get<int>()];
  EXPECT_EQ(positions["componentType"], 5126);  // float
  EXPECT_EQ(positions["type"], "VEC3");
  const auto& pview = j["bufferViews"][positions["bufferView"].get<int>()];
  const size_t pat = pview.value("byteOffset", 0) + positions.value("byteOffset", 0);
  out.local.resize(positions["count"].get<size_t>());
  std::memcpy(out.local.data(), glb.bin.data() + pat, out.local.size() * 12);
  const auto& iview = j["bufferViews"][indices["bufferView"].get<int>()];
  const size_t iat = iview.value("byteOffset", 0) + indices.value("byteOffset", 0);
  const size_t count = indices["count"].get<size_t>();
  EXPECT_EQ(count % 3, 0u);
  const int type = indices["componentType"].get<int>();
  EXPECT_TRUE(type == 5123 || type == 5125) << type;  // uint16 or uint32
  out.triangles.resize(count / 3);
  for (size_t i = 0; i < count; ++i) {
    uint32_t v = 0;
    if (type == 5123) {
      uint16_t s;
      std::memcpy(&s, glb.bin.data() + iat + 2 * i, 2);
      v = s;
    } else {
      std::memcpy(&v, glb.bin.data() + iat + 4 * i, 4);
    }
    out.triangles[i / 3][i % 3] = v;
  }
  return out;
}

// The Khronos validator's reports (a JSON array, one per file) for `files`.
nlohmann::json validate_gltf(const std::vector<std::string>& files) {
  const std::string modules = DSMPLAN_NPM_DIR "/node_modules";
  if (!std::filesystem::exists(modules + "/gltf-validator")) {
    ADD_FAILURE() << "the glTF validator is not installed in " DSMPLAN_NPM_DIR
                     ": scripts/test.sh installs it (npm ci from tests/gltf_validator)";
    return nlohmann::json::array();
  }
  std::string command = "NODE_PATH='" + modules + "' node '" DSMPLAN_GLTF_VALIDATOR "'";
  for (const auto& file : files) command += " '" + file + "'";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) {
    ADD_FAILURE() << "cannot run " << command;
    return nlohmann::json::array();
  }
  std::string output;
  char buffer[4096];
  for (size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) output.append(buffer, n);
  const int status = ::pclose(pipe);
  EXPECT_EQ(status, 0) << command << "\n" << output;
  try {
    return nlohmann::json::parse(output);
  } catch (const std::exception& e) {
    ADD_FAILURE() << command << ": " << e.what() << "\n" << output;
    return nlohmann::json::array();
  }
}

void expect_valid(const nlohmann::json& report) {
  const auto& issues = report["issues"];
  EXPECT_EQ(issues["numErrors"], 0) << report.dump(1);
  EXPECT_EQ(issues["numWarnings"], 0) << report.dump(1);
}

}  // namespace

TEST(GlbWriter, RealMeshReadsBackWithinFloat32AndCarriesTheCrs) {
  const Mesh mesh = triangulate_xy3(testkit::nrw_crop());
  ASSERT_GT(mesh.vertices.size(), 65535u);  // uint32 indices
  testkit::TempDir dir;
  const std::string path = dir.path("crop.glb");
  EXPECT_EQ(mesh_format_for(path), MeshFormat::Glb);
  EXPECT_EQ(write_mesh(mesh, path, MeshFormat::Glb), 0u);
  const Glb glb = parse_glb(path);
  const GlbMesh back = glb_mesh(glb);
  ASSERT_EQ(back.local.size(), mesh.vertices.size());
  ASSERT_EQ(back.triangles.size(), mesh.triangles.size());
  EXPECT_TRUE(back.triangles == mesh.triangles);

  // The origin: the bounding box's centre rounded to whole units, recorded twice.
  const auto& asset = glb.json["asset"];
  EXPECT_EQ(asset["version"], "2.0");
  EXPECT_EQ(asset["generator"], "dsmplan " DSMPLAN_VERSION);
  const auto& extras = asset["extras"];
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(back.translation[k], std::round(back.translation[k]));
    EXPECT_EQ(extras["origin"][k].get<double>(), back.translation[k]);
  }
  double max_local = 0;
  for (const auto& p : back.local)
    for (float c : p) max_local = std::max(max_local, double(std::abs(c)));
  EXPECT_LE(max_local, 260.0);  // 500 m x 500 m around the centre
  const double bound = std::ldexp(1.0, -24) * max_local * 2;
  double worst = 0;
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vertex& v = mesh.vertices[i];
    const double c[3] = {v.x, v.y, v.z};
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(back.translation[k] + back.local[i][k] - c[k]));
  }
  EXPECT_LE(worst, bound);

  // The accessor's min and max are those of the stored floats (the spec requires them).
  const auto& positions = glb.json["accessors"][0];
  for (int k = 0; k < 3; ++k) {
    float lo = INFINITY, hi = -INFINITY;
    for (const auto& p : back.local) lo = std::min(lo, p[k]), hi = std::max(hi, p[k]);
    EXPECT_EQ(positions["min"][k].get<double>(), lo);
    EXPECT_EQ(positions["max"][k].get<double>(), hi);
  }

  // The root node turns z-up into glTF's y-up; the CRS and vertical reference are in extras.
  const auto& root = glb.json["nodes"][0];
  EXPECT_EQ(glb.json["scenes"][0]["nodes"], nlohmann::json::array({0}));
  EXPECT_EQ(root["children"], nlohmann::json::array({1}));
  EXPECT_NEAR(root["rotation"][0].get<double>(), -std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(root["rotation"][3].get<double>(), std::sqrt(0.5), 1e-15);
  EXPECT_EQ(extras["crs"]["epsg"], 25832);
  EXPECT_EQ(extras["crs"]["name"], mesh.crs.name);
  EXPECT_EQ(extras["crs"]["wkt"], mesh.crs.wkt);
  EXPECT_NE(extras["axes"].get<std::string>().find("z up"), std::string::npos);
  EXPECT_EQ(extras.contains("vertical"), !mesh.crs.vertical_name.empty() || !mesh.crs.vertical_unit.empty());
}

TEST(GlbWriter, SmallMeshesUseUint16AndTheCrsVerticalIsRecorded) {
  Mesh mesh;
  mesh.vertices = {{356000, 5699000, 100}, {356001, 5699000, 100}, {356000, 5699001, 101.5}};
  mesh.triangles = {{0, 1, 2}};
  mesh.crs.name = "ETRS89 / UTM zone 32N + DHHN2016 height";
  mesh.crs.vertical_name = "DHHN2016 height";
  mesh.crs.vertical_unit = "metre";
  testkit::TempDir dir;
  const std::string path = dir.path("small.dat");  // the format is the argument's, not the name's
  EXPECT_EQ(write_mesh(mesh, path, MeshFormat::Glb), 0u);
  const Glb glb = parse_glb(path);
  EXPECT_EQ(glb.json["accessors"][1]["componentType"], 5123);
  EXPECT_EQ(glb.json["asset"]["extras"]["vertical"]["name"], "DHHN2016 height");
  EXPECT_EQ(glb.json["asset"]["extras"]["vertical"]["unit"], "metre");
  EXPECT_FALSE(glb.json["asset"]["extras"]["crs"].contains("epsg"));  // not known: left out
  const GlbMesh back = glb_mesh(glb);
  EXPECT_TRUE(back.triangles == mesh.triangles);
  EXPECT_THROW(read_mesh(path), InputError);  // written, not read
}

TEST(GlbWriter, TrianglesWithoutAreaInFloat32AreLeftOutAndCounted) {
  // Far from the origin, 1e-9 apart is the same float: the triangle 0-3-2 has no area in the
  // file, though it has in double.
  Mesh mesh;
  mesh.vertices = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {1e-9, 0, 0}, {2, 2, 0}};
  mesh.triangles = {{0, 1, 2}, {3, 1, 2}, {0, 3, 2}, {1, 4, 2}};
  testkit::TempDir dir;
  EXPECT_EQ(write_mesh(mesh, dir.path("d.glb"), MeshFormat::Glb), 1u);
  const GlbMesh back = glb_mesh(parse_glb(dir.path("d.glb")));
  EXPECT_EQ(back.triangles, (std::vector<Triangle>{{0, 1, 2}, {3, 1, 2}, {1, 4, 2}}));

  // Nothing left: the nodes alone.
  Mesh flat;
  flat.vertices = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
  flat.triangles = {{0, 1, 2}};
  EXPECT_EQ(write_mesh(flat, dir.path("none.glb"), MeshFormat::Glb), 1u);
  EXPECT_EQ(write_mesh(Mesh(), dir.path("empty.glb"), MeshFormat::Glb), 0u);
  const Glb none = parse_glb(dir.path("none.glb"));
  EXPECT_FALSE(none.json["nodes"][1].contains("mesh"));
  EXPECT_FALSE(none.json.contains("buffers"));
  const auto reports = validate_gltf({dir.path("none.glb"), dir.path("empty.glb")});
  ASSERT_EQ(reports.size(), 2u);
  for (const auto& report : reports) expect_valid(report);

  EXPECT_THROW(write_mesh(mesh, dir.path("missing/m.glb"), MeshFormat::Glb), OutputError);
}

TEST(GlbWriter, FormatNames) {
  for (MeshFormat f : {MeshFormat::Ply, MeshFormat::Obj, MeshFormat::Off, MeshFormat::Glb}) {
    EXPECT_EQ(parse_mesh_format(to_string(f)), f);
    EXPECT_EQ(mesh_format_for(std::string("a.") + to_string(f)), f);
  }
  EXPECT_EQ(parse_mesh_format("GLB"), MeshFormat::Glb);
  EXPECT_EQ(mesh_format_for("A.GLB"), MeshFormat::Glb);
  try {
    parse_mesh_format("bogus");
    ADD_FAILURE() << "parsed";
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("--of"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("glb"), std::string::npos) << e.what();
  }
}

// The real sample, full resolution and simplified: the Khronos validator finds nothing, with
// degenerate triangles raised to errors. A copy with one triangle made degenerate shows that
// the raised check is live.
TEST(GlbValidator, RealMeshesHaveNoErrorsOrWarnings) {
  const Grid& dsm = testkit::nrw_crop();
  const Mesh full = triangulate_xy3(dsm);
  BoundedSimplifyOptions options;
  options.max_error = 0.4;
  options.conservative = true;
  const Mesh simplified = simplify_bounded(dsm, options);
  ASSERT_LT(simplified.vertices.size(), full.vertices.size());
  testkit::TempDir dir;
  EXPECT_EQ(write_mesh(full, dir.path("full.glb"), MeshFormat::Glb), 0u);
  EXPECT_EQ(write_mesh(simplified, dir.path("bounded.glb"), MeshFormat::Glb), 0u);

  // One degenerate triangle: the first triangle's second index made its first.
  std::string bytes = testkit::read_file(dir.path("bounded.glb"));
  const Glb glb = parse_glb(dir.path("bounded.glb"));
  const auto& iview = glb.json["bufferViews"][glb.json["accessors"][1]["bufferView"].get<int>()];
  const size_t bin_at = 20 + le32(bytes, 12) + 8;
  const size_t first = bin_at + iview.value("byteOffset", 0);
  const size_t width = glb.json["accessors"][1]["componentType"] == 5123 ? 2 : 4;
  std::memcpy(bytes.data() + first + width, bytes.data() + first, width);
  testkit::write_file(dir.path("broken.glb"), bytes);

  const auto reports = validate_gltf({dir.path("full.glb"), dir.path("bounded.glb"), dir.path("broken.glb")});
  ASSERT_EQ(reports.size(), 3u);
  for (int i = 0; i < 2; ++i) {
    expect_valid(reports[i]);
    EXPECT_EQ(reports[i]["issues"]["numInfos"], 0) << reports[i].dump(1);
  }
  EXPECT_EQ(reports[0]["info"]["totalTriangleCount"], full.triangles.size());
  EXPECT_EQ(reports[1]["info"]["totalTriangleCount"], simplified.triangles.size());
  const auto& broken = reports[2]["issues"];
  EXPECT_GE(broken["numErrors"].get<int>(), 1);
  bool flagged = false;
  for (const auto& message : broken["messages"]) flagged |= message["code"] == "ACCESSOR_INDEX_TRIANGLE_DEGENERATE";
  EXPECT_TRUE(flagged) << broken.dump(1);
}

// ---- DJI WPML (.kmz) ------------------------------------------------------------------------
// The archive is opened with GDAL's /vsizip/ (its own ZIP reader), the two documents parsed
// with GDAL's CPLParseXMLString, and every number compared with the Mission it came from; the
// ellipsoidal heights of WPML's WGS84 mode with GDAL's own EGM96 to WGS 84 transformation.
#include <cpl_minixml.h>
#include <cpl_string.h>
#include <cpl_vsi.h>

namespace {

struct XmlDeleter {
  void operator()(CPLXMLNode* node) const { CPLDestroyXMLNode(node); }
};
using XmlTree = std::unique_ptr<CPLXMLNode, XmlDeleter>;

std::vector<std::string> vsi_dir(const std::string& path) {
  char** list = VSIReadDir(path.c_str());
  std::vector<std::string> names;
  for (int i = 0; list && list[i]; ++i) names.push_back(list[i]);
  CSLDestroy(list);
  std::sort(names.begin(), names.end());
  return names;
}

std::string vsi_read(const std::string& path) {
  VSILFILE* file = VSIFOpenL(path.c_str(), "rb");
  if (!file) return {};
  std::string bytes;
  char buffer[4096];
  for (size_t n; (n = VSIFReadL(buffer, 1, sizeof buffer, file)) > 0;) bytes.append(buffer, n);
  VSIFCloseL(file);
  return bytes;
}

std::vector<const CPLXMLNode*> xml_children(const CPLXMLNode* parent, const std::string& name) {
  std::vector<const CPLXMLNode*> found;
  for (const CPLXMLNode* c = parent ? parent->psChild : nullptr; c; c = c->psNext)
    if (c->eType == CXT_Element && name == c->pszValue) found.push_back(c);
  return found;
}

std::string xml_text(const CPLXMLNode* node, const char* path) {
  const char* value = CPLGetXMLValue(node, path, nullptr);
  return value ? value : "<missing " + std::string(path) + ">";
}

double xml_number(const CPLXMLNode* node, const char* path) {
  const char* value = CPLGetXMLValue(node, path, nullptr);
  EXPECT_TRUE(value) << path;
  return value ? std::stod(value) : NAN;
}

// GDAL's (PROJ's through OGR) EGM96 height to WGS 84 ellipsoidal height.
double gdal_ellipsoidal(const Point3& lonlatamsl) {
  static const std::unique_ptr<OGRCoordinateTransformation> t = [] {
    OGRSpatialReference egm96, ellipsoid;
    EXPECT_EQ(egm96.SetFromUserInput("EPSG:4326+5773"), OGRERR_NONE);
    EXPECT_EQ(ellipsoid.importFromEPSG(4979), OGRERR_NONE);
    egm96.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    ellipsoid.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    return std::unique_ptr<OGRCoordinateTransformation>(OGRCreateCoordinateTransformation(&egm96, &ellipsoid));
  }();
  EXPECT_TRUE(t);
  double x = lonlatamsl[0], y = lonlatamsl[1], z = lonlatamsl[2];
  EXPECT_TRUE(t && t->Transform(1, &x, &y, &z));
  return z;
}

struct WpmlKmz {
  XmlTree template_kml, waylines_wpml;
  const CPLXMLNode* template_root = nullptr;
  const CPLXMLNode* waylines_root = nullptr;
};

WpmlKmz open_wpml_kmz(const std::string& path) {
  const std::string zip = "/vsizip/" + path;
  EXPECT_EQ(vsi_dir(zip), (std::vector<std::string>{"wpmz"}));
  EXPECT_EQ(vsi_dir(zip + "/wpmz"), (std::vector<std::string>{"template.kml", "waylines.wpml"}));
  WpmlKmz kmz;
  kmz.template_kml.reset(CPLParseXMLString(vsi_read(zip + "/wpmz/template.kml").c_str()));
  kmz.waylines_wpml.reset(CPLParseXMLString(vsi_read(zip + "/wpmz/waylines.wpml").c_str()));
  EXPECT_TRUE(kmz.template_kml && kmz.waylines_wpml) << CPLGetLastErrorMsg();
  kmz.template_root = CPLGetXMLNode(kmz.template_kml.get(), "=kml");
  kmz.waylines_root = CPLGetXMLNode(kmz.waylines_wpml.get(), "=kml");
  EXPECT_TRUE(kmz.template_root && kmz.waylines_root);
  return kmz;
}

// Everything a written mission must say, from the Mission and options alone.
void expect_wpml_mission(const std::string& path, const Mission& mission, const MissionOptions& options) {
  const WpmlKmz kmz = open_wpml_kmz(path);
  if (!kmz.template_root || !kmz.waylines_root) return;
  const bool relative = options.altitude_frame == AltitudeFrame::relative;
  const char* finish = mission.end == MissionEnd::rtl    ? "goHome"
                       : mission.end == MissionEnd::land ? "autoLand"
                                                         : "noAction";
  const double takeoff = mission.route[0][2] - mission.home[2];
  for (const CPLXMLNode* root : {kmz.template_root, kmz.waylines_root}) {
    EXPECT_EQ(xml_text(root, "xmlns"), "http://www.opengis.net/kml/2.2");
    EXPECT_EQ(xml_text(root, "xmlns:wpml"), "http://www.dji.com/wpmz/1.0.2");
    const CPLXMLNode* config = CPLGetXMLNode(root, "Document.wpml:missionConfig");
    ASSERT_TRUE(config);
    EXPECT_EQ(xml_text(config, "wpml:flyToWaylineMode"), "safely");
    EXPECT_EQ(xml_text(config, "wpml:finishAction"), finish);
    EXPECT_EQ(xml_text(config, "wpml:exitOnRCLost"), "executeLostAction");
    EXPECT_EQ(xml_text(config, "wpml:executeRCLostAction"), "goBack");
    EXPECT_NEAR(xml_number(config, "wpml:takeOffSecurityHeight"), takeoff, 1e-3);
    EXPECT_NEAR(xml_number(config, "wpml:globalTransitionalSpeed"), options.speed, 1e-3);
    EXPECT_TRUE(CPLGetXMLNode(config, "wpml:droneInfo.wpml:droneEnumValue"));
    EXPECT_EQ(xml_children(CPLGetXMLNode(root, "Document"), "Folder").size(), 1u);
  }

  // waylines.wpml: what the aircraft flies.
  const CPLXMLNode* folder = CPLGetXMLNode(kmz.waylines_root, "Document.Folder");
  ASSERT_TRUE(folder);
  EXPECT_EQ(xml_text(folder, "wpml:templateId"), "0");
  EXPECT_EQ(xml_text(folder, "wpml:waylineId"), "0");
  // DJI's execution modes are WGS84 (ellipsoidal) and relativeToStartPoint; there is no EGM96 one.
  EXPECT_EQ(xml_text(folder, "wpml:executeHeightMode"), relative ? "relativeToStartPoint" : "WGS84");
  EXPECT_NEAR(xml_number(folder, "wpml:autoFlightSpeed"), options.speed, 1e-3);
  const auto placemarks = xml_children(folder, "Placemark");
  ASSERT_EQ(placemarks.size(), mission.route.size());  // route[0], the takeoff's top, is waypoint 0
  for (size_t i = 0; i < placemarks.size(); ++i) {
    const CPLXMLNode* p = placemarks[i];
    const Point3& q = mission.route[i];
    const CPLStringList lonlat(CSLTokenizeString2(xml_text(p, "Point.coordinates").c_str(), ",", 0));
    ASSERT_EQ(lonlat.size(), 2) << i;
    EXPECT_NEAR(std::stod(lonlat[0]), q[0], 1e-9) << i;
    EXPECT_NEAR(std::stod(lonlat[1]), q[1], 1e-9) << i;
    EXPECT_EQ(xml_text(p, "wpml:index"), std::to_string(i));
    const double height = relative ? q[2] - mission.home[2] : gdal_ellipsoidal(q);
    EXPECT_NEAR(xml_number(p, "wpml:executeHeight"), height, 1e-3) << i;
    if (!relative) {
      // The geoid lies about 47 m above the ellipsoid here: an EGM96 height written as it is
      // would fly that much too low.
      EXPECT_GT(xml_number(p, "wpml:executeHeight") - q[2], 40) << i;
      EXPECT_LT(xml_number(p, "wpml:executeHeight") - q[2], 55) << i;
    }
    EXPECT_NEAR(xml_number(p, "wpml:waypointSpeed"), options.speed, 1e-3) << i;
    EXPECT_EQ(xml_text(p, "wpml:waypointHeadingParam.wpml:waypointHeadingMode"), "followWayline");
    EXPECT_EQ(xml_text(p, "wpml:waypointTurnParam.wpml:waypointTurnMode"), "toPointAndStopWithDiscontinuityCurvature");
    EXPECT_EQ(xml_text(p, "wpml:useStraightLine"), "1");
  }
  // Waypoint 0 is directly above home, as high as the takeoff climbs.
  const CPLStringList first(CSLTokenizeString2(xml_text(placemarks[0], "Point.coordinates").c_str(), ",", 0));
  EXPECT_NEAR(std::stod(first[0]), mission.home[0], 1e-7);
  EXPECT_NEAR(std::stod(first[1]), mission.home[1], 1e-7);
  if (relative) EXPECT_NEAR(xml_number(placemarks[0], "wpml:executeHeight"), takeoff, 1e-3);

  // template.kml: the same route as an editable waypoint template, heights in its height mode
  // and on the ellipsoid.
  const CPLXMLNode* plan = CPLGetXMLNode(kmz.template_root, "Document.Folder");
  ASSERT_TRUE(plan);
  EXPECT_EQ(xml_text(plan, "wpml:templateType"), "waypoint");
  EXPECT_EQ(xml_text(plan, "wpml:templateId"), "0");
  EXPECT_EQ(xml_text(plan, "wpml:waylineCoordinateSysParam.wpml:coordinateMode"), "WGS84");
  EXPECT_EQ(xml_text(plan, "wpml:waylineCoordinateSysParam.wpml:heightMode"),
            relative ? "relativeToStartPoint" : "EGM96");
  EXPECT_NEAR(xml_number(plan, "wpml:autoFlightSpeed"), options.speed, 1e-3);
  EXPECT_EQ(xml_text(plan, "wpml:globalWaypointTurnMode"), "toPointAndStopWithDiscontinuityCurvature");
  const CPLStringList reference(CSLTokenizeString2(
      xml_text(kmz.template_root, "Document.wpml:missionConfig.wpml:takeOffRefPoint").c_str(), ",", 0));
  ASSERT_EQ(reference.size(), 3);
  EXPECT_NEAR(std::stod(reference[0]), mission.home[1], 1e-9);  // latitude first here
  EXPECT_NEAR(std::stod(reference[1]), mission.home[0], 1e-9);
  EXPECT_NEAR(std::stod(reference[2]), gdal_ellipsoidal(mission.home), 1e-3);
  const auto points = xml_children(plan, "Placemark");
  ASSERT_EQ(points.size(), mission.route.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Point3& q = mission.route[i];
    EXPECT_EQ(xml_text(points[i], "wpml:index"), std::to_string(i));
    EXPECT_EQ(xml_text(points[i], "wpml:useGlobalHeight"), "0");
    EXPECT_NEAR(xml_number(points[i], "wpml:height"), relative ? q[2] - mission.home[2] : q[2], 1e-3) << i;
    EXPECT_NEAR(xml_number(points[i], "wpml:ellipsoidHeight"), gdal_ellipsoidal(q), 1e-3) << i;
    const CPLStringList lonlat(CSLTokenizeString2(xml_text(points[i], "Point.coordinates").c_str(), ",", 0));
    ASSERT_EQ(lonlat.size(), 2) << i;
    EXPECT_NEAR(std::stod(lonlat[0]), q[0], 1e-9) << i;
    EXPECT_NEAR(std::stod(lonlat[1]), q[1], 1e-9) << i;
  }
}

}  // namespace

TEST(MissionWpml, EveryEndAndFrameReadsBackAsTheMission) {
  testkit::TempDir dir;
  for (const MissionEnd end : {MissionEnd::rtl, MissionEnd::land, MissionEnd::none})
    for (const AltitudeFrame frame : {AltitudeFrame::relative, AltitudeFrame::amsl}) {
      SCOPED_TRACE(testing::Message() << "end " << int(end) << " frame " << int(frame));
      const Mission mission = sample_mission(end);
      MissionOptions options;
      options.altitude_frame = frame;
      options.speed = 7.25;
      const std::string path = dir.path("m" + std::to_string(int(end)) + std::to_string(int(frame)) + ".kmz");
      write_wpml_kmz(mission, options, path);
      expect_wpml_mission(path, mission, options);
    }
  EXPECT_EQ(dir.files().size(), 6u);  // no temporaries beside them
}

// Every entry carries a real date (GDAL's writer left the MS-DOS date 0, read as 1980-00-00):
// Python's zipfile (both the central directory and each local header; testzip() checks every
// entry's CRC) is the oracle.
TEST(MissionWpml, EntriesAreDatedAndTheArchiveTestsClean) {
  testkit::TempDir dir;
  const std::string path = dir.path("m.kmz");
  write_wpml_kmz(sample_mission(MissionEnd::rtl), MissionOptions{}, path);
  const std::string script =
      "import sys, zipfile, struct\n"
      "z = zipfile.ZipFile(sys.argv[1])\n"
      "assert z.testzip() is None\n"
      "raw = open(sys.argv[1], 'rb').read()\n"
      "for info in z.infolist():\n"
      "    local = struct.unpack_from('<HH', raw, info.header_offset + 10)\n"
      "    print(info.filename, info.date_time, local)\n";
  const auto listed = testkit::run_program("python3", {"-c", script, path});
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_NE(listed.out.find("wpmz/template.kml (1980, 1, 1, 0, 0, 0) (0, 33)"), std::string::npos) << listed.out;
  EXPECT_NE(listed.out.find("wpmz/waylines.wpml (1980, 1, 1, 0, 0, 0) (0, 33)"), std::string::npos) << listed.out;
  expect_wpml_mission(path, sample_mission(MissionEnd::rtl), MissionOptions{});
}

// Issue 52: --drone names the aircraft in droneInfo, as DJI's Cloud API demo keys its drones
// ("domain-type-subType", cloud-sdk DeviceEnum.java: transcribed here, the oracle), in both
// files; an aircraft WPML does not name is refused before anything is written.
TEST(MissionWpml, DroneInfoNamesTheAircraftAsDjiKeysIt) {
  const std::vector<std::pair<std::string, std::string>> dji_keys{
      {"m350", "0-89-0"}, {"m300", "0-60-0"}, {"m30", "0-67-0"}, {"m30t", "0-67-1"}, {"m3e", "0-77-0"},
      {"m3t", "0-77-1"},  {"m3m", "0-77-2"},  {"m3d", "0-91-0"}, {"m3td", "0-91-1"}};
  ASSERT_EQ(dji_drones().size(), dji_keys.size());
  testkit::TempDir dir;
  for (const auto& [name, key] : dji_keys) {
    MissionOptions options;
    options.drone = name;
    const std::string path = dir.path(name + ".kmz");
    write_wpml_kmz(sample_mission(MissionEnd::rtl), options, path);
    const WpmlKmz kmz = open_wpml_kmz(path);
    for (const CPLXMLNode* root : {kmz.template_root, kmz.waylines_root}) {
      const CPLXMLNode* info = CPLGetXMLNode(root, "Document.wpml:missionConfig.wpml:droneInfo");
      ASSERT_TRUE(info) << name;
      EXPECT_EQ("0-" + xml_text(info, "wpml:droneEnumValue") + "-" + xml_text(info, "wpml:droneSubEnumValue"), key)
          << name;
    }
  }
  MissionOptions unknown;
  unknown.drone = "phantom4";
  EXPECT_THROW(write_wpml_kmz(sample_mission(MissionEnd::rtl), unknown, dir.path("no.kmz")), ArgumentError);
  EXPECT_EQ(dir.files().size(), dji_keys.size());
}

TEST(MissionWpml, ALongerRouteKeepsItsOrderAndOverwritesInPlace) {
  Mission mission = sample_mission(MissionEnd::rtl);
  for (int i = 1; i <= 40; ++i) mission.route.push_back({6.935 + 1e-5 * i, 51.4271 - 7e-6 * i, 179 + 0.125 * (i % 7)});
  mission.route.push_back(mission.route.front());  // back above home, as the planner ends an rtl route
  testkit::TempDir dir;
  const std::string path = dir.path("long.kmz");
  write_wpml_kmz(sample_mission(MissionEnd::none), {}, path);
  write_wpml_kmz(mission, {}, path);
  expect_wpml_mission(path, mission, {});
  EXPECT_EQ(dir.files(), std::vector<std::string>{"long.kmz"});
}

// GDAL's KML drivers (KML, LIBKML) read the template's Placemarks as 2D points, in order: WPML's
// coordinates are "longitude,latitude" only, and both drivers skip the wpml: elements (no fields
// come of them), so the heights are checked through the XML above, not here.
TEST(MissionWpml, GdalKmlReadsTheTemplatesPoints) {
  const Mission mission = sample_mission(MissionEnd::land);
  testkit::TempDir dir;
  write_wpml_kmz(mission, {}, dir.path("m.kmz"));
  const std::string kml = "/vsizip/" + dir.path("m.kmz") + "/wpmz/template.kml";
  int drivers_tried = 0;
  for (const char* driver : {"KML", "LIBKML"}) {
    if (!GDALGetDriverByName(driver)) continue;
    ++drivers_tried;
    const char* const allowed[] = {driver, nullptr};
    GDALDatasetH ds = GDALOpenEx(kml.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, allowed, nullptr, nullptr);
    ASSERT_TRUE(ds) << driver << ": " << CPLGetLastErrorMsg();
    std::vector<std::array<double, 2>> points;
    for (int l = 0; l < GDALDatasetGetLayerCount(ds); ++l) {
      OGRLayerH layer = GDALDatasetGetLayer(ds, l);
      OGR_L_ResetReading(layer);
      while (OGRFeatureH f = OGR_L_GetNextFeature(layer)) {
        OGRGeometryH g = OGR_F_GetGeometryRef(f);
        EXPECT_TRUE(g && OGR_G_GetGeometryType(g) == wkbPoint) << driver;  // 2D: no height in the coordinates
        if (g) points.push_back({OGR_G_GetX(g, 0), OGR_G_GetY(g, 0)});
        OGR_F_Destroy(f);
      }
    }
    GDALClose(ds);
    ASSERT_EQ(points.size(), mission.route.size()) << driver;
    for (size_t i = 0; i < points.size(); ++i) {
      EXPECT_NEAR(points[i][0], mission.route[i][0], 1e-9) << driver << " " << i;
      EXPECT_NEAR(points[i][1], mission.route[i][1], 1e-9) << driver << " " << i;
    }
  }
  EXPECT_GT(drivers_tried, 0) << "GDAL has neither the KML nor the LIBKML driver";
}

TEST(MissionWpml, RefusesWhatCannotFlyAndLeavesNothing) {
  testkit::TempDir dir;
  const std::string path = dir.path("m.kmz");
  const auto refused = [&](const Mission& mission, const MissionOptions& options = {}) {
    EXPECT_THROW(write_wpml_kmz(mission, options, path), ArgumentError);
    EXPECT_TRUE(dir.files().empty()) << dir.files().front();
  };
  for (const auto& [mission, options] : unflyable_missions()) refused(mission, options);
  // autoLand lands where the route ends: a landing point elsewhere cannot be said in WPML.
  Mission m = sample_mission(MissionEnd::land);
  m.land[0] += 1e-5;
  refused(m);

  // A refused mission leaves an earlier file as it was.
  write_wpml_kmz(sample_mission(MissionEnd::none), {}, path);
  const std::string before = testkit::read_file(path);
  m = sample_mission(MissionEnd::rtl);
  m.route.clear();
  EXPECT_THROW(write_wpml_kmz(m, {}, path), ArgumentError);
  EXPECT_EQ(testkit::read_file(path), before);
  EXPECT_EQ(dir.files(), std::vector<std::string>{"m.kmz"});
}

TEST(MissionWpml, UnwritablePathsAreOutputErrorsAndLeaveNothing) {
  testkit::TempDir dir;
  EXPECT_THROW(write_wpml_kmz(sample_mission(MissionEnd::rtl), {}, dir.path("missing/m.kmz")), OutputError);
  EXPECT_TRUE(dir.files().empty());
  std::filesystem::create_directory(dir.path("folder.kmz"));
  EXPECT_THROW(write_wpml_kmz(sample_mission(MissionEnd::rtl), {}, dir.path("folder.kmz")), OutputError);
  EXPECT_EQ(dir.files(), std::vector<std::string>{"folder.kmz"});
  EXPECT_TRUE(std::filesystem::is_empty(dir.path("folder.kmz")));
}
