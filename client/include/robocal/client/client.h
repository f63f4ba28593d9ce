// robocal::Client: a thin C++ client over every endpoint of the robocal HTTP API (v1), for cell software.
// Requests and results are the api's wire types (robocal/api/robots.h, plans.h, campaigns.h, calibration.h,
// operations.h, error.h, health.h): the server writes them and the client reads them with the same strict
// from_json, so a response missing a field is a ProtocolError naming it, never a silent default. cpp-httplib
// stays inside client.cc, so including this header pulls in no HTTP library.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/cells.h"
#include "robocal/api/error.h"
#include "robocal/api/health.h"
#include "robocal/api/history.h"
#include "robocal/api/operations.h"
#include "robocal/api/plans.h"
#include "robocal/api/programs.h"
#include "robocal/api/robots.h"
#include "robocal/api/tracker_files.h"

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

/// The service answered with an error (HTTP 4xx / 5xx): its HTTP status and the error body (canonical status,
/// message and per-field details). An answer that is not the API's error body (a proxy in between) gets the
/// status its HTTP code stands for (e.g. 503 kUnavailable, other codes kInternal) and the start of the body as
/// its message.
class ServiceError : public std::runtime_error {
 public:
  ServiceError(int http_status, api::ErrorInfo info);
  int http_status() const { return http_status_; }
  api::Status status() const { return info_.status; }
  const std::string& message() const { return info_.message; }
  const std::vector<api::FieldViolation>& details() const { return info_.details; }
  const api::ErrorInfo& info() const { return info_; }

 private:
  int http_status_;
  api::ErrorInfo info_;
};

