// Latency of health probes and small :forward calls while many stalled clients hold connections open to a
// running robocal-server (docs/service.md, "Measured performance"). Run by hand, never by ctest:
//
//   robocal_stalled_clients --port 8080 --stalled 200 --probes 200
//
// Half of the stalled clients send a partial request line and go silent; the other half send a request with a
// body that never completes, one more byte every second (each read is quick; the request never ends). They
// reconnect when the server closes them, so the server faces `--stalled` of them for the whole run. Prints the
// latency of every probe kind: p50, p99, max, and how many failed.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

int Connect(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return fd;
}

// One request on a new connection; the seconds until the whole reply arrived, or -1 on failure / non-200.
double Probe(int port, const std::string& request) {
  const auto start = Clock::now();
  const int fd = Connect(port);
  if (fd < 0) return -1;
  ::send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  std::string reply;
  char buf[8192];
  while (true) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 10000) <= 0) break;
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    reply.append(buf, static_cast<std::size_t>(n));
    const auto end = reply.find("\r\n\r\n");
    const auto cl = reply.find("Content-Length: ");
    if (end != std::string::npos && cl != std::string::npos &&
        reply.size() >= end + 4 + std::strtoul(reply.c_str() + cl + 16, nullptr, 10)) {
      break;
    }
  }
  ::close(fd);
  if (reply.rfind("HTTP/1.1 200", 0) != 0) return -1;
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void Report(const char* name, std::vector<double> seconds) {
  const auto failed = std::count(seconds.begin(), seconds.end(), -1.0);
  std::erase(seconds, -1.0);
  std::sort(seconds.begin(), seconds.end());
  const auto at = [&](double q) {
    return seconds.empty() ? 0.0 : seconds[std::min(seconds.size() - 1, static_cast<std::size_t>(q * seconds.size()))];
  };
  std::printf("%-28s n=%zu  p50 %.1f ms  p99 %.1f ms  max %.1f ms  failed %td\n", name, seconds.size() + failed,
              1e3 * at(0.5), 1e3 * at(0.99), seconds.empty() ? 0.0 : 1e3 * seconds.back(), failed);
}

}  // namespace

int main(int argc, char** argv) {
  int port = 8080, stalled = 200, probes = 200;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const int value = std::atoi(argv[i + 1]);
    if (flag == "--port") port = value;
    else if (flag == "--stalled") stalled = value;
    else if (flag == "--probes") probes = value;
    else {
      std::fprintf(stderr, "usage: %s [--port P] [--stalled N] [--probes M]\n", argv[0]);
      return 2;
    }
  }
  std::atomic<bool> stop{false};
  std::atomic<long> reconnects{0};
  // The stalled clients, on one thread: each socket either silent after a partial line, or trickling a body.
  std::thread holder([&] {
    std::vector<int> fds(static_cast<std::size_t>(stalled), -1);
    const std::string trickle_head =
        "POST /v1/plans HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100000\r\n\r\n";
    while (!stop) {
      for (std::size_t i = 0; i < fds.size(); ++i) {
        if (fds[i] >= 0) {
          // Still open? A closed one is reopened, so the server keeps facing the same number.
          pollfd p{fds[i], POLLIN, 0};
          char scratch[4096];
          if (::poll(&p, 1, 0) > 0 && ::recv(fds[i], scratch, sizeof scratch, MSG_DONTWAIT) <= 0) {
            ::close(fds[i]);
            fds[i] = -1;
          } else if (i % 2 == 1) {
            ::send(fds[i], " ", 1, MSG_NOSIGNAL);
          }
        }
        if (fds[i] < 0) {
          fds[i] = Connect(port);
          if (fds[i] >= 0) {
            ++reconnects;
            const std::string first = i % 2 == 0 ? std::string("GET /v1/rob") : trickle_head;
            ::send(fds[i], first.data(), first.size(), MSG_NOSIGNAL);
          }
        }
      }
      std::this_thread::sleep_for(std::chrono::seconds(1));
    }
    for (const int fd : fds) {
      if (fd >= 0) ::close(fd);
    }
  });
  std::this_thread::sleep_for(std::chrono::seconds(2));
  const std::string health = "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n";
  const std::string body = R"({"joints":[[0,-90,90,0,90,0]]})";
  const std::string forward = "POST /v1/robots/ur5e:forward HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                              "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
  std::vector<double> health_s, forward_s;
  for (int i = 0; i < probes; ++i) {
    health_s.push_back(Probe(port, health));
    forward_s.push_back(Probe(port, forward));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  stop = true;
  holder.join();
  std::printf("%d stalled clients held open (%ld connections opened in all)\n", stalled, reconnects.load());
  Report("GET /healthz", health_s);
  Report("POST /v1/robots/ur5e:forward", forward_s);
  return 0;
}
