// dsmplan view (src/tools/view_server.cpp) and the three.js page it serves (web/viewer), tested
// end to end: the real binary serves a GLB meshed from the bundled DSM and a path, Debian's
// headless Chromium (scripts/test.sh installs it) renders the page with SwiftShader's WebGL, and
// the screenshot is read back with libpng. Chromium missing is a failure, not a skip.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <png.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "testkit.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

const std::string kDsm = "nrw-dom1/nrw_dom1_crop500m_1m.tif";  // x 356300..356800, y 5699250..5699750, z 109.2..167.7

// Starts `argv` with stdout and stderr into `log`; returns the pid.
pid_t spawn(const std::vector<std::string>& args, const std::string& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::vector<std::string> storage = args;
  std::vector<char*> argv;
  for (auto& arg : storage) argv.push_back(arg.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error("cannot start " + args[0]);
  return pid;
}

// Waits up to `limit` for `pid`; kills it past that. Returns the exit code (-1: killed by us).
int wait_for(pid_t pid, std::chrono::seconds limit) {
  const auto end = Clock::now() + limit;
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (Clock::now() > end) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// `dsmplan view ... --port 0` for the life of the object: the URL it prints, killed at the end.
class ViewServer {
public:
  ViewServer(const testkit::TempDir& dir, std::vector<std::string> args) : log_(dir.path("server.log")) {
    args.insert(args.begin(), {DSMPLAN_CLI, "view"});
    args.insert(args.end(), {"--port", "0"});
    pid_ = spawn(args, log_);
    // The URL line is printed (and flushed) once the port is bound.
    for (const auto end = Clock::now() + std::chrono::seconds(30); Clock::now() < end;) {
      const std::string out = testkit::read_file(log_);
      const auto at = out.find("http://");
      if (at != std::string::npos && out.find(' ', at) != std::string::npos) {
        url_ = out.substr(at, out.find(' ', at) - at);
        return;
      }
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        ADD_FAILURE() << "dsmplan view stopped: " << out;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ADD_FAILURE() << "dsmplan view printed no URL in 30 s: " << testkit::read_file(log_);
  }
  ~ViewServer() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
  }
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;
  const std::string& url() const { return url_; }
  int port() const { return std::stoi(url_.substr(url_.rfind(':') + 1)); }

private:
  std::string log_, url_;
  pid_t pid_ = -1;
};

std::string find_chromium() {
  for (const char* name : {"chromium", "chromium-browser"}) {
    std::istringstream path(std::getenv("PATH") ? std::getenv("PATH") : "/usr/bin");
    for (std::string dir; std::getline(path, dir, ':');)
      if (!dir.empty() && access((dir + "/" + name).c_str(), X_OK) == 0) return dir + "/" + name;
  }
  return "";
}

// Headless Chromium on `url`: `mode` is "--screenshot=FILE" or "--dump-dom". WebGL comes from
// SwiftShader (no GPU here); as root Chromium needs --no-sandbox. The virtual time budget lets
// the page load and draw before the picture is taken: virtual time stands still while requests
// are pending and runs ahead (not in real time) when the page is idle.
std::string run_chromium(const testkit::TempDir& dir, const std::string& url, const std::string& mode) {
  const std::string chromium = find_chromium();
  if (chromium.empty()) {
    ADD_FAILURE() << "chromium is not installed: scripts/test.sh installs it (Debian's package chromium)";
    return "";
  }
  const std::string log = dir.path("chromium.log");
  const pid_t pid = spawn({chromium, "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
                           "--enable-unsafe-swiftshader", "--window-size=800,600", "--hide-scrollbars",
                           "--virtual-time-budget=30000", "--user-data-dir=" + dir.path("profile"), mode, url},
                          log);
  const int rc = wait_for(pid, std::chrono::seconds(180));
  const std::string out = testkit::read_file(log);
  EXPECT_EQ(rc, 0) << chromium << " " << mode << " " << url << ":\n" << out;
  return out;
}

struct Picture {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;
};

Picture read_png(const std::string& path) {
  Picture picture;
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) {
    ADD_FAILURE() << path << ": " << image.message;
    return picture;
  }
  image.format = PNG_FORMAT_RGB;
  picture.width = static_cast<int>(image.width);
  picture.height = static_cast<int>(image.height);
  picture.rgb.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, picture.rgb.data(), 0, nullptr)) {
    ADD_FAILURE() << path << ": " << image.message;
    picture = Picture();
  }
  return picture;
}

// What the tests look for in a screenshot. The path is drawn unlit in #ff00ff and the waypoints
// in #00ffff (web/viewer/viewer.js); the mesh's height ramp and the white background have neither.
struct Census {
  size_t pixels = 0, distinct = 0, not_background = 0, path = 0, waypoints = 0;
};

