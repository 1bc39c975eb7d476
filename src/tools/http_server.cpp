// DeadlineServer: httplib 0.11.4's connection loop (Server::process_and_close_socket and
// detail::process_server_socket_core, httplib.h) over a Stream of our own that bounds each
// request by a deadline and byte caps, and ConnectionThreads, its task queue.
#include "http_server.hpp"

#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <deque>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>

#include "dsmplan/core.hpp"

namespace dsmplan {

namespace {

using Clock = std::chrono::steady_clock;

long milliseconds_until(Clock::time_point end) {
  return std::max<long>(0, std::chrono::ceil<std::chrono::milliseconds>(end - Clock::now()).count());
}

// Address and port of a socket's end, numeric: httplib's detail::get_ip_and_port, which the
// Debian library does not export.
void ip_and_port(int (*name)(int, sockaddr*, socklen_t*), socket_t sock, std::string& ip, int& port) {
  sockaddr_storage address{};
  socklen_t length = sizeof address;
  if (name(sock, reinterpret_cast<sockaddr*>(&address), &length) != 0) return;
  if (address.ss_family == AF_INET)
    port = ntohs(reinterpret_cast<const sockaddr_in*>(&address)->sin_port);
  else if (address.ss_family == AF_INET6)
    port = ntohs(reinterpret_cast<const sockaddr_in6*>(&address)->sin6_port);
  else
    return;
  char text[NI_MAXHOST] = {};
  if (getnameinfo(reinterpret_cast<const sockaddr*>(&address), length, text, sizeof text, nullptr, 0, NI_NUMERICHOST) ==
      0)
    ip = text;
}

// One connection's requests, one after the other. Reads as httplib's detail::SocketStream does
// (a 4 KiB buffer, each recv after waiting up to the read timeout) but the wait also ends at
// the request's deadline, and the bytes of its head and body are counted against their caps.
// The buffer lives as long as the connection, so a pipelined next request is kept (httplib
// makes a new SocketStream, and a new buffer, for each request).
class DeadlineStream : public httplib::Stream {
public:
  DeadlineStream(socket_t sock, long read_timeout_ms, long write_timeout_ms, size_t max_head, size_t max_body)
      : sock_(sock),
        read_timeout_ms_(read_timeout_ms),
        write_timeout_ms_(write_timeout_ms),
        max_head_(max_head),
        max_body_(max_body) {}

  // True when a request's first bytes are here or arrive within `idle`, as httplib's
  // detail::keep_alive(); the wait is cut in steps of 100 ms to see whether the server stopped.
  bool wait_for_request(std::chrono::milliseconds idle, const std::function<bool()>& stopped) {
    for (const auto end = Clock::now() + idle; off_ == end_;) {
      if (stopped()) return false;
      const int ready = wait(POLLIN, std::min(milliseconds_until(end), 100L));
      if (ready != 0) return ready > 0;
      if (Clock::now() >= end) return false;
    }
    return true;
  }

  void begin_request(Clock::time_point deadline, std::function<bool()> stopped) {
    deadline_ = deadline;
    stopped_ = std::move(stopped);
    head_ = body_ = 0;
    last_four_ = 0;
    head_done_ = replied_ = false;
  }

  // A limit was hit: the reason was sent and the connection must close.
  bool failed() const { return failed_; }

  bool is_readable() const override { return off_ < end_ || wait(POLLIN, read_wait_ms()) > 0; }
  bool is_writable() const override { return !failed_ && wait(POLLOUT, write_timeout_ms_) > 0; }

