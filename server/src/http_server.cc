// The HTTP server: routes, auth, error mapping, logging, metrics.
#include "robocal/server/http_server.h"

#include <chrono>
#include <functional>
#include <map>
#include <mutex>
#include <regex>
#include <semaphore>
#include <sstream>
#include <variant>

#include <httplib.h>

#include "http_edge.h"
#include "request_checks.h"
#include "routes.h"
#include "robocal/api/health.h"
#include "robocal/api/json_reader.h"
#include "robocal/api/text.h"
#include "robocal/server/logging.h"
#include "robocal/server/openapi_spec.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;
using nlohmann::json;

// Per-request state: a request is handled start to end on one worker thread.
thread_local std::chrono::steady_clock::time_point request_start;
thread_local std::string request_id;
// The name of the token the request being handled presented (unset without tokens).
thread_local std::optional<std::string> request_caller;

}  // namespace

// Requests by route and status, and their durations (a member of HttpServer::Impl: not in the anonymous
// namespace, whose types a class with linkage may not hold).
class Metrics {
 public:
  void Record(const std::string& method, const std::string& route, int status, double seconds) {
    std::lock_guard lock(mutex_);
    ++requests_[{method, route, status}];
    auto& d = durations_[route];
    d.first += seconds;
    d.second += 1;
  }
  std::string Render(int running_operations, const edge::Counters& connections) {
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
    // One metric without labels: its help, its type and its value.
    const auto single = [&out](const char* name, const char* type, const char* help, auto value) {
      out << "# HELP " << name << " " << help << "\n# TYPE " << name << " " << type << "\n"
          << name << " " << value << "\n";
    };
    single("robocal_operations_running", "gauge", "Long-running operations in progress.", running_operations);
    single("robocal_http_connections_active", "gauge", "Connections being served.", connections.active.load());
    single("robocal_http_connections_queued", "gauge", "Accepted connections waiting for a connection thread.",
           connections.queued.load());
    single("robocal_http_connections_refused_total", "counter",
           "Connections refused (503) because the queue was full.", connections.refused.load());
    single("robocal_http_requests_timed_out_total", "counter",
           "Requests not received within request_read_timeout_s.", connections.timed_out.load());
    single("robocal_http_requests_too_large_total", "counter", "Requests whose head or body exceeded its limit.",
           connections.too_large.load());
    out        << "# HELP robocal_build_info Build version.\n# TYPE robocal_build_info gauge\n"
        << "robocal_build_info{version=\"" << ROBOCAL_VERSION << "\"} 1\n";
    return out.str();
  }

 private:
  std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, std::uint64_t> requests_;
  std::map<std::string, std::pair<double, std::uint64_t>> durations_;
};

const std::string& OpenApiSpec() {
  static const std::string spec = [] {
    std::string text;
    for (const char* part : kOpenApiJsonParts) text += part;
    return text;
  }();
  return spec;
}

// The index of the token `presented` is, or -1.
int MatchingToken(const std::string& presented, const std::vector<std::string>& tokens) {
  // Every token is compared over its full length whatever matched, so timing reveals neither which token nor
  // how many leading characters were right.
  int matched = -1;
  for (std::size_t k = 0; k < tokens.size(); ++k) {
    const std::string& token = tokens[k];
    unsigned diff = static_cast<unsigned>(presented.size() ^ token.size());
    for (std::size_t i = 0; i < token.size(); ++i) {
      const unsigned char p = i < presented.size() ? static_cast<unsigned char>(presented[i]) : 0;
      diff |= p ^ static_cast<unsigned char>(token[i]);
    }
    if (diff == 0) matched = static_cast<int>(k);
  }
  return matched;
}

bool TokenMatches(const std::string& presented, const std::vector<std::string>& tokens) {
  return MatchingToken(presented, tokens) >= 0;
}

Caller RequestCaller() { return {request_caller}; }

struct HttpServer::Impl {
  ServerConfig config;
  Service* service;
  std::vector<std::string> tokens;
  /// The tokens' names (tokens[k]'s is token_names[k]; "token k+1" where there is none).
  std::vector<std::string> token_names;
  edge::Counters connections;
  std::unique_ptr<httplib::Server> server;
  Metrics metrics;
  // Requests handled at once (`threads`); connection threads beyond wait here, not in the handlers.
  std::unique_ptr<std::counting_semaphore<>> handler_slots;
  bool tls = false;
  int port = -1;

