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

namespace dsmplan {

namespace {

using Clock = std::chrono::steady_clock;

// One request on its way through the pool: the connection's thread waits for `answer` until the
// deadline; past it the worker is told (`abandoned`) and the planning is cancelled.
struct Job {
  std::string body;
  Clock::time_point deadline;
  std::atomic<bool> abandoned{false};
  std::promise<PlanService::Answer> answer;
};

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
    if (closed_ || queue_.size() >= capacity_ + idle_) return false;
    queue_.push_back(std::move(job));
    ready_.notify_one();
    return true;
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
      }
      const Job& j = *job;
      const Progress in_budget = [&j](double) { return !j.abandoned && Clock::now() < j.deadline; };
      if (!in_budget(0))
        job->answer.set_value({504, ""});  // waited past its budget: not planned (the connection answers)
      else
        job->answer.set_value(service_.plan(job->body, *worker, in_budget));
    }
  }

  const PlanService& service_;
  size_t capacity_, idle_ = 0;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::shared_ptr<Job>> queue_;
  bool closed_ = false;
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

  bool admitted(const httplib::Request& request, httplib::Response& response) const {
    if (token.empty() || same_secret(request.get_header_value("Authorization"), "Bearer " + token)) return true;
    response.set_header("WWW-Authenticate", "Bearer");
    answer_json(response, 401, error_body("a bearer token is required: Authorization: Bearer <token>"));
    return false;
  }

  void plan(const httplib::Request& request, httplib::Response& response) const {
    if (!admitted(request, response)) return;
    const double budget = service.options().budget_seconds;
    if (draining) return answer_json(response, 503, error_body("the server is shutting down"));
    auto job = std::make_shared<Job>();
    job->body = request.body;
    job->deadline = Clock::now() + std::chrono::microseconds(std::llround(budget * 1e6));
    std::future<PlanService::Answer> answer = job->answer.get_future();
    if (!pool.submit(job))
      return answer_json(response, 503,
                         error_body("the queue is full (" + std::to_string(service.options().queue) +
                                    " requests waiting): try again later"));
    if (answer.wait_until(job->deadline) == std::future_status::ready) {
      PlanService::Answer a = answer.get();
      if (a.status != 504) return answer_json(response, a.status, a.body);
    }
    job->abandoned = true;
    answer_json(response, 504, error_body("past the request's time budget of " + short_number(budget) + " s"));
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
  server.Post("/v1/plan", [&routes](const httplib::Request& q, httplib::Response& r) { routes.plan(q, r); });
  server.Get("/v1/health", [&](const httplib::Request& q, httplib::Response& r) {
    if (routes.admitted(q, r)) answer_json(r, 200, draining ? R"({"status":"stopping"})" : R"({"status":"ok"})");
  });
  server.Get("/v1/info", [&](const httplib::Request& q, httplib::Response& r) {
    if (routes.admitted(q, r)) answer_json(r, 200, service.info());
  });
  server.set_error_handler([](const httplib::Request&, httplib::Response& r) {
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
    server.stop();  // no new connection; those in flight finish (ConnectionThreads::shutdown)
  });
  const std::string host = options.host.find(':') != std::string::npos ? "[" + options.host + "]" : options.host;
  listening("http://" + host + ":" + std::to_string(port));
  const bool served = server.listen_after_bind();
  if (!draining) pthread_kill(stopper.native_handle(), SIGTERM);  // stopped otherwise: end the signal thread
  stopper.join();
  if (!served && !draining) throw Error("--port: the server stopped listening");
}

}  // namespace dsmplan