  ssize_t read(char* ptr, size_t size) override {
    if (failed_) return -1;
    if (off_ == end_) {
      // No byte within the read timeout, or the deadline passed: 408 either way. Waited in steps
      // of 100 ms, to see whether the server is stopping (503: a slow client does not hold it).
      const Clock::time_point give_up = Clock::now() + std::chrono::milliseconds(read_wait_ms());
      for (;;) {
        if (stopped_ && stopped_()) return fail(503, "Service Unavailable");
        const long ms = milliseconds_until(give_up);
        if (ms == 0) return fail(408, "Request Timeout");
        const int ready = wait(POLLIN, std::min(ms, 100L));
        if (ready < 0) return fail(408, "Request Timeout");
        if (ready > 0) break;
      }
      ssize_t n;
      do n = ::recv(sock_, buffer_, sizeof buffer_, 0);
      while (n < 0 && errno == EINTR);
      if (n <= 0) return n;  // closed by the client (0) or broken (-1), as httplib sees it
      off_ = 0;
      end_ = static_cast<size_t>(n);
    }
    const size_t n = std::min(size, end_ - off_);
    // The head ends at its first empty line, "\r\n\r\n" (httplib's detail::read_headers wants
    // CRLF; lines ending in a bare LF it skips); httplib reads it a byte at a time.
    size_t i = 0;
    for (; i < n && !head_done_; ++i, ++head_) {
      last_four_ = last_four_ << 8 | static_cast<unsigned char>(buffer_[off_ + i]);
      head_done_ = last_four_ == 0x0d0a0d0a;
    }
    body_ += n - i;
    if (head_ > max_head_) return fail(431, "Request Header Fields Too Large");
    if (body_ > max_body_) return fail(413, "Payload Too Large");
    std::memcpy(ptr, buffer_ + off_, n);
    off_ += n;
    return static_cast<ssize_t>(n);
  }

