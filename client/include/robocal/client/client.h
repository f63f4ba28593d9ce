// robocal::Client: a thin C++ client over every endpoint of the robocal HTTP API (v1), for cell software.
// Requests are the wire types of api/types.h, results the typed views of results.h. cpp-httplib stays
// inside client.cc, so including this header pulls in no HTTP library.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "robocal/api/types.h"
#include "robocal/client/results.h"

namespace robocal::client {

struct ClientOptions {
  /// "http://host:port" or "https://host:port" (no path).
  std::string server_url = "http://127.0.0.1:8080";
  /// Sent as "Authorization: Bearer <token>" when not empty.
  std::string bearer_token;
  /// Time to establish a connection, and to wait for a response once the request is sent. A synchronous
  /// plan or a fit may take long; the server stops synchronous plans at its own request deadline (60 s by
  /// default), so the read timeout sits above that.
  std::chrono::milliseconds connect_timeout{5000};
  std::chrono::milliseconds read_timeout{120000};
  /// Retries of idempotent calls (GETs and measurement uploads, which carry a request_id) after a connection
  /// failure or a 408 / 502 / 503 / 504. Waits retry_backoff, 2 retry_backoff, 4 retry_backoff, ... between tries.
  /// Other calls (a POST that creates a plan or campaign, a fit) are never retried: repeating them could do
  /// the work twice.
  int max_retries = 3;
  std::chrono::milliseconds retry_backoff{200};
  /// https only: a PEM file of the certificate authorities to trust (e.g. the cell network's own CA, or a
  /// server's self-signed certificate itself). Empty: the system's CA store.
  std::string ca_cert_file;
  /// https only: check the server's certificate chain and host name. Setting this to false accepts ANY
  /// certificate, so anyone on the network path can impersonate the server and read the bearer token; it is
  /// meant for a first test against a lab server with a self-signed certificate. Prefer ca_cert_file.
  bool verify_tls = true;

  bool IsValid(std::string* error) const;
};

/// The service answered with an error (HTTP 4xx / 5xx): its HTTP status, canonical status string
/// ("INVALID_ARGUMENT", "NOT_FOUND", ...), message and per-field details.
class ServiceError : public std::runtime_error {
 public:
  ServiceError(int http_status, ErrorInfo info);
  int http_status() const { return http_status_; }
  const std::string& status() const { return info_.status; }
  const std::string& message() const { return info_.message; }
  const std::vector<api::FieldViolation>& details() const { return info_.details; }
  const ErrorInfo& info() const { return info_; }

 private:
  int http_status_;
  ErrorInfo info_;
};

/// The server could not be reached or the connection broke (after the retries allowed for the call).
class ConnectionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The server answered something that is not the API's JSON (another service on that port, or a server of an
/// incompatible version).
class ProtocolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Called while waiting for an operation, with its latest state. Return false to stop waiting.
using OperationCallback = std::function<bool(const Operation&)>;

/// One connection's worth of client. Not safe to use from several threads at once; make one per thread.
/// Every call throws ServiceError, ConnectionError or ProtocolError; std::invalid_argument for invalid
/// options.
class Client {
 public:
  explicit Client(ClientOptions options = {});
  ~Client();
  Client(Client&&) noexcept;
  Client& operator=(Client&&) noexcept;

  const ClientOptions& options() const { return options_; }

  // Service.
  Health GetHealth();
  /// The OpenAPI 3 document the server was built with.
  nlohmann::json GetOpenApi();
  /// Prometheus text.
  std::string GetMetrics();

  // Robots.
  /// Every preset and registered robot, following the server's pages (`page_size` per request, 1..1000).
  std::vector<RobotInfo> ListRobots(int page_size = 100);
  RobotInfo GetRobot(const std::string& robot);
  RobotInfo RegisterRobot(const api::RegisterRobotRequest& request);
  /// The body as read from a robot definition file (same fields as RegisterRobotRequest).
  RobotInfo RegisterRobot(const nlohmann::json& body);
  void DeleteRobot(const std::string& robot);
  /// Nominal tool poses (world = nominal base frame) for joint vectors (deg / mm).
  std::vector<api::PoseWire> RobotForward(const std::string& robot, const std::vector<std::vector<double>>& joints);

