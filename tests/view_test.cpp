// dsmplan view (src/tools/view_server.cpp) and the three.js page it serves (web/viewer), tested
// end to end: the real binary serves a GLB meshed from the bundled DSM and a path, Debian's
// headless Chromium (scripts/test.sh installs it) renders the page with SwiftShader's WebGL, and
// the screenshot is read back with libpng. Chromium missing is a failure, not a skip.
#include "dsmplan/view.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <png.h>
#include <poll.h>
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

// serve_view() with options the command line does not offer (a short request deadline), in a
// child process of the test: the URL comes back through a pipe, the child is killed at the end.
// Forked before the test starts any thread of its own.
class ForkedViewServer {
public:
  explicit ForkedViewServer(const dsmplan::ViewOptions& options) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("pipe failed");
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      ::close(fds[0]);
      try {
        dsmplan::serve_view(options, [&](const std::string& url) {
          (void)!::write(fds[1], url.data(), url.size());
          ::close(fds[1]);
        });
      } catch (const std::exception& e) {
        std::fprintf(stderr, "serve_view: %s\n", e.what());
      }
      ::_exit(1);
    }
    ::close(fds[1]);
    pollfd ready{fds[0], POLLIN, 0};
    char buffer[512];
    for (ssize_t n = 1; n > 0 && ::poll(&ready, 1, 30000) > 0;)
      if ((n = ::read(fds[0], buffer, sizeof buffer)) > 0) url_.append(buffer, static_cast<size_t>(n));
    ::close(fds[0]);
    if (url_.empty()) ADD_FAILURE() << "serve_view gave no URL";
  }
  ~ForkedViewServer() {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
  ForkedViewServer(const ForkedViewServer&) = delete;
  ForkedViewServer& operator=(const ForkedViewServer&) = delete;
  int port() const { return std::stoi(url_.substr(url_.rfind(':') + 1)); }

private:
  pid_t pid_ = -1;
  std::string url_;
};

