// Tools layer: the reports' JSON keys are a contract (added to, never renamed), and each report
// agrees with the file the tool wrote, read back independently.
#include "dsmplan/tools.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>

#include "dsmplan/export.hpp"
#include "testkit.hpp"

using namespace dsmplan;

namespace {

void expect_keys(const Json& json, const std::vector<std::string>& keys) {
  for (const auto& key : keys) EXPECT_TRUE(json.contains(key)) << "missing key '" << key << "'";
}

// "element vertex N" of a PLY header.
long long ply_count(const std::string& bytes, const std::string& element) {
  std::istringstream header(bytes.substr(0, bytes.find("end_header")));
  for (std::string line; std::getline(header, line);) {
    if (line.rfind("element " + element + " ", 0) == 0) return std::stoll(line.substr(element.size() + 9));
  }
  return -1;
}

}  // namespace

TEST(Tools, MeshReportIsTheWrittenFileAndKeepsItsKeys) {
  testkit::TempDir dir;
  MeshJobOptions job;
  job.input = testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif");
  job.output = dir.path("mesh.ply");
  job.resolution = 3;
  job.resampling = Resampling::Max;
  const MeshReport report = mesh_dsm(job);
  const std::string ply = testkit::read_file(job.output);
  EXPECT_EQ(ply_count(ply, "vertex"), static_cast<long long>(report.vertices));
  EXPECT_EQ(ply_count(ply, "face"), static_cast<long long>(report.faces));
  EXPECT_EQ(report.file_bytes, ply.size());
  EXPECT_EQ(report.width, 167);  // ceil(500 / 3)

  const Json json = to_json(report);
  expect_keys(json, {"input", "output", "vertices", "faces", "cells", "valid_cells", "nodata_cells", "holes", "width",
                     "height", "source_resolution", "resolution", "resampling", "zstep", "max_edge_length",
                     "file_bytes", "crs", "vertical", "seconds"});
  expect_keys(json["seconds"], {"read", "resample", "triangulate", "write", "total"});
  expect_keys(json["crs"], {"name", "epsg", "wkt"});
  EXPECT_EQ(json["resampling"], "max");
  EXPECT_EQ(json["crs"]["epsg"], 25832);
}

TEST(Tools, RasterReportKeepsItsKeys) {
  InfoOptions info;
  info.input = testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif");
  const Json json = to_json(describe_raster(info));
  expect_keys(json, {"file", "width", "height", "resolution", "extent", "crs", "vertical", "cells", "valid_cells",
                     "nodata_cells", "holes", "height_range"});
  expect_keys(json["extent"], {"xmin", "ymin", "xmax", "ymax"});
  expect_keys(json["vertical"], {"name", "unit"});
}

// The written GeoTIFF is what the summary says, and the vertical datum survives whether the compound
// CRS is named by its parts or by its own code (EPSG:7415 lost it once).
class GridKeepsTheCompoundCrs : public ::testing::TestWithParam<const char*> {};

TEST_P(GridKeepsTheCompoundCrs, GridSummaryIsTheWrittenGeoTiff) {
  testkit::TempDir dir;
  GridOptions options;
  options.inputs = {testkit::data_path("delft-ahn3/ahn3_cropped_1.las"),
                    testkit::data_path("delft-ahn3/ahn3_cropped_2.las")};
  options.output = dir.path("dsm.tif");
  options.crs = GetParam();
  options.grid.resolution = 1;
  const GridSummary written = grid_to_geotiff(options);
  const Grid read_back = read_raster(options.output);
  const GridSummary read = summarize(read_back);
  EXPECT_EQ(written.valid, read.valid);
  EXPECT_EQ(written.holes, read.holes);
  EXPECT_GT(read.holes, 0u);  // canals stay holes
  EXPECT_EQ(read_back.crs.vertical_name, "NAP height");
  EXPECT_EQ(read_back.crs.epsg, 28992);
}

INSTANTIATE_TEST_SUITE_P(Tools, GridKeepsTheCompoundCrs, ::testing::Values("EPSG:28992+5709", "EPSG:7415"));

