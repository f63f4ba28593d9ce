// Drift checks: does a robot still hold its calibration? A few poses measured now are compared with what the
// calibrated model predicts, against the scatter the calibration itself left (docs/drift.md).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "robocal/core/identification.h"
#include "robocal/core/measurement.h"
#include "robocal/core/robot_model.h"

namespace robocal {

/// The parameters of a frames-only fit ("scope": "frames"): the base site's six, the tool site's translations, and
/// the tool's rotations the measurements see (a point none, a point and an axis two, a pose or several nests three).
std::vector<int> FrameParameters(const RobotModel& model, MeasurementType type, bool reflectors = false);

struct DriftCheckOptions {
  MeasurementType measurement_type = MeasurementType::kPose;
  /// The noise the residuals are whitened with: the tracker's, the robot's repeatability and the calibration's
  /// model error (MeasurementNoise::model_error_mm, model_error_rad per row), as the calibration's fit weighted.
  MeasurementNoise noise;
  /// Re-register the base and the tool on the check's shots (the tracker or the probe moved since the
  /// calibration); false: the model's own frames are the calibration's (the tracker stayed).
  bool register_frames = true;
  /// The stated false alarm rate: the probability that a robot which holds its calibration is called drifted.
  /// Split evenly between the two tests below. In (0, 0.5).
  double false_alarm_rate = 0.05;
  /// The calibration's own shots (tracker frame of its cell) and its registered tracker -> base transform: the
  /// checked robot at that base reproduces the calibration there, so its residuals are the calibration's own scatter.
  /// Their covariance (rows scaled by `noise`'s row weights, in the base frame) whitens every residual; scaled by
  /// null_correction, (R + p) / (R - p) for the calibration's R rows and p parameters (an in-sample residual's
  /// variance falls short of the noise's by p / R on average, a new pose's exceeds it by as much), they stand for a
  /// new pose's.
  std::vector<Measurement> reference;
  Transform reference_T_world_base = Transform::Identity();
  double null_correction = 1.0;
  /// Draws of the paired bootstrap that gives both tests' null distributions, seeded.
  int null_draws = 2000;
  std::uint64_t seed = 1;
  /// Error parameters tested one at a time (indices into the model's); empty: every geometric parameter the
  /// registration does not estimate, joint offsets first (each alone beside the frames; one the frames already
  /// hold is left out by its fit).
  std::vector<int> candidates;

  bool IsValid(std::string* error) const;
};

/// A parameter that explains the check's residuals: its change fitted beside the frames (mm or rad, linearised at
/// the registration), its std, and the drop of the whitened squared residual sum it brings (chi-square with 1
/// degree of freedom if it did not change). `equivalent`: the other parameters the check's poses cannot tell from
/// it (their directions within 5.7 deg of its in the residuals' space), e.g. a joint 1 offset and a turn of the base.
struct DriftSuspect {
  int index = -1;
  std::string name;
  double change = 0.0;
  double std = 0.0;
  double chi2_drop = 0.0;
  std::vector<std::string> equivalent;
};

struct DriftCheck {
  bool drifted = false;
  /// Test 1, the residual level: the whitened squared residual sum per degree of freedom of the check (rows less
  /// the registration's parameters). Both tests are judged against their null distributions by a paired bootstrap:
  /// sets of as many of the calibration's own shots, each with its residual and its Jacobian (so that the robot's
  /// unmodelled error comes with the directions it takes at its poses); each threshold is the
  /// (1 - false_alarm_rate / 2) quantile.
  double statistic = 0.0;
  double threshold = 0.0;
  /// The share of the null draws at or above the statistic.
  double p_value = 1.0;
  /// Test 2, one parameter: the largest chi2_drop over the candidates (the score test of each beside the frames,
  /// in the calibration's residual metric), against the same quantile of the largest drop in the bootstrap.
  double largest_drop = 0.0;
  double drop_threshold = 0.0;
  int num_candidates = 0;
  /// The candidates whose drop exceeds drop_threshold, largest first (of parameters the poses cannot tell apart, a
  /// joint offset first: the usual cause); when only the level test fails, the three largest drops.
  std::vector<DriftSuspect> suspects;
  /// The frames as registered (or kept): tracker -> base and flange -> tool; the residuals against them.
  Transform T_world_base = Transform::Identity();
  Transform T_flange_tool = Transform::Identity();
  int num_measurements = 0;
  int dof = 0;
  double rms_position_mm = 0.0;
  /// The position RMS the calibration predicts per shot (tracker, repeatability and model error).
  double expected_rms_position_mm = 0.0;
  std::string message;
};

/// Checks `shots` (tracker frame) of the calibrated robot `model` (its T_world_base and tool the calibration's when
/// frames are kept). Throws std::invalid_argument for invalid options or shots of the wrong size; too few shots for
/// the registration (fewer rows than its parameters + 1) give a message and drifted = false with statistic NaN.
DriftCheck CheckDrift(const RobotModel& model, const std::vector<Measurement>& shots, const DriftCheckOptions& options);

}  // namespace robocal
