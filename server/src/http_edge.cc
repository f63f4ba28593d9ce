// The HTTP edge: connection pool, a stream with request deadlines and byte caps, plain and TLS transports.
// Written by hand because the HTTP library offers only per-read timeouts and an unbounded queue (see the
// header); its parser and routing stay in use through Server::process_request.
#include "http_edge.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <netdb.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>

#include <openssl/err.h>
#include <openssl/ssl.h>

namespace robocal::server::edge {
namespace {

using Clock = std::chrono::steady_clock;

// A byte transport over a non-blocking socket: >0 bytes moved; 0 the peer closed; -1 with *want set to what
// the transport waits for (POLLIN / POLLOUT), or to 0 on a hard error.
class Transport {
 public:
  virtual ~Transport() = default;
  virtual ssize_t Recv(char* data, std::size_t size, short* want) = 0;
  virtual ssize_t Send(const char* data, std::size_t size, short* want) = 0;
  /// Bytes already decoded and waiting (TLS records).
  virtual bool Pending() const { return false; }
  virtual void Shutdown() {}
};

class PlainTransport : public Transport {
 public:
  explicit PlainTransport(int sock) : sock_(sock) {}
  ssize_t Recv(char* data, std::size_t size, short* want) override {
    const ssize_t n = ::recv(sock_, data, size, 0);
    if (n < 0) *want = (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) ? POLLIN : 0;
    return n;
  }
  ssize_t Send(const char* data, std::size_t size, short* want) override {
    const ssize_t n = ::send(sock_, data, size, MSG_NOSIGNAL);
    if (n < 0) *want = (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) ? POLLOUT : 0;
    return n;
  }

 private:
  int sock_;
};

class TlsTransport : public Transport {
 public:
  explicit TlsTransport(SSL* ssl) : ssl_(ssl) {}
  ssize_t Recv(char* data, std::size_t size, short* want) override {
    const int n = SSL_read(ssl_, data, static_cast<int>(std::min<std::size_t>(size, 1 << 30)));
    if (n > 0) return n;
    return Fail(n, want);
  }
  ssize_t Send(const char* data, std::size_t size, short* want) override {
    const int n = SSL_write(ssl_, data, static_cast<int>(std::min<std::size_t>(size, 1 << 30)));
    if (n > 0) return n;
    return Fail(n, want);
  }
  bool Pending() const override { return SSL_pending(ssl_) > 0; }
  void Shutdown() override { SSL_shutdown(ssl_); }

 private:
  ssize_t Fail(int n, short* want) {
    switch (SSL_get_error(ssl_, n)) {
      case SSL_ERROR_WANT_READ:
        *want = POLLIN;
        return -1;
      case SSL_ERROR_WANT_WRITE:
        *want = POLLOUT;
        return -1;
      case SSL_ERROR_ZERO_RETURN:
        return 0;
      default:
        ERR_clear_error();
        *want = 0;
        return -1;
    }
  }
  SSL* ssl_;
};

// Waits until `sock` is ready for `events` or `deadline` passes, or (given `listening`) the server stops. True if
// ready.
bool WaitReady(int sock, short events, Clock::time_point deadline,
               const std::atomic<socket_t>* listening = nullptr) {
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0 || (listening != nullptr && *listening == INVALID_SOCKET)) return false;
    pollfd p{sock, events, 0};
    const int r = ::poll(&p, 1, static_cast<int>(std::min<long long>(left, 200)));
    if (r > 0) return true;
    if (r < 0 && errno != EINTR) return false;
  }
}

class GuardedStream;

// The connection served on this thread: the request hooks reach it from the route handlers.
struct ConnectionState {
  GuardedStream* stream = nullptr;
  bool close_after = false;
};
thread_local ConnectionState* current = nullptr;

class GuardedStream : public httplib::Stream {
 public:
  GuardedStream(int sock, Transport* transport, const Limits& limits, const std::atomic<socket_t>& listening)
      : sock_(sock), transport_(transport), limits_(limits), listening_(listening), buffer_(16384) {}

