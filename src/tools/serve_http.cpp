// dsmplan serve over HTTP (cpp-httplib, DeadlineServer): connection threads read the requests
// under a deadline and caps, a fixed pool of workers plans them from a bounded queue (a full
// queue answers 503 at once rather than let the wait grow), each request within its time budget
// (504), and SIGTERM lets the requests in flight finish while no new one is taken.
#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <future>
#include <mutex>
#include <thread>

#include "core/text.hpp"
#include "dsmplan/serve.hpp"
#include "http_server.hpp"
#include "tools/serve_parts.hpp"

namespace dsmplan {

namespace {

using Clock = std::chrono::steady_clock;

// One request on its way through the pool: the connection's thread waits for `answer` until the
// deadline. Every search of the request checks `stop` (core.hpp), whose deadline is the budget's,
// so the worker is free within a few validity checks of it; SIGTERM stops it sooner.
struct Job {
  explicit Job(Clock::time_point deadline) : deadline(deadline), stop(std::make_shared<StopToken>(deadline)) {}
  std::string body;
  Clock::time_point deadline;
  std::shared_ptr<StopToken> stop;
  std::atomic<bool> shutting_down{false};  // stopped by SIGTERM, not by its budget
  std::promise<PlanService::Answer> answer;
};

// How long a connection waits past the budget for the worker's own 504, which names the stage it
// was stopped in (a worker notices its stop within a few validity checks: milliseconds).
constexpr auto kStageWait = std::chrono::milliseconds(200);

// A fixed pool of workers over a bounded queue.
class WorkerPool {
public:
  WorkerPool(const PlanService& service, int threads, size_t capacity) : service_(service), capacity_(capacity) {
    for (int i = 0; i < threads; ++i) threads_.emplace_back([this] { work(); });
  }
  ~WorkerPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  /// False when the queue is full (503): the request is not taken. A free worker takes it at once.
  bool submit(std::shared_ptr<Job> job) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_ || stopping_ || queue_.size() >= capacity_ + idle_) return false;
    queue_.push_back(std::move(job));
    ready_.notify_one();
    return true;
  }
  /// Stops every request waiting or being planned (each answers 503 within a few validity checks).
  void stop_all() {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    for (const std::shared_ptr<Job>& job : queue_) job->shutting_down = true, job->stop->request_stop();
    for (const std::shared_ptr<Job>& job : running_) job->shutting_down = true, job->stop->request_stop();
  }
  /// Requests waiting or being planned.
  size_t busy() {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size() + running_.size();
  }

private:
  void work() {
    const std::shared_ptr<PlanService::Worker> worker = service_.worker();
    for (;;) {
      std::shared_ptr<Job> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        ++idle_;
        ready_.wait(lock, [this] { return closed_ || !queue_.empty(); });
        --idle_;
        if (queue_.empty()) return;  // closed, and nothing left
        job = std::move(queue_.front());
        queue_.pop_front();
        running_.push_back(job);
      }
      const StopToken& stop = *job->stop;
      const Progress in_budget = [&stop](double) { return !stop.stop_requested(); };
      if (!in_budget(0))
        job->answer.set_value({504, ""});  // waited past its budget: not planned (the connection answers)
      else
        job->answer.set_value(service_.plan(job->body, *worker, in_budget, job->stop));
      std::lock_guard<std::mutex> lock(mutex_);
      running_.erase(std::find(running_.begin(), running_.end(), job));
    }
  }

  const PlanService& service_;
  size_t capacity_, idle_ = 0;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::shared_ptr<Job>> queue_;
  std::vector<std::shared_ptr<Job>> running_;
  bool closed_ = false, stopping_ = false;
  std::vector<std::thread> threads_;
};

void answer_json(httplib::Response& response, int status, const std::string& body) {
  response.status = status;
  response.set_header("Cache-Control", "no-store");
  response.set_content(body, "application/json");
}

// Compares without stopping at the first difference, so the time taken does not tell how much
// of a guessed token was right.
bool same_secret(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i % std::max<size_t>(1, b.size())]);
  return diff == 0;
}

// The routes: POST /v1/plan through the pool, GET /v1/health and /v1/info at once; every one
// behind the token when there is one.
struct Routes {
  const PlanService& service;
  WorkerPool& pool;
  std::string token;
  std::atomic<bool>& draining;

  // RFC 7235: the scheme's name is case-insensitive ("bearer" too); the token itself is not.
  bool admitted(const httplib::Request& request, httplib::Response& response) const {
    if (token.empty()) return true;
    const std::string given = request.get_header_value("Authorization");
    if (given.size() > 7 && lower_case(given.substr(0, 7)) == "bearer " && same_secret(given.substr(7), token))
      return true;
    response.set_header("WWW-Authenticate", "Bearer");
    answer_json(response, 401, error_body("a bearer token is required: Authorization: Bearer <token>"));
    return false;
  }

