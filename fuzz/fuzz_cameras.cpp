// libFuzzer target: CAMERAS.json of `dsmplan stereo --cameras` on arbitrary bytes (a file named
// *.json): read_camera_file() reads and checks it whole (crs, height_range, every camera's image,
// size, intrinsics, distortion, rotation, centre) and opens no image.
#include "dsmplan/stereo_frames.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return dsmplan_fuzz::run(data, size, ".json", [](const std::string& path) { (void)dsmplan::read_camera_file(path); });
}
