// Cameras from a COLMAP text model (dsmplan/colmap_model.hpp, `dsmplan stereo --colmap`), each
// part against an oracle that shares none of its code path:
//   - the models and poses: COLMAP's projection written out here from its documentation and
//     src/colmap/sensor/models.h (perspective division, each model's distortion, f·u' + c, then
//     COLMAP's half-pixel to ours), the quaternion turned into R by Eigen (the Hamilton convention
//     COLMAP uses), against project() of the cameras read;
//   - the similarity: known cameras written as COLMAP would, in a frame made by a random
//     similarity (scale ~0.1, any rotation, an offset), read back with their true centres: every
//     camera projects test points to the same pixels as the original (< 1e-6 px), the fit finds
//     the scale; the DSM from --colmap is the DSM from --cameras with the exact cameras;
//   - bad input: one line naming the file and the place.
#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "aerial_scene.hpp"
#include "dsmplan/colmap_model.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/stereo_frames.hpp"
#include "dsmplan/stereo_io.hpp"
#include "testkit.hpp"

using namespace dsmplan;

namespace {

// The real COLMAP run's views: small, so that the whole run stays under a minute.
constexpr int kColmapImageSize = 480;
constexpr double kColmapFocal = 495;

std::string number(double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

Eigen::Matrix3d to_eigen(const Mat3& m) {
  Eigen::Matrix3d out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out(i, j) = m[i][j];
  return out;
}

// The images.txt line of a camera at (R, C) in some frame: q of R (Eigen), t = -R C.
std::string image_line(int id, const Eigen::Matrix3d& r, const Eigen::Vector3d& c, int camera_id,
                       const std::string& name) {
  const Eigen::Quaterniond q(r);
  const Eigen::Vector3d t = -r * c;
  return std::to_string(id) + " " + number(q.w()) + " " + number(q.x()) + " " + number(q.y()) + " " + number(q.z()) +
         " " + number(t.x()) + " " + number(t.y()) + " " + number(t.z()) + " " + std::to_string(camera_id) + " " +
         name + "\n";
}

// A FrameCamera as COLMAP's cameras.txt line: SIMPLE_PINHOLE, PINHOLE or OPENCV, whichever says
// it exactly (COLMAP's principal point half a pixel further than ours).
std::string camera_line(int id, const FrameCamera& c) {
  const std::string size = " " + std::to_string(c.width) + " " + std::to_string(c.height) + " ";
  const std::string centre = number(c.cx + 0.5) + " " + number(c.cy + 0.5);
  if (c.distorted())
    return std::to_string(id) + " OPENCV" + size + number(c.fx) + " " + number(c.fy) + " " + centre + " " +
           number(c.distortion[0]) + " " + number(c.distortion[1]) + " " + number(c.distortion[2]) + " " +
           number(c.distortion[3]) + "\n";
  if (c.fx == c.fy) return std::to_string(id) + " SIMPLE_PINHOLE" + size + number(c.fx) + " " + centre + "\n";
  return std::to_string(id) + " PINHOLE" + size + number(c.fx) + " " + number(c.fy) + " " + centre + "\n";
}

// The NRW crop and three cameras over it as in stereo_pipeline_test (the right one tilted, with
// lens distortion; the third across the strip, so the centres are not on a line).
struct Scene {
  Grid truth;
  double lo = 0, hi = 0;
  std::vector<FrameCamera> cameras;
};
const Scene& scene() {
  static const Scene s = [] {
    Scene p;
    const Grid& nrw = testkit::nrw_crop();
    p.truth = aerial::crop(nrw, nrw.width / 2 - 20, nrw.height / 2 - 20, 40);
    const auto [lo, hi] = std::minmax_element(p.truth.z.begin(), p.truth.z.end());
    p.lo = *lo, p.hi = *hi;
    const double xc = p.truth.x0 + 20, yc = p.truth.y0 - 20, zc = p.lo + 110;
    p.cameras = {aerial::nadir_camera(240, 380, {xc - 12, yc, zc}),
                 aerial::nadir_camera(240, 380, {xc + 12, yc + 1, zc + 2}, 0.02, -0.03, -0.04, 0.0005),
                 aerial::nadir_camera(240, 380, {xc, yc + 14, zc - 1}, -0.02, 0.01)};
    p.cameras[2].fy = 381;  // PINHOLE
    return p;
  }();
  return s;
}

// The cameras written as a COLMAP model in the frame X_model = Qᵀ (X - T) / s, and the true
// centres as centres.csv; returns the similarity model -> CRS (s, Q, T).
Similarity write_model(const std::vector<FrameCamera>& cameras, const std::string& model, const std::string& centres) {
  std::mt19937 random(34);
  std::uniform_real_distribution<double> uniform(-1, 1);
  const Eigen::Quaterniond q =
      Eigen::Quaterniond(uniform(random), uniform(random), uniform(random), uniform(random)).normalized();
  const Eigen::Matrix3d big_q = q.toRotationMatrix();
  const double s = 10.0 * (1 + 0.2 * uniform(random));  // model -> CRS: the model is ~0.1 of the world
  const Eigen::Vector3d big_t(356000 + 100 * uniform(random), 5699000 + 100 * uniform(random), 80 * uniform(random));
  std::filesystem::create_directories(model);
  std::string cameras_txt =
      "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, "
      "PARAMS[]\n# Number of cameras: 3\n";
  std::string images_txt = "# Image list with two lines of data per image:\n";
  std::string csv = "image,x,y,z\n";
  for (int i = 0; i < static_cast<int>(cameras.size()); ++i) {
    const FrameCamera& c = cameras[i];
    const Eigen::Vector3d centre(c.center[0], c.center[1], c.center[2]);
    const Eigen::Matrix3d r_model = to_eigen(c.rotation) * big_q;  // R Q: R_model Qᵀ = R
    const Eigen::Vector3d c_model = big_q.transpose() * (centre - big_t) / s;
    cameras_txt += camera_line(7 + i, c);
    const std::string name = "img_" + std::to_string(i) + ".png";
    images_txt += image_line(20 - i, r_model, c_model, 7 + i, name);
    images_txt += i == 1 ? "\n" : "12.5 40.25 3 99.5 10.75 -1\n";  // an empty 2D points line too
    csv += name + "," + number(c.center[0]) + "," + number(c.center[1]) + "," + number(c.center[2]) + "\n";
  }
  testkit::write_file(model + "/cameras.txt", cameras_txt);
  testkit::write_file(model + "/images.txt", images_txt);
  testkit::write_file(centres, csv);
  Similarity out;
  out.scale = s;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.rotation[i][j] = big_q(i, j);
    out.translation[i] = big_t(i);
  }
  return out;
}

// `image` as an 8-bit grey band in GDAL's memory driver (null, and a test failure, if it cannot be).
std::unique_ptr<GDALDataset> grey_in_memory(const GreyImage& image) {
  GDALAllRegister();
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  EXPECT_TRUE(mem);
  if (!mem) return nullptr;
  std::unique_ptr<GDALDataset> data(mem->Create("", image.width, image.height, 1, GDT_Byte, nullptr));
  std::vector<std::uint8_t> bytes(image.pixels.size());
  for (size_t i = 0; i < bytes.size(); ++i)
    bytes[i] = static_cast<std::uint8_t>(std::clamp(image.pixels[i], 0.0f, 255.0f));
  const CPLErr written = data->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, image.width, image.height, bytes.data(),
                                                          image.width, image.height, GDT_Byte, 0, 0);
  EXPECT_EQ(written, CE_None);
  return written == CE_None ? std::move(data) : nullptr;
}

