// RPC cameras (dsmplan/rpc.hpp, issue 17): points per second of ground -> image
// (project) and image -> ground at a given height (localize, Newton), dsmplan's beside GDAL's RPC
// transformer (GDALCreateRPCTransformerV2: the same RPC, GDAL's evaluation and its own iterative
// inverse), on the pre-event Pléiades crop (data/pleiades-kahramanmaras/pre_event_img1), one core.
//
// Paired, interleaved rounds (each round runs every variant once, in the same order); the table
// gives the median over the rounds with its min-max and each round's 1-minute load average, and
// dsmplan against GDAL as the median (min-max) of the per-round ratios. Never a best-of.
// It also reports the largest disagreement between the two on the points timed.
//   build/bench/bench_rpc [ROUNDS=7]
#include <gdal_alg.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/rpc.hpp"
#include "dsmplan/rpc_io.hpp"
#include "gdal_rpc_oracle.hpp"

namespace {

using dsmplan::GeoPoint;
using dsmplan::PixelPoint;

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::max(5, std::atoi(argv[1])) : 7;
  const dsmplan::RpcCamera cam =
      dsmplan::read_rpc_camera(DSMPLAN_DATA_DIR "/pleiades-kahramanmaras/pre_event_img1.tif");
  // GDAL's transformer knows only the scene: give it the scene's positions (crop offset added).
  const dsmplan::RpcCamera scene(cam.model());
  void* gdal = gdal_rpc_transformer(cam.model());

  // 100 x 100 pixels over the crop at three heights.
  std::vector<PixelPoint> pixels;
  std::vector<double> heights;
  for (double h : {300.0, 600.0, 900.0})
    for (int j = 0; j < 100; ++j)
      for (int i = 0; i < 100; ++i) pixels.push_back({10.0 * i + 5, 10.0 * j + 5}), heights.push_back(h);
  const size_t n = pixels.size();
  std::vector<GeoPoint> ground(n);
  for (size_t k = 0; k < n; ++k) ground[k] = cam.localize(pixels[k], heights[k]);

  std::vector<double> t_project, t_project_gdal, t_localize, t_localize_gdal;
  double worst_project = 0, worst_localize = 0, sink = 0;
  std::vector<double> x(n), y(n), z(n);
  std::vector<int> ok(n);
  for (int r = 0; r < rounds; ++r) {
    auto start = std::chrono::steady_clock::now();
    for (size_t k = 0; k < n; ++k) {
      const PixelPoint p = cam.project(ground[k]);
      sink += p.col;
    }
    t_project.push_back(bench::seconds_since(start));

    for (size_t k = 0; k < n; ++k) x[k] = ground[k].lon, y[k] = ground[k].lat, z[k] = ground[k].height;
    start = std::chrono::steady_clock::now();
    GDALRPCTransform(gdal, TRUE, static_cast<int>(n), x.data(), y.data(), z.data(), ok.data());
    t_project_gdal.push_back(bench::seconds_since(start));
    for (size_t k = 0; k < n; ++k) {
      const PixelPoint p = cam.project(ground[k]);
      worst_project =
          std::max(worst_project, std::hypot(p.col - (x[k] - cam.sensor_col()), p.row - (y[k] - cam.sensor_row())));
    }

    start = std::chrono::steady_clock::now();
    for (size_t k = 0; k < n; ++k) sink += cam.localize(pixels[k], heights[k]).lon;
    t_localize.push_back(bench::seconds_since(start));

    for (size_t k = 0; k < n; ++k)
      x[k] = pixels[k].col + cam.sensor_col(), y[k] = pixels[k].row + cam.sensor_row(), z[k] = heights[k];
    start = std::chrono::steady_clock::now();
    GDALRPCTransform(gdal, FALSE, static_cast<int>(n), x.data(), y.data(), z.data(), ok.data());
    t_localize_gdal.push_back(bench::seconds_since(start));
    for (size_t k = 0; k < n; ++k) {
      if (!ok[k]) continue;
      const double R = 6378137.0, rad = M_PI / 180;
      const double dx = (x[k] - ground[k].lon) * rad * R * std::cos(ground[k].lat * rad),
                   dy = (y[k] - ground[k].lat) * rad * R;
      worst_localize = std::max(worst_localize, std::hypot(dx, dy));
    }
    std::printf("round %d: load %s\n", r + 1, bench::load_average().c_str());
  }
  GDALDestroyRPCTransformer(gdal);

  auto row = [&](const char* what, std::vector<double> t) {
    std::sort(t.begin(), t.end());
    const double med = t[t.size() / 2];
    std::printf("| %-28s | %12.0f | %10.3f (%.3f-%.3f) |\n", what, static_cast<double>(n) / med, med * 1e3,
                t.front() * 1e3, t.back() * 1e3);
  };
  std::printf("\n%zu points (100 x 100 pixels of pre_event_img1 at 300, 600, 900 m), %d rounds, one core, %s\n\n", n,
              rounds, bench::cpu_model().c_str());
  std::printf("| %-28s | %12s | %s |\n", "operation", "points/s", "ms per round, median (min-max)");
  std::printf("|---|---:|---|\n");
  row("project, dsmplan", t_project);
  row("project, GDAL", t_project_gdal);
  row("localize, dsmplan (Newton)", t_localize);
  row("localize, GDAL", t_localize_gdal);
  const auto per_round = [](const std::vector<double>& gdal, const std::vector<double>& ours) {
    bench::Samples g, o;
    for (double t : gdal) g.add(t);
    for (double t : ours) o.add(t);
    return bench::ratios(g, o).text("%.2f");
  };
  std::printf(
      "\nGDAL's seconds / dsmplan's in the same round (> 1: dsmplan faster), median (min-max): project %s, "
      "localize %s\n",
      per_round(t_project_gdal, t_project).c_str(), per_round(t_localize_gdal, t_localize).c_str());
  std::printf("\nlargest difference: project %.2e px, localize %.3g m (GDAL's inverse stops at its own tolerance)\n",
              worst_project, worst_localize);
  return sink == 12345.678 ? 1 : 0;
}
