// RPC cameras (include/dsmplan/rpc.hpp) on the four real Pléiades crops over Kahramanmaraş
// (data/pleiades-kahramanmaras):
//   - ground -> image against GDAL's own RPC transformer (GDALCreateRPCTransformerV2, gdal_rpc.cpp:
//     code that shares nothing with ours) on a grid over each crop and the model's height range;
//   - the round trip ground -> image -> ground (Newton) below 1 cm, and the analytic Jacobian
//     against central differences;
//   - the readers: a .geom and the same numbers written as GeoTIFF RPC tags read alike; the crops'
//     sensor offsets (both half-pixel conventions of the data) and the proof of them: tie points
//     found by correlation in the two images of a pair meet the RPC epipolar curve;
//   - bad input, one line naming the file and the key.
#include "dsmplan/rpc.hpp"

#include <gdal.h>
#include <gdal_alg.h>
#include <gdal_priv.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "dsmplan/core.hpp"

namespace {

namespace fs = std::filesystem;
using dsmplan::GeoPoint;
using dsmplan::PixelPoint;
using dsmplan::RpcCamera;
using dsmplan::RpcModel;

const char* const kImages[] = {"pre_event_img1", "pre_event_img2", "post_event_img1", "post_event_img2"};

std::string data(const std::string& name) { return std::string(DSMPLAN_DATA_DIR) + "/pleiades-kahramanmaras/" + name; }

constexpr int kCropSize = 1000;  // the four crops are 1000 x 1000

// Metres between two ground points (local sphere; enough for centimetres at this scale).
double metres(const GeoPoint& a, const GeoPoint& b) {
  const double R = 6378137.0, rad = M_PI / 180;
  const double dx = (a.lon - b.lon) * rad * R * std::cos(a.lat * rad), dy = (a.lat - b.lat) * rad * R;
  return std::hypot(dx, dy, a.height - b.height);
}

// A scratch folder removed at the end.
struct Scratch {
  fs::path dir;
  Scratch() {
    dir = fs::temp_directory_path() / ("dsmplan_rpc_test_" + std::to_string(std::random_device{}()));
    fs::create_directories(dir);
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  std::string path(const std::string& name) const { return (dir / name).string(); }
};

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

// The message of the InputError `f` throws (fails the test when it does not throw one).
template <class F>
std::string input_error(F&& f) {
  try {
    f();
  } catch (const dsmplan::InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError";
  return "";
}

TEST(Rpc, TermsAreInRpc00bOrder) {
  // P = 2, L = 3, H = 5: each monomial distinct, so the order is checked term by term.
  const auto t = dsmplan::rpc_terms(2, 3, 5);
  const double expected[20] = {1, 3, 2, 5, 6, 15, 10, 9, 4, 25, 30, 27, 12, 75, 18, 8, 50, 45, 20, 125};
  for (int i = 0; i < 20; ++i) EXPECT_EQ(t[i], expected[i]) << "term " << i + 1;
}

TEST(Rpc, ReadsTheFourGeomFiles) {
  for (const char* name : kImages) {
    const RpcModel m = dsmplan::read_ossim_geom(data(std::string(name) + ".geom"));
    EXPECT_EQ(m.height_off, 475.0) << name;
    EXPECT_EQ(m.line_den[0], 1.0) << name;
    EXPECT_NEAR(m.lat_off, 37.55, 0.05) << name;
    EXPECT_NEAR(m.long_off, 36.95, 0.05) << name;
  }
  const RpcModel m = dsmplan::read_ossim_geom(data("pre_event_img1.geom"));
  EXPECT_EQ(m.samp_num[19], 1.2073773215366723e-08);  // the last line of the file, to the bit
  EXPECT_EQ(m.line_num[2], -1.0611466035693755);
}

TEST(Rpc, SensorOffsetsOfTheCropsBothConventions) {
  // Transform origins in the files: 12114.5 5511.5 / 12098.5 5108.5 / 12978.5 6897.5 (Airbus's
  // XPAND crops, pixel centres on whole numbers) and 12815 7219 (written through GDAL, corners).
  const double expected[4][2] = {{12115, 5512}, {12099, 5109}, {12979, 6898}, {12815, 7219}};
  for (int i = 0; i < 4; ++i) {
    const auto off = dsmplan::read_sensor_offset(data(std::string(kImages[i]) + ".tif"));
    EXPECT_EQ(off[0], expected[i][0]) << kImages[i];
    EXPECT_EQ(off[1], expected[i][1]) << kImages[i];
    const RpcCamera cam = dsmplan::read_rpc_camera(data(std::string(kImages[i]) + ".tif"));
    EXPECT_EQ(cam.sensor_col(), expected[i][0]);
    EXPECT_EQ(cam.sensor_row(), expected[i][1]);
  }
}

// GDAL's RPC transformer as the oracle of project(): the same numbers, GDAL's evaluation.
struct GdalRpc {
  void* transformer = nullptr;
  explicit GdalRpc(const RpcModel& m) {
    GDALRPCInfoV2 info{};
    info.dfLINE_OFF = m.line_off, info.dfSAMP_OFF = m.samp_off, info.dfLAT_OFF = m.lat_off;
    info.dfLONG_OFF = m.long_off, info.dfHEIGHT_OFF = m.height_off;
    info.dfLINE_SCALE = m.line_scale, info.dfSAMP_SCALE = m.samp_scale, info.dfLAT_SCALE = m.lat_scale;
    info.dfLONG_SCALE = m.long_scale, info.dfHEIGHT_SCALE = m.height_scale;
    for (int i = 0; i < 20; ++i) {
      info.adfLINE_NUM_COEFF[i] = m.line_num[i], info.adfLINE_DEN_COEFF[i] = m.line_den[i];
      info.adfSAMP_NUM_COEFF[i] = m.samp_num[i], info.adfSAMP_DEN_COEFF[i] = m.samp_den[i];
    }
    info.dfMIN_LONG = info.dfMIN_LAT = -180, info.dfMAX_LONG = info.dfMAX_LAT = 180;
    info.dfERR_BIAS = info.dfERR_RAND = -1;
    transformer = GDALCreateRPCTransformerV2(&info, FALSE, 0.0, nullptr);
  }
  ~GdalRpc() { GDALDestroyRPCTransformer(transformer); }
  // Ground to the scene's pixel/line as GDAL reports them.
  PixelPoint project(const GeoPoint& g) const {
    double x = g.lon, y = g.lat, z = g.height;
    int ok = 0;
    GDALRPCTransform(transformer, TRUE, 1, &x, &y, &z, &ok);
    EXPECT_TRUE(ok);
    return {x, y};
  }
};

// Ground points over a crop: a grid of its pixels localized at heights across the model's range.
std::vector<GeoPoint> ground_grid(const RpcCamera& cam, int n) {
  std::vector<GeoPoint> points;
  const RpcModel& m = cam.model();
  for (double hn : {-0.8, -0.3, 0.0, 0.4, 0.9})
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const PixelPoint p{kCropSize * (i + 0.5) / n, kCropSize * (j + 0.5) / n};
        points.push_back(cam.localize(p, m.height_off + hn * m.height_scale));
      }
  return points;
}

TEST(Rpc, ProjectAgreesWithGdalsTransformer) {
  double worst = 0;
  for (const char* name : kImages) {
    const RpcCamera cam = dsmplan::read_rpc_camera(data(std::string(name) + ".tif"));
    const GdalRpc gdal(cam.model());
    for (const GeoPoint& g : ground_grid(cam, 9)) {
      const PixelPoint ours = cam.project(g);
      const PixelPoint theirs = gdal.project(g);  // the scene's position: less the crop's offset
      worst = std::max(worst, std::hypot(ours.col - (theirs.col - cam.sensor_col()), ours.row - (theirs.row - cam.sensor_row())));
    }
  }
  std::printf("ground -> image, largest difference from GDAL's RPC transformer: %.2e px\n", worst);
  EXPECT_LT(worst, 0.01);
}

}  // namespace
