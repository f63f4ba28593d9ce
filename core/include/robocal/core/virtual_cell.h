// The virtual cell: a simulated "true" robot with hidden geometric errors and a laser tracker measuring it.
// Used by the tests, the experiment command and the mock-tracker client. Given a measurement cell, it measures
// only the configurations whose reflector the tracker can see, as a real tracker does (no beam, no point).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/cell.h"
#include "robocal/core/error_model.h"
#include "robocal/core/measurement.h"
#include "robocal/core/random.h"
#include "robocal/core/reflectors.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/transforms.h"

namespace robocal {

/// Magnitudes of the hidden errors and of the tracker's noise. Every draw comes from `seed`.
/// Defaults are those of an industrial robot measured by a laser tracker.
struct VirtualCellOptions {
  std::uint64_t seed = 1;
  /// 1-sigma of the joint sites' geometric errors (dx, dy, dz; rx, ry, rz): tenths of a mm, hundredths of a
  /// degree.
  double joint_translation_sigma_mm = 0.2;
  double joint_rotation_sigma_rad = 3.5e-4;  // 0.02 deg
  /// 1-sigma of the tool (reflector / TCP) offset errors.
  double tool_translation_sigma_mm = 0.5;
  double tool_rotation_sigma_rad = 1e-3;
  /// Tracker placement: its origin this far from the robot base (mm), at a random bearing, with a random yaw
  /// (full circle) and tilt (1-sigma `tracker_tilt_sigma_rad`). The fit does not know this transform.
  double tracker_distance_mm = 3000.0;
  double tracker_tilt_sigma_rad = 0.05;
  /// Tracker noise per shot (1-sigma): position per axis (mm), orientation per axis of the rotation vector
  /// (rad). Zero gives exact measurements. With noise.tracker set, a shot's position error is drawn from the
  /// tracker model's covariance at the true point instead (larger along and across the beam as the distance
  /// grows) and its orientation error from the model's orientation sigma. noise.repeatability_mm (ISO 9283 RP)
  /// > 0: each visit of a configuration (one Measure call) lands the tool displaced by an isotropic Gaussian of
  /// 1-sigma RP / kRepeatabilityPerSigma per axis, shared by all the visit's shots.
  MeasurementNoise noise{0.015, 1e-4, std::nullopt};
  /// Gross errors, as a real cell has them (a reflector in the wrong nest, a beam break, a robot that had not
  /// settled): each shot is, with probability outlier_rate, moved by a distance drawn uniformly from
  /// [outlier_min_mm, outlier_max_mm] in a uniformly drawn direction. Its index among the shots measured so
  /// far is recorded (outlier_shots()).
  double outlier_rate = 0.0;
  double outlier_min_mm = 1.0;
  double outlier_max_mm = 5.0;
  /// Robot error the geometric model cannot express (gear transmission and encoder errors): each joint's true
  /// angle is its command plus sum over the orders k (below) of a_k sin(k q) + b_k cos(k q), every a_k, b_k drawn
  /// with 1-sigma joint_harmonic_sigma_rad (after the other hidden errors, and only when positive, so a seed's
  /// geometric errors stay). Zero: the robot is exactly geometric.
  double joint_harmonic_sigma_rad = 0.0;
  /// The orders of those harmonics, 1 <= min <= max <= 4 (2..4 by default): 1..2 simulates errors a model with
  /// joint harmonics of order 2 (RobotModelSpec::error_terms) expresses exactly.
  int joint_harmonic_min_order = 2;
  int joint_harmonic_max_order = 4;
  /// Joint compliance (joint_errors.h): every revolute joint's true angle also moves by c_i tau_i, tau_i the gravity
  /// torque of the nominal robot's link masses and the shot's payload. Each c_i is drawn so that at the largest
  /// gravity torque the joint bears (no payload) it moves the tool, at the robot's reach, by
  /// compliance_deflection_mm times a uniform draw from [0.5, 1.5] (after the other hidden errors, so a seed's
  /// geometric errors stay). Needs a robot with masses. Zero: no compliance; at most 10 mm.
  double compliance_deflection_mm = 0.0;
  /// Shots per pose (the paper measures each pose 10 times).
  int shots_per_pose = 10;
  /// Reflectors on the tool (flange frame): with any, Measure shoots each of them `shots` times per visit
  /// (Measurement::reflector set), at its true position: the given one plus a hidden offset error of
  /// tool_translation_sigma_mm per axis (none for a fixed reflector, whose position is known). Empty: the tool
  /// point.
  std::vector<Reflector> reflectors;
  /// The measurement cell (cell.h, in the robot's base frame), e.g. PresetCellSpec(robot); unset: every
  /// configuration is measured and the tracker stands as drawn above. Set: the tracker's origin stands at the
  /// cell's tracker position instead (tracker_distance_mm is unused; bearing, yaw and tilt are drawn as before,
  /// so the hidden errors of a seed are those of the cell-less virtual cell), and a configuration is measured
  /// only when the cell finds it feasible (IsFeasible with the NOMINAL model: the geometry the planner saw; the
  /// hidden errors move the reflector by tenths of a mm, far below the clearances and angles that decide).
  /// The constructor builds it and throws std::invalid_argument (InvalidModelError) if it is invalid.
  std::optional<CellSpec> measurement_cell;

