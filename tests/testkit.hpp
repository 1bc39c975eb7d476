// Shared by the tests: where the real data is, scratch folders, running the CLI. Linking it also
// registers GDAL (with .aux.xml writing off), so tests may call GDAL as an oracle directly.
#pragma once

#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "dsmplan/mesh.hpp"
#include "dsmplan/raster.hpp"

namespace testkit {

/// A file of the bundled real data (data/ in the repository), e.g. "nrw-dom1/nrw_dom1_crop500m_1m.tif".
std::string data_path(const std::string& relative);

/// The real DSMs the tests share, read once per test binary.
const dsmplan::Grid& nrw_crop();  ///< NRW DOM1, 500 m x 500 m at 1 m, no nodata
const dsmplan::Grid& nrw_full();  ///< NRW DOM1 tile, 1000 x 1000 at 1 m
/// Delft AHN3 LiDAR gridded at 0.5 m (median): canals and yards without returns are real holes.
const dsmplan::Grid& delft_grid();

/// A fresh folder, removed with everything in it when the object goes.
class TempDir {
public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  const std::filesystem::path& dir() const { return dir_; }
  /// Names of the files in the folder (to check that nothing was left behind).
  std::vector<std::string> files() const;

private:
  std::filesystem::path dir_;
};

struct CliResult {
  int exit_code = -1;
  std::string out, err;
};

/// Runs the dsmplan binary with `args` (no shell), capturing stdout and stderr.
CliResult run_cli(const std::vector<std::string>& args);
/// Runs `program` (looked up in PATH) with `args`, the same way.
CliResult run_program(const std::string& program, const std::vector<std::string>& args);

/// Whole file as bytes.
std::string read_file(const std::string& path);
void write_file(const std::string& path, const std::string& bytes);

/// Serves a grid by windows (a GridView) and counts what it was asked for: how the out-of-core
/// modes are shown to hold only windows.
class CountingSource : public dsmplan::GridSource {
public:
  explicit CountingSource(const dsmplan::Grid& grid) : view_(grid) {}
  const dsmplan::Grid& frame() const override { return view_.frame(); }
  void read(int col0, int row0, int w, int h, float* out) override {
    const size_t cells = static_cast<size_t>(w) * static_cast<size_t>(h);
    largest = std::max(largest, cells);
    largest_rows = std::max(largest_rows, h);
    cells_read += cells;
    ++reads;
    view_.read(col0, row0, w, h, out);
  }
  size_t largest = 0, cells_read = 0, reads = 0;  ///< largest window and all reads, in cells
  int largest_rows = 0;

private:
  dsmplan::GridView view_;
};

/// The triangles with their corners rotated to start at the smallest index, sorted: a mesh's
/// triangle set, whatever the order of its triangles.
std::vector<dsmplan::Triangle> triangle_set(std::vector<dsmplan::Triangle> triangles);

}  // namespace testkit
