// An httplib::Server that slow or idle clients cannot hold: each request (head and body) must
// arrive within a deadline, its head and body within byte caps, and each connection has a thread
// of its own, a bounded number at once. Used by `dsmplan view`; made for `dsmplan serve` too.
#pragma once

#include <httplib.h>

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>

namespace dsmplan {

struct RequestLimits {
  /// From a request's first byte (or, for a connection that waited for a thread, from when it
  /// got one) to its last, head and body: past it the client gets 408 and the connection is
  /// closed. httplib itself bounds only each read (its read timeout), so a client sending a byte
  /// a second held a thread for as long as it liked.
  std::chrono::milliseconds deadline{10000};
  /// The request line and headers together: past it 431 and close. httplib reads a whole line
  /// into memory before it checks the line's length, and any number of lines.
  std::size_t max_head_bytes = 64 * 1024;
  /// Connections served at once, each on a thread of its own; the others wait in arrival order.
  int max_connections = 256;
  /// Connections the system holds for accept(). httplib listens with a backlog of 5: a burst of
  /// 300 clients had handshakes dropped and retried, the last one accepted after 47 s.
  int backlog = 512;
};

/// httplib::Server with RequestLimits. The body's cap is httplib's set_payload_max_length(),
/// applied here to the bytes as they arrive (chunk framing included) so that it holds for chunked
/// bodies and bodies without a length too, which httplib 0.11 reads without a limit.
/// Idle connections between requests are closed after set_keep_alive_timeout(), as by httplib.
class DeadlineServer : public httplib::Server {
public:
  explicit DeadlineServer(const RequestLimits& limits = {});
  /// httplib's, with RequestLimits::backlog (httplib's own listen() would keep its backlog of 5):
  /// bind_to_port() or bind_to_any_port(), then listen_after_bind(); or listen().
  bool listen_after_bind();
  bool listen(const std::string& host, int port);

private:
  // httplib's accept loop calls this (virtually) on a connection thread for each connection.
  bool process_and_close_socket(socket_t sock) override;

  RequestLimits limits_;
};

/// httplib::TaskQueue that runs each task (a connection) on a thread of its own, up to
/// `max_threads` at once; the others wait their turn in arrival order. httplib's ThreadPool
/// serves one connection a thread on a few threads: with 32 of them, 40 clients sending a header
/// byte a second held every request for 25 s. shutdown() waits for the tasks running and queued.
class ConnectionThreads : public httplib::TaskQueue {
public:
  explicit ConnectionThreads(int max_threads);
  void enqueue(std::function<void()> fn) override;
  void shutdown() override;

private:
  struct State;
  std::shared_ptr<State> state_;  // shared with the threads, which may outlive the queue
};

/// Binds `server` to host:port (0: any free port) and returns the port. Error("--host") for an
/// address not of this machine, Error("--port") for a port in use; SO_REUSEADDR, not SO_REUSEPORT
/// (with which a second server would share the port).
int bind_listening(DeadlineServer& server, const std::string& host, int port);

/// The bearer token in `file`: its first line, blanks trimmed, at least 16 characters; "" for no
/// file. InputError naming the file otherwise. `dsmplan serve --token-file` requires it of every
/// request; `dsmplan view --serve-token-file` sends it to the service.
std::string read_token(const std::string& file);

}  // namespace dsmplan
