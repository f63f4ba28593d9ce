// Retries against a gateway that loses replies: the request reaches the real server, the answer never comes
// back. A retried upload must be stored once (its request_id), a call that is not idempotent must not be
// retried, and the read timeout must end the wait for a reply that does not come.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <mutex>
#include <thread>

#include "mock_tracker.h"
#include "robocal/client/client.h"
#include "test_server.h"

namespace robocal {
namespace {

// A one-connection-at-a-time HTTP/1.1 forwarder on a free loopback port. It forwards each request to the
// backend; for the first `lose_replies` requests it then drops the reply: it closes the connection (kClose),
// or keeps it open without answering until the client gives up (kHang, the client's read timeout). With
// kRequestTimeout it does not forward them at all and answers 408, as a server does whose read deadline a slow
// link missed.
class LossyGateway {
 public:
  enum class Loss { kClose, kHang, kRequestTimeout };

  LossyGateway(const std::string& backend_url, int lose_replies, Loss loss) : lose_replies_(lose_replies), loss_(loss) {
    ClientOptions options;
    options.server_url = backend_url;
    options.max_retries = 0;
    backend_ = std::make_unique<Client>(options);
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = 0;
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(listen_fd_, 8) != 0) {
      throw std::runtime_error("gateway: cannot listen");
    }
    socklen_t len = sizeof addr;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    thread_ = std::thread([this] { Serve(); });
  }
  ~LossyGateway() {
    stop_ = true;
    thread_.join();
    ::close(listen_fd_);
  }

  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }
  /// Requests that reached the backend.
  int forwarded() const { return forwarded_; }

 private:
  // Waits until fd is readable or the gateway stops; false on stop.
  bool WaitReadable(int fd) {
    while (!stop_) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 20) > 0) return true;
    }
    return false;
  }

  void Serve() {
    while (WaitReadable(listen_fd_)) {
      const int fd = ::accept(listen_fd_, nullptr, nullptr);
      if (fd < 0) continue;
      Handle(fd);
      ::close(fd);
    }
  }

  void Handle(int fd) {
    std::string data;
    char buffer[65536];
    std::size_t header_end = std::string::npos;
    std::size_t length = 0;
    while (header_end == std::string::npos || data.size() < header_end + 4 + length) {
      if (!WaitReadable(fd)) return;
      const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
      if (n <= 0) return;
      data.append(buffer, static_cast<std::size_t>(n));
      if (header_end == std::string::npos && (header_end = data.find("\r\n\r\n")) != std::string::npos) {
        std::string headers = data.substr(0, header_end);
        for (char& c : headers) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        const auto at = headers.find("content-length:");
        if (at != std::string::npos) length = std::stoul(headers.substr(at + 15));
      }
    }
    const std::string request_line = data.substr(0, data.find("\r\n"));
    const std::string method = request_line.substr(0, request_line.find(' '));
    const std::string path = request_line.substr(method.size() + 1, request_line.rfind(' ') - method.size() - 1);
    const std::string body_text = data.substr(header_end + 4, length);
    int status = 200;
    std::string reply;
    if (loss_ == Loss::kRequestTimeout && forwarded_ < lose_replies_) {
      ++forwarded_;
      reply = R"({"error":{"code":408,"status":"DEADLINE_EXCEEDED","message":"request not received in time",)"
              R"("details":[{"field":"request","reason":"slow link"}]}})";
      const std::string response = "HTTP/1.1 408 Request Timeout\r\nContent-Type: application/json\r\n"
                                   "Connection: close\r\nContent-Length: " +
                                   std::to_string(reply.size()) + "\r\n\r\n" + reply;
      ::send(fd, response.data(), response.size(), MSG_NOSIGNAL);
      return;
    }
    try {
      const nlohmann::json body = body_text.empty() ? nlohmann::json() : nlohmann::json::parse(body_text);
      reply = backend_->Call(method, path, body_text.empty() ? nullptr : &body, false).dump();
    } catch (const client::ServiceError& e) {
      status = e.http_status();
      reply = nlohmann::json{{"error", e.info()}}.dump();
    }
    if (forwarded_++ < lose_replies_) {
      // The work is done on the backend; its answer is lost.
      if (loss_ == Loss::kHang) {
        while (WaitReadable(fd) && ::recv(fd, buffer, sizeof buffer, 0) > 0) {
        }
      }
      return;
    }
    const std::string response =
        "HTTP/1.1 " + std::to_string(status) +
        " X\r\nContent-Type: application/json\r\nConnection: close\r\nContent-Length: " + std::to_string(reply.size()) +
        "\r\n\r\n" + reply;
    ::send(fd, response.data(), response.size(), MSG_NOSIGNAL);
  }

  const int lose_replies_;
  const Loss loss_;
  std::unique_ptr<Client> backend_;
  int listen_fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<int> forwarded_{0};
  std::thread thread_;
};

