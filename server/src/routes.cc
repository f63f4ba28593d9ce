// The route table.
#include "routes.h"

#include "robocal/server/http_server.h"

#include <algorithm>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <variant>

#include "robocal/api/json_reader.h"
#include "robocal/api/text.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;
using nlohmann::json;

// The pre-routing check has made sure a POST carries a body declared as JSON; an empty one is refused here.
json Body(const Service& service, const httplib::Request& req) {
  if (req.body.empty()) {
    throw ApiError(Status::kInvalidArgument, "empty request body: send a JSON object ({} for the defaults)",
                   {{"body", "must be a JSON object, got an empty body"}});
  }
  return api::ParseBody(req.body, service.limits().max_array_length);
}
// A typed reply as the response body; a plan or fit is either the result or (async) its operation. Dumping
// with `replace` cannot throw on a byte a stored document might hold; requests are validated.
std::string Dump(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }
template <typename T>
std::string Reply(const T& value) {
  return Dump(json(value));
}
template <typename... T>
std::string Reply(const std::variant<T...>& value) {
  return std::visit([](const auto& v) { return Dump(json(v)); }, value);
}
// The largest reply of the API is written directly (api::DumpCompensatedTargets says why).
std::string Reply(const api::CompensatedTargets& value) { return api::DumpCompensatedTargets(value); }
std::string Id(const httplib::Request& req, int i = 1) { return req.matches[i].str(); }
std::string Query(const httplib::Request& req, const char* key) {
  return req.has_param(key) ? req.get_param_value(key) : "";
}

// The query parameters of `req` by name, each given once and named in `allowed`; anything else is
// INVALID_ARGUMENT naming the parameter ("query" for an empty name). A name without "=" has the value "". Read
// from the raw target: cpp-httplib's own parse drops an exact repeat and an empty name.
std::map<std::string, std::string> StrictQuery(const httplib::Request& req, const std::set<std::string>& allowed,
                                               const std::string& what) {
  std::vector<std::pair<std::string, std::string>> pairs;
  const std::size_t question = req.target.find('?');
  for (std::size_t begin = question == std::string::npos ? req.target.size() + 1 : question + 1;
       begin <= req.target.size();) {
    const std::size_t end = std::min(req.target.find('&', begin), req.target.size());
    const std::string pair = req.target.substr(begin, end - begin);
    begin = end + 1;
    if (pair.empty()) continue;  // "?" or "a=1&&b=2": no parameter between
    const std::size_t equals = pair.find('=');
    pairs.emplace_back(httplib::detail::decode_url(pair.substr(0, equals), true),
                       equals == std::string::npos ? "" : httplib::detail::decode_url(pair.substr(equals + 1), true));
  }
  std::map<std::string, std::string> params;
  for (const auto& [name, value] : pairs) {
    const std::string field = name.empty() ? "query" : api::SafeText(name, 64);
    if (!allowed.count(name)) {
      std::string names;
      for (const std::string& a : allowed) names += (names.empty() ? "" : ", ") + a;
      throw ApiError(Status::kInvalidArgument,
                     "invalid " + what + " request: unknown query parameter \"" + api::SafeText(name, 64) + "\"",
                     {{field, "unknown query parameter; this route takes " + names}});
    }
    if (!params.emplace(name, value).second) {
      const auto times = std::to_string(
          std::count_if(pairs.begin(), pairs.end(), [&name = name](const auto& p) { return p.first == name; }));
      throw ApiError(Status::kInvalidArgument,
                     "invalid " + what + " request: query parameter " + name + " given " + times + " times",
                     {{field, "given " + times + " times; give it once"}});
    }
  }
  return params;
}

}  // namespace