  // Plans.
  /// A plan computed while the call waits (request.async is ignored and sent as false).
  PlanResult CreatePlan(const api::PlanRequest& request);
  /// Starts the plan as a long-running operation (request.async is sent as true); see WaitOperation.
  Operation StartPlan(const api::PlanRequest& request);
  PlanResult GetPlan(const std::string& plan);

  // Campaigns.
  Campaign CreateCampaign(const api::CreateCampaignRequest& request);
  /// Every campaign, following the server's pages (`page_size` per request, 1..1000).
  std::vector<Campaign> ListCampaigns(int page_size = 100);
  Campaign GetCampaign(const std::string& campaign);
  /// Uploads one batch. An empty request_id is filled with one derived from the batch's content (role and
  /// measurements), so that a retried or repeated upload of the same batch is stored once.
  UploadResult UploadMeasurements(const std::string& campaign, const api::MeasurementBatchRequest& batch);
  /// One page; role "" (all), "calibration" or "validation"; after: the sequence to continue after.
  MeasurementPage ListMeasurements(const std::string& campaign, const std::string& role = "", std::int64_t after = 0,
                                   int limit = 1000);
  /// A fit computed while the call waits (request.async is ignored and sent as false); stored as the
  /// campaign's calibration unless it stopped at the server's request deadline (result.stored says).
  CalibrationResult Fit(const std::string& campaign, const api::FitRequest& request = {});
  /// Starts the fit as a long-running operation (request.async is sent as true); see WaitOperation. The
  /// calibration is stored when the operation SUCCEEDS; Operation::fit holds the result.
  Operation StartFit(const std::string& campaign, const api::FitRequest& request = {});
  CalibrationResult GetCalibration(const std::string& campaign);
  std::vector<Compensation> Compensate(const std::string& campaign, const api::CompensateRequest& request);
  /// Convenience: compensated joints for nominal joint commands (deg / mm).
  std::vector<Compensation> CompensateJoints(const std::string& campaign,
                                             const std::vector<std::vector<double>>& nominal_joints);
  /// Tool poses of the calibrated robot (tracker frame) for joint vectors.
  std::vector<api::PoseWire> CampaignForward(const std::string& campaign,
                                             const std::vector<std::vector<double>>& joints);
  Evaluation Evaluate(const std::string& campaign, const api::EvaluateRequest& request = {});

  // Operations.
  Operation GetOperation(const std::string& operation);
  Operation CancelOperation(const std::string& operation);
  /// Polls every `poll_interval` until the operation is done (or `callback` returns false); returns its last
  /// state. The callback sees every polled state, e.g. to draw progress.
  Operation WaitOperation(const std::string& operation, const OperationCallback& callback = nullptr,
                          std::chrono::milliseconds poll_interval = std::chrono::milliseconds(250));

  /// A raw call for endpoints or fields the typed API does not cover: returns the response JSON.
  /// `idempotent` allows retries.
  nlohmann::json Call(const std::string& method, const std::string& path, const nlohmann::json* body, bool idempotent);
  /// GETs `path` page by page (page_size, page_token) and returns the items of array `key` of every page.
  std::vector<nlohmann::json> GetAllPages(const std::string& path, const std::string& key, int page_size);

 private:
  struct Impl;
  ClientOptions options_;
  std::unique_ptr<Impl> impl_;
};

/// The request_id UploadMeasurements uses for a batch without one: "auto-" and a 64-bit hash of its content.
std::string ContentRequestId(const api::MeasurementBatchRequest& batch);

}  // namespace robocal::client

namespace robocal {
using Client = client::Client;
using ClientOptions = client::ClientOptions;
}  // namespace robocal