// `image` as an 8-bit grey PNG through GDAL.
void write_png(const GreyImage& image, const std::string& path) {
  GDALDriver* png = GetGDALDriverManager()->GetDriverByName("PNG");
  const std::unique_ptr<GDALDataset> data = grey_in_memory(image);
  ASSERT_TRUE(png && data);
  std::unique_ptr<GDALDataset> out(png->CreateCopy(path.c_str(), data.get(), FALSE, nullptr, nullptr, nullptr));
  ASSERT_TRUE(out);
}

}  // namespace

TEST(Colmap, CamerasFromAnArbitraryFrameProjectAsTheOriginals) {
  const Scene& s = scene();
  testkit::TempDir dir;
  const Similarity truth = write_model(s.cameras, dir.path("sparse"), dir.path("centres.csv"));
  const ColmapCameras read =
      colmap_cameras({.model = dir.path("sparse"), .centres = dir.path("centres.csv"), .crs = "EPSG:25832"});
  ASSERT_EQ(read.file.cameras.size(), 3u);
  EXPECT_EQ(read.georeference.method, "centres");
  EXPECT_EQ(read.georeference.centres, 3u);
  EXPECT_NEAR(read.georeference.scale, truth.scale, 1e-9 * truth.scale);
  EXPECT_LT(read.georeference.rms, 1e-6);
  EXPECT_EQ(read.georeference.bound, 0.5);
  EXPECT_EQ(read.file.path, dir.path("sparse") + "/images.txt");
  EXPECT_EQ(read.file.images[2], dir.path("sparse") + "/img_2.png");  // no images/ beside the model
  std::filesystem::create_directories(dir.path("photos"));            // the folder COLMAP's project.ini names
  testkit::write_file(dir.path("sparse/project.ini"), "log_to_stderr=true\nimage_path=" + dir.path("photos") +
                                                          "\n[Mapper]\nba_refine_focal_length=true\n");
  EXPECT_EQ(colmap_cameras({.model = dir.path("sparse"), .centres = dir.path("centres.csv"), .crs = "EPSG:25832"})
                .file.images[0],
            dir.path("photos") + "/img_0.png");
  std::mt19937 random(1);
  std::uniform_real_distribution<double> across(-30, 30), up(s.lo, s.hi + 20);
  double worst = 0;
  int seen = 0;
  for (int i = 0; i < 3; ++i) {
    const FrameCamera& original = s.cameras[i];
    const FrameCamera& recovered = read.file.cameras[i];
    EXPECT_EQ(recovered.distortion, original.distortion) << i;
    EXPECT_NEAR(recovered.cx, original.cx, 1e-12);
    EXPECT_EQ(recovered.fy, original.fy);
    for (int k = 0; k < 2000; ++k) {
      const Vec3 x{s.truth.x0 + 20 + across(random), s.truth.y0 - 20 + across(random), up(random)};
      double u0, v0, u1, v1;
      ASSERT_TRUE(project(original, x, u0, v0));
      ASSERT_TRUE(project(recovered, x, u1, v1));
      if (u0 < 0 || v0 < 0 || u0 > original.width - 1 || v0 > original.height - 1) continue;
      ++seen;
      worst = std::max({worst, std::abs(u1 - u0), std::abs(v1 - v0)});
    }
  }
  std::printf("recovered cameras: %d points in the images, largest difference %.3g px\n", seen, worst);
  EXPECT_GT(seen, 1000);
  EXPECT_LT(worst, 1e-6);

  // Given as a transform instead (the 13-number form), with the centres: checked, not fitted.
  std::string text = number(truth.scale) + "\n";
  for (const auto& row : truth.rotation) text += number(row[0]) + " " + number(row[1]) + " " + number(row[2]) + "\n";
  text += number(truth.translation[0]) + "," + number(truth.translation[1]) + "," + number(truth.translation[2]) + "\n";
  testkit::write_file(dir.path("transform.txt"), "# model -> EPSG:25832\n" + text);
  const ColmapCameras given = colmap_cameras({.model = dir.path("sparse"),
                                              .centres = dir.path("centres.csv"),
                                              .transform = dir.path("transform.txt"),
                                              .crs = "EPSG:25832"});
  EXPECT_EQ(given.georeference.method, "transform");
  EXPECT_LT(given.georeference.max, 1e-6);
}