  ssize_t write(const char* ptr, size_t size) override {
    if (failed_) return -1;  // our reply went out: httplib's own (a 400) is dropped
    if (wait(POLLOUT, write_timeout_ms_) <= 0) return -1;
    replied_ = true;
    ssize_t n;
    do n = ::send(sock_, ptr, size, MSG_NOSIGNAL);
    while (n < 0 && errno == EINTR);
    return n;
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override { ip_and_port(getpeername, sock_, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { ip_and_port(getsockname, sock_, ip, port); }
  socket_t socket() const override { return sock_; }

private:
  long read_wait_ms() const { return std::min(read_timeout_ms_, milliseconds_until(deadline_)); }

  int wait(short events, long ms) const {
    pollfd fd{sock_, events, 0};
    int ready;
    do ready = ::poll(&fd, 1, static_cast<int>(ms));
    while (ready < 0 && errno == EINTR);
    return ready;
  }

  // Says why in a short reply (unless a response has begun) and makes every later read and write
  // fail, so that httplib gives up the request and the connection closes. The reply is sent
  // without waiting: a client that does not read it does not hold the thread either.
  ssize_t fail(int status, const char* reason) {
    if (!failed_ && !replied_) {
      const std::string reply =
          "HTTP/1.1 " + std::to_string(status) + " " + reason + "\r\nConnection: close\r\nContent-Length: 0\r\n\r\n";
      (void)!::send(sock_, reply.data(), reply.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    }
    failed_ = true;
    return -1;
  }

  socket_t sock_;
  long read_timeout_ms_, write_timeout_ms_;
  size_t max_head_, max_body_;
  char buffer_[4096];
  size_t off_ = 0, end_ = 0;  // buffer_[off_, end_) not yet read
  Clock::time_point deadline_ = Clock::now();
  std::function<bool()> stopped_;  // the server is stopping
  size_t head_ = 0, body_ = 0;
  uint32_t last_four_ = 0;  // the head's last four bytes
  bool head_done_ = false, replied_ = false, failed_ = false;
};

long to_milliseconds(time_t sec, time_t usec) { return static_cast<long>(sec * 1000 + usec / 1000); }

}  // namespace

DeadlineServer::DeadlineServer(const RequestLimits& limits) : limits_(limits) {
  new_task_queue = [max = limits.max_connections] { return new ConnectionThreads(max); };
}

bool DeadlineServer::listen_after_bind() {
  // listen() again on the bound socket only sets its backlog (Linux: inet_listen()).
  if (svr_sock_ != INVALID_SOCKET) ::listen(svr_sock_, limits_.backlog);
  return httplib::Server::listen_after_bind();
}

bool DeadlineServer::listen(const std::string& host, int port) {
  return bind_to_port(host, port) && listen_after_bind();
}

// httplib's Server::process_and_close_socket and detail::process_server_socket_core: up to
// keep_alive_max_count_ requests while the server runs, each after at most
// keep_alive_timeout_sec_ idle, the last one answered with "Connection: close"; then the socket
// is shut down and closed. Each request's deadline starts when its thread starts reading it.
bool DeadlineServer::process_and_close_socket(socket_t sock) {
  DeadlineStream stream(sock, to_milliseconds(read_timeout_sec_, read_timeout_usec_),
                        to_milliseconds(write_timeout_sec_, write_timeout_usec_), limits_.max_head_bytes,
                        payload_max_length_);
  bool ret = false;
  for (size_t count = keep_alive_max_count_; count > 0; --count) {
    if (!stream.wait_for_request(std::chrono::seconds(keep_alive_timeout_sec_),
                                 [this] { return svr_sock_ == INVALID_SOCKET; }))
      break;
    stream.begin_request(Clock::now() + limits_.deadline, [this] { return svr_sock_ == INVALID_SOCKET; });
    bool connection_closed = false;
    ret = process_request(stream, count == 1, connection_closed, nullptr);
    if (!ret || connection_closed || stream.failed()) break;
  }
  ::shutdown(sock, SHUT_RDWR);
  ::close(sock);
  return ret;
}

struct ConnectionThreads::State {
  explicit State(int max) : max_threads(max) {}
  const int max_threads;
  std::mutex mutex;
  std::condition_variable done;
  std::deque<std::function<void()>> waiting;
  int running = 0;

  // Starts threads for the tasks waiting, up to the cap; each, when its task is done, starts
  // the next one waiting. Called with the mutex held.
  static void start(const std::shared_ptr<State>& state) {
    while (state->running < state->max_threads && !state->waiting.empty()) {
      std::function<void()> fn = std::move(state->waiting.front());
      state->waiting.pop_front();
      ++state->running;
      std::thread([state, fn = std::move(fn)] {
        fn();
        std::unique_lock<std::mutex> lock(state->mutex);
        --state->running;
        start(state);
        state->done.notify_all();
      }).detach();
    }
  }
};

ConnectionThreads::ConnectionThreads(int max_threads) : state_(std::make_shared<State>(std::max(1, max_threads))) {}

void ConnectionThreads::enqueue(std::function<void()> fn) {
  std::unique_lock<std::mutex> lock(state_->mutex);
  state_->waiting.push_back(std::move(fn));
  State::start(state_);
}

void ConnectionThreads::shutdown() {  // the requests in flight finish, then the server stops
  std::unique_lock<std::mutex> lock(state_->mutex);
  state_->done.wait(lock, [&] { return state_->running == 0 && state_->waiting.empty(); });
}

namespace {

// Whether a socket can be bound to `host` (on a port the system picks): false for a name that
// does not resolve or an address of another machine.
bool can_listen_on(const std::string& host) {
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  if (::getaddrinfo(host.c_str(), "0", &hints, &found) != 0) return false;
  bool bound = false;
  for (const addrinfo* a = found; a && !bound; a = a->ai_next) {
    const int probe = ::socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if (probe < 0) continue;
    bound = ::bind(probe, a->ai_addr, a->ai_addrlen) == 0;
    ::close(probe);
  }
  ::freeaddrinfo(found);
  return bound;
}

}  // namespace

int bind_listening(DeadlineServer& server, const std::string& host, int port_asked) {
  // httplib's default also sets SO_REUSEPORT, with which a second server binds a port in use
  // and the two share the requests; SO_REUSEADDR alone still allows a restart at once.
  server.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  // The host first, so that a port in use and an address not of this machine are told apart.
  if (!can_listen_on(host)) throw Error("--host: cannot listen on " + host + ": not an address of this machine");
  int port = port_asked;
  if (port == 0) {
    port = server.bind_to_any_port(host);
    // Not a usage error (exit 2) but the machine's state: an Error (exit 1).
    if (port < 0) throw Error("--host: cannot listen on " + host);
  } else if (!server.bind_to_port(host, port)) {
    throw Error("--port: cannot listen on " + host + ":" + std::to_string(port) + " (in use)");
  }
  return port;
}

std::string read_token(const std::string& file) {
  if (file.empty()) return "";
  require_input_file(file, 4096, "a token file");
  std::ifstream in(file);
  std::string line;
  if (!in || !std::getline(in, line)) throw InputError(file, "", "cannot read the token");
  const size_t begin = line.find_first_not_of(" \t\r"), end = line.find_last_not_of(" \t\r");
  const std::string token = begin == std::string::npos ? "" : line.substr(begin, end - begin + 1);
  if (token.size() < 16) throw InputError(file, "", "the token must be at least 16 characters on the first line");
  return token;
}

}  // namespace dsmplan
