// The satellite rows of the stereo benchmark (issue 17, point 3): satellite_stereo_job() (what
// `dsmplan stereo IMG1 IMG2` runs) on the whole Pléiades crops of data/pleiades-kahramanmaras, the
// pre-event and the post-event pair, at 1 m over their common footprint (the intersection of the
// two pairs' own footprints, so that the DSMs share one grid). Rounds are interleaved (each round
// runs both pairs once); each figure is the median over the rounds with its min-max, never a
// best-of, and each round's 1-minute load average is printed. After the rounds, the two DSMs of the
// last round are compared (no ground truth exists): median |pre - post| over cells valid in both,
// the share over 1 m, and each DSM's completeness.
#include "stereo_satellite.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/satellite_stereo_job.hpp"

namespace {

struct Pair {
  const char* name;
  std::string a, b;
};

std::string data(const std::string& name) { return DSMPLAN_DATA_DIR "/pleiades-kahramanmaras/" + name; }

struct Spread {
  double median = 0, min = 0, max = 0;
};
Spread spread(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return {v[v.size() / 2], v.front(), v.back()};
}

std::string cell(const std::vector<double>& v) {
  const Spread s = spread(v);
  char text[64];
  std::snprintf(text, sizeof text, "%.2f (%.2f-%.2f)", s.median, s.min, s.max);
  return text;
}

}  // namespace

int run_satellite_stereo_bench(int rounds) {
  const Pair pairs[2] = {{"pre-event", data("pre_event_img1.tif"), data("pre_event_img2.tif")},
                         {"post-event", data("post_event_img1.tif"), data("post_event_img2.tif")}};
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "dsmplan_bench_stereo_satellite";
  std::filesystem::create_directories(dir);
  std::printf("# dsmplan stereo IMG1 IMG2 on the Pléiades crops (1000 x 1000 px, 0.5 m), DSM at 1 m\n");
  std::printf("# CPU: %s, %u threads; %d rounds, interleaved; median (min-max) over the rounds\n",
              bench::cpu_model().c_str(), std::max(1u, std::thread::hardware_concurrency()), rounds);
  try {
    // The common footprint: each pair's own bounds (from a first, untimed run), intersected.
    std::array<double, 4> common{-1e300, -1e300, 1e300, 1e300};
    for (const Pair& p : pairs) {
      dsmplan::SatelliteStereoOptions o;
      o.images = {p.a, p.b};
      o.output = (dir / "footprint.tif").string();
      o.resolution = 1;
      const auto r = dsmplan::satellite_stereo_job(o);
      common = {std::max(common[0], r.bounds[0]), std::max(common[1], r.bounds[1]), std::min(common[2], r.bounds[2]),
                std::min(common[3], r.bounds[3])};
    }
    std::printf("# common footprint (EPSG:32637): %.0f,%.0f,%.0f,%.0f (%.0f x %.0f m)\n", common[0], common[1],
                common[2], common[3], common[2] - common[0], common[3] - common[1]);
    const char* stages[] = {"read",        "survey",    "rectify", "pointing", "match",
                            "triangulate", "transform", "fuse",    "write",    "total"};
    std::vector<std::vector<std::vector<double>>> seconds(2, std::vector<std::vector<double>>(10));
    std::vector<std::string> loads;
    std::array<dsmplan::SatelliteStereoReport, 2> last;
    for (int round = 0; round < rounds; ++round) {
      loads.push_back(bench::load_average());
      for (int k = 0; k < 2; ++k) {
        dsmplan::SatelliteStereoOptions o;
        o.images = {pairs[k].a, pairs[k].b};
        o.output = (dir / (std::string(pairs[k].name) + ".tif")).string();
        o.resolution = 1;
        o.bounds = common;
        std::filesystem::remove(o.output);
        const auto start = std::chrono::steady_clock::now();
        last[k] = dsmplan::satellite_stereo_job(o);
        const double wall = bench::seconds_since(start);
        const auto& r = last[k];
        const double values[10] = {
            r.seconds_read,        r.seconds_survey,    r.seconds_rectify, r.seconds_pointing, r.seconds_match,
            r.seconds_triangulate, r.seconds_transform, r.seconds_fuse,    r.seconds_write,    wall};
        for (int s = 0; s < 10; ++s) seconds[k][s].push_back(values[s]);
      }
    }
    std::printf("\n| pair | cells | points |");
    for (const char* s : stages) std::printf(" %s s |", s);
    std::printf(" cells/s |\n|---|---:|---:|");
    for (int s = 0; s < 10; ++s) std::printf("---:|");
    std::printf("---:|\n");
    for (int k = 0; k < 2; ++k) {
      const auto& r = last[k];
      const double cells = static_cast<double>(r.width) * r.height;
      std::vector<double> rate;
      for (double t : seconds[k][9]) rate.push_back(cells / t);
      const Spread s = spread(rate);
      std::printf("| %s | %s | %s |", pairs[k].name, bench::grouped(static_cast<size_t>(cells)).c_str(),
                  bench::grouped(r.points).c_str());
      for (int st = 0; st < 10; ++st) std::printf(" %s |", cell(seconds[k][st]).c_str());
      std::printf(" %.0f (%.0f-%.0f) |\n", s.median, s.min, s.max);
    }
    std::printf("\n1-minute load average at the start of each round:");
    for (const std::string& l : loads) std::printf(" %s", l.c_str());
    std::printf("\n");
    // The checks on the two DSMs of the last round.
    const dsmplan::Grid pre = dsmplan::read_raster((dir / "pre-event.tif").string());
    const dsmplan::Grid post = dsmplan::read_raster((dir / "post-event.tif").string());
    std::vector<double> diff;
    for (size_t i = 0; i < pre.z.size() && i < post.z.size(); ++i)
      if (!std::isnan(pre.z[i]) && !std::isnan(post.z[i])) diff.push_back(std::abs(double(pre.z[i]) - post.z[i]));
    size_t over1 = 0;
    for (double d : diff) over1 += d > 1;
    std::sort(diff.begin(), diff.end());
    std::printf(
        "\npre vs post over the common footprint: %zu cells valid in both (of %zu); median |difference| %.2f m, "
        "p90 %.2f m, %.1f %% over 1 m; completeness pre %.1f %%, post %.1f %%\n",
        diff.size(), pre.z.size(), diff.empty() ? NAN : diff[diff.size() / 2],
        diff.empty() ? NAN : diff[diff.size() * 9 / 10], diff.empty() ? NAN : 100.0 * over1 / diff.size(),
        100 * last[0].completeness, 100 * last[1].completeness);
    for (int k = 0; k < 2; ++k)
      for (const auto& p : last[k].pairs)
        std::printf(
            "%s: scene heights searched %.0f..%.0f m (%zu survey tie points), %zu tiles (%zu with the pointing "
            "corrected), %zu tie points, %.1f %% of the tiles' pixels matched\n",
            pairs[k].name, p.height_min, p.height_max, p.survey_tie_points, p.tiles, p.tiles_pointing_corrected,
            p.tie_points, p.tile_pixels ? 100.0 * p.matched_pixels / p.tile_pixels : 0.0);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 1;
  }
  std::filesystem::remove_all(dir);
  return 0;
}
