// dsmplan serve end to end: the binary serves a mesh of the bundled NRW crop on an ephemeral
// port; its answers are checked against the real `dsmplan plan` run on the same request (the
// oracle: the command line's files, byte for byte), and its limits against what the issue asks:
// each error status, concurrency, the token, SIGTERM's drain, a slow client, memory that stays flat.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "testkit.hpp"

extern char** environ;

namespace {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

const std::string kDsm = "nrw-dom1/nrw_dom1_crop500m_1m.tif";
const std::string kWaypoints = "nrw-dom1/sample_waypoints.csv";
// The sample's three waypoints (x, y, z in EPSG:25832).
const std::vector<std::array<double, 3>> kPoints = {
    {356320, 5699270, 130}, {356560, 5699500, 145}, {356780, 5699730, 135}};

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

// The mesh every test serves: the crop's XY-3 mesh at 1 m, made once.
const std::string& sample_mesh() {
  static testkit::TempDir* dir = new testkit::TempDir;
  static const std::string mesh = [] {
    const std::string path = dir->path("crop.ply");
    const auto made = testkit::run_cli({"mesh", testkit::data_path(kDsm), "-o", path, "-q"});
    if (made.exit_code != 0) throw std::runtime_error("dsmplan mesh failed: " + made.err);
    return path;
  }();
  return mesh;
}

// `dsmplan serve MESH ... --port 0` for the life of the object.
class Server {
public:
  // `vertical`: the sample's vertical reference given (the DSM itself names none).
  explicit Server(std::vector<std::string> args = {}, bool vertical = true) : log_(dir_.path("server.log")) {
    args.insert(args.begin(), {DSMPLAN_CLI, "serve", sample_mesh()});
    args.insert(args.end(), {"--port", "0", "-q"});
    if (vertical) args.insert(args.end(), {"--vertical-crs", "EPSG:7837", "--allow-approximate-vertical"});
    // A request's first roadmap takes seconds on a machine the whole suite shares: the default
    // 10 s budget is tested on its own (504), not by the load of the other tests.
    if (std::find(args.begin(), args.end(), "--budget") == args.end()) args.insert(args.end(), {"--budget", "600"});
    pid_ = spawn(args, log_);
    for (const auto end = Clock::now() + std::chrono::seconds(60); Clock::now() < end;) {
      const std::string out = testkit::read_file(log_);
      const auto at = out.find("http://127.0.0.1:");
      if (at != std::string::npos && out.find(' ', at) != std::string::npos) {
        first_line_ = out.substr(0, out.find('\n'));
        port_ = std::stoi(out.substr(at + 17, out.find(' ', at) - at - 17));
        return;
      }
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("dsmplan serve stopped: " + out);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    throw std::runtime_error("dsmplan serve printed no address in 60 s: " + testkit::read_file(log_));
  }
  ~Server() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  const std::string& first_line() const { return first_line_; }
  std::string log() const { return testkit::read_file(log_); }
  // Sends SIGTERM and waits for the exit code (-1: still running after `limit`).
  int terminate(std::chrono::seconds limit) {
    kill(pid_, SIGTERM);
    const auto end = Clock::now() + limit;
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) == 0) {
      if (Clock::now() > end) return -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  long rss_kib() const {
    std::ifstream in("/proc/" + std::to_string(pid_) + "/status");
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
    return -1;
  }

private:
  testkit::TempDir dir_;
  std::string log_, first_line_;
  pid_t pid_ = -1;
  int port_ = 0;
};

struct Reply {
  int status = -1;
  std::string body;
  Json json() const { return Json::parse(body); }
};

Reply post(int port, const std::string& body, const std::string& token = "") {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(60, 0);
  httplib::Headers headers;
  if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
  const auto result = client.Post("/v1/plan", headers, body, "application/json");
  if (!result) return {};
  return {result->status, result->body};
}

Reply get(int port, const std::string& path) {
  httplib::Client client("127.0.0.1", port);
  const auto result = client.Get(path.c_str());
  if (!result) return {};
  return {result->status, result->body};
}

Json waypoints_json(const std::vector<std::array<double, 3>>& points) {
  Json list = Json::array();
  for (const auto& p : points) list.push_back({p[0], p[1], p[2]});
  return list;
}

// What `dsmplan plan` writes for the same request: the oracle.
std::string cli_path(const testkit::TempDir& dir, const std::string& waypoints_file, const std::string& ext,
                     std::vector<std::string> more = {}) {
  const std::string out = dir.path("cli." + ext);
  std::vector<std::string> args{
      "plan", sample_mesh(), "--waypoints",    waypoints_file, "-o",
      out,    "-q",          "--vertical-crs", "EPSG:7837",    "--allow-approximate-vertical"};
  args.insert(args.end(), more.begin(), more.end());
  const auto run = testkit::run_cli(args);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  return testkit::read_file(out);
}

std::string decode_base64(const std::string& text) {
  std::string out;
  uint32_t buffer = 0;
  int bits = 0;
  for (char c : text) {
    const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const char* at = std::strchr(digits, c);
    if (c == '=' || !at) break;
    buffer = buffer << 6 | uint32_t(at - digits);
    if ((bits += 6) >= 8) out += char(buffer >> (bits -= 8) & 0xff);
  }
  return out;
}

TEST(Serve, SaysWhereItListensAndWhatItHolds) {
  Server server;
  EXPECT_NE(server.first_line().find("dsmplan serve: listening on http://127.0.0.1:"), std::string::npos)
      << server.first_line();
  const Reply health = get(server.port(), "/v1/health");
  EXPECT_EQ(health.status, 200);
  EXPECT_EQ(health.json()["status"], "ok");
  const Reply info = get(server.port(), "/v1/info");
  ASSERT_EQ(info.status, 200);
  const Json j = info.json();
  EXPECT_EQ(j["crs"]["epsg"], 25832);
  // The crop's extent (gdalinfo): x 356300..356800, y 5699250..5699750; the mesh joins the cells' centres.
  EXPECT_NEAR(j["extent"][0].get<double>(), 356300.5, 0.6);
  EXPECT_NEAR(j["extent"][3].get<double>(), 5699749.5, 0.6);
  EXPECT_EQ(j["limits"]["safety_min_m"], 2.0);
  EXPECT_GT(j["loaded"]["roadmap"]["nodes"].get<int>(), 100);
}

TEST(Serve, AnswersTheSameBytesAsDsmplanPlan) {
  Server server;
  testkit::TempDir dir;
  const std::string csv = testkit::data_path(kWaypoints);
  for (const std::string format : {"csv", "geojson", "kml", "plan", "waypoints"}) {
    const Reply reply = post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}, {"format", format}}.dump());
    ASSERT_EQ(reply.status, 200) << format << ": " << reply.body;
    EXPECT_EQ(reply.json()["path"].get<std::string>(), cli_path(dir, csv, format)) << format;
  }
  // A mission with options, and a lower ceiling and larger safety than the server's.
  const Json mission{{"waypoints", waypoints_json(kPoints)},
                     {"format", "plan"},
                     {"safety", 3},
                     {"max_agl", 60},
                     {"mission", {{"end", "rtl"}, {"firmware", "px4"}, {"speed", 7}}}};
  const Reply reply = post(server.port(), mission.dump());
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.json()["path"].get<std::string>(),
            cli_path(dir, csv, "plan",
                     {"--safety", "3", "--max-agl", "60", "--end", "rtl", "--firmware", "px4", "--speed", "7"}));
  // GeoJSON waypoints in WGS 84: the command line's own GeoJSON path read back as waypoints.
  const std::string geo = dir.path("waypoints.geojson");
  testkit::write_file(geo, cli_path(dir, csv, "geojson"));
  const Reply from_geo = post(server.port(), "{\"waypoints\":" + testkit::read_file(geo) + ",\"format\":\"csv\"}");
  ASSERT_EQ(from_geo.status, 200) << from_geo.body;
  EXPECT_EQ(from_geo.json()["path"].get<std::string>(), cli_path(dir, geo, "csv"));
  // The figures are those of --stats (the timings aside).
  const std::string stats = dir.path("stats.json");
  cli_path(dir, csv, "csv", {"--stats", stats});
  const Json cli_stats = Json::parse(testkit::read_file(stats));
  const Json served =
      post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}, {"format", "csv"}}.dump()).json()["stats"];
  for (const char* key : {"path_length_m", "min_clearance_m", "max_agl_m", "ground", "roadmap_nodes", "roadmap_edges"})
    EXPECT_EQ(served[key], cli_stats[key]) << key;
  EXPECT_EQ(served["roadmap_reused"], true);
}

