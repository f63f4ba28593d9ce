// The calibration service: what every endpoint does, between a parsed request body and the storage, returning
// the typed wire shapes of api/ (the routes serialise them). Knows nothing of HTTP; errors are api::ApiError
// (or StorageError), mapped to HTTP statuses in one place (api::HttpStatusOf). Its parts live in one file per
// resource family: service_robots.cc, service_plans.cc, service_campaigns.cc, service_calibration.cc; long-running
// and deadline-bound work in OperationRunner.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/cells.h"
#include "robocal/api/drift.h"
#include "robocal/api/history.h"
#include "robocal/api/operations.h"
#include "robocal/api/plans.h"
#include "robocal/api/programs.h"
#include "robocal/api/robots.h"
#include "robocal/api/stored.h"
#include "robocal/api/tracker_files.h"
#include "robocal/core/robot_model.h"
#include "robocal/server/memory_trimmer.h"
#include "robocal/server/operation_runner.h"
#include "server/storage/storage.h"

namespace robocal::server {

struct ServiceOptions {
  api::Limits limits;
  /// Passed to Storage::AppendMeasurements.
  std::int64_t max_measurements_per_campaign = 100000;
  /// A synchronous plan or fit stops at this deadline with its best result so far (NO_CONVERGENCE, says so);
  /// longer searches belong in `async: true`.
  std::chrono::milliseconds request_deadline{60000};
  /// Operations (async plans and fits) running at once; more is UNAVAILABLE.
  int max_running_operations = 2;
  /// The lease of a running operation (OperationRunnerOptions::lease).
  std::chrono::milliseconds operation_lease{10000};
  /// Threads that solve the targets of one :compensate (0: as many as the hardware runs at once). The results
  /// do not depend on it.
  int compensation_threads = 0;
  /// For tests: called in every fit's progress callback (once per iteration) before the deadline and the
  /// cancel flag are checked, so that a test can hold a fit at a known point instead of racing it. Empty in
  /// the server.
  std::function<void()> on_fit_progress;
};

/// Who makes a request: the name of its bearer token (unset on a server without tokens). History entries record it.
struct Caller {
  std::optional<std::string> name;
};

/// A plan computed while the request waits, or (async) the operation computing it.
using PlanReply = std::variant<api::PlanResult, api::Operation>;
/// A fit computed while the request waits, or (async) the operation computing it.
using FitReply = std::variant<api::CalibrationResult, api::Operation>;

class Service {
 public:
  Service(Storage* storage, ServiceOptions options);
  /// Cancels running operations and waits for them.
  ~Service();

  /// Marks FAILED the operations no live instance runs (OperationRunner::Recover). Returns how many.
  int RecoverOperations() { return operations_.Recover(); }
  /// Renews this instance's operation leases and fails expired ones now (the runner does it every third of
  /// the lease); for tests.
  int KeepOperationLeases() { return operations_.KeepLeases(); }

  // Robots (service_robots.cc). page_size: "" (default 100) or 1..1000; page_token: "" or the next_page_token
  // of the previous page. Presets come first, then registered robots in id order.
  api::RobotList ListRobots(const std::string& page_size = "", const std::string& page_token = "");
  /// A robot registered from a calibration starts its history (service_history.cc) with `caller`.
  api::Robot CreateRobot(const nlohmann::json& body, const Caller& caller = {});
  api::Robot GetRobot(const std::string& id);
  void DeleteRobot(const std::string& id);
  api::ForwardResult RobotForward(const std::string& id, const nlohmann::json& body);
  // A robot's calibration history and drift checks (service_history.cc, docs/drift.md). Each :check, :calibrate and
  // :rollback is an entry of the history, by `caller`; nothing is ever removed.
  api::DriftCheckWire CheckRobot(const std::string& id, const nlohmann::json& body, const Caller& caller = {});
  api::RobotHistoryWire RobotHistory(const std::string& id);
  api::RobotHistoryWire CalibrateRobot(const std::string& id, const nlohmann::json& body, const Caller& caller = {});
  api::RobotHistoryWire RollbackRobot(const std::string& id, const nlohmann::json& body, const Caller& caller = {});

  // Cells (service_cells.cc): paged like robots. CheckCell takes {"joints": [[...]]} within the robot's limits.
  api::CellWire CreateCell(const nlohmann::json& body);
  api::CellList ListCells(const std::string& page_size = "", const std::string& page_token = "");
  api::CellWire GetCell(const std::string& id);
  void DeleteCell(const std::string& id);
  api::CellCheckResult CheckCell(const std::string& id, const nlohmann::json& body);

  // Plans (service_plans.cc).
  PlanReply CreatePlan(const nlohmann::json& body);
  api::PlanResult GetPlan(const std::string& id);

