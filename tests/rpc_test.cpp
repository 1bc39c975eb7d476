// RPC cameras (dsmplan/rpc.hpp) on the four real Pléiades crops over Kahramanmaraş
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
#include "dsmplan/rpc_io.hpp"
#include "dsmplan/tools.hpp"
#include "gdal_rpc_oracle.hpp"

namespace {

namespace fs = std::filesystem;
using dsmplan::GeoPoint;
using dsmplan::PixelPoint;
using dsmplan::RpcCamera;
using dsmplan::RpcModel;

// The tests call GDAL directly (as the oracle and to write test files), each possibly alone
// (ctest runs one test per process): register the drivers before any of them.
const bool kGdalRegistered = [] {
  GDALAllRegister();
  return true;
}();

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
  const double expected[4][2] = {{12115, 5512}, {12099, 5109}, {12979, 6898}, {12816, 7220}};
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
  explicit GdalRpc(const RpcModel& m) : transformer(gdal_rpc_transformer(m)) {}
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

// A regular longitude/latitude grid over the crop's footprint (its corners localized at the mean
// height, widened by 10 %) at five heights: ground points that localize() did not make.
std::vector<GeoPoint> lon_lat_grid(const RpcCamera& cam, int n) {
  const RpcModel& m = cam.model();
  double lon0 = 1e9, lon1 = -1e9, lat0 = 1e9, lat1 = -1e9;
  for (const PixelPoint& c :
       {PixelPoint{0, 0}, PixelPoint{kCropSize, 0}, PixelPoint{0, kCropSize}, PixelPoint{kCropSize, kCropSize}}) {
    const GeoPoint g = cam.localize(c, m.height_off);
    lon0 = std::min(lon0, g.lon), lon1 = std::max(lon1, g.lon), lat0 = std::min(lat0, g.lat),
    lat1 = std::max(lat1, g.lat);
  }
  const double wl = 0.1 * (lon1 - lon0), wt = 0.1 * (lat1 - lat0);
  lon0 -= wl, lon1 += wl, lat0 -= wt, lat1 += wt;
  std::vector<GeoPoint> points;
  for (double hn : {-0.9, -0.4, 0.0, 0.5, 0.95})
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        points.push_back({lon0 + (lon1 - lon0) * i / (n - 1), lat0 + (lat1 - lat0) * j / (n - 1),
                          m.height_off + hn * m.height_scale});
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
      worst = std::max(
          worst, std::hypot(ours.col - (theirs.col - cam.sensor_col()), ours.row - (theirs.row - cam.sensor_row())));
    }
  }
  std::printf("ground -> image, largest difference from GDAL's RPC transformer: %.2e px\n", worst);
  EXPECT_LT(worst, 0.01);
}

TEST(Rpc, RoundTripBelowOneCentimetre) {
  // ground -> image -> ground at the same height, over every crop and the model's height range.
  double worst = 0;
  for (const char* name : kImages) {
    const RpcCamera cam = dsmplan::read_rpc_camera(data(std::string(name) + ".tif"));
    for (const GeoPoint& g : lon_lat_grid(cam, 21)) {
      EXPECT_TRUE(cam.in_domain(g));
      const GeoPoint back = cam.localize(cam.project(g), g.height);
      worst = std::max(worst, metres(g, back));
    }
  }
  std::printf("round trip ground -> image -> ground, largest error: %.3g m\n", worst);
  EXPECT_LT(worst, 0.01);
}