Census census(const Picture& picture) {
  Census c;
  std::set<uint32_t> colours;
  for (size_t i = 0; i + 2 < picture.rgb.size(); i += 3) {
    const int r = picture.rgb[i], g = picture.rgb[i + 1], b = picture.rgb[i + 2];
    ++c.pixels;
    colours.insert(uint32_t(r) << 16 | uint32_t(g) << 8 | uint32_t(b));
    if (r < 235 || g < 235 || b < 235) ++c.not_background;
    if (r >= 230 && g <= 40 && b >= 230) ++c.path;
    if (r <= 40 && g >= 230 && b >= 230) ++c.waypoints;
  }
  c.distinct = colours.size();
  return c;
}

std::string describe(const Census& c) {
  std::ostringstream out;
  out << c.pixels << " pixels, " << c.distinct << " colours, " << c.not_background << " not background, " << c.path
      << " path (#ff00ff), " << c.waypoints << " waypoint (#00ffff)";
  return out.str();
}

// The scene every test shows: the bundled DSM meshed at 5 m as a GLB (10 000 vertices), and a
// path of four points well inside its extent, either above every roof (z 185) or under the
// lowest ground (z 100), with its two ends as waypoints.
struct Scene {
  testkit::TempDir dir;
  std::string mesh = dir.path("city.glb"), high = dir.path("high.csv"), buried = dir.path("buried.csv"),
              waypoints = dir.path("waypoints.csv");
  Scene() {
    const auto made = testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "5", "-o", mesh, "-q"});
    EXPECT_EQ(made.exit_code, 0) << made.err;
    const char* xy[] = {"356380,5699330", "356500,5699470", "356640,5699520", "356720,5699670"};
    std::string h = "x,y,z\n", b = "x,y,z\n";
    for (const char* p : xy) {
      h += std::string(p) + ",185\n";
      b += std::string(p) + ",100\n";
    }
    testkit::write_file(high, h);
    testkit::write_file(buried, b);
    testkit::write_file(waypoints, std::string("x,y,z\n") + xy[0] + ",185\n" + xy[3] + ",185\n");
  }
};

Census screenshot(const Scene& scene, const std::vector<std::string>& args, const std::string& name) {
  ViewServer server(scene.dir, args);
  if (server.url().empty()) return {};
  const std::string png = scene.dir.path(name + ".png");
  run_chromium(scene.dir, server.url(), "--screenshot=" + png);
  if (!fs::exists(png)) {
    ADD_FAILURE() << "no screenshot " << png;
    return {};
  }
  const Picture picture = read_png(png);
  EXPECT_EQ(picture.width, 800);
  EXPECT_EQ(picture.height, 600);
  return census(picture);
}

}  // namespace

TEST(View, PageLoadsTheMeshAndPathAndSaysReady) {
  Scene scene;
  ViewServer server(scene.dir, {scene.mesh, "--path", scene.high, "--waypoints", scene.waypoints});
  ASSERT_FALSE(server.url().empty());
  // The page's own verdict: data-state is "ready" only after every file loaded and a frame was drawn.
  const std::string dom = run_chromium(scene.dir, server.url(), "--dump-dom");
  EXPECT_NE(dom.find("data-state=\"ready\""), std::string::npos) << dom;
  EXPECT_NE(dom.find("path: 4 points"), std::string::npos) << dom;
  EXPECT_NE(dom.find("2 waypoints"), std::string::npos) << dom;
  // The bare address, what people type, shows the same page (not "no mesh").
  const std::string bare = server.url().substr(0, server.url().find('?'));
  const std::string typed = run_chromium(scene.dir, bare, "--dump-dom");
  EXPECT_NE(typed.find("data-state=\"ready\""), std::string::npos) << typed;
  EXPECT_NE(typed.find("path: 4 points"), std::string::npos) << typed;
}

TEST(View, ScreenshotShowsTheMeshAndThePathInItsColour) {
  Scene scene;
  const Census with = screenshot(scene, {scene.mesh, "--path", scene.high, "--waypoints", scene.waypoints}, "with");
  std::printf("with the path: %s\n", describe(with).c_str());
  // Not blank: the mesh, shaded by height and lit, covers much of the picture in many colours.
  EXPECT_GT(with.not_background, with.pixels / 5) << describe(with);
  EXPECT_GT(with.distinct, 1000u) << describe(with);
  // The path: 4 segments, ~450 m long, some 5 px wide in the picture.
  EXPECT_GT(with.path, 500u) << describe(with);
  EXPECT_GT(with.waypoints, 50u) << describe(with);

  // Without the path neither colour is anywhere, so the counts above are the path's own.
  const Census without = screenshot(scene, {scene.mesh}, "without");
  std::printf("without: %s\n", describe(without).c_str());
  EXPECT_EQ(without.path, 0u) << describe(without);
  EXPECT_EQ(without.waypoints, 0u) << describe(without);
  EXPECT_GT(without.not_background, without.pixels / 5) << describe(without);
}

