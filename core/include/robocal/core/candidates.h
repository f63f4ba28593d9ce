// Planning from the cell's own configurations, beyond the planners themselves (planning.h takes a CandidatePool):
// the reasons a cell rejects a candidate, how well a pool covers the joints and determines the parameters, task
// configurations from a box in the base frame, and the predicted error on the task against the number of poses
// (docs/planning.md, "Plans from the cell's own configurations").
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "robocal/core/cell.h"
#include "robocal/core/observability.h"
#include "robocal/core/planning.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"

namespace robocal {

/// CandidatePool::infeasibility_reasons for a cell: the names (ToString(CellRule)) of the rules
/// CheckConfiguration(model, cell, q) finds the candidate failing. Keeps copies of both.
std::function<std::vector<std::string>(const Eigen::VectorXd& q)> CellRuleReasons(const RobotModel& model,
                                                                                  const Cell& cell);

// ---- Coverage -----------------------------------------------------------------------------------------------

struct CoverageOptions {
  /// A parameter is poorly determined when its predicted standard deviation from the configurations is more than
  /// this many times what as many configurations spread uniformly within the joint limits would give: the
  /// configurations would need max_std_ratio^2 times as many poses to determine it as well (10: 100 times).
  double max_std_ratio = 10.0;
  /// The spread reference: this many configurations uniform within the limits, from Rng(seed); its standard
  /// deviations are scaled by sqrt(num_reference / M) to M configurations.
  int num_reference = 500;
  std::uint64_t seed = 1;

  bool IsValid(std::string* error) const;
};

/// The range one joint covers, against its limits (rad, or mm for a prismatic joint).
struct JointCoverage {
  std::string name;
  double min = 0.0;
  double max = 0.0;
  double lower_limit = 0.0;
  double upper_limit = 0.0;
  /// (max - min) / (upper_limit - lower_limit).
  double fraction = 0.0;
  /// Named by the warning: spreading this joint alone over its limits would determine a poorly determined
  /// parameter within max_std_ratio.
  bool too_narrow = false;
};

/// How well the configurations determine one parameter of ObservabilityOptions::parameters.
struct ParameterDetermination {
  /// Index into the fit's parameters (the model's error parameters, then 3 offsets per reflector) and its name
  /// (RobotModel::parameter_name, or "reflector 2 dy").
  int parameter = 0;
  std::string name;
  /// Predicted 1-sigma (mm or rad, for the options' noise): sqrt of the diagonal of (E*' W E*)^-1, taken on the
  /// unit-column scaled matrix over the directions it determines; +inf when the configurations do not determine
  /// it (it has a share above 1e-6 in a direction whose eigenvalue is at most 1e-12 of the largest, the cut of
  /// the predicted_error index).
  double std = 0.0;
  /// The same for the spread reference, scaled to as many configurations.
  double reference_std = 0.0;
  /// std / reference_std (+inf when std is).
  double std_ratio = 0.0;
  /// 0-based joints whose spreading alone brings std_ratio within max_std_ratio (only for poorly determined
  /// parameters).
  std::vector<int> joints;
};

/// A candidate pool's or a chosen set's coverage.
struct CandidateCoverage {
  int num_configurations = 0;
  /// One per joint.
  std::vector<JointCoverage> joints;
  /// One per ObservabilityOptions::parameters, in its order.
  std::vector<ParameterDetermination> parameters;
  /// 0-based joints marked too_narrow, ascending; positions in `parameters` of the poorly determined ones
  /// (std_ratio > max_std_ratio), ascending.
  std::vector<int> narrow_joints;
  std::vector<int> poorly_determined;
  /// Empty when no parameter is poorly determined; else one sentence naming the narrow joints with their ranges
  /// (degrees for revolute joints) and the poorly determined parameters with their ratios.
  std::string warning;
};

/// Each joint's covered range against its limits, and which parameters `configurations` (>= 1, each of the
/// model's joint count, finite) determine far worse than as many spread configurations would, and which joints'
/// narrow range is the cause: a joint is named when spreading its values alone (uniform within its limits, from
/// Rng(seed + 1 + joint), the other joints as they are) brings a poorly determined parameter within
/// max_std_ratio. The rows are weighted and the parameters chosen as `observability` says (the plan's own E*).
/// Throws std::invalid_argument for invalid options or configurations.
CandidateCoverage AnalyseCoverage(const RobotModel& model, const ObservabilityOptions& observability,
                                  const std::vector<Eigen::VectorXd>& configurations,
                                  const CoverageOptions& options = {});

// ---- Task configurations ------------------------------------------------------------------------------------

/// Where the robot will work: the tool point in an axis-aligned box of the robot's base frame, with the tool
/// in one of the given orientations.
struct TaskBox {
  Eigen::Vector3d min_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_mm = Eigen::Vector3d::Zero();
  /// R_base_tool of each orientation (rotation matrices). Empty: any orientation.
  std::vector<Eigen::Matrix3d> orientations;
};

/// The mean of the length of a 3-D isotropic normal error over its RMS, sqrt(8 / (3 pi)) (the Maxwell
/// distribution): how a predicted RMS error compares with a mean error such as E_xyz's. On the IPA UR10 the held-out
/// mean over the model error's RMS is 0.91.
inline constexpr double kMeanOverRms3d = 0.9213177319235613;

/// TaskSample::method's values.
inline constexpr const char* kTaskByInverseKinematics = "inverse_kinematics";
inline constexpr const char* kTaskByRejectionSampling = "rejection_sampling";

struct TaskSample {
  /// Joint vectors within the model's limits (rad / mm), at most the count asked for.
  std::vector<Eigen::VectorXd> configurations;
  /// "inverse_kinematics": a point uniform in the box and an orientation drawn from the list, solved in closed
  /// form (ArmSolver, a 6R arm of a known family), one of the solutions within the limits drawn at random.
  /// "rejection_sampling": configurations uniform within the limits whose tool point lies in the box, for a model
  /// without closed-form inverse kinematics or a box without orientations; the orientations are then not
  /// imposed (a random configuration never meets a given one exactly).
  std::string method;
  /// Points (inverse kinematics) or configurations (rejection sampling) tried, and how many gave nothing.
  std::int64_t attempts = 0;
  std::int64_t failures = 0;
  /// False when the attempts ran out before `count`: the box is (mostly) out of reach.
  bool complete = false;
  std::string message;
};

/// `count` (>= 1) task configurations for the predicted_error objective (SolisWetsOptions::task and the others'),
/// seeded; at most max_attempts_per_configuration x count attempts. Throws std::invalid_argument for a box with
/// min > max or non-finite corners, an orientation that is not a rotation (to 1e-6), or count or
/// max_attempts_per_configuration < 1.
TaskSample SampleTaskConfigurations(const RobotModel& model, const TaskBox& box, int count, std::uint64_t seed,
                                    int max_attempts_per_configuration = 1000);

// ---- How many poses -----------------------------------------------------------------------------------------

struct PoseCountOptions {
  /// The N to predict at: strictly ascending, each >= 1. Empty: 6, 7, ..., 60.
  std::vector<int> num_configurations;
  /// The smallest N whose predicted error reaches this (mm) is chosen. 0: no goal (the curve only).
  double accuracy_goal_mm = 0.0;
  /// The pool (exchange.candidates: required), the objective that picks the sets (log_det or predicted_error
  /// normally), the seed, feasibility, screening and iteration limits, the task or num_validation of the
  /// prediction. The curve reports predicted_error on the task whatever the objective; ObservabilityOptions::
  /// model_error_mm sets where it flattens. A drawn pool is a caller's DrawFeasibleConfigurations given as
  /// candidates.
  ExchangeOptions exchange;

