// Tools layer: the reports' JSON keys are a contract (added to, never renamed), and each report
// agrees with the file the tool wrote, read back independently.
#include "dsmplan/tools.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <sstream>
#include <utility>

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

// grid_point_files() is grid_to_geotiff() without the writing: the same grid, cell for cell.
TEST(Tools, GridPointFilesIsTheGridThatGridToGeotiffWrites) {
  testkit::TempDir dir;
  GridOptions options;
  options.inputs = {testkit::data_path("delft-ahn3/ahn3_cropped_1.las"),
                    testkit::data_path("delft-ahn3/ahn3_cropped_2.las")};
  options.output = dir.path("dsm.tif");
  options.crs = "EPSG:7415";
  options.grid.resolution = 2;
  options.fill_distance = 10;
  grid_to_geotiff(options);
  const Grid written = read_raster(options.output);
  const Grid in_memory = grid_point_files(options);
  ASSERT_EQ(in_memory.width, written.width);
  ASSERT_EQ(in_memory.height, written.height);
  EXPECT_EQ(in_memory.x0, written.x0);
  EXPECT_EQ(in_memory.y0, written.y0);
  EXPECT_EQ(in_memory.crs.epsg, written.crs.epsg);
  for (size_t i = 0; i < written.z.size(); ++i)
    ASSERT_TRUE(in_memory.z[i] == written.z[i] || (std::isnan(in_memory.z[i]) && std::isnan(written.z[i]))) << i;
  // And write_dsm() writes the same bytes.
  write_dsm(in_memory, dir.path("again.tif"));
  EXPECT_EQ(testkit::read_file(dir.path("again.tif")), testkit::read_file(options.output));
}

// write_dsm() writes nothing dsmplan's own reader would refuse.
TEST(Tools, WriteDsmRefusesWhatReadRasterWouldRefuse) {
  testkit::TempDir dir;
  Grid grid;
  grid.width = 2, grid.height = 2, grid.x0 = 356000, grid.y0 = 5699000;
  grid.z = {1, 2, 3, 4};
  const auto refused = [&](const Grid& g, const std::string& name, const std::string& field) {
    try {
      write_dsm(g, dir.path(name));
      ADD_FAILURE() << name << " was written";
    } catch (const ArgumentError& error) {
      EXPECT_EQ(error.field(), field) << error.what();
    }
  };
  refused(grid, "no_crs.tif", "crs");
  grid.crs.definition = "EPSG:2263";  // New York Long Island, US survey feet
  resolve_crs(grid.crs);
  refused(grid, "feet.tif", "crs");
  grid.crs = Crs();
  grid.crs.definition = "EPSG:25832";
  resolve_crs(grid.crs);
  Grid empty = grid;
  empty.z.assign(4, NAN);
  refused(empty, "empty.tif", "heights");
  refused(grid, "dsm.png", dir.path("dsm.png"));
  EXPECT_TRUE(dir.files().empty());
  write_dsm(grid, dir.path("dsm.tif"));
  EXPECT_EQ(read_raster(dir.path("dsm.tif")).z, grid.z);
}

// choose_classes() is the rule of grid's three class flags, for every face.
TEST(Tools, ChooseClassesIsTheRuleOfGridsClassFlags) {
  const auto chosen = [](std::vector<int> keep, std::optional<std::vector<int>> drop, bool all) {
    GridPointsOptions options;
    choose_classes(options, keep, drop, all);
    return std::make_pair(options.keep_classes, options.drop_classes);
  };
  using Classes = std::vector<int>;
  EXPECT_EQ(chosen({}, std::nullopt, false), std::make_pair(Classes{}, Classes{7, 18}));  // noise dropped
  EXPECT_EQ(chosen({}, Classes{}, false), std::make_pair(Classes{}, Classes{7, 18}));     // empty: the default
  EXPECT_EQ(chosen({}, Classes{6}, false), std::make_pair(Classes{}, Classes{6}));
  EXPECT_EQ(chosen({2, 7}, std::nullopt, false), std::make_pair(Classes{2, 7}, Classes{}));  // listed alone
  EXPECT_EQ(chosen({2}, Classes{9}, false), std::make_pair(Classes{2}, Classes{9}));
  EXPECT_EQ(chosen({}, Classes{6}, true), std::make_pair(Classes{}, Classes{}));  // every class
  try {
    chosen({2}, std::nullopt, true);
    ADD_FAILURE() << "--classes with --keep-all-classes was taken";
  } catch (const ArgumentError& error) {
    EXPECT_EQ(error.field(), "keep_classes");
    EXPECT_NE(error.problem().find("--keep-all-classes"), std::string::npos);
  }
}

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
    if (method == SimplifyMethod::Bounded) {
      job.max_error = 0.4;
      job.conservative = true;
    }
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

// ---- the options' own checks: the same one-line error as `dsmplan ...` prints ----------------

namespace {

// What `options` is refused with (ArgumentError's what(), the CLI's line after "dsmplan: "),
// or "" when the job got past its checks; nothing may be written either way.
template <typename Job>
std::string refusal(const Job& job, const std::string& output) {
  try {
    job();
  } catch (const ArgumentError& error) {
    EXPECT_FALSE(std::filesystem::exists(output)) << output;
    return error.what();
  } catch (const Error&) {
  }
  return "";
}

}  // namespace

