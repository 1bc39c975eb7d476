// Issue 36, point 5: `dsmplan serve` under load on the loopback. Starts the server on the NRW
// tile's XY-3 mesh at 1 m (`dsmplan mesh TILE -o MESH`, as bench/plan_process.sh makes it), picks
// 2-waypoint requests 200-1,500 m apart (x, y uniform over the tile, each waypoint HEIGHT m above
// the DSM there; pairs the server refuses, e.g. above the ceiling over a roof, are drawn again and
// counted), then holds CLIENTS keep-alive clients sending them for SECONDS and prints the
// throughput, the latency's p50/p99/max, the errors, and how the cores were shared (CPU seconds
// of the server and of this client, from /proc and getrusage; the load average).
//   bench_serve_load DSMPLAN MESH MAX_AGL HEIGHT [SECONDS=60] [CLIENTS=4] [THREADS=2]
#include <httplib.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"

extern char** environ;
using namespace dsmplan;
using Clock = std::chrono::steady_clock;

namespace {

double cpu_seconds_of(pid_t pid) {  // utime + stime of a process, from /proc
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), {});
  size_t at = stat.rfind(')') + 2;
  std::vector<std::string> fields;
  for (size_t next; (next = stat.find(' ', at)) != std::string::npos; at = next + 1)
    fields.push_back(stat.substr(at, next - at));
  return (std::stod(fields[11]) + std::stod(fields[12])) / sysconf(_SC_CLK_TCK);
}

double own_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

int start_server(const std::string& cli, const std::string& mesh, const std::string& agl, const std::string& threads,
                 const std::string& log, pid_t& pid) {
  std::vector<std::string> args{cli,         "serve", mesh,        "--port", "0",       "-q",
                                "--max-agl", agl,     "--threads", threads,  "--queue", "256"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  if (posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) return -1;
  for (int i = 0; i < 1200; ++i) {
    std::ifstream in(log);
    std::string text((std::istreambuf_iterator<char>(in)), {});
    if (const auto at = text.find("http://127.0.0.1:");
        at != std::string::npos && text.find(' ', at) != std::string::npos)
      return std::stoi(text.substr(at + 17));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return -1;
}

// Requests the server answers: 2 waypoints 200-1,500 m apart, `height` above the DSM.
std::vector<std::string> make_requests(int port, const Grid& dsm, double height, size_t count, size_t& refused) {
  std::mt19937_64 random(36);
  std::uniform_real_distribution<double> x(dsm.x0 + 20, dsm.x0 + dsm.width * dsm.cell_x - 20),
      y(dsm.y0 - dsm.height * dsm.cell_y + 20, dsm.y0 - 20);
  httplib::Client client("127.0.0.1", port);
  std::vector<std::string> bodies;
  for (size_t drawn = 0; bodies.size() < count && drawn < 100 * count; ++drawn) {
    const double ax = x(random), ay = y(random), bx = x(random), by = y(random);
    const double d = std::hypot(bx - ax, by - ay);
    const float az = dsm.height_at(ax, ay), bz = dsm.height_at(bx, by);
    if (d < 200 || d > 1500 || !std::isfinite(az) || !std::isfinite(bz)) continue;
    char body[256];
    std::snprintf(body, sizeof body, "{\"waypoints\":[[%.2f,%.2f,%.2f],[%.2f,%.2f,%.2f]],\"format\":\"csv\"}", ax, ay,
                  az + height, bx, by, bz + height);
    const auto r = client.Post("/v1/plan", body, "application/json");
    if (r && r->status == 200)
      bodies.push_back(body);
    else
      ++refused;
  }
  return bodies;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: bench_serve_load DSMPLAN MESH MAX_AGL HEIGHT [SECONDS=60] [CLIENTS=4] [THREADS=2]\n");
    return 2;
  }
  const double seconds = argc > 5 ? std::atof(argv[5]) : 60;
  const int clients = argc > 6 ? std::atoi(argv[6]) : 4;
  const std::string threads = argc > 7 ? argv[7] : "2";
  const std::string log = "/tmp/bench_serve_load_" + std::to_string(getpid()) + ".log";
  pid_t server = 0;
  const int port = start_server(argv[1], argv[2], argv[3], threads, log, server);
  if (port < 0) return std::fprintf(stderr, "the server did not start (%s)\n", log.c_str()), 1;
  const Grid dsm = read_raster(bench::tile);
  size_t refused = 0;
  const std::vector<std::string> bodies = make_requests(port, dsm, std::atof(argv[4]), 200, refused);
  std::printf(
      "machine: %ld cores, %s; load average %s at the start; max_agl %s, waypoints %s m above the DSM, "
      "%d clients, %s workers; 200 requests (%zu drawn pairs refused)\n",
      sysconf(_SC_NPROCESSORS_ONLN), bench::cpu_model().c_str(), bench::load_average().c_str(), argv[3], argv[4],
      clients, threads.c_str(), refused);
  std::atomic<bool> stop{false};
  std::atomic<size_t> errors{0};
  std::vector<std::vector<double>> latencies(clients);
  const double server_cpu0 = cpu_seconds_of(server), own_cpu0 = own_cpu_seconds();
  const auto start = Clock::now();
  std::vector<std::thread> pool;
  for (int c = 0; c < clients; ++c)
    pool.emplace_back([&, c] {
      httplib::Client client("127.0.0.1", port);
      client.set_keep_alive(true);
      client.set_tcp_nodelay(true);
      for (size_t i = c; !stop; i += clients) {
        const auto t0 = Clock::now();
        const auto r = client.Post("/v1/plan", bodies[i % bodies.size()], "application/json");
        latencies[c].push_back(std::chrono::duration<double>(Clock::now() - t0).count());
        if (!r || r->status != 200) ++errors;
      }
    });
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  stop = true;
  for (auto& t : pool) t.join();
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  const double server_cpu = cpu_seconds_of(server) - server_cpu0, own_cpu = own_cpu_seconds() - own_cpu0;
  kill(server, SIGTERM);
  waitpid(server, nullptr, 0);
  std::vector<double> all;
  for (const auto& l : latencies) all.insert(all.end(), l.begin(), l.end());
  std::sort(all.begin(), all.end());
  const auto at = [&](double q) { return all[std::min(all.size() - 1, size_t(q * all.size()))] * 1000; };
  std::printf(
      "%zu requests in %.1f s: %.0f req/s, latency p50 %.2f ms, p99 %.2f ms, max %.2f ms, %zu errors; "
      "CPU: server %.1f s (%.2f cores), client %.1f s (%.2f cores); load average %s at the end\n",
      all.size(), wall, all.size() / wall, at(0.5), at(0.99), all.back() * 1000, errors.load(), server_cpu,
      server_cpu / wall, own_cpu, own_cpu / wall, bench::load_average().c_str());
  return errors == 0 ? 0 : 1;
}