TEST(Serve, AnswersAKmzAsTheCommandLineWritesIt) {
  Server server;
  testkit::TempDir dir;
  const Reply reply = post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}, {"format", "kmz"}}.dump());
  ASSERT_EQ(reply.status, 200) << reply.body;
  const std::string kmz = decode_base64(reply.json()["path_base64"].get<std::string>());
  const std::string cli = cli_path(dir, testkit::data_path(kWaypoints), "kmz");
  EXPECT_EQ(kmz.substr(0, 2), "PK");
  EXPECT_EQ(kmz.size(), cli.size());
}

TEST(Serve, RefusesBadRequestsWithTheStatusAndOneLine) {
  Server server({"--max-body", "4096"});
  const int port = server.port();
  const auto expect = [&](const std::string& body, int status, const std::string& phrase) {
    const Reply reply = post(port, body);
    EXPECT_EQ(reply.status, status) << body << " -> " << reply.body;
    if (status != 413) {
      const std::string error = reply.json()["error"];
      EXPECT_NE(error.find(phrase), std::string::npos) << error;
      EXPECT_EQ(error.find('\n'), std::string::npos);
    }
  };
  const std::string wp = waypoints_json(kPoints).dump();
  expect("{", 400, "not JSON");
  expect(std::string(100, '['), 400, "nested");
  expect("[1,2]", 400, "JSON object");
  expect("{\"waypoints\":[[1,2]]}", 400, "waypoints[0]");
  expect("{\"waypoints\":" + wp + ",\"safety\":1}", 400, "safety: must be at least 2");
  expect("{\"waypoints\":" + wp + ",\"no_fly_buffer\":1}", 400, "no_fly_buffer: must be at least 2");
  expect("{\"waypoints\":" + wp + ",\"max_agl\":500}", 400, "max_agl: must lie in (0, 120]");
  expect("{\"waypoints\":" + wp + ",\"saftey\":3}", 400, "saftey: unknown key");
  expect("{\"waypoints\":" + wp + ",\"format\":\"shp\"}", 400,
         "format: must be csv, geojson, plan, waypoints, kmz or kml, got 'shp'");
  expect("{\"waypoints\":" + wp + ",\"format\":\"geojsn\"}", 400, "(did you mean geojson?)");
  expect("{\"waypoints\":" + wp + ",\"mission\":{\"end\":\"land\"}}", 400, "mission.end: applies to missions");
  expect("{\"waypoints\":" + wp + ",\"planner\":\"astar\"}", 400, "planner: must be prm, rrtconnect or freespace");
  expect("{\"waypoints\":" + wp + ",\"planner\":\"rrtconect\"}", 400, "(did you mean rrtconnect?)");
  expect("{\"waypoints\":" + wp + ",\"objective\":\"lowest\"}", 400, "objective: must be low or shortest");
  expect("{\"waypoints\":" + wp + ",\"mission\":{\"firmware\":\"PX4\"},\"format\":\"plan\"}", 400,
         "mission.firmware: must be px4, ardupilot or generic, got 'PX4' (did you mean px4?)");
  expect("{\"waypoints\":{\"type\":\"Point\"}}", 400, "waypoints");
  expect("{\"waypoints\":" + wp + ",\"x\":\"" + std::string(5000, 'a') + "\"}", 413, "");
  // Under the roofs: the planner's own reason, naming the waypoint.
  expect("{\"waypoints\":[[356320,5699270,130],[356560,5699500,100]]}", 422, "waypoint 2");
  // A home the data refuse is the data's fault (422), named by its key; a malformed one is 400.
  expect("{\"waypoints\":" + wp + ",\"format\":\"plan\",\"mission\":{\"home\":[356000,5699000]}}", 422,
         "mission.home: x 356000.00, y 5699000.00 lies outside the DSM");
  expect("{\"waypoints\":" + wp + ",\"format\":\"plan\",\"mission\":{\"home\":[356000]}}", 400, "mission.home");
  EXPECT_EQ(get(port, "/v1/nothing").status, 404);
}

