// robocal::Client over cpp-httplib: one place that sends a request, retries idempotent calls and turns
// non-2xx answers into ServiceError. The only translation unit of the client that includes httplib.
#include "robocal/client/client.h"

#include "robocal/api/text.h"

#include <httplib.h>

#include <cstdio>
#include <fstream>
#include <thread>

namespace robocal::client {
namespace {

using nlohmann::json;

bool StartsWith(const std::string& text, const std::string& prefix) { return text.rfind(prefix, 0) == 0; }

// Identifiers are validated by the server; escaping here keeps a stray '/' or '?' in a caller's id from
// turning into another path.
std::string Segment(const std::string& id) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : id) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

// 408: the server did not receive the whole request in time (a slow link); the others: a gateway or a full
// server. Each is safe to repeat for an idempotent call.
bool Retryable(int status) { return status == 408 || status == 502 || status == 503 || status == 504; }

std::string Snippet(const std::string& body) {
  std::string s = body.substr(0, 200);
  for (char& c : s) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return s;
}

json PlanBody(const api::PlanRequest& request, bool async) {
  api::PlanRequest r = request;
  r.async = async;
  return r;
}

json FitBody(const api::FitRequest& request, bool async) {
  api::FitRequest r = request;
  r.async = async;
  return r;
}

json JointsBody(const std::vector<std::vector<double>>& joints) { return api::ForwardRequest{.joints = joints}; }

// A response read as the resource T, strictly: a response without the shape T requires is the server's fault
// (another version, or not robocal), not the caller's, and is reported as such, naming the field.
template <typename T>
T Parse(const json& body, const std::string& what) {
  try {
    return api::FromWire<T>(body);
  } catch (const api::WireError& e) {
    throw ProtocolError("unexpected " + what + " response: " + e.what());
  } catch (const json::exception& e) {
    throw ProtocolError("unexpected " + what + " response: " + e.what());
  }
}

// The status an HTTP code stands for, for an error answer that is not the API's error body (a proxy or a
// gateway in between): the inverse of api::HttpStatusOf where that is one status, else kInternal.
api::Status StatusOfHttp(int http_status) {
  switch (http_status) {
    case 400:
      return api::Status::kInvalidArgument;
    case 401:
      return api::Status::kUnauthenticated;
    case 403:
      return api::Status::kPermissionDenied;
    case 404:
      return api::Status::kNotFound;
    case 408:
      return api::Status::kDeadlineExceeded;
    case 409:
      return api::Status::kAlreadyExists;
    case 413:
    case 429:
      return api::Status::kResourceExhausted;
    case 502:
    case 503:
    case 504:
      return api::Status::kUnavailable;
    default:
      return api::Status::kInternal;
  }
}

}  // namespace

bool ClientOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  const bool http = StartsWith(server_url, "http://"), https = StartsWith(server_url, "https://");
  if (!http && !https) return fail("server_url must start with http:// or https:// (got \"" + server_url + "\")");
  const std::string rest = server_url.substr(http ? 7 : 8);
  if (rest.empty() || rest.front() == ':' || rest.front() == '/') return fail("server_url has no host");
  const auto slash = rest.find('/');
  if (slash != std::string::npos && slash + 1 != rest.size()) {
    return fail("server_url must not have a path (got \"" + server_url + "\")");
  }
  if (connect_timeout.count() <= 0 || read_timeout.count() <= 0) return fail("timeouts must be positive");
  if (max_retries < 0 || max_retries > 10) return fail("max_retries must be in [0, 10]");
  if (retry_backoff.count() < 0) return fail("retry_backoff must not be negative");
  if (bearer_token.find_first_of("\r\n") != std::string::npos) return fail("bearer_token has a line break");
  if (!ca_cert_file.empty() && !https) return fail("ca_cert_file is for https:// servers only");
  return true;
}

namespace {

std::string ErrorMessage(int http_status, const api::ErrorInfo& info) {
  std::string text = "HTTP " + std::to_string(http_status) + " " + api::WireName(info.status) + ": " + info.message;
  for (const api::FieldViolation& d : info.details) text += "; " + d.field + ": " + d.reason;
  return text;
}

}  // namespace

