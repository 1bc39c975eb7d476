// bench_stereo's frame-camera table (issue 16 point 3(b)): aerial views rendered by ray casting
// 160 m x 160 m of the real NRW DSM (bench/aerial_scene.hpp: cells as solid columns, a texture
// varying in x, y and z), 480 x 480 pixels from 150 m over the lowest cell (0.25 m a pixel on
// the ground), back to a 1 m DSM by stereo_dsm() (dsmplan/stereo_frames.hpp) over the
// central 64 m x 64 m, against the DSM they were rendered from: completeness, median |error|,
// share off by more than 1 m and 3 m. Each set-up runs with dsmplan's SGM and with OpenCV's
// StereoSGBM (MODE_HH and MODE_SGBM_3WAY, bench/sgbm_matcher.hpp) in the same pipeline: the same
// rectification, triangulation and median fusion, only the matcher differs. The height range
// given is the truth's (lowest and highest cell).
//
// Timing: the whole stereo_dsm() per set-up, the matchers in turn (A B C A B C ...) for `rounds`
// rounds after one untimed run (whose DSM is the one scored: the runs are deterministic); the
// median with min-max, the match stage's median, the 1-minute load before and after, and each
// OpenCV mode against dsmplan as the median (min-max) of the per-round ratios of the match stage's
// seconds (theirs / dsmplan's). Never a best-of.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "aerial_blocks.hpp"
#include "aerial_scene.hpp"
#include "bench_kit.hpp"
#include "bench_stereo.hpp"
#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/stereo_frames.hpp"
#include "sgbm_matcher.hpp"