// A parameter of the other simplification method would be ignored without a word: refused by
// the library itself, with the flag's name, as `dsmplan simplify` refuses it.
TEST(Tools, SimplifyRefusesAParameterOfTheOtherMethod) {
  testkit::TempDir dir;
  SimplifyJobOptions base;
  base.input = testkit::data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif");
  base.output = dir.path("simplified.ply");
  const auto refused = [&](const SimplifyJobOptions& job) { return refusal([&] { simplify_job(job); }, job.output); };
  const std::string bounded_only =
      "belongs to the paper's variants (--method variant1|variant2); the bounded mode "
      "(the default) is bounded by --max-error";

  SimplifyJobOptions job = base;
  job.method = SimplifyMethod::Variant1;
  job.max_error = 0.3;
  EXPECT_EQ(refused(job), "--max-error: belongs to the bounded mode, not --method variant1");
  job.max_error.reset();
  job.method = SimplifyMethod::Variant2;
  job.conservative = true;
  EXPECT_EQ(refused(job), "--conservative: belongs to the bounded mode, not --method variant2");

  job = base;
  job.dz = 0.3;  // the bounded mode by default
  EXPECT_EQ(refused(job), "--dz: " + bounded_only);
  job = base;
  job.method = SimplifyMethod::Bounded;
  job.dco = 1e-4;
  EXPECT_EQ(refused(job), "--dco: " + bounded_only);
  job.max_error = 0.3;  // --max-error makes no paper's tolerance right
  EXPECT_EQ(refused(job), "--dco: " + bounded_only);

  // The ranges, after the rules: what check_bounded_options says, by the flag the CLI maps it to.
  job = base;
  job.max_error = 0;
  EXPECT_EQ(refused(job), "max_error: must be from 0.001 to 10000 (vertical units), got 0");
}

// Given or not is what the defaults hang on: no --max-error is the conservative bounded mode at
// 0.4 m; --max-error E alone is |mesh - DSM| <= E; --conservative with it is 0 <= mesh - DSM <= E.
TEST(Tools, SimplifyOptionsResolveWhatWasNotGiven) {
  SimplifyJobOptions job;
  EXPECT_EQ(job.chosen_method(), SimplifyMethod::Bounded);
  EXPECT_EQ(job.bounded_options().max_error, 0.4);
  EXPECT_TRUE(job.bounded_options().conservative);
  job.max_error = 0.7;
  EXPECT_EQ(job.bounded_options().max_error, 0.7);
  EXPECT_FALSE(job.bounded_options().conservative);
  job.conservative = true;
  EXPECT_TRUE(job.bounded_options().conservative);
  job = SimplifyJobOptions();
  job.output = "simplified.ply";
  job.method = SimplifyMethod::Variant1;
  job.dz = 0.2;
  EXPECT_EQ(job.paper_options().variant, PaperVariant::One);
  EXPECT_EQ(job.paper_options().dz, 0.2);
  EXPECT_EQ(job.paper_options().dco, PaperSimplifyOptions().dco);
  EXPECT_NO_THROW(job.check());
}

// --classes keeps exactly what it lists, --keep-all-classes everything: both at once is refused
// by the library, as `dsmplan grid` refuses it; each alone, and with --drop-classes, resolves
// as the CLI always did.
TEST(Tools, GridClassesAreOneChoice) {
  testkit::TempDir dir;
  GridOptions job;
  job.inputs = {dir.path("points.las")};  // never opened: the options are refused first
  job.output = dir.path("dsm.tif");
  job.crs = "EPSG:28992";
  job.classes = {2};
  job.keep_all_classes = true;
  EXPECT_EQ(refusal([&] { grid_to_geotiff(job); }, job.output),
            "keep_classes: keeps only the classes listed, --keep-all-classes every class: give one");

  const std::vector<int> noise = {7, 18};
  job.classes.clear();
  EXPECT_EQ(job.points_options().drop_classes, std::vector<int>());  // --keep-all-classes
  job.keep_all_classes = false;
  EXPECT_EQ(job.points_options().drop_classes, noise);  // nothing given
  job.classes = {2, 7};
  EXPECT_EQ(job.points_options().keep_classes, job.classes);
  EXPECT_EQ(job.points_options().drop_classes, std::vector<int>());  // --classes alone: noise too if listed
  job.drop_classes = std::vector<int>{18};
  EXPECT_EQ(job.points_options().drop_classes, std::vector<int>{18});

  // The grid's own lists would be replaced: refused rather than ignored.
  job.grid.keep_classes = {2};
  EXPECT_NE(refusal([&] { grid_to_geotiff(job); }, job.output), "");
}

TEST(Tools, InfoFormatIsTextOrJson) {
  EXPECT_EQ(parse_info_format(""), InfoFormat::Text);
  EXPECT_EQ(parse_info_format("text"), InfoFormat::Text);
  EXPECT_EQ(parse_info_format("json"), InfoFormat::Json);
  try {
    parse_info_format("xml");
    ADD_FAILURE() << "--of xml was taken";
  } catch (const ArgumentError& error) {
    EXPECT_EQ(std::string(error.what()), "--of: info prints text or json, got 'xml'");
  }
}