// Each model's parameters against COLMAP's projection written out from its formulas.
TEST(Colmap, EveryModelMapsAsColmapProjects) {
  struct Case {
    const char* model;
    std::vector<double> params;
  };
  const std::vector<Case> cases = {
      {"SIMPLE_PINHOLE", {1500, 640, 480}},
      {"PINHOLE", {1500, 1490, 641.5, 479.25}},
      {"SIMPLE_RADIAL", {1500, 640, 480, -0.08}},
      {"RADIAL", {1500, 640, 480, -0.08, 0.03}},
      {"OPENCV", {1500, 1490, 641.5, 479.25, -0.08, 0.03, 0.001, -0.002}},
      {"FULL_OPENCV", {1500, 1490, 641.5, 479.25, -0.08, 0.03, 0.001, -0.002, 0.01, 0, 0, 0}},
  };
  // COLMAP's ImgFromCam: u = X/Z, v = Y/Z, (du, dv) by the model, x = fx (u + du) + cx.
  const auto colmap_pixel = [](const Case& c, const Eigen::Vector3d& p) {
    const std::string m = c.model;
    const std::vector<double>& k = c.params;
    const bool one_focal = m == "SIMPLE_PINHOLE" || m == "SIMPLE_RADIAL" || m == "RADIAL";
    const double fx = k[0], fy = one_focal ? k[0] : k[1], cx = one_focal ? k[1] : k[2], cy = one_focal ? k[2] : k[3];
    const double u = p.x() / p.z(), v = p.y() / p.z(), r2 = u * u + v * v;
    double du = 0, dv = 0;
    if (m == "SIMPLE_RADIAL") du = u * k[3] * r2, dv = v * k[3] * r2;
    if (m == "RADIAL") du = u * (k[3] * r2 + k[4] * r2 * r2), dv = v * (k[3] * r2 + k[4] * r2 * r2);
    if (m == "OPENCV" || m == "FULL_OPENCV") {
      const double k3 = m == "FULL_OPENCV" ? k[8] : 0;
      const double radial = k[4] * r2 + k[5] * r2 * r2 + k3 * r2 * r2 * r2;
      du = u * radial + 2 * k[6] * u * v + k[7] * (r2 + 2 * u * u);
      dv = v * radial + 2 * k[7] * u * v + k[6] * (r2 + 2 * v * v);
    }
    return Eigen::Vector2d(fx * (u + du) + cx - 0.5, fy * (v + dv) + cy - 0.5);  // COLMAP's (0.5, 0.5) is our (0, 0)
  };
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized();
  const Eigen::Vector3d t(0.3, -1.2, 4.0);
  for (const Case& c : cases) {
    testkit::TempDir dir;
    std::string line = "3 " + std::string(c.model) + " 1280 960";
    for (double p : c.params) line += " " + number(p);
    testkit::write_file(dir.path("cameras.txt"), line + "\n");
    testkit::write_file(dir.path("images.txt"), "1 " + number(q.w()) + " " + number(q.x()) + " " + number(q.y()) + " " +
                                                    number(q.z()) + " " + number(t.x()) + " " + number(t.y()) + " " +
                                                    number(t.z()) + " 3 a.jpg\n\n2 1 0 0 0 1 0 0 3 b.jpg\n\n");
    const std::vector<ColmapImage> images = read_colmap_model(dir.path(""));
    ASSERT_EQ(images.size(), 2u);
    EXPECT_EQ(images[0].id, 1);
    EXPECT_EQ(images[1].name, "b.jpg");
    std::mt19937 random(5);
    std::uniform_real_distribution<double> across(-0.35, 0.35), depth(2, 50);
    double worst = 0;
    for (int k = 0; k < 500; ++k) {
      const double z = depth(random);
      const Eigen::Vector3d in_camera(across(random) * z, across(random) * z, z);
      const Eigen::Vector3d world = q.toRotationMatrix().transpose() * (in_camera - t);  // x_cam = R X + t
      const Eigen::Vector2d expected = colmap_pixel(c, in_camera);
      double u, v;
      ASSERT_TRUE(project(images[0].camera, {world.x(), world.y(), world.z()}, u, v));
      worst = std::max({worst, std::abs(u - expected.x()), std::abs(v - expected.y())});
    }
    EXPECT_LT(worst, 1e-8) << c.model;
  }
}

// --colmap through the binary: the same DSM as --cameras with the exact cameras, and the fit's
// residuals in --stats.
TEST(Colmap, DsmFromTheModelIsTheDsmFromTheExactCameras) {
  const Scene& s = scene();
  testkit::TempDir dir;
  write_model(s.cameras, dir.path("project/sparse"), dir.path("centres.csv"));
  std::filesystem::create_directories(dir.path("project/images"));
  nlohmann::json cameras = {{"crs", "EPSG:25832"}, {"cameras", nlohmann::json::array()}};
  for (int i = 0; i < 3; ++i) {
    const std::string name = "img_" + std::to_string(i) + ".png";
    write_png(aerial::render(aerial::ColumnScene{s.truth, s.lo, s.hi}, s.cameras[i], 1 + i),
              dir.path("project/images/" + name));
    cameras["cameras"].push_back(aerial::camera_json(s.cameras[i], "project/images/" + name));
  }
  testkit::write_file(dir.path("cameras.json"), cameras.dump(1));
  const std::string bounds =
      number(s.truth.x0) + "," + number(s.truth.y1()) + "," + number(s.truth.x1()) + "," + number(s.truth.y0);
  const auto exact = testkit::run_cli({"stereo", "--cameras", dir.path("cameras.json"), "-o", dir.path("exact.tif"),
                                       "--res", "1", "--bounds", bounds, "-q"});
  ASSERT_EQ(exact.exit_code, 0) << exact.err;
  const auto model = testkit::run_cli({"stereo", "--colmap", dir.path("project/sparse"), "--centres",
                                       dir.path("centres.csv"), "--crs", "EPSG:25832", "-o", dir.path("colmap.tif"),
                                       "--res", "1", "--bounds", bounds, "--stats", dir.path("stats.json")});
  ASSERT_EQ(model.exit_code, 0) << model.err;
  EXPECT_NE(model.err.find("residuals at 3 centres RMS 0.000 m"), std::string::npos) << model.err;
  const Grid a = read_raster(dir.path("exact.tif")), b = read_raster(dir.path("colmap.tif"));
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  EXPECT_EQ(b.crs.epsg, 25832);
  int valid_a = 0, valid_b = 0, both = 0, same = 0;
  for (int r = 0; r < a.height; ++r)
    for (int c = 0; c < a.width; ++c) {
      valid_a += a.valid(c, r), valid_b += b.valid(c, r);
      if (!a.valid(c, r) || !b.valid(c, r)) continue;
      ++both;
      same += std::abs(a.at(c, r) - b.at(c, r)) < 1e-3;
    }
  const aerial::DsmErrors e = aerial::dsm_errors(b, s.truth);
  std::printf(
      "--colmap vs --cameras: %d and %d valid cells, %d in both, %d within 1 mm; completeness %.1f %%, "
      "median |error| %.3f m\n",
      valid_b, valid_a, both, same, 100 * e.completeness, e.median);
  EXPECT_GT(valid_a, 0.85 * a.cells());
  EXPECT_LE(std::abs(valid_a - valid_b), valid_a / 1000);
  EXPECT_GE(same, both - both / 1000);
  const auto stats = nlohmann::json::parse(testkit::read_file(dir.path("stats.json")));
  EXPECT_EQ(stats["georeference"]["method"], "centres");
  EXPECT_EQ(stats["georeference"]["centres"], 3);
  EXPECT_LT(stats["georeference"]["residual_rms"].get<double>(), 1e-6);
  EXPECT_EQ(stats["cameras"], dir.path("project/sparse") + "/images.txt");
}

