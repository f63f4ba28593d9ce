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
#include "robocal/api/wire.h"
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

struct PlanRequest {
  std::string robot;
  /// A cell of the robot: every configuration (and the random baseline's) is then feasible in it. Empty: none.
  std::string cell;
  int num_configurations = 10;
  MeasurementType measurement_type = MeasurementType::kPose;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
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
};
template <>
struct WireFields<PlanRequest> {
  using S = PlanRequest;
  static constexpr auto fields =
      std::make_tuple(Field{"robot", &S::robot}.Mandatory().Size(0, 64),
                      Field{"cell", &S::cell, Presence::kOmitEmpty}.Size(0, 64).Rule(&IsValidId, kIdRule),
                      Field{"num_configurations", &S::num_configurations}.Range(1, std::numeric_limits<int>::max()),
                      Field{"measurement_type", &S::measurement_type}, Field{"objective", &S::objective},
                      Field{"optimiser", &S::optimiser}, Field{"scaling", &S::scaling}, Field{"noise", &S::noise},
                      Field{"tracker", &S::tracker, Presence::kOmitEmpty},
                      Field{"reflectors", &S::reflectors, Presence::kOmitEmpty}.Size(0, kMaxPlanReflectors),
                      Field{"seed", &S::seed}, Field{"num_validation", &S::num_validation}.Range(1, 10000),
                      Field{"async", &S::async}, Field{"options", &S::options});
  /// Reflectors named once and with position measurements.
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
};
template <>
struct WireFields<PlanResult> {
  using S = PlanResult;
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id},
      Field{"robot", &S::robot},
      Field{"request", &S::request},
      Field{"measurement_type", &S::measurement_type},
      Field{"objective", &S::objective},
      Field{"optimiser", &S::optimiser},
      Field{"joint_units", &S::joint_units},
      Field{"configurations", &S::configurations},
      Field{"indices", &S::indices},
      Field{"baseline", &S::baseline},
      Field{"identifiable_parameters", &S::identifiable_parameters},
      Field{"dropped_parameters", &S::dropped_parameters},
      Field{"predicted_accuracy", &S::predicted_accuracy},
      Field{"summary", &S::summary},
      Field{"created_unix_ms", &S::created_unix_ms},
      Field{"cell", &S::cell},
      Field{"configuration_checks", &S::configuration_checks});
};
ROBOCAL_WIRE_DECLARE(PlanResult);

}  // namespace robocal::api
