// The real HTTP server in-process on a free port, stopped on scope exit, and a small JSON client for it.
#pragma once

#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "fake_storage.h"
#include "guarded_client.h"
#include "robocal/api/robots.h"
#include "robocal/core/measurement.h"
#include "robocal/server/http_server.h"
#include "robocal/server/logging.h"
#include "robocal/server/service.h"

namespace robocal::server::testing {

struct Reply {
  int status = 0;
  nlohmann::json body;
  std::string text;
};

class TestServer {
 public:
  explicit TestServer(ServerConfig config = {}, std::vector<std::string> tokens = {},
                      ServiceOptions options = {}, std::unique_ptr<Storage> storage = nullptr)
      : storage_(storage ? std::move(storage) : std::make_unique<FakeStorage>()) {
    spdlog::set_level(spdlog::level::warn);  // request lines would drown the test output
    config.host = "127.0.0.1";
    config.port = 0;
    config.threads = 4;
    service_ = std::make_unique<Service>(storage_.get(), options);
    server_ = std::make_unique<HttpServer>(config, service_.get(), std::move(tokens));
    port_ = server_->Bind();
    EXPECT_GT(port_, 0);
    thread_ = std::thread([this] { server_->Listen(); });
    client_ = std::make_unique<httplib::Client>(GuardedClient(port_));
  }
  ~TestServer() {
    server_->Stop();
    thread_.join();
  }

  void set_token(const std::string& token) { token_ = token; }

  /// Waits until `done` holds for the server's connection counts: the event a test waits on (the server has
  /// taken its stalled clients, or let them go), not a time. False after 30 s, so that a server that never gets
  /// there fails the test instead of hanging it.
  bool WaitForConnections(const std::function<bool(const HttpServer::ConnectionCounts&)>& done) const {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (!done(server_->connection_counts())) {
      if (std::chrono::steady_clock::now() > give_up) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return true;
  }

  Reply Request(const std::string& method, const std::string& path, const std::string& body = "") {
    httplib::Headers headers;
    if (!token_.empty()) headers.emplace("Authorization", "Bearer " + token_);
    httplib::Result r = method == "GET"      ? client_->Get(path, headers)
                        : method == "DELETE" ? client_->Delete(path, headers)
                                             : client_->Post(path, headers, body, "application/json");
    Reply reply;
    if (!r) {
      ADD_FAILURE() << method << " " << path << ": no response (" << httplib::to_string(r.error()) << ")";
      return reply;
    }
    reply.status = r->status;
    reply.text = r->body;
    reply.body = nlohmann::json::parse(r->body, nullptr, false);
    return reply;
  }
  Reply Get(const std::string& path) { return Request("GET", path); }
  Reply Delete(const std::string& path) { return Request("DELETE", path); }
  Reply Post(const std::string& path, const nlohmann::json& body) { return Request("POST", path, body.dump()); }
  Reply PostText(const std::string& path, const std::string& body) { return Request("POST", path, body); }

  Storage& storage() { return *storage_; }
  Service& service() { return *service_; }
  int port() const { return port_; }

 private:
  std::unique_ptr<Storage> storage_;
  std::unique_ptr<Service> service_;
  std::unique_ptr<HttpServer> server_;
  std::unique_ptr<httplib::Client> client_;
  std::thread thread_;
  std::string token_;
  int port_ = -1;
};

/// The first violation's field of an error reply ("" if none).
inline std::string FirstField(const Reply& r) {
  if (!r.body.is_object() || !r.body.contains("error")) return "";
  const auto& d = r.body["error"]["details"];
  return d.empty() ? "" : d[0].value("field", "");
}

/// True if any violation names `field`.
inline bool NamesField(const Reply& r, const std::string& field) {
  if (!r.body.is_object() || !r.body.contains("error")) return false;
  for (const auto& d : r.body["error"]["details"]) {
    if (d.value("field", "") == field) return true;
  }
  return false;
}

/// A measurement batch body (POST .../measurements) of core measurements: joints in wire units, full poses.
/// The reason an error reply gives for `field`, "" if it does not name it.
inline std::string ReasonOf(const Reply& r, const std::string& field) {
  if (!r.body.is_object() || !r.body.contains("error")) return "";
  for (const auto& d : r.body["error"]["details"]) {
    if (d.value("field", "") == field) return d.value("reason", "");
  }
  return "";
}

inline nlohmann::json Batch(const RobotModel& model, const std::vector<Measurement>& measurements,
                            const std::string& request_id, const std::string& role) {
  nlohmann::json list = nlohmann::json::array();
  for (const Measurement& m : measurements) {
    list.push_back({{"joints", api::JointsToWire(model, m.joints)},
                    {"pose", nlohmann::json(api::TransformToPose(m.T_world_tool))}});
  }
  return {{"request_id", request_id}, {"role", role}, {"measurements", list}};
}

}  // namespace robocal::server::testing