  // Campaigns and measurements (service_campaigns.cc). Campaigns are listed in id order, paged like robots.
  api::Campaign CreateCampaign(const nlohmann::json& body);
  api::CampaignList ListCampaigns(const std::string& page_size = "", const std::string& page_token = "");
  api::Campaign GetCampaign(const std::string& id);
  api::BatchResult AppendMeasurements(const std::string& campaign, const nlohmann::json& body);
  /// POST .../measurements:import: a tracker's point export (api/tracker_files.h) matched to a plan's
  /// configurations, stored as one batch of position measurements, or nothing when any line is bad.
  api::BatchResult ImportMeasurements(const std::string& campaign, const nlohmann::json& body);
  /// role: "" (all), calibration, validation; after: sequence to start after; limit: page size.
  api::MeasurementList ListMeasurements(const std::string& campaign, const std::string& role,
                                        const std::string& after, const std::string& limit);

  // Calibration (service_calibration.cc). The fit is stored as the campaign's calibration unless it stopped at
  // the request deadline (then returned with summary.deadline_exceeded and stored: false); or (async) an
  // operation whose result is the fit, stored when the operation SUCCEEDS.
  FitReply Fit(const std::string& campaign, const nlohmann::json& body);
  api::CalibrationResult GetCalibration(const std::string& campaign);
  /// The calibrated robot as a URDF document (docs/formats.md): the imported document with the errors folded
  /// in, or one generated from the model for a robot that came from a table.
  std::string CalibrationUrdf(const std::string& campaign);
  /// GET .../calibration?format=dh|mdh: the calibrated robot as a DH (standard or modified) table, a body that
  /// registers it (POST /v1/robots); FAILED_PRECONDITION naming the parameters where no DH table can hold it.
  api::RegisterRobotRequest CalibrationDh(const std::string& campaign, GeometryConvention convention);
  api::CompensatedTargets Compensate(const std::string& campaign, const nlohmann::json& body);
  /// A robot program in its controller's language, compensated (service_programs.cc, docs/programs.md).
  api::CompensateProgramResult CompensateProgram(const std::string& campaign, const nlohmann::json& body);
  api::ForwardResult CampaignForward(const std::string& campaign, const nlohmann::json& body);
  api::Evaluation Evaluate(const std::string& campaign, const nlohmann::json& body);
  /// The campaign report (service_report.cc, docs/report.md): one self-contained HTML page of the robot, the
  /// plan, the fit (its correlations and singular values as stored with it, per-pose residuals computed from the
  /// stored calibration and the measurements it used) and the validation. h_mm: absent (30) or E_tot's h as the query
  /// gave it (a decimal number in :evaluate's range). FAILED_PRECONDITION when the campaign is not calibrated.
  std::string CampaignReport(const std::string& campaign, const std::optional<std::string>& h_mm = std::nullopt);
  /// GET /v1/campaigns/{c}/iso9283 (service_iso9283.cc, docs/iso9283.md): the ISO 9283 pose characteristics of the
  /// campaign's test shots. FAILED_PRECONDITION without test shots, with a pose and cycle shot twice, or shots of
  /// poses the campaign's test plan does not have.
  api::Iso9283ReportWire Iso9283Report(const std::string& campaign);

  // Operations.
  api::Operation GetOperation(const std::string& id) { return operations_.Get(id); }
  api::Operation CancelOperation(const std::string& id) { return operations_.Cancel(id); }
  int running_operations() { return operations_.running(); }
  /// Returns once no operation runs on this instance (OperationRunner::WaitUntilIdle).
  void WaitForOperations() { operations_.WaitUntilIdle(); }

  /// The request limits the service enforces (the routes apply max_array_length while parsing bodies).
  const api::Limits& limits() const { return options_.limits; }
  /// For /healthz and metrics.
  Storage* storage() { return storage_; }

