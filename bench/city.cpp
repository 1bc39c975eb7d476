// Issue 6's benchmark: a city-size DSM meshed and simplified out of core. The mosaic is
// SYNTHETIC: the real NRW DOM1 tile (1 km x 1 km at 1 m) repeated N x N times in a VRT, every
// other copy mirrored in x and/or y so that neighbouring copies meet without a step (a seamless
// 100 M-cell city for N = 10). The bounded mode (conservative, E = 0.4 m) streams it window by
// window into a binary PLY; the bench reports cells per second, peak memory (VmHWM) and the
// certified error, then reads the PLY back and checks its seams: every edge has exactly one twin
// (the same edge the other way) unless it lies on the mosaic's outer border, so there is no
// crack and no T-junction anywhere, across the 1 km files and across the blocks. Last, the
// speed-up of all cores over one on a 3 x 3 km mosaic (into a counting sink: no disk), and the
// full XY-3 mesh of that mosaic band by band.
//
// Timing (bench/bench_kit.hpp): the city is streamed RUNS times (default 3), the rate given as the
// median with its min-max; the speed-up of all cores over one is the median (min-max) of the
// per-pair ratios of PAIRS interleaved pairs (one thread, all threads, one thread, ...; at least 5);
// the XY-3 mesh the median (min-max) of PAIRS runs. The 1-minute load average is printed at every
// run's and pair's start. Never a best-of; the cells-per-second bar is judged on the median.
//
//   bench_city [N = 10] [out folder = out/bench/city] [--keep] [--runs RUNS = 3] [--pairs PAIRS = 5]
//   (needs ~2.5 GB of disk)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/simplify.hpp"
#include "dsmplan/simplify_streamed.hpp"

using namespace dsmplan;
namespace fs = std::filesystem;

namespace {

constexpr double cells_per_second_bar = 2e6;
constexpr double memory_bar = 2.0 * (1 << 30);

double peak_memory_bytes() {  // VmHWM: the process's peak resident set
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) * 1024;
  return NAN;
}

std::string xml_escaped(const std::string& text) {
  std::string out;
  for (char c : text)
    out += c == '"' ? "&quot;" : c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return out;
}

// The four mirror images of the tile, once, and an n x n VRT of them.
std::string make_mosaic(const fs::path& folder, int n) {
  fs::create_directories(folder);
  const Grid tile = read_raster(bench::tile);
  const char* names[4] = {"tile.tif", "tile_mirror_x.tif", "tile_mirror_y.tif", "tile_mirror_xy.tif"};
  for (int m = 0; m < 4; ++m) {
    if (fs::exists(folder / names[m])) continue;
    Grid mirrored = tile;
    for (int r = 0; r < tile.height; ++r)
      for (int c = 0; c < tile.width; ++c)
        mirrored.z[mirrored.index(c, r)] = tile.at(m & 1 ? tile.width - 1 - c : c, m & 2 ? tile.height - 1 - r : r);
    write_geotiff(mirrored, (folder / names[m]).string());
  }
  char gt[256];
  std::snprintf(gt, sizeof gt, "%.17g, %.17g, 0, %.17g, 0, %.17g", tile.x0, tile.cell_x, tile.y0, -tile.cell_y);
  std::string vrt = "<VRTDataset rasterXSize=\"" + std::to_string(n * tile.width) + "\" rasterYSize=\"" +
                    std::to_string(n * tile.height) + "\">\n  <SRS>" + xml_escaped(tile.crs.wkt) +
                    "</SRS>\n  <GeoTransform>" + gt + "</GeoTransform>\n" +
                    "  <VRTRasterBand dataType=\"Float32\" band=\"1\">\n    <NoDataValue>-9999</NoDataValue>\n";
  const std::string size = "xSize=\"" + std::to_string(tile.width) + "\" ySize=\"" + std::to_string(tile.height) + "\"";
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      vrt += "    <SimpleSource><SourceFilename relativeToVRT=\"1\">" + std::string(names[(i & 1) | (j & 1) << 1]) +
             "</SourceFilename><SourceBand>1</SourceBand><SrcRect xOff=\"0\" yOff=\"0\" " + size +
             "/><DstRect xOff=\"" + std::to_string(i * tile.width) + "\" yOff=\"" + std::to_string(j * tile.height) +
             "\" " + size + "/></SimpleSource>\n";
    }
  }
  vrt += "  </VRTRasterBand>\n</VRTDataset>\n";
  const fs::path path = folder / ("city_" + std::to_string(n) + "km.vrt");
  std::ofstream(path) << vrt;
  return path.string();
}

