// bench_stereo_block (issue 34, point 3): pair selection and the whole frame-camera pipeline on a
// block of many views. A block of S x S nadir views (default 10 x 10 = 100), 60 % forward and 30 %
// side overlap, 96 x 96 px from 150 m over the lowest cell of the NRW DSM (0.67 m a pixel; small
// images: the bench is about the pairs, not the matching), rendered by bench/aerial_scene.hpp.
//
// Per round, interleaved (A B C D A B C D ...):
//   A  select_pairs_auto(): ground boxes met by a sweep, each camera's 12 best candidates cut;
//   B  the selection it replaced, kept here as it was: every pair within the B/H bounds cut both
//      ways (O(n^2) footprint cuts);
//   C  the screening frame_dsm() does before any image is read: each chosen pair's rectified
//      geometry (pair_problem()) and its footprint on the lowest and highest plane;
//   D  stereo_dsm() over the chosen pairs into a 1 m DSM of the block (heights given: the truth's).
// Figures: the median (min-max) of the rounds, B/A as the median (min-max) of the per-round
// ratios, the 1-minute load at each round's start, and the peak resident memory (getrusage's
// ru_maxrss, a high-water mark of the whole process) after rendering, after the first round's selections and at
// the end. Then the selection alone (A, B) on blocks of 100, 400 and 1600 cameras (no images).
//
// Last, what a user waits for, as whole processes: the block written as 8-bit PNGs with its
// CAMERAS.json (with the truth's height range, and without: estimated), and `dsmplan stereo
// --cameras ... --res 1` run on each in turn (E F E F ...), wall and CPU seconds (wait4()) and
// the peak resident memory of the process, as GNU time's %M reports it (/usr/bin/time runs it: a
// child spawned from this process would inherit its high-water mark at execve()).
//
// Usage: bench_stereo_block [rounds=5] [side=10]
#include <gdal_priv.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "aerial_scene.hpp"
#include "bench_kit.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/stereo_frames.hpp"

namespace {

using dsmplan::FrameCamera;
using dsmplan::GreyImage;
using dsmplan::Grid;

double peak_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;  // kilobytes on Linux
}