// A server over the sample as it comes, its DSM naming no vertical reference: a request without
// "format" gets the CSV `dsmplan plan` writes (no vertical reference needed), /v1/info says so,
// and GeoJSON, whose heights need one, is refused as the data's fault (422) naming the key.
TEST(Serve, AnswersTheSampleByDefaultWithoutAVerticalReference) {
  Server server({}, false);
  const Json info = Json::parse(get(server.port(), "/v1/info").body);
  EXPECT_EQ(info["limits"]["default_format"], "csv") << info.dump();
  const Reply reply = post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}}.dump());
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.json()["format"], "csv");
  testkit::TempDir dir;
  EXPECT_EQ(reply.json()["path"], cli_path(dir, testkit::data_path(kWaypoints), "csv"));
  const Reply geojson = post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}, {"format", "geojson"}}.dump());
  EXPECT_EQ(geojson.status, 422) << geojson.body;
  const std::string error = geojson.json()["error"];
  EXPECT_EQ(error.rfind("format: 'geojson' needs heights", 0), 0u) << error;
  EXPECT_NE(error.find("csv needs none"), std::string::npos) << error;
  // With the vertical reference given, GeoJSON is the default again.
  Server named;
  EXPECT_EQ(Json::parse(get(named.port(), "/v1/info").body)["limits"]["default_format"], "geojson");
}

