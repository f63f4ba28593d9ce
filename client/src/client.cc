// robocal::Client over cpp-httplib: one place that sends a request, retries idempotent calls and turns
// non-2xx answers into ServiceError. The only translation unit of the client that includes httplib.
#include "robocal/client/client.h"

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
  return api::ToJson(r);
}

json JointsBody(const std::vector<std::vector<double>>& joints) { return {{"joints", joints}}; }

std::vector<api::PoseWire> Poses(const json& response) {
  std::vector<api::PoseWire> poses;
  for (const json& p : response.at("poses")) poses.push_back(ParsePoseResult(p));
  return poses;
}

// Runs a parser on a response; a response without the expected members is the server's fault, not the
// caller's, and is reported as such.
template <typename Parser>
auto Parse(const json& body, const char* what, Parser parser) -> decltype(parser(body)) {
  try {
    return parser(body);
  } catch (const json::exception& e) {
    throw ProtocolError(std::string("unexpected ") + what + " response: " + e.what());
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

std::string ErrorMessage(int http_status, const ErrorInfo& info) {
  std::string text = "HTTP " + std::to_string(http_status) + " " + info.status + ": " + info.message;
  for (const api::FieldViolation& d : info.details) text += "; " + d.field + ": " + d.reason;
  return text;
}

}  // namespace

ServiceError::ServiceError(int http_status, ErrorInfo info)
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
      ErrorInfo info;
      try {
        info = ParseErrorInfo(json::parse(response.body).at("error"));
      } catch (const json::exception&) {
        // Not the API's error body (a proxy in between, or not a robocal server).
        info.code = response.status;
        info.status = "HTTP_" + std::to_string(response.status);
        info.message = Snippet(response.body);
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

Health Client::GetHealth() {
  const json j = Call("GET", "/healthz", nullptr, true);
  return {j.value("status", ""), j.value("version", "")};
}

json Client::GetOpenApi() { return Call("GET", "/v1/openapi.json", nullptr, true); }

std::string Client::GetMetrics() {
  return Send(*impl_->http, impl_->base_url, options_, "GET", "/metrics", nullptr, true);
}

std::vector<json> Client::GetAllPages(const std::string& path, const std::string& key, int page_size) {
  if (page_size < 1 || page_size > 1000) {
    throw std::invalid_argument("page_size must be in 1..1000, got " + std::to_string(page_size));
  }
  std::vector<json> items;
  std::string token;
  do {
    std::string query = path + "?page_size=" + std::to_string(page_size);
    if (!token.empty()) query += "&page_token=" + Segment(token);
    const json page = Call("GET", query, nullptr, true);
    token = Parse(page, (key + " page").c_str(), [&](const json& b) {
      for (const json& item : b.at(key)) items.push_back(item);
      return b.contains("next_page_token") && b["next_page_token"].is_string()
                 ? b["next_page_token"].get<std::string>()
                 : std::string();
    });
  } while (!token.empty());
  return items;
}

std::vector<RobotInfo> Client::ListRobots(int page_size) {
  std::vector<RobotInfo> robots;
  for (const json& r : GetAllPages("/v1/robots", "robots", page_size)) {
    robots.push_back(Parse(r, "robot", ParseRobotInfo));
  }
  return robots;
}

RobotInfo Client::GetRobot(const std::string& robot) {
  return Parse(Call("GET", "/v1/robots/" + Segment(robot), nullptr, true), "robot", ParseRobotInfo);
}

RobotInfo Client::RegisterRobot(const api::RegisterRobotRequest& request) {
  return RegisterRobot(api::ToJson(request));
}

RobotInfo Client::RegisterRobot(const json& body) {
  return Parse(Call("POST", "/v1/robots", &body, false), "robot", ParseRobotInfo);
}

void Client::DeleteRobot(const std::string& robot) { Call("DELETE", "/v1/robots/" + Segment(robot), nullptr, false); }

std::vector<api::PoseWire> Client::RobotForward(const std::string& robot,
                                                const std::vector<std::vector<double>>& joints) {
  const json body = JointsBody(joints);
  // Forward kinematics changes nothing on the server: safe to retry.
  return Parse(Call("POST", "/v1/robots/" + Segment(robot) + ":forward", &body, true), "forward", Poses);
}

PlanResult Client::CreatePlan(const api::PlanRequest& request) {
  const json body = PlanBody(request, false);
  return Parse(Call("POST", "/v1/plans", &body, false), "plan", ParsePlanResult);
}

Operation Client::StartPlan(const api::PlanRequest& request) {
  const json body = PlanBody(request, true);
  return Parse(Call("POST", "/v1/plans", &body, false), "operation", ParseOperation);
}

PlanResult Client::GetPlan(const std::string& plan) {
  return Parse(Call("GET", "/v1/plans/" + Segment(plan), nullptr, true), "plan", ParsePlanResult);
}

Campaign Client::CreateCampaign(const api::CreateCampaignRequest& request) {
  const json body = api::ToJson(request);
  return Parse(Call("POST", "/v1/campaigns", &body, false), "campaign", ParseCampaign);
}

std::vector<Campaign> Client::ListCampaigns(int page_size) {
  std::vector<Campaign> campaigns;
  for (const json& c : GetAllPages("/v1/campaigns", "campaigns", page_size)) {
    campaigns.push_back(Parse(c, "campaign", ParseCampaign));
  }
  return campaigns;
}

Campaign Client::GetCampaign(const std::string& campaign) {
  return Parse(Call("GET", "/v1/campaigns/" + Segment(campaign), nullptr, true), "campaign", ParseCampaign);
}

std::string ContentRequestId(const api::MeasurementBatchRequest& batch) {
  api::MeasurementBatchRequest content = batch;
  content.request_id.clear();
  return "auto-" + api::ContentHash(api::ToJson(content).dump());
}

UploadResult Client::UploadMeasurements(const std::string& campaign, const api::MeasurementBatchRequest& batch) {
  api::MeasurementBatchRequest request = batch;
  if (request.request_id.empty()) request.request_id = ContentRequestId(batch);
  const json body = api::ToJson(request);
  // The request_id makes the upload idempotent on the server, so a retry after a lost answer stores it once.
  return Parse(Call("POST", "/v1/campaigns/" + Segment(campaign) + "/measurements", &body, true), "upload",
               ParseUploadResult);
}

MeasurementPage Client::ListMeasurements(const std::string& campaign, const std::string& role, std::int64_t after,
                                         int limit) {
  std::string path = "/v1/campaigns/" + Segment(campaign) + "/measurements?limit=" + std::to_string(limit);
  if (!role.empty()) path += "&role=" + Segment(role);
  if (after > 0) path += "&after=" + std::to_string(after);
  return Parse(Call("GET", path, nullptr, true), "measurement list", ParseMeasurementPage);
}

CalibrationResult Client::Fit(const std::string& campaign, const api::FitRequest& request) {
  json body = api::ToJson(request);
  body["async"] = false;
  return Parse(Call("POST", "/v1/campaigns/" + Segment(campaign) + ":fit", &body, false), "fit",
               ParseCalibrationResult);
}

Operation Client::StartFit(const std::string& campaign, const api::FitRequest& request) {
  json body = api::ToJson(request);
  body["async"] = true;
  return Parse(Call("POST", "/v1/campaigns/" + Segment(campaign) + ":fit", &body, false), "operation",
               ParseOperation);
}

CalibrationResult Client::GetCalibration(const std::string& campaign) {
  return Parse(Call("GET", "/v1/campaigns/" + Segment(campaign) + "/calibration", nullptr, true), "calibration",
               ParseCalibrationResult);
}

std::vector<Compensation> Client::Compensate(const std::string& campaign, const api::CompensateRequest& request) {
  const json body = api::ToJson(request);
  // Compensation is a pure computation on the stored calibration: safe to retry.
  const json j = Call("POST", "/v1/campaigns/" + Segment(campaign) + ":compensate", &body, true);
  return Parse(j, "compensation", [](const json& b) {
    std::vector<Compensation> results;
    for (const json& r : b.at("results")) results.push_back(ParseCompensation(r));
    return results;
  });
}

std::vector<Compensation> Client::CompensateJoints(const std::string& campaign,
                                                   const std::vector<std::vector<double>>& nominal_joints) {
  api::CompensateRequest request;
  for (const auto& q : nominal_joints) {
    api::CompensationTargetWire target;
    target.joints = q;
    request.targets.push_back(std::move(target));
  }
  return Compensate(campaign, request);
}

std::vector<api::PoseWire> Client::CampaignForward(const std::string& campaign,
                                                   const std::vector<std::vector<double>>& joints) {
  const json body = JointsBody(joints);
  return Parse(Call("POST", "/v1/campaigns/" + Segment(campaign) + ":forward", &body, true), "forward", Poses);
}

Evaluation Client::Evaluate(const std::string& campaign, const api::EvaluateRequest& request) {
  const json body = api::ToJson(request);
  return Parse(Call("POST", "/v1/campaigns/" + Segment(campaign) + ":evaluate", &body, true), "evaluation",
               ParseEvaluation);
}

Operation Client::GetOperation(const std::string& operation) {
  return Parse(Call("GET", "/v1/operations/" + Segment(operation), nullptr, true), "operation", ParseOperation);
}

Operation Client::CancelOperation(const std::string& operation) {
  const json body = json::object();
  // Cancelling twice is the same as cancelling once.
  return Parse(Call("POST", "/v1/operations/" + Segment(operation) + ":cancel", &body, true), "operation",
               ParseOperation);
}

Operation Client::WaitOperation(const std::string& operation, const OperationCallback& callback,
                                std::chrono::milliseconds poll_interval) {
  for (;;) {
    Operation op = GetOperation(operation);
    if (callback && !callback(op)) return op;
    if (op.done) return op;
    std::this_thread::sleep_for(poll_interval);
  }
}

}  // namespace robocal::client