  // The constructor's steps, in order (http_server.cc below).
  void CreateServer();       // plain or TLS, with the edge's limits and canned replies
  void ConfigureServer();    // connection pool, socket options, body limit, keep-alive
  void InstallAdmission();   // Expect: 100-continue, head checks, request ids, bearer tokens
  void InstallRoutes();      // the route table, behind `threads` handler slots
  void InstallErrorReplies();  // exceptions and the library's own errors as the API's error body
  void InstallLogger();      // one log line and the metrics per request
};

namespace {

// The edge's own replies, in the API's error shape.
std::string CannedReply(Status status, int code, const std::string& message, const std::string& field,
                        const std::string& reason, const char* extra_headers = "") {
  const std::string body = api::ErrorBody(status, code, message, {{field, reason}}).dump();
  const char* phrase = code == 408   ? "Request Timeout"
                       : code == 503 ? "Service Unavailable"
                       : code == 431 ? "Request Header Fields Too Large"
                                     : "Error";
  return "HTTP/1.1 " + std::to_string(code) + " " + phrase +
         "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) +
         "\r\nConnection: close\r\n" + extra_headers + "\r\n" + body;
}

edge::Limits EdgeLimits(const ServerConfig& c) {
  edge::Limits limits;
  limits.max_head_bytes = static_cast<std::size_t>(c.max_head_bytes);
  limits.max_body_bytes = static_cast<std::size_t>(c.max_body_bytes);
  limits.request_read_timeout = std::chrono::seconds(c.request_read_timeout_s);
  limits.keep_alive_timeout = std::chrono::seconds(c.keep_alive_timeout_s);
  limits.write_timeout = std::chrono::seconds(c.write_timeout_s);
  return limits;
}

edge::CannedReplies EdgeReplies(const ServerConfig& c) {
  edge::CannedReplies canned;
  canned.busy = CannedReply(Status::kUnavailable, HttpStatusOf(Status::kUnavailable), "server busy: every connection slot is taken", "connection",
                            "max_connections and max_queued_connections are reached; retry later",
                            "Retry-After: 1\r\n");
  canned.timeout = CannedReply(Status::kDeadlineExceeded, HttpStatusOf(Status::kDeadlineExceeded), "request not received in time", "request",
                               "the request line, headers and body must arrive within request_read_timeout_s (" +
                                   std::to_string(c.request_read_timeout_s) + " s)");
  canned.head_too_large = CannedReply(Status::kResourceExhausted, 431, "request head too large", "head",
                                      "request line and headers exceed max_head_bytes (" +
                                          std::to_string(c.max_head_bytes) + ")");
  canned.stopping = CannedReply(Status::kUnavailable, HttpStatusOf(Status::kUnavailable), "server shutting down",
                                "request", "the server stopped while the request was arriving; retry",
                                "Retry-After: 1\r\n");
  return canned;
}

// A storage failure as the API's error; the database's own text (statements, driver messages) goes to the log
// only, with the request's id.
void WriteStorageError(httplib::Response& res, const StorageError& e) {
  if (!e.detail().empty()) {
    LogEvent(spdlog::level::warn, "storage error",
             {{"request_id", request_id}, {"error", api::SafeText(e.what())}, {"detail", api::SafeText(e.detail())}});
  }
  switch (e.kind()) {
    case StorageError::Kind::kNotFound:
      WriteError(res, Status::kNotFound, e.what());
      return;
    case StorageError::Kind::kAlreadyExists:
      WriteError(res, Status::kAlreadyExists, e.what());
      return;
    case StorageError::Kind::kVersionConflict:
      WriteError(res, Status::kAborted, e.what());
      return;
    case StorageError::Kind::kResourceExhausted:
      WriteError(res, Status::kResourceExhausted, e.what());
      return;
    case StorageError::Kind::kUnavailable:
      res.set_header("Retry-After", "1");
      WriteError(res, Status::kUnavailable, std::string("storage unavailable: ") + e.what());
      return;
    case StorageError::Kind::kInternal:
      WriteError(res, Status::kInternal, std::string("storage error: ") + e.what());
      return;
  }
}

}  // namespace