TEST(Serve, RequiresTheTokenWhenGivenOne) {
  testkit::TempDir dir;
  const std::string token = "s3cret-token-0123456789";
  testkit::write_file(dir.path("token"), token + "\n");
  Server server({"--token-file", dir.path("token")});
  const std::string body = Json{{"waypoints", waypoints_json(kPoints)}}.dump();
  EXPECT_EQ(post(server.port(), body).status, 401);
  EXPECT_EQ(post(server.port(), body, "wrong-token-0123456789").status, 401);
  EXPECT_EQ(get(server.port(), "/v1/info").status, 401);
  EXPECT_EQ(post(server.port(), body, token).status, 200);
}

TEST(Serve, ConcurrentAnswersEqualSequentialOnes) {
  Server server({"--threads", "2"});
  std::vector<std::string> bodies;
  for (size_t a = 0; a < 3; ++a)
    for (size_t b = 0; b < 3; ++b)
      if (a != b)
        for (double agl : {120.0, 60.0})
          bodies.push_back(
              Json{{"waypoints", waypoints_json({kPoints[a], kPoints[b]})}, {"max_agl", agl}, {"format", "csv"}}
                  .dump());
  std::vector<std::string> sequential;
  for (const auto& body : bodies) {
    const Reply reply = post(server.port(), body);
    ASSERT_EQ(reply.status, 200) << reply.body;
    sequential.push_back(reply.json()["path"]);
  }
  std::atomic<int> mismatches{0}, answered{0};
  std::vector<std::thread> clients;
  for (int t = 0; t < 6; ++t)
    clients.emplace_back([&, t] {
      for (size_t k = 0; k < 3 * bodies.size(); ++k) {
        const size_t i = (k + t) % bodies.size();
        const Reply reply = post(server.port(), bodies[i]);
        if (reply.status != 200 || reply.json()["path"] != sequential[i]) ++mismatches;
        ++answered;
      }
    });
  for (auto& c : clients) c.join();
  EXPECT_EQ(mismatches, 0);
  EXPECT_EQ(answered, 6 * 3 * static_cast<int>(bodies.size()));
}

TEST(Serve, AFullQueueAnswers503AndABudgetPassed504) {
  {
    Server server({"--threads", "1", "--queue", "0"});
    // Each safety of its own makes a roadmap of its own: a worker busy for a while.
    std::atomic<int> ok{0}, full{0}, other{0};
    std::vector<std::thread> clients;
    for (int t = 0; t < 8; ++t)
      clients.emplace_back([&, t] {
        const Reply r =
            post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}, {"safety", 2.1 + t * 0.1}}.dump());
        (r.status == 200 ? ok : r.status == 503 ? full : other)++;
        if (r.status == 503) EXPECT_NE(r.json()["error"].get<std::string>().find("queue is full"), std::string::npos);
      });
    for (auto& c : clients) c.join();
    EXPECT_GE(ok, 1);
    EXPECT_GE(full, 1);
    EXPECT_EQ(other, 0);
  }
  Server server({"--budget", "0.002"});
  const Reply r = post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}, {"safety", 4.5}}.dump());
  EXPECT_EQ(r.status, 504) << r.body;
  EXPECT_NE(r.json()["error"].get<std::string>().find("time budget"), std::string::npos);
}

