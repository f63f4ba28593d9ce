// Typed results of the robocal HTTP API (v1), as the client returns them. Requests reuse the wire types of
// api/types.h; responses are built by the server from api/convert.h and parsed back here. Units are the wire's:
// mm and degrees (revolute joints in degrees, prismatic joints in mm). Every result keeps the full response in
// `raw`, so that fields the typed view leaves out (and fields added by later servers) stay reachable.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "robocal/api/error.h"
#include "robocal/api/types.h"

namespace robocal::client {

/// A joint as the robot resource describes it; min / max in the joint's unit (deg or mm).
struct JointInfo {
  std::string name;
  std::string type;  // "revolute" | "prismatic"
  std::string unit;  // "deg" | "mm"
  double min = 0.0;
  double max = 0.0;
};

/// GET /v1/robots/{robot}.
struct RobotInfo {
  std::string id;
  bool preset = false;
  std::string description;
  std::string convention;
  std::vector<JointInfo> joints;
  api::PoseWire base;
  api::PoseWire tool;
  std::vector<std::string> error_parameters;
  nlohmann::json raw;
};

/// Observability indices of a configuration set (condition number and O1..O5; null on the wire -> NaN).
struct Indices {
  int num_configurations = 0;
  int num_parameters = 0;
  double condition_number = 0.0;
  double o1 = 0.0, o2 = 0.0, o3 = 0.0, o4 = 0.0, o5 = 0.0;
  double log_det = 0.0;
};

/// Predicted position / orientation accuracy of a plan on random validation configurations.
struct PredictedAccuracy {
  int num_validation = 0;
  double rms_position_mm = 0.0;
  double max_position_mm = 0.0;
  /// NaN for position-only measurements.
  double rms_orientation_deg = 0.0;
};

/// POST /v1/plans (synchronous) and GET /v1/plans/{plan}.
struct PlanResult {
  std::string id;
  std::string robot;
  std::string measurement_type;
  std::string objective;
  std::string optimiser;
  /// Per joint "deg" or "mm".
  std::vector<std::string> joint_units;
  /// M configurations, each a joint vector in joint_units.
  std::vector<std::vector<double>> configurations;
  Indices indices;
  /// The random baseline of the same size.
  Indices baseline_indices;
  PredictedAccuracy predicted_accuracy;
  PredictedAccuracy baseline_predicted_accuracy;
  std::vector<std::string> identifiable_parameters;
  std::string termination;
  std::string summary;
  nlohmann::json raw;
};

/// An error as it appears in an error body or in a failed operation.
struct ErrorInfo {
  int code = 0;
  std::string status;
  std::string message;
  std::vector<api::FieldViolation> details;
};


/// POST/GET /v1/campaigns.
struct Campaign {
  std::string id;
  std::string description;
  std::string robot;
  std::string measurement_type;
  std::string plan;  // empty if none
  api::NoiseWire noise;
  std::int64_t calibration_count = 0;
  std::int64_t validation_count = 0;
  bool calibrated = false;
  nlohmann::json raw;
};

/// POST /v1/campaigns/{c}/measurements.
struct UploadResult {
  std::string batch_id;
  std::string request_id;
  /// True if the server had this request_id with the same content already (nothing was written twice).
  bool replayed = false;
  std::int64_t first_sequence = 0;
  std::int64_t count = 0;
  std::int64_t campaign_total = 0;
  nlohmann::json raw;
};

/// One stored measurement of GET /v1/campaigns/{c}/measurements.
struct StoredMeasurement {
  std::int64_t sequence = 0;
  std::string batch_id;
  std::string role;
  api::MeasurementWire measurement;
};

struct MeasurementPage {
  std::vector<StoredMeasurement> measurements;
  /// Set when there may be more: pass it as `after` for the next page.
  std::optional<std::int64_t> next_after;
  nlohmann::json raw;
};

/// One identified parameter: value and standard deviation in `unit` (mm or deg).
struct ParameterEstimate {
  std::string name;
  std::string unit;
  double value = 0.0;
  double std = 0.0;
};

struct DroppedParameterInfo {
  std::string name;
  std::string reason;
};

/// Residuals of the calibration measurements against a model.
struct Residuals {
  int num_measurements = 0;
  double rms_position_mm = 0.0;
  double max_position_mm = 0.0;
  double rms_orientation_deg = 0.0;
  double max_orientation_deg = 0.0;
};

/// POST /v1/campaigns/{c}:fit and GET /v1/campaigns/{c}/calibration.
struct CalibrationResult {
  std::vector<ParameterEstimate> parameters;
  std::vector<DroppedParameterInfo> dropped;
  /// Calibrated tracker -> robot base (the frame of compensation targets with frame "base").
  api::PoseWire base;
  /// Calibrated flange -> tool.
  api::PoseWire tool;
  /// The base registration the fit started from (without the identified base errors).
  api::PoseWire registered_base;
  Residuals residuals_before;
  Residuals residuals_after;
  double condition_number = 0.0;
  std::string termination;
  std::string message;
  int iterations = 0;
  std::string brief;
  /// False if the fit stopped at the request deadline or was cancelled: returned, not stored.
  bool stored = true;
  /// The synchronous fit stopped at the server's request deadline (request_timeout_s).
  bool deadline_exceeded = false;
  nlohmann::json raw;
};

/// GET /v1/operations/{op}: long-running work (async plans and fits).
struct Operation {
  std::string id;
  std::string kind;
  /// RUNNING | SUCCEEDED | FAILED | CANCELLED.
  std::string state;
  bool done = false;
  /// 0..1.
  double progress = 0.0;
  /// Plans: the plan id once SUCCEEDED (or CANCELLED with a best-so-far plan).
  std::string plan;
  /// Fits: the fit once SUCCEEDED (stored as the calibration) or CANCELLED (best so far, not stored).
  std::optional<CalibrationResult> fit;
  std::optional<ErrorInfo> error;
  nlohmann::json raw;
};

/// One result of POST /v1/campaigns/{c}:compensate.
struct Compensation {
  /// The joints to command (deg / mm); empty if the solver produced none.
  std::vector<double> joints;
  double position_error_mm = 0.0;
  double orientation_error_deg = 0.0;
  double free_rotation_deg = 0.0;
  bool converged = false;
  int iterations = 0;
  std::string message;
};

/// mean, std, max and RP = mean + 3 std of one error (unit as named by the owning field).
struct Statistics {
  int count = 0;
  double mean = 0.0;
  double std = 0.0;
  double max = 0.0;
  double rp = 0.0;
};

/// The paper's three errors over the validation measurements.
struct Accuracy {
  double h_mm = 0.0;
  Statistics e_xyz_mm;
  Statistics e_cos_deg;
  Statistics e_tot_mm;
};

/// POST /v1/campaigns/{c}:evaluate.
struct Evaluation {
  int num_validation = 0;
  double h_mm = 0.0;
  Accuracy nominal;
  Accuracy calibrated;
  /// e.g. "e_xyz_mean" -> 87.5 (percent; NaN when undefined).
  std::map<std::string, double> improvement_percent;
  nlohmann::json raw;
};

/// GET /healthz.
struct Health {
  std::string status;
  std::string version;
};

// Parsers of response bodies. They throw nlohmann::json::exception on a body that lacks a required member (a
// server of another version); the client turns that into a ProtocolError.
api::PoseWire ParsePoseResult(const nlohmann::json& j);
RobotInfo ParseRobotInfo(const nlohmann::json& j);
Indices ParseIndices(const nlohmann::json& j);
PlanResult ParsePlanResult(const nlohmann::json& j);
ErrorInfo ParseErrorInfo(const nlohmann::json& j);
Operation ParseOperation(const nlohmann::json& j);
Campaign ParseCampaign(const nlohmann::json& j);
UploadResult ParseUploadResult(const nlohmann::json& j);
MeasurementPage ParseMeasurementPage(const nlohmann::json& j);
CalibrationResult ParseCalibrationResult(const nlohmann::json& j);
Compensation ParseCompensation(const nlohmann::json& j);
Evaluation ParseEvaluation(const nlohmann::json& j);

}  // namespace robocal::client