// A client connected to 127.0.0.1:`port`, or -1.
int connect_to(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// A request head that a slowloris client never finishes: one more byte of it on each call.
struct Slowloris {
  int fd = -1;
  size_t sent = 0;
  std::string reply;
  bool closed = false;
  double closed_after = 0;  // seconds from the first byte
  Clock::time_point start;

  void send_next_byte() {
    static const std::string head = "GET /index.html HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: " + std::string(4000, 'a');
    if (sent == 0) start = Clock::now();
    if (!closed) (void)!::send(fd, &head[sent++ % head.size()], 1, MSG_NOSIGNAL);
  }
  // Reads what the server sent without waiting; true once the server closed the connection.
  bool check_closed() {
    if (closed) return true;
    char buffer[512];
    for (;;) {
      const ssize_t n = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
      if (n > 0) {
        reply.append(buffer, static_cast<size_t>(n));
        continue;
      }
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return false;
      closed = true;  // end of stream, or reset
      closed_after = std::chrono::duration<double>(Clock::now() - start).count();
      return true;
    }
  }
};

dsmplan::ViewOptions short_deadline_view(const std::string& glb, double deadline) {
  dsmplan::ViewOptions options;
  options.mesh = glb;
  options.port = 0;
  options.viewer_dir = (fs::path(DSMPLAN_CLI).parent_path() / "web" / "viewer").string();
  options.request_deadline_seconds = deadline;
  return options;
}

// `clients` slow clients (Slowloris) of a viewer with the given deadline, then a browser asking
// for the page, with `page_timeout` seconds to answer; then up to 10 s for the server to cut
// every slow client, when it got the page.
struct Crowd {
  int status = 0;     // of the page; 0: none came
  std::string error;  // why not
  double page_seconds = 0, last_closed = 0;
  size_t closed = 0, with_408 = 0, clients = 0;
  std::string describe() const {
    std::ostringstream out;
    out << (status ? "page " + std::to_string(status) : "no page (" + error + ")") << " after " << page_seconds
        << " s; " << closed << " of " << clients << " slow clients cut (" << with_408 << " with 408), the last "
        << last_closed << " s after its first byte";
    return out.str();
  }
};

Crowd page_behind_slow_clients(const std::string& glb, double deadline, size_t clients, int page_timeout) {
  ForkedViewServer server(short_deadline_view(glb, deadline));
  Crowd crowd;
  crowd.clients = clients;
  std::vector<Slowloris> slow(clients);
  for (Slowloris& s : slow) {
    s.fd = connect_to(server.port());
    EXPECT_GE(s.fd, 0);
    s.send_next_byte();
  }
  std::atomic<bool> stop{false};
  std::atomic<size_t> closed{0};  // the slow clients are the trickle thread's until it stops
  std::thread trickle([&] {
    while (!stop) {
      for (int t = 0; t < 5 && !stop; ++t) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      size_t now_closed = 0;
      for (Slowloris& s : slow) {
        if (!s.check_closed()) s.send_next_byte();
        now_closed += s.closed;
      }
      closed = now_closed;
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // every thread is taken
  const auto started = Clock::now();
  httplib::Client browser("127.0.0.1", server.port());
  browser.set_read_timeout(page_timeout, 0);
  const auto page = browser.Get("/index.html");
  crowd.page_seconds = std::chrono::duration<double>(Clock::now() - started).count();
  crowd.status = page ? page->status : 0;
  crowd.error = httplib::to_string(page.error());
  if (page)
    for (const auto end = Clock::now() + std::chrono::seconds(10); Clock::now() < end && closed < clients;)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
  stop = true;
  trickle.join();
  for (Slowloris& s : slow) {
    crowd.closed += s.check_closed();
    crowd.with_408 += s.reply.rfind("HTTP/1.1 408", 0) == 0;
    if (s.closed) crowd.last_closed = std::max(crowd.last_closed, s.closed_after);
    ::close(s.fd);
  }
  return crowd;
}

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

TEST(View, SlowClientIsCutAtTheRequestDeadline) {
  // A client sending its request head a byte every 0.5 s: each read comes well within the 2 s
  // read timeout, so before the deadline it held its thread for as long as it kept sending.
  testkit::TempDir dir;
  const std::string glb = dir.path("m.glb");
  ASSERT_EQ(testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "25", "-o", glb, "-q"}).exit_code, 0);
  constexpr double kDeadline = 1;
  ForkedViewServer server(short_deadline_view(glb, kDeadline));
  Slowloris slow;
  slow.fd = connect_to(server.port());
  ASSERT_GE(slow.fd, 0);
  for (const auto end = Clock::now() + std::chrono::seconds(15); Clock::now() < end && !slow.check_closed();) {
    slow.send_next_byte();
    pollfd ready{slow.fd, POLLIN, 0};
    ::poll(&ready, 1, 500);
  }
  ::close(slow.fd);
  ASSERT_TRUE(slow.closed) << "still open after 15 s and " << slow.sent << " bytes";
  std::printf("slow client: closed after %.2f s and %zu bytes, reply \"%s\"\n", slow.closed_after, slow.sent,
              slow.reply.substr(0, slow.reply.find('\r')).c_str());
  EXPECT_GT(slow.closed_after, kDeadline - 0.1);
  EXPECT_LT(slow.closed_after, kDeadline + 1.5);
  EXPECT_EQ(slow.reply.rfind("HTTP/1.1 408 Request Timeout\r\n", 0), 0u) << slow.reply;
}

TEST(View, MoreSlowClientsThanThreadsDoNotKeepThePageFromOthers) {
  // 300 slow clients, more than the 256 connection threads, then a browser asks for the page.
  testkit::TempDir dir;
  const std::string glb = dir.path("m.glb");
  ASSERT_EQ(testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "25", "-o", glb, "-q"}).exit_code, 0);
  constexpr double kDeadline = 1;
  const Crowd cut = page_behind_slow_clients(glb, kDeadline, 300, 20);
  std::printf("deadline %.0f s: %s\n", kDeadline, cut.describe().c_str());
  // Each slow client is cut at the deadline, and the page comes within about one deadline.
  EXPECT_EQ(cut.status, 200) << cut.describe();
  EXPECT_LT(cut.page_seconds, kDeadline + 3) << "the page waited behind the slow clients";
  EXPECT_EQ(cut.closed, 300u) << cut.describe();
  EXPECT_GE(cut.with_408, 250u) << cut.describe();  // the reply may be lost to a reset
  EXPECT_LT(cut.last_closed, 2 * kDeadline + 3) << cut.describe();

  // The control: with a deadline of a minute the same clients do hold every thread (as they did
  // for as long as they kept sending before there was a deadline), so the page does not come.
  const Crowd held = page_behind_slow_clients(glb, 60, 300, 3);
  std::printf("deadline 60 s: %s\n", held.describe().c_str());
  EXPECT_EQ(held.status, 0) << "the slow clients did not take every thread: the test above proves nothing";
}

TEST(View, OversizedHeadOrBodyIsRefused) {
  // httplib reads a whole header line, any number of lines, and a chunked body, into memory
  // without a limit. Each case sends exactly one byte past the 64 KiB cap, so that the server has
  // read all of it when it answers (unread bytes would turn its close into a reset).
  testkit::TempDir dir;
  const std::string glb = dir.path("m.glb");
  ASSERT_EQ(testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "25", "-o", glb, "-q"}).exit_code, 0);
  ForkedViewServer server(short_deadline_view(glb, 10));
  const size_t kCap = 64 * 1024;
  const std::string head = "GET /index.html HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Long: ";
  const std::string post = "POST /index.html HTTP/1.1\r\nHost: 127.0.0.1\r\nTransfer-Encoding: chunked\r\n\r\n";
  const std::string chunk = "FFFFF\r\n";
  for (const auto& [request, status] : std::vector<std::pair<std::string, std::string>>{
           {head + std::string(kCap + 1 - head.size(), 'a'), "431"},
           {post + chunk + std::string(kCap + 1 - chunk.size(), 'b'), "413"}}) {
    const int fd = connect_to(server.port());
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::send(fd, request.data(), request.size(), MSG_NOSIGNAL), static_cast<ssize_t>(request.size()));
    std::string reply;
    char buffer[512];
    pollfd ready{fd, POLLIN, 0};
    for (ssize_t n = 1; n > 0 && ::poll(&ready, 1, 5000) > 0;)
      if ((n = ::recv(fd, buffer, sizeof buffer, 0)) > 0) reply.append(buffer, static_cast<size_t>(n));
    ::close(fd);
    EXPECT_EQ(reply.rfind("HTTP/1.1 " + status + " ", 0), 0u) << status << ": " << reply;
  }
}