// A request whose every waypoint lies under the ground: each refusal searched the nearest valid
// point (about 26 ms each on this mesh), 3,000 of them 79 s of a worker's time.
std::string buried_request(size_t count) {
  std::vector<std::array<double, 3>> points;
  for (size_t i = 0; i < count; ++i)
    points.push_back({356310.0 + double(i % 50) * 9, 5699260.0 + double(i / 50) * 7, 20});
  return Json{{"waypoints", waypoints_json(points)}}.dump();
}

// A request that is long to answer: 20,000 waypoints, the sample's three again and again, each
// moved by up to half a metre (no leg the same), every leg planned: seconds of a worker's time.
// (A safety of 900 m was such a request until the refusals' searches were bounded by their cost.)
std::string long_request() {
  std::vector<std::array<double, 3>> points;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> shift(-0.5, 0.5);
  for (size_t i = 0; i < 20000; ++i) {
    const auto& p = kPoints[i % kPoints.size()];
    const auto cm = [](double v) { return std::round(v * 100) / 100; };  // short numbers: under the 1 MiB limit
    points.push_back({cm(p[0] + shift(random)), cm(p[1] + shift(random)), cm(p[2] + 0.5 + shift(random))});
  }
  return Json{{"waypoints", waypoints_json(points)}}.dump();
}

TEST(Serve, ManyRefusedWaypointsAreAnsweredAtOnce) {
  Server server({"--threads", "1", "--budget", "10"});
  const auto start = Clock::now();
  const Reply r = post(server.port(), buried_request(3000));
  EXPECT_EQ(r.status, 422) << r.body;
  const std::string error = r.json()["error"].get<std::string>();
  EXPECT_EQ(error.rfind("waypoints: waypoint 1: under the surface", 0), 0u) << error;
  EXPECT_NE(error.find("valid point"), std::string::npos) << error;    // the nearest, or none within 50 m
  EXPECT_NE(error.find("and 2989 more"), std::string::npos) << error;  // the first 11 named
  // The nearest point is searched for the 11 named only: a second, not 79 s (20 s leaves room
  // for the sanitizers' build).
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - start).count(), 20.0);
}

TEST(Serve, SigtermStopsTheRequestsInFlightWithinTwoSeconds) {
  Server server({"--threads", "1"});
  Reply in_flight;
  std::thread client([&] { in_flight = post(server.port(), long_request()); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the worker is searching
  const int port = server.port();
  const auto start = Clock::now();
  EXPECT_EQ(server.terminate(std::chrono::seconds(30)), 0);
  const double took = std::chrono::duration<double>(Clock::now() - start).count();
  client.join();
  EXPECT_LT(took, 2.0) << "SIGTERM took " << took << " s to end the service";
  EXPECT_EQ(in_flight.status, 503) << in_flight.body;
  EXPECT_NE(in_flight.body.find("shutting down"), std::string::npos) << in_flight.body;
  EXPECT_EQ(get(port, "/v1/health").status, -1);  // refused: nobody listens
}

TEST(Serve, SigtermLetsAShortRequestInFlightFinish) {
  Server server({"--threads", "1"});
  std::atomic<int> status{0};
  // A request that builds a roadmap of its own (another safety): in flight when the signal comes,
  // and done within the grace (a fraction of a second alone; the grace is 1 s).
  std::thread client([&] {
    status = post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}, {"safety", 3.7}}.dump()).status;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  EXPECT_EQ(server.terminate(std::chrono::seconds(30)), 0);
  client.join();
  EXPECT_TRUE(status == 200 || status == 503) << status;  // 503 only when the machine is loaded past the grace
}

TEST(Serve, ARequestPastItsBudgetFreesItsWorkerAndSaysTheStage) {
  Server server({"--threads", "1", "--budget", "1"});
  const auto start = Clock::now();
  const Reply given_up = post(server.port(), long_request());
  const double answered = std::chrono::duration<double>(Clock::now() - start).count();
  EXPECT_EQ(given_up.status, 504) << given_up.body;
  const std::string error = given_up.json()["error"].get<std::string>();
  EXPECT_NE(error.find("time budget of 1 s (--budget), stopped while "), std::string::npos) << error;
  EXPECT_LT(answered, 2.5);  // the budget and its answer; the work would take seconds more
  // The one worker is free at once: before, it computed on for minutes and this one got 504 too.
  const Reply next = post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}}.dump());
  EXPECT_EQ(next.status, 200) << next.body;
}