  bool IsValid(std::string* error) const;
};

/// The realistic cell's figures (docs/experiment.md, "The realistic cell"): a laser tracker with the datasheet
/// MPE of TrackerUncertainty's defaults, a robot of 0.03 mm ISO 9283 repeatability (a UR5e's datasheet
/// figure; large industrial arms state 0.02-0.08 mm), and 2 % of the shots gross errors of 1-5 mm.
inline constexpr double kRealisticRepeatabilityMm = 0.03;
inline constexpr double kRealisticOutlierRate = 0.02;
/// `options` with the realistic cell's tracker model, repeatability and outliers (seed, magnitudes of the hidden
/// errors, shots and measurement cell kept).
VirtualCellOptions Realistic(VirtualCellOptions options);

/// The realistic cell's reflector nests for position measurements: three on a tool plate, 60 mm off the flange
/// axis and 20 mm out (not on one line, so that they observe the tool's orientation), held at their positions
/// (measured on the plate: the fit calibrates the tool point through them).
std::vector<Reflector> RealisticReflectors();

/// A simulated cell: the true robot is `nominal` with the tracker as its world frame (T_world_base = the
/// hidden tracker placement) and hidden error parameters on every site.
class VirtualCell {
 public:
  /// Draws the hidden errors and tracker placement from options.seed. Throws std::invalid_argument if the
  /// options are invalid.
  VirtualCell(const RobotModel& nominal, const VirtualCellOptions& options = {});

  const RobotModel& nominal() const { return nominal_; }
  /// The true robot's model (nominal geometry, T_world_base = true tracker -> base) and its error parameters
  /// (num_error_parameters: mm, rad). Hidden from identification; exposed for tests and reports.
  const RobotModel& true_model() const { return true_model_; }
  const Eigen::VectorXd& true_errors() const { return true_errors_; }
  /// The reflectors' hidden offset errors (3 per reflector, flange frame, mm; zero for fixed ones).
  const Eigen::VectorXd& true_reflector_errors() const { return true_reflector_errors_; }
  /// The unmodelled joint error at command q (joint_harmonic_sigma_rad; rad per joint, zero without it).
  Eigen::VectorXd JointError(const Eigen::VectorXd& q) const;
  /// The true harmonic amplitudes (rad): row = joint, column = order - joint_harmonic_min_order; empty without
  /// joint_harmonic_sigma_rad.
  const Eigen::MatrixXd& true_harmonic_sin() const { return harmonic_sin_; }
  const Eigen::MatrixXd& true_harmonic_cos() const { return harmonic_cos_; }
  /// The true joint compliances (rad per N*m, per joint; zero without compliance_deflection_mm).
  const Eigen::VectorXd& true_compliance() const { return true_compliance_; }
  /// The true robot's joint deflection at command q under `payload`: JointError plus the compliance's.
  Eigen::VectorXd JointDeflection(const Eigen::VectorXd& q, const Payload& payload = Payload()) const;
  const VirtualCellOptions& options() const { return options_; }