 private:
  /// A robot's model and definition (presets: {"id", "from_preset"}); NOT_FOUND for an unknown robot.
  struct ResolvedRobot {
    RobotModel model;
    api::RegisterRobotRequest definition;
  };
  ResolvedRobot ResolveRobot(const std::string& id);
  /// A registered robot's stored document, read (NOT_FOUND naming robot when there is none).
  std::pair<Document, api::StoredRobot> LoadRobotDocument(const std::string& id);
  api::StoredCampaign LoadCampaign(const std::string& id);
  // Reads a registered robot's document, lets `change` change it (its history completed for a robot stored before
  // histories were kept), and writes it back if no other request wrote it meanwhile (else again from the read).
  api::StoredRobot UpdateRobot(const std::string& id,
                               const std::function<void(const Document&, api::StoredRobot*)>& change);
  // POST /v1/robots with "from_calibration": the definition of the campaign's calibrated robot.
  api::RegisterRobotRequest DefinitionFromCalibration(const api::RobotFromCalibrationRequest& request);
  // An import of a file that carries its joints (no plan): ImportMeasurements' second way.
  api::BatchResult ImportMeasurementsWithJoints(const std::string& campaign_id, const api::StoredCampaign& campaign,
                                                const api::ImportMeasurementsRequest& request);
  // Stores a parsed batch in one transaction with each measurement's stale flag (FlagStaleShots): `stale` as given
  // (an import's, in its file's order), or against the shot stored last and then in the batch's order.
  // The test shots of a campaign made from an ISO 9283 test plan: each a visit the plan has (its cycle, its pose's
  // joint commands); INVALID_ARGUMENT naming the shots that are not.
  void CheckTestShots(const api::StoredCampaign& campaign, const api::MeasurementBatchRequest& req);
  api::BatchResult StoreBatch(const api::StoredCampaign& campaign, const RobotModel& model,
                              api::MeasurementBatchRequest request, std::optional<std::vector<char>> stale);
  // An import's measurements, one per point of its file in order: checked as an upload, flagged stale in the
  // file's order, and stored (only request.rows, if given).
  api::BatchResult StoreImported(const api::StoredCampaign& campaign, const api::ImportMeasurementsRequest& request,
                                 const std::vector<api::TrackerPoint>& points, api::MeasurementBatchRequest batch);
  /// A stored cell with the model of its robot's stored definition (NOT_FOUND for an unknown cell).
  struct LoadedCell {
    api::CellWire wire;
    RobotModel model;
    Cell cell;
    /// The copy of the robot's definition the cell was made for.
    api::RegisterRobotRequest robot_definition;
  };
  LoadedCell LoadCell(const std::string& id);
  /// The campaign resource of a stored campaign (counts and calibrated from the storage).
  api::Campaign CampaignResource(const api::StoredCampaign& stored);
  /// Computes a plan for `model` (the resolved request.robot) under `control`, feasible in `cell` if given.
  // What a plan is made from beside its request, resolved before any work starts: the candidates in core units
  // (null: none; with each one's file line for a tracker export), the task's joint vectors, and the robot's model
  // error from the calibration it was registered from (0 without one).
  struct PlanInputs {
    std::shared_ptr<const std::vector<Eigen::VectorXd>> candidates;
    std::vector<int> candidate_lines;
    std::shared_ptr<const std::vector<Eigen::VectorXd>> task;
    double model_error_mm = 0.0;
    double model_error_deg = 0.0;
  };
  PlanInputs ResolvePlanInputs(const api::PlanRequest& request, const ResolvedRobot& robot);
  api::PlanResult RunPlan(const RobotModel& model, const api::PlanRequest& request, const PlanInputs& inputs,
                          const std::string& plan_id, WorkControl& control, const LoadedCell* cell);
  /// A plan with "test" (service_iso9283.cc): the test's poses on `model` (feasible in `cell`), with the joint
  /// commands of the nominal robot or of the calibration of test.compensated_by.
  api::PlanResult RunTestPlan(const RobotModel& model, const api::PlanRequest& request, const std::string& plan_id,
                              const LoadedCell* cell);
  /// FAILED_PRECONDITION when a sample of the cell's joint ranges finds (almost) nothing feasible.
  void CheckCellLeavesRoom(const LoadedCell& cell, std::uint64_t seed);
  /// A campaign's nominal model and stored calibration (FAILED_PRECONDITION if not calibrated yet).
  struct Calibrated {
    api::StoredCampaign campaign;
    RobotModel model;
    Calibration calibration;
    /// The fit as returned and stored.
    api::CalibrationResult result;
    /// The last calibration measurement the fit saw (api::StoredCalibration); absent in older stored fits.
    std::optional<std::int64_t> last_calibration_sequence;
  };
  Calibrated LoadCalibrated(const std::string& campaign);
  /// The validation measurements against the nominal and the calibrated model (:evaluate's figures, with E_tot's
  /// h_mm); the per-pose values in `before` / `after` when given. FAILED_PRECONDITION without validation
  /// measurements.
  api::Evaluation EvaluateLoaded(const Calibrated& loaded, double h_mm, AccuracyReport* before = nullptr,
                                 AccuracyReport* after = nullptr);

  Storage* storage_;
  ServiceOptions options_;
  /// Returns the memory of large requests to the system after them.
  MemoryTrimmer trimmer_;
  OperationRunner operations_;
};

/// Milliseconds since the Unix epoch.
std::int64_t NowUnixMs();
/// A fresh identifier "<prefix>-<16 hex digits>".
std::string NewId(const std::string& prefix);

}  // namespace robocal::server