TEST(Rpc, LocalizeHitsThePixelAndTheJacobianIsTheDerivative) {
  const RpcCamera cam = dsmplan::read_rpc_camera(data("post_event_img2.tif"));
  double worst_px = 0, worst_rel = 0;
  for (const GeoPoint& g : ground_grid(cam, 5)) {
    const auto J = cam.jacobian(g);
    const double e = 1e-6;  // degrees (~0.1 m): central differences are good to ~1e-8 relative
    const PixelPoint xp = cam.project({g.lon + e, g.lat, g.height}), xm = cam.project({g.lon - e, g.lat, g.height});
    const PixelPoint yp = cam.project({g.lon, g.lat + e, g.height}), ym = cam.project({g.lon, g.lat - e, g.height});
    const double numeric[4] = {(xp.col - xm.col) / (2 * e), (yp.col - ym.col) / (2 * e), (xp.row - xm.row) / (2 * e),
                               (yp.row - ym.row) / (2 * e)};
    const double scale = std::max({std::abs(J[0]), std::abs(J[1]), std::abs(J[2]), std::abs(J[3])});
    for (int k = 0; k < 4; ++k) worst_rel = std::max(worst_rel, std::abs(J[k] - numeric[k]) / scale);
  }
  for (int j = 0; j <= 10; ++j)
    for (int i = 0; i <= 10; ++i) {
      const PixelPoint target{i * 100.0, j * 100.0};
      for (double h : {0.0, 475.0, 950.0}) {
        const PixelPoint back = cam.project(cam.localize(target, h));
        worst_px = std::max(worst_px, std::hypot(back.col - target.col, back.row - target.row));
      }
    }
  EXPECT_LT(worst_px, 1e-6);
  EXPECT_LT(worst_rel, 1e-6);
}

TEST(Rpc, CropShiftsTheImageAndNotTheGround) {
  const RpcCamera cam = dsmplan::read_rpc_camera(data("pre_event_img1.tif"));
  const RpcCamera window = cam.crop(200, 300);
  const GeoPoint g = cam.localize({500.5, 600.5}, 600);
  const PixelPoint p = window.project(g);
  EXPECT_NEAR(p.col, 300.5, 1e-9);
  EXPECT_NEAR(p.row, 300.5, 1e-9);
}

TEST(Rpc, GeoTiffRpcTagsReadAsTheGeom) {
  // The .geom's numbers written into a GeoTIFF's RPC tags by GDAL, read back through GDAL's RPC
  // domain: the same model (to the 15 significant digits GDAL prints).
  const RpcModel geom = dsmplan::read_ossim_geom(data("pre_event_img2.geom"));
  Scratch scratch;
  const std::string tif = scratch.path("with_rpc.tif");
  {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    ASSERT_NE(driver, nullptr);
    GDALDataset* ds = driver->Create(tif.c_str(), 8, 8, 1, GDT_UInt16, nullptr);
    ASSERT_NE(ds, nullptr);
    GDALRPCInfoV2 info = gdal_rpc_info(geom);
    char** md = RPCInfoV2ToMD(&info);
    ds->SetMetadata(md, "RPC");
    CSLDestroy(md);
    GDALClose(ds);
  }
  const RpcCamera cam = dsmplan::read_rpc_camera(tif);  // no .geom beside it: GDAL's domain
  EXPECT_EQ(cam.sensor_col(), 0);
  const RpcCamera reference(geom);
  for (const GeoPoint& g : ground_grid(RpcCamera(geom, 12099, 5109), 4)) {
    const PixelPoint a = cam.project(g), b = reference.project(g);
    EXPECT_NEAR(a.col, b.col, 1e-6);
    EXPECT_NEAR(a.row, b.row, 1e-6);
  }
}

// --- The half-pixel convention of the crops' offsets, proven on the pairs.
//
// The two images of a pair see the same ground, so a feature at pA in image A appears in image B
// on the RPC epipolar curve h -> B.project(A.localize(pA, h)), up to the pair's relative pointing
// error (small for two images of one pass: the same orbit and attitude model, a minute apart).
// Tie points found by correlation (13 x 13 normalised cross-correlation, searched along the curve
// and across it, refined to 0.05 px) measure the distance across the curve. Along-track stereo
// has its parallax along the rows, so the distance across the curve is mostly in columns: a
// misread half pixel in a column offset moves every tie point by about 0.5 px across the curve.

struct Picture {
  int width = 0, height = 0;
  std::vector<float> v;
  // Bilinear value at a GDAL position (pixel centres at i + 0.5); false outside.
  bool at(double col, double row, float& out) const {
    const double x = col - 0.5, y = row - 0.5;
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    if (x0 < 0 || y0 < 0 || x0 + 1 >= width || y0 + 1 >= height) return false;
    const double fx = x - x0, fy = y - y0;
    const float* p = &v[static_cast<size_t>(y0) * width + x0];
    out = static_cast<float>((1 - fy) * ((1 - fx) * p[0] + fx * p[1]) + fy * ((1 - fx) * p[width] + fx * p[width + 1]));
    return true;
  }
};