namespace bench {
namespace {

using dsmplan::FrameCamera;
using dsmplan::GreyImage;
using dsmplan::Grid;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct SetUp {
  std::string name;
  std::vector<FrameCamera> cameras;
  std::vector<unsigned> seeds;
  double noise = 1.5;
  std::string pairs = "auto";
};

struct Matcher {
  std::string name;
  dsmplan::DenseMatcher match;  // empty: dsmplan's SGM
};

// dsmplan's SGM, then OpenCV's MODE_HH (and MODE_SGBM_3WAY with `three_way`) where the build has it.
std::vector<Matcher> matchers_to_compare(bool three_way) {
  std::vector<Matcher> matchers{{"dsmplan SGM", {}}};
#ifdef DSMPLAN_HAVE_OPENCV
  matchers.push_back({"OpenCV MODE_HH", sgbm_matcher(sgbm_hh)});
  if (three_way) matchers.push_back({"OpenCV MODE_SGBM_3WAY", sgbm_matcher(sgbm_3way)});
#else
  (void)three_way;
  std::printf("OpenCV not found at configure time: dsmplan alone (apt-get install libopencv-dev)\n");
#endif
  return matchers;
}

}  // namespace

void frame_camera_table(int rounds) {
  const Grid nrw = dsmplan::read_raster(DSMPLAN_DATA_DIR "/nrw-dom1/nrw_dom1_crop500m_1m.tif");
  const int n = 160, m = 64;
  const int c0 = nrw.width / 2 - n / 2, r0 = nrw.height / 2 - n / 2;
  const Grid scene_dsm = aerial::crop(nrw, c0, r0, n);
  const Grid truth = aerial::crop(nrw, c0 + (n - m) / 2, r0 + (n - m) / 2, m);
  const auto [lo_it, hi_it] = std::minmax_element(scene_dsm.z.begin(), scene_dsm.z.end());
  const double lo = *lo_it, hi = *hi_it;
  const aerial::ColumnScene scene{scene_dsm, lo, hi};
  const double xc = truth.x0 + m / 2.0, yc = truth.y0 - m / 2.0, zc = lo + 150;
  const int size = 480;
  const double f = 600;  // 0.25 m a pixel at 150 m
  using aerial::nadir_camera;
  const FrameCamera A = nadir_camera(size, f, {xc - 20, yc, zc}), B = nadir_camera(size, f, {xc + 20, yc, zc}),
                    M = nadir_camera(size, f, {xc, yc, zc}), C = nadir_camera(size, f, {xc - 20, yc + 30, zc}),
                    D = nadir_camera(size, f, {xc + 20, yc + 30, zc});
  // 40 m east of M, turned 15 degrees back towards the centre.
  const FrameCamera T = nadir_camera(size, f, {xc + 40, yc, zc}, 0, 0.2618);
  const FrameCamera Ad = nadir_camera(size, f, {xc - 20, yc, zc}, 0.01, -0.01, -0.12, 0.001),
                    Bd = nadir_camera(size, f, {xc + 20, yc, zc}, -0.01, 0.02, -0.12, 0.001);
  const std::vector<SetUp> setups{
      {"nadir strip, 2 views (B/H 0.27)", {A, B}, {1, 2}},
      {"nadir strip, 3 views", {A, M, B}, {1, 3, 2}},
      {"2 strips, 4 views (30 m apart)", {A, B, C, D}, {1, 2, 4, 5}},
      {"nadir + 15 degrees tilted (B/H 0.27)", {M, T}, {3, 6}},
      {"2 views, lens distortion k1 -0.12", {Ad, Bd}, {7, 8}},
      {"2 views, noise sigma 6 grey levels", {A, B}, {9, 10}, 6.0},
  };
  std::printf(
      "\nFrame cameras: NRW DSM %d m x %d m (heights %.1f..%.1f m) rendered from %.0f m over its lowest cell, "
      "%d x %d px, %.2f m a pixel; DSM 1 m over the central %d m x %d m\n",
      n, n, lo, hi, zc - lo, size, size, (zc - lo) / f, m, m);

  const std::vector<Matcher> matchers = matchers_to_compare(true);

  struct Row {
    std::string setup, matcher;
    std::size_t pairs = 0;
    aerial::DsmErrors errors;
    std::vector<double> seconds, match_seconds;
  };
  std::vector<Row> rows;
  const std::string load_before = load_average();
  for (const SetUp& s : setups) {
    const auto render_start = std::chrono::steady_clock::now();
    std::vector<GreyImage> images;
    for (std::size_t i = 0; i < s.cameras.size(); ++i)
      images.push_back(aerial::render(scene, s.cameras[i], s.seeds[i], s.noise));
    dsmplan::PairSelectionOptions selection;
    selection.ground_height = lo;
    const auto pairs = dsmplan::select_pairs_auto(s.cameras, selection);
    std::printf("  %s: %zu pairs, rendered in %.1f s\n", s.name.c_str(), pairs.size(), seconds_since(render_start));
    dsmplan::FrameStereoOptions options;
    options.rectify.min_height = lo;
    options.rectify.max_height = hi;
    const std::size_t first = rows.size();
    const auto run = [&](const Matcher& matcher, Row& row, bool score) {
      options.matcher = matcher.match;
      Grid dsm = dsmplan::dsm_grid({truth.x0, truth.y1(), truth.x1(), truth.y0}, 1.0);
      const auto start = std::chrono::steady_clock::now();
      const dsmplan::FrameStereoStats stats = dsmplan::stereo_dsm(s.cameras, images, pairs, dsm, options);
      const double seconds = seconds_since(start);
      if (score) {
        row.errors = aerial::dsm_errors(dsm, truth);
        row.pairs = stats.pairs;
      } else {
        row.seconds.push_back(seconds);
        row.match_seconds.push_back(stats.seconds_match);
      }
    };
    for (const Matcher& matcher : matchers) {
      rows.push_back({s.name, matcher.name, 0, {}, {}, {}});
      run(matcher, rows.back(), true);
    }
    for (int round = 0; round < rounds; ++round)
      for (std::size_t k = 0; k < matchers.size(); ++k) run(matchers[k], rows[first + k], false);
  }
  const std::string load_after = load_average();

  std::printf("\n%d interleaved rounds per set-up, load (1 min) %s before, %s after\n\n", rounds, load_before.c_str(),
              load_after.c_str());
  std::printf(
      "| set-up | pairs | matcher | filled | median abs. error | > 1 m | > 3 m | pipeline s, median (min–max) | "
      "match s, median | match s / dsmplan's, per round |\n|---|---:|---|---:|---:|---:|---:|---|---:|---|\n");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    const Row& ours = rows[i - i % matchers.size()];  // each set-up's rows start with dsmplan's
    Samples mine, theirs;
    for (double t : ours.match_seconds) mine.add(t);
    for (double t : r.match_seconds) theirs.add(t);
    const auto [fastest, slowest] = std::minmax_element(r.seconds.begin(), r.seconds.end());
    std::printf("| %s | %zu | %s | %.1f %% | %.2f m | %.1f %% | %.1f %% | %.2f (%.2f–%.2f) | %.2f | %s |\n",
                r.setup.c_str(), r.pairs, r.matcher.c_str(), 100 * r.errors.completeness, r.errors.median,
                100 * r.errors.over1, 100 * r.errors.over3, median(r.seconds), *fastest, *slowest,
                median(r.match_seconds), &r == &ours ? "1" : ratios(theirs, mine).text("%.2f").c_str());
  }
  std::printf(
      "\nOpenCV settings (bench_sgm's, tuned on Aloe): HH blockSize %d P1 %d P2 %d; 3WAY blockSize %d P1 %d P2 %d; "
      "uniquenessRatio 10, disp12MaxDiff 1, preFilterCap 63, speckle 100 px / 1 px\n",
#ifdef DSMPLAN_HAVE_OPENCV
      sgbm_hh.block_size, sgbm_hh.p1, sgbm_hh.p2, sgbm_3way.block_size, sgbm_3way.p1, sgbm_3way.p2
#else
      0, 0, 0, 0, 0, 0
#endif
  );
}

