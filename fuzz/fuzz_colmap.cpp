// libFuzzer target: the COLMAP text parsers of `dsmplan stereo --colmap` (dsmplan/colmap_model.hpp)
// on arbitrary bytes. The first byte chooses what is read, the rest is split at NUL bytes into
// files written in one per-process folder:
//   0  cameras.txt, images.txt              read_colmap_model()
//   1  a --centres CSV                      read_centres()
//   2  a --gcps CSV                         read_gcps()
//   3  a --transform file                   read_similarity()
//   4  cameras.txt, images.txt, --gcps CSV  colmap_cameras(): the model, each point triangulated
//                                           (DLT), the similarity fitted (Umeyama) and checked
//   5  cameras.txt, images.txt, centres CSV colmap_cameras() with --centres
// Nothing here reads an image or touches GDAL or PROJ (the CRS is only named).
#include <filesystem>
#include <string>
#include <vector>

#include "dsmplan/colmap_model.hpp"
#include "fuzz_file.hpp"

namespace {

const std::string& folder() {
  static const std::string dir = [] {
    const std::string d = dsmplan_fuzz::scratch_dir() + "/dsmplan-fuzz-colmap-" + std::to_string(::getpid());
    std::filesystem::create_directories(d);
    static std::string for_exit;
    for_exit = d;
    std::atexit([] { std::filesystem::remove_all(for_exit); });
    return d;
  }();
  return dir;
}

void write(const std::string& path, const std::string& text) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr || (!text.empty() && std::fwrite(text.data(), 1, text.size(), f) != text.size()) ||
      std::fclose(f) != 0) {
    std::perror(path.c_str());
    std::abort();  // the fuzzer's own scratch file failed: not a finding
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const int mode = data[0] % 6;
  std::vector<std::string> parts(1);
  for (size_t i = 1; i < size; ++i) {
    if (data[i] == 0 && parts.size() < 3)
      parts.emplace_back();
    else
      parts.back() += static_cast<char>(data[i]);
  }
  parts.resize(3);
  const std::string& dir = folder();
  const std::string cameras = dir + "/cameras.txt", images = dir + "/images.txt", csv = dir + "/points.csv";
  try {
    if (mode == 0 || mode >= 4) {
      write(cameras, parts[0]);
      write(images, parts[1]);
      write(csv, parts[2]);
    } else {
      write(csv, parts[0]);
    }
    switch (mode) {
      case 0:
        (void)dsmplan::read_colmap_model(dir);
        break;
      case 1:
        (void)dsmplan::read_centres(csv);
        break;
      case 2:
        (void)dsmplan::read_gcps(csv);
        break;
      case 3:
        (void)dsmplan::read_similarity(csv);
        break;
      case 4:
        (void)dsmplan::colmap_cameras({.model = dir, .gcps = csv, .crs = "EPSG:25832", .images = dir});
        break;
      default:
        (void)dsmplan::colmap_cameras({.model = dir, .centres = csv, .crs = "EPSG:25832", .images = dir});
    }
  } catch (const dsmplan::Error& e) {
    static const bool verbose = std::getenv("DSMPLAN_FUZZ_VERBOSE") != nullptr;
    if (verbose) std::fprintf(stderr, "refused: %s\n", e.what());
  }
  return 0;
}