  /// Starts reading a request whose bytes must all arrive by `deadline`.
  void BeginRequest(Clock::time_point deadline) {
    read_deadline_ = deadline;
    fault_ = Fault::kNone;
    head_bytes_ = body_bytes_ = 0;
    head_done_ = line_done_ = no_body_ = false;
    tail_ = 0;
    writing_ = false;
  }
  /// Waits for the first byte of a request until `deadline`; false if none came or the server stops.
  bool WaitForRequest(Clock::time_point deadline, const std::atomic<socket_t>& listening) {
    if (begin_ < end_ || transport_->Pending()) return true;
    while (listening != INVALID_SOCKET) {
      const auto slice = std::min(deadline, Clock::now() + std::chrono::milliseconds(200));
      if (WaitReady(sock_, POLLIN, slice)) return true;
      if (Clock::now() >= deadline) return false;
    }
    return false;
  }
  Fault fault() const { return fault_; }
  bool line_done() const { return line_done_; }
  void set_no_body() { no_body_ = true; }

  bool is_readable() const override { return begin_ < end_ || transport_->Pending(); }
  bool is_writable() const override {
    pollfd p{sock_, POLLOUT, 0};
    return ::poll(&p, 1, 0) > 0;
  }

  ssize_t read(char* ptr, std::size_t size) override {
    if (fault_ != Fault::kNone) return -1;
    if (head_done_ && no_body_) return 0;
    if (begin_ == end_) {
      const ssize_t filled = Fill();
      if (filled <= 0) return filled;
    }
    std::size_t n = std::min(size, end_ - begin_);
    if (!head_done_) {
      // Count the head byte by byte to find its end: body bytes are counted against another limit.
      std::size_t k = 0;
      while (k < n && !head_done_) {
        const char c = buffer_[begin_ + k];
        tail_ = ((tail_ << 8) | static_cast<unsigned char>(c)) & 0xFFFFFFFFu;
        if (c == '\n') line_done_ = true;
        head_done_ = tail_ == 0x0D0A0D0Au;
        ++k;
      }
      head_bytes_ += k;
      if (head_bytes_ > limits_.max_head_bytes) return Stop(Fault::kHeadTooLarge);
      n = k;
    } else {
      if (body_bytes_ + n > limits_.max_body_bytes) return Stop(Fault::kBodyTooLarge);
      body_bytes_ += n;
    }
    std::memcpy(ptr, buffer_.data() + begin_, n);
    begin_ += n;
    return static_cast<ssize_t>(n);
  }