  void plan(const httplib::Request& request, const std::string& body, httplib::Response& response) const {
    if (!admitted(request, response)) return;
    const double budget = service.options().budget_seconds;
    if (draining) return answer_json(response, 503, error_body("the server is shutting down"));
    auto job = std::make_shared<Job>(Clock::now() + std::chrono::microseconds(std::llround(budget * 1e6)));
    job->body = body;
    std::future<PlanService::Answer> answer = job->answer.get_future();
    if (!pool.submit(job))
      return draining ? answer_json(response, 503, error_body("the server is shutting down"))
                      : answer_json(response, 503,
                                    error_body("the queue is full (" + std::to_string(service.options().queue) +
                                               " requests waiting): try again later"));
    // Past the budget the worker stops itself (the token's deadline); its 504 names the stage.
    if (answer.wait_until(job->deadline) != std::future_status::ready) {
      job->stop->request_stop();
      answer.wait_for(kStageWait);
    }
    if (answer.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
      PlanService::Answer a = answer.get();
      if (job->shutting_down && a.status == 504)
        return answer_json(response, 503, error_body("the server is shutting down: the request was stopped"));
      if (!a.body.empty()) return answer_json(response, a.status, a.body);
    }
    answer_json(response, 504, error_body(budget_message(budget, "")));
  }
};

// Blocks the stopping signals in this thread and every thread it starts; a thread of its own
// takes them with sigwait() and stops the server gently.
sigset_t stopping_signals() {
  sigset_t set;
  sigemptyset(&set);
  for (int s : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&set, s);
  return set;
}

}  // namespace

void ServeOptions::check() const {
  if (threads < 1 || threads > 256)
    throw ArgumentError("--threads", "must lie in [1, 256], got " + std::to_string(threads));
  if (queue < 0 || queue > 100000)
    throw ArgumentError("--queue", "must lie in [0, 100000], got " + std::to_string(queue));
  if (!(budget_seconds > 0 && budget_seconds <= 3600))
    throw ArgumentError("--budget", "must lie in (0, 3600] s, got " + short_number(budget_seconds));
  if (max_body_bytes < 1024 || max_body_bytes > (64u << 20))
    throw ArgumentError("--max-body", "must lie in [1024, 67108864] bytes, got " + std::to_string(max_body_bytes));
  if (!(request_deadline_seconds > 0 && request_deadline_seconds <= 3600))
    throw ArgumentError("--request-deadline", "must lie in (0, 3600] s, got " + short_number(request_deadline_seconds));
  if (port < 0 || port > 65535) throw ArgumentError("--port", "must lie in [0, 65535], got " + std::to_string(port));
  check_plan_options(plan);
  (void)read_token(token_file);
}

void block_stopping_signals() {
  const sigset_t signals = stopping_signals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
}

void serve_plans(const PlanService& service, const std::function<void(const std::string& url)>& listening) {
  const ServeOptions& options = service.options();
  const sigset_t signals = stopping_signals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  RequestLimits limits;
  limits.deadline = std::chrono::milliseconds(std::lround(options.request_deadline_seconds * 1000));
  DeadlineServer server(limits);
  server.set_read_timeout(2, 0);
  server.set_keep_alive_timeout(5);
  server.set_payload_max_length(options.max_body_bytes);
  // httplib sends the head and the body in two writes: with Nagle's algorithm the body waited for
  // the client's delayed ACK, 40 ms, and every answer took 88 ms at 0.2 cores (bench_serve_load).
  server.set_tcp_nodelay(true);
  std::atomic<bool> draining{false};
  WorkerPool pool(service, options.threads, static_cast<size_t>(options.queue));
  const Routes routes{service, pool, read_token(options.token_file), draining};
  // The body read here, whatever its Content-Type: httplib would otherwise parse a form-encoded
  // one (what `curl -d` sends) under its own 8 KB cap, and answer 413 under a 1 MiB --max-body.
  server.Post("/v1/plan",
              [&routes](const httplib::Request& q, httplib::Response& r, const httplib::ContentReader& read) {
                std::string body;
                read([&body](const char* data, size_t size) {
                  body.append(data, size);
                  return true;
                });
                routes.plan(q, body, r);
              });
  server.Get("/v1/health", [&](const httplib::Request& q, httplib::Response& r) {
    if (routes.admitted(q, r)) answer_json(r, 200, draining ? R"({"status":"stopping"})" : R"({"status":"ok"})");
  });
  server.Get("/v1/info", [&](const httplib::Request& q, httplib::Response& r) {
    if (routes.admitted(q, r)) answer_json(r, 200, service.info());
  });
  server.set_error_handler([&routes](const httplib::Request& q, httplib::Response& r) {
    // Behind the token too: without it, a client learns nothing, not even which routes exist.
    if (r.status == 404 && !routes.admitted(q, r)) return;
    if (r.body.empty())
      answer_json(r, r.status,
                  error_body(r.status == 404 ? "no such route: POST /v1/plan, GET "
                                               "/v1/health, GET /v1/info"
                                             : "HTTP " + std::to_string(r.status)));
  });
  const int port = bind_listening(server, options.host, options.port);
  std::thread stopper([&] {
    int signal = 0;
    sigwait(&signals, &signal);
    draining = true;
    server.stop();  // no new connection; those in flight are answered (ConnectionThreads::shutdown)
    // Those being planned get a grace to finish, then are stopped: the service ends within 2 s.
    const Clock::time_point grace = Clock::now() + std::chrono::milliseconds(std::lround(kStopGraceSeconds * 1000));
    while (pool.busy() > 0 && Clock::now() < grace) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    pool.stop_all();
  });
  const std::string host = options.host.find(':') != std::string::npos ? "[" + options.host + "]" : options.host;
  listening("http://" + host + ":" + std::to_string(port));
  const bool served = server.listen_after_bind();
  if (!draining) pthread_kill(stopper.native_handle(), SIGTERM);  // stopped otherwise: end the signal thread
  stopper.join();
  if (!served && !draining) throw Error("--port: the server stopped listening");
}

}  // namespace dsmplan