struct SeamCheck {
  size_t edges = 0, twinned = 0, outer = 0, cracks = 0, duplicates = 0, across_files = 0;
};

// Reads the streamed PLY back (binary: doubles x,y,z; faces uchar 3 + uint32 x 3).
SeamCheck check_seams(const std::string& ply, const Grid& frame, int tile_cells) {
  std::FILE* in = std::fopen(ply.c_str(), "rb");
  if (!in) throw std::runtime_error("cannot open " + ply);
  size_t vertices = 0, faces = 0;
  char line[1 << 16];
  while (std::fgets(line, sizeof line, in)) {
    std::sscanf(line, "element vertex %zu", &vertices);
    std::sscanf(line, "element face %zu", &faces);
    if (std::strncmp(line, "end_header", 10) == 0) break;
  }
  std::vector<int32_t> col(vertices), row(vertices);
  std::vector<double> xyz(3 * 65536);
  for (size_t v = 0; v < vertices;) {
    const size_t n = std::min<size_t>(65536, vertices - v);
    if (std::fread(xyz.data(), 24, n, in) != n) throw std::runtime_error("truncated vertices");
    for (size_t k = 0; k < n; ++k, ++v) {
      col[v] = static_cast<int32_t>(std::lround((xyz[3 * k] - frame.x0) / frame.cell_x - 0.5));
      row[v] = static_cast<int32_t>(std::lround((frame.y0 - xyz[3 * k + 1]) / frame.cell_y - 0.5));
    }
  }
  SeamCheck check;
  std::unordered_map<uint64_t, uint8_t> open;  // half-edges waiting for their twin
  open.reserve(1 << 22);
  std::vector<unsigned char> records(13 * 65536);
  for (size_t f = 0; f < faces;) {
    const size_t n = std::min<size_t>(65536, faces - f);
    if (std::fread(records.data(), 13, n, in) != n) throw std::runtime_error("truncated faces");
    for (size_t k = 0; k < n; ++k, ++f) {
      uint32_t t[3];
      std::memcpy(t, records.data() + 13 * k + 1, 12);
      for (int e = 0; e < 3; ++e) {
        const uint32_t a = t[e], b = t[(e + 1) % 3];
        ++check.edges;
        const int tile_a = col[a] / tile_cells + 1000 * (row[a] / tile_cells);
        const int tile_b = col[b] / tile_cells + 1000 * (row[b] / tile_cells);
        check.across_files += tile_a != tile_b;
        const auto twin = open.find(uint64_t(b) << 32 | a);
        if (twin != open.end()) {
          open.erase(twin);
          check.twinned += 2;
        } else if (!open.emplace(uint64_t(a) << 32 | b, 0).second) {
          ++check.duplicates;
        }
      }
    }
  }
  std::fclose(in);
  for (const auto& [key, unused] : open) {
    const uint32_t a = key >> 32, b = key & 0xffffffffu;
    const bool outer = (col[a] == col[b] && (col[a] == 0 || col[a] == frame.width - 1)) ||
                       (row[a] == row[b] && (row[a] == 0 || row[a] == frame.height - 1));
    outer ? ++check.outer : ++check.cracks;
  }
  return check;
}

class CountingSink : public MeshSink {
public:
  void append(const std::vector<Vertex>& vertices, const std::vector<Triangle>& triangles) override {
    this->vertices += vertices.size();
    this->triangles += triangles.size();
  }
  size_t vertices = 0, triangles = 0;
};

}  // namespace