ServiceError::ServiceError(int http_status, api::ErrorInfo info)
    : std::runtime_error(ErrorMessage(http_status, info)), http_status_(http_status), info_(std::move(info)) {}

struct Client::Impl {
  std::unique_ptr<httplib::Client> http;
  std::string base_url;
};

Client::Client(ClientOptions options) : options_(std::move(options)), impl_(std::make_unique<Impl>()) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("invalid client options: " + error);
  impl_->base_url = options_.server_url;
  if (!impl_->base_url.empty() && impl_->base_url.back() == '/') impl_->base_url.pop_back();
  impl_->http = std::make_unique<httplib::Client>(impl_->base_url);
  if (!impl_->http->is_valid()) throw std::invalid_argument("invalid server_url \"" + options_.server_url + "\"");
  auto split = [](std::chrono::milliseconds ms) {
    return std::make_pair(static_cast<time_t>(ms.count() / 1000), static_cast<time_t>(ms.count() % 1000 * 1000));
  };
  const auto [connect_s, connect_us] = split(options_.connect_timeout);
  const auto [read_s, read_us] = split(options_.read_timeout);
  impl_->http->set_connection_timeout(connect_s, connect_us);
  impl_->http->set_read_timeout(read_s, read_us);
  impl_->http->set_write_timeout(read_s, read_us);
  impl_->http->set_keep_alive(true);
  if (!options_.bearer_token.empty()) impl_->http->set_bearer_token_auth(options_.bearer_token.c_str());
  impl_->http->enable_server_certificate_verification(options_.verify_tls);
  if (!options_.ca_cert_file.empty()) {
    // httplib reads the file only at the first handshake and then reports a bare SSL error: check it here.
    if (!std::ifstream(options_.ca_cert_file)) {
      throw std::invalid_argument("cannot read ca_cert_file " + options_.ca_cert_file);
    }
    impl_->http->set_ca_cert_path(options_.ca_cert_file.c_str());
  }
}

Client::~Client() = default;
Client::Client(Client&&) noexcept = default;
Client& Client::operator=(Client&&) noexcept = default;

namespace {

// Sends one request (retrying as allowed) and returns the 2xx body; throws for anything else.
std::string Send(httplib::Client& http, const std::string& base_url, const ClientOptions& options,
                 const std::string& method, const std::string& path, const json* body, bool idempotent) {
  const int attempts = idempotent ? 1 + options.max_retries : 1;
  const std::string text = body ? body->dump() : std::string();
  const httplib::Headers headers = {{"Accept", "application/json"}};
  for (int attempt = 0;; ++attempt) {
    httplib::Result result{nullptr, httplib::Error::Unknown};
    if (method == "GET") {
      result = http.Get(path, headers);
    } else if (method == "POST") {
      result = http.Post(path, headers, text, "application/json");
    } else if (method == "DELETE") {
      result = http.Delete(path, headers, text, body ? "application/json" : "");
    } else {
      throw std::invalid_argument("unsupported method " + method);
    }
    const bool last = attempt + 1 >= attempts;
    if (!result) {
      // A certificate the client does not trust stays untrusted: no point in retrying.
      const bool tls_trust =
          result.error() == httplib::Error::SSLServerVerification || result.error() == httplib::Error::SSLLoadingCerts;
      if (last || tls_trust) {
        throw ConnectionError("cannot reach " + base_url + " (" + method + " " + path +
                              "): " + httplib::to_string(result.error()) +
                              (tls_trust ? " (the server's certificate is not trusted: see ca_cert_file)" : ""));
      }
    } else if (!(Retryable(result->status) && !last)) {
      const httplib::Response& response = *result;
      if (response.status < 400) return response.body;
      api::ErrorInfo info;
      try {
        info = api::FromWire<api::ErrorInfo>(json::parse(response.body).at("error"));
      } catch (const std::exception&) {
        // Not the API's error body (a proxy in between, or not a robocal server).
        info.code = response.status;
        info.status = StatusOfHttp(response.status);
        info.message = "HTTP " + std::to_string(response.status) + " without the API's error body: " +
                       Snippet(response.body);
      }
      throw ServiceError(response.status, std::move(info));
    }
    // A connection failure or a 502/503/504 on an idempotent call: wait and try again.
    std::this_thread::sleep_for(options.retry_backoff * (1 << attempt));
  }
}

}  // namespace