// The selection before issue 34 (select_pairs.cpp at ff1691c), for the comparison: every pair
// within the B/H bounds has both footprints cut.
std::vector<std::pair<int, int>> every_pair_selection(const std::vector<FrameCamera>& cameras,
                                                      const dsmplan::PairSelectionOptions& options) {
  const int n = static_cast<int>(cameras.size());
  std::vector<std::vector<std::pair<double, int>>> partners(n);
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const double ratio = dsmplan::base_to_height(cameras[i], cameras[j], options.ground_height);
      if (!(ratio >= options.min_base_to_height && ratio <= options.max_base_to_height)) continue;
      const double overlap = std::min(dsmplan::footprint_overlap(cameras[i], cameras[j], options.ground_height),
                                      dsmplan::footprint_overlap(cameras[j], cameras[i], options.ground_height));
      if (!(overlap >= options.min_overlap)) continue;
      const double score = overlap * std::min(1.0, ratio / 0.3);
      partners[i].emplace_back(score, j);
      partners[j].emplace_back(score, i);
    }
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < n; ++i) {
    auto& mine = partners[i];
    const size_t kept = std::min(mine.size(), static_cast<size_t>(options.max_partners));
    std::partial_sort(mine.begin(), mine.begin() + kept, mine.end(), [](const auto& a, const auto& b) {
      return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
    for (size_t k = 0; k < kept; ++k) pairs.emplace_back(std::min(i, mine[k].second), std::max(i, mine[k].second));
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

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

// One whole process under /usr/bin/time: wall seconds, CPU seconds (user + sys, wait4()) and
// peak RSS (MiB, time's %M written to `rss_file`).
struct ProcessRun {
  double wall = 0, cpu = 0, rss_mib = 0;
};
ProcessRun run_process(const std::vector<std::string>& command, const std::string& rss_file) {
  std::vector<std::string> args{"/usr/bin/time", "-f", "%M", "-o", rss_file};
  args.insert(args.end(), command.begin(), command.end());
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const auto start = std::chrono::steady_clock::now();
  pid_t child = 0;
  if (posix_spawn(&child, argv[0], nullptr, nullptr, argv.data(), environ) != 0)
    throw std::runtime_error(args[0] + ": cannot be started");
  int status = 0;
  rusage usage{};
  wait4(child, &status, 0, &usage);
  ProcessRun run;
  run.wall = bench::seconds_since(start);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) throw std::runtime_error(command[0] + " failed");
  run.cpu = usage.ru_utime.tv_sec + usage.ru_stime.tv_sec + 1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
  double kilobytes = 0;
  std::ifstream(rss_file) >> kilobytes;
  run.rss_mib = kilobytes / 1024.0;
  return run;
}

constexpr int kSize = 96;
constexpr double kFootprint = 64;  // metres on the ground of one image's side, from 150 m

std::vector<FrameCamera> block(int side, double x0, double y0, double z) {
  const double f = kSize * 150 / kFootprint;
  std::vector<FrameCamera> cameras;
  for (int s = 0; s < side; ++s)
    for (int i = 0; i < side; ++i)
      cameras.push_back(aerial::nadir_camera(kSize, f, {x0 + 0.4 * kFootprint * i, y0 + 0.7 * kFootprint * s, z}));
  return cameras;
}

// The selection alone on a block of side x side cameras: A (and B when `brute`) interleaved.
void selection_only(int side, int rounds, bool brute) {
  const std::vector<FrameCamera> cameras = block(side, 0, 0, 150);
  dsmplan::PairSelectionOptions options;
  bench::Samples a, b;
  bench::LoadLog load;
  size_t chosen = 0, cut = 0;
  int most = 0;
  for (int r = 0; r < rounds; ++r) {
    load.note();
    dsmplan::PairSelectionStats stats;
    std::vector<std::pair<int, int>> pairs;
    a.add(bench::timed([&] { pairs = dsmplan::select_pairs_auto(cameras, options, &stats); }));
    chosen = pairs.size(), cut = stats.footprints_cut;
    std::vector<int> degree(cameras.size(), 0);
    for (const auto& [i, j] : pairs) ++degree[i], ++degree[j];
    most = *std::max_element(degree.begin(), degree.end());
    if (brute) b.add(bench::timed([&] { every_pair_selection(cameras, options); }));
  }
  std::printf("| %d | %zu | %d | %zu | %s | %s | %s | %s |\n", side * side, chosen, most, cut, a.text("%.4f").c_str(),
              brute ? b.text("%.3f").c_str() : "not run", brute ? bench::ratios(b, a).text("%.1f").c_str() : "",
              load.text().c_str());
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::atoi(argv[1]) : 5;
  const int side = argc > 2 ? std::atoi(argv[2]) : 10;
  if (rounds < 1 || side < 2) {
    std::fprintf(stderr, "usage: bench_stereo_block [rounds>=1] [side>=2]\n");
    return 2;
  }
  std::printf("bench_stereo_block: %s, load (1 min) %s\n", bench::cpu_model().c_str(), bench::load_average().c_str());
  const Grid nrw = dsmplan::read_raster(DSMPLAN_DATA_DIR "/nrw-dom1/nrw_dom1_crop500m_1m.tif");
  const auto [lo_it, hi_it] = std::minmax_element(nrw.z.begin(), nrw.z.end());
  const double lo = *lo_it, hi = *hi_it;
  // The block centred on the crop.
  const double width = 0.4 * kFootprint * (side - 1), height = 0.7 * kFootprint * (side - 1);
  const double xc = nrw.x0 + nrw.width * nrw.cell_x / 2, yc = nrw.y0 - nrw.height * nrw.cell_y / 2;
  const std::vector<FrameCamera> cameras = block(side, xc - width / 2, yc - height / 2, lo + 150);
  const aerial::ColumnScene scene{nrw, lo, hi};
  std::vector<GreyImage> images;
  const double render_seconds = bench::timed([&] {
    for (size_t i = 0; i < cameras.size(); ++i) images.push_back(aerial::render(scene, cameras[i], 1 + i));
  });
  const double rss_render = peak_mib();
  std::printf("%zu views of %d x %d px (heights %.1f..%.1f m), rendered in %.1f s; peak RSS %.1f MiB\n", cameras.size(),
              kSize, kSize, lo, hi, render_seconds, rss_render);

  dsmplan::PairSelectionOptions selection;
  selection.ground_height = lo;
  dsmplan::FrameStereoOptions options;
  options.rectify.min_height = lo;
  options.rectify.max_height = hi;
  // The DSM under the camera centres, on the crop's own 1 m cells (the truth is then its cells).
  const double bx = nrw.x0 + std::floor(xc - width / 2 - nrw.x0), by = nrw.y0 - std::floor(nrw.y0 - (yc + height / 2));
  const std::array<double, 4> bounds{bx, by - std::floor(height), bx + std::floor(width), by};
  bench::Samples select, brute, screen, match;
  bench::LoadLog load;
  std::vector<std::pair<int, int>> pairs, old_pairs;
  dsmplan::PairSelectionStats stats;
  double rss_select = 0;
  aerial::DsmErrors errors;
  size_t matched = 0, left_out = 0, windows = 0;
  for (int r = 0; r < rounds; ++r) {
    load.note();
    select.add(bench::timed([&] { pairs = dsmplan::select_pairs_auto(cameras, selection, &stats); }));
    brute.add(bench::timed([&] { old_pairs = every_pair_selection(cameras, selection); }));
    if (r == 0) rss_select = peak_mib();  // before the first stereo_dsm()
    screen.add(bench::timed([&] {
      for (const auto& [a, b] : pairs) {
        std::array<double, 4> box;
        if (!dsmplan::pair_problem(cameras[a], cameras[b], options.rectify).empty()) continue;
        dsmplan::footprint_box(cameras[a], cameras[b], lo, box);
        dsmplan::footprint_box(cameras[a], cameras[b], hi, box);
      }
    }));
    Grid dsm = dsmplan::dsm_grid(bounds, 1.0);
    dsmplan::FrameStereoStats result;
    match.add(bench::timed([&] { result = dsmplan::stereo_dsm(cameras, images, pairs, dsm, options); }));
    matched = result.pairs, left_out = result.pair_stats.size() - result.pairs, windows = 0;
    for (const auto& p : result.pair_stats) windows = std::max<size_t>(windows, p.windows);
    if (r == 0) {
      Grid truth = dsm;
      for (int row = 0; row < truth.height; ++row)
        for (int col = 0; col < truth.width; ++col) {
          const double x = truth.x0 + (col + 0.5) * truth.cell_x, y = truth.y0 - (row + 0.5) * truth.cell_y;
          const int c = static_cast<int>((x - nrw.x0) / nrw.cell_x), rr = static_cast<int>((nrw.y0 - y) / nrw.cell_y);
          truth.z[static_cast<size_t>(row) * truth.width + col] = nrw.z[static_cast<size_t>(rr) * nrw.width + c];
        }
      errors = aerial::dsm_errors(dsm, truth);
    }
  }
  size_t same = 0;
  for (const auto& p : pairs) same += std::count(old_pairs.begin(), old_pairs.end(), p);
  std::printf(
      "\n%d rounds (A B C D interleaved), load (1 min) at the rounds' starts %s\n"
      "pairs: %zu (%.2f a view; %zu of them also the every-pair selection's %zu), %zu boxes met, %zu footprints cut\n"
      "A select_pairs_auto:         %s s\n"
      "B every pair cut (before):   %s s; B/A per round %s\n"
      "C screening the pairs:       %s s\n"
      "D stereo_dsm, %zu pairs:      %s s (%zu left out, windows per pair at most %zu); DSM %.0f m x %.0f m: filled "
      "%.1f %%, "
      "median |error| %.2f m, > 1 m %.1f %%, > 3 m %.1f %%\n"
      "peak RSS: %.1f MiB after rendering, %.1f MiB after the selections, %.1f MiB at the end\n",
      rounds, load.text().c_str(), pairs.size(), double(pairs.size()) / cameras.size(), same, old_pairs.size(),
      stats.boxes_met, stats.footprints_cut, select.text("%.4f").c_str(), brute.text("%.3f").c_str(),
      bench::ratios(brute, select).text("%.1f").c_str(), screen.text("%.4f").c_str(), matched,
      match.text("%.2f").c_str(), left_out, windows, width, height, 100 * errors.completeness, errors.median,
      100 * errors.over1, 100 * errors.over3, rss_render, rss_select, peak_mib());

  std::printf("\nThe selection alone, 150 m up, 96 px cameras, %d rounds:\n\n", rounds);
  std::printf(
      "| views | pairs | most partners of a camera | footprints cut | A select_pairs_auto s | B every pair s | B/A | "
      "load |\n|---:|---:|---:|---:|---|---|---|---|\n");
  for (const int s : {10, 20, 40}) selection_only(s, rounds, true);
  std::printf("\npeak RSS at the end: %.1f MiB\n", peak_mib());

  // Whole processes: `dsmplan stereo --cameras` on the block's files.
  const std::string dir = std::filesystem::temp_directory_path() / ("bench_stereo_block_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  nlohmann::json given{{"crs", "EPSG:25832"}, {"height_range", {lo, hi}}, {"cameras", nlohmann::json::array()}};
  for (size_t i = 0; i < cameras.size(); ++i) {
    const std::string name = "img_" + std::to_string(i) + ".png";
    write_png(images[i], dir + "/" + name);
    given["cameras"].push_back(aerial::camera_json(cameras[i], name));
  }
  nlohmann::json estimated = given;
  estimated.erase("height_range");
  std::ofstream(dir + "/given.json") << given.dump(1);
  std::ofstream(dir + "/estimated.json") << estimated.dump(1);
  bench::Samples wall[2], cpu[2], rss[2];
  bench::LoadLog process_load;
  for (int r = 0; r < rounds; ++r) {
    process_load.note();
    for (int k = 0; k < 2; ++k) {
      const std::string json = dir + (k == 0 ? "/given.json" : "/estimated.json");
      const ProcessRun run = run_process({DSMPLAN_CLI, "stereo", "--cameras", json, "-o", dir + "/dsm.tif", "--res",
                                          "1", "--stats", dir + "/stats.json", "-q"},
                                         dir + "/rss.txt");
      wall[k].add(run.wall), cpu[k].add(run.cpu), rss[k].add(run.rss_mib);
      std::filesystem::remove(dir + "/dsm.tif");
      std::filesystem::rename(dir + "/stats.json", dir + "/stats_" + std::to_string(k) + ".json");
    }
  }
  std::printf(
      "\n`dsmplan stereo --cameras` on the %zu views as PNGs, --res 1, %d rounds (E F E F ...), load (1 min) %s\n\n"
      "| run | wall s | CPU s (user + sys) | peak RSS MiB |\n|---|---|---|---|\n",
      cameras.size(), rounds, process_load.text().c_str());
  for (int k = 0; k < 2; ++k)
    std::printf("| %s | %s | %s | %s |\n", k == 0 ? "E height range given" : "F height range estimated",
                wall[k].text("%.2f").c_str(), cpu[k].text("%.2f").c_str(), rss[k].text("%.1f").c_str());
  for (int k = 0; k < 2; ++k) {
    const auto report = nlohmann::json::parse(std::ifstream(dir + "/stats_" + std::to_string(k) + ".json"));
    std::printf(
        "%s, last run: %zu pairs matched, %zu left out, height range %.1f..%.1f m, seconds: height range %.2f, "
        "read %.2f, match %.2f, total %.2f\n",
        k == 0 ? "E" : "F", report["pairs"].size(), report["pairs_left_out"].get<size_t>(),
        report["height_range"][0].get<double>(), report["height_range"][1].get<double>(),
        report["seconds"]["height_range"].get<double>(), report["seconds"]["read"].get<double>(),
        report["seconds"]["match"].get<double>(), report["seconds"]["total"].get<double>());
  }
  if (std::getenv("DSMPLAN_BENCH_KEEP"))  // the block's files, to look at or run by hand
    std::printf("files kept in %s\n", dir.c_str());
  else
    std::filesystem::remove_all(dir);
  return 0;
}
