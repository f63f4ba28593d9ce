// The HTTP server: routes, auth, error mapping, logging, metrics.
#include "robocal/server/http_server.h"

#include <chrono>
#include <functional>
#include <map>
#include <mutex>
#include <regex>
#include <sstream>

#include <httplib.h>

#include "robocal/api/json_reader.h"
#include "robocal/server/logging.h"
#include "robocal/server/openapi_spec.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;
using nlohmann::json;

// What a route does: parse path/query/body, call the service, return the response body.
using RouteHandler = std::function<json(Service&, const httplib::Request&)>;

struct Route {
  const char* method;
  const char* pattern;  // cpp-httplib regex; ids never contain '/' or ':'
  const char* openapi_path;
  RouteHandler handler;
};

json Body(const httplib::Request& req) { return api::ParseBody(req.body.empty() ? "{}" : req.body); }
std::string Id(const httplib::Request& req, int i = 1) { return req.matches[i].str(); }
std::string Query(const httplib::Request& req, const char* key) {
  return req.has_param(key) ? req.get_param_value(key) : "";
}

// The single route table: registration, the OpenAPI completeness test and /metrics labels all come from it.
const std::vector<Route>& RouteTable() {
  static const std::vector<Route> routes = {
      {"GET", "/healthz", "/healthz", nullptr},
      {"GET", "/metrics", "/metrics", nullptr},
      {"GET", "/v1/openapi.json", "/v1/openapi.json", nullptr},
      {"GET", "/v1/robots", "/v1/robots",
       [](Service& s, const httplib::Request& r) {
         return s.ListRobots(Query(r, "page_size"), Query(r, "page_token"));
       }},
      {"POST", "/v1/robots", "/v1/robots",
       [](Service& s, const httplib::Request& r) { return s.CreateRobot(Body(r)); }},
      {"GET", R"(/v1/robots/([^/:]+))", "/v1/robots/{robot}",
       [](Service& s, const httplib::Request& r) { return s.GetRobot(Id(r)); }},
      {"DELETE", R"(/v1/robots/([^/:]+))", "/v1/robots/{robot}",
       [](Service& s, const httplib::Request& r) {
         s.DeleteRobot(Id(r));
         return json::object();
       }},
      {"POST", R"(/v1/robots/([^/:]+):forward)", "/v1/robots/{robot}:forward",
       [](Service& s, const httplib::Request& r) { return s.RobotForward(Id(r), Body(r)); }},
      {"POST", "/v1/plans", "/v1/plans", [](Service& s, const httplib::Request& r) { return s.CreatePlan(Body(r)); }},
      {"GET", R"(/v1/plans/([^/:]+))", "/v1/plans/{plan}",
       [](Service& s, const httplib::Request& r) { return s.GetPlan(Id(r)); }},
      {"GET", "/v1/campaigns", "/v1/campaigns",
       [](Service& s, const httplib::Request& r) {
         return s.ListCampaigns(Query(r, "page_size"), Query(r, "page_token"));
       }},
      {"POST", "/v1/campaigns", "/v1/campaigns",
       [](Service& s, const httplib::Request& r) { return s.CreateCampaign(Body(r)); }},
      {"GET", R"(/v1/campaigns/([^/:]+))", "/v1/campaigns/{campaign}",
       [](Service& s, const httplib::Request& r) { return s.GetCampaign(Id(r)); }},
      {"POST", R"(/v1/campaigns/([^/:]+)/measurements)", "/v1/campaigns/{campaign}/measurements",
       [](Service& s, const httplib::Request& r) { return s.AppendMeasurements(Id(r), Body(r)); }},
      {"GET", R"(/v1/campaigns/([^/:]+)/measurements)", "/v1/campaigns/{campaign}/measurements",
       [](Service& s, const httplib::Request& r) {
         return s.ListMeasurements(Id(r), Query(r, "role"), Query(r, "after"), Query(r, "limit"));
       }},
      {"POST", R"(/v1/campaigns/([^/:]+):fit)", "/v1/campaigns/{campaign}:fit",
       [](Service& s, const httplib::Request& r) { return s.Fit(Id(r), Body(r)); }},
      {"GET", R"(/v1/campaigns/([^/:]+)/calibration)", "/v1/campaigns/{campaign}/calibration",
       [](Service& s, const httplib::Request& r) { return s.GetCalibration(Id(r)); }},
      {"POST", R"(/v1/campaigns/([^/:]+):compensate)", "/v1/campaigns/{campaign}:compensate",
       [](Service& s, const httplib::Request& r) { return s.Compensate(Id(r), Body(r)); }},
      {"POST", R"(/v1/campaigns/([^/:]+):forward)", "/v1/campaigns/{campaign}:forward",
       [](Service& s, const httplib::Request& r) { return s.CampaignForward(Id(r), Body(r)); }},
      {"POST", R"(/v1/campaigns/([^/:]+):evaluate)", "/v1/campaigns/{campaign}:evaluate",
       [](Service& s, const httplib::Request& r) { return s.Evaluate(Id(r), Body(r)); }},
      {"GET", R"(/v1/operations/([^/:]+))", "/v1/operations/{operation}",
       [](Service& s, const httplib::Request& r) { return s.GetOperation(Id(r)); }},
      {"POST", R"(/v1/operations/([^/:]+):cancel)", "/v1/operations/{operation}:cancel",
       [](Service& s, const httplib::Request& r) { return s.CancelOperation(Id(r)); }},
  };
  return routes;
}

