// The mock tracker: a simulated robot and laser tracker (the core's VirtualCell) that drives the whole
// calibration workflow over HTTP through robocal::Client, then checks the result on validation poses the way a
// cell would: command nominal and compensated joints, and see where the true robot lands.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "robocal/client/client.h"
#include "robocal/core/accuracy.h"
#include "robocal/core/virtual_cell.h"

namespace robocal::mock {

struct MockTrackerOptions {
  /// A preset robot (the cell must know the nominal model to simulate it).
  std::string robot = "grinder5";
  int count = 10;
  std::string measurement_type = "pose";
  std::string optimiser = "solis_wets";
  std::string objective = "condition_number";
  /// Seeds the cell (hidden errors, tracker placement, noise), the plan and the validation poses.
  std::uint64_t seed = 1;
  int shots_per_pose = 10;
  int num_validation = 36;
  /// E_tot = E_xyz + h E_cos (mm).
  double h_mm = 30.0;
  /// Also calibrate from random configurations (the paper's baseline) and compare.
  bool compare_random = false;

  bool IsValid(std::string* error) const;
};

/// One calibration run and how the robot does on the validation poses before and after it.
struct CampaignOutcome {
  client::PlanResult plan;
  client::Campaign campaign;
  client::CalibrationResult calibration;
  /// Nominal joints commanded: the nominal model's accuracy (with the calibrated base registration).
  AccuracyReport before;
  /// Compensated joints commanded.
  AccuracyReport after;
  /// The service's own evaluation on the uploaded validation measurements.
  client::Evaluation evaluation;
};

struct MockTrackerReport {
  CampaignOutcome planned;
  std::optional<CampaignOutcome> random;
  /// after.E_tot mean < before.E_tot mean and after.E_xyz mean < before.E_xyz mean.
  bool improved = false;
};

/// The simulated cell of these options (preset robot, seeded hidden errors and noise, shots per pose).
VirtualCell MakeCell(const MockTrackerOptions& options);

/// `count` validation configurations drawn uniformly within the limits, seeded from options.seed.
std::vector<Eigen::VectorXd> ValidationConfigurations(const RobotModel& model, const MockTrackerOptions& options);

/// Runs the workflow; progress lines go to `log` (may be null). Throws what the client throws.
MockTrackerReport RunMockTracker(client::Client& client, const MockTrackerOptions& options, std::ostream* log);

/// The paper's tables of a report (and, with --compare random, the improvement of the plan over random).
std::string FormatReport(const MockTrackerReport& report, const MockTrackerOptions& options);
nlohmann::json ReportToJson(const MockTrackerReport& report);

/// A measurement batch body (POST /v1/campaigns/{c}/measurements) of the cell measuring `configurations`
/// (wire joints: deg / mm), with request_id "mock-<seed>-<role>".
nlohmann::json MeasurementBatch(VirtualCell* cell, const std::vector<std::vector<double>>& configurations,
                                const std::string& role, const MockTrackerOptions& options);

}  // namespace robocal::mock