int main(int argc, char** argv) {
  int n = 10;
  fs::path folder = "out/bench/city";
  bool keep = false;
  int positional = 0, runs = 3, pairs = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--keep")
      keep = true;
    else if (arg == "--runs" && i + 1 < argc)
      runs = std::max(1, std::stoi(argv[++i]));
    else if (arg == "--pairs" && i + 1 < argc)
      pairs = std::max(5, std::stoi(argv[++i]));
    else if (positional++ == 0)
      n = std::stoi(arg);
    else
      folder = arg;
  }
  std::printf("bench_city: %s, %u hardware threads, load %s\n", bench::cpu_model().c_str(),
              std::thread::hardware_concurrency(), bench::load_average().c_str());
  std::printf("Mosaic: SYNTHETIC, the NRW DOM1 tile %d x %d times, mirrored copies, as a VRT of 4 GeoTIFFs\n", n, n);
  const std::string vrt = make_mosaic(folder, n);
  BoundedSimplifyOptions options;
  options.max_error = 0.4;
  options.conservative = true;

  // 1. The city, streamed to disk, `runs` times (each run writes the same file anew).
  const std::string ply = (folder / ("city_" + std::to_string(n) + "km.ply")).string();
  Grid frame;
  double cells = 0;
  bench::Samples seconds;
  bench::LoadLog city_loads;
  BoundedStreamResult result;
  for (int run = 0; run < runs; ++run) {
    city_loads.note();
    const std::unique_ptr<GridSource> dsm = open_raster(vrt);
    frame = dsm->frame();
    cells = double(frame.width) * frame.height;
    std::printf("run %d of %d (load average %s): ", run + 1, runs, bench::load_average().c_str());
    const auto start = std::chrono::steady_clock::now();
    {
      PlyStreamWriter writer(ply, frame.crs);
      int last = -1;
      result = simplify_bounded(*dsm, options, writer, [&](double f) {
        const int percent = int(f * 10) * 10;
        if (percent != last)
          std::printf("%d%s", last = percent, percent == 100 ? " - done" : "..."), std::fflush(stdout);
        return true;
      });
      writer.finish();
    }
    seconds.add(bench::seconds_since(start));
    std::printf(", %.1f s\n", seconds.values.back());
  }
  const double peak = peak_memory_bytes();  // over all runs
  const bench::Samples rates = bench::rates(cells, seconds);
  const double rate = rates.median();
  std::printf("\n| %-34s | %s |\n|%s|%s|\n", "city, bounded conservative E 0.4 m", "value",
              std::string(36, '-').c_str(), std::string(26, '-').c_str());
  auto row = [](const char* what, const std::string& value) { std::printf("| %-34s | %24s |\n", what, value.c_str()); };
  row("cells (synthetic mosaic)",
      bench::grouped(size_t(cells)) + " (" + std::to_string(frame.width) + " x " + std::to_string(frame.height) + ")");
  row("blocks", bench::grouped(result.blocks));
  row("vertices", bench::grouped(result.vertices));
  row("triangles", bench::grouped(result.triangles));
  char text[96];
  std::snprintf(text, sizeof text, "%d runs, load %s", runs, city_loads.text().c_str());
  row("runs, load average at their starts", text);
  row("wall seconds (read, simplify, write)", seconds.text("%.1f"));
  row("cells per second, median", bench::grouped(size_t(rate)));
  std::snprintf(text, sizeof text, "%.2f-%.2f M", rates.min() / 1e6, rates.max() / 1e6);
  row("cells per second, min-max", text);
  row("peak memory (VmHWM)", format_bytes(peak));
  row("certified max above DSM (m)", std::to_string(result.error.max_above));
  row("certified max below DSM (m)", std::to_string(result.error.max_below));
  row("PLY size", format_bytes(double(fs::file_size(ply))));

  // 2. Seams, on the file as written.
  const auto check_start = std::chrono::steady_clock::now();
  const SeamCheck seams = check_seams(ply, frame, 1000);
  row("half-edges", bench::grouped(seams.edges));
  row("... with their twin", bench::grouped(seams.twinned));
  row("... on the outer border", bench::grouped(seams.outer));
  row("... crossing a 1 km file seam", bench::grouped(seams.across_files));
  row("cracks or T-junctions (no twin)", bench::grouped(seams.cracks));
  row("duplicate half-edges (folds)", bench::grouped(seams.duplicates));
  std::printf("(seam check: %.1f s)\n", bench::seconds_since(check_start));
  if (!keep) fs::remove(ply);

  // 3. Speed-up on 2 cores: a 3 x 3 km mosaic, all cores vs one, into a counting sink, in pairs.
  const std::string small = make_mosaic(folder, 3);
  bench::Samples one_core, all_cores;
  bench::LoadLog pair_loads;
  for (int pair = 0; pair < pairs; ++pair) {
    pair_loads.note();
    for (int threads : {1, 0}) {
      BoundedSimplifyOptions o = options;
      o.threads = threads;
      const std::unique_ptr<GridSource> source = open_raster(small);
      CountingSink sink;
      const auto t0 = std::chrono::steady_clock::now();
      simplify_bounded(*source, o, sink);
      (threads == 1 ? one_core : all_cores).add(bench::seconds_since(t0));
    }
  }
  std::printf("\nSpeed-up, 3 x 3 km mosaic (9 M cells), no disk, %d interleaved pairs (load average %s at their\n",
              pairs, pair_loads.text().c_str());
  std::printf("starts): 1 thread %s s, all %u cores %s s: %sx (median of the per-pair ratios, min-max)\n",
              one_core.text("%.2f").c_str(), std::thread::hardware_concurrency(), all_cores.text("%.2f").c_str(),
              bench::ratios(one_core, all_cores).text("%.2f").c_str());

  // 4. The full XY-3 mesh (no simplification) of the 3 x 3 km mosaic, band by band, no disk.
  {
    bench::Samples t;
    bench::LoadLog xy3_loads;
    MeshStreamResult xy3;
    for (int run = 0; run < pairs; ++run) {
      xy3_loads.note();
      const std::unique_ptr<GridSource> source = open_raster(small);
      CountingSink sink;
      const auto t0 = std::chrono::steady_clock::now();
      xy3 = triangulate_xy3(*source, sink);
      t.add(bench::seconds_since(t0));
    }
    std::printf("XY-3 mesh band by band, 3 x 3 km: %s vertices, %s triangles, %zu bands, %s s, %s M cells/s\n",
                bench::grouped(xy3.vertices).c_str(), bench::grouped(xy3.triangles).c_str(), xy3.bands,
                t.text("%.2f").c_str(), bench::rates(9e6 / 1e6, t).text("%.2f").c_str());
    std::printf("(%d runs, median (min-max); load average %s at their starts, %s at the end)\n", pairs,
                xy3_loads.text().c_str(), bench::load_average().c_str());
  }

  const bool speed_ok = rate >= cells_per_second_bar, memory_ok = peak <= memory_bar;
  const bool seams_ok = seams.cracks == 0 && seams.duplicates == 0;
  const bool bound_ok = result.error.max_above <= 0.4 && result.error.max_below == 0;
  std::printf(
      "\nBars: >= 2 M cells/s (median of the runs): %s (%.2f M/s); peak <= 2 GB: %s (%s); seams: %s; bound: %s\n",
      speed_ok ? "PASS" : "FAIL", rate / 1e6, memory_ok ? "PASS" : "FAIL", format_bytes(peak).c_str(),
      seams_ok ? "PASS" : "FAIL", bound_ok ? "PASS" : "FAIL");
  std::printf("At this rate Berlin (891 km^2 at 1 m) takes %.1f minutes.\n", 891e6 / rate / 60);
  return speed_ok && memory_ok && seams_ok && bound_ok ? 0 : 1;
}