// A table, one route an entry, kept whole on purpose: registration, metrics labels and the OpenAPI test read it.
const std::vector<Route>& RouteTable() {
  static const std::vector<Route> routes = {
      {"GET", "/healthz", "/healthz", nullptr},
      {"GET", "/metrics", "/metrics", nullptr},
      {"GET", "/v1/openapi.json", "/v1/openapi.json", nullptr},
      {"GET", "/v1/robots", "/v1/robots",
       [](Service& s, const httplib::Request& r) {
         return Reply(s.ListRobots(Query(r, "page_size"), Query(r, "page_token")));
       }},
      {"POST", "/v1/robots", "/v1/robots",
       [](Service& s, const httplib::Request& r) { return Reply(s.CreateRobot(Body(s, r), RequestCaller())); }},
      {"GET", R"(/v1/robots/([^/:]+))", "/v1/robots/{robot}",
       [](Service& s, const httplib::Request& r) { return Reply(s.GetRobot(Id(r))); }},
      {"DELETE", R"(/v1/robots/([^/:]+))", "/v1/robots/{robot}",
       [](Service& s, const httplib::Request& r) {
         s.DeleteRobot(Id(r));
         return std::string("{}");
       }},
      {"POST", R"(/v1/robots/([^/:]+):forward)", "/v1/robots/{robot}:forward",
       [](Service& s, const httplib::Request& r) { return Reply(s.RobotForward(Id(r), Body(s, r))); }},
      {"POST", R"(/v1/robots/([^/:]+):check)", "/v1/robots/{robot}:check",
       [](Service& s, const httplib::Request& r) { return Reply(s.CheckRobot(Id(r), Body(s, r), RequestCaller())); }},
      {"POST", R"(/v1/robots/([^/:]+):calibrate)", "/v1/robots/{robot}:calibrate",
       [](Service& s, const httplib::Request& r) {
         return Reply(s.CalibrateRobot(Id(r), Body(s, r), RequestCaller()));
       }},
      {"POST", R"(/v1/robots/([^/:]+):rollback)", "/v1/robots/{robot}:rollback",
       [](Service& s, const httplib::Request& r) {
         return Reply(s.RollbackRobot(Id(r), Body(s, r), RequestCaller()));
       }},
      {"GET", R"(/v1/robots/([^/:]+)/calibrations)", "/v1/robots/{robot}/calibrations",
       [](Service& s, const httplib::Request& r) { return Reply(s.RobotHistory(Id(r))); }},
      {"GET", "/v1/cells", "/v1/cells",
       [](Service& s, const httplib::Request& r) {
         return Reply(s.ListCells(Query(r, "page_size"), Query(r, "page_token")));
       }},
      {"POST", "/v1/cells", "/v1/cells",
       [](Service& s, const httplib::Request& r) { return Reply(s.CreateCell(Body(s, r))); }},
      {"GET", R"(/v1/cells/([^/:]+))", "/v1/cells/{cell}",
       [](Service& s, const httplib::Request& r) { return Reply(s.GetCell(Id(r))); }},
      {"DELETE", R"(/v1/cells/([^/:]+))", "/v1/cells/{cell}",
       [](Service& s, const httplib::Request& r) {
         s.DeleteCell(Id(r));
         return std::string("{}");
       }},
      {"POST", R"(/v1/cells/([^/:]+):check)", "/v1/cells/{cell}:check",
       [](Service& s, const httplib::Request& r) { return Reply(s.CheckCell(Id(r), Body(s, r))); }},
      {"POST", "/v1/plans", "/v1/plans",
       [](Service& s, const httplib::Request& r) { return Reply(s.CreatePlan(Body(s, r))); }},
      {"GET", R"(/v1/plans/([^/:]+))", "/v1/plans/{plan}",
       [](Service& s, const httplib::Request& r) { return Reply(s.GetPlan(Id(r))); }},
      {"GET", "/v1/campaigns", "/v1/campaigns",
       [](Service& s, const httplib::Request& r) {
         return Reply(s.ListCampaigns(Query(r, "page_size"), Query(r, "page_token")));
       }},
      {"POST", "/v1/campaigns", "/v1/campaigns",
       [](Service& s, const httplib::Request& r) { return Reply(s.CreateCampaign(Body(s, r))); }},
      {"GET", R"(/v1/campaigns/([^/:]+))", "/v1/campaigns/{campaign}",
       [](Service& s, const httplib::Request& r) { return Reply(s.GetCampaign(Id(r))); }},
      {"POST", R"(/v1/campaigns/([^/:]+)/measurements:import)", "/v1/campaigns/{campaign}/measurements:import",
       [](Service& s, const httplib::Request& r) { return Reply(s.ImportMeasurements(Id(r), Body(s, r))); }},
      {"POST", R"(/v1/campaigns/([^/:]+)/measurements)", "/v1/campaigns/{campaign}/measurements",
       [](Service& s, const httplib::Request& r) { return Reply(s.AppendMeasurements(Id(r), Body(s, r))); }},
      {"GET", R"(/v1/campaigns/([^/:]+)/measurements)", "/v1/campaigns/{campaign}/measurements",
       [](Service& s, const httplib::Request& r) {
         return Reply(s.ListMeasurements(Id(r), Query(r, "role"), Query(r, "after"), Query(r, "limit")));
       }},
      {"POST", R"(/v1/campaigns/([^/:]+):fit)", "/v1/campaigns/{campaign}:fit",
       [](Service& s, const httplib::Request& r) { return Reply(s.Fit(Id(r), Body(s, r))); }},
      {"GET", R"(/v1/campaigns/([^/:]+)/calibration)", "/v1/campaigns/{campaign}/calibration",
       [](Service& s, const httplib::Request& r) -> RouteReply {
         const std::string format = Query(r, "format");
         if (format == "urdf") return {s.CalibrationUrdf(Id(r)), "application/xml"};
         if (format == "dh") return Reply(s.CalibrationDh(Id(r), GeometryConvention::kStandardDh));
         if (format == "mdh") return Reply(s.CalibrationDh(Id(r), GeometryConvention::kModifiedDh));
         if (!format.empty() && format != "json") {
           throw ApiError(Status::kInvalidArgument, "unknown format \"" + format + "\"",
                          {{"format", "must be json (the default), urdf, dh or mdh"}});
         }
         return Reply(s.GetCalibration(Id(r)));
       }},
      {"GET", R"(/v1/campaigns/([^/:]+)/report)", "/v1/campaigns/{campaign}/report",
       [](Service& s, const httplib::Request& r) -> RouteReply {
         const std::map<std::string, std::string> query = StrictQuery(r, {"h_mm"}, "report");
         const auto h_mm = query.find("h_mm");
         RouteReply reply(s.CampaignReport(Id(r), h_mm == query.end() ? std::nullopt : std::optional(h_mm->second)),
                          "text/html; charset=utf-8");
         // The page needs nothing but its own inline styles and SVG: a browser is told to load and run nothing
         // else, whatever a stored name might smuggle in.
         reply.headers = {{"Content-Security-Policy", "default-src 'none'; style-src 'unsafe-inline'; img-src data:"},
                          {"X-Content-Type-Options", "nosniff"}};
         return reply;
       }},
      {"GET", R"(/v1/campaigns/([^/:]+)/iso9283)", "/v1/campaigns/{campaign}/iso9283",
       [](Service& s, const httplib::Request& r) -> RouteReply {
         const std::map<std::string, std::string> query = StrictQuery(r, {"format"}, "iso9283");
         const auto format = query.find("format");
         const std::string f = format == query.end() ? "json" : format->second;
         if (f != "json" && f != "csv") {
           throw ApiError(Status::kInvalidArgument, "unknown format \"" + f + "\"",
                          {{"format", "must be json (the default) or csv"}});
         }
         const api::Iso9283ReportWire report = s.Iso9283Report(Id(r));
         if (f == "csv") return {api::Iso9283Csv(report), "text/csv; charset=utf-8"};
         return Reply(report);
       }},
      {"POST", R"(/v1/campaigns/([^/:]+):compensate)", "/v1/campaigns/{campaign}:compensate",
       [](Service& s, const httplib::Request& r) { return Reply(s.Compensate(Id(r), Body(s, r))); }},
      {"POST", R"(/v1/campaigns/([^/:]+):compensate-program)", "/v1/campaigns/{campaign}:compensate-program",
       [](Service& s, const httplib::Request& r) { return Reply(s.CompensateProgram(Id(r), Body(s, r))); }},
      {"POST", R"(/v1/campaigns/([^/:]+):forward)", "/v1/campaigns/{campaign}:forward",
       [](Service& s, const httplib::Request& r) { return Reply(s.CampaignForward(Id(r), Body(s, r))); }},
      {"POST", R"(/v1/campaigns/([^/:]+):evaluate)", "/v1/campaigns/{campaign}:evaluate",
       [](Service& s, const httplib::Request& r) { return Reply(s.Evaluate(Id(r), Body(s, r))); }},
      {"GET", R"(/v1/operations/([^/:]+))", "/v1/operations/{operation}",
       [](Service& s, const httplib::Request& r) { return Reply(s.GetOperation(Id(r))); }},
      {"POST", R"(/v1/operations/([^/:]+):cancel)", "/v1/operations/{operation}:cancel",
       [](Service& s, const httplib::Request& r) { return Reply(s.CancelOperation(Id(r))); }},
  };
  return routes;
}

std::string MethodLabel(const std::string& method) {
  for (const char* known : {"GET", "POST", "DELETE", "PUT", "PATCH", "HEAD", "OPTIONS", "CONNECT", "TRACE"}) {
    if (method == known) return method;
  }
  return "other";
}

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

std::vector<RouteInfo> Routes() {
  std::vector<RouteInfo> routes;
  for (const Route& r : RouteTable()) routes.push_back({r.method, r.openapi_path});
  return routes;
}

}  // namespace robocal::server
