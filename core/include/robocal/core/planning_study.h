// A reproducible study of the planners: how far the paper's Solis & Wets preset lowers the condition number
// below random starting sets, how much of the best gain found by longer budgets it reaches, what each plan buys
// in predicted accuracy, and how plans by different objectives (condition number, log det, predicted error)
// compare on predicted and on simulated accuracy. The planning figures of docs/planning.md come from it
// (`robocal-plan-study`).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "robocal/core/measurement.h"
#include "robocal/core/observability.h"

namespace robocal {

constexpr std::uint64_t kPlanningStudyValidationSeedOffset = 0x5EED0000ULL;
/// The virtual cell of seed s's simulated accuracy is seeded s + kPlanningStudySimulationSeedOffset.
constexpr std::uint64_t kPlanningStudySimulationSeedOffset = 0x51AA0000ULL;

struct PlanningStudyOptions {
  /// Robot presets (presets.h) and measurement types; the study runs every pair.
  std::vector<std::string> robots = {"grinder5", "puma560", "ur5e"};
  std::vector<MeasurementType> measurement_types = {MeasurementType::kPosition, MeasurementType::kPose};
  /// Configurations per plan (the paper's 10). M x MeasurementRows(type) must reach the number of identifiable
  /// parameters of every case (checked by RunPlanningStudy).
  int num_configurations = 10;
  /// Seeds first_seed .. first_seed + seeds - 1; each seed is one random starting set, shared by every budget.
  int seeds = 20;
  std::uint64_t first_seed = 1;
  /// k_max of the Solis & Wets runs, strictly ascending; otherwise the paper preset. The first is normally the
  /// paper's 100; the last is the best known result that the headroom is measured against.
  std::vector<int> budgets = {100, 1000, 10000};
  /// Scaling of E* for the condition numbers (the optimisers' objective is the condition number), the tracker
  /// noise that weights its rows (and the predicted accuracy), and the expected error sizes of
  /// kExpectedDeviation.
  ColumnScaling scaling = ColumnScaling::kColumnNorm;
  MeasurementNoise noise;
  double expected_translation_mm = 0.1;
  double expected_rotation_rad = 1e-3;
  /// Random validation configurations of the predicted accuracy: RandomConfigurations(model, num_validation)
  /// drawn from Rng(first_seed + kPlanningStudyValidationSeedOffset), apart from the plans' seeds.
  int num_validation = 200;
  /// Also run the exchange optimiser with log det (D-optimality) as objective, for contrast.
  bool exchange = true;
  int exchange_candidates = 2000;
  /// The objectives compared (the third table): per seed, a plan by the paper preset with k_max = budgets.front()
  /// and (with `exchange`) one by the exchange optimiser for each, from the seed's generator. predicted_error
  /// plans optimise their own `objective_validation` configurations (the planners' num_validation, drawn from
  /// Rng(seed + kPredictedErrorSeedOffset)); the study judges every plan at its own validation configurations.
  std::vector<ObservabilityIndex> objectives = {ObservabilityIndex::kConditionNumber, ObservabilityIndex::kLogDet,
                                                ObservabilityIndex::kPredictedError};
  int objective_validation = 50;
  /// Simulated accuracy of the third table's plans and of the random starting sets: each plan measured in a
  /// virtual cell (one per seed: hidden errors and tracker placement from seed + kPlanningStudySimulationSeedOffset,
  /// VirtualCellOptions' defaults otherwise, `noise`, one shot per pose: the noise the prediction assumes; every
  /// plan of a seed sees the same cell and the same noise draws), identified (Identify, the identifiable
  /// parameters); the error is the calibrated model's tool pose against the true robot's at the validation
  /// configurations, as the predicted_error index weighs it.
  bool simulate = true;
  /// Worker threads (>= 1). Results do not depend on it: every run has its own seeded generator.
  int threads = 1;
  /// Called after each finished run with (runs done, runs in all); may be called from any worker thread,
  /// one call at a time.
  std::function<void(int, int)> progress;

  bool IsValid(std::string* error) const;
};

/// One plan of the objective comparison: medians over the seeds.
struct ObjectivePlanResult {
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  /// "solis_wets" (the paper preset, k_max = budgets.front()) or "exchange".
  std::string method;
  double condition_number = 0.0;
  /// Predicted RMS error after calibration at the study's validation configurations (PredictAccuracy,
  /// rms_error_mm: position, and for types that observe orientation the orientation times 30 mm), mm.
  double predicted_rms_error_mm = 0.0;
  /// The same error simulated (see PlanningStudyOptions::simulate), mm; NaN without simulation or when an
  /// identification failed.
  double simulated_rms_error_mm = 0.0;
};

/// One robot and measurement type: medians over the seeds.
struct PlanningStudyRow {
  std::string robot;
  MeasurementType measurement_type = MeasurementType::kPose;
  /// Identifiable parameters (columns of E*).
  int num_parameters = 0;
  /// Condition number of E* (the study's scaling): random starting sets, each budget, exchange (log det).
  double start_condition_number = 0.0;
  std::vector<double> condition_number;
  double exchange_condition_number = 0.0;
  /// Predicted RMS position error after calibration (noise only, PredictAccuracy), mm.
  double start_rms_position_mm = 0.0;
  std::vector<double> rms_position_mm;
  double exchange_rms_position_mm = 0.0;
  /// The objective comparison: the random starting sets (predicted and simulated, as ObjectivePlanResult), then
  /// the paper preset for each objective, then exchange for each.
  double start_predicted_rms_error_mm = 0.0;
  double start_simulated_rms_error_mm = 0.0;
  std::vector<ObjectivePlanResult> objectives;

  /// start / budget b (medians).
  double Ratio(int b) const;
  /// ln(start / budget b) / ln(start / last budget): the share of the best gain found (by the longest budget)
  /// that budget b already reaches (1 for the last budget; NaN when the last budget gained nothing).
  double GainShare(int b) const;
};

struct PlanningStudyResult {
  PlanningStudyOptions options;
  std::vector<PlanningStudyRow> rows;
  double seconds = 0.0;
};

/// Runs the study. Throws std::invalid_argument for invalid options (naming the field) or too few
/// configurations for a case's parameters; rethrows the first exception of a run (after stopping the others).
PlanningStudyResult RunPlanningStudy(const PlanningStudyOptions& options);

/// The study as three tables (condition numbers with ratio and headroom; predicted accuracy; the objectives
/// compared on predicted and simulated accuracy), plain text.
std::string FormatPlanningStudy(const PlanningStudyResult& result);

}  // namespace robocal
