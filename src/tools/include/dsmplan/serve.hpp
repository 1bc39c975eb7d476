// dsmplan/serve.hpp: `dsmplan serve`, a resident planning service: one city's mesh, index, DSM,
// DTM and roadmap held in memory, paths answered over HTTP in the query's time, byte for byte as
// `dsmplan plan` writes them for the same request (docs/commands.md, "dsmplan serve", is the
// reference of the requests and answers).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/flight.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/wgs84.hpp"

namespace dsmplan {

struct ServeOptions {
  std::string mesh;   ///< obstacle mesh (.ply, .obj, .off) in a projected CRS, as `dsmplan plan` reads it
  std::string dsm;    ///< optional raw DSM: every path keeps `safety` from its columns
  std::string dtm;    ///< optional terrain: the ground max_agl counts from
  std::string index;  ///< optional kept clearance index (--index of `dsmplan plan`): opened, else built and written
  /// Optional roadmap file for the server's own options: read when it exists and fits, else built
  /// and written. Without it the roadmap is built in memory at start.
  std::string roadmap;
  std::string host = "127.0.0.1";   ///< another address is said on the first line, with a warning
  int port = 8080;                  ///< 0: any free port (the first line names it)
  int threads = 2;                  ///< workers planning at once, in [1, 256]
  int queue = 64;                   ///< requests waiting for a worker, at most (then 503), in [0, 100000]
  double budget_seconds = 10;       ///< a request's time from its arrival to its answer, at most (then 504), (0, 3600]
  size_t max_body_bytes = 1 << 20;  ///< a request body's bytes, at most (then 413), [1 KiB, 64 MiB]
  double request_deadline_seconds = 10;  ///< a request's head and body must arrive within this (then 408)
  /// File holding the bearer token every request must send (Authorization: Bearer ...); empty:
  /// none. Its first line, blanks trimmed, at least 16 characters.
  std::string token_file;
  /// The defaults of every request, and its bounds: a request may ask for a larger safety (never
  /// a smaller one) and a lower max_agl (never a higher one); spacing, max_edge, refine_rounds are
  /// the server's alone (they shape the roadmap).
  PlanOptions plan;
  VerticalOptions vertical;  ///< heights of GeoJSON, missions and KML, as `dsmplan plan` takes them
  /// No-fly zones every request keeps out of, and which restrictions block (`dsmplan plan --no-fly`).
  std::vector<std::string> no_fly, no_fly_blocking;

  /// ArgumentError naming the flag ("--threads", "--queue", "--budget", "--max-body", "--port",
  /// "--safety", ...) for a value out of the ranges above; InputError for a token file that cannot
  /// be read or holds too short a token.
  void check() const;
};

/// The service without its transport: the data checked and prepared once (FlightArea: index,
/// columns, ground; the roadmap of the server's options built or read), then any number of
/// requests answered from many threads at once. A request never names a file of the server.
class PlanService {
public:
  /// Reads the files as `dsmplan plan` does (InputError, ArgumentError as plan_job()), builds the
  /// clearance index and the roadmap.
  explicit PlanService(const ServeOptions& options, const Progress& progress = {});
  /// The same over data in memory (data.names name it in the messages); no file is read or written.
  PlanService(const ServeOptions& options, FlightData data);
  ~PlanService();
  PlanService(const PlanService&) = delete;
  PlanService& operator=(const PlanService&) = delete;

  /// What one thread keeps from request to request (the WGS 84 transformations: a PROJ context
  /// each). One per thread; made by worker().
  class Worker;
  std::shared_ptr<Worker> worker() const;

  struct Answer {
    int status = 200;  ///< 200; 400 a bad request (naming the key); 422 no path or waypoints that cannot be flown;
                       ///< 504 cancelled by `progress` or `stop`, naming the stage it was in; 500 an internal error
    std::string body;  ///< JSON: {"format", "path" | "path_base64", "stats"}, or {"error": one line}
  };
  /// POST /v1/plan: the request body (JSON) to the answer. Never throws; never crashes on any
  /// bytes (fuzz/fuzz_serve.cpp). `progress` returning false cancels (504); so does `stop`
  /// (core.hpp), which every search of the request checks between its steps: once it is
  /// requested or its deadline passes, plan() returns within a few validity checks.
  Answer plan(const std::string& body, Worker& worker, const Progress& progress = {},
              std::shared_ptr<const StopToken> stop = nullptr) const;
  /// GET /v1/info: the CRS, the extent, the vertical reference, what was loaded, the limits.
  std::string info() const;
  const ServeOptions& options() const;

  struct State;  // serve_service.cpp's

private:
  std::unique_ptr<State> state_;
};

/// {"error": message} as the service answers errors.
std::string error_body(const std::string& message);

/// Blocks SIGTERM, SIGINT and SIGHUP in the calling thread and in every thread it starts later,
/// so that serve_plans() alone takes them (else a thread of the pool that built the index would
/// take SIGTERM and end the process at once): call it before making the PlanService.
void block_stopping_signals();

/// Serves `service` over HTTP (DeadlineServer) on options.host:port with options.threads workers
/// and the bounded queue: POST /v1/plan, GET /v1/health, GET /v1/info. Calls `listening` with
/// the address once bound; returns after SIGTERM, SIGINT or SIGHUP: new requests are refused,
/// those in flight get until kStopGraceSeconds to finish and are then stopped (504), so the
/// service ends within 2 s whatever runs. ArgumentError("--port") when the port cannot be bound.
constexpr double kStopGraceSeconds = 1;

void serve_plans(const PlanService& service, const std::function<void(const std::string& url)>& listening);

}  // namespace dsmplan