// The route label of a request path for metrics and logs (bounded cardinality: never the raw path).
std::string RouteLabel(const std::string& method, const std::string& path) {
  // Compiled once: building a std::regex costs far more than matching one.
  static const std::vector<std::regex> patterns = [] {
    std::vector<std::regex> compiled;
    for (const Route& r : RouteTable()) compiled.emplace_back(r.pattern);
    return compiled;
  }();
  const auto& routes = RouteTable();
  for (std::size_t i = 0; i < routes.size(); ++i) {
    if (method == routes[i].method && std::regex_match(path, patterns[i])) return routes[i].openapi_path;
  }
  return "unmatched";
}

// Per-request state: a request is handled start to end on one worker thread.
thread_local std::chrono::steady_clock::time_point request_start;
thread_local std::string request_id;

void WriteError(httplib::Response& res, Status status, const std::string& message,
                const std::vector<api::FieldViolation>& details = {}) {
  const int code = HttpStatusOf(status);
  res.status = code;
  res.set_content(api::ErrorBody(status, code, message, details).dump(), "application/json");
}

class Metrics {
 public:
  void Record(const std::string& method, const std::string& route, int status, double seconds) {
    std::lock_guard lock(mutex_);
    ++requests_[{method, route, status}];
    auto& d = durations_[route];
    d.first += seconds;
    d.second += 1;
  }
  std::string Render(int running_operations) {
    std::ostringstream out;
    std::lock_guard lock(mutex_);
    out << "# HELP robocal_http_requests_total HTTP requests by method, route and status code.\n"
           "# TYPE robocal_http_requests_total counter\n";
    for (const auto& [key, n] : requests_) {
      const auto& [method, route, status] = key;
      out << "robocal_http_requests_total{method=\"" << method << "\",route=\"" << route << "\",code=\"" << status
          << "\"} " << n << "\n";
    }
    out << "# HELP robocal_http_request_duration_seconds Time spent handling requests, by route.\n"
           "# TYPE robocal_http_request_duration_seconds summary\n";
    for (const auto& [route, d] : durations_) {
      out << "robocal_http_request_duration_seconds_sum{route=\"" << route << "\"} " << d.first << "\n"
          << "robocal_http_request_duration_seconds_count{route=\"" << route << "\"} " << d.second << "\n";
    }
    out << "# HELP robocal_operations_running Long-running operations in progress.\n"
           "# TYPE robocal_operations_running gauge\n"
        << "robocal_operations_running " << running_operations << "\n"
        << "# HELP robocal_build_info Build version.\n# TYPE robocal_build_info gauge\n"
        << "robocal_build_info{version=\"" << ROBOCAL_VERSION << "\"} 1\n";
    return out.str();
  }

 private:
  std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, std::uint64_t> requests_;
  std::map<std::string, std::pair<double, std::uint64_t>> durations_;
};

}  // namespace

int HttpStatusOf(Status status) {
  switch (status) {
    case Status::kInvalidArgument:
      return 400;
    case Status::kFailedPrecondition:
      return 400;
    case Status::kNotFound:
      return 404;
    case Status::kAlreadyExists:
      return 409;
    case Status::kUnauthenticated:
      return 401;
    case Status::kPermissionDenied:
      return 403;
    case Status::kResourceExhausted:
      return 413;
    case Status::kInternal:
      return 500;
    case Status::kUnavailable:
      return 503;
  }
  return 500;
}

std::vector<RouteInfo> Routes() {
  std::vector<RouteInfo> routes;
  for (const Route& r : RouteTable()) routes.push_back({r.method, r.openapi_path});
  return routes;
}

