// The HTTP edge: how connections are accepted, read and answered before the HTTP library parses a request.
//
// The library reads a request with a timeout per read, from a thread pool with an unbounded queue, and buffers
// bodies of any transfer encoding before checking their size. On a shop-floor network that lets a handful of
// slow or stalled clients hold every worker, and one chunked body fill the memory. The edge keeps the
// library's parser and routing but owns the connection: a pool of connection threads with a bounded queue that
// refuses connections when full, one deadline for a request's head and body together, a cap on head and body
// bytes while they are read (whatever the encoding), a deadline for writing a reply, and a lingering close.
// Only http_server.cc and this part include the HTTP library.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>

namespace robocal::server::edge {

struct Limits {
  /// Request line and headers together (bytes). Larger heads are refused (431) while they are read.
  std::size_t max_head_bytes = 65536;
  /// Body bytes as sent (chunk framing included), counted while they are read.
  std::size_t max_body_bytes = 8388608;
  /// The whole head and body of one request must arrive within this time of its first byte (for the first
  /// request of a connection: of the connection's accept). A client that trickles bytes cannot extend it.
  std::chrono::milliseconds request_read_timeout{10000};
  /// An idle keep-alive connection is closed after this.
  std::chrono::milliseconds keep_alive_timeout{2000};
  /// A reply must be taken by the client within this time of its first byte.
  std::chrono::milliseconds write_timeout{60000};
  /// Requests served on one connection before it is closed.
  std::size_t keep_alive_max_requests = 100;
};

/// Why reading the current request stopped early.
enum class Fault {
  kNone,
  kDeadline,      // head and body did not arrive within request_read_timeout
  kHeadTooLarge,  // more than max_head_bytes before the blank line
  kBodyTooLarge,  // more than max_body_bytes of body
  kStopping,      // the server began to shut down while the request was arriving
};

/// The fault of the request being handled on this thread (kNone outside a connection).
Fault CurrentFault();
/// Closes the connection after the current reply (used when a body is refused unread).
void CloseAfterResponse();
/// The current request has no body (no Content-Length, no chunked encoding): reading it ends at once, as
/// HTTP/1.1 says, instead of waiting for the connection to close.
void NoBody();

/// Counters for /metrics.
struct Counters {
  std::atomic<std::int64_t> active{0};         // connections being served
  std::atomic<std::int64_t> queued{0};         // accepted, waiting for a thread
  std::atomic<std::uint64_t> refused{0};       // refused because the queue was full
  std::atomic<std::uint64_t> timed_out{0};     // requests cut at request_read_timeout
  std::atomic<std::uint64_t> too_large{0};     // heads or bodies over their limit
};

/// The connection pool: up to `max_threads` connections served at once (threads start as needed and stay),
/// up to `max_queued` waiting; a connection beyond that is answered 503 at once and closed, on the accepting
/// thread, without reading it.
class ConnectionPool : public httplib::TaskQueue {
 public:
  ConnectionPool(std::size_t max_threads, std::size_t max_queued, Counters* counters);
  ~ConnectionPool() override;
  void enqueue(std::function<void()> fn) override;
  void shutdown() override;

 private:
  void Work();

  const std::size_t max_threads_;
  const std::size_t max_queued_;
  Counters* counters_;
  std::mutex mutex_;
  std::condition_variable ready_;
  // Each task with the time its connection was accepted: its first request's deadline runs from there, also
  // while it waits in the queue.
  std::deque<std::pair<std::function<void()>, std::chrono::steady_clock::time_point>> queue_;
  std::vector<std::thread> threads_;
  std::size_t idle_ = 0;      // threads waiting for a task
  std::size_t starting_ = 0;  // threads started that have not yet waited
  bool shutdown_ = false;
};

/// Replies that the edge writes itself (no request was parsed): status line, headers and body.
struct CannedReplies {
  std::string busy;          // 503, for a refused connection
  std::string timeout;       // 408, for a request line that did not arrive in time
  std::string head_too_large;  // 431, for a request line beyond max_head_bytes
  std::string stopping;        // 503, for a request line cut off by the server stopping
};

/// Closes refused connections on its own thread after reading and dropping what their clients still send:
/// closing a socket with unread bytes makes the kernel reset it, and the client would lose the 503 before
/// reading it. The accepting thread only hands the socket over. At most `capacity` sockets linger, each at
/// most one second; beyond that the oldest is closed at once.
class Lingerer {
 public:
  explicit Lingerer(std::size_t capacity = 256);
  ~Lingerer();
  void Close(int sock);

 private:
  void Run();
  const std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::pair<int, std::chrono::steady_clock::time_point>> sockets_;
  bool stop_ = false;
  std::thread thread_;
};

/// The library listens with a backlog of a few connections; beyond that the kernel drops connection attempts
/// and clients retry after a second or more. Widens the backlog of the bound socket `listening` (call after
/// binding, before serving).
void WidenBacklog(int listening);

/// What the plain and the TLS server share: the limits, the canned replies and the counters.
struct Settings {
  Limits limits;
  CannedReplies canned;
  Counters* counters;
};

class Server : public httplib::Server {
 public:
  explicit Server(Settings settings);
  /// The bound listening socket (after bind_to_port), for WidenBacklog.
  int listening_socket() const { return svr_sock_; }

 private:
  bool process_and_close_socket(socket_t sock) override;
  const Settings settings_;
  Lingerer lingerer_;
};

class SslServer : public httplib::SSLServer {
 public:
  SslServer(const char* cert_path, const char* key_path, Settings settings);
  int listening_socket() const { return svr_sock_; }

 private:
  bool process_and_close_socket(socket_t sock) override;
  const Settings settings_;
  Lingerer lingerer_;
};

}  // namespace robocal::server::edge