namespace {
// The two DSMs the blocks are rendered from: the NRW tile, and Delft's AHN3 LiDAR gridded at 1 m
// (median), as the test grids it.
struct Cities {
  Grid nrw, delft;
};
Cities block_cities() {
  std::vector<dsmplan::PointCloud> clouds{dsmplan::read_las(DSMPLAN_DATA_DIR "/delft-ahn3/ahn3_cropped_1.las"),
                                          dsmplan::read_las(DSMPLAN_DATA_DIR "/delft-ahn3/ahn3_cropped_2.las")};
  dsmplan::GridPointsOptions gridding;
  gridding.resolution = 1.0;
  return {dsmplan::read_raster(DSMPLAN_DATA_DIR "/nrw-dom1/dom1_32_356_5699_1_nw_2020.tif"),
          dsmplan::grid_points(clouds, gridding)};
}
}  // namespace

// Issue 34 point 5: the blocks of point 2 (bench/aerial_blocks.hpp: both cities, base/height
// 0.2-0.8, tilts to 15 degrees, 2-8 views, two strips, a low sun, gains, noise), each run as
// `dsmplan stereo` runs a block without a height range: the range estimated from the images
// (estimate_height_range()), the pairs chosen by select_pairs_auto() on its lowest plane, then
// stereo_dsm() once with dsmplan's SGM and once with OpenCV's MODE_HH in its place (the same
// range, pairs, rectification, triangulation and fusion). Scored at 1 m over the cells two views
// see (aerial::seen_by_two(): what stereo can measure at all), against the DSM rendered.
void block_table(int rounds) {
  const Cities cities = block_cities();

  const std::vector<Matcher> matchers = matchers_to_compare(false);
  struct Row {
    std::string setup, matcher;
    std::size_t pairs = 0;
    aerial::DsmErrors errors;
    std::vector<double> seconds;
  };
  std::vector<Row> rows;
  const std::string load_before = load_average();
  for (const aerial::BlockSetup& s : aerial::block_setups()) {
    const aerial::Block b = aerial::render_block(s, s.delft ? cities.delft : cities.nrw);
    const Grid seen = aerial::seen_by_two(b);
    const std::array<double, 4> bounds = aerial::seen_bounds(seen);
    const dsmplan::HeightRangeEstimate range =
        dsmplan::estimate_height_range(b.cameras, b.images, dsmplan::height_range_pairs(b.cameras));
    dsmplan::PairSelectionOptions selection;
    selection.ground_height = range.min_height;
    const auto pairs = dsmplan::select_pairs_auto(b.cameras, selection);
    dsmplan::FrameStereoOptions options;
    options.rectify.min_height = range.min_height;
    options.rectify.max_height = range.max_height;
    const std::size_t first = rows.size();
    const auto run = [&](const Matcher& matcher, Row& row, bool score) {
      options.matcher = matcher.match;
      Grid dsm = dsmplan::dsm_grid(bounds, 1.0);
      const auto start = std::chrono::steady_clock::now();
      const dsmplan::FrameStereoStats stats = dsmplan::stereo_dsm(b.cameras, b.images, pairs, dsm, options);
      const double seconds = seconds_since(start);
      if (score) {
        row.errors = aerial::dsm_errors(dsm, seen);
        row.pairs = stats.pairs;
      } else {
        row.seconds.push_back(seconds);
      }
    };
    for (const Matcher& matcher : matchers) {
      rows.push_back({s.name, matcher.name, 0, {}, {}});
      run(matcher, rows.back(), true);
    }
    for (int round = 0; round < rounds; ++round)
      for (std::size_t k = 0; k < matchers.size(); ++k) run(matchers[k], rows[first + k], false);
    std::printf("  %s: %zu views, %zu pairs, range %.1f..%.1f m\n", s.name, b.cameras.size(), pairs.size(),
                range.min_height, range.max_height);
  }
  const std::string load_after = load_average();
  std::printf("\nBlocks of issue 34 point 2, %d interleaved rounds per set-up, load (1 min) %s before, %s after\n\n",
              rounds, load_before.c_str(), load_after.c_str());
  std::printf(
      "| set-up | pairs | matcher | filled | median abs. error | > 1 m | > 3 m | > 3 m too low | most too low | "
      "pipeline s, median (min–max) | s / dsmplan's, per round "
      "|\n|---|---:|---|---:|---:|---:|---:|---:|---:|---|---|\n");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    const Row& ours = rows[i - i % matchers.size()];
    Samples mine, theirs;
    for (double t : ours.seconds) mine.add(t);
    for (double t : r.seconds) theirs.add(t);
    const auto [fastest, slowest] = std::minmax_element(r.seconds.begin(), r.seconds.end());
    std::printf("| %s | %zu | %s | %.1f %% | %.2f m | %.1f %% | %.1f %% | %.2f %% | %.1f m | %.2f (%.2f–%.2f) | %s |\n",
                r.setup.c_str(), r.pairs, r.matcher.c_str(), 100 * r.errors.completeness, r.errors.median,
                100 * r.errors.over1, 100 * r.errors.over3, 100 * r.errors.low3, r.errors.lowest, median(r.seconds),
                *fastest, *slowest, &r == &ours ? "1" : ratios(theirs, mine).text("%.2f").c_str());
  }
}