// Bad input: one line, naming the file and the place.
TEST(Colmap, BadInputIsOneLineNamingTheFileAndPlace) {
  const Scene& s = scene();
  testkit::TempDir dir;
  const std::string model = dir.path("sparse"), centres = dir.path("centres.csv");
  write_model(s.cameras, model, centres);
  const auto refused = [&](const ColmapOptions& options, const std::string& expected) {
    try {
      colmap_cameras(options);
      ADD_FAILURE() << "not refused: " << expected;
    } catch (const Error& error) {
      const std::string what = error.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      EXPECT_NE(what.find(expected), std::string::npos) << what << "\nexpected: " << expected;
    }
  };
  const ColmapOptions good{.model = model, .centres = centres, .crs = "EPSG:25832"};
  ColmapOptions o = good;
  o.model = dir.path("nothing");
  refused(o, dir.path("nothing") + "/cameras.txt: missing or cannot be opened");
  std::filesystem::create_directories(dir.path("binary"));
  testkit::write_file(dir.path("binary/cameras.bin"), "x");
  o.model = dir.path("binary");
  refused(o, "cameras.txt: missing; the model is binary: convert it with `colmap model_converter");
  o = good;
  o.centres = "";
  refused(o, "--centres: a COLMAP model's frame is arbitrary");

  const std::string cameras_txt = testkit::read_file(model + "/cameras.txt");
  const std::string images_txt = testkit::read_file(model + "/images.txt");
  testkit::write_file(model + "/cameras.txt", cameras_txt + "11 OPENCV_FISHEYE 240 240 380 380 120 120 0 0 0 0\n");
  refused(good, model + "/cameras.txt: line 7: camera model 'OPENCV_FISHEYE' cannot be written");
  testkit::write_file(model + "/cameras.txt", cameras_txt + "11 RADIAL 240 240 380 120 120 0.1\n");
  refused(good, model + "/cameras.txt: line 7: RADIAL needs CAMERA_ID MODEL WIDTH HEIGHT and 5 parameters");
  testkit::write_file(model + "/cameras.txt",
                      cameras_txt + "11 FULL_OPENCV 240 240 380 380 120 120 0.1 0 0 0 0 0.2 0 0\n");
  refused(good, model + "/cameras.txt: line 7: FULL_OPENCV with k4, k5, k6 not 0");
  testkit::write_file(model + "/cameras.txt", cameras_txt);

  testkit::write_file(model + "/images.txt", images_txt + "30 1 0 0 0 1 2 3 7\n\n");
  refused(good, model + "/images.txt: line 8: needs IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME (10 fields), got 9");
  testkit::write_file(model + "/images.txt", images_txt + "30 1 0 0 0 1 2 3 42 x.png\n\n");
  refused(good, model + "/images.txt: line 8: CAMERA_ID 42 is not in cameras.txt");
  testkit::write_file(model + "/images.txt", images_txt + "30 1 0 0 0 1 2 abc 7 x.png\n\n");
  refused(good, model + "/images.txt: line 8: TZ must be a finite number, got 'abc'");
  testkit::write_file(model + "/images.txt", images_txt);

  const std::string csv = testkit::read_file(centres);
  testkit::write_file(centres, csv.substr(0, csv.rfind("img_2")));
  refused(good, centres + ": 2 of its 2 centres name an image of the model (3 needed");
  testkit::write_file(centres, csv + "img_9.png,1,2\n");
  refused(good, centres + ": line 5: needs image,x,y,z (4 fields), got 3");
  // One centre 20 m off: the fit's RMS residual is over max(0.5 m, 1 % of ~30 m).
  const FrameCamera& c = s.cameras[1];
  std::string shifted = csv;
  const std::string row = "img_1.png," + number(c.center[0]);
  shifted.replace(shifted.find(row), row.size(), "img_1.png," + number(c.center[0] + 20));
  testkit::write_file(centres, shifted);
  // (the line named is the largest residual's: with 3 centres the fit spreads the error over all)
  refused(good, centres +
                    ": line 4: the similarity leaves residuals of RMS 6.03 m (max 7.14 m, at 'img_2.png'), "
                    "over the bound 0.50 m");
  testkit::write_file(centres, csv);

  testkit::write_file(dir.path("transform.txt"), "1 0 0 0\n0 1 0 0\n0 0 1 0\n");
  o = good;
  o.transform = dir.path("transform.txt");
  refused(o, "the similarity leaves residuals of RMS");  // the identity is not the model's frame
  testkit::write_file(dir.path("transform.txt"), "1 0 0\n0 1 0\n");
  refused(o, dir.path("transform.txt") + ": holds 6 numbers; a transform is 16");
  testkit::write_file(dir.path("transform.txt"), "2 0 0 0\n0 1 0 0\n0 0 1 0\n");
  refused(o, dir.path("transform.txt") + ": the 3 x 3 part is not a scale times a rotation");

  // Through the binary: exit 1, the one line, no output.
  testkit::write_file(model + "/cameras.txt", cameras_txt + "11 FOV 240 240 380 380 120 120 0.1\n");
  const auto result = testkit::run_cli({"stereo", "--colmap", model, "--centres", centres, "--crs", "EPSG:25832", "-o",
                                        dir.path("dsm.tif"), "--res", "1"});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_EQ(result.err, "dsmplan: " + model +
                            "/cameras.txt: line 7: camera model 'FOV' cannot be written as "
                            "dsmplan's pinhole with Brown-Conrady distortion (SIMPLE_PINHOLE, "
                            "PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV are): make PINHOLE images with "
                            "`colmap image_undistorter`\n");
  EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif")));
  const auto no_crs =
      testkit::run_cli({"stereo", "--colmap", model, "--centres", centres, "-o", dir.path("dsm.tif"), "--res", "1"});
  EXPECT_EQ(no_crs.exit_code, 2) << no_crs.err;
  EXPECT_NE(no_crs.err.find("--crs"), std::string::npos) << no_crs.err;
}

namespace {

// The pixel of X in camera c by OpenCV's projection written out here (x_cam = R (X - C), the
// Brown-Conrady terms, f x' + c; our pixel convention), not through project().
Eigen::Vector2d oracle_pixel(const FrameCamera& c, const Eigen::Vector3d& world) {
  const Eigen::Vector3d p = to_eigen(c.rotation) * (world - Eigen::Vector3d(c.center[0], c.center[1], c.center[2]));
  const double x = p.x() / p.z(), y = p.y() / p.z(), r2 = x * x + y * y;
  const auto& [k1, k2, p1, p2, k3] = c.distortion;
  const double radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {c.fx * xd + c.cx, c.fy * yd + c.cy};
}

// Ground control points on the scene's surface (heights of the DSM), each row an observation in
// every camera that sees it; header "point,x,y,z,image,u,v".
struct Gcps {
  std::vector<Eigen::Vector3d> points;
  std::string csv;
};
Gcps make_gcps(const Scene& s, int count, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> cell(4, s.truth.width - 5);
  Gcps out;
  out.csv = "point,x,y,z,image,u,v\n";
  for (int k = 0; k < count; ++k) {
    const int c = cell(random), r = cell(random);
    const Eigen::Vector3d x(s.truth.x0 + c + 0.5, s.truth.y0 - r - 0.5, s.truth.at(c, r));
    out.points.push_back(x);
    for (int i = 0; i < static_cast<int>(s.cameras.size()); ++i) {
      const Eigen::Vector2d px = oracle_pixel(s.cameras[i], x);
      if (px.x() < 0 || px.y() < 0 || px.x() > s.cameras[i].width - 1 || px.y() > s.cameras[i].height - 1) continue;
      out.csv += "P" + std::to_string(k) + "," + number(x.x()) + "," + number(x.y()) + "," + number(x.z()) + ",img_" +
                 std::to_string(i) + ".png," + number(px.x()) + "," + number(px.y()) + "\n";
    }
  }
  return out;
}

}  // namespace

