// The sample's aerial block (scripts/sample.sh; issue 16 point 5): four views of the NRW sample
// rendered as bench/aerial_scene.hpp renders them (cells as solid columns, a texture varying in
// x, y and z, 2 x 2 rays a pixel, noise), two strips of two nadir views 30 m apart, one camera
// tilted with lens distortion, 400 x 400 px, 0.3 m a pixel on the ground, 120 m over the lowest
// cell, written as `dsmplan stereo` takes them; and the score of a DSM against the truth.
//
//   aerial_sample render OUTDIR    img_0..3.png, cameras.json (no height_range: dsmplan estimates
//                                  it), truth.tif (the central 60 m x 60 m, 1 m cells),
//                                  waypoints.csv (three points 10 m over the highest cell),
//                                  bounds.txt (x0,y0,x1,y1 of truth.tif), sfm/ (six views
//                                  without distortion and their centres.csv: image,x,y,z, for
//                                  the COLMAP route)
//   aerial_sample score DSM TRUTH  one line: filled, median |error|, > 1 m, > 3 m
#include <gdal_priv.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "aerial_scene.hpp"
#include "dsmplan/raster_io.hpp"

namespace {

using dsmplan::FrameCamera;
using dsmplan::GreyImage;
using dsmplan::Grid;

void write_png(const GreyImage& image, const std::string& path) {
  GDALAllRegister();
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDriver* png = GetGDALDriverManager()->GetDriverByName("PNG");
  std::unique_ptr<GDALDataset> data(mem->Create("", image.width, image.height, 1, GDT_Byte, nullptr));
  std::vector<std::uint8_t> bytes(image.pixels.size());
  for (size_t i = 0; i < bytes.size(); ++i)
    bytes[i] = static_cast<std::uint8_t>(std::clamp(image.pixels[i], 0.0f, 255.0f));
  if (data->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, image.width, image.height, bytes.data(), image.width,
                                       image.height, GDT_Byte, 0, 0) != CE_None)
    throw std::runtime_error(path + ": cannot be written");
  std::unique_ptr<GDALDataset> out(png->CreateCopy(path.c_str(), data.get(), FALSE, nullptr, nullptr, nullptr));
  if (!out) throw std::runtime_error(path + ": cannot be written");
}

using aerial::camera_json;

int render(const std::string& dir) {
  std::filesystem::create_directories(dir);
  const Grid nrw = dsmplan::read_raster(DSMPLAN_DATA_DIR "/nrw-dom1/nrw_dom1_crop500m_1m.tif");
  const int n = 140, m = 60;
  const int c0 = nrw.width / 2 - n / 2, r0 = nrw.height / 2 - n / 2;
  const Grid scene_dsm = aerial::crop(nrw, c0, r0, n);
  const Grid truth = aerial::crop(nrw, c0 + (n - m) / 2, r0 + (n - m) / 2, m);
  const auto [lo, hi] = std::minmax_element(scene_dsm.z.begin(), scene_dsm.z.end());
  const aerial::ColumnScene scene{scene_dsm, *lo, *hi};
  const double xc = truth.x0 + m / 2.0, yc = truth.y0 - m / 2.0, zc = *lo + 120;
  const int size = 400;
  const double f = 400;  // 0.3 m a pixel at 120 m
  using aerial::nadir_camera;
  const std::vector<FrameCamera> cameras{nadir_camera(size, f, {xc - 15, yc - 12, zc}),
                                         nadir_camera(size, f, {xc + 15, yc - 12, zc + 1}),
                                         nadir_camera(size, f, {xc - 15, yc + 12, zc}, 0.03, -0.02, -0.05, 0.0005),
                                         nadir_camera(size, f, {xc + 15, yc + 12, zc - 1})};
  nlohmann::json json{{"crs", "EPSG:25832"}, {"cameras", nlohmann::json::array()}};
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const std::string name = "img_" + std::to_string(i) + ".png";
    write_png(aerial::render(scene, cameras[i], static_cast<unsigned>(11 + i)), dir + "/" + name);
    json["cameras"].push_back(camera_json(cameras[i], name));
  }
  std::ofstream(dir + "/cameras.json") << json.dump(1) << "\n";
  // The block for structure-from-motion (sfm/): six views without lens distortion in a 3 x 2
  // grid 18 m apart, 480 x 480 px, about 100 m over the lowest cell, as colmap_test's
  // ColmapBinary test flies them; their centres as image,x,y,z for `--colmap --centres`.
  std::filesystem::create_directories(dir + "/sfm");
  std::ofstream centres(dir + "/sfm/centres.csv");
  centres << std::fixed << std::setprecision(4) << "image,x,y,z\n";
  for (int row = 0, i = 0; row < 2; ++row)
    for (int col = 0; col < 3; ++col, ++i) {
      const FrameCamera c =
          nadir_camera(480, 495, {xc + 18.0 * (col - 1), yc + 18.0 * (row - 0.5), *lo + 100 + 2.0 * col - row},
                       0.02 * (col - 1), 0.015 * (row - 0.5));
      const std::string name = "view_" + std::to_string(i) + ".png";
      write_png(aerial::render(scene, c, static_cast<unsigned>(21 + i)), dir + "/sfm/" + name);
      centres << name << "," << c.center[0] << "," << c.center[1] << "," << c.center[2] << "\n";
    }
  dsmplan::write_geotiff(truth, dir + "/truth.tif");
  const float thi = *std::max_element(truth.z.begin(), truth.z.end());
  std::ofstream waypoints(dir + "/waypoints.csv");
  waypoints << std::fixed << std::setprecision(2)
            << "# three points 10 m over the highest cell of truth.tif: x,y in EPSG:25832, z in m\nx,y,z\n";
  for (const auto& [dx, dy] : {std::pair{8.0, 8.0}, std::pair{30.0, 50.0}, std::pair{52.0, 10.0}})
    waypoints << truth.x0 + dx << "," << truth.y0 - dy << "," << thi + 10 << "\n";
  std::ofstream(dir + "/bounds.txt") << std::fixed << truth.x0 << "," << truth.y1() << "," << truth.x1() << ","
                                     << truth.y0 << "\n";
  std::printf(
      "rendered 4 views of %d x %d px (and 6 for structure-from-motion) of the NRW sample (%d m x %d m, heights "
      "%.1f..%.1f m) into %s\n",
      size, size, n, n, *lo, *hi, dir.c_str());
  return 0;
}

int score(const std::string& dsm_path, const std::string& truth_path) {
  const Grid dsm = dsmplan::read_raster(dsm_path), truth = dsmplan::read_raster(truth_path);
  const aerial::DsmErrors e = aerial::dsm_errors(dsm, truth);
  std::printf(
      "%s against the rendered truth (%d x %d cells): filled %.1f %%, median |error| %.2f m, > 1 m %.1f %%, > 3 m %.1f "
      "%%\n",
      dsm_path.c_str(), truth.width, truth.height, 100 * e.completeness, e.median, 100 * e.over1, 100 * e.over3);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 3 && std::strcmp(argv[1], "render") == 0) return render(argv[2]);
    if (argc == 4 && std::strcmp(argv[1], "score") == 0) return score(argv[2], argv[3]);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "aerial_sample: %s\n", error.what());
    return 1;
  }
  std::fprintf(stderr, "usage: aerial_sample render OUTDIR | aerial_sample score DSM TRUTH\n");
  return 2;
}