  ssize_t write(const char* ptr, std::size_t size) override {
    if (!writing_) {
      writing_ = true;
      write_deadline_ = Clock::now() + limits_.write_timeout;
    }
    for (;;) {
      short want = 0;
      const ssize_t n = transport_->Send(ptr, size, &want);
      if (n > 0) return n;
      // A client that does not take its reply is cut at the write deadline, or when the server stops.
      if (n == 0 || want == 0 || !WaitReady(sock_, want, write_deadline_, &listening_)) return -1;
    }
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override { Address(true, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { Address(false, ip, port); }
  socket_t socket() const override { return sock_; }

 private:
  ssize_t Stop(Fault fault) {
    fault_ = fault;
    return -1;
  }
  // Reads what the transport has into the empty buffer, waiting until the request's deadline.
  ssize_t Fill() {
    begin_ = end_ = 0;
    for (;;) {
      short want = 0;
      const ssize_t n = transport_->Recv(buffer_.data(), buffer_.size(), &want);
      if (n > 0) {
        end_ = static_cast<std::size_t>(n);
        return n;
      }
      if (n == 0) return 0;
      if (want == 0) return -1;
      if (!WaitReady(sock_, want, read_deadline_, &listening_)) {
        return Stop(listening_ == INVALID_SOCKET ? Fault::kStopping : Fault::kDeadline);
      }
    }
  }
  void Address(bool remote, std::string& ip, int& port) const {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    const int r = remote ? ::getpeername(sock_, reinterpret_cast<sockaddr*>(&addr), &len)
                         : ::getsockname(sock_, reinterpret_cast<sockaddr*>(&addr), &len);
    char host[NI_MAXHOST] = {0};
    char service[NI_MAXSERV] = {0};
    if (r == 0 && ::getnameinfo(reinterpret_cast<sockaddr*>(&addr), len, host, sizeof host, service,
                                sizeof service, NI_NUMERICHOST | NI_NUMERICSERV) == 0) {
      ip = host;
      port = std::atoi(service);
    }
  }

  int sock_;
  Transport* transport_;
  const Limits& limits_;
  const std::atomic<socket_t>& listening_;
  std::vector<char> buffer_;
  std::size_t begin_ = 0, end_ = 0;
  Clock::time_point read_deadline_{}, write_deadline_{};
  Fault fault_ = Fault::kNone;
  std::size_t head_bytes_ = 0, body_bytes_ = 0;
  std::uint32_t tail_ = 0;  // the last four head bytes, to find the blank line
  bool head_done_ = false, line_done_ = false, no_body_ = false, writing_ = false;
};

// Best effort: a short reply on a socket that nothing has been read from (never blocks).
void SendNow(int sock, const std::string& reply) { (void)::send(sock, reply.data(), reply.size(), MSG_NOSIGNAL | MSG_DONTWAIT); }

// Closing with unread bytes in the socket makes the kernel send a reset, which can destroy the reply before the
// client reads it. So stop sending, then read and drop what the client still sends, for a short while.
void LingeringClose(int sock, bool drain) {
  ::shutdown(sock, SHUT_WR);
  if (drain) {
    const auto until = Clock::now() + std::chrono::milliseconds(500);
    char scratch[4096];
    std::size_t dropped = 0;
    while (dropped < (1u << 20) && WaitReady(sock, POLLIN, until)) {
      const ssize_t n = ::recv(sock, scratch, sizeof scratch, 0);
      if (n <= 0 && !(n < 0 && (errno == EAGAIN || errno == EINTR))) break;
      if (n > 0) dropped += static_cast<std::size_t>(n);
    }
  }
  ::close(sock);
}

// Serves the requests of one connection; `process` is the library's request processing.
using ProcessRequest = std::function<bool(httplib::Stream&, bool close_connection, bool& connection_closed)>;

bool Serve(int sock, Transport* transport, const Limits& limits, const CannedReplies& canned,
           Counters* counters, Clock::time_point accepted, const std::atomic<socket_t>& listening,
           const ProcessRequest& process) {
  GuardedStream stream(sock, transport, limits, listening);
  ConnectionState state{&stream, false};
  current = &state;
  bool ok = true;
  bool unread = false;  // the client may still be sending
  // The first request's turn comes even when the server is stopping: a connection that waited in the queue until
  // then is told so (503), not closed in silence.
  for (std::size_t n = 0; n < limits.keep_alive_max_requests && (n == 0 || listening != INVALID_SOCKET); ++n) {
    const Clock::time_point wait_until = n == 0 ? accepted + limits.request_read_timeout
                                                : Clock::now() + limits.keep_alive_timeout;
    if (!stream.WaitForRequest(wait_until, listening)) {
      if (n == 0 && listening != INVALID_SOCKET) {
        // Connected and silent until the deadline: say why it is closed.
        ++counters->timed_out;
        (void)stream.write(canned.timeout.data(), canned.timeout.size());
      } else if (n == 0) {
        // Stopping before this connection's first request was read (it may still be sending it).
        (void)stream.write(canned.stopping.data(), canned.stopping.size());
        unread = true;
      }
      break;
    }
    stream.BeginRequest(n == 0 ? accepted + limits.request_read_timeout
                               : Clock::now() + limits.request_read_timeout);
    state.close_after = false;
    bool closed = false;
    ok = process(stream, n + 1 == limits.keep_alive_max_requests, closed);
    const Fault fault = stream.fault();
    if (fault == Fault::kDeadline) ++counters->timed_out;
    if (fault == Fault::kHeadTooLarge || fault == Fault::kBodyTooLarge) ++counters->too_large;
    if (fault != Fault::kNone && !stream.line_done()) {
      // The library writes nothing when the request line itself is incomplete.
      const std::string& reply = fault == Fault::kDeadline   ? canned.timeout
                                 : fault == Fault::kStopping ? canned.stopping
                                                             : canned.head_too_large;
      (void)stream.write(reply.data(), reply.size());
    }
    if (fault != Fault::kNone || state.close_after) unread = true;
    if (!ok || closed || unread) break;
  }
  current = nullptr;
  transport->Shutdown();
  LingeringClose(sock, unread);
  return ok;
}

void MakeNonBlocking(int sock) {
  const int flags = ::fcntl(sock, F_GETFL, 0);
  ::fcntl(sock, F_SETFL, flags | O_NONBLOCK);
}

// Set by the pool while it refuses a connection on the accepting thread.
thread_local bool refusing = false;
// Set by the pool before it runs a connection's task: when the connection was accepted.
thread_local Clock::time_point accepted_at{};

Clock::time_point AcceptedAt() { return accepted_at == Clock::time_point{} ? Clock::now() : accepted_at; }

}  // namespace

Fault CurrentFault() { return current != nullptr && current->stream != nullptr ? current->stream->fault() : Fault::kNone; }

void CloseAfterResponse() {
  if (current != nullptr) current->close_after = true;
}

void NoBody() {
  if (current != nullptr && current->stream != nullptr) current->stream->set_no_body();
}

void WidenBacklog(int listening) {
  if (listening >= 0) ::listen(listening, SOMAXCONN);
}

Lingerer::Lingerer(std::size_t capacity) : capacity_(capacity), thread_([this] { Run(); }) {}

Lingerer::~Lingerer() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
  for (const auto& [sock, until] : sockets_) ::close(sock);
}

void Lingerer::Close(int sock) {
  ::shutdown(sock, SHUT_WR);
  {
    std::lock_guard lock(mutex_);
    if (sockets_.size() >= capacity_) {
      ::close(sockets_.front().first);
      sockets_.pop_front();
    }
    sockets_.emplace_back(sock, Clock::now() + std::chrono::seconds(1));
  }
  wake_.notify_one();
}

void Lingerer::Run() {
  std::unique_lock lock(mutex_);
  while (!stop_) {
    if (sockets_.empty()) {
      wake_.wait(lock, [this] { return stop_ || !sockets_.empty(); });
      continue;
    }
    std::vector<pollfd> fds;
    for (const auto& [sock, until] : sockets_) fds.push_back({sock, POLLIN, 0});
    lock.unlock();
    ::poll(fds.data(), fds.size(), 50);
    std::vector<int> done;
    for (const pollfd& p : fds) {
      if (p.revents == 0) continue;
      char scratch[4096];
      const ssize_t n = ::recv(p.fd, scratch, sizeof scratch, MSG_DONTWAIT);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) done.push_back(p.fd);
    }
    lock.lock();
    const auto now = Clock::now();
    for (auto it = sockets_.begin(); it != sockets_.end();) {
      if (it->second <= now || std::find(done.begin(), done.end(), it->first) != done.end()) {
        ::close(it->first);
        it = sockets_.erase(it);
      } else {
        ++it;
      }
    }
  }
}

