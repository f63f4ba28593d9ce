// Wire types of the robocal HTTP API (v1): requests as structs with validating parsers and serialisers, and
// the limits they are validated against. Wire units are mm and degrees (revolute joints in degrees, prismatic
// joints in mm); names carry their unit where a reader could guess wrong. Responses are built by convert.h.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/error.h"
#include "robocal/core/error_model.h"
#include "robocal/core/planning.h"
#include "robocal/core/robot_model.h"

namespace robocal::api {

/// Size and work limits applied while parsing, to each request's total before any work starts. The server
/// fills them from its configuration; each bounds what its comment says.
struct Limits {
  /// Joint vectors / targets / measurements in one request.
  std::size_t max_array_length = 10000;
  /// Configurations of one plan (M).
  int max_plan_configurations = 1000;
  /// Objective evaluations of one plan at most (PlanWork::evaluations: all restarts, and the exchange
  /// optimiser's screening of candidates).
  std::int64_t max_plan_evaluations = 1000000;
  /// Identification Jacobians of single configurations one plan computes at most (PlanWork::jacobians plus the
  /// predicted accuracy's 2 x num_validation): the time of M x evaluations.
  std::int64_t max_plan_jacobians = 10000000;
  /// The exchange optimiser's candidate pool (its memory: rows x L + joints doubles per candidate, at most
  /// 2.7 kB for 12 joints).
  int max_plan_candidates = 20000;
  /// Entries of a fit's Jacobian, rows per measurement x calibration measurements x parameters (the fit holds
  /// a few copies of it, 8 bytes an entry).
  std::int64_t max_fit_jacobian_entries = 2000000;
};

/// The reason given for a request value over one of the limits above: names the limit, so that a caller knows
/// what bounds the request and an operator what to raise. E.g. "16200000 Jacobian entries (...) exceed the
/// server's limit max_fit_jacobian_entries = 2000000".
std::string OverLimit(std::int64_t value, const std::string& what, const std::string& limit_name, std::int64_t limit);

/// Identifiers of robots, plans, campaigns, operations: [a-z0-9][a-z0-9_.-]{0,63}, so that they never
/// collide with the ':' of custom methods or with path separators.
bool IsValidId(const std::string& id);

/// A pose in the wire form {"position_mm":[x,y,z],"quaternion":[w,x,y,z]}. As input, "rpy_deg":[r,p,y]
/// (fixed-axis x-y-z, R = Rz(y) Ry(p) Rx(r)) may stand instead of "quaternion"; the quaternion is normalised
/// (and rejected if its norm is far from 1). Orientation may be omitted only where the context allows it
/// (position measurements); it is then the identity and has_orientation is false.
struct PoseWire {
  std::array<double, 3> position_mm{0.0, 0.0, 0.0};
  std::array<double, 4> quaternion{1.0, 0.0, 0.0, 0.0};
  bool has_orientation = true;
};
/// Parses a pose at `path`; false (with problems recorded) if invalid.
bool ParsePose(const nlohmann::json& value, const std::string& path, bool orientation_required,
               Problems* problems, PoseWire* out);
nlohmann::json ToJson(const PoseWire& pose);

/// One joint of a registered robot. Angles in degrees, lengths in mm. Limits are in the joint's unit:
/// "min_deg"/"max_deg" for a revolute joint, "min_mm"/"max_mm" for a prismatic one.
struct JointWire {
  std::string name;
  std::string type = "revolute";  // "revolute" | "prismatic"
  // dh / mdh row (mdh: alpha and a of the previous link, as in Craig's table).
  double a_mm = 0.0, alpha_deg = 0.0, d_mm = 0.0, theta_deg = 0.0;
  // transform: fixed transform from the previous joint frame.
  std::array<double, 3> xyz_mm{0.0, 0.0, 0.0};
  std::array<double, 3> rpy_deg{0.0, 0.0, 0.0};
  double min = 0.0, max = 0.0;
};

/// POST /v1/robots. Either a full table (convention + joints) or `from_preset` (a preset's geometry, with
/// base / tool optionally replaced).
struct RegisterRobotRequest {
  std::string id;
  std::string description;
  std::string from_preset;
  std::string convention = "dh";  // "dh" | "mdh" | "transform"
  std::vector<JointWire> joints;
  std::optional<PoseWire> base;  // tracker (world) -> robot base
  std::optional<PoseWire> tool;  // flange -> tool (measured point, z = tool axis)
};
RegisterRobotRequest ParseRegisterRobotRequest(const nlohmann::json& body, const Limits& limits);
nlohmann::json ToJson(const RegisterRobotRequest& request);
/// The core spec of a registered robot (throws ApiError kInvalidArgument naming the fields the core rejects).
RobotModelSpec ToSpec(const RegisterRobotRequest& request);

/// Tracker noise on the wire (1-sigma): position per axis (mm) and orientation (deg).
struct NoiseWire {
  double position_mm = 0.015;
  double orientation_deg = 0.0057295779513082;  // 1e-4 rad
};
MeasurementNoise ToCore(const NoiseWire& noise);

/// POST /v1/robots/{robot}:forward and /v1/campaigns/{c}:forward: {"joints": [[...], ...]}.
struct ForwardRequest {
  std::vector<std::vector<double>> joints;  // deg / mm per joint
};
/// Validates sizes and joint limits against `model`.
ForwardRequest ParseForwardRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits);
nlohmann::json ToJson(const ForwardRequest& request);