const std::string& OpenApiSpec() {
  static const std::string spec(kOpenApiJson);
  return spec;
}

bool TokenMatches(const std::string& presented, const std::vector<std::string>& tokens) {
  // Every token is compared over its full length whatever matched, so timing reveals neither which token nor
  // how many leading characters were right.
  unsigned matched = 0;
  for (const std::string& token : tokens) {
    unsigned diff = static_cast<unsigned>(presented.size() ^ token.size());
    for (std::size_t i = 0; i < token.size(); ++i) {
      const unsigned char p = i < presented.size() ? static_cast<unsigned char>(presented[i]) : 0;
      diff |= p ^ static_cast<unsigned char>(token[i]);
    }
    matched |= static_cast<unsigned>(diff == 0);
  }
  return matched != 0;
}

struct HttpServer::Impl {
  ServerConfig config;
  Service* service;
  std::vector<std::string> tokens;
  std::unique_ptr<httplib::Server> server;
  Metrics metrics;
  bool tls = false;
  int port = -1;
};

HttpServer::HttpServer(const ServerConfig& config, Service* service, std::vector<std::string> tokens)
    : impl_(std::make_unique<Impl>()) {
  impl_->config = config;
  impl_->service = service;
  impl_->tokens = std::move(tokens);
  if (!config.tls_cert.empty()) {
    auto ssl = std::make_unique<httplib::SSLServer>(config.tls_cert.c_str(), config.tls_key.c_str());
    if (!ssl->is_valid()) {
      throw std::runtime_error("cannot load TLS certificate " + config.tls_cert + " / key " + config.tls_key);
    }
    impl_->server = std::move(ssl);
    impl_->tls = true;
  } else {
    impl_->server = std::make_unique<httplib::Server>();
  }
  httplib::Server& svr = *impl_->server;
  Impl* impl = impl_.get();
  const int threads = config.threads;
  svr.new_task_queue = [threads] { return new httplib::ThreadPool(static_cast<std::size_t>(threads)); };
  // Headers and body leave in separate writes; with Nagle's algorithm the body would wait for the client's
  // delayed ACK (about 40 ms on Linux) on every request.
  svr.set_tcp_nodelay(true);
  svr.set_payload_max_length(static_cast<std::size_t>(config.max_body_bytes));
  // Waiting clients hold worker threads: an idle keep-alive connection for keep_alive_timeout_s, a slow one
  // for read / write_timeout_s per read or write.
  svr.set_keep_alive_timeout(config.keep_alive_timeout_s);
  svr.set_read_timeout(config.read_timeout_s, 0);
  svr.set_write_timeout(config.write_timeout_s, 0);

  svr.set_pre_routing_handler([impl](const httplib::Request& req, httplib::Response& res) {
    request_start = std::chrono::steady_clock::now();
    request_id = req.has_header("X-Request-Id") && req.get_header_value("X-Request-Id").size() <= 128
                     ? req.get_header_value("X-Request-Id")
                     : NewId("req");
    res.set_header("X-Request-Id", request_id);
    if (impl->tokens.empty() || req.path == "/healthz") return httplib::Server::HandlerResponse::Unhandled;
    const std::string auth = req.get_header_value("Authorization");
    const std::string prefix = "Bearer ";
    if (auth.rfind(prefix, 0) == 0 && TokenMatches(auth.substr(prefix.size()), impl->tokens)) {
      return httplib::Server::HandlerResponse::Unhandled;
    }
    res.set_header("WWW-Authenticate", "Bearer");
    WriteError(res, Status::kUnauthenticated,
               auth.empty() ? "missing bearer token (Authorization: Bearer <token>)" : "invalid bearer token");
    return httplib::Server::HandlerResponse::Handled;
  });

  for (const Route& route : RouteTable()) {
    httplib::Server::Handler handler;
    const std::string path = route.openapi_path;
    if (path == "/healthz") {
      handler = [impl](const httplib::Request&, httplib::Response& res) {
        res.set_content(json{{"status", "ok"}, {"version", ROBOCAL_VERSION}}.dump(), "application/json");
      };
    } else if (path == "/metrics") {
      handler = [impl](const httplib::Request&, httplib::Response& res) {
        res.set_content(impl->metrics.Render(impl->service->running_operations()), "text/plain; version=0.0.4");
      };
    } else if (path == "/v1/openapi.json") {
      handler = [](const httplib::Request&, httplib::Response& res) {
        res.set_content(OpenApiSpec(), "application/json");
      };
    } else {
      handler = [impl, fn = route.handler](const httplib::Request& req, httplib::Response& res) {
        res.set_content(fn(*impl->service, req).dump(), "application/json");
      };
    }
    const std::string method = route.method;
    if (method == "GET") svr.Get(route.pattern, handler);
    if (method == "POST") svr.Post(route.pattern, handler);
    if (method == "DELETE") svr.Delete(route.pattern, handler);
  }

  // One exception handler: every error a handler throws becomes the API's error body; the server keeps serving.
  svr.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
    try {
      std::rethrow_exception(ep);
    } catch (const ApiError& e) {
      WriteError(res, e.status(), e.what(), e.details());
    } catch (const StorageError& e) {
      switch (e.kind()) {
        case StorageError::Kind::kNotFound:
          WriteError(res, Status::kNotFound, e.what());
          break;
        case StorageError::Kind::kAlreadyExists:
          WriteError(res, Status::kAlreadyExists, e.what());
          break;
        case StorageError::Kind::kResourceExhausted:
          WriteError(res, Status::kResourceExhausted, e.what());
          break;
        case StorageError::Kind::kUnavailable:
          WriteError(res, Status::kUnavailable, std::string("storage unavailable: ") + e.what());
          break;
        case StorageError::Kind::kInternal:
          WriteError(res, Status::kInternal, std::string("storage error: ") + e.what());
          break;
      }
    } catch (const std::invalid_argument& e) {
      // A core precondition the wire validation let through: still the caller's input.
      WriteError(res, Status::kInvalidArgument, e.what());
    } catch (const std::exception& e) {
      LogEvent(spdlog::level::err, "unhandled exception", {{"request_id", request_id}, {"what", e.what()}});
      WriteError(res, Status::kInternal, std::string("internal error: ") + e.what());
    } catch (...) {
      WriteError(res, Status::kInternal, "internal error");
    }
  });

  // Errors produced by the HTTP library itself (unknown path, body too large) get the same body shape.
  svr.set_error_handler([impl](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;
    const bool form = req.get_header_value("Content-Type") == "application/x-www-form-urlencoded" &&
                      req.get_header_value<std::uint64_t>("Content-Length") <=
                          static_cast<std::uint64_t>(impl->config.max_body_bytes);
    if (res.status == 404) {
      WriteError(res, Status::kNotFound, "no such endpoint: " + req.method + " " + req.path);
    } else if (res.status == 413 && form) {
      // The HTTP library caps form bodies (curl -d's default type) far below max_body_bytes.
      WriteError(res, Status::kResourceExhausted, "form-encoded request body too large; send JSON as application/json",
                 {{"body", "Content-Type must be application/json"}});
    } else if (res.status == 413) {
      WriteError(res, Status::kResourceExhausted, "request body larger than max_body_bytes",
                 {{"body", "exceeds the max_body_bytes limit"}});
    } else if (res.status == 400) {
      WriteError(res, Status::kInvalidArgument, "malformed HTTP request");
    } else {
      const int status = res.status;
      res.set_content(api::ErrorBody(Status::kInvalidArgument, status, "HTTP error " + std::to_string(status))
                          .dump(),
                      "application/json");
    }
  });

  svr.set_logger([impl](const httplib::Request& req, const httplib::Response& res) {
    const double seconds =
        request_start == std::chrono::steady_clock::time_point{}
            ? 0.0
            : std::chrono::duration<double>(std::chrono::steady_clock::now() - request_start).count();
    const std::string route = RouteLabel(req.method, req.path);
    impl->metrics.Record(req.method, route, res.status, seconds);
    LogEvent(res.status >= 500 ? spdlog::level::err : spdlog::level::info, "request",
             {{"request_id", request_id},
              {"method", req.method},
              {"path", req.path},
              {"status", res.status},
              {"ms", std::round(seconds * 1e4) / 10.0}});
    request_start = {};
  });
}

HttpServer::~HttpServer() { Stop(); }

int HttpServer::Bind() {
  if (impl_->config.port == 0) {
    impl_->port = impl_->server->bind_to_any_port(impl_->config.host);
  } else {
    impl_->port = impl_->server->bind_to_port(impl_->config.host, impl_->config.port) ? impl_->config.port : -1;
  }
  return impl_->port;
}

bool HttpServer::Listen() { return impl_->server->listen_after_bind(); }

void HttpServer::Stop() {
  if (impl_ && impl_->server) impl_->server->stop();
}

bool HttpServer::is_running() const { return impl_->server->is_running(); }
bool HttpServer::tls() const { return impl_->tls; }

}  // namespace robocal::server