Picture read_picture(const std::string& path) {
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(path.c_str(), GA_ReadOnly));
  EXPECT_NE(ds, nullptr) << path;
  Picture p;
  if (!ds) return p;
  p.width = ds->GetRasterXSize(), p.height = ds->GetRasterYSize();
  p.v.resize(static_cast<size_t>(p.width) * p.height);
  EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, p.width, p.height, p.v.data(), p.width, p.height, GDT_Float32,
                                           0, 0, nullptr),
            CE_None);
  GDALClose(ds);
  return p;
}

constexpr int kHalf = 6;  // 13 x 13 patches

// NCC of A's patch (mean-free, unit norm, given) against B's patch centred at (col, row).
double ncc(const std::vector<double>& a, const Picture& B, double col, double row) {
  std::vector<double> b;
  b.reserve(a.size());
  double mean = 0;
  for (int dy = -kHalf; dy <= kHalf; ++dy)
    for (int dx = -kHalf; dx <= kHalf; ++dx) {
      float value;
      if (!B.at(col + dx, row + dy, value)) return -1;
      b.push_back(value), mean += value;
    }
  mean /= static_cast<double>(b.size());
  double dotp = 0, norm = 0;
  for (size_t i = 0; i < b.size(); ++i) dotp += a[i] * (b[i] - mean), norm += (b[i] - mean) * (b[i] - mean);
  return norm > 0 ? dotp / std::sqrt(norm) : -1;
}

struct TieResiduals {
  std::vector<double> across;             // signed distance across the epipolar curve, px
  double normal_col = 0, normal_row = 0;  // the unit normal of the curve (direction of `across`)
  double px_per_m = 0;                    // the curve's length per metre of height
};

TieResiduals tie_point_residuals(const std::string& a_name, const std::string& b_name) {
  const RpcCamera camA = dsmplan::read_rpc_camera(data(a_name + ".tif")),
                  camB = dsmplan::read_rpc_camera(data(b_name + ".tif"));
  const Picture A = read_picture(data(a_name + ".tif")), B = read_picture(data(b_name + ".tif"));
  TieResiduals out;
  const double h0 = 400, h1 = 1000;  // ellipsoidal heights searched (the city lies at ~500-800 m)
  for (int j = 0; j < 8; ++j)
    for (int i = 0; i < 8; ++i) {
      const PixelPoint pa{150.5 + 100 * i, 150.5 + 100 * j};
      std::vector<double> a;
      double mean = 0;
      for (int dy = -kHalf; dy <= kHalf; ++dy)
        for (int dx = -kHalf; dx <= kHalf; ++dx) {
          float value;
          A.at(pa.col + dx, pa.row + dy, value);
          a.push_back(value), mean += value;
        }
      mean /= static_cast<double>(a.size());
      double norm = 0;
      for (double& x : a) x -= mean, norm += x * x;
      if (norm < 1e-6 * static_cast<double>(a.size()) * 100) continue;  // flat patch: no texture
      for (double& x : a) x /= std::sqrt(norm);
      auto curve = [&](double h) { return camB.project(camA.localize(pa, h)); };
      const PixelPoint e0 = curve(h0), e1 = curve(h1);
      const double len = std::hypot(e1.col - e0.col, e1.row - e0.row);
      const double nc = -(e1.row - e0.row) / len, nr = (e1.col - e0.col) / len;
      out.normal_col = nc, out.normal_row = nr, out.px_per_m = len / (h1 - h0);
      // Coarse: every 1.5 m of height (0.9 px along the curve), every pixel across; then fine
      // around the best: 0.1 m (0.06 px) along, 0.05 px across.
      double best = -2, best_h = 0, best_s = 0;
      auto search = [&](double ha, double hb, double hstep, double sa, double sb, double sstep) {
        for (double h = ha; h <= hb + 1e-9; h += hstep) {
          const PixelPoint q = curve(h);
          for (double s = sa; s <= sb + 1e-9; s += sstep) {
            const double c = ncc(a, B, q.col + s * nc, q.row + s * nr);
            if (c > best) best = c, best_h = h, best_s = s;
          }
        }
      };
      search(h0, h1, 1.5, -3, 3, 1);
      const double coarse_h = best_h, coarse_s = best_s;
      search(coarse_h - 1.5, coarse_h + 1.5, 0.1, coarse_s - 0.8, coarse_s + 0.8, 0.05);
      // Distinct and not at the edge of the search across.
      if (best > 0.9 && std::abs(best_s) < 2.5 && best_h > h0 + 5 && best_h < h1 - 5) out.across.push_back(best_s);
    }
  return out;
}