json Client::Call(const std::string& method, const std::string& path, const json* body, bool idempotent) {
  const std::string text = Send(*impl_->http, impl_->base_url, options_, method, path, body, idempotent);
  if (text.empty()) return json::object();
  try {
    return json::parse(text);
  } catch (const json::exception&) {
    throw ProtocolError("not JSON from " + impl_->base_url + path + ": " + Snippet(text));
  }
}

api::Health Client::GetHealth() { return Parse<api::Health>(Call("GET", "/healthz", nullptr, true), "health"); }

json Client::GetOpenApi() { return Call("GET", "/v1/openapi.json", nullptr, true); }

std::string Client::GetMetrics() {
  return Send(*impl_->http, impl_->base_url, options_, "GET", "/metrics", nullptr, true);
}

namespace {

void CheckPageSize(int page_size) {
  if (page_size < 1 || page_size > 1000) {
    throw std::invalid_argument("page_size must be in 1..1000, got " + std::to_string(page_size));
  }
}

std::string PageQuery(const std::string& path, int page_size, const std::string& token) {
  std::string query = path + "?page_size=" + std::to_string(page_size);
  if (!token.empty()) query += "&page_token=" + Segment(token);
  return query;
}

// Every item of a paged list (RobotList, CampaignList: `items` and next_page_token), page by page.
template <typename List, typename Item>
std::vector<Item> AllPages(Client& client, const std::string& path, const std::string& what, int page_size,
                           std::vector<Item> List::*items) {
  CheckPageSize(page_size);
  std::vector<Item> all;
  std::string token;
  do {
    List page = Parse<List>(client.Call("GET", PageQuery(path, page_size, token), nullptr, true), what);
    for (Item& item : page.*items) all.push_back(std::move(item));
    token = page.next_page_token.value_or("");
  } while (!token.empty());
  return all;
}

}  // namespace

std::vector<json> Client::GetAllPages(const std::string& path, const std::string& key, int page_size) {
  CheckPageSize(page_size);
  std::vector<json> items;
  std::string token;
  do {
    const json page = Call("GET", PageQuery(path, page_size, token), nullptr, true);
    std::vector<json> list;
    std::optional<std::string> next;
    try {
      const api::WireReader reader(page);
      reader.Required(key.c_str(), &list);
      reader.Optional("next_page_token", &next);
    } catch (const api::WireError& e) {
      throw ProtocolError("unexpected " + key + " page: " + e.what());
    }
    items.insert(items.end(), list.begin(), list.end());
    token = next.value_or("");
  } while (!token.empty());
  return items;
}

std::vector<api::Robot> Client::ListRobots(int page_size) {
  return AllPages(*this, "/v1/robots", "robot list", page_size, &api::RobotList::robots);
}

api::Robot Client::GetRobot(const std::string& robot) {
  return Parse<api::Robot>(Call("GET", "/v1/robots/" + Segment(robot), nullptr, true), "robot");
}

api::Robot Client::RegisterRobot(const api::RegisterRobotRequest& request) { return RegisterRobot(json(request)); }

api::Robot Client::RegisterRobot(const json& body) {
  return Parse<api::Robot>(Call("POST", "/v1/robots", &body, false), "robot");
}

api::Robot Client::ImportRobot(const api::ImportUrdfRequest& request) { return RegisterRobot(json(request)); }

api::Robot Client::RegisterRobotFromCalibration(const api::RobotFromCalibrationRequest& request) {
  return RegisterRobot(json(request));
}

void Client::DeleteRobot(const std::string& robot) { Call("DELETE", "/v1/robots/" + Segment(robot), nullptr, false); }

api::CellWire Client::CreateCell(const api::CellWire& request) { return CreateCell(json(request)); }

api::CellWire Client::CreateCell(const json& body) {
  return Parse<api::CellWire>(Call("POST", "/v1/cells", &body, false), "cell");
}