TEST(View, PathUnderTheGroundIsHiddenByTheMesh) {
  // The same path 9 m under the lowest ground: in the mesh's frame it is hidden by the surface;
  // put into the wrong frame (origin or rotation not applied as in the GLB) it would show.
  Scene scene;
  const Census buried = screenshot(scene, {scene.mesh, "--path", scene.buried}, "buried");
  std::printf("buried path: %s\n", describe(buried).c_str());
  EXPECT_EQ(buried.path, 0u) << describe(buried);
  EXPECT_GT(buried.not_background, buried.pixels / 5) << describe(buried);
}

TEST(View, BadInputIsOneLineAndExitCodeOneOrTwoForUsage) {
  testkit::TempDir dir;
  const std::string glb = dir.path("m.glb"), ply = dir.path("m.ply"), fake = dir.path("fake.glb");
  ASSERT_EQ(testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "25", "-o", glb, "-q"}).exit_code, 0);
  ASSERT_EQ(testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "25", "-o", ply, "-q"}).exit_code, 0);
  testkit::write_file(fake, "not a binary glTF");
  testkit::write_file(dir.path("bad.csv"), "x,y,z\n1,2,3\n1,2\n");
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::vector<Case> cases{
      {{dir.path("missing.glb")}, "no such file"},
      {{ply}, "not a .glb"},
      {{fake}, "does not start with 'glTF'"},
      {{glb, "--path", dir.path("missing.csv")}, "no such file"},
      {{glb, "--path", dir.path("bad.csv")}, "line 3"},
      {{glb, "--viewer-dir", dir.path("")}, "not the viewer's folder"},
      {{glb, "--port", "70000"}, "--port"},
      // An address of another machine (TEST-NET-1, RFC 5737) is the host's fault, not the port's.
      {{glb, "--host", "192.0.2.7", "--port", "8123"}, "--host: cannot listen on 192.0.2.7: not an address"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args{"view"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const auto result = testkit::run_cli(args);
    EXPECT_EQ(result.exit_code, c.says == "--port" ? 2 : 1) << c.says;  // a bad option value is a usage error
    EXPECT_EQ(result.err.rfind("dsmplan: ", 0), 0u) << result.err;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_NE(result.err.find(c.says), std::string::npos) << result.err;
  }

  // A port in use (httplib's default SO_REUSEPORT would let a second server share it).
  ViewServer first(dir, {glb});
  ASSERT_FALSE(first.url().empty());
  const auto second = testkit::run_cli({"view", glb, "--port", std::to_string(first.port())});
  EXPECT_EQ(second.exit_code, 1);
  EXPECT_NE(second.err.find("--port: cannot listen on 127.0.0.1:" + std::to_string(first.port()) + " (in use)"),
            std::string::npos)
      << second.err;
}

TEST(View, ServesTheViewerAndTheNamedFilesOnly) {
  testkit::TempDir dir;
  const std::string glb = dir.path("m.glb"), csv = dir.path("p.csv");
  ASSERT_EQ(testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "25", "-o", glb, "-q"}).exit_code, 0);
  testkit::write_file(csv, "x,y,z\n356400,5699300,180\n356700,5699700,180\n");
  ViewServer server(dir, {glb, "--path", csv});
  ASSERT_FALSE(server.url().empty());
  EXPECT_NE(server.url().find("/?mesh=/data/mesh.glb&path=/data/path.csv"), std::string::npos) << server.url();
  httplib::Client client("127.0.0.1", server.port());
  client.set_url_encode(false);  // send the paths below as they are
  const auto get = [&](const std::string& path) { return client.Get(path.c_str()); };

  // The bare address is sent to the page with what it shows.
  const auto bare = get("/");
  ASSERT_TRUE(bare);
  EXPECT_EQ(bare->status, 302);
  EXPECT_EQ(bare->get_header_value("Location"), "/?mesh=/data/mesh.glb&path=/data/path.csv");
  const auto page = get("/?mesh=/data/mesh.glb&path=/data/path.csv");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("importmap"), std::string::npos);
  // Module scripts run only when served as JavaScript.
  for (const char* script : {"/viewer.js", "/node_modules/three/build/three.module.js",
                             "/node_modules/three/examples/jsm/loaders/GLTFLoader.js"}) {
    const auto js = get(script);
    ASSERT_TRUE(js) << script;
    EXPECT_EQ(js->status, 200) << script;
    EXPECT_EQ(js->get_header_value("Content-Type").rfind("text/javascript", 0), 0u) << script;
  }
  const auto mesh = get("/data/mesh.glb");
  ASSERT_TRUE(mesh);
  EXPECT_EQ(mesh->get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_TRUE(mesh->body == testkit::read_file(glb));
  const auto path = get("/data/path.csv");
  ASSERT_TRUE(path);
  EXPECT_EQ(path->body, testkit::read_file(csv));

  // Nothing else: not a waypoint file that was not given, nothing outside the viewer's folder.
  EXPECT_EQ(get("/data/waypoints.csv")->status, 404);
  for (const char* escape : {"/../CMakeCache.txt", "/%2e%2e/%2e%2e/CMakeCache.txt", "//etc/passwd",
                             "/node_modules/../index.html", "/..%2f..%2fCMakeCache.txt"}) {
    const auto refused = get(escape);
    ASSERT_TRUE(refused) << escape;
    EXPECT_EQ(refused->status, 403) << escape;
  }
}

