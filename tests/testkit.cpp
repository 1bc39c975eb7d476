#include "testkit.hpp"

#include <cpl_conv.h>
#include <fcntl.h>
#include <gdal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"

extern char** environ;

namespace testkit {

namespace {
// Tests call GDAL directly as an oracle; any test may run alone (ctest runs them one by one).
// PAM off: computing statistics must not write .aux.xml files next to the bundled data.
[[maybe_unused]] const bool gdal_ready = [] {
  CPLSetConfigOption("GDAL_PAM_ENABLED", "NO");
  GDALAllRegister();
  return true;
}();
}  // namespace

std::string data_path(const std::string& relative) { return std::string(DSMPLAN_DATA_DIR) + "/" + relative; }

const dsmplan::Grid& nrw_crop() {
  static const dsmplan::Grid grid = dsmplan::read_raster(data_path("nrw-dom1/nrw_dom1_crop500m_1m.tif"));
  return grid;
}

const dsmplan::Grid& nrw_full() {
  static const dsmplan::Grid grid = dsmplan::read_raster(data_path("nrw-dom1/dom1_32_356_5699_1_nw_2020.tif"));
  return grid;
}

const dsmplan::Grid& delft_grid() {
  static const dsmplan::Grid grid = [] {
    std::vector<dsmplan::PointCloud> clouds{dsmplan::read_las(data_path("delft-ahn3/ahn3_cropped_1.las")),
                                            dsmplan::read_las(data_path("delft-ahn3/ahn3_cropped_2.las"))};
    dsmplan::GridPointsOptions options;
    options.resolution = 0.5;
    return dsmplan::grid_points(clouds, options);
  }();
  return grid;
}

TempDir::TempDir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "dsmplan-test-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
  dir_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(dir_, ec);
}

std::vector<std::string> TempDir::files() const {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
  return names;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + path);
}

CliResult run_cli(const std::vector<std::string>& args) { return run_program(DSMPLAN_CLI, args); }

CliResult run_program(const std::string& program, const std::vector<std::string>& args) {
  TempDir capture;
  std::string out_path = capture.path("stdout"), err_path = capture.path("stderr");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<std::string> argv_storage{program};
  argv_storage.insert(argv_storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& arg : argv_storage) argv.push_back(arg.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  int rc = posix_spawnp(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error("cannot start " + program);
  int status = 0;
  waitpid(pid, &status, 0);
  CliResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  result.out = read_file(out_path);
  result.err = read_file(err_path);
  return result;
}

std::vector<dsmplan::Triangle> triangle_set(std::vector<dsmplan::Triangle> triangles) {
  for (dsmplan::Triangle& t : triangles) std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
  std::sort(triangles.begin(), triangles.end());
  return triangles;
}

}  // namespace testkit