std::vector<api::CellWire> Client::ListCells(int page_size) {
  return AllPages(*this, "/v1/cells", "cell list", page_size, &api::CellList::cells);
}

api::CellWire Client::GetCell(const std::string& cell) {
  return Parse<api::CellWire>(Call("GET", "/v1/cells/" + Segment(cell), nullptr, true), "cell");
}

void Client::DeleteCell(const std::string& cell) { Call("DELETE", "/v1/cells/" + Segment(cell), nullptr, false); }

api::CellCheckResult Client::CheckCell(const std::string& cell, const std::vector<std::vector<double>>& joints) {
  // The server checks at most kMaxCheckConfigurations per request: longer lists go in consecutive requests,
  // their results concatenated in order. A check changes nothing on the server: safe to retry.
  api::CellCheckResult result;
  result.cell = cell;
  std::size_t first = 0;
  do {
    const std::size_t count = std::min(api::kMaxCheckConfigurations, joints.size() - first);
    const json body = JointsBody({joints.begin() + static_cast<long>(first),
                                  joints.begin() + static_cast<long>(first + count)});
    api::CellCheckResult part = Parse<api::CellCheckResult>(
        Call("POST", "/v1/cells/" + Segment(cell) + ":check", &body, true), "cell check");
    result.cell = part.cell;
    for (api::ConfigurationCheckWire& c : part.results) result.results.push_back(std::move(c));
    first += count;
  } while (first < joints.size());
  return result;
}

api::DriftCheckWire Client::CheckRobot(const std::string& robot, const api::DriftCheckRequest& request) {
  const json body = request;
  return Parse<api::DriftCheckWire>(Call("POST", "/v1/robots/" + Segment(robot) + ":check", &body, false), "check");
}

api::RobotHistoryWire Client::RobotHistory(const std::string& robot) {
  return Parse<api::RobotHistoryWire>(Call("GET", "/v1/robots/" + Segment(robot) + "/calibrations", nullptr, true),
                                      "robot history");
}

api::RobotHistoryWire Client::CalibrateRobot(const std::string& robot, const std::string& campaign,
                                             const std::string& note) {
  const json body = api::CalibrateRobotRequest{campaign, note};
  return Parse<api::RobotHistoryWire>(Call("POST", "/v1/robots/" + Segment(robot) + ":calibrate", &body, false),
                                      "robot history");
}

api::RobotHistoryWire Client::RollbackRobot(const std::string& robot, std::int64_t entry, const std::string& note) {
  const json body = api::RollbackRequest{entry, note};
  return Parse<api::RobotHistoryWire>(Call("POST", "/v1/robots/" + Segment(robot) + ":rollback", &body, false),
                                      "robot history");
}

api::ForwardResult Client::RobotForward(const std::string& robot, const std::vector<std::vector<double>>& joints,
                                        const std::optional<api::PayloadWire>& payload) {
  const json body = api::ForwardRequest{joints, payload};
  // Forward kinematics changes nothing on the server: safe to retry.
  return Parse<api::ForwardResult>(Call("POST", "/v1/robots/" + Segment(robot) + ":forward", &body, true),
                                   "forward");
}

api::PlanResult Client::CreatePlan(const api::PlanRequest& request) {
  const json body = PlanBody(request, false);
  return Parse<api::PlanResult>(Call("POST", "/v1/plans", &body, false), "plan");
}

api::Operation Client::StartPlan(const api::PlanRequest& request) {
  const json body = PlanBody(request, true);
  return Parse<api::Operation>(Call("POST", "/v1/plans", &body, false), "operation");
}

api::PlanResult Client::GetPlan(const std::string& plan) {
  return Parse<api::PlanResult>(Call("GET", "/v1/plans/" + Segment(plan), nullptr, true), "plan");
}

api::Campaign Client::CreateCampaign(const api::CreateCampaignRequest& request) {
  const json body = request;
  return Parse<api::Campaign>(Call("POST", "/v1/campaigns", &body, false), "campaign");
}

