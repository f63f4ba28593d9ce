// Raw TCP connections to a server under test: the bytes a client library would never send (invalid UTF-8,
// partial requests, endless chunked bodies), and the reply as the server wrote it.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <string>

#include <nlohmann/json.hpp>

namespace robocal::server::testing {

/// A reply read off the wire: the status code (0 if none came), the headers' text and the body.
struct RawReply {
  int status = 0;
  std::string head;
  std::string body;
  nlohmann::json json;  // the body parsed (discarded if it is not JSON)
};

class RawConnection {
 public:
  explicit RawConnection(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  ~RawConnection() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawConnection(const RawConnection&) = delete;
  RawConnection& operator=(const RawConnection&) = delete;

  bool connected() const { return connected_; }
  /// Sends all of `bytes`; false if the server closed or reset the connection first.
  bool Send(const std::string& bytes) {
    std::size_t sent = 0;
    while (sent < bytes.size()) {
      const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) return false;
      sent += static_cast<std::size_t>(n);
    }
    return true;
  }
  /// Reads until the server closes the connection, a whole reply (by Content-Length) has arrived, or `wait`
  /// passes; returns what came. The default wait is a hang guard: a reply returns as soon as it is whole, and a
  /// busy machine may take seconds.
  RawReply Read(std::chrono::milliseconds wait = std::chrono::milliseconds(30000)) {
    const auto until = std::chrono::steady_clock::now() + wait;
    std::string data;
    data.swap(pending_);
    for (;;) {
      if (const std::size_t n = ReplyLength(data); n > 0) {
        pending_ = data.substr(n);  // a pipelined reply that came along
        data.resize(n);
        break;
      }
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now()).count();
      if (left <= 0) break;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) break;
      char buf[65536];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) break;
      data.append(buf, static_cast<std::size_t>(n));
    }
    return Parse(data);
  }
  /// True once the server has something to say (a reply, or its close) within `wait`; reads nothing.
  bool Answered(std::chrono::milliseconds wait) {
    if (!pending_.empty()) return true;
    pollfd p{fd_, POLLIN, 0};
    return ::poll(&p, 1, static_cast<int>(wait.count())) > 0;
  }
  /// True once the server has closed its side (reads EOF or a reset within `wait`).
  bool ClosedByServer(std::chrono::milliseconds wait) {
    const auto until = std::chrono::steady_clock::now() + wait;
    for (;;) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now()).count();
      if (left <= 0) return false;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) return false;
      char buf[4096];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) return true;
    }
  }

  /// One whole request's reply: send, then read.
  static RawReply Exchange(int port, const std::string& request,
                           std::chrono::milliseconds wait = std::chrono::milliseconds(30000)) {
    RawConnection c(port);
    c.Send(request);
    return c.Read(wait);
  }

 private:
  // The length of the first whole reply in `data` (by its Content-Length), or 0.
  static std::size_t ReplyLength(const std::string& data) {
    const auto end = data.find("\r\n\r\n");
    if (end == std::string::npos) return 0;
    const auto cl = data.find("Content-Length: ");
    if (cl == std::string::npos || cl > end) return 0;
    const std::size_t total = end + 4 + std::stoul(data.substr(cl + 16));
    return data.size() >= total ? total : 0;
  }
  static RawReply Parse(const std::string& data) {
    RawReply r;
    if (data.rfind("HTTP/1.1 ", 0) != 0 || data.size() < 12) return r;
    r.status = std::stoi(data.substr(9, 3));
    const auto end = data.find("\r\n\r\n");
    r.head = data.substr(0, end);
    if (end != std::string::npos) r.body = data.substr(end + 4);
    r.json = nlohmann::json::parse(r.body, nullptr, false);
    return r;
  }

  int fd_ = -1;
  bool connected_ = false;
  std::string pending_;
};

/// The field of the first violation in an error body ("" if none).
inline std::string FirstDetailField(const RawReply& r) {
  if (!r.json.is_object() || !r.json.contains("error")) return "";
  const auto& d = r.json["error"]["details"];
  return d.empty() ? "" : d[0].value("field", "");
}

}  // namespace robocal::server::testing