  /// Noise-free tool pose of the true robot at joints q, tracker frame. Throws std::invalid_argument for a q of
  /// the wrong size or with a non-finite value (Measure too).
  Transform TruePose(const Eigen::VectorXd& q, const Payload& payload = Payload()) const;
  /// Where the true robot's tool lands when commanded q: TruePose displaced by one draw of the robot's
  /// repeatability (noise.repeatability_mm; none when 0, and then nothing is drawn). What a validation of the
  /// calibrated robot sees, by an ideal observer.
  Transform Land(const Eigen::VectorXd& q, const Payload& payload = Payload());

  /// The built measurement cell, or nullptr when options.measurement_cell is unset.
  const Cell* measurement_cell() const { return cell_ ? &*cell_ : nullptr; }
  /// Whether the tracker can measure the tool at joints q: always without a measurement cell, else
  /// IsFeasible(nominal, cell, q). Throws std::invalid_argument for a q of the wrong size.
  bool Measurable(const Eigen::VectorXd& q) const;

  /// `shots` noisy tracker shots of the tool at joints q (shots <= 0 means options.shots_per_pose); none, and
  /// unmeasured() counts one more, when q is not Measurable. Noise is drawn from the cell's own generator, so a
  /// sequence of calls is reproducible from the seed (an unmeasured configuration draws nothing).
  /// Every shot carries `payload` (Measurement::payload), and the true robot deflects under it.
  std::vector<Measurement> Measure(const Eigen::VectorXd& q, int shots = 0, const Payload& payload = Payload());

  /// Measure() for every configuration, concatenated in order. If `lost` is given, it receives the indices of
  /// the configurations that were not measurable (in order; empty when all were).
  std::vector<Measurement> MeasureAll(const std::vector<Eigen::VectorXd>& configurations, int shots = 0,
                                      std::vector<int>* lost = nullptr, const Payload& payload = Payload());

  /// From here on, noise (and outliers and repeatability) is drawn from a generator seeded by options.seed and
  /// `stream` (stream 0 is not the construction's). Two processes that simulate one cell, one shooting the
  /// calibration poses and one the validation poses, thus draw independent noise for the same hidden robot.
  void StartNoiseStream(std::uint64_t stream);

  /// Configurations Measure() was asked for and could not measure, since construction.
  int unmeasured() const { return unmeasured_; }
  /// Indices of the shots given an outlier, counting every shot Measure() returned since construction (for
  /// MeasureAll on a new cell: indices into its result).
  const std::vector<int>& outlier_shots() const { return outlier_shots_; }
  /// Shots Measure() returned since construction.
  int shots() const { return shots_; }

 private:
  RobotModel nominal_;
  RobotModel true_model_;
  Eigen::VectorXd true_errors_;
  Eigen::VectorXd true_reflector_errors_;
  std::vector<Eigen::Vector3d> true_in_tool_;
  // Per joint, the harmonics: sine and cosine amplitudes for orders joint_harmonic_min_order..4 (rad).
  Eigen::MatrixXd harmonic_sin_, harmonic_cos_;
  Eigen::VectorXd true_compliance_;
  VirtualCellOptions options_;
  Rng rng_;
  std::optional<Cell> cell_;
  int unmeasured_ = 0;
  int shots_ = 0;
  std::vector<int> outlier_shots_;
};

}  // namespace robocal