void HttpServer::Impl::CreateServer() {
  edge::Counters* counters = &connections;
  if (!config.tls_cert.empty()) {
    auto ssl = std::make_unique<edge::SslServer>(config.tls_cert.c_str(), config.tls_key.c_str(),
                                                 edge::Settings{EdgeLimits(config), EdgeReplies(config), counters});
    if (!ssl->is_valid()) {
      throw std::runtime_error("cannot load TLS certificate " + config.tls_cert + " / key " + config.tls_key);
    }
    server = std::move(ssl);
    tls = true;
  } else {
    server = std::make_unique<edge::Server>(edge::Settings{EdgeLimits(config), EdgeReplies(config), counters});
  }
}

void HttpServer::Impl::ConfigureServer() {
  httplib::Server& svr = *server;
  edge::Counters* counters = &connections;
  const auto max_connections = static_cast<std::size_t>(config.max_connections);
  const auto max_queued = static_cast<std::size_t>(config.max_queued_connections);
  svr.new_task_queue = [max_connections, max_queued, counters] {
    return new edge::ConnectionPool(max_connections, max_queued, counters);
  };
  // Headers and body leave in separate writes; with Nagle's algorithm the body would wait for the client's
  // delayed ACK (about 40 ms on Linux) on every request.
  svr.set_tcp_nodelay(true);
  svr.set_payload_max_length(static_cast<std::size_t>(config.max_body_bytes));
  // The edge applies its own deadlines (request_read_timeout_s for a whole request, write_timeout_s for a whole
  // reply); the library's keep-alive figures only go into the Keep-Alive header it writes.
  svr.set_keep_alive_timeout(config.keep_alive_timeout_s);
  svr.set_keep_alive_max_count(100);
  // The library's default sets SO_REUSEPORT: a second server started on a port another one listens on would
  // start without error and the kernel would split the connections between the two (two databases). With
  // SO_REUSEADDR only, a restarted server still binds while its old connections linger in TIME_WAIT, and a port
  // in use is a bind error.
  svr.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
}

void HttpServer::Impl::InstallAdmission() {
  httplib::Server& svr = *server;
  // A client that asks before sending its body (Expect: 100-continue, as curl does for large ones) gets the
  // refusal instead of the go-ahead.
  svr.set_expect_100_continue_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (!CheckHead(req, res, config.max_body_bytes)) {
      res.set_header("Connection", "close");
      edge::CloseAfterResponse();
      return res.status;
    }
    return 100;
  });

  svr.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    IgnoreRanges(req);
    request_start = std::chrono::steady_clock::now();
    const std::string* client_id = RawHeader(req, "X-Request-Id");
    request_id = client_id != nullptr && UsableRequestId(*client_id) ? *client_id : NewId("req");
    res.set_header("X-Request-Id", request_id);
    const auto handled = [&res] {
      // Whatever body the request carries stays unread: the connection cannot be reused.
      res.set_header("Connection", "close");
      edge::CloseAfterResponse();
      return httplib::Server::HandlerResponse::Handled;
    };
    if (!CheckHead(req, res, config.max_body_bytes)) return handled();
    request_caller.reset();
    if (tokens.empty() || req.path == "/healthz") return httplib::Server::HandlerResponse::Unhandled;
    const std::string* auth = RawHeader(req, "Authorization");
    const std::string prefix = "Bearer ";
    if (auth != nullptr && auth->rfind(prefix, 0) == 0) {
      if (const int k = MatchingToken(auth->substr(prefix.size()), tokens); k >= 0) {
        request_caller = k < static_cast<int>(token_names.size()) && !token_names[k].empty()
                             ? token_names[k]
                             : "token " + std::to_string(k + 1);
        return httplib::Server::HandlerResponse::Unhandled;
      }
    }
    res.set_header("WWW-Authenticate", "Bearer");
    WriteError(res, Status::kUnauthenticated,
               auth == nullptr ? "missing bearer token (Authorization: Bearer <token>)" : "invalid bearer token");
    return handled();
  });
}

