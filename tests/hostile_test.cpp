// The catalogue of hostile inputs (tests/hostile/catalogue.json), run through the real binary.
//
// Every case must end the same way, whatever is wrong: a non-zero exit, exactly one line on
// stderr that names the file (or option) at fault and says what is wrong (the case's phrases),
// and no output: nothing in the scratch output folder, no temporary file left next to any path
// the command was given, the fixtures untouched. The fixtures and what is wrong with each are
// described in tests/hostile/make_fixtures.py, which wrote them.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "testkit.hpp"

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

const std::string kFixtures = DSMPLAN_HOSTILE_DIR;
constexpr int kTimeout = 60;  // seconds a case may take (the slowest takes about 2 under ASan)

std::vector<json> load_catalogue() {
  std::ifstream in(kFixtures + "/catalogue.json");
  if (!in) throw std::runtime_error("cannot open " + kFixtures + "/catalogue.json");
  return json::parse(in).at("cases").get<std::vector<json>>();
}

std::string substitute(std::string text, const std::string& out, const std::string& work) {
  for (const auto& [key, value] : {std::pair<std::string, std::string>{"{in}", kFixtures},
                                   {"{out}", out},
                                   {"{work}", work},
                                   {"{data}", DSMPLAN_DATA_DIR}}) {
    for (size_t at; (at = text.find(key)) != std::string::npos;) text.replace(at, key.size(), value);
  }
  return text;
}

// testkit::run_cli, with a file size limit when asked: RLIMIT_FSIZE makes write() fail with
// EFBIG past the limit (SIGXFSZ ignored, so it is an error, not a kill), a full disk in small.
// Under AddressSanitizer the binary reserves terabytes of address space for its shadow memory
// and cannot start under ulimit -v (see run_limited()).
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

testkit::CliResult run_limited(const std::vector<std::string>& args, long file_size_limit, long address_space_limit) {
  testkit::TempDir capture;
  const std::string out_path = capture.path("stdout"), err_path = capture.path("stderr");
  std::vector<std::string> storage{DSMPLAN_CLI};
  storage.insert(storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& arg : storage) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    const int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out < 0 || err < 0 || ::dup2(out, 1) < 0 || ::dup2(err, 2) < 0) ::_exit(126);
    if (file_size_limit > 0) {
      ::signal(SIGXFSZ, SIG_IGN);
      const rlimit limit{static_cast<rlim_t>(file_size_limit), static_cast<rlim_t>(file_size_limit)};
      if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(126);
    }
    if (address_space_limit > 0 && kAddressSanitizer) {
      // ASan's shadow memory cannot start under ulimit -v: the same machine, as dsmplan's own
      // limit says it (core.hpp, machine_memory_bytes()); the plain build runs the real one.
      ::setenv("DSMPLAN_MAX_MEMORY", std::to_string(address_space_limit).c_str(), 1);
    } else if (address_space_limit > 0) {  // ulimit -v: a machine with that much memory, as the process sees it
      const rlimit limit{static_cast<rlim_t>(address_space_limit), static_cast<rlim_t>(address_space_limit)};
      if (::setrlimit(RLIMIT_AS, &limit) != 0) ::_exit(126);
    }
    ::execv(DSMPLAN_CLI, argv.data());
    ::_exit(127);
  }
  // A hang is a finding too: past kTimeout seconds the child is killed (exit 128 + SIGKILL).
  int status = 0;
  const auto started = std::chrono::steady_clock::now();
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() - started > std::chrono::seconds(kTimeout)) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      break;
    }
    ::usleep(2000);
  }
  testkit::CliResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  result.out = testkit::read_file(out_path);
  result.err = testkit::read_file(err_path);
  return result;
}

// Temporary files of the atomic writer (".NAME.partial-XXXXXX") in `folder`.
std::vector<std::string> partial_files(const fs::path& folder) {
  std::vector<std::string> found;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return found;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.find(".partial-") != std::string::npos) found.push_back(entry.path().string());
  }
  return found;
}

std::vector<std::string> listing(const fs::path& folder) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

class Hostile : public testing::TestWithParam<json> {};

TEST_P(Hostile, FailsCleanly) {
  const json& c = GetParam();
  testkit::TempDir out, work;
  const std::string out_dir = out.dir().string(), work_dir = work.dir().string();

  if (c.contains("sparse")) {
    // A fixture's first bytes, extended with a hole to a size no test machine could hold.
    const json& s = c["sparse"];
    const std::string to = work.path(s.at("to").get<std::string>());
    testkit::write_file(to, testkit::read_file(kFixtures + "/" + s.at("from").get<std::string>()));
    fs::resize_file(to, s.at("size").get<uintmax_t>());
  }
  // Inputs that are no files: FIFOs with no writer (an open() for reading waits for one), and
  // symbolic links to any path (/dev/zero, a real image) under a name a reader expects.
  const json fifos = c.value("fifos", json::array()), links = c.value("links", json::object());
  for (const auto& name : fifos) ASSERT_EQ(::mkfifo(work.path(name.get<std::string>()).c_str(), 0600), 0) << name;
  for (const auto& link : links.items())
    fs::create_symlink(substitute(link.value().get<std::string>(), out_dir, work_dir), work.path(link.key()));
  std::vector<std::string> args;
  for (const auto& arg : c.at("args")) args.push_back(substitute(arg.get<std::string>(), out_dir, work_dir));
  const std::vector<std::string> fixtures_before = listing(kFixtures);

  const testkit::CliResult result =
      run_limited(args, c.value("file_size_limit", 0L), c.value("address_space_limit", 0L));

  const std::string& err = result.err;
  EXPECT_NE(result.exit_code, 0);
  EXPECT_LT(result.exit_code, 128) << "killed by signal " << result.exit_code - 128;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << "stderr: " << err;
  EXPECT_TRUE(!err.empty() && err.back() == '\n') << "stderr: " << err;
  const std::string names = substitute(c.at("names").get<std::string>(), out_dir, work_dir);
  EXPECT_NE(err.find(names), std::string::npos) << "stderr should name '" << names << "': " << err;
  for (const auto& phrase : c.at("expect"))
    EXPECT_NE(err.find(phrase.get<std::string>()), std::string::npos)
        << "stderr should say '" << phrase.get<std::string>() << "': " << err;

  EXPECT_TRUE(out.files().empty()) << "left behind in {out}: " << out.files().front();
  EXPECT_EQ(listing(kFixtures), fixtures_before) << "the fixture folder changed";
  // No temporary file next to anything the command was pointed at (outputs included).
  for (const std::string& arg : args) {
    if (arg.find('/') == std::string::npos) continue;
    for (const fs::path& folder : {fs::path(arg).parent_path(), fs::path(arg).parent_path().parent_path()}) {
      const std::vector<std::string> left = partial_files(folder);
      EXPECT_TRUE(left.empty()) << "temporary file left behind: " << left.front();
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Catalogue, Hostile, testing::ValuesIn(load_catalogue()),
                         [](const testing::TestParamInfo<json>& info) {
                           return info.param.at("name").get<std::string>();
                         });

TEST(HostileCatalogue, CoversTheIssue) {
  // Issue 7 asks for at least 30 cases; the fixture folder stays small enough to keep in git.
  EXPECT_GE(load_catalogue().size(), 30u);
  uintmax_t bytes = 0;
  for (const auto& entry : fs::recursive_directory_iterator(kFixtures))  // COLMAP models are folders
    if (entry.is_regular_file()) bytes += entry.file_size();
  EXPECT_LT(bytes, uintmax_t{1} << 20);
}

}  // namespace