TEST(RpcSensorOffset, TiePointsMeetTheEpipolarCurveOnBothPairs) {
  // The pre-event crops are both Airbus's (origins .5), the post-event pair one of each (img1 .5,
  // img2 .0, written through GDAL): the post-event pair tests the reading of the one against the
  // other, the pre-event pair shows how small a pass's relative pointing error is.
  for (const auto& [a, b] : {std::pair<std::string, std::string>{"pre_event_img1", "pre_event_img2"},
                             std::pair<std::string, std::string>{"post_event_img1", "post_event_img2"}}) {
    const TieResiduals r = tie_point_residuals(a, b);
    ASSERT_GE(r.across.size(), 20u) << a;
    std::vector<double> sorted = r.across;
    std::sort(sorted.begin(), sorted.end());
    const double m = sorted[sorted.size() / 2];
    const double q1 = sorted[sorted.size() / 4], q3 = sorted[3 * sorted.size() / 4];
    std::printf(
        "%s / %s: %zu tie points (NCC > 0.9), distance across the epipolar curve: median %.3f px, "
        "quartiles %.3f %.3f (curve normal %.2f %.2f, %.2f px per m of height)\n",
        a.c_str(), b.c_str(), r.across.size(), m, q1, q3, r.normal_col, r.normal_row, r.px_per_m);
    EXPECT_LT(std::abs(m), 0.3) << a;
    // B's offset read half a pixel or a pixel otherwise (on both axes) moves B's curve by that
    // much: the tie points would lie off it by m + d (n_col + n_row).
    for (double d : {-1.0, -0.5, 0.5, 1.0}) {
      const double other = m + d * (r.normal_col + r.normal_row);
      std::printf("  B's offset %+.1f px: median distance %.3f px\n", d, other);
      EXPECT_GT(std::abs(other), std::abs(m) + 0.3) << a << " offset " << d;
    }
  }
}

// --- Bad input: one line naming the file and the key.

std::string geom_with(const std::string& key, const std::string& value) {
  std::string text = read_text(data("pre_event_img1.geom")), out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(key + ":", 0) == 0) {
      if (value.empty()) continue;  // drop the line
      line = key + ": " + value;
    }
    out += line + "\n";
  }
  return out;
}

TEST(RpcBadInput, GeomWithAMissingCoefficient) {
  Scratch scratch;
  const std::string path = scratch.path("missing.geom");
  write_text(path, geom_with("samp_den_coeff_07", ""));
  const std::string message = input_error([&] { dsmplan::read_ossim_geom(path); });
  EXPECT_EQ(message, path + ": samp_den_coeff_07: missing");
}

TEST(RpcBadInput, GeomWithANonNumericCoefficient) {
  Scratch scratch;
  const std::string path = scratch.path("nan.geom");
  write_text(path, geom_with("line_num_coeff_12", "1.2e-4x"));
  EXPECT_EQ(input_error([&] { dsmplan::read_ossim_geom(path); }),
            path + ": line_num_coeff_12: not a number: '1.2e-4x'");
  write_text(path, geom_with("lat_scale", "nan"));
  EXPECT_EQ(input_error([&] { dsmplan::read_ossim_geom(path); }), path + ": lat_scale: not a number: 'nan'");
  write_text(path, geom_with("height_scale", "0"));
  EXPECT_EQ(input_error([&] { dsmplan::read_ossim_geom(path); }), path + ": height_scale: is zero (a scale divides)");
  write_text(path, geom_with("polynomial_format", "A"));
  EXPECT_EQ(input_error([&] { dsmplan::read_ossim_geom(path); }),
            path + ": polynomial_format: is 'A'; only B (RPC00B) is read");
  // A long value is not echoed whole: the line stays short. A .geom over 1 MB is no .geom.
  write_text(path, geom_with("line_num_coeff_12", std::string(600000, '7') + "x"));
  const std::string long_value = input_error([&] { dsmplan::read_ossim_geom(path); });
  EXPECT_EQ(long_value, path + ": line_num_coeff_12: not a number: '" + std::string(40, '7') + "...'");
  write_text(path, geom_with("line_num_coeff_12", std::string(5 << 20, '7') + "x"));
  EXPECT_EQ(input_error([&] { dsmplan::read_ossim_geom(path); }),
            path + ": is 5.2 MB, more than an OSSIM .geom may be (at most 1.0 MB): is it the file meant?");
  const std::string message = input_error([&] { dsmplan::read_ossim_geom(scratch.path("none.geom")); });
  EXPECT_EQ(message, scratch.path("none.geom") + ": no such file");
  for (const std::string& m : {message}) EXPECT_EQ(m.find('\n'), std::string::npos);
}