ConnectionPool::ConnectionPool(std::size_t max_threads, std::size_t max_queued, Counters* counters)
    : max_threads_(std::max<std::size_t>(1, max_threads)), max_queued_(max_queued), counters_(counters) {}

ConnectionPool::~ConnectionPool() { shutdown(); }

void ConnectionPool::enqueue(std::function<void()> fn) {
  {
    std::unique_lock lock(mutex_);
    // Threads that will take a task without a new one started: idle ones and ones still starting.
    const std::size_t free = idle_ + starting_;
    if (queue_.size() < free + (max_threads_ - threads_.size()) + max_queued_) {
      queue_.emplace_back(std::move(fn), Clock::now());
      ++counters_->queued;
      if (queue_.size() > free && threads_.size() < max_threads_) {
        ++starting_;
        threads_.emplace_back([this] { Work(); });
      }
      lock.unlock();
      ready_.notify_one();
      return;
    }
  }
  // Full: the task runs here and only answers 503 (see the servers' process_and_close_socket).
  ++counters_->refused;
  refusing = true;
  fn();
  refusing = false;
}

void ConnectionPool::shutdown() {
  std::vector<std::thread> threads;
  {
    std::lock_guard lock(mutex_);
    shutdown_ = true;
    threads.swap(threads_);
  }
  ready_.notify_all();
  for (std::thread& t : threads) t.join();
}

