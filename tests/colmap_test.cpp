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

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "aerial_scene.hpp"
#include "dsmplan/colmap_model.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/stereo_frames.hpp"
#include "testkit.hpp"

using namespace dsmplan;

namespace {

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

// `image` as an 8-bit grey PNG through GDAL.
void write_png(const GreyImage& image, const std::string& path) {
  GDALAllRegister();
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDriver* png = GetGDALDriverManager()->GetDriverByName("PNG");
  ASSERT_TRUE(mem && png);
  std::unique_ptr<GDALDataset> data(mem->Create("", image.width, image.height, 1, GDT_Byte, nullptr));
  std::vector<std::uint8_t> bytes(image.pixels.size());
  for (size_t i = 0; i < bytes.size(); ++i)
    bytes[i] = static_cast<std::uint8_t>(std::clamp(image.pixels[i], 0.0f, 255.0f));
  ASSERT_EQ(data->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, image.width, image.height, bytes.data(), image.width,
                                             image.height, GDT_Byte, 0, 0),
            CE_None);
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