std::vector<api::Campaign> Client::ListCampaigns(int page_size) {
  return AllPages(*this, "/v1/campaigns", "campaign list", page_size, &api::CampaignList::campaigns);
}

api::Campaign Client::GetCampaign(const std::string& campaign) {
  return Parse<api::Campaign>(Call("GET", "/v1/campaigns/" + Segment(campaign), nullptr, true), "campaign");
}

std::string ContentRequestId(const api::MeasurementBatchRequest& batch) {
  api::MeasurementBatchRequest content = batch;
  content.request_id.clear();
  return "auto-" + api::ContentHash(json(content).dump());
}

api::BatchResult Client::UploadMeasurements(const std::string& campaign, const api::MeasurementBatchRequest& batch) {
  api::MeasurementBatchRequest request = batch;
  if (request.request_id.empty()) request.request_id = ContentRequestId(batch);
  const json body = request;
  // The request_id makes the upload idempotent on the server, so a retry after a lost answer stores it once.
  return Parse<api::BatchResult>(
      Call("POST", "/v1/campaigns/" + Segment(campaign) + "/measurements", &body, true), "upload");
}

api::BatchResult Client::ImportMeasurements(const std::string& campaign, const api::ImportMeasurementsRequest& request) {
  // JSON carries UTF-8 only: an export saved in another encoding (Windows-1252 names) is named by its line.
  if (!api::IsValidUtf8(request.text)) {
    std::size_t start = 0;
    for (int line = 1;; ++line) {
      const std::size_t end = request.text.find('\n', start);
      if (!api::IsValidUtf8(std::string_view(request.text).substr(start, end == std::string::npos ? end : end - start))) {
        throw std::invalid_argument("line " + std::to_string(line) + " is not UTF-8 text (save the export as UTF-8)");
      }
      if (end == std::string::npos) break;
      start = end + 1;
    }
  }
  api::ImportMeasurementsRequest content = request;
  content.request_id.clear();
  json body = request;
  if (request.request_id.empty()) body["request_id"] = "auto-" + api::ContentHash(json(content).dump());
  return Parse<api::BatchResult>(
      Call("POST", "/v1/campaigns/" + Segment(campaign) + "/measurements:import", &body, true), "import");
}

api::MeasurementList Client::ListMeasurements(const std::string& campaign, std::optional<api::MeasurementRole> role,
                                              std::int64_t after, int limit) {
  std::string path = "/v1/campaigns/" + Segment(campaign) + "/measurements?limit=" + std::to_string(limit);
  if (role) path += std::string("&role=") + api::WireName(*role);
  if (after > 0) path += "&after=" + std::to_string(after);
  return Parse<api::MeasurementList>(Call("GET", path, nullptr, true), "measurement list");
}

api::CalibrationResult Client::Fit(const std::string& campaign, const api::FitRequest& request) {
  const json body = FitBody(request, false);
  return Parse<api::CalibrationResult>(Call("POST", "/v1/campaigns/" + Segment(campaign) + ":fit", &body, false),
                                       "fit");
}

api::Operation Client::StartFit(const std::string& campaign, const api::FitRequest& request) {
  const json body = FitBody(request, true);
  return Parse<api::Operation>(Call("POST", "/v1/campaigns/" + Segment(campaign) + ":fit", &body, false),
                               "operation");
}

std::string Client::GetCalibrationUrdf(const std::string& campaign) {
  return Send(*impl_->http, impl_->base_url, options_, "GET",
              "/v1/campaigns/" + Segment(campaign) + "/calibration?format=urdf", nullptr, true);
}

api::RegisterRobotRequest Client::GetCalibrationDh(const std::string& campaign, GeometryConvention convention) {
  return Parse<api::RegisterRobotRequest>(Call("GET",
                                               "/v1/campaigns/" + Segment(campaign) +
                                                   "/calibration?format=" + ToString(convention),
                                               nullptr, true),
                                          "robot definition");
}

