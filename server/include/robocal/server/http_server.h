// The HTTP server: one route table (method, pattern, OpenAPI path), a pre-routing auth check, one exception
// handler that turns every error into the API's error body, per-request logging and Prometheus metrics.
// cpp-httplib is included only by http_server.cc.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "robocal/api/error.h"
#include "robocal/server/config.h"
#include "robocal/server/service.h"

namespace robocal::server {

using api::HttpStatusOf;

/// A route as registered with the HTTP library and as documented in the OpenAPI spec.
struct RouteInfo {
  std::string method;        // "GET", "POST", "DELETE"
  std::string openapi_path;  // e.g. "/v1/campaigns/{campaign}:fit"
};
/// Every route the server registers (the tests check it against api/openapi.json both ways).
std::vector<RouteInfo> Routes();

/// The embedded OpenAPI document (api/openapi.json).
const std::string& OpenApiSpec();

/// Constant-time comparison of a presented token with each configured token.
bool TokenMatches(const std::string& presented, const std::vector<std::string>& tokens);

class HttpServer {
 public:
  /// Throws std::runtime_error if TLS files cannot be loaded. `token_names[k]` names tokens[k] in the history entries
  /// a request with it makes (none or empty: "token k+1").
  HttpServer(const ServerConfig& config, Service* service, std::vector<std::string> tokens,
             std::vector<std::string> token_names = {});
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  /// Binds config.host:config.port (port 0: any free port). Returns the port, or -1 on failure.
  int Bind();
  /// Serves until Stop(); returns false if serving failed.
  bool Listen();
  void Stop();
  bool is_running() const;
  bool tls() const;
  /// Connections being served and accepted connections waiting for a connection thread (the /metrics gauges
  /// robocal_http_connections_active and _queued): the server's own state, for a caller that waits on it.
  struct ConnectionCounts {
    std::int64_t active = 0;
    std::int64_t queued = 0;
  };
  ConnectionCounts connection_counts() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace robocal::server