// --gcps: points of the scene projected into the cameras by an independent projection, the model
// in a random similarity frame; the transform recovered is the true one.
TEST(Colmap, GroundControlPointsRecoverTheTrueSimilarity) {
  const Scene& s = scene();
  testkit::TempDir dir;
  const Similarity truth = write_model(s.cameras, dir.path("sparse"), dir.path("centres.csv"));
  const Gcps gcps = make_gcps(s, 6, 7);
  testkit::write_file(dir.path("gcps.csv"), gcps.csv);
  const ColmapCameras read =
      colmap_cameras({.model = dir.path("sparse"), .gcps = dir.path("gcps.csv"), .crs = "EPSG:25832"});
  EXPECT_EQ(read.georeference.method, "gcps");
  EXPECT_EQ(read.georeference.gcps, 6u);
  EXPECT_EQ(read.georeference.centres, 0u);
  EXPECT_LT(read.georeference.rms, 1e-6);
  EXPECT_LT(read.georeference.gcp_reprojection_max, 1e-6);
  double rotation = 0, translation = 0;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j)
      rotation = std::max(rotation, std::abs(read.transform.rotation[i][j] - truth.rotation[i][j]));
    translation = std::max(translation, std::abs(read.transform.translation[i] - truth.translation[i]));
  }
  std::printf("GCPs: scale %.9g (true %.9g), rotation off by %.2g, translation by %.2g m, RMS %.2g m\n",
              read.transform.scale, truth.scale, rotation, translation, read.georeference.rms);
  EXPECT_NEAR(read.transform.scale, truth.scale, 1e-8 * truth.scale);
  EXPECT_LT(rotation, 1e-8);
  EXPECT_LT(translation, 1e-5);
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(read.file.cameras[i].center[k], s.cameras[i].center[k], 1e-6);

  // The same points without a point column, columns reordered, pixels 0.3 px off at random: a fit
  // to within the bound, its transform near the truth.
  std::mt19937 random(3);
  std::normal_distribution<double> noise(0, 0.3);
  std::string csv = "image,u,v,x,y,z,remark\n";
  for (std::size_t k = 0; k < gcps.points.size(); ++k)
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector2d px =
          oracle_pixel(s.cameras[i], gcps.points[k]) + Eigen::Vector2d(noise(random), noise(random));
      csv += "img_" + std::to_string(i) + ".png," + number(px.x()) + "," + number(px.y()) + "," +
             number(gcps.points[k].x()) + "," + number(gcps.points[k].y()) + "," + number(gcps.points[k].z()) + ",x\n";
    }
  testkit::write_file(dir.path("noisy.csv"), csv);
  const ColmapCameras noisy =
      colmap_cameras({.model = dir.path("sparse"), .gcps = dir.path("noisy.csv"), .crs = "EPSG:25832"});
  EXPECT_EQ(noisy.georeference.gcps, 6u);
  EXPECT_GT(noisy.georeference.gcp_reprojection_max, 0.01);
  EXPECT_LT(noisy.georeference.rms, noisy.georeference.bound);
  EXPECT_NEAR(noisy.transform.scale, truth.scale, 0.02 * truth.scale);
  std::printf("GCPs with 0.3 px noise: RMS %.3f m, reprojection at most %.2f px, scale off by %.2g %%\n",
              noisy.georeference.rms, noisy.georeference.gcp_reprojection_max,
              100 * std::abs(noisy.transform.scale / truth.scale - 1));

  // Through the binary: the DSM made, the fit in --stats.
  std::filesystem::create_directories(dir.path("images"));
  for (int i = 0; i < 3; ++i)
    write_png(aerial::render(aerial::ColumnScene{s.truth, s.lo, s.hi}, s.cameras[i], 1 + i),
              dir.path("images/img_" + std::to_string(i) + ".png"));
  const auto cli = testkit::run_cli(
      {"stereo", "--colmap", dir.path("sparse"), "--gcps", dir.path("gcps.csv"), "--crs", "EPSG:25832", "-o",
       dir.path("dsm.tif"), "--res", "1", "--bounds",
       number(s.truth.x0) + "," + number(s.truth.y1()) + "," + number(s.truth.x1()) + "," + number(s.truth.y0),
       "--stats", dir.path("stats.json")});
  ASSERT_EQ(cli.exit_code, 0) << cli.err;
  EXPECT_NE(cli.err.find("residuals at 6 ground control points RMS 0.000 m"), std::string::npos) << cli.err;
  const auto stats = nlohmann::json::parse(testkit::read_file(dir.path("stats.json")));
  EXPECT_EQ(stats["georeference"]["method"], "gcps");
  EXPECT_EQ(stats["georeference"]["gcps"], 6);
  EXPECT_EQ(stats["georeference"]["residuals_at"], "gcps");
  const aerial::DsmErrors e = aerial::dsm_errors(read_raster(dir.path("dsm.tif")), s.truth);
  std::printf("DSM through --gcps: completeness %.1f %%, median |error| %.3f m\n", 100 * e.completeness, e.median);
  EXPECT_GT(e.completeness, 0.8);
  EXPECT_LT(e.median, 0.5);
}