TEST(View, NoDotfilesNoSymlinksOutNoForeignHostNoBlockingIdlers) {
  // A viewer folder of our own: the three files the server checks for, a dotfile, and two
  // symbolic links (one to a file outside the folder, one to a file inside it).
  testkit::TempDir dir;
  const std::filesystem::path viewer = dir.dir() / "viewer";
  std::filesystem::create_directories(viewer / "node_modules/three/build");
  testkit::write_file((viewer / "index.html").string(), "<html>importmap</html>\n");
  testkit::write_file((viewer / "viewer.js").string(), "// viewer\n");
  testkit::write_file((viewer / "node_modules/three/build/three.module.js").string(), "// three\n");
  testkit::write_file((viewer / ".env").string(), "SECRET=1\n");
  testkit::write_file(dir.path("outside.txt"), "outside\n");
  std::filesystem::create_symlink(dir.path("outside.txt"), viewer / "leak.txt");
  std::filesystem::create_symlink(viewer / "viewer.js", viewer / "alias.js");
  const std::string glb = dir.path("m.glb");
  ASSERT_EQ(testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "25", "-o", glb, "-q"}).exit_code, 0);
  ViewServer server(dir, {glb, "--viewer-dir", viewer.string()});
  ASSERT_FALSE(server.url().empty());
  httplib::Client client("127.0.0.1", server.port());
  client.set_url_encode(false);
  const std::string port = std::to_string(server.port());

  EXPECT_EQ(client.Get("/index.html")->status, 200);
  EXPECT_EQ(client.Get("/alias.js")->status, 200);  // a link that stays inside is fine
  for (const char* refused : {"/.env", "/leak.txt", "/node_modules/.bin/x", "/%2eenv"}) {
    const auto r = client.Get(refused);
    ASSERT_TRUE(r) << refused;
    EXPECT_EQ(r->status, 403) << refused;
    EXPECT_EQ(r->body.find("SECRET"), std::string::npos);
    EXPECT_EQ(r->body.find("outside"), std::string::npos);
  }
  // DNS rebinding: a foreign name in Host is refused; addresses and localhost with our port are not.
  for (const auto& [host, status] : std::vector<std::pair<std::string, int>>{{"evil.example:" + port, 403},
                                                                             {"127.0.0.1:" + port, 200},
                                                                             {"localhost:" + port, 200},
                                                                             {"127.0.0.1:1", 403},
                                                                             {"", 403}}) {
    const auto r = client.Get("/index.html", httplib::Headers{{"Host", host}});
    ASSERT_TRUE(r) << host;
    EXPECT_EQ(r->status, status) << "Host: " << host;
  }
  // 200 connections that never send a byte, and 40 that send their request head a byte every
  // second (each read within the 2 s timeout, so never dropped), do not keep the page from a
  // browser (they held it for 10 s and 25 s on httplib's pool of threads).
  const auto connect = [&] {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(server.port()));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    return fd;
  };
  std::vector<int> idle, slow;
  for (int i = 0; i < 200; ++i) idle.push_back(connect());
  for (int i = 0; i < 40; ++i) slow.push_back(connect());
  std::atomic<bool> stop{false};
  std::thread trickle([&] {
    const std::string head = "GET /index.html HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ";
    for (size_t k = 0; !stop; k = (k + 1) % head.size()) {
      for (int fd : slow) (void)!::send(fd, &head[k], 1, MSG_NOSIGNAL);
      for (int t = 0; t < 10 && !stop; ++t) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // the slow ones are past their first byte
  const auto started = Clock::now();
  httplib::Client browser("127.0.0.1", server.port());
  browser.set_read_timeout(30, 0);
  const auto page = browser.Get("/index.html");
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  stop = true;
  trickle.join();
  for (int fd : idle) ::close(fd);
  for (int fd : slow) ::close(fd);
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_LT(seconds, 2) << "the page waited behind idle or slow connections";
}
