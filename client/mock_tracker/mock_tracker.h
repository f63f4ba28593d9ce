// The mock tracker: a simulated robot and laser tracker (the core's VirtualCell) that drives the whole
// calibration workflow over HTTP through robocal::Client, then checks the result on validation poses the way a
// cell would: command nominal and compensated joints, and see where the true robot lands.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "robocal/api/campaigns.h"
#include "robocal/client/client.h"
#include "robocal/core/accuracy.h"
#include "robocal/core/cell.h"
#include "robocal/core/transforms.h"
#include "robocal/core/virtual_cell.h"

namespace robocal::mock {

struct MockTrackerOptions {
  /// A preset robot (the cell must know the nominal model to simulate it).
  std::string robot = "grinder5";
  int count = 10;
  MeasurementType measurement_type = MeasurementType::kPose;
  api::Optimiser optimiser = api::Optimiser::kSolisWets;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  /// Seeds the cell (hidden errors, tracker placement, noise), the plan and the validation poses.
  std::uint64_t seed = 1;
  int shots_per_pose = 10;
  int num_validation = 36;
  /// E_tot = E_xyz + h E_cos (mm).
  double h_mm = 30.0;
  /// Also calibrate from random configurations (the paper's baseline) and compare.
  bool compare_random = false;
  /// Independent trials: trial t (0-based) is a new cell (hidden errors, tracker placement, noise) and new
  /// plan and validation seeds, all from seed + t; the validation errors are pooled over the trials. One trial
  /// of 10 configurations and 36 validation poses is a noisy comparison of two selection methods.
  int trials = 1;
  /// The measurement cell: "" none (every configuration is measured); "preset": the robot's preset cell
  /// (docs/cells.md), created on the server as "preset-<robot>" unless it is there already; else the id of a
  /// cell on the server. With a cell, plans are made in it (PlanRequest::cell), the virtual cell's tracker
  /// measures only the poses the cell finds feasible, and validation poses are drawn feasible.
  std::string cell;
  /// The realistic cell (docs/experiment.md): the datasheet tracker model (sent to the service as the plan's and
  /// the campaign's `tracker`), 0.03 mm robot repeatability and 2 % outliers of 1-5 mm.
  bool realistic = false;
  /// Share of shots turned into outliers (unset: 0, or the realistic cell's 2 %), of a size drawn uniformly
  /// from outlier_size_mm (unset: 1-5 mm).
  std::optional<double> outlier_rate;
  std::optional<std::array<double, 2>> outlier_size_mm;
  /// Reflector nests on the tool (0..3; needs position measurements): each pose shoots every one. Unset: none,
  /// or 3 in a realistic position campaign. Fixed (positions measured on the tool plate, so the fit calibrates
  /// the tool point through them) unless free_nests: then the cell hides an offset error of each and the
  /// campaign identifies it.
  std::optional<int> reflectors;
  bool free_nests = false;

  /// The reflector count this run uses (reflectors, or its default).
  int NumReflectors() const;

  bool IsValid(std::string* error) const;
};

/// One calibration run and how the robot does on the validation poses before and after it.
struct CampaignOutcome {
  api::PlanResult plan;
  /// Planned poses the tracker could not measure (no shot uploaded): 0 expected for a plan made in the cell.
  int unmeasured_poses = 0;
  api::Campaign campaign;
  api::CalibrationResult calibration;
  /// Outliers the cell put into the calibration shots (sequence numbers), and how many of them the fit excluded.
  std::vector<std::int64_t> injected_outliers;
  int outliers_found = 0;
  /// Nominal joints commanded: the nominal model's accuracy (with the calibrated base registration).
  AccuracyReport before;
  /// Compensated joints commanded.
  AccuracyReport after;
  /// The service's own evaluation on the uploaded validation measurements.
  api::Evaluation evaluation;
  /// Per validation pose: the target, and where the true robot went with nominal and compensated joints
  /// (tracker frame); kept for pooling over trials.
  std::vector<Transform> targets, reached_nominal, reached_compensated;
};

/// The cell a run measures in (MockTrackerOptions::cell), resolved on the server: its id and its core spec.
struct ResolvedCell {
  std::string id;
  CellSpec spec;
};
/// Resolves options.cell: nullopt for "", the preset cell (created if absent) for "preset", else GetCell.
std::optional<ResolvedCell> ResolveCell(client::Client& client, const MockTrackerOptions& options);

/// One trial: a cell of its own, calibrated from the plan and (with compare_random) from random configurations.
struct TrialOutcome {
  /// The seed of this trial's cell, plan and validation poses (options.seed + trial).
  std::uint64_t seed = 0;
  CampaignOutcome planned;
  std::optional<CampaignOutcome> random;
};

/// Validation errors of one selection method pooled over the trials (num_validation x trials poses).
struct PooledAccuracy {
  AccuracyReport before;
  AccuracyReport after;
};

struct MockTrackerReport {
  std::vector<TrialOutcome> trials;
  PooledAccuracy planned;
  std::optional<PooledAccuracy> random;
  /// Pooled over trials: after.E_tot mean < before.E_tot mean and after.E_xyz mean < before.E_xyz mean.
  bool improved = false;
};

/// The simulated cell of these options (preset robot, hidden errors and noise seeded from options.seed, shots
/// per pose; measuring in `cell` if given). Trial t of a run uses the cell of options.seed + t.
VirtualCell MakeCell(const MockTrackerOptions& options, const std::optional<ResolvedCell>& cell = std::nullopt);

/// `count` validation configurations drawn uniformly within the limits (feasible ones, within its joint ranges,
/// when the virtual cell has a measurement cell), seeded from options.seed.
std::vector<Eigen::VectorXd> ValidationConfigurations(const VirtualCell& cell, const MockTrackerOptions& options);

/// Runs the workflow; progress lines go to `log` (may be null). Throws what the client throws.
MockTrackerReport RunMockTracker(client::Client& client, const MockTrackerOptions& options, std::ostream* log);

/// The paper's tables of a report, pooled over trials (and, with --compare random, the improvement of the plan
/// over random, with a note when a single trial makes that comparison noisy).
std::string FormatReport(const MockTrackerReport& report, const MockTrackerOptions& options);
/// The report as JSON: per trial and pooled, the accuracies as api::Accuracy (mm and degrees, as the service
/// reports them), the service's own evaluation as api::Evaluation, improvements as api::Improvement.
nlohmann::json ReportToJson(const MockTrackerReport& report);

/// The measurement batch (POST /v1/campaigns/{c}/measurements) of the cell measuring `configurations` (wire
/// joints: deg / mm): the cell's shots per pose for calibration, one shot per pose for validation, none for a
/// configuration its measurement cell finds unmeasurable (cell->unmeasured() counts them); request_id
/// "mock-<seed>-<role>". Role test (an ISO 9283 test plan's configurations): one shot per configuration, tagged with
/// `tags` (one per configuration, the plan's test.tags).
api::MeasurementBatchRequest MeasurementBatch(VirtualCell* cell, const std::vector<std::vector<double>>& configurations,
                                              api::MeasurementRole role, const MockTrackerOptions& options,
                                              const std::vector<api::TestTagWire>& tags = {});

}  // namespace robocal::mock