void HttpServer::Impl::InstallRoutes() {
  httplib::Server& svr = *server;
  for (const Route& route : RouteTable()) {
    httplib::Server::Handler handler;
    const std::string path = route.openapi_path;
    if (path == "/healthz") {
      handler = [](const httplib::Request&, httplib::Response& res) {
        res.set_content(json(api::Health{"ok", ROBOCAL_VERSION}).dump(), "application/json");
      };
    } else if (path == "/metrics") {
      handler = [this](const httplib::Request&, httplib::Response& res) {
        res.set_content(metrics.Render(service->running_operations(), connections),
                        "text/plain; version=0.0.4");
      };
    } else if (path == "/v1/openapi.json") {
      handler = [](const httplib::Request&, httplib::Response& res) {
        res.set_content(OpenApiSpec(), "application/json");
      };
    } else {
      handler = [this, fn = route.handler](const httplib::Request& req, httplib::Response& res) {
        // Service work runs `threads` requests at a time; health, metrics and the spec never wait for it.
        const auto wait = std::chrono::seconds(config.request_timeout_s);
        if (!handler_slots->try_acquire_for(wait)) {
          res.set_header("Retry-After", "1");
          WriteError(res, Status::kUnavailable, "server busy: every request slot stayed taken",
                     {{"request", "no slot among `threads` freed within request_timeout_s; retry later"}});
          return;
        }
        struct Release {
          std::counting_semaphore<>* slots;
          ~Release() { slots->release(); }
        } release{handler_slots.get()};
        RouteReply reply = fn(*service, req);
        for (const auto& [name, value] : reply.headers) res.set_header(name, value);
        res.set_content(std::move(reply.body), reply.content_type);
      };
    }
    const std::string method = route.method;
    if (method == "GET") svr.Get(route.pattern, handler);
    if (method == "POST") svr.Post(route.pattern, handler);
    if (method == "DELETE") svr.Delete(route.pattern, handler);
  }
}

void HttpServer::Impl::InstallErrorReplies() {
  httplib::Server& svr = *server;
  // One exception handler: every error a handler throws becomes the API's error body; the server keeps serving.
  // WriteError cannot throw; the outer catch is for the rest (a log line that fails, say).
  svr.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
    try {
      try {
        std::rethrow_exception(ep);
      } catch (const ApiError& e) {
        WriteError(res, e.status(), e.what(), e.details());
      } catch (const StorageError& e) {
        WriteStorageError(res, e);
      } catch (const std::invalid_argument& e) {
        // A core precondition the wire validation let through: still the caller's input.
        WriteError(res, Status::kInvalidArgument, e.what());
      } catch (const std::exception& e) {
        LogEvent(spdlog::level::err, "unhandled exception",
                 {{"request_id", request_id}, {"what", api::SafeText(e.what())}});
        WriteError(res, Status::kInternal, std::string("internal error: ") + e.what());
      } catch (...) {
        WriteError(res, Status::kInternal, "internal error");
      }
    } catch (...) {
      res.status = 500;
      res.set_content(kInternalErrorBody, "application/json");
    }
  });

  // Errors produced by the HTTP library itself (unknown path, a head it cannot parse, a body the edge cut off)
  // get the same body shape. Nothing in here may throw out: the reply falls back to a fixed 500 body.
  svr.set_error_handler([this](const httplib::Request& req, httplib::Response& res) {
    IgnoreRanges(req);
    try {
      const edge::Fault fault = edge::CurrentFault();
      if (fault != edge::Fault::kNone) {
        res.set_header("Connection", "close");
        res.body.clear();
      }
      if (!res.body.empty()) return;
      const std::string limit_s = std::to_string(config.request_read_timeout_s);
      switch (fault) {
        case edge::Fault::kDeadline:
          WriteError(res, Status::kDeadlineExceeded, "request not received in time",
                     {{"request", "the request line, headers and body must arrive within request_read_timeout_s (" +
                                      limit_s + " s)"}});
          return;
        case edge::Fault::kHeadTooLarge:
          WriteError(res, Status::kResourceExhausted, "request head too large",
                     {{"head", "request line and headers exceed max_head_bytes (" +
                                   std::to_string(config.max_head_bytes) + ")"}},
                     431);
          return;
        case edge::Fault::kBodyTooLarge:
          WriteError(res, Status::kResourceExhausted, "request body larger than max_body_bytes",
                     {{"body", "exceeds the max_body_bytes limit (" + std::to_string(config.max_body_bytes) +
                                   "), counted as sent"}});
          return;
        case edge::Fault::kStopping:
          res.set_header("Retry-After", "1");
          WriteError(res, Status::kUnavailable, "server shutting down",
                     {{"request", "the server stopped while the request was arriving; retry"}});
          return;
        case edge::Fault::kNone:
          break;
      }
      if (res.status == 404) {
        WriteError(res, Status::kNotFound, "no such endpoint: " + req.method + " " + req.path,
                   {{"path", "no route for " + req.method + " " + req.path + " (see /v1/openapi.json)"}});
      } else if (res.status == 413) {
        WriteError(res, Status::kResourceExhausted, "request body larger than max_body_bytes",
                   {{"body", "exceeds the max_body_bytes limit"}});
      } else if (res.status == 414) {
        WriteError(res, Status::kInvalidArgument, "request line too long",
                   {{"uri", "the request line is longer than 8192 bytes"}}, 414);
      } else if (res.status == 400) {
        WriteError(res, Status::kInvalidArgument, "malformed HTTP request",
                   {{"request", "the request line or a header could not be parsed"}});
      } else {
        const int status = res.status;
        res.set_content(api::ErrorBody(Status::kInvalidArgument, status, "HTTP error " + std::to_string(status),
                                       {{"request", "the HTTP layer answered " + std::to_string(status)}})
                            .dump(),
                        "application/json");
      }
    } catch (...) {
      res.status = 500;
      res.set_content(kInternalErrorBody, "application/json");
    }
  });
}

