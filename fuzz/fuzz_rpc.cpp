// libFuzzer target: the RPC camera files dsmplan reads (dsmplan/rpc_io.hpp) on arbitrary bytes.
// The first byte picks the file: 0, an OSSIM .geom (read_ossim_geom, our parser); 1, a .RPB and
// 2, an _RPC.TXT beside a fixed 4 x 4 GeoTIFF (GDAL parses those into its RPC metadata, which
// read_rpc_camera() turns into numbers and checks); then the camera is asked for a projection and
// a localisation, as the stereo pipeline asks it.
#include <cstdio>

#include "dsmplan/raster_io.hpp"
#include "dsmplan/rpc.hpp"
#include "dsmplan/rpc_io.hpp"
#include "fuzz_file.hpp"

namespace {

// The image the sidecars sit beside, written once: "<scratch>/dsmplan-fuzz-<pid>-image.tif".
const std::string& image() {
  static const std::string path = [] {
    const std::string p = dsmplan_fuzz::scratch_dir() + "/dsmplan-fuzz-" + std::to_string(::getpid()) + "-image.tif";
    dsmplan::Grid grid(4, 4, 0, 4, 1, 1);
    grid.z.assign(16, 1.0f);
    dsmplan::write_geotiff(grid, p);
    static std::string for_exit;
    for_exit = p;
    std::atexit([] { std::remove(for_exit.c_str()); });
    return p;
  }();
  return path;
}

void use(const dsmplan::RpcCamera& camera) {
  const dsmplan::GeoPoint g = camera.localize({0.5, 0.5}, camera.model().height_off);
  (void)camera.project(g);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t kind = data[0] % 3;
  if (kind == 0)
    return dsmplan_fuzz::run(data + 1, size - 1, ".geom",
                             [](const std::string& path) { use(dsmplan::RpcCamera(dsmplan::read_ossim_geom(path))); });
  const std::string& tif = image();
  const std::string sidecar = tif.substr(0, tif.size() - 4) + (kind == 1 ? ".RPB" : "_RPC.TXT");
  std::FILE* f = std::fopen(sidecar.c_str(), "wb");
  if (!f || (size > 1 && std::fwrite(data + 1, 1, size - 1, f) != size - 1) || std::fclose(f) != 0) std::abort();
  try {
    use(dsmplan::read_rpc_camera(tif));
  } catch (const dsmplan::Error&) {
  }
  std::remove(sidecar.c_str());
  return 0;
}
