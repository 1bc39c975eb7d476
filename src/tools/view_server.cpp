// dsmplan view: the three.js viewer of web/viewer and the files it shows, over HTTP on localhost,
// with Debian's cpp-httplib. Only the viewer's folder and the named files are served.
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "core/text.hpp"
#include "dsmplan/plan_job.hpp"
#include "dsmplan/view.hpp"
#include "http_server.hpp"
#include "tools/job_parts.hpp"
#include "view_proxy.hpp"

namespace dsmplan {

namespace fs = std::filesystem;

namespace {

// Module scripts are run only when served with a JavaScript type (HTML spec, "fetch a module
// script"), so the type matters here, not only for politeness.
const char* content_type(const fs::path& file) {
  static const std::map<std::string, const char*> types{{".html", "text/html; charset=utf-8"},
                                                        {".js", "text/javascript; charset=utf-8"},
                                                        {".mjs", "text/javascript; charset=utf-8"},
                                                        {".json", "application/json"},
                                                        {".css", "text/css"},
                                                        {".glb", "model/gltf-binary"},
                                                        {".csv", "text/csv; charset=utf-8"},
                                                        {".png", "image/png"},
                                                        {".svg", "image/svg+xml"},
                                                        {".wasm", "application/wasm"}};
  const auto it = types.find(lower_case(file.extension().string()));
  return it == types.end() ? "application/octet-stream" : it->second;
}

bool read_whole(const fs::path& file, std::string& bytes) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return false;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  bytes = std::move(buffer).str();
  return true;
}

void check_glb(const std::string& path) {
  if (!fs::is_regular_file(path)) throw InputError(path, "", "no such file");
  if (lower_case(fs::path(path).extension().string()) != ".glb")
    throw InputError(path, "", "not a .glb (write one with dsmplan mesh|simplify -o MESH.glb)");
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  if (!in.read(magic, 4) || std::string(magic, 4) != "glTF")
    throw InputError(path, "", "not a GLB (binary glTF): it does not start with 'glTF'");
}

void check_csv(const std::string& path, const char* what) {
  if (!fs::is_regular_file(path)) throw InputError(path, "", "no such file");
  // The viewer reads the same "x,y,z" lines; a broken file is refused here with its line number.
  if (read_waypoints_csv(path).empty()) throw InputError(path, "", std::string("no points in the ") + what);
}

// True for "ADDRESS:PORT" with our port and an IP address or "localhost" before it: a name
// of any other site (DNS rebinding) is refused, an address a user typed is not.
bool host_is_ours(const std::string& host, const std::string& port) {
  const size_t colon = host.rfind(':');
  if (colon == std::string::npos || host.substr(colon + 1) != port || colon == 0) return false;
  const std::string name = lower_case(host.substr(0, colon));
  if (name == "localhost") return true;
  if (name.front() == '[') return name.back() == ']';  // IPv6 literal
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isdigit(static_cast<unsigned char>(c)) || c == '.'; });
}

}  // namespace

std::string default_viewer_dir() {
  std::error_code error;
  const fs::path exe = fs::read_symlink("/proc/self/exe", error);
  if (error) return "web/viewer";
  return (exe.parent_path() / "web" / "viewer").string();
}

