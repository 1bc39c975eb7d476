// Shared by the tests: where the real data is, scratch folders, running the CLI. Linking it also
// registers GDAL (with .aux.xml writing off), so tests may call GDAL as an oracle directly.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace dsmplan {
struct Grid;
}

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

}  // namespace testkit