/// POST /v1/plans.
struct PlanRequest {
  std::string robot;
  int num_configurations = 10;
  std::string measurement_type = "pose";      // position | position_axis | pose
  std::string objective = "condition_number";  // condition_number | o1..o5 | log_det
  std::string optimiser = "solis_wets";       // solis_wets | random | exchange
  std::string scaling = "column_norm";        // column_norm | expected_deviation | none
  NoiseWire noise;
  std::uint64_t seed = 1;
  /// Optimiser options ("options" object); unset ones keep the core's defaults (the paper's for solis_wets).
  int k_max = 100, restarts = 0;                        // solis_wets
  double step_fraction = 0.1;                           // solis_wets
  int max_evaluations = 0;                              // solis_wets, exchange (0: no cap)
  int num_sets = 1;                                     // random
  int num_candidates = 2000, screen = 16, max_iterations = 200;  // exchange
  /// Random validation configurations for the predicted accuracy.
  int num_validation = 100;
  /// Run as a long-running operation.
  bool async = false;
};
/// Also refuses a request whose work (MaxWork) exceeds the limits, naming the fields that set it.
PlanRequest ParsePlanRequest(const nlohmann::json& body, const Limits& limits);
nlohmann::json ToJson(const PlanRequest& request);
/// The core options of the request's optimiser, objective and seed included (progress left empty).
SolisWetsOptions ToSolisWetsOptions(const PlanRequest& request);
RandomSelectionOptions ToRandomSelectionOptions(const PlanRequest& request);
ExchangeOptions ToExchangeOptions(const PlanRequest& request);
/// The most work the request can cause: its optimiser's (MaxPlanWork), and the Jacobians of the predicted
/// accuracy of the plan and of its random baseline (2 x num_validation).
PlanWork MaxWork(const PlanRequest& request);

/// POST /v1/campaigns.
struct CreateCampaignRequest {
  std::string id;  // optional: generated when empty
  std::string description;
  std::string robot;
  std::string measurement_type = "pose";
  std::string plan;  // optional plan id (its robot and measurement type must match)
  NoiseWire noise;
};
CreateCampaignRequest ParseCreateCampaignRequest(const nlohmann::json& body);
nlohmann::json ToJson(const CreateCampaignRequest& request);

/// One tracker shot on the wire: {"joints":[...], "pose":{...}} (joints deg / mm, pose in the tracker frame).
struct MeasurementWire {
  std::vector<double> joints;
  PoseWire pose;
};
nlohmann::json ToJson(const MeasurementWire& measurement);

/// POST /v1/campaigns/{c}/measurements.
struct MeasurementBatchRequest {
  std::string request_id;
  std::string role = "calibration";  // calibration | validation
  std::vector<MeasurementWire> measurements;
};
/// Validates sizes, finiteness and joint limits against `model`; orientation is required unless `type` is
/// position.
MeasurementBatchRequest ParseMeasurementBatchRequest(const nlohmann::json& body, const RobotModel& model,
                                                     MeasurementType type, const Limits& limits);
nlohmann::json ToJson(const MeasurementBatchRequest& request);
/// The content hash that makes measurement uploads idempotent: 16 hex digits of the 64-bit FNV-1a hash of
/// `text`. Client (a request_id derived from a batch) and server (a batch's content) share it so that both
/// agree on what "the same batch" means.
std::string ContentHash(const std::string& text);
/// Parses one stored measurement (as written by ToJson(MeasurementWire)).
MeasurementWire MeasurementFromJson(const nlohmann::json& value);

/// POST /v1/campaigns/{c}:fit.
struct FitRequest {
  /// Parameter names to estimate (e.g. "joint2.dz"); empty: the identifiable set.
  std::vector<std::string> parameters;
  bool register_base = true;
  int max_iterations = 100;
  /// Run as a long-running operation.
  bool async = false;
};
FitRequest ParseFitRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits);
nlohmann::json ToJson(const FitRequest& request);

/// One compensation target: nominal joints ("joints"), or a pose ("pose", with "frame" tracker | base and
/// optional "start_joints" for the solver).
struct CompensationTargetWire {
  std::vector<double> joints;
  std::optional<PoseWire> pose;
  std::string frame = "tracker";
  std::vector<double> start_joints;
};
/// POST /v1/campaigns/{c}:compensate.
struct CompensateRequest {
  std::vector<CompensationTargetWire> targets;
};
CompensateRequest ParseCompensateRequest(const nlohmann::json& body, const RobotModel& model,
                                         const Limits& limits);
nlohmann::json ToJson(const CompensateRequest& request);

/// POST /v1/campaigns/{c}:evaluate.
struct EvaluateRequest {
  /// E_tot = E_xyz + h E_cos (E_cos in rad), mm.
  double h_mm = 30.0;
};
EvaluateRequest ParseEvaluateRequest(const nlohmann::json& body);
nlohmann::json ToJson(const EvaluateRequest& request);

/// Joint values between the wire (deg / mm) and the core (rad / mm). Sizes must match the model.
Eigen::VectorXd JointsToCore(const RobotModel& model, const std::vector<double>& wire);
std::vector<double> JointsToWire(const RobotModel& model, const Eigen::VectorXd& q);

/// Checks a wire joint vector against the model (size, limits) and records violations at `path`.
bool CheckJoints(const RobotModel& model, const std::vector<double>& wire, const std::string& path,
                 Problems* problems);

}  // namespace robocal::api