TEST(RpcBadInput, ImageWithoutRpc) {
  // A GeoTIFF with neither RPC tags nor a .geom beside it (a copy of a crop without its .geom).
  Scratch scratch;
  const std::string tif = scratch.path("no_rpc.tif");
  fs::copy_file(data("post_event_img1.tif"), tif);
  EXPECT_EQ(input_error([&] { dsmplan::read_rpc_camera(tif); }),
            tif + ": has no RPC (no RPC tags, _RPC.TXT, .RPB or .geom beside it)");
  // A .geom beside it, but the crop's transform is not on the pixel grid.
  const std::string shifted = scratch.path("shifted.tif");
  {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    ASSERT_NE(driver, nullptr);
    GDALDataset* ds = driver->Create(shifted.c_str(), 8, 8, 1, GDT_UInt16, nullptr);
    ASSERT_NE(ds, nullptr);
    double gt[6] = {100.25, 1, 0, 50.5, 0, 1};
    ds->SetGeoTransform(gt);
    GDALClose(ds);
  }
  fs::copy_file(data("post_event_img1.geom"), scratch.path("shifted.geom"));
  EXPECT_EQ(input_error([&] { dsmplan::read_rpc_camera(shifted); }),
            shifted +
                ": transform: column origin 100.250000 is neither whole nor half: not a crop cut on the "
                "scene's pixel grid");
}

// --- dsmplan info on a satellite image: the camera beside the raster's numbers.

TEST(RpcInfo, DescribesTheCamera) {
  dsmplan::InfoOptions options;
  options.input = data("post_event_img2.tif");
  const dsmplan::RasterReport report = dsmplan::describe_raster(options);
  ASSERT_TRUE(report.rpc.has_value());
  EXPECT_EQ(report.rpc->source, data("post_event_img2.geom"));
  EXPECT_EQ(report.rpc->sensor_col, 12816);
  EXPECT_EQ(report.rpc->sensor_row, 7220);
  EXPECT_EQ(report.rpc->height_min, -50);
  EXPECT_EQ(report.rpc->height_max, 1000);
  // The corners at 475 m: a 1000 x 1000 crop of 0.5 m pixels is about 500 m a side.
  const auto& c = report.rpc->corners;
  const double side = metres({c[0].lon, c[0].lat, 0}, {c[1].lon, c[1].lat, 0});
  EXPECT_GT(side, 400);
  EXPECT_LT(side, 650);
  const dsmplan::Json json = dsmplan::to_json(report);
  EXPECT_EQ(json["rpc"]["sensor_offset"][0], 12816);
  EXPECT_EQ(json["rpc"]["footprint"]["corners"].size(), 4u);
  EXPECT_NE(dsmplan::to_text(report).find("RPC:         from " + data("post_event_img2.geom") +
                                          ", sensor offset 12816 7220 px"),
            std::string::npos)
      << dsmplan::to_text(report);
}

TEST(RpcInfo, ADsmHasNoCameraAndABadGeomIsOneLine) {
  dsmplan::InfoOptions options;
  options.input = std::string(DSMPLAN_DATA_DIR) + "/nrw-dom1/nrw_dom1_crop500m_1m.tif";
  const dsmplan::RasterReport report = dsmplan::describe_raster(options);
  EXPECT_FALSE(report.rpc.has_value());
  EXPECT_TRUE(dsmplan::to_json(report)["rpc"].is_null());
  Scratch scratch;
  options.input = scratch.path("crop.tif");
  fs::copy_file(data("pre_event_img1.tif"), options.input);
  write_text(scratch.path("crop.geom"), geom_with("long_scale", ""));
  EXPECT_EQ(input_error([&] { dsmplan::describe_raster(options); }),
            scratch.path("crop.geom") + ": long_scale: missing");
}

}  // namespace