std::string Client::GetCampaignReport(const std::string& campaign, std::optional<double> h_mm) {
  std::string path = "/v1/campaigns/" + Segment(campaign) + "/report";
  if (h_mm) {
    char number[64];
    std::snprintf(number, sizeof(number), "%.17g", *h_mm);
    path += "?h_mm=" + std::string(number);
  }
  std::string page = Send(*impl_->http, impl_->base_url, options_, "GET", path, nullptr, true);
  if (page.rfind("<!DOCTYPE html>", 0) != 0) {
    throw ProtocolError("not an HTML page from " + impl_->base_url + path + ": " + Snippet(page));
  }
  return page;
}

api::CalibrationResult Client::GetCalibration(const std::string& campaign) {
  return Parse<api::CalibrationResult>(
      Call("GET", "/v1/campaigns/" + Segment(campaign) + "/calibration", nullptr, true), "calibration");
}

api::CompensatedTargets Client::Compensate(const std::string& campaign, const api::CompensateRequest& request) {
  const json body = request;
  // Compensation is a pure computation on the stored calibration: safe to retry.
  return Parse<api::CompensatedTargets>(Call("POST", "/v1/campaigns/" + Segment(campaign) + ":compensate", &body, true),
                                        "compensation");
}

api::CompensateProgramResult Client::CompensateProgram(const std::string& campaign,
                                                       const api::CompensateProgramRequest& request) {
  const json body = request;
  // A pure computation on the stored calibration, as :compensate: safe to retry.
  return Parse<api::CompensateProgramResult>(
      Call("POST", "/v1/campaigns/" + Segment(campaign) + ":compensate-program", &body, true), "program compensation");
}

api::CompensatedTargets Client::CompensateJoints(const std::string& campaign,
                                                 const std::vector<std::vector<double>>& nominal_joints) {
  api::CompensateRequest request;
  for (const auto& q : nominal_joints) {
    api::CompensationTargetWire target;
    target.joints = q;
    request.targets.push_back(std::move(target));
  }
  return Compensate(campaign, request);
}

api::ForwardResult Client::CampaignForward(const std::string& campaign, const std::vector<std::vector<double>>& joints,
                                           const std::optional<api::PayloadWire>& payload) {
  const json body = api::ForwardRequest{joints, payload};
  return Parse<api::ForwardResult>(Call("POST", "/v1/campaigns/" + Segment(campaign) + ":forward", &body, true),
                                   "forward");
}

api::Evaluation Client::Evaluate(const std::string& campaign, const api::EvaluateRequest& request) {
  const json body = request;
  return Parse<api::Evaluation>(Call("POST", "/v1/campaigns/" + Segment(campaign) + ":evaluate", &body, true),
                                "evaluation");
}

api::Iso9283ReportWire Client::Iso9283(const std::string& campaign) {
  return Parse<api::Iso9283ReportWire>(Call("GET", "/v1/campaigns/" + Segment(campaign) + "/iso9283", nullptr, true),
                                       "ISO 9283 report");
}

std::string Client::Iso9283Csv(const std::string& campaign) {
  const std::string path = "/v1/campaigns/" + Segment(campaign) + "/iso9283?format=csv";
  std::string csv = Send(*impl_->http, impl_->base_url, options_, "GET", path, nullptr, true);
  if (csv.rfind("set,pose,cycles,", 0) != 0) {
    throw ProtocolError("not the ISO 9283 CSV from " + impl_->base_url + path + ": " + Snippet(csv));
  }
  return csv;
}

api::Operation Client::GetOperation(const std::string& operation) {
  return Parse<api::Operation>(Call("GET", "/v1/operations/" + Segment(operation), nullptr, true), "operation");
}

api::Operation Client::CancelOperation(const std::string& operation) {
  const json body = json::object();
  // Cancelling twice is the same as cancelling once.
  return Parse<api::Operation>(Call("POST", "/v1/operations/" + Segment(operation) + ":cancel", &body, true),
                               "operation");
}

api::Operation Client::WaitOperation(const std::string& operation, const OperationCallback& callback,
                                     std::chrono::milliseconds poll_interval) {
  for (;;) {
    api::Operation op = GetOperation(operation);
    if (callback && !callback(op)) return op;
    if (op.done) return op;
    std::this_thread::sleep_for(poll_interval);
  }
}

}  // namespace robocal::client
