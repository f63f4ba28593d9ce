// The paper's experiment, simulated: plan M configurations three ways (Solis & Wets, random, exchange),
// measure and identify each in the virtual cell, then compensate validation poses and compare accuracy. In a
// measurement cell, also: random configurations that ignore the cell, and the planners with every objective.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "robocal/core/accuracy.h"
#include "robocal/core/error_model.h"
#include "robocal/core/virtual_cell.h"

namespace robocal {

struct ExperimentOptions {
  std::string robot = "grinder5";
  MeasurementType measurement_type = MeasurementType::kPose;
  /// Configurations per plan (paper: 10).
  int num_configurations = 10;
  /// Independent trials (new hidden errors, new plans per trial); results aggregated.
  int trials = 10;
  /// Validation poses per trial (paper: 36), random within the limits.
  int num_validation = 36;
  /// E_tot = E_xyz + h E_cos (mm).
  double h_mm = 30.0;
  std::uint64_t seed = 1;
  /// The simulated cell (seed overridden per trial from `seed`). With cell.measurement_cell set (e.g.
  /// PresetCellSpec(robot)), the planners plan inside that cell and its tracker measures only measurable poses;
  /// see RunExperiment.
  VirtualCellOptions cell;
  /// The models every plan is fitted with, side by side (ParseModelName: "geometric", "compliance,harmonics=2",
  /// "auto", ...); each method's accuracy is reported per model. Richer models need masses (compliance) and more
  /// configurations than parameters; with joint terms the fit chooses its parameters itself.
  std::vector<std::string> models = {"geometric"};
  /// Called after each trial with (trials done, trials); for progress output.
  std::function<void(int, int)> progress;

  bool IsValid(std::string* error) const;
};

/// Results of one selection method, validation errors pooled over all trials.
struct MethodResult {
  /// "solis_wets", "random", "exchange" (all minimising the condition number); in a measurement cell also
  /// "random_ignoring_cell", "solis_wets_log_det", "solis_wets_predicted_error", "exchange_log_det",
  /// "exchange_predicted_error".
  std::string method;
  /// Median condition number of the plans (scaled E*, column_norm).
  double median_condition_number = 0.0;
  /// Accuracy of the compensated commands (after calibration), pooled over trials.
  AccuracyReport after;
  /// Trials whose identification failed (excluded from `after`).
  int failed_trials = 0;
  /// Validation targets whose compensation did not converge (near a singularity or a joint limit). They stay
  /// in `after`: the robot is sent to the best joints found, as a controller would.
  int unconverged_targets = 0;
  /// Planned poses over all trials, and how many of them the tracker could not measure (0 without a
  /// measurement cell, and for every method that plans in the cell).
  int planned_poses = 0;
  int unmeasured_poses = 0;
  /// The model it was fitted with (ExperimentOptions::models).
  std::string model = "geometric";
};

struct ExperimentResult {
  ExperimentOptions options;
  /// Accuracy of the nominal commands (before calibration), pooled over trials.
  AccuracyReport before;
  std::vector<MethodResult> methods;
  double seconds = 0.0;
};

/// Runs the experiment. Per trial (seeds derived from options.seed): a virtual cell with new hidden errors;
/// plans of M configurations by random selection (one set, the paper's baseline), Solis & Wets (the paper's
/// preset, started from that random set) and exchange (default options), all minimising the condition number
/// of the identifiable parameters; each plan measured in the cell and identified; then `num_validation`
/// random configurations: the target is the nominal model's tool pose relative to the robot's true base,
/// placed in the tracker frame; "before" is the true robot at the nominal joints, "after" the true robot at the
/// joints CompensatePose finds on each calibration (noise-free poses). Errors are pooled over trials.
///
/// With a measurement cell (options.cell.measurement_cell): every planner plans in the cell's joint ranges with
/// IsFeasible as its predicate, the random set and Solis & Wets' start are random feasible configurations, and
/// five more methods run: "random_ignoring_cell" (random within the joint ranges, as if there were no cell: the
/// tracker loses the poses it cannot see, and the fit uses the rest), and Solis & Wets and exchange with the
/// log_det and predicted_error objectives. Validation configurations are drawn within the cell's joint ranges
/// (not required feasible: accuracy is judged on the true robot, not measured). A plan that fails (the cell
/// leaves too little feasible) counts as a failed trial.
/// Throws std::invalid_argument for invalid options.
ExperimentResult RunExperiment(const ExperimentOptions& options);

/// The paper's Table 1 form (E_xyz, E_tot in um; E_cos in arc-seconds), one block per method plus "before", and
/// the improvement of Solis & Wets, then of exchange, over random selection in percent (mean and RP of E_xyz,
/// E_cos, E_tot; "n/a" where random selection's value is 0). In a measurement cell, each method's block also
/// says how many planned poses could not be measured.
std::string FormatExperimentReport(const ExperimentResult& result);

}  // namespace robocal