// --gcps refusals: one line naming the file, the row and the problem.
TEST(Colmap, GroundControlPointsRefusedInOneLine) {
  const Scene& s = scene();
  testkit::TempDir dir;
  write_model(s.cameras, dir.path("sparse"), dir.path("centres.csv"));
  const Gcps gcps = make_gcps(s, 4, 11);
  const std::string path = dir.path("gcps.csv");
  const auto refused = [&](const std::string& csv, const std::string& expected) {
    testkit::write_file(path, csv);
    try {
      colmap_cameras({.model = dir.path("sparse"), .gcps = path, .crs = "EPSG:25832"});
      ADD_FAILURE() << "not refused: " << expected;
    } catch (const InputError& error) {
      const std::string what = error.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      EXPECT_NE(what.find(expected), std::string::npos) << what << "\nexpected: " << expected;
    }
  };
  // P9 seen in one image of the model only (its other image is not in the model).
  refused(gcps.csv + "P9,356000,5699000,100,img_1.png,10,10\nP9,356000,5699000,100,img_7.png,20,20\n",
          path + ": line " + std::to_string(std::count(gcps.csv.begin(), gcps.csv.end(), '\n') + 1) +
              ": point 'P9' is seen in 1 image(s) of the model; 2 are needed to triangulate it ('img_7.png' is not "
              "a registered image of the model)");
  // A pixel 40 px off: the observations disagree.
  std::vector<std::string> rows;
  std::istringstream lines(gcps.csv);
  for (std::string line; std::getline(lines, line);) rows.push_back(line);
  std::string bad = rows[0] + "\n";
  for (std::size_t i = 1; i < rows.size(); ++i) {
    std::string row = rows[i];
    if (i == 2) row = row.substr(0, row.rfind(',')) + "," + number(std::stod(row.substr(row.rfind(',') + 1)) + 40);
    bad += row + "\n";
  }
  refused(bad, "line 3: point 'P0''s observations disagree");
  refused("point,x,y,z,image,u\n", path + ": line 1: the header has no column v");
  refused("x,y,z,image,u,v\n1,2,3,img_0.png,4\n", path + ": line 2: has 5 fields, the header 6");
  refused("point,x,y,z,image,u,v\nA,1,2,3,img_0.png,4,5\nA,1,2,4,img_1.png,4,5\n",
          path + ": line 3: point 'A' is given other x, y, z than on line 2");
  refused("x,y,z,image,u,v\n1,2,3,img_0.png,4,nan\n", path + ": line 2: v must be a finite number, got 'nan'");
  // Two points: not enough for a similarity.
  std::string two = rows[0] + "\n";
  for (std::size_t i = 1; i < rows.size(); ++i)
    if (rows[i].rfind("P0,", 0) == 0 || rows[i].rfind("P1,", 0) == 0) two += rows[i] + "\n";
  refused(two, path + ": holds 2 ground control point(s); 3 are needed");
  // A point 20 m off in the CRS: residuals over the bound, the worst point's row named.
  std::string moved = rows[0] + "\n";
  for (std::size_t i = 1; i < rows.size(); ++i) {
    std::string row = rows[i];
    if (row.rfind("P3,", 0) == 0) {
      const auto comma = row.find(',', 3);
      row = "P3," + number(std::stod(row.substr(3, comma - 3)) + 20) + row.substr(comma);
    }
    moved += row + "\n";
  }
  refused(moved, "the similarity leaves residuals of RMS");
  // Both --centres and --gcps.
  const auto both =
      testkit::run_cli({"stereo", "--colmap", dir.path("sparse"), "--gcps", path, "--centres", dir.path("centres.csv"),
                        "--crs", "EPSG:25832", "-o", dir.path("dsm.tif"), "--res", "1"});
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("--gcps: give --centres or --gcps, not both"), std::string::npos) << both.err;
  // Through the binary: exit 1, one line, nothing written.
  testkit::write_file(path, "x,y,z,image,u,v\n1,2,3,img_0.png,4,5\n");
  const auto cli = testkit::run_cli({"stereo", "--colmap", dir.path("sparse"), "--gcps", path, "--crs", "EPSG:25832",
                                     "-o", dir.path("dsm.tif"), "--res", "1"});
  EXPECT_EQ(cli.exit_code, 1);
  EXPECT_EQ(cli.err,
            "dsmplan: " + path +
                ": line 2: point '1,2,3' is seen in 1 image(s) of the model; 2 are needed to triangulate it\n");
  EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif")));
}

namespace {

// Degrees as EXIF's "(d) (m) (s)".
std::string dms(double degrees) {
  degrees = std::abs(degrees);
  const double d = std::floor(degrees), m = std::floor((degrees - d) * 60), s = ((degrees - d) * 60 - m) * 60;
  char text[64];
  std::snprintf(text, sizeof text, "(%.0f) (%.0f) (%.6f)", d, m, s);
  return text;
}

// `image` as an 8-bit JPEG through GDAL, with EXIF GPS tags (GDAL's JPEG driver writes EXIF_*
// metadata items into the EXIF segment).
void write_jpeg_with_gps(const GreyImage& image, const std::string& path, double latitude, double longitude,
                         double altitude) {
  const std::unique_ptr<GDALDataset> data = grey_in_memory(image);
  GDALDriver* jpeg = GetGDALDriverManager()->GetDriverByName("JPEG");
  ASSERT_TRUE(jpeg && data);
  data->SetMetadataItem("EXIF_GPSLatitude", dms(latitude).c_str());
  data->SetMetadataItem("EXIF_GPSLatitudeRef", latitude < 0 ? "S" : "N");
  data->SetMetadataItem("EXIF_GPSLongitude", dms(longitude).c_str());
  data->SetMetadataItem("EXIF_GPSLongitudeRef", longitude < 0 ? "W" : "E");
  char metres[32];
  std::snprintf(metres, sizeof metres, "(%.4f)", std::abs(altitude));
  data->SetMetadataItem("EXIF_GPSAltitude", metres);
  data->SetMetadataItem("EXIF_GPSAltitudeRef", altitude < 0 ? "0x01" : "0x00");  // a BYTE, as GDAL reads it
  const char* options[] = {"QUALITY=95", nullptr};
  std::unique_ptr<GDALDataset> out(
      jpeg->CreateCopy(path.c_str(), data.get(), FALSE, const_cast<char**>(options), nullptr, nullptr));
  ASSERT_TRUE(out);
  out.reset();
  std::filesystem::remove(path + ".aux.xml");  // the tags must come from the JPEG itself
}

}  // namespace

