// Tools layer: the reports' JSON keys are a contract (added to, never renamed), and each report
// agrees with the file the tool wrote, read back independently.
#include "dsmplan/tools.hpp"

#include <gtest/gtest.h>

#include <sstream>

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

TEST(Tools, GridSummaryIsTheWrittenGeoTiff) {
  testkit::TempDir dir;
  GridOptions options;
  options.inputs = {testkit::data_path("delft-ahn3/ahn3_cropped_1.las"),
                    testkit::data_path("delft-ahn3/ahn3_cropped_2.las")};
  options.output = dir.path("dsm.tif");
  options.crs = "EPSG:28992+5709";
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