namespace {

// The options and the viewer's folder, before the port is taken; the folder checked.
fs::path checked_viewer_dir(const ViewOptions& options) {
  check_glb(options.mesh);
  if (!options.path.empty()) check_csv(options.path, "path");
  if (!options.waypoints.empty()) check_csv(options.waypoints, "waypoints");
  for (const std::string& raster : {options.dtm, options.dsm})
    if (!raster.empty() && !fs::is_regular_file(raster)) throw InputError(raster, "", "no such file");
  if (options.port < 0 || options.port > 65535)
    throw ArgumentError("--port", "must be 0 (any free port) to 65535, got " + std::to_string(options.port));
  if (!(options.request_deadline_seconds >= 0.001 && options.request_deadline_seconds <= 86400))
    throw ArgumentError("request_deadline_seconds",
                        "must be 0.001 to 86400, got " + short_number(options.request_deadline_seconds));
  const fs::path viewer = options.viewer_dir.empty() ? fs::path(default_viewer_dir()) : fs::path(options.viewer_dir);
  for (const char* part : {"index.html", "viewer.js"})
    if (!fs::is_regular_file(viewer / part))
      throw InputError(viewer.string(), "", std::string("no ") + part + ": not the viewer's folder (--viewer-dir)");
  if (!fs::is_regular_file(viewer / "node_modules/three/build/three.module.js"))
    throw InputError(viewer.string(), "",
                     "three is not installed in node_modules (scripts/build.sh installs it: npm ci from web/viewer)");
  return viewer;
}

void refuse(httplib::Response& response, const std::string& why) {
  response.status = 403;
  response.set_content("refused: " + why + "\n", "text/plain");
}

// Answers a GET: the data files under fixed names (no file name reaches a URL or the disk from a
// request), everything else inside the viewer's folder; the bare address is sent to `query`.
struct ViewFiles {
  fs::path viewer, viewer_real;
  std::map<std::string, fs::path> data;
  std::map<std::string, std::string> made;  // made in memory at start: the zones' JSON
  std::string query;
  const std::string* port;  // the port listened on, set before the first request

  // A page of another site that made its name resolve to this address (DNS rebinding) sends
  // its own name as Host: only an address (or "localhost") with our port is answered.
  bool admitted(const httplib::Request& request, httplib::Response& response) const {
    const std::string host = request.get_header_value("Host");
    if (host_is_ours(host, *port)) return true;
    refuse(response, "Host '" + host + "' is not an address of this server (port " + *port + ")");
    return false;
  }

  // The service's routes, passed on. Another site's page may send this server a POST (a form, or
  // fetch without CORS): its Origin differs from our address, and a form cannot send JSON
  // without the preflight this server never grants, so both are refused before the service sees them.
  void pass(const httplib::Request& request, httplib::Response& response, const ServiceProxy& proxy) const {
    if (!admitted(request, response)) return;
    const std::string origin = request.get_header_value("Origin");
    if (!origin.empty() && origin != "http://" + request.get_header_value("Host"))
      return refuse(response, "Origin '" + origin + "' is not this server's page");
    if (request.method == "POST" && request.get_header_value("Content-Type").rfind("application/json", 0) != 0) {
      response.status = 415;
      return response.set_content("refused: the plan must be sent as application/json\n", "text/plain");
    }
    proxy.forward(request, response);
  }

  void answer(const httplib::Request& request, httplib::Response& response) const {
    if (!admitted(request, response)) return;
    // request.path is percent-decoded already, so "%2e%2e" is caught here too.
    const std::string& url = request.path;
    if (url == "/" && request.params.empty()) return response.set_redirect(query);
    if (const auto it = made.find(url); it != made.end()) {
      response.set_header("Cache-Control", "no-store");
      return response.set_content(it->second, "application/json");
    }
    fs::path file;
    if (const auto it = data.find(url); it != data.end()) {
      file = it->second;
    } else if (url.empty() || url[0] != '/' || url.find("..") != std::string::npos ||
               url.find("//") != std::string::npos || url.find('\\') != std::string::npos ||
               url.find('\0') != std::string::npos || url.find("/.") != std::string::npos) {
      // ".." climbs out of the folder; "//etc" would join as the absolute "/etc"; "/." is a
      // dotfile or dot folder (.git, .env, .npmrc), never part of the viewer.
      return refuse(response, "only files inside the viewer's folder, no dotfiles");
    } else {
      file = viewer / (url == "/" ? std::string("index.html") : url.substr(1));
      // A symbolic link inside the folder may point anywhere: what it resolves to must be inside too.
      std::error_code error;
      const fs::path real = fs::weakly_canonical(file, error);
      const auto [end, rest] = std::mismatch(viewer_real.begin(), viewer_real.end(), real.begin(), real.end());
      if (error || end != viewer_real.end()) return refuse(response, "only files inside the viewer's folder");
    }
    std::string bytes;
    if (!fs::is_regular_file(file) || !read_whole(file, bytes)) {
      response.status = 404;
      response.set_content("not found: " + url + "\n", "text/plain");
      return;
    }
    // The files change between runs (a new mesh, a new path) under the same names.
    response.set_header("Cache-Control", "no-store");
    response.set_content(std::move(bytes), content_type(file));
  }
};

// The waypoints as the page draws them, x,y,z in the CRS: an agl file's heights measured as
// `dsmplan plan` measures them (read_picture_waypoints()).
std::string waypoints_csv(const ViewOptions& options) {
  const std::string& ground_file = options.dtm.empty() ? options.dsm : options.dtm;
  std::optional<Grid> ground;  // read only for an agl file
  const auto ground_of = [&]() -> const Grid* {
    if (ground_file.empty()) return nullptr;
    ground = read_raster(ground_file);
    return &*ground;
  };
  return path_to_csv(
      read_picture_waypoints(options.waypoints, ground_of, options.dtm.empty() ? "dsm" : "dtm", "give --dtm or --dsm"));
}

}  // namespace

