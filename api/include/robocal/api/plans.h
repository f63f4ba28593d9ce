// Wire shapes of plans: the plan request and its mapping to the core's optimiser options, and the plan resource
// (configurations, observability indices, predicted accuracy, the random baseline, the search's summary).
#pragma once

#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "robocal/api/campaigns.h"
#include "robocal/api/cells.h"
#include "robocal/api/iso9283.h"
#include "robocal/api/tracker_files.h"
#include "robocal/api/wire.h"
#include "robocal/core/candidates.h"
#include "robocal/core/planning.h"

namespace robocal::api {

/// POST /v1/plans.
/// Nests a plan may name: a tool carries two to four (each adds 3 rows per configuration to the planners' work
/// and the exchange pool's memory).
inline constexpr int kMaxPlanReflectors = 4;

/// A plan request's "options": the optimiser's; unset ones keep the core's defaults (the paper's for solis_wets).
struct PlanOptionsWire {
  int k_max = 100, restarts = 0;                                 // solis_wets
  double step_fraction = 0.1;                                    // solis_wets
  int max_evaluations = 0;                                       // solis_wets, exchange (0: no cap)
  int num_sets = 1;                                              // random
  int num_candidates = 2000, screen = 16, max_iterations = 200;  // exchange
};
template <>
struct WireFields<PlanOptionsWire> {
  using S = PlanOptionsWire;
  // Each option within the core's own range; what they add up to is checked against the server's limits.
  static constexpr auto fields = std::make_tuple(
      Field{"k_max", &S::k_max}.Range(1, 1e7), Field{"restarts", &S::restarts}.Range(0, 1e4),
      Field{"max_evaluations", &S::max_evaluations}.Range(0, std::numeric_limits<int>::max()),
      Field{"step_fraction", &S::step_fraction}.Range(1e-6, 1.0), Field{"num_sets", &S::num_sets}.Range(1, 1e7),
      Field{"num_candidates", &S::num_candidates}.Range(1, 1e6), Field{"screen", &S::screen}.Range(1, 1e6),
      Field{"max_iterations", &S::max_iterations}.Range(1, 1e7));
};
ROBOCAL_WIRE_DECLARE(PlanOptionsWire);

/// A plan's "candidates": the cell's own configurations, of which the plan picks N (docs/planning.md, "Plans from
/// the cell's own configurations"). Exactly one source: joint vectors (deg / mm; a request may give the list
/// itself as "candidates"), the joints of a campaign's measurements (each pose once), or a tracker export with
/// joint columns, read as measurements:import reads it (rows with equal joints are one pose).
struct PlanCandidatesWire {
  std::vector<std::vector<double>> joints;
  std::string campaign;
  /// An import request's members (format "csv" with "joints"; request_id and role are not needed).
  std::optional<ImportMeasurementsRequest> file;
  /// A candidate with the wrong joint count, a non-finite value or one beyond the limits: "refuse" the request
  /// (400 naming it) or "reject" it (counted with its reason, as the cell's rejections are).
  MalformedCandidates malformed = MalformedCandidates::kThrow;
};
template <>
struct WireFields<PlanCandidatesWire> {
  using S = PlanCandidatesWire;
  static constexpr auto fields = std::make_tuple(
      // Joint vectors and the file are read by ParsePlanRequest (a list, or an import request's members).
      Field{"joints", &S::joints, Presence::kOmitEmpty}.Apart().Size(1, 0),
      Field{"campaign", &S::campaign, Presence::kOmitEmpty}.Size(0, 64).Rule(&IsValidId, kIdRule),
      Field{"file", &S::file, Presence::kOmitEmpty}.Apart(), Field{"malformed", &S::malformed});
};
ROBOCAL_WIRE_DECLARE(PlanCandidatesWire);

/// A task box: the tool point in an axis-aligned box of the robot's base frame (mm), in one of the given
/// orientations of the tool (fixed-axis roll, pitch, yaw in degrees, R = Rz(y) Ry(p) Rx(r), base frame; none: any
/// orientation), `count` configurations drawn from it (seeded by the plan's seed).
struct TaskBoxWire {
  std::array<double, 3> min_mm{0.0, 0.0, 0.0};
  std::array<double, 3> max_mm{0.0, 0.0, 0.0};
  std::vector<std::array<double, 3>> orientations_rpy_deg;
  int count = 50;
};
template <>
struct WireFields<TaskBoxWire> {
  using S = TaskBoxWire;
  static constexpr auto fields = std::make_tuple(
      Field{"min_mm", &S::min_mm}.Mandatory().Range(-kMaxLengthMm, kMaxLengthMm),
      Field{"max_mm", &S::max_mm}.Mandatory().Range(-kMaxLengthMm, kMaxLengthMm),
      Field{"orientations_rpy_deg", &S::orientations_rpy_deg, Presence::kOmitEmpty}.Size(0, 100).Range(-360.0, 360.0),
      Field{"count", &S::count}.Range(1, 10000));
  /// min_mm <= max_mm per axis.
  static void CheckRequest(const S& box, const std::string& path, Problems* problems);
};
ROBOCAL_WIRE_DECLARE(TaskBoxWire);

/// The poses the robot will work in, for the predicted_error objective and the predicted accuracy: joint
/// vectors (deg / mm), or a box in the base frame with orientations.
struct PlanTaskWire {
  std::vector<std::vector<double>> joints;
  std::optional<TaskBoxWire> box;
};
template <>
struct WireFields<PlanTaskWire> {
  using S = PlanTaskWire;
  static constexpr auto fields =
      std::make_tuple(Field{"joints", &S::joints, Presence::kOmitEmpty}.Apart().Size(1, 10000),
                      Field{"box", &S::box, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(PlanTaskWire);

/// What a plan is for: a calibration (the default), or a drift check of a calibrated robot (POST /v1/robots/{r}:check):
/// 8 to 15 well-spread poses (log_det unless an objective is given).
enum class PlanPurpose { kCalibration, kCheck };
template <>
struct EnumTable<PlanPurpose> {
  static constexpr std::array<PlanPurpose, 2> values = {PlanPurpose::kCalibration, PlanPurpose::kCheck};
  static const char* Name(PlanPurpose value);
};
/// The poses a check plan may have.
inline constexpr int kMinCheckPoses = 8;
inline constexpr int kMaxCheckPoses = 15;

struct PlanRequest {
  std::string robot;
  /// A cell of the robot: every configuration (and the random baseline's) is then feasible in it. Empty: none.
  std::string cell;
  /// On the wire a number, or "auto" (num_configurations_auto): the smallest N in [min_configurations,
  /// max_configurations] whose predicted error on the task reaches accuracy_goal_mm.
  int num_configurations = 10;
  bool num_configurations_auto = false;
  int min_configurations = 6;
  int max_configurations = 60;
  std::optional<double> accuracy_goal_mm;
  MeasurementType measurement_type = MeasurementType::kPose;
  /// Unset: condition_number (the paper's) for a drawn plan; for a plan from candidates log_det, or
  /// predicted_error with a task (PlanObjective).
  std::optional<ObservabilityIndex> objective;
  Optimiser optimiser = Optimiser::kSolisWets;
  ColumnScaling scaling = ColumnScaling::kColumnNorm;
  NoiseWire noise;
  /// The tracker's uncertainty model: rows whitened by it at each configuration (from the cell's tracker when
  /// the plan has a cell, else its isotropic equivalent at 3 m). Unset: `noise`.
  std::optional<TrackerModelWire> tracker;
  /// Reflector nests on the tool (position plans, at most kMaxPlanReflectors): the plan is chosen for what
  /// shots of every nest identify (their offsets, free ones, among the parameters) rather than the tool point.
  std::vector<CampaignReflectorWire> reflectors;
  std::uint64_t seed = 1;
  /// Random validation configurations for the predicted accuracy.
  int num_validation = 100;
  /// Run as a long-running operation.
  bool async = false;
  PlanOptionsWire options;
  /// The cell's own configurations to choose from; unset: the planner draws configurations itself.
  std::optional<PlanCandidatesWire> candidates;
  /// The poses the robot will work in (predicted_error's sample and the predicted accuracy's); unset: num_validation
  /// random configurations.
  std::optional<PlanTaskWire> task;
  /// A standard test instead of a calibration plan (docs/iso9283.md): its poses and cycles are the configurations.
  std::optional<PlanTestWire> test;
  PlanPurpose purpose = PlanPurpose::kCalibration;
};
/// The objective a request plans with (its own, or the default for its kind of plan).
ObservabilityIndex PlanObjective(const PlanRequest& request);
namespace detail {
bool WriteNumConfigurations(const PlanRequest& request, nlohmann::json* value);
void ReadNumConfigurations(const nlohmann::json* value, const std::string& path, PlanRequest* request);
}  // namespace detail
template <>
struct WireFields<PlanRequest> {
  using S = PlanRequest;
  static constexpr bool (*kAuto)(const S&) = +[](const S& r) { return r.num_configurations_auto; };
  static constexpr auto fields = std::make_tuple(
      Field{"robot", &S::robot}.Mandatory().Size(0, 64),
      Field{"cell", &S::cell, Presence::kOmitEmpty}.Size(0, 64).Rule(&IsValidId, kIdRule),
      // A number or "auto": the parser reads it.
      Computed<S>{"num_configurations", &detail::WriteNumConfigurations, &detail::ReadNumConfigurations, true},
      // "auto"'s range: written and read with "auto" only (a request that gives it otherwise is refused).
      Field{"min_configurations", &S::min_configurations, Presence::kOptionalOnRead}.When(kAuto).Range(1, 1000),
      Field{"max_configurations", &S::max_configurations, Presence::kOptionalOnRead}.When(kAuto).Range(1, 1000),
      Field{"accuracy_goal_mm", &S::accuracy_goal_mm, Presence::kOmitEmpty}.Range(1e-6, 1e3),
      Field{"measurement_type", &S::measurement_type}, Field{"objective", &S::objective, Presence::kOmitEmpty},
      Field{"optimiser", &S::optimiser}, Field{"scaling", &S::scaling}, Field{"noise", &S::noise},
      Field{"tracker", &S::tracker, Presence::kOmitEmpty},
      Field{"reflectors", &S::reflectors, Presence::kOmitEmpty}.Size(0, kMaxPlanReflectors), Field{"seed", &S::seed},
      Field{"num_validation", &S::num_validation}.Range(1, 10000), Field{"async", &S::async},
      Field{"options", &S::options},
      // A list of joint vectors or the object: the parser reads it.
      Field{"candidates", &S::candidates, Presence::kOmitEmpty}.Apart(), Field{"task", &S::task, Presence::kOmitEmpty},
      Field{"test", &S::test, Presence::kOmitEmpty}, Field{"purpose", &S::purpose});
  /// Reflectors named once and with position measurements; "auto" with its goal and range.
  static void CheckRequest(const S& request, const std::string& path, Problems* problems);
};
ROBOCAL_WIRE_DECLARE(PlanRequest);
/// Validates a request; also refuses one whose work (MaxWork) exceeds the limits, naming the fields that set it.
PlanRequest ParsePlanRequest(const nlohmann::json& body, const Limits& limits);

/// The core options of the request's optimiser, objective and seed included (progress left empty). One mapping
/// for every optimiser; the values were validated by ParsePlanRequest.
SolisWetsOptions ToSolisWetsOptions(const PlanRequest& request);
RandomSelectionOptions ToRandomSelectionOptions(const PlanRequest& request);
ExchangeOptions ToExchangeOptions(const PlanRequest& request);
/// The observability options of the request (measurement type, noise, scaling); parameters left empty.
ObservabilityOptions ToObservabilityOptions(const PlanRequest& request);
/// The most work the request can cause: its optimiser's (MaxPlanWork), and the Jacobians of the predicted
/// accuracy of the plan and of its random baseline (2 x num_validation).
PlanWork MaxWork(const PlanRequest& request);

/// Observability indices of a configuration set (non-finite values are null on the wire, NaN here).
struct Indices {
  int num_configurations = 0;
  int num_parameters = 0;
  double condition_number = 0.0;
  double o1 = 0.0, o2 = 0.0, o3 = 0.0, o4 = 0.0, o5 = 0.0;
  double log_det = 0.0;
  /// The predicted_error index (mm; null when the set was evaluated without a validation sample).
  double predicted_error_mm = 0.0;
  std::vector<double> singular_values;
  std::string scaling;
};
template <>
struct WireFields<Indices> {
  using S = Indices;
  static constexpr auto fields = std::make_tuple(
      Field{"num_configurations", &S::num_configurations},
      Field{"num_parameters", &S::num_parameters},
      Field{"condition_number", &S::condition_number},
      Field{"o1", &S::o1},
      Field{"o2", &S::o2},
      Field{"o3", &S::o3},
      Field{"o4", &S::o4},
      Field{"o5", &S::o5},
      Field{"log_det", &S::log_det},
      Field{"predicted_error_mm", &S::predicted_error_mm},
      Field{"singular_values", &S::singular_values},
      Field{"scaling", &S::scaling});
};
ROBOCAL_WIRE_DECLARE(Indices);
Indices ToWire(const ObservabilityIndices& indices);

/// Predicted accuracy on random validation configurations; rms_orientation_deg is NaN (null) for position-only
/// measurements.
struct PredictedAccuracyWire {
  int num_validation = 0;
  double rms_position_mm = 0.0;
  double max_position_mm = 0.0;
  double rms_orientation_deg = 0.0;
  /// The predicted_error index at these configurations (mm): position and, for types that observe orientation,
  /// orientation weighted by a length (docs/planning.md).
  double rms_error_mm = 0.0;
};
template <>
struct WireFields<PredictedAccuracyWire> {
  using S = PredictedAccuracyWire;
  static constexpr auto fields = std::make_tuple(
      Field{"num_validation", &S::num_validation},
      Field{"rms_position_mm", &S::rms_position_mm},
      Field{"max_position_mm", &S::max_position_mm},
      Field{"rms_orientation_deg", &S::rms_orientation_deg},
      Field{"rms_error_mm", &S::rms_error_mm});
};
ROBOCAL_WIRE_DECLARE(PredictedAccuracyWire);
PredictedAccuracyWire ToWire(const PredictedAccuracy& accuracy);

/// How the search ended.
struct PlanSummaryWire {
  Termination termination = Termination::kFailure;
  std::string message;
  std::string method;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  int iterations = 0;
  std::int64_t evaluations = 0;
  double seconds = 0.0;
  /// The indices of the starting set.
  Indices initial;
  std::string brief;
  /// A synchronous plan stopped at the server's request deadline (termination NO_CONVERGENCE, best set so far).
  bool deadline_exceeded = false;
};
template <>
struct WireFields<PlanSummaryWire> {
  using S = PlanSummaryWire;
  static constexpr auto fields = std::make_tuple(
      Field{"termination", &S::termination},
      Field{"message", &S::message},
      Field{"method", &S::method},
      Field{"objective", &S::objective},
      Field{"iterations", &S::iterations},
      Field{"evaluations", &S::evaluations},
      Field{"seconds", &S::seconds},
      Field{"initial", &S::initial},
      Field{"brief", &S::brief},
      Field{"deadline_exceeded", &S::deadline_exceeded});
};
ROBOCAL_WIRE_DECLARE(PlanSummaryWire);
PlanSummaryWire ToWire(const PlanSummary& summary);

/// The paper's baseline: a random set of the same size.
struct PlanBaseline {
  std::vector<std::vector<double>> configurations;
  Indices indices;
  PredictedAccuracyWire predicted_accuracy;
};
template <>
struct WireFields<PlanBaseline> {
  using S = PlanBaseline;
  static constexpr auto fields = std::make_tuple(
      Field{"configurations", &S::configurations},
      Field{"indices", &S::indices},
      Field{"predicted_accuracy", &S::predicted_accuracy});
};
ROBOCAL_WIRE_DECLARE(PlanBaseline);

/// A reason candidates were rejected: how many, and the first few (0-based indices into the candidates).
struct CandidateRejectionWire {
  std::string reason;
  int count = 0;
  std::vector<int> first_indices;
};
template <>
struct WireFields<CandidateRejectionWire> {
  using S = CandidateRejectionWire;
  static constexpr auto fields = std::make_tuple(Field{"reason", &S::reason}, Field{"count", &S::count},
                                                 Field{"first_indices", &S::first_indices});
};
ROBOCAL_WIRE_DECLARE(CandidateRejectionWire);

/// The candidates a plan chose from: how many were given, how many it could use, and why the others were not.
struct CandidateAccountWire {
  int num_candidates = 0;
  int num_usable = 0;
  std::vector<CandidateRejectionWire> rejected;
};
template <>
struct WireFields<CandidateAccountWire> {
  using S = CandidateAccountWire;
  static constexpr auto fields = std::make_tuple(Field{"num_candidates", &S::num_candidates},
                                                 Field{"num_usable", &S::num_usable}, Field{"rejected", &S::rejected});
};
ROBOCAL_WIRE_DECLARE(CandidateAccountWire);
CandidateAccountWire ToWire(const CandidateAccount& account);

/// The range one joint's candidates cover against its limits, in the joint's unit (deg / mm).
struct JointCoverageWire {
  std::string joint;
  double min = 0.0;
  double max = 0.0;
  double lower_limit = 0.0;
  double upper_limit = 0.0;
  /// (max - min) / (upper_limit - lower_limit).
  double fraction = 0.0;
  /// Named in the warning: spreading this joint alone would determine a poorly determined parameter.
  bool too_narrow = false;
};
template <>
struct WireFields<JointCoverageWire> {
  using S = JointCoverageWire;
  static constexpr auto fields = std::make_tuple(
      Field{"joint", &S::joint}, Field{"min", &S::min}, Field{"max", &S::max}, Field{"lower_limit", &S::lower_limit},
      Field{"upper_limit", &S::upper_limit}, Field{"fraction", &S::fraction}, Field{"too_narrow", &S::too_narrow});
};
ROBOCAL_WIRE_DECLARE(JointCoverageWire);

/// A parameter the candidates determine far worse than as many spread configurations would: its predicted std
/// over the spread reference's (null: the candidates do not determine it at all).
struct PoorlyDeterminedWire {
  std::string parameter;
  double std_ratio = 0.0;
};
template <>
struct WireFields<PoorlyDeterminedWire> {
  using S = PoorlyDeterminedWire;
  static constexpr auto fields = std::make_tuple(Field{"parameter", &S::parameter}, Field{"std_ratio", &S::std_ratio});
};
ROBOCAL_WIRE_DECLARE(PoorlyDeterminedWire);

/// How well the candidates cover the joints and determine the parameters (docs/planning.md, "Coverage").
struct CoverageWire {
  std::vector<JointCoverageWire> joints;
  std::vector<PoorlyDeterminedWire> poorly_determined;
  /// Empty when every parameter is determined well enough.
  std::string warning;
};
template <>
struct WireFields<CoverageWire> {
  using S = CoverageWire;
  static constexpr auto fields = std::make_tuple(
      Field{"joints", &S::joints}, Field{"poorly_determined", &S::poorly_determined}, Field{"warning", &S::warning});
};
ROBOCAL_WIRE_DECLARE(CoverageWire);
CoverageWire ToWire(const RobotModel& model, const CandidateCoverage& coverage);

/// One point of the predicted error on the task against N.
struct PoseCountPointWire {
  int num_configurations = 0;
  /// The predicted RMS error on the task (mm; null when the set does not determine every parameter), and the mean
  /// position error it implies, kMeanOverRms3d of it, which the goal is compared with.
  double predicted_error_mm = 0.0;
  double predicted_mean_mm = 0.0;
};
template <>
struct WireFields<PoseCountPointWire> {
  using S = PoseCountPointWire;
  static constexpr auto fields = std::make_tuple(Field{"num_configurations", &S::num_configurations},
                                                 Field{"predicted_error_mm", &S::predicted_error_mm},
                                                 Field{"predicted_mean_mm", &S::predicted_mean_mm});
};
ROBOCAL_WIRE_DECLARE(PoseCountPointWire);

/// "num_configurations": "auto": the curve a user reads to decide, and the N it chose.
struct PoseCountWire {
  double accuracy_goal_mm = 0.0;
  /// The robot's model error the prediction includes (mm, RMS; 0 without an earlier calibration).
  double model_error_mm = 0.0;
  std::vector<PoseCountPointWire> points;
  /// The smallest N whose prediction reaches the goal (null: none in the range does; the plan then has the
  /// range's largest N).
  std::optional<int> chosen;
  std::string message;
};
template <>
struct WireFields<PoseCountWire> {
  using S = PoseCountWire;
  static constexpr auto fields =
      std::make_tuple(Field{"accuracy_goal_mm", &S::accuracy_goal_mm}, Field{"model_error_mm", &S::model_error_mm},
                      Field{"points", &S::points}, Field{"chosen", &S::chosen}, Field{"message", &S::message});
};
ROBOCAL_WIRE_DECLARE(PoseCountWire);

/// POST /v1/plans (synchronous) and GET /v1/plans/{plan}.
struct PlanResult {
  std::string id;
  std::string robot;
  PlanRequest request;
  MeasurementType measurement_type = MeasurementType::kPose;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  Optimiser optimiser = Optimiser::kSolisWets;
  /// Per joint "deg" or "mm".
  std::vector<std::string> joint_units;
  /// M configurations, each a joint vector in joint_units.
  std::vector<std::vector<double>> configurations;
  Indices indices;
  PlanBaseline baseline;
  std::vector<std::string> identifiable_parameters;
  std::vector<DroppedParameterWire> dropped_parameters;
  PredictedAccuracyWire predicted_accuracy;
  PlanSummaryWire summary;
  std::int64_t created_unix_ms = 0;
  /// The cell the plan was made for (null on the wire when none), and each configuration's feasibility report
  /// in it (one per configuration; empty without a cell).
  std::optional<std::string> cell;
  std::vector<ConfigurationCheckWire> configuration_checks;
  /// A plan from candidates: each configuration's 0-based index into the candidates, with its 1-based line of the
  /// file for candidates from a tracker export; the candidates' account and coverage.
  std::vector<int> candidate_indices;
  std::vector<int> candidate_lines;
  std::optional<CandidateAccountWire> candidates;
  std::optional<CoverageWire> coverage;
  /// "num_configurations": "auto".
  std::optional<PoseCountWire> pose_count;
  /// A task box: how its configurations were found ("inverse_kinematics" or "rejection_sampling").
  std::optional<std::string> task_method;
  /// A test plan: the test (its configurations are the test's shots in order; the optimisation figures are null).
  std::optional<Iso9283PlanWire> test;
};
template <>
struct WireFields<PlanResult> {
  using S = PlanResult;
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id}, Field{"robot", &S::robot}, Field{"request", &S::request},
      Field{"measurement_type", &S::measurement_type}, Field{"objective", &S::objective},
      Field{"optimiser", &S::optimiser}, Field{"joint_units", &S::joint_units},
      Field{"configurations", &S::configurations}, Field{"indices", &S::indices}, Field{"baseline", &S::baseline},
      Field{"identifiable_parameters", &S::identifiable_parameters},
      Field{"dropped_parameters", &S::dropped_parameters}, Field{"predicted_accuracy", &S::predicted_accuracy},
      Field{"summary", &S::summary}, Field{"created_unix_ms", &S::created_unix_ms}, Field{"cell", &S::cell},
      Field{"configuration_checks", &S::configuration_checks},
      Field{"candidate_indices", &S::candidate_indices, Presence::kOmitEmpty},
      Field{"candidate_lines", &S::candidate_lines, Presence::kOmitEmpty},
      Field{"candidates", &S::candidates, Presence::kOmitEmpty}, Field{"coverage", &S::coverage, Presence::kOmitEmpty},
      Field{"pose_count", &S::pose_count, Presence::kOmitEmpty},
      Field{"task_method", &S::task_method, Presence::kOmitEmpty}, Field{"test", &S::test, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(PlanResult);

}  // namespace robocal::api