  bool IsValid(std::string* error) const;
};

struct PoseCountPoint {
  int num_configurations = 0;
  /// predicted_error on the task (mm, with the model error); +inf for a set that does not determine every
  /// parameter.
  double predicted_error_mm = std::numeric_limits<double>::infinity();
  double log_det = 0.0;
  /// The set: candidate indices (into exchange.candidates) and their configurations.
  std::vector<int> candidate_indices;
  std::vector<Eigen::VectorXd> configurations;
};

struct PoseCountCurve {
  Termination termination = Termination::kFailure;
  std::string message = "not run";
  /// One point per N asked for that the usable candidates allow.
  std::vector<PoseCountPoint> points;
  /// Position in `points` of the smallest N whose prediction reaches the goal; -1 without a goal or when none does.
  int chosen = -1;
  CandidateAccount candidates;
  /// The exchange plan at the first N (iterations, evaluations, its indices).
  PlanSummary exchange;
  /// Screening gains and exact evaluations of the additions after the first N.
  int addition_evaluations = 0;
  double seconds = 0.0;
};

/// The predicted error on the task against the number of poses N, from the candidates: the exchange optimiser picks
/// the first N (seeded), then each further N adds the candidate the exchange's addition step picks (greedy
/// sequential addition over the same per-candidate blocks), so the sets are nested and the curve cannot rise.
/// CONVERGENCE with the curve; DEGRADED when the usable candidates cut the curve short; FAILURE with no points when
/// fewer candidates than the first N are usable (the message names both counts). Throws std::invalid_argument for
/// invalid options, no candidates, a malformed candidate under kThrow, or a bad task.
PoseCountCurve PlanPoseCount(const RobotModel& model, const ObservabilityOptions& observability,
                             const PoseCountOptions& options);

}  // namespace robocal