void PrintTo(LossyGateway::Loss loss, std::ostream* os) {
  *os << (loss == LossyGateway::Loss::kClose ? "connection closed" : "no answer");
}

api::MeasurementBatchRequest SomeShots() {
  mock::MockTrackerOptions options;
  options.shots_per_pose = 3;
  VirtualCell cell = mock::MakeCell(options);
  api::MeasurementBatchRequest batch = mock::MeasurementBatch(
      &cell, {{400, 300, 200, 0, 0}, {500, 200, 250, 10, -20}}, api::MeasurementRole::kCalibration, options);
  batch.request_id.clear();  // derived from the content, as a cell without its own ids uploads
  return batch;
}

class RetryTest : public ::testing::TestWithParam<LossyGateway::Loss> {
 protected:
  ClientOptions Through(const LossyGateway& gateway) const {
    ClientOptions o;
    o.server_url = gateway.url();
    o.retry_backoff = std::chrono::milliseconds(1);
    // Ends the wait of the kHang case. A reply the gateway does send must come within it, backend call included,
    // or the client retries once more than the test counts: 5 s, so that a busy machine keeps to the count (2 s
    // failed once in a loaded sanitizer run). A closed connection (kClose) is seen at once and waits for nothing.
    o.read_timeout =
        GetParam() == LossyGateway::Loss::kHang ? std::chrono::milliseconds(5000) : std::chrono::seconds(30);
    return o;
  }

  testing::TestServer server_;
};

TEST_P(RetryTest, RetriedUploadIsStoredOnce) {
  ClientOptions direct_options;
  direct_options.server_url = server_.url();
  Client direct(direct_options);
  api::CreateCampaignRequest request;
  request.robot = "grinder5";
  const std::string campaign = direct.CreateCampaign(request).id;
  const api::MeasurementBatchRequest batch = SomeShots();

  LossyGateway gateway(server_.url(), 2, GetParam());
  Client c(Through(gateway));
  const api::BatchResult result = c.UploadMeasurements(campaign, batch);
  EXPECT_EQ(gateway.forwarded(), 3);  // two lost answers, then the one that came back
  EXPECT_TRUE(result.replayed);       // the server had it since the first try
  EXPECT_EQ(result.count, 6);
  EXPECT_EQ(direct.GetCampaign(campaign).counts.calibration, 6);
  EXPECT_EQ(direct.ListMeasurements(campaign).measurements.size(), 6u);
}

TEST_P(RetryTest, CreatingIsNotRetried) {
  LossyGateway gateway(server_.url(), 1, GetParam());
  Client c(Through(gateway));
  api::CreateCampaignRequest request;
  request.robot = "grinder5";
  EXPECT_THROW(c.CreateCampaign(request), client::ConnectionError);
  EXPECT_EQ(gateway.forwarded(), 1);
  ClientOptions direct_options;
  direct_options.server_url = server_.url();
  EXPECT_EQ(Client(direct_options).ListCampaigns().size(), 1u);  // created once, and the caller knows it failed
}

TEST_P(RetryTest, GivesUpAfterMaxRetries) {
  LossyGateway gateway(server_.url(), 100, GetParam());
  ClientOptions options = Through(gateway);
  options.max_retries = 2;
  Client c(options);
  EXPECT_THROW(c.ListRobots(), client::ConnectionError);
  EXPECT_EQ(gateway.forwarded(), 3);
}

TEST(RetryOnRequestTimeoutTest, IdempotentCallsAreRetriedAfter408AndOthersAreNot) {
  testing::TestServer server;
  {
    LossyGateway gateway(server.url(), 2, LossyGateway::Loss::kRequestTimeout);
    ClientOptions o;
    o.server_url = gateway.url();
    o.retry_backoff = std::chrono::milliseconds(1);
    EXPECT_EQ(Client(o).ListRobots().size(), 3u);
    EXPECT_EQ(gateway.forwarded(), 3);  // two 408s, then the answer
  }
  LossyGateway gateway(server.url(), 1, LossyGateway::Loss::kRequestTimeout);
  ClientOptions o;
  o.server_url = gateway.url();
  o.retry_backoff = std::chrono::milliseconds(1);
  api::CreateCampaignRequest request;
  request.robot = "grinder5";
  try {
    Client(o).CreateCampaign(request);
    ADD_FAILURE() << "a 408 on a campaign creation must reach the caller";
  } catch (const client::ServiceError& e) {
    EXPECT_EQ(e.http_status(), 408);
    EXPECT_EQ(e.status(), api::Status::kDeadlineExceeded);
  }
  EXPECT_EQ(gateway.forwarded(), 1);
}

INSTANTIATE_TEST_SUITE_P(LostReplies, RetryTest,
                         ::testing::Values(LossyGateway::Loss::kClose, LossyGateway::Loss::kHang),
                         [](const auto& info) {
                           return std::string(info.param == LossyGateway::Loss::kClose ? "ConnectionClosed"
                                                                                       : "ReadTimeout");
                         });

}  // namespace
}  // namespace robocal
