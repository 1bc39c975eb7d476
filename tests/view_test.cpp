// dsmplan view (src/tools/view_server.cpp) and the three.js page it serves (web/viewer), tested
// end to end: the real binary serves a GLB meshed from the bundled DSM and a path, Debian's
// headless Chromium (scripts/test.sh installs it) renders the page with SwiftShader's WebGL, and
// the screenshot is read back with libpng. Chromium missing is a failure, not a skip.
#include "dsmplan/view.hpp"

#include <fcntl.h>
#include <gdal.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <ogr_srs_api.h>
#include <png.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
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
// `command` "serve": `dsmplan serve ...`, whose first line names its address the same way.
class ViewServer {
public:
  ViewServer(const testkit::TempDir& dir, std::vector<std::string> args, const std::string& command = "view")
      : log_(dir.path(command + ".log")) {
    args.insert(args.begin(), {DSMPLAN_CLI, command});
    args.insert(args.end(), {"--port", "0"});
    pid_ = spawn(args, log_);
    // The URL line is printed (and flushed) once the port is bound (serve first builds its roadmap).
    for (const auto end = Clock::now() + std::chrono::seconds(90); Clock::now() < end;) {
      const std::string out = testkit::read_file(log_);
      const auto at = out.find("http://");
      if (at != std::string::npos && out.find(' ', at) != std::string::npos) {
        url_ = out.substr(at, out.find(' ', at) - at);
        return;
      }
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        ADD_FAILURE() << "dsmplan " << command << " stopped: " << out;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ADD_FAILURE() << "dsmplan " << command << " printed no URL in 90 s: " << testkit::read_file(log_);
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

// ---- The viewer with a planning service (dsmplan view --serve) ----------------------------

using Json = nlohmann::json;

// The bundled DSM as read by GDAL: the tests' oracle of the heights under a path.
struct Dsm {
  double x0 = 0, y0 = 0, dx = 1, dy = -1;
  int width = 0, height = 0;
  std::vector<float> z;
  // The cells whose centres lie within `radius` of (x, y) horizontally, as (x, y, z) triples.
  template <class F>
  void near(double x, double y, double radius, F&& visit) const {
    const int c0 = std::max(0, int(std::floor((x - radius - x0) / dx))),
              c1 = std::min(width - 1, int((x + radius - x0) / dx));
    const int r0 = std::max(0, int(std::floor((y + radius - y0) / dy))),
              r1 = std::min(height - 1, int((y - radius - y0) / dy));
    for (int r = r0; r <= r1; ++r)
      for (int c = c0; c <= c1; ++c) {
        const double cx = x0 + (c + 0.5) * dx, cy = y0 + (r + 0.5) * dy;
        if (std::hypot(cx - x, cy - y) <= radius) visit(cx, cy, double(z[size_t(r) * width + c]));
      }
  }
  double highest_near(double x, double y, double radius) const {
    double h = -1e30;
    near(x, y, radius, [&](double, double, double z) { h = std::max(h, z); });
    return h;
  }
  double lowest_near(double x, double y, double radius) const {
    double h = 1e30;
    near(x, y, radius, [&](double, double, double z) { h = std::min(h, z); });
    return h;
  }
};

// The surface of Scene's GLB (`dsmplan mesh --res 5`: the median of each 5 x 5 block of cells
// at the block's centre, heights to 0.1 m, each square of four centres split along its higher
// diagonal) over (x, y): the surface split either way, or none off the centres' grid.
std::vector<double> glb_surface(const Dsm& dsm, double x, double y) {
  const double step = 5 * dsm.dx;
  const double u = (x - dsm.x0) / step - 0.5, v = (dsm.y0 - y) / step - 0.5;  // in blocks, rows down
  const int i = int(std::floor(u)), j = int(std::floor(v));
  if (i < 0 || j < 0 || i + 1 >= dsm.width / 5 || j + 1 >= dsm.height / 5) return {};
  const auto median = [&](int bi, int bj) {
    std::vector<float> block;
    for (int r = 5 * bj; r < 5 * bj + 5; ++r)
      for (int c = 5 * bi; c < 5 * bi + 5; ++c) block.push_back(dsm.z[size_t(r) * dsm.width + c]);
    std::nth_element(block.begin(), block.begin() + 12, block.end());
    return std::round(block[12] * 10.0) / 10.0;
  };
  const double z00 = median(i, j), z10 = median(i + 1, j), z01 = median(i, j + 1), z11 = median(i + 1, j + 1);
  const double a = u - i, b = v - j;
  // Split along 00-11, then along 10-01.
  const double first = a >= b ? z00 + a * (z10 - z00) + b * (z11 - z10) : z00 + b * (z01 - z00) + a * (z11 - z01);
  const double second =
      a + b <= 1 ? z00 + a * (z10 - z00) + b * (z01 - z00) : z11 + (1 - a) * (z01 - z11) + (1 - b) * (z10 - z11);
  return {first, second};
}

Dsm read_dsm() {
  Dsm dsm;
  GDALDatasetH data = GDALOpen(testkit::data_path(kDsm).c_str(), GA_ReadOnly);
  if (!data) throw std::runtime_error("GDAL cannot open " + kDsm);
  double g[6];
  GDALGetGeoTransform(data, g);
  dsm.x0 = g[0], dsm.dx = g[1], dsm.y0 = g[3], dsm.dy = g[5];
  dsm.width = GDALGetRasterXSize(data), dsm.height = GDALGetRasterYSize(data);
  dsm.z.resize(size_t(dsm.width) * dsm.height);
  const CPLErr read = GDALRasterIO(GDALGetRasterBand(data, 1), GF_Read, 0, 0, dsm.width, dsm.height, dsm.z.data(),
                                   dsm.width, dsm.height, GDT_Float32, 0, 0);
  GDALClose(data);
  if (read != CE_None) throw std::runtime_error("GDAL cannot read " + kDsm);
  return dsm;
}

// (x, y) from EPSG `from` to EPSG `to` (longitude, latitude order for WGS 84), by GDAL's own
// transformation.
bool transform_point(int from, int to, double& x, double& y) {
  OGRSpatialReferenceH source = OSRNewSpatialReference(nullptr), target = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(source, from);
  OSRImportFromEPSG(target, to);
  OSRSetAxisMappingStrategy(source, OAMS_TRADITIONAL_GIS_ORDER);
  OSRSetAxisMappingStrategy(target, OAMS_TRADITIONAL_GIS_ORDER);
  OGRCoordinateTransformationH transform = OCTNewCoordinateTransformation(source, target);
  const bool done = transform && OCTTransform(transform, 1, &x, &y, nullptr);
  if (transform) OCTDestroyCoordinateTransformation(transform);
  OSRDestroySpatialReference(source);
  OSRDestroySpatialReference(target);
  return done;
}

// Longitude, latitude (WGS 84) to EPSG:25832 (the crop's CRS).
bool to_utm32(double& x, double& y) { return transform_point(4326, 25832, x, y); }

// The mesh `dsmplan serve` plans over: the bundled DSM meshed at 1 m as a PLY (serve_test's),
// the same area and CRS (EPSG:25832) as the viewer's GLB at 5 m.
std::string service_mesh(const testkit::TempDir& dir) {
  const std::string ply = dir.path("city_1m.ply");
  const auto made = testkit::run_cli({"mesh", testkit::data_path(kDsm), "-o", ply, "-q"});
  EXPECT_EQ(made.exit_code, 0) << made.err;
  return ply;
}

std::vector<std::string> serve_args(const testkit::TempDir& dir, std::vector<std::string> more = {}) {
  std::vector<std::string> args{service_mesh(dir), "-q", "--vertical-crs", "EPSG:7837", "--allow-approximate-vertical"};
  args.insert(args.end(), more.begin(), more.end());
  return args;
}

// The text of the element `<TAG id="ID" ...>...</TAG>` of a dumped page (entities undone), or "".
std::string element_text(const std::string& dom, const std::string& tag, const std::string& id) {
  const size_t at = dom.find("<" + tag + " id=\"" + id + "\"");
  if (at == std::string::npos) return "";
  const size_t begin = dom.find('>', at) + 1, end = dom.find("</" + tag + ">", begin);
  std::string text = dom.substr(begin, end - begin);
  for (const auto& [entity, c] : std::vector<std::pair<std::string, std::string>>{
           {"&quot;", "\""}, {"&lt;", "<"}, {"&gt;", ">"}, {"&#39;", "'"}, {"&amp;", "&"}})
    for (size_t k; (k = text.find(entity)) != std::string::npos;) text.replace(k, entity.size(), c);
  return text;
}

// The value of attribute `name` on the element with id `id`, or "".
std::string attribute(const std::string& dom, const std::string& id, const std::string& name) {
  const size_t at = dom.find("id=\"" + id + "\"");
  if (at == std::string::npos) return "";
  const size_t tag_start = dom.rfind('<', at), tag_end = dom.find('>', at);
  const std::string tag = dom.substr(tag_start, tag_end - tag_start);
  const size_t a = tag.find(" " + name + "=\"");
  if (a == std::string::npos) return "";
  const size_t begin = a + name.size() + 3;
  return tag.substr(begin, tag.find('"', begin) - begin);
}

std::vector<std::array<double, 3>> read_xyz(const std::string& csv) {
  std::vector<std::array<double, 3>> points;
  std::istringstream in(csv);
  for (std::string line; std::getline(in, line);) {
    std::array<double, 3> p{};
    if (std::sscanf(line.c_str(), "%lf,%lf,%lf", &p[0], &p[1], &p[2]) == 3) points.push_back(p);
  }
  return points;
}

Json post_plan(int port, const std::string& body, int& status) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(60, 0);
  const auto result = client.Post("/v1/plan", body, "application/json");
  status = result ? result->status : -1;
  return result ? Json::parse(result->body, nullptr, false) : Json();
}

// A building well inside the crop: the cell whose surroundings within 6 m stand the most above
// the lowest cell within 25 m (the street). Found in the data, not written down, so that the
// test says what it needs.
std::array<double, 3> highest_building(const Dsm& dsm) {
  std::array<double, 3> best{0, 0, -1};
  for (int r = 100; r < dsm.height - 100; r += 3)
    for (int c = 100; c < dsm.width - 100; c += 3) {
      const double x = dsm.x0 + (c + 0.5) * dsm.dx, y = dsm.y0 + (r + 0.5) * dsm.dy;
      const double rise = dsm.lowest_near(x, y, 6) - dsm.lowest_near(x, y, 25);
      if (rise > best[2]) best = {x, y, rise};
    }
  return best;
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
  testkit::write_file(dir.path("token"), "view-test-token-0123456789\n");
  struct Case {
    std::vector<std::string> args;
    std::string says;
    int exit_code = 1;  // 2: a bad option value, a usage error
  };
  const std::vector<Case> cases{
      {{dir.path("missing.glb")}, "no such file"},
      {{ply}, "not a .glb"},
      {{fake}, "does not start with 'glTF'"},
      {{glb, "--path", dir.path("missing.csv")}, "no such file"},
      {{glb, "--path", dir.path("bad.csv")}, "line 3"},
      {{glb, "--viewer-dir", dir.path("")}, "not the viewer's folder"},
      {{glb, "--port", "70000"}, "--port", 2},
      {{glb, "--serve", "https://127.0.0.1:8080"},
       "--serve: 'https://127.0.0.1:8080' is not the planning service's",
       2},
      {{glb, "--serve", "http://127.0.0.1:8080/v1/plan"}, "no path, query or user", 2},
      {{glb, "--serve", "http://127.0.0.1:99999"}, "the port must lie in [1, 65535]", 2},
      {{glb, "--serve-token-file", dir.path("token")}, "--serve-token-file: is the token of the service", 2},
      {{glb, "--serve", "http://127.0.0.1:8080", "--serve-token-file", dir.path("none")},
       "none: cannot read the token"},
      // An address of another machine (TEST-NET-1, RFC 5737) is the host's fault, not the port's.
      {{glb, "--host", "192.0.2.7", "--port", "8123"}, "--host: cannot listen on 192.0.2.7: not an address"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args{"view"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const auto result = testkit::run_cli(args);
    EXPECT_EQ(result.exit_code, c.exit_code) << c.says;
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

// ---- dsmplan view --serve: planning on click ----------------------------------------------

TEST(View, PlansOnClickThroughTheServiceAndDrawsThePathWithItsFigures) {
  Scene scene;
  ViewServer service(scene.dir, serve_args(scene.dir), "serve");
  ASSERT_FALSE(service.url().empty());
  ViewServer view(scene.dir, {scene.mesh, "--serve", service.url()});
  ASSERT_FALSE(view.url().empty());
  EXPECT_NE(view.url().find("&service=/v1"), std::string::npos) << view.url();
  // Two clicks on the mesh (the page's test hook clicks from straight above, through the same
  // function as the mouse), each waypoint 10 m above the surface (the page's default), then Plan.
  const double clicked[2][2] = {{356380, 5699330}, {356720, 5699670}};
  const std::string url = view.url() + "&clicks=356380,5699330;356720,5699670";
  const std::string dom = run_chromium(scene.dir, url, "--dump-dom");
  ASSERT_NE(dom.find("data-plan=\"drawn\""), std::string::npos) << element_text(dom, "div", "figures") << "\n" << dom;
  const std::string request = element_text(dom, "pre", "plan-request"), drawn = element_text(dom, "pre", "plan-path");
  std::printf("the page sent %s\nand shows: %s\n", request.c_str(), element_text(dom, "div", "figures").c_str());

  // The oracle of what the page shows: the service's own answer to the request the page sent.
  int status = 0;
  const Json answer = post_plan(service.port(), request, status);
  ASSERT_EQ(status, 200) << request << " -> " << answer.dump();
  EXPECT_EQ(drawn, answer["path"].get<std::string>());
  const Json& stats = answer["stats"];
  for (const auto& [data, key] :
       std::vector<std::pair<std::string, std::string>>{{"data-length-m", "path_length_m"},
                                                        {"data-min-clearance-m", "min_clearance_m"},
                                                        {"data-max-agl-m", "max_agl_m"}}) {
    const std::string shown = attribute(dom, "figures", data);
    ASSERT_FALSE(shown.empty()) << data;
    EXPECT_DOUBLE_EQ(std::stod(shown), stats[key].get<double>()) << key;
  }
  const auto path = read_xyz(drawn);
  ASSERT_GE(path.size(), 2u) << drawn;
  EXPECT_EQ(attribute(dom, "figures", "data-points"), std::to_string(path.size()));

  // The waypoints: where clicked, 10 m above the GLB's surface there (a 5 m mesh: within the DSM's
  // heights around), and the path's ends.
  const Dsm dsm = read_dsm();
  const Json sent = Json::parse(request);
  ASSERT_EQ(sent["waypoints"].size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    const Json& w = sent["waypoints"][k];
    const double x = w[0], y = w[1], z = w[2];
    EXPECT_NEAR(x, clicked[k][0], 0.01);
    EXPECT_NEAR(y, clicked[k][1], 0.01);
    EXPECT_GE(z - 10, dsm.lowest_near(x, y, 8) - 0.1) << k;
    EXPECT_LE(z - 10, dsm.highest_near(x, y, 8) + 0.1) << k;
    const auto& end = k == 0 ? path.front() : path.back();
    EXPECT_NEAR(std::hypot(end[0] - x, end[1] - y, end[2] - z), 0, 0.01) << k;
  }
  // The path against the DSM itself, every 0.5 m: its distance to the cells' centres (the service
  // mesh's vertices, to its 0.1 m height step) is at least the least clearance the service gives,
  // and that at least the safety (2 m); its height above the highest cell within 1.5 m (at least
  // the mesh's surface under it) at most the highest above the ground it gives; and its length.
  double least = 1e30, highest = -1e30, length = 0;
  for (size_t i = 0; i + 1 < path.size(); ++i) {
    const auto &p = path[i], &q = path[i + 1];
    const double d = std::hypot(q[0] - p[0], q[1] - p[1], q[2] - p[2]);
    length += d;
    const int steps = std::max(1, int(std::ceil(d / 0.5)));
    for (int t = 0; t <= steps; ++t) {
      const double f = double(t) / steps;
      const double x = p[0] + f * (q[0] - p[0]), y = p[1] + f * (q[1] - p[1]), z = p[2] + f * (q[2] - p[2]);
      dsm.near(x, y, 10,
               [&](double cx, double cy, double cz) { least = std::min(least, std::hypot(cx - x, cy - y, cz - z)); });
      highest = std::max(highest, z - dsm.highest_near(x, y, 1.5));
    }
  }
  std::printf(
      "%zu points, %.2f m; least distance to the DSM's cell centres %.3f m (service: least clearance %.3f m); "
      "highest above the DSM %.2f m (service: %.2f m above the %s)\n",
      path.size(), length, least, stats["min_clearance_m"].get<double>(), highest, stats["max_agl_m"].get<double>(),
      stats["ground"].get<std::string>().c_str());
  EXPECT_NEAR(length, stats["path_length_m"].get<double>(), 0.01);
  EXPECT_GE(stats["min_clearance_m"].get<double>(), 2 - 1e-9);
  EXPECT_GE(least, stats["min_clearance_m"].get<double>() - 0.06);
  EXPECT_GE(least, 2 - 0.06);
  EXPECT_LE(highest, stats["max_agl_m"].get<double>() + 0.06);
  EXPECT_LE(stats["max_agl_m"].get<double>(), 120);

  // And drawn: the path's magenta and the waypoints' cyan are in the picture, and neither is
  // there on the same page before any click.
  const std::string png = scene.dir.path("planned.png"), idle_png = scene.dir.path("idle.png");
  run_chromium(scene.dir, url, "--screenshot=" + png);
  run_chromium(scene.dir, view.url(), "--screenshot=" + idle_png);
  const Census planned = census(read_png(png)), idle = census(read_png(idle_png));
  std::printf("planned: %s\nbefore any click: %s\n", describe(planned).c_str(), describe(idle).c_str());
  EXPECT_GT(planned.path, 300u) << describe(planned);
  EXPECT_GT(planned.waypoints, 20u) << describe(planned);
  EXPECT_EQ(idle.path, 0u) << describe(idle);
  EXPECT_EQ(idle.waypoints, 0u) << describe(idle);
}

TEST(View, ShowsTheServiceOneLineWhenAWaypointIsInsideABuilding) {
  Scene scene;
  const Dsm dsm = read_dsm();
  const std::array<double, 3> roof = highest_building(dsm);
  std::printf("roof at %.1f, %.1f: %.1f m above the street\n", roof[0], roof[1], roof[2]);
  ASSERT_GT(roof[2], 8) << "no building in the crop";
  ViewServer service(scene.dir, serve_args(scene.dir), "serve");
  ASSERT_FALSE(service.url().empty());
  ViewServer view(scene.dir, {scene.mesh, "--serve", service.url()});
  ASSERT_FALSE(view.url().empty());
  // Two clicks on the roof, 4 m under its surface: inside the building.
  char clicks[128];
  std::snprintf(clicks, sizeof clicks, "&height=-4&clicks=%.1f,%.1f;%.1f,%.1f", roof[0], roof[1], roof[0] + 4,
                roof[1] + 4);
  const std::string dom = run_chromium(scene.dir, view.url() + clicks, "--dump-dom");
  const std::string shown = element_text(dom, "div", "figures"), request = element_text(dom, "pre", "plan-request");
  std::printf("the page sent %s\nand shows: %s\n", request.c_str(), shown.c_str());
  EXPECT_NE(dom.find("data-plan=\"error\""), std::string::npos) << dom;
  EXPECT_EQ(attribute(dom, "figures", "class"), "error");
  EXPECT_EQ(element_text(dom, "pre", "plan-path"), "");
  const Json sent = Json::parse(request, nullptr, false);
  ASSERT_TRUE(sent.is_object()) << request;
  const double x = sent["waypoints"][0][0], y = sent["waypoints"][0][1], z = sent["waypoints"][0][2];
  EXPECT_LT(z, dsm.lowest_near(x, y, 2) - 2) << "not under the roof";
  EXPECT_GT(z, dsm.lowest_near(x, y, 20) + 2) << "not above the street";
  // The service's own words for the same request, as the page shows them.
  int status = 0;
  const Json answer = post_plan(service.port(), request, status);
  EXPECT_EQ(status, 422) << answer.dump();
  const std::string error = answer.value("error", "");
  EXPECT_NE(error.find("waypoint 1"), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  EXPECT_EQ(shown, "no path: " + error);
}

TEST(View, PassesOnTheServiceRoutesOnlyFromItsOwnPageWithTheToken) {
  testkit::TempDir dir, plain_dir, dead_dir;
  const std::string glb = dir.path("m.glb"), token = dir.path("token");
  ASSERT_EQ(testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "25", "-o", glb, "-q"}).exit_code, 0);
  const std::string secret = "view-test-token-0123456789";
  testkit::write_file(token, secret + "\n");
  ViewServer service(dir, serve_args(dir, {"--token-file", token}), "serve");
  ASSERT_FALSE(service.url().empty());
  ViewServer view(dir, {glb, "--serve", service.url(), "--serve-token-file", token});
  ASSERT_FALSE(view.url().empty());
  httplib::Client client("127.0.0.1", view.port());
  client.set_read_timeout(60, 0);
  httplib::Client direct("127.0.0.1", service.port());
  direct.set_read_timeout(60, 0);
  const httplib::Headers bearer{{"Authorization", "Bearer " + secret}};

  // The three routes, with the token added by the view server: the service's own answers.
  const auto info = client.Get("/v1/info"), info_direct = direct.Get("/v1/info", bearer);
  ASSERT_TRUE(info && info_direct);
  EXPECT_EQ(info->status, 200) << info->body;
  EXPECT_EQ(info->body, info_direct->body);
  EXPECT_EQ(client.Get("/v1/health")->body, R"({"status":"ok"})");
  const std::string body = R"({"waypoints": [[356380, 5699330, 185], [356720, 5699670, 185]], "format": "csv"})";
  const auto planned = client.Post("/v1/plan", body, "application/json");
  const auto planned_direct = direct.Post("/v1/plan", bearer, body, "application/json");
  ASSERT_TRUE(planned && planned_direct);
  EXPECT_EQ(planned->status, 200) << planned->body;
  const Json via = Json::parse(planned->body, nullptr, false),
             own_answer = Json::parse(planned_direct->body, nullptr, false);
  EXPECT_EQ(via["path"], own_answer["path"]);  // the figures too, the timings aside
  for (const char* key : {"path_length_m", "min_clearance_m", "max_agl_m", "ground"})
    EXPECT_EQ(via["stats"][key], own_answer["stats"][key]) << key;
  // From the page's own origin, yes; from another site's page, or not as JSON (a form), no.
  const std::string own = "http://127.0.0.1:" + std::to_string(view.port());
  EXPECT_EQ(client.Post("/v1/plan", httplib::Headers{{"Origin", own}}, body, "application/json")->status, 200);
  EXPECT_EQ(
      client.Post("/v1/plan", httplib::Headers{{"Origin", "http://evil.example"}}, body, "application/json")->status,
      403);
  EXPECT_EQ(client.Post("/v1/plan", body, "text/plain")->status, 415);
  EXPECT_EQ(client
                .Post("/v1/plan", httplib::Headers{{"Host", "evil.example:" + std::to_string(view.port())}}, body,
                      "application/json")
                ->status,
            403);
  // Nothing else of the service, nor anything else anywhere.
  EXPECT_EQ(client.Post("/v1/info", body, "application/json")->status, 404);
  EXPECT_EQ(client.Get("/v1/plan")->status, 404);
  EXPECT_EQ(client.Get("/v1/roadmap")->status, 404);

  // Without the token the page gets one line naming the flag; with no service, one line too.
  ViewServer plain(plain_dir, {glb, "--serve", service.url()});
  ViewServer dead(dead_dir, {glb, "--serve", "http://127.0.0.1:1"});
  for (const auto& [server, says] : std::vector<std::pair<const ViewServer*, std::string>>{
           {&plain, "requires a token: give dsmplan view --serve-token-file"}, {&dead, "does not answer"}}) {
    httplib::Client c("127.0.0.1", server->port());
    const auto r = c.Post("/v1/plan", body, "application/json");
    ASSERT_TRUE(r) << says;
    EXPECT_EQ(r->status, 502) << r->body;
    const std::string error = Json::parse(r->body, nullptr, false).value("error", "");
    EXPECT_NE(error.find(says), std::string::npos) << r->body;
    EXPECT_EQ(error.find('\n'), std::string::npos) << r->body;
    EXPECT_EQ(r->body.find(secret), std::string::npos);
  }
}

// ---- dsmplan view --no-fly: the zones as prisms ------------------------------------------

TEST(View, DrawsEachNoFlyZoneAsAPrismFromItsFloorToItsCeiling) {
  // The hand-made ED-269 zones over the crop: a polygon with a hole and no floor, a circle, an
  // AGL floor, an AMSL band (hence the vertical options), one in feet, one that does not block.
  const std::string file = std::string(DSMPLAN_TESTS_DIR) + "/data/airspace/nrw_zones_ed269.json";
  Scene scene;
  ViewServer view(scene.dir,
                  {scene.mesh, "--no-fly", file, "--vertical-crs", "EPSG:7837", "--allow-approximate-vertical"});
  ASSERT_FALSE(view.url().empty());
  EXPECT_NE(view.url().find("&zones=/data/zones.json"), std::string::npos) << view.url();
  const std::string dom = run_chromium(scene.dir, view.url(), "--dump-dom");
  ASSERT_NE(dom.find("data-state=\"ready\""), std::string::npos) << dom;
  EXPECT_NE(dom.find("; 6 no-fly zones"), std::string::npos) << element_text(dom, "div", "status");

  // The file read here on its own: one prism per geometry item, in order, its limits in metres.
  struct Expected {
    std::string name, lower_ref, upper_ref;
    double lower = 0, upper = 0;
    bool blocks = false, circle = false;
    size_t corners = 0;
    double lon = 0, lat = 0;  // the first corner
  };
  std::vector<Expected> expected;
  const Json zones = Json::parse(testkit::read_file(file));
  for (const Json& feature : zones["features"])
    for (const Json& g : feature["geometry"]) {
      Expected e;
      e.name = feature["name"];
      const std::string restriction = feature["restriction"];
      e.blocks = restriction == "PROHIBITED" || restriction == "REQ_AUTHORISATION";
      const double unit = g.value("uomDimensions", "M") == "FT" ? 0.3048 : 1;
      if (g.contains("lowerLimit"))
        e.lower = g["lowerLimit"].get<double>() * unit, e.lower_ref = g["lowerVerticalReference"];
      if (g.contains("upperLimit"))
        e.upper = g["upperLimit"].get<double>() * unit, e.upper_ref = g["upperVerticalReference"];
      const Json& shape = g["horizontalProjection"];
      e.circle = shape["type"] == "Circle";
      if (!e.circle) {
        for (const Json& ring : shape["coordinates"]) e.corners += ring.size() - (ring.front() == ring.back());
        e.lon = shape["coordinates"][0][0][0], e.lat = shape["coordinates"][0][0][1];
      }
      expected.push_back(e);
    }
  ASSERT_EQ(expected.size(), 6u);

  // What the page drew: one <li> per prism, its figures from the corners drawn.
  std::vector<std::string> items;
  for (size_t at = dom.find("<li "); at != std::string::npos; at = dom.find("<li ", at + 1))
    items.push_back(dom.substr(at, dom.find('>', at) - at));
  ASSERT_EQ(items.size(), expected.size()) << element_text(dom, "ul", "zones");
  const auto number = [](const std::string& tag, const std::string& name) {
    const size_t at = tag.find(" data-" + name + "=\"");
    return at == std::string::npos ? std::nan("") : std::stod(tag.substr(at + name.size() + 8));
  };
  const auto text = [](const std::string& tag, const std::string& name) {
    const size_t at = tag.find(" data-" + name + "=\"");
    if (at == std::string::npos) return std::string();
    const size_t begin = at + name.size() + 8;
    return tag.substr(begin, tag.find('"', begin) - begin);
  };
  const Dsm dsm = read_dsm();
  // The mesh's lowest point, where the zone without a floor starts.
  double floor_min_of_mesh = std::nan("");
  for (size_t i = 0; i < items.size(); ++i)
    if (expected[i].lower_ref.empty()) floor_min_of_mesh = number(items[i], "floor-min");
  ASSERT_FALSE(std::isnan(floor_min_of_mesh));
  const double dsm_low = *std::min_element(dsm.z.begin(), dsm.z.end());
  const double dsm_high = *std::max_element(dsm.z.begin(), dsm.z.end());
  for (size_t i = 0; i < items.size(); ++i) {
    const Expected& e = expected[i];
    const std::string& tag = items[i];
    SCOPED_TRACE(e.name + ": " + tag);
    EXPECT_EQ(text(tag, "caption"), e.name);
    EXPECT_EQ(text(tag, "blocks"), e.blocks ? "true" : "false");
    if (e.circle)
      EXPECT_GE(number(tag, "corners"), 32);
    else
      EXPECT_EQ(number(tag, "corners"), double(e.corners));
    const double floor_min = number(tag, "floor-min"), floor_max = number(tag, "floor-max");
    const double ceiling_min = number(tag, "ceiling-min"), ceiling_max = number(tag, "ceiling-max");
    // AMSL limits: flat, at the file's height (EPSG:7837 taken as EGM96: the same numbers).
    if (e.lower_ref == "AMSL") {
      EXPECT_NEAR(floor_min, e.lower, 0.01);
      EXPECT_NEAR(floor_max, e.lower, 0.01);
    }
    if (e.upper_ref == "AMSL") {
      EXPECT_NEAR(ceiling_min, e.upper, 0.01);
      EXPECT_NEAR(ceiling_max, e.upper, 0.01);
    }
    // AGL limits: on the surface, which the DSM's heights bound (the mesh's lowest point where a
    // corner is off it), and for two AGL limits their difference at every corner (feet converted).
    if (e.lower_ref == "AGL") {
      EXPECT_GE(floor_min - e.lower, dsm_low - 0.1);
      EXPECT_LE(floor_max - e.lower, dsm_high + 0.1);
    }
    if (e.upper_ref == "AGL") {
      EXPECT_GE(ceiling_min - e.upper, dsm_low - 0.1);
      EXPECT_LE(ceiling_max - e.upper, dsm_high + 0.1);
    }
    if (e.lower_ref == "AGL" && e.upper_ref == "AGL") {
      EXPECT_NEAR(number(tag, "thickness-min"), e.upper - e.lower, 1e-6);
      EXPECT_NEAR(number(tag, "thickness-max"), e.upper - e.lower, 1e-6);
    }
    // No floor: from the mesh's lowest point (the DSM's lowest, as the 5 m median keeps it).
    if (e.lower_ref.empty()) {
      EXPECT_EQ(floor_min, floor_max);
      EXPECT_NEAR(floor_min, dsm_low, 1.0);
    }
    EXPECT_GT(ceiling_min, floor_max - 1e-9);
    // The first corner: where GDAL puts the file's first position in the mesh's CRS, and its AGL
    // limits on the GLB's surface there (glb_surface()), or on the mesh's lowest point
    // off the mesh.
    double corner[4] = {};
    ASSERT_EQ(std::sscanf(text(tag, "first-corner").c_str(), "%lf,%lf,%lf,%lf", &corner[0], &corner[1], &corner[2],
                          &corner[3]),
              4);
    if (!e.circle) {
      double x = e.lon, y = e.lat;
      ASSERT_TRUE(to_utm32(x, y));
      EXPECT_NEAR(corner[0], x, 0.01);
      EXPECT_NEAR(corner[1], y, 0.01);
    }
    const bool on_mesh = corner[0] >= dsm.x0 + 2.5 && corner[0] <= dsm.x0 + dsm.width * dsm.dx - 2.5 &&
                         corner[1] <= dsm.y0 - 2.5 && corner[1] >= dsm.y0 + dsm.height * dsm.dy + 2.5;
    for (const auto& [ref, h, z] :
         {std::tuple{e.lower_ref, e.lower, corner[2]}, std::tuple{e.upper_ref, e.upper, corner[3]}})
      if (ref == "AGL" && on_mesh) {
        const std::vector<double> surface = glb_surface(dsm, corner[0], corner[1]);
        ASSERT_EQ(surface.size(), 2u);
        std::printf("%s: first corner %.2f, %.2f: %s %g m above %.2f (the GLB's surface %.2f or %.2f)\n",
                    e.name.c_str(), corner[0], corner[1], ref.c_str(), h, z - h, surface[0], surface[1]);
        // Split along its higher diagonal, the square's surface is the higher of the two.
        EXPECT_NEAR(z - h, std::max(surface[0], surface[1]), 0.02) << ref << " " << h;
      } else if (ref == "AGL") {
        EXPECT_NEAR(z - h, floor_min_of_mesh, 1e-6);
      }
  }

  // And seen: the zones' dark red tint covers much of the picture, and nothing of it is there
  // without the zones.
  const auto reddish = [](const Picture& picture) {
    size_t n = 0;
    for (size_t i = 0; i + 2 < picture.rgb.size(); i += 3)
      n += picture.rgb[i] > picture.rgb[i + 1] + 60 && picture.rgb[i] > picture.rgb[i + 2] + 60;
    return n;
  };
  const std::string with = scene.dir.path("zones.png"), without = scene.dir.path("no_zones.png");
  run_chromium(scene.dir, view.url(), "--screenshot=" + with);
  run_chromium(scene.dir, view.url().substr(0, view.url().find("&zones=")), "--screenshot=" + without);
  const size_t red_with = reddish(read_png(with)), red_without = reddish(read_png(without));
  std::printf("reddish pixels: %zu with the zones, %zu without\n", red_with, red_without);
  EXPECT_GT(red_with, 480000u / 10);
  EXPECT_LT(red_without, 100u);
}

TEST(View, DrawsGeoJsonZonesFromTheGroundToTheClampedTopAndRepeatsNoFly) {
  // A GeoJSON file written here over the crop: a square with no limits (from below the ground to
  // no top) and one from 30 to 90 m above the ground that does not block; then the ED-269 file
  // as a second --no-fly, its six zones after these two.
  Scene scene;
  const auto lonlat = [](double x, double y) {
    EXPECT_TRUE(transform_point(25832, 4326, x, y));
    return Json::array({x, y});
  };
  const auto square = [&](double x, double y, double h) {
    return Json::array({Json::array({lonlat(x - h, y - h), lonlat(x + h, y - h), lonlat(x + h, y + h),
                                     lonlat(x - h, y + h), lonlat(x - h, y - h)})});
  };
  const Json collection{{"type", "FeatureCollection"},
                        {"features",
                         {{{"type", "Feature"},
                           {"properties", {{"name", "Open sky"}}},
                           {"geometry", {{"type", "Polygon"}, {"coordinates", square(356450, 5699400, 40)}}}},
                          {{"type", "Feature"},
                           {"properties",
                            {{"id", "CND-1"},
                             {"restriction", "CONDITIONAL"},
                             {"lower", 30},
                             {"lower_ref", "AGL"},
                             {"upper", 90},
                             {"upper_ref", "AGL"}}},
                           {"geometry", {{"type", "Polygon"}, {"coordinates", square(356650, 5699600, 30)}}}}}}};
  const std::string geojson = scene.dir.path("zones.geojson");
  testkit::write_file(geojson, collection.dump());
  const std::string ed269 = std::string(DSMPLAN_TESTS_DIR) + "/data/airspace/nrw_zones_ed269.json";
  ViewServer view(scene.dir, {scene.mesh, "--no-fly", geojson, "--no-fly", ed269, "--vertical-crs", "EPSG:7837",
                              "--allow-approximate-vertical"});
  ASSERT_FALSE(view.url().empty());
  const std::string dom = run_chromium(scene.dir, view.url(), "--dump-dom");
  EXPECT_NE(dom.find("; 8 no-fly zones"), std::string::npos) << element_text(dom, "div", "status");
  std::vector<std::string> items;
  for (size_t at = dom.find("<li "); at != std::string::npos; at = dom.find("<li ", at + 1))
    items.push_back(dom.substr(at, dom.find('>', at) - at));
  ASSERT_EQ(items.size(), 8u) << element_text(dom, "ul", "zones");
  const auto value = [](const std::string& tag, const std::string& name) {
    const size_t begin = tag.find(" data-" + name + "=\"") + name.size() + 8;
    return tag.substr(begin, tag.find('"', begin) - begin);
  };
  EXPECT_EQ(value(items[0], "caption"), "Open sky");
  EXPECT_EQ(value(items[1], "caption"), "CND-1");  // no name: its identifier
  EXPECT_EQ(value(items[2], "caption"), "Courtyard ring");
  EXPECT_EQ(value(items[0], "blocks"), "true");  // GeoJSON's default restriction: PROHIBITED
  EXPECT_EQ(value(items[1], "blocks"), "false");
  EXPECT_EQ(value(items[0], "corners"), "4");
  // The mesh's lowest and highest points: the least and greatest 5 m block median, to 0.1 m.
  const Dsm dsm = read_dsm();
  double low = 1e30, high = -1e30;
  for (int j = 0; j < dsm.height / 5; ++j)
    for (int i = 0; i < dsm.width / 5; ++i) {
      std::vector<float> block;
      for (int r = 5 * j; r < 5 * j + 5; ++r)
        for (int c = 5 * i; c < 5 * i + 5; ++c) block.push_back(dsm.z[size_t(r) * dsm.width + c]);
      std::nth_element(block.begin(), block.begin() + 12, block.end());
      low = std::min(low, std::round(block[12] * 10.0) / 10.0),
      high = std::max(high, std::round(block[12] * 10.0) / 10.0);
    }
  std::printf("the mesh from %.2f to %.2f m; open sky drawn from %s to %s\n", low, high,
              value(items[0], "floor-min").c_str(), value(items[0], "ceiling-max").c_str());
  // No floor: from the mesh's lowest point; no top: 120 m above its highest; flat both.
  for (const char* key : {"floor-min", "floor-max"}) EXPECT_NEAR(std::stod(value(items[0], key)), low, 0.01) << key;
  for (const char* key : {"ceiling-min", "ceiling-max"})
    EXPECT_NEAR(std::stod(value(items[0], key)), high + 120, 0.01) << key;
  // 30 to 90 m above the ground: 60 m thick at every corner.
  EXPECT_NEAR(std::stod(value(items[1], "thickness-min")), 60, 1e-6);
  EXPECT_NEAR(std::stod(value(items[1], "thickness-max")), 60, 1e-6);
}

// Issue 52: an x,y,agl waypoint file is drawn where `dsmplan plan` flies it: each sphere at its
// height above the DSM cell under it (GDAL's read of the DSM, the oracle), and refused in one line
// when nothing is given to measure from.
TEST(View, DrawsAnAglWaypointFileAtItsHeightAboveTheDsm) {
  testkit::TempDir dir;
  const std::string glb = dir.path("m.glb"), agl = dir.path("agl.csv");
  ASSERT_EQ(testkit::run_cli({"mesh", testkit::data_path(kDsm), "--res", "25", "-o", glb, "-q"}).exit_code, 0);
  const std::vector<std::array<double, 3>> asked{{356412.3, 5699321.7, 20}, {356655.5, 5699604.1, 35.5}};
  std::string text = "x,y,agl\n";
  for (const auto& p : asked)
    text += std::to_string(p[0]) + "," + std::to_string(p[1]) + "," + std::to_string(p[2]) + "\n";
  testkit::write_file(agl, text);

  const auto refused = testkit::run_cli({"view", glb, "--waypoints", agl});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.err;
  EXPECT_NE(refused.err.find(agl + ": line 1: its header names the height column agl"), std::string::npos)
      << refused.err;
  EXPECT_NE(refused.err.find("give --dtm or --dsm"), std::string::npos) << refused.err;

  const Dsm dsm = read_dsm();
  ViewServer server(dir, {glb, "--waypoints", agl, "--dsm", testkit::data_path(kDsm)});
  ASSERT_FALSE(server.url().empty());
  httplib::Client client("127.0.0.1", server.port());
  const auto served = client.Get("/data/waypoints.csv");
  ASSERT_TRUE(served);
  ASSERT_EQ(served->status, 200);
  const auto drawn = read_xyz(served->body);
  ASSERT_EQ(drawn.size(), asked.size()) << served->body;
  for (size_t i = 0; i < asked.size(); ++i) {
    const int col = int(std::floor((asked[i][0] - dsm.x0) / dsm.dx)),
              row = int(std::floor((asked[i][1] - dsm.y0) / dsm.dy));
    const double ground = dsm.z[size_t(row) * dsm.width + col];
    EXPECT_NEAR(drawn[i][0], asked[i][0], 1e-3);
    EXPECT_NEAR(drawn[i][1], asked[i][1], 1e-3);
    EXPECT_NEAR(drawn[i][2], ground + asked[i][2], 1e-3) << "waypoint " << i + 1;
  }
}