// --centres exif: JPEGs whose EXIF GPS is the true centres (latitude, longitude by OGR from
// EPSG:25832, heights as EGM96 heights); the centres recovered in EPSG:25832 are the true ones.
TEST(Colmap, ExifGpsCentresAreTheTrueCentres) {
  const Scene& s = scene();
  testkit::TempDir dir;
  const Similarity truth = write_model(s.cameras, dir.path("project/sparse"), dir.path("centres.csv"));
  std::filesystem::create_directories(dir.path("project/images"));
  OGRSpatialReference utm, wgs84;
  utm.importFromEPSG(25832);
  wgs84.importFromEPSG(4326);
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> to_wgs84(OGRCreateCoordinateTransformation(&utm, &wgs84));
  ASSERT_TRUE(to_wgs84);
  for (int i = 0; i < 3; ++i) {
    double x = s.cameras[i].center[0], y = s.cameras[i].center[1];
    ASSERT_TRUE(to_wgs84->Transform(1, &x, &y));
    write_jpeg_with_gps(aerial::render(aerial::ColumnScene{s.truth, s.lo, s.hi}, s.cameras[i], 1 + i),
                        dir.path("project/images/img_" + std::to_string(i) + ".png"), y, x, s.cameras[i].center[2]);
  }
  const ExifCentres exif = [](const std::vector<std::string>& images) { return exif_centres(images, "EPSG:25832"); };
  const ColmapCameras read =
      colmap_cameras({.model = dir.path("project/sparse"), .centres = kExifCentres, .crs = "EPSG:25832"}, exif);
  EXPECT_EQ(read.georeference.method, "exif");
  EXPECT_EQ(read.georeference.centres, 3u);
  EXPECT_NE(read.georeference.heights.find("EGM96"), std::string::npos) << read.georeference.heights;
  double worst = 0;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k)
      worst = std::max(worst, std::abs(read.file.cameras[i].center[k] - s.cameras[i].center[k]));
  std::printf(
      "EXIF GPS centres: largest error of a recovered centre %.4f m, RMS residual %.4f m; scale %.6g (true "
      "%.6g)\n",
      worst, read.georeference.rms, read.transform.scale, truth.scale);
  EXPECT_LT(worst, 0.01);  // EXIF keeps seconds as rationals: ~1e-4" is 3 mm
  EXPECT_NEAR(read.transform.scale, truth.scale, 1e-3 * truth.scale);

  // The references: south, west, below sea level.
  write_jpeg_with_gps(aerial::render(aerial::ColumnScene{s.truth, s.lo, s.hi}, s.cameras[0], 1), dir.path("south.jpg"),
                      -33.5, -70.25, -12.5);
  const std::optional<ExifGps> south = read_exif_gps(dir.path("south.jpg"));
  ASSERT_TRUE(south);
  EXPECT_NEAR(south->latitude, -33.5, 1e-7);
  EXPECT_NEAR(south->longitude, -70.25, 1e-7);
  EXPECT_NEAR(south->altitude, -12.5, 1e-3);
  write_png(aerial::render(aerial::ColumnScene{s.truth, s.lo, s.hi}, s.cameras[0], 1), dir.path("plain.png"));
  EXPECT_FALSE(read_exif_gps(dir.path("plain.png")));

  // Images without GPS: refused in one line naming the images' folder.
  write_png(aerial::render(aerial::ColumnScene{s.truth, s.lo, s.hi}, s.cameras[1], 2),
            dir.path("project/images/img_1.png"));
  try {
    colmap_cameras({.model = dir.path("project/sparse"), .centres = kExifCentres, .crs = "EPSG:25832"}, exif);
    ADD_FAILURE() << "not refused";
  } catch (const InputError& error) {
    EXPECT_EQ(std::string(error.what()), dir.path("project/images") +
                                             ": 2 of the model's 3 images here record a GPS position with altitude "
                                             "in their EXIF (3 needed for a similarity)");
  }
}