void HttpServer::Impl::InstallLogger() {
  httplib::Server& svr = *server;
  svr.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
    const double seconds =
        request_start == std::chrono::steady_clock::time_point{}
            ? 0.0
            : std::chrono::duration<double>(std::chrono::steady_clock::now() - request_start).count();
    const std::string route = RouteLabel(req.method, req.path);
    metrics.Record(MethodLabel(req.method), route, res.status, seconds);
    // A head the library could not parse never reached the pre-routing handler: it has no id of its own.
    if (request_id.empty()) request_id = NewId("req");
    LogEvent(res.status >= 500 ? spdlog::level::err : spdlog::level::info, "request",
             {{"request_id", request_id},
              {"method", api::SafeText(req.method, 16)},
              {"path", api::SafeText(req.path, 256)},
              {"status", res.status},
              {"ms", std::round(seconds * 1e4) / 10.0}});
    request_start = {};
    request_id.clear();
  });
}

HttpServer::HttpServer(const ServerConfig& config, Service* service, std::vector<std::string> tokens,
                       std::vector<std::string> token_names)
    : impl_(std::make_unique<Impl>()) {
  impl_->config = config;
  impl_->service = service;
  impl_->tokens = std::move(tokens);
  impl_->token_names = std::move(token_names);
  impl_->handler_slots = std::make_unique<std::counting_semaphore<>>(std::max(1, config.threads));
  impl_->CreateServer();
  impl_->ConfigureServer();
  impl_->InstallAdmission();
  impl_->InstallRoutes();
  impl_->InstallErrorReplies();
  impl_->InstallLogger();
}

HttpServer::~HttpServer() { Stop(); }

int HttpServer::Bind() {
  if (impl_->config.port == 0) {
    impl_->port = impl_->server->bind_to_any_port(impl_->config.host);
  } else {
    impl_->port = impl_->server->bind_to_port(impl_->config.host, impl_->config.port) ? impl_->config.port : -1;
  }
  if (impl_->port > 0) {
    edge::WidenBacklog(impl_->tls ? static_cast<edge::SslServer&>(*impl_->server).listening_socket()
                                  : static_cast<edge::Server&>(*impl_->server).listening_socket());
  }
  return impl_->port;
}

bool HttpServer::Listen() { return impl_->server->listen_after_bind(); }

void HttpServer::Stop() {
  if (impl_ && impl_->server) impl_->server->stop();
}

bool HttpServer::is_running() const { return impl_->server->is_running(); }
bool HttpServer::tls() const { return impl_->tls; }
HttpServer::ConnectionCounts HttpServer::connection_counts() const {
  return {impl_->connections.active.load(), impl_->connections.queued.load()};
}

}  // namespace robocal::server