// The simplify report is the written mesh, its keys are Table 2's columns and the certified
// error, and that error is the one the written file (read back) has against the DSM.
TEST(Tools, SimplifyReportIsTheWrittenMeshAndKeepsItsKeys) {
  testkit::TempDir dir;
  const std::string dsm_path = testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif");
  for (const SimplifyMethod method : {SimplifyMethod::Variant2, SimplifyMethod::Bounded}) {
    SimplifyJobOptions job;
    job.input = dsm_path;
    job.output = dir.path(std::string(to_string(method)) + ".ply");
    job.resolution = 2;
    job.method = method;
    job.bounded.max_error = 0.4;
    job.bounded.conservative = method == SimplifyMethod::Bounded;
    const SimplifyReport report = simplify_job(job);
    const std::string ply = testkit::read_file(job.output);
    EXPECT_EQ(ply_count(ply, "vertex"), static_cast<long long>(report.vertices_out));
    EXPECT_EQ(ply_count(ply, "face"), static_cast<long long>(report.faces_out));
    EXPECT_EQ(report.vertices_in, 250u * 250u);  // 500 m at 2 m, no nodata
    EXPECT_LT(report.vertices_out, report.vertices_in);

    const Mesh written = read_mesh(job.output);
    const VerticalError error = certify(written, resample(read_raster(dsm_path), 2, Resampling::Median));
    EXPECT_DOUBLE_EQ(error.max_above, report.error.max_above);
    EXPECT_DOUBLE_EQ(error.max_below, report.error.max_below);
    EXPECT_EQ(error.cells, report.error.cells);

    const Json json = to_json(report);
    expect_keys(json, {"input",
                       "output",
                       "method",
                       "dz",
                       "dco",
                       "max_error",
                       "conservative",
                       "vertices_in",
                       "vertices_out",
                       "removed_coplanar",
                       "removed_colinear",
                       "faces_out",
                       "max_above_m",
                       "max_below_m",
                       "rms_m",
                       "certified_cells",
                       "uncovered_cells",
                       "crs",
                       "vertical",
                       "seconds"});
    expect_keys(json["seconds"], {"read", "certify", "write", "total"});
    EXPECT_EQ(json["crs"]["epsg"], 25832);
    if (method == SimplifyMethod::Bounded) {
      EXPECT_TRUE(json["removed_coplanar"].is_null());
      EXPECT_EQ(json["max_below_m"], 0.0);
      EXPECT_LE(json["max_above_m"].get<double>(), 0.4);
    } else {
      EXPECT_EQ(json["removed_coplanar"].get<size_t>() + json["removed_colinear"].get<size_t>(),
                report.vertices_in - report.vertices_out);
      expect_keys(json["seconds"], {"search", "triangulate"});
    }
  }
}

// A mesh input is certified against the DSM it came from, and refused without one.
TEST(Tools, SimplifyMeshInputNeedsItsDsm) {
  testkit::TempDir dir;
  MeshJobOptions mesh;
  mesh.input = testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif");
  mesh.output = dir.path("mesh.ply");
  mesh.resolution = 4;
  mesh_dsm(mesh);
  SimplifyJobOptions job;
  job.input = mesh.output;
  job.output = dir.path("simplified.ply");
  job.method = SimplifyMethod::Variant2;  // the bounded default works on the DSM grid only
  EXPECT_THROW(simplify_job(job), ArgumentError);
  EXPECT_FALSE(std::filesystem::exists(job.output));
  job.dsm = mesh.input;
  job.resolution = 4;
  const SimplifyReport from_mesh = simplify_job(job);
  // The same as simplifying the DSM directly.
  job.input = mesh.input;
  job.output = dir.path("direct.ply");
  const SimplifyReport direct = simplify_job(job);
  EXPECT_EQ(from_mesh.vertices_out, direct.vertices_out);
  EXPECT_EQ(from_mesh.faces_out, direct.faces_out);
  EXPECT_DOUBLE_EQ(from_mesh.error.max_below, direct.error.max_below);
}