// Issue 34 point 2: what the estimated height range costs the DSM. Each block of point 2 run as
// `dsmplan stereo` runs it (the range estimated, the pairs select_pairs_auto() chooses on its
// lowest plane, dsmplan's SGM) and again given the true range as CAMERAS.json would give it:
// the lowest and highest cell two views see (aerial::seen_by_two()), widened by 7.5 % of their
// difference and 1.5 m a side (the widest range the bound allows, centred on the truth).
// Scored as block_table() scores, and, apart, over the cells whose truth lies outside the
// estimate (the cells the estimate misses): how many each DSM has within 1 m of the truth.
void range_cost_table() {
  const Cities cities = block_cities();
  std::printf(
      "\n| set-up | estimated m | given m | pairs est. / given | filled est. / given | median est. / given | > 1 m "
      "est. / given | cells outside the estimate | of them filled, est. / given | within 1 m | over 1 m too low |\n"
      "|---|---|---|---|---|---|---|---:|---|---|---|\n");
  for (const aerial::BlockSetup& s : aerial::block_setups()) {
    const aerial::Block b = aerial::render_block(s, s.delft ? cities.delft : cities.nrw);
    const Grid seen = aerial::seen_by_two(b);
    const dsmplan::HeightRangeEstimate range =
        dsmplan::estimate_height_range(b.cameras, b.images, dsmplan::height_range_pairs(b.cameras));
    const aerial::RangeCost cost = aerial::range_cost(b, seen, range.min_height, range.max_height);
    const aerial::DsmErrors &e = cost.estimated.errors, &g = cost.given.errors;
    const aerial::Outside &missed = cost.missed, &recovered = cost.recovered;
    std::printf(
        "| %s | %.1f..%.1f | %.1f..%.1f | %zu / %zu | %.1f / %.1f %% | %.2f / %.2f m | %.1f / %.1f %% | %zu | %zu / "
        "%zu "
        "| %zu / %zu | %zu / %zu |\n",
        s.name, range.min_height, range.max_height, cost.given_low, cost.given_high, cost.estimated.pairs,
        cost.given.pairs, 100 * e.completeness, 100 * g.completeness, e.median, g.median, 100 * e.over1, 100 * g.over1,
        missed.cells, missed.filled, recovered.filled, missed.within_1m, recovered.within_1m, missed.low_by_1m,
        recovered.low_by_1m);
  }
}

}  // namespace bench
