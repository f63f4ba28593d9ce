// The real HTTP(S) server in-process on a free port with in-memory SQLite storage, stopped on scope exit.
#pragma once

#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "robocal/server/http_server.h"
#include "robocal/server/logging.h"
#include "robocal/server/service.h"
#include "server/storage/storage.h"

namespace robocal::testing {

class TestServer {
 public:
  /// With tls_cert and tls_key (PEM files) it serves HTTPS, as robocal-server --tls-cert/--tls-key does.
  explicit TestServer(std::vector<std::string> tokens = {}, const std::string& tls_cert = "",
                      const std::string& tls_key = "") {
    server::SetupLogging("warn", "text");
    storage_ = server::OpenSqliteStorage(":memory:");
    service_ = std::make_unique<server::Service>(storage_.get(), server::ServiceOptions{});
    server::ServerConfig config;
    config.port = 0;
    config.threads = 4;
    config.tls_cert = tls_cert;
    config.tls_key = tls_key;
    tls_ = !tls_cert.empty();
    http_ = std::make_unique<server::HttpServer>(config, service_.get(), std::move(tokens));
    port_ = http_->Bind();
    if (port_ <= 0) throw std::runtime_error("cannot bind a port");
    thread_ = std::thread([this] { http_->Listen(); });
    // listen_after_bind starts accepting at once; wait only for the thread to get there.
    while (!http_->is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ~TestServer() {
    http_->Stop();
    thread_.join();
  }
  TestServer(const TestServer&) = delete;
  TestServer& operator=(const TestServer&) = delete;

  std::string url() const { return std::string(tls_ ? "https" : "http") + "://127.0.0.1:" + std::to_string(port_); }
  int port() const { return port_; }

 private:
  std::unique_ptr<server::Storage> storage_;
  std::unique_ptr<server::Service> service_;
  std::unique_ptr<server::HttpServer> http_;
  int port_ = -1;
  bool tls_ = false;
  std::thread thread_;
};

}  // namespace robocal::testing