// The real COLMAP end to end (issue 34, point 4): six views rendered from the NRW DSM, their
// poses not given to dsmplan; COLMAP's feature_extractor, exhaustive_matcher and mapper on the
// CPU make the model; `dsmplan stereo --colmap MODEL --centres centres.csv --crs EPSG:25832`
// makes the DSM; scored against the DSM the views were rendered from, next to the run with the
// exact cameras: completeness within 2 points, median |error| within 0.05 m. Skipped (naming
// why) only when `colmap` is not on PATH; scripts/deps.sh installs it.
TEST(ColmapBinary, RealColmapModelGivesTheDsmOfTheExactCameras) {
  if (std::system("command -v colmap > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "colmap is not on PATH (scripts/deps.sh installs Debian's colmap)";
  const Grid& nrw = testkit::nrw_crop();
  const int n = 100;
  const Grid truth = aerial::crop(nrw, nrw.width / 2 - n / 2, nrw.height / 2 - n / 2, n);
  const auto [lo, hi] = std::minmax_element(truth.z.begin(), truth.z.end());
  const double xc = truth.x0 + n / 2.0, yc = truth.y0 - n / 2.0, zc = *lo + 100;
  std::vector<FrameCamera> cameras;
  for (int row = 0; row < 2; ++row)
    for (int col = 0; col < 3; ++col)
      cameras.push_back(aerial::nadir_camera(kColmapImageSize, kColmapFocal,
                                             {xc + 18.0 * (col - 1), yc + 18.0 * (row - 0.5), zc + 2.0 * col - row},
                                             0.02 * (col - 1), 0.015 * (row - 0.5)));
  testkit::TempDir dir;
  std::filesystem::create_directories(dir.path("images"));
  nlohmann::json exact = {{"crs", "EPSG:25832"}, {"cameras", nlohmann::json::array()}};
  std::string centres = "image,x,y,z\n";
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const std::string name = "view_" + std::to_string(i) + ".png";
    write_png(aerial::render(aerial::ColumnScene{truth, *lo, *hi}, cameras[i], 11 + i), dir.path("images/" + name));
    exact["cameras"].push_back(aerial::camera_json(cameras[i], "images/" + name));
    centres += name + "," + number(cameras[i].center[0]) + "," + number(cameras[i].center[1]) + "," +
               number(cameras[i].center[2]) + "\n";
  }
  testkit::write_file(dir.path("cameras.json"), exact.dump(1));
  testkit::write_file(dir.path("centres.csv"), centres);

  // COLMAP on the CPU: its own features, matches and poses; the camera's size and focal length
  // given as a drone's calibration would be (PINHOLE, not refined), the poses all its own.
  const auto start = std::chrono::steady_clock::now();
  const std::string f = number(kColmapFocal), c = number(kColmapImageSize / 2.0);
  std::filesystem::create_directories(dir.path("sparse"));
  std::filesystem::create_directories(dir.path("model"));
  const std::vector<std::vector<std::string>> steps = {
      {"feature_extractor", "--database_path", dir.path("colmap.db"), "--image_path", dir.path("images"),
       "--ImageReader.camera_model", "PINHOLE", "--ImageReader.single_camera", "1", "--ImageReader.camera_params",
       f + "," + f + "," + c + "," + c, "--SiftExtraction.use_gpu", "0", "--SiftExtraction.num_threads", "2"},
      {"exhaustive_matcher", "--database_path", dir.path("colmap.db"), "--SiftMatching.use_gpu", "0",
       "--SiftMatching.num_threads", "2"},
      {"mapper", "--database_path", dir.path("colmap.db"), "--image_path", dir.path("images"), "--output_path",
       dir.path("sparse"), "--Mapper.num_threads", "2", "--Mapper.ba_refine_focal_length", "0",
       "--Mapper.ba_refine_principal_point", "0", "--Mapper.ba_refine_extra_params", "0"},
      {"model_converter", "--input_path", dir.path("sparse/0"), "--output_path", dir.path("model"), "--output_type",
       "TXT"}};
  setenv("QT_QPA_PLATFORM", "offscreen", 1);
  for (const auto& step : steps) {
    const auto run = testkit::run_program("colmap", step);
    ASSERT_EQ(run.exit_code, 0) << "colmap " << step[0] << ":\n"
                                << run.out.substr(run.out.size() > 3000 ? run.out.size() - 3000 : 0) << run.err;
  }
  const double colmap_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string bounds = number(truth.x0 + 15) + "," + number(truth.y1() + 15) + "," + number(truth.x1() - 15) +
                             "," + number(truth.y0 - 15);
  const auto from_exact = testkit::run_cli({"stereo", "--cameras", dir.path("cameras.json"), "-o",
                                            dir.path("exact.tif"), "--res", "1", "--bounds", bounds, "-q"});
  ASSERT_EQ(from_exact.exit_code, 0) << from_exact.err;
  // As the issue's command line: no --images (the model's folder has images/ beside it).
  const auto from_colmap = testkit::run_cli(
      {"stereo", "--colmap", dir.path("model"), "--centres", dir.path("centres.csv"), "--crs", "EPSG:25832", "-o",
       dir.path("colmap.tif"), "--res", "1", "--bounds", bounds, "--stats", dir.path("stats.json")});
  ASSERT_EQ(from_colmap.exit_code, 0) << from_colmap.err;
  const auto stats = nlohmann::json::parse(testkit::read_file(dir.path("stats.json")));
  const Grid scored = aerial::crop(truth, 15, 15, n - 30);
  const aerial::DsmErrors e = aerial::dsm_errors(read_raster(dir.path("exact.tif")), scored);
  const aerial::DsmErrors m = aerial::dsm_errors(read_raster(dir.path("colmap.tif")), scored);
  std::printf(
      "COLMAP (%.1f s): %zu of 6 images registered, fit to the centres RMS %.3f m (max %.3f m)\n"
      "exact cameras: completeness %.2f %%, median |error| %.3f m, over 1 m %.2f %%\n"
      "COLMAP model:  completeness %.2f %%, median |error| %.3f m, over 1 m %.2f %%\n",
      colmap_seconds, stats["camera_count"].get<std::size_t>(), stats["georeference"]["residual_rms"].get<double>(),
      stats["georeference"]["residual_max"].get<double>(), 100 * e.completeness, e.median, 100 * e.over1,
      100 * m.completeness, m.median, 100 * m.over1);
  EXPECT_EQ(stats["camera_count"], 6);
  EXPECT_GT(e.completeness, 0.9);  // the reference run is itself sound
  EXPECT_LT(e.median, 0.5);
  EXPECT_LE(std::abs(m.completeness - e.completeness), 0.02);
  EXPECT_LE(std::abs(m.median - e.median), 0.05);
}

// A model's mistakes named as what they are: a missing image as a missing image, a model without
// its 2D points lines refused (not read as half its images), centres in degrees with a metric
// CRS refused (not made a DSM of one cell).
TEST(Colmap, ModelMistakesAreNamedAsWhatTheyAre) {
  const Scene& s = scene();
  testkit::TempDir dir;
  const std::string model = dir.path("project/sparse"), centres = dir.path("centres.csv");
  write_model(s.cameras, model, centres);
  std::filesystem::create_directories(dir.path("project/images"));
  for (int i = 0; i < 2; ++i)  // img_2.png missing
    write_png(aerial::render(aerial::ColumnScene{s.truth, s.lo, s.hi}, s.cameras[i], 1 + i),
              dir.path("project/images/img_" + std::to_string(i) + ".png"));
  const std::string bounds =
      number(s.truth.x0) + "," + number(s.truth.y1()) + "," + number(s.truth.x1()) + "," + number(s.truth.y0);
  const auto stereo = [&](std::vector<std::string> more) {
    std::vector<std::string> args{"stereo", "--colmap",          model,   "--centres", centres, "--crs", "EPSG:25832",
                                  "-o",     dir.path("dsm.tif"), "--res", "1",         "-q"};
    args.insert(args.end(), more.begin(), more.end());
    return testkit::run_cli(args);
  };
  for (const auto& more : {std::vector<std::string>{}, std::vector<std::string>{"--bounds", bounds}}) {
    const auto missing = stereo(more);
    EXPECT_EQ(missing.exit_code, 1) << missing.err;
    EXPECT_EQ(missing.err, "dsmplan: " + dir.path("project/images/img_2.png") + ": camera 2: missing (an image of " +
                               model + "/images.txt)\n");
    EXPECT_EQ(missing.err.find("height"), std::string::npos) << missing.err;
    EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif")));
  }
  write_png(aerial::render(aerial::ColumnScene{s.truth, s.lo, s.hi}, s.cameras[2], 3),
            dir.path("project/images/img_2.png"));

  // images.txt without its 2D points lines: the second image's line would be read as the first's
  // points, and the model as half its images.
  const std::string images_txt = testkit::read_file(model + "/images.txt");
  {
    std::string rebuilt;
    std::istringstream in(images_txt);
    for (std::string line; std::getline(in, line);)
      if (line.rfind("#", 0) == 0 || std::count(line.begin(), line.end(), ' ') == 9) rebuilt += line + "\n";
    testkit::write_file(model + "/images.txt", rebuilt);
  }
  try {
    read_colmap_model(model);
    ADD_FAILURE() << "a model without its 2D points lines was read";
  } catch (const InputError& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find(model + "/images.txt: line "), std::string::npos) << what;
    EXPECT_NE(what.find("2D points"), std::string::npos) << what;
  }
  testkit::write_file(model + "/images.txt", images_txt);

  // The centres as longitude and latitude, the CRS metric: refused, naming the centres file.
  const auto lonlat = [&](const std::string& path) {
    std::string csv = "image,x,y,z\n";
    for (int i = 0; i < 3; ++i)
      csv += "img_" + std::to_string(i) + ".png," + number(6.95 + 1e-5 * (s.cameras[i].center[0] - 356000)) + "," +
             number(51.43 + 1e-5 * (s.cameras[i].center[1] - 5699000)) + "," + number(s.cameras[i].center[2]) + "\n";
    testkit::write_file(path, csv);
  };
  lonlat(dir.path("lonlat.csv"));
  const auto degrees = testkit::run_cli({"stereo", "--colmap", model, "--centres", dir.path("lonlat.csv"), "--crs",
                                         "EPSG:25832", "-o", dir.path("dsm.tif"), "--res", "1", "-q"});
  EXPECT_EQ(degrees.exit_code, 1) << degrees.err;
  EXPECT_EQ(degrees.err.rfind("dsmplan: " + dir.path("lonlat.csv") + ": ", 0), 0u) << degrees.err;
  EXPECT_NE(degrees.err.find("degrees"), std::string::npos) << degrees.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path("dsm.tif")));
  // The true centres still make a DSM.
  const auto made = stereo({"--bounds", bounds});
  EXPECT_EQ(made.exit_code, 0) << made.err;
}
