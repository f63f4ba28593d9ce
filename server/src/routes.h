// The route table of the HTTP API: each route's method, pattern, documented path and what it does (parse the
// request, call the service, serialise the typed reply). Registration, the OpenAPI completeness test and the
// /metrics labels all come from it.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/server/service.h"
// After the service: the library's header must not come before Eigen's.
#include <httplib.h>

namespace robocal::server {

/// A route's reply: its body and media type (JSON unless a route says otherwise, e.g. a URDF document).
struct RouteReply {
  RouteReply(std::string body_text) : body(std::move(body_text)) {}  // NOLINT: JSON replies convert implicitly
  RouteReply(std::string body_text, std::string type) : body(std::move(body_text)), content_type(std::move(type)) {}
  std::string body;
  std::string content_type = "application/json";
  /// Headers beside the content type (e.g. the report's Content-Security-Policy).
  std::vector<std::pair<std::string, std::string>> headers;
};

// What a route does: parse path/query/body, call the service, return the response.
using RouteHandler = std::function<RouteReply(Service&, const httplib::Request&)>;

struct Route {
  const char* method;
  const char* pattern;  // cpp-httplib regex; ids never contain '/' or ':'
  const char* openapi_path;
  RouteHandler handler;
};

/// Who makes the request being handled on this thread: its bearer token's name (set by the server's admission, unset
/// without tokens).
Caller RequestCaller();

/// Every route; /healthz, /metrics and the spec have no handler here (the server answers them itself).
const std::vector<Route>& RouteTable();

/// The method label for metrics: one of the methods HTTP defines, else "other" (a client may send any bytes as a
/// method; each distinct one would otherwise become a series kept forever).
std::string MethodLabel(const std::string& method);
/// The route label of a request path for metrics and logs (bounded cardinality: never the raw path).
std::string RouteLabel(const std::string& method, const std::string& path);

}  // namespace robocal::server