TEST(Serve, ASlowClientGets408AndBlocksNoOne) {
  Server server({"--request-deadline", "1", "--threads", "1"});
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(server.port()));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  const std::string head = "POST /v1/plan HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 100\r\n\r\n{\"waypoints\":";
  ::send(fd, head.data(), head.size(), MSG_NOSIGNAL);  // and the rest never comes
  const auto start = Clock::now();
  const Reply other = post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}}.dump());
  EXPECT_EQ(other.status, 200);
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - start).count(), 0.9);
  std::string reply;
  char buffer[512];
  timeval wait{5, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &wait, sizeof wait);
  for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) reply.append(buffer, static_cast<size_t>(n));
  ::close(fd);
  EXPECT_EQ(reply.rfind("HTTP/1.1 408", 0), 0u) << reply;
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - start).count(), 3.0);
}

TEST(Serve, ResidentMemoryStaysFlat) {
  Server server({"--threads", "2"});
  const std::string body = Json{{"waypoints", waypoints_json({kPoints[0], kPoints[2]})}, {"format", "geojson"}}.dump();
  const auto load = [&](int n) {
    std::vector<std::thread> clients;
    for (int t = 0; t < 2; ++t)
      clients.emplace_back([&] {
        httplib::Client client("127.0.0.1", server.port());
        for (int i = 0; i < n / 2; ++i) ASSERT_EQ(client.Post("/v1/plan", body, "application/json")->status, 200);
      });
    for (auto& c : clients) c.join();
  };
  load(500);  // the arenas and caches settle
  const long before = server.rss_kib();
  load(3000);
  const long after = server.rss_kib();
  EXPECT_LE(after, before * 1.05) << before << " KiB after 500 requests, " << after << " KiB after 3500";
}

}  // namespace

// With the hand-made ED-269 zones over the crop: the same path bytes as `dsmplan plan --no-fly`,
// the zones in the figures, and a waypoint inside a zone answered 422 with the CLI's words.
TEST(Serve, KeepsOutOfTheNoFlyZonesAsThePlanCommandDoes) {
  const std::string zones = std::string(DSMPLAN_TESTS_DIR) + "/data/airspace/nrw_zones_ed269.json";
  Server server({"--no-fly", zones});
  testkit::TempDir dir;
  // The first and last of the sample's waypoints: the straight line between them crosses the
  // circle, which stands on the second.
  const std::vector<std::array<double, 3>> ends{kPoints.front(), kPoints.back()};
  const std::string ends_file = dir.path("ends.csv");
  testkit::write_file(ends_file, "x,y,z\n356320,5699270,130\n356780,5699730,135\n");
  const Reply reply = post(server.port(), Json{{"waypoints", waypoints_json(ends)}, {"format", "csv"}}.dump());
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.json()["path"].get<std::string>(), cli_path(dir, ends_file, "csv", {"--no-fly", zones}));
  const Json figures = reply.json()["stats"]["no_fly_zones"];
  ASSERT_EQ(figures.size(), 6u);
  for (const Json& zone : figures)
    if (zone["blocks"]) EXPECT_GE(zone["min_distance_m"].get<double>(), 2 - 0.01) << zone["zone"];
  // The sample's second waypoint stands in the file's 40 m circle; the server names the file by
  // its name only.
  const Reply refused = post(server.port(), Json{{"waypoints", waypoints_json(kPoints)}}.dump());
  EXPECT_EQ(refused.status, 422) << refused.body;
  const std::string error = refused.json()["error"];
  EXPECT_NE(error.find("waypoint 2: inside no-fly zone 'Centre circle' (DSM-T-CIRCLE) of nrw_zones_ed269.json"),
            std::string::npos)
      << error;
  EXPECT_EQ(error.find(DSMPLAN_TESTS_DIR), std::string::npos) << error;
}