void serve_view(const ViewOptions& options, const std::function<void(const std::string& url)>& listening) {
  std::string port_text;
  ViewFiles files{checked_viewer_dir(options), {},        {{"/data/mesh.glb", options.mesh}}, {},
                  "/?mesh=/data/mesh.glb",     &port_text};
  files.viewer_real = fs::canonical(files.viewer);
  if (!options.path.empty()) files.data["/data/path.csv"] = options.path, files.query += "&path=/data/path.csv";
  if (!options.waypoints.empty())
    files.made["/data/waypoints.csv"] = waypoints_csv(options), files.query += "&waypoints=/data/waypoints.csv";
  if (!options.no_fly.files.empty())
    files.made["/data/zones.json"] = view_zones_json(options.no_fly, options.mesh),
    files.query += "&zones=/data/zones.json";
  std::unique_ptr<ServiceProxy> proxy;
  if (!options.serve.empty())
    proxy = std::make_unique<ServiceProxy>(options.serve, options.serve_token_file), files.query += "&service=/v1";
  else if (!options.serve_token_file.empty())
    throw ArgumentError("--serve-token-file", "is the token of the service --serve names: give --serve too");

  // A slow or idle client holds a connection thread for a bounded time: a request (head and
  // body) must arrive within the deadline (a client sending a header byte a second was held for
  // as long as it kept sending), an idle connection is dropped after 2 s (httplib's defaults,
  // 5 s on a pool of a few threads, let 40 of them block the page for 20 s), and up to 256
  // connections are served at once, each on a thread of its own, the others in arrival order.
  RequestLimits limits;
  limits.deadline = std::chrono::milliseconds(std::lround(options.request_deadline_seconds * 1000));
  DeadlineServer server(limits);
  server.set_read_timeout(2, 0);
  server.set_keep_alive_timeout(2);
  server.set_payload_max_length(64 * 1024);  // the viewer takes no bodies: any is junk
  if (proxy) {                               // before the files' route, which would take the GETs
    const auto pass = [&files, &proxy](const httplib::Request& q, httplib::Response& r) { files.pass(q, r, *proxy); };
    for (const char* route : {"/v1/info", "/v1/health"}) server.Get(route, pass);
    server.Post("/v1/plan", pass);
  }
  server.Get(R"(/.*)", [&files](const httplib::Request& request, httplib::Response& response) {
    files.answer(request, response);
  });
  const int port = bind_listening(server, options.host, options.port);
  const std::string authority =
      (options.host.find(':') != std::string::npos ? "[" + options.host + "]" : options.host) + ":" +
      std::to_string(port);
  port_text = std::to_string(port);
  const std::string url = "http://" + authority + files.query;
  listening(url);
  if (!server.listen_after_bind()) throw OutputError(url, "the server stopped");
}

}  // namespace dsmplan