void ConnectionPool::Work() {
  {
    std::lock_guard lock(mutex_);
    --starting_;
  }
  for (;;) {
    std::function<void()> fn;
    {
      std::unique_lock lock(mutex_);
      ++idle_;
      ready_.wait(lock, [this] { return shutdown_ || !queue_.empty(); });
      --idle_;
      if (queue_.empty()) return;  // shut down and drained
      fn = std::move(queue_.front().first);
      accepted_at = queue_.front().second;
      queue_.pop_front();
    }
    --counters_->queued;
    ++counters_->active;
    fn();
    --counters_->active;
  }
}

Server::Server(Settings settings) : settings_(std::move(settings)) {}

bool Server::process_and_close_socket(socket_t sock) {
  if (refusing) {
    SendNow(sock, settings_.canned.busy);
    lingerer_.Close(sock);
    return false;
  }
  const auto accepted = AcceptedAt();
  MakeNonBlocking(sock);
  PlainTransport transport(sock);
  return Serve(sock, &transport, settings_.limits, settings_.canned, settings_.counters, accepted, svr_sock_,
               [this](httplib::Stream& strm, bool close_connection, bool& connection_closed) {
                 return process_request(strm, close_connection, connection_closed, nullptr);
               });
}

SslServer::SslServer(const char* cert_path, const char* key_path, Settings settings)
    : httplib::SSLServer(cert_path, key_path), settings_(std::move(settings)) {}

bool SslServer::process_and_close_socket(socket_t sock) {
  if (refusing) {
    // Nothing readable can be said before a handshake: close at once.
    lingerer_.Close(sock);
    return false;
  }
  const auto accepted = AcceptedAt();
  MakeNonBlocking(sock);
  SSL* ssl = SSL_new(ssl_context());
  if (ssl == nullptr || SSL_set_fd(ssl, sock) != 1) {
    if (ssl != nullptr) SSL_free(ssl);
    LingeringClose(sock, false);
    return false;
  }
  // The handshake counts against the first request's deadline.
  const auto deadline = accepted + settings_.limits.request_read_timeout;
  bool shaken = false;
  for (;;) {
    const int r = SSL_accept(ssl);
    if (r == 1) {
      shaken = true;
      break;
    }
    const int e = SSL_get_error(ssl, r);
    const short want = e == SSL_ERROR_WANT_READ ? POLLIN : e == SSL_ERROR_WANT_WRITE ? POLLOUT : 0;
    if (want == 0 || !WaitReady(sock, want, deadline, &svr_sock_)) break;
  }
  bool ok = false;
  if (shaken) {
    TlsTransport transport(ssl);
    ok = Serve(sock, &transport, settings_.limits, settings_.canned, settings_.counters, accepted, svr_sock_,
               [this](httplib::Stream& strm, bool close_connection, bool& connection_closed) {
                 return process_request(strm, close_connection, connection_closed, nullptr);
               });
  } else {
    ERR_clear_error();
    LingeringClose(sock, false);
  }
  SSL_free(ssl);
  return ok;
}

}  // namespace robocal::server::edge