/// The server could not be reached or the connection broke (after the retries allowed for the call).
class ConnectionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The server answered something that is not the API's JSON (another service on that port), or JSON without
/// the shape of the expected resource (a server of an incompatible version): what() names the response and
/// the field, e.g. "unexpected campaign response: counts.calibration: required".
class ProtocolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Called while waiting for an operation, with its latest state. Return false to stop waiting.
using OperationCallback = std::function<bool(const api::Operation&)>;

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
  api::Health GetHealth();
  /// The OpenAPI 3 document the server was built with.
  nlohmann::json GetOpenApi();
  /// Prometheus text.
  std::string GetMetrics();

  // Robots.
  /// Every preset and registered robot, following the server's pages (`page_size` per request, 1..1000).
  std::vector<api::Robot> ListRobots(int page_size = 100);
  api::Robot GetRobot(const std::string& robot);
  /// POST /v1/robots/{r}:check: a drift check of the calibration the robot carries (docs/drift.md). Not retried: each
  /// check is an entry of the robot's history.
  api::DriftCheckWire CheckRobot(const std::string& robot, const api::DriftCheckRequest& request);
  /// GET /v1/robots/{r}/calibrations, and the history after :calibrate (a campaign's calibration put on the robot)
  /// and :rollback (back to an earlier entry's); neither of those two is retried.
  api::RobotHistoryWire RobotHistory(const std::string& robot);
  api::RobotHistoryWire CalibrateRobot(const std::string& robot, const std::string& campaign,
                                       const std::string& note = "");
  api::RobotHistoryWire RollbackRobot(const std::string& robot, std::int64_t entry, const std::string& note = "");
  api::Robot RegisterRobot(const api::RegisterRobotRequest& request);
  /// The body as read from a robot definition file (same fields as RegisterRobotRequest).
  api::Robot RegisterRobot(const nlohmann::json& body);
  /// POST /v1/robots with "from_calibration": the campaign's calibrated robot as a robot of its own.
  api::Robot RegisterRobotFromCalibration(const api::RobotFromCalibrationRequest& request);
  /// POST /v1/robots with a URDF document: the chain base_link -> tip_link (docs/formats.md).
  api::Robot ImportRobot(const api::ImportUrdfRequest& request);
  void DeleteRobot(const std::string& robot);
  /// Nominal tool poses (frame "world (nominal base)") for joint vectors (deg / mm), one per vector in order,
  /// under `payload` (a robot holding compliances deflects under it; none if unset).
  api::ForwardResult RobotForward(const std::string& robot, const std::vector<std::vector<double>>& joints,
                                  const std::optional<api::PayloadWire>& payload = std::nullopt);

  // Cells.
  api::CellWire CreateCell(const api::CellWire& request);
  /// The body as read from a cell file (same fields as CellWire).
  api::CellWire CreateCell(const nlohmann::json& body);
  /// Every cell, following the server's pages (`page_size` per request, 1..1000).
  std::vector<api::CellWire> ListCells(int page_size = 100);
  api::CellWire GetCell(const std::string& cell);
  void DeleteCell(const std::string& cell);
  /// The feasibility report of each joint vector (deg / mm, within the robot's limits) in the cell; more than
  /// api::kMaxCheckConfigurations go in consecutive requests.
  api::CellCheckResult CheckCell(const std::string& cell, const std::vector<std::vector<double>>& joints);

  // Plans.
  /// A plan computed while the call waits (request.async is ignored and sent as false).
  api::PlanResult CreatePlan(const api::PlanRequest& request);
  /// Starts the plan as a long-running operation (request.async is sent as true); see WaitOperation.
  api::Operation StartPlan(const api::PlanRequest& request);
  api::PlanResult GetPlan(const std::string& plan);

  // Campaigns.
  api::Campaign CreateCampaign(const api::CreateCampaignRequest& request);
  /// Every campaign (with its measurement counts and whether it is calibrated), following the server's pages
  /// (`page_size` per request, 1..1000).
  std::vector<api::Campaign> ListCampaigns(int page_size = 100);
  api::Campaign GetCampaign(const std::string& campaign);
  /// Uploads one batch. An empty request_id is filled with one derived from the batch's content (role and
  /// measurements), so that a retried or repeated upload of the same batch is stored once.
  api::BatchResult UploadMeasurements(const std::string& campaign, const api::MeasurementBatchRequest& batch);
  /// A tracker's point export (Spatial Analyzer style or CSV; docs/formats.md) matched to a plan's configurations
  /// and stored as one batch (POST .../measurements:import). Without a request_id it is derived from the content,
  /// so a repeated import is stored once. ApiError names each bad line of the file; nothing is stored then.
  /// Throws std::invalid_argument naming the line when the text is not UTF-8 (nothing is sent).
  api::BatchResult ImportMeasurements(const std::string& campaign, const api::ImportMeasurementsRequest& request);
  /// One page of at most `limit` measurements; `role` unset: both roles; after: the sequence to continue after
  /// (the page's next_after).
  api::MeasurementList ListMeasurements(const std::string& campaign,
                                        std::optional<api::MeasurementRole> role = std::nullopt,
                                        std::int64_t after = 0, int limit = 1000);
  /// A fit computed while the call waits (request.async is ignored and sent as false); stored as the
  /// campaign's calibration unless it stopped at the server's request deadline (result.stored and
  /// result.summary.deadline_exceeded say).
  api::CalibrationResult Fit(const std::string& campaign, const api::FitRequest& request = {});
  /// Starts the fit as a long-running operation (request.async is sent as true); see WaitOperation. The
  /// calibration is stored when the operation SUCCEEDS; Operation::fit holds the result.
  api::Operation StartFit(const std::string& campaign, const api::FitRequest& request = {});
  api::CalibrationResult GetCalibration(const std::string& campaign);
  /// The calibrated robot as a URDF document (GET .../calibration?format=urdf; docs/formats.md).
  std::string GetCalibrationUrdf(const std::string& campaign);
  /// The calibrated robot as a standard or modified DH table (GET .../calibration?format=dh|mdh): a robot
  /// definition that RegisterRobot takes as it is. Throws ApiError (400, field format) where no DH table can
  /// hold the calibration.
  api::RegisterRobotRequest GetCalibrationDh(const std::string& campaign, GeometryConvention convention);
  /// The campaign report: one self-contained HTML page (GET .../report; docs/report.md). `h_mm`: E_tot's h in
  /// the validation table (unset: the server's default, 30 mm). ProtocolError if the reply is not an HTML page.
  std::string GetCampaignReport(const std::string& campaign, std::optional<double> h_mm = std::nullopt);
  /// One result per target, in order.
  api::CompensatedTargets Compensate(const std::string& campaign, const api::CompensateRequest& request);
  /// A robot program in its controller's language, compensated on the campaign's calibration (docs/programs.md):
  /// the files back with every target corrected, and a report per target. ApiError 400 naming file, line and
  /// column for a program the service cannot read; 400 FAILED_PRECONDITION naming the targets when
  /// on_failure is refuse and one fails.
  api::CompensateProgramResult CompensateProgram(const std::string& campaign,
                                                 const api::CompensateProgramRequest& request);
  /// Convenience: compensated joints for nominal joint commands (deg / mm).
  api::CompensatedTargets CompensateJoints(const std::string& campaign,
                                           const std::vector<std::vector<double>>& nominal_joints);
  /// Tool poses of the calibrated robot (frame "tracker") for joint vectors, under `payload` (unset: the
  /// campaign's, or none).
  api::ForwardResult CampaignForward(const std::string& campaign, const std::vector<std::vector<double>>& joints,
                                     const std::optional<api::PayloadWire>& payload = std::nullopt);
  api::Evaluation Evaluate(const std::string& campaign, const api::EvaluateRequest& request = {});
  /// GET /v1/campaigns/{c}/iso9283: the ISO 9283 pose characteristics of the campaign's test shots
  /// (docs/iso9283.md), as JSON or (Iso9283Csv) as the CSV table.
  api::Iso9283ReportWire Iso9283(const std::string& campaign);
  std::string Iso9283Csv(const std::string& campaign);

  // Operations.
  api::Operation GetOperation(const std::string& operation);
  api::Operation CancelOperation(const std::string& operation);
  /// Polls every `poll_interval` until the operation is done (or `callback` returns false); returns its last
  /// state. The callback sees every polled state, e.g. to draw progress.
  api::Operation WaitOperation(const std::string& operation, const OperationCallback& callback = nullptr,
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
