// Identification: the robot's geometric error parameters from tracker measurements, by weighted nonlinear
// least squares (Levenberg-Marquardt), after registering the unknown tracker -> base frame.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "robocal/core/error_model.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/measurement.h"
#include "robocal/core/priors.h"
#include "robocal/core/reflectors.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"
#include "robocal/core/transforms.h"

namespace robocal {

/// The rigid transform T (rotation + translation, no scale) minimising sum |T * from_i - to_i|^2
/// (Kabsch / Umeyama). Needs at least 3 points not on one line; throws std::invalid_argument otherwise or on
/// size mismatch.
Transform RegisterPoints(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to);

/// Beyond these an identified error is no longer a calibration of the nominal geometry: a fit that identifies one
/// is DEGRADED and says so (mm; rad, 10 degrees).
inline constexpr double kImplausibleErrorMm = 100.0;
inline constexpr double kImplausibleErrorRad = 0.17453292519943295;

struct IdentificationOptions {
  MeasurementType measurement_type = MeasurementType::kPose;
  /// 1-sigma tracker noise; residual rows are divided by it (position mm, orientation rad).
  MeasurementNoise noise;
  /// Several reflectors on the tool (position measurements only; reflectors.h): each measurement names the one
  /// it shot (Measurement::reflector), and the fit estimates the free reflectors' offset errors beside the
  /// model's parameters. Empty: every shot is of the tool point.
  std::vector<Reflector> reflectors;
  /// Error parameters to estimate (indices into the model's parameters, then the reflectors' offsets:
  /// reflectors.h's index space; ascending). Empty: the identifiable set from FindIdentifiableParameters(model,
  /// measurement_type) with `identifiability` options and these reflectors.
  std::vector<int> parameters;
  IdentifiabilityOptions identifiability;
  /// Estimate the tracker -> base transform by point-set registration of the measured positions onto the
  /// nominal model's before the fit. False: start from the model's own T_world_base.
  bool register_base = true;
  /// Stop when an iteration changes the cost by less than `function_tolerance` relative.
  double function_tolerance = 1e-12;
  /// Stop when max |J' r| (weighted) < gradient_tolerance.
  double gradient_tolerance = 1e-10;
  /// Stop when the step is smaller than parameter_tolerance * (|x| + parameter_tolerance).
  double parameter_tolerance = 1e-12;
  int max_iterations = 100;
  /// The robot error the geometric model does not explain (docs/identification.md, "Model error"): estimated
  /// beside the tracker's noise by variance-component estimation, one component for the position rows and one
  /// for the orientation (or axis) rows, each a 1-sigma per row shared by the shots of one pose
  /// (MeasurementNoise::model_error_mm, model_error_rad). The fit is then weighted, its covariance scaled and
  /// its outliers judged with the tracker's covariance plus these. False: the noise model is taken as given
  /// (noise.model_error_* included) and a scatter far beyond it is DEGRADED.
  bool estimate_model_error = true;
  /// The robust fit (docs/identification.md, "Outliers"): after the least-squares fit every measurement's
  /// studentised residual z is computed (its whitened residual against the covariance of a residual, which
  /// accounts for its leverage: z^2 = a' (I - H)^-1 a, or (I + H)^-1 for a measurement the fit left out); those
  /// with z^2 above the chi-square quantile of their rows at 1 - outlier_probability are excluded and the fit
  /// repeated, until the excluded set stops changing. A measurement excluded in one round comes back when the
  /// next fit explains it. Without a model error (not estimated, or estimated as zero) z is divided by the
  /// median-based scale of all of them (at least 0.001) where that is below 1: data more precise than the noise
  /// model says are judged by their own scatter. False: plain least squares over every measurement.
  bool reject_outliers = true;
  /// The probability that a clean measurement is flagged (per measurement), in (0, 0.1].
  double outlier_probability = 1e-3;
  /// Parameter priors (priors.h, docs/identification.md "Parameter priors"): each estimated parameter k with a
  /// finite prior standard deviation sigma_k (PriorStd(model, *priors, reflectors)) gets the row x_k / sigma_k
  /// beside the whitened measurements, so that the fit minimises sum of squared whitened residuals + sum
  /// (x_k / sigma_k)^2: the MAP estimate under a zero-mean Gaussian prior. Levenberg-Marquardt, the rank test,
  /// the covariance ((J'WJ + P)^-1 sigma_hat^2, P = diag(1 / sigma_k^2)), sigma_hat's degrees of freedom (the
  /// rows less the trace of the hat matrix), the model error's redundancies and the studentised residuals all
  /// see those rows. Which parameters are estimated is chosen as without priors (structurally unidentifiable
  /// ones stay dropped); a parameter the data leave open but its prior determines passes the rank test and is
  /// listed in IdentificationSummary::prior_determined. Unset (the default): no priors, the fit is plain
  /// (weighted) least squares.
  std::optional<ParameterPriors> priors;
  /// Called after every Levenberg-Marquardt iteration that did not converge, with iterations / max_iterations;
  /// returning false cancels the fit: it stops with NO_CONVERGENCE, message "cancelled", and the best
  /// parameters so far with their covariance (the accepted steps only ever lower the cost).
  std::function<bool(double fraction_done)> progress;

  bool IsValid(std::string* error) const;
};

/// One estimated parameter: value and 1-sigma standard deviation, in mm (translations) or rad (rotations).
struct IdentifiedParameter {
  int index = -1;
  std::string name;
  double value = 0.0;
  double std = 0.0;
};

/// A measurement the robust fit excluded.
struct OutlierMeasurement {
  /// Why it was excluded: the robust fit found its residual too large, or it is a stale tracker reading
  /// (Measurement::stale), left out before any fit.
  enum class Cause { kResidual, kStale };
  /// Index into the measurements given to Identify, and its reflector (Measurement::reflector).
  int measurement = -1;
  int reflector = -1;
  /// The studentised residual (sigma units, against the final fit; over the robust scale where that applies); for
  /// a stale shot its whitened residual against the final fit (the fit's noise, model error included).
  double normalized_residual = 0.0;
  Cause cause = Cause::kResidual;
};

/// What makes a tracker reading stale (FlagStaleShots): its measurement within `position_mm` (and, measuring
/// orientation, `angle_rad`) of the shot before it, while a joint's command changed by more than `joint_rad`
/// (revolute) or `joint_mm` (prismatic).
struct StaleShotTolerance {
  double position_mm = 0.1;
  double angle_rad = 0.01 * 3.14159265358979323846 / 180.0;
  double joint_rad = 0.01 * 3.14159265358979323846 / 180.0;
  double joint_mm = 0.01;
};

/// Flags stale tracker readings in `shots` (in the order they were taken): a shot whose measurement repeats the
/// previous shot's within `tolerance` although the joints moved (a joint's command changed beyond the tolerance;
/// on the IPA UR10 the stale rows follow a change of arm configuration to the same tool pose, where a real reading
/// differs by tenths of a mm). Measuring positions only, the nominal robot must also move the point by more than
/// max(10 x tolerance.position_mm, 3 x repeatability_mm) or turn the tool by more than 10 x tolerance.angle_rad: a
/// point on the last joint's axis stays where it is as that joint turns. Shots of different reflectors are not
/// compared. `before`, if not null, is the shot taken just before shots[0]. Returns one flag per shot.
std::vector<char> FlagStaleShots(const RobotModel& nominal, const std::vector<Measurement>& shots, MeasurementType type,
                                 double repeatability_mm, const StaleShotTolerance& tolerance = {},
                                 const Measurement* before = nullptr);

/// Residuals of a model against the measurements (measured - model).
struct ResidualStatistics {
  int num_measurements = 0;
  double rms_position_mm = 0.0;
  double max_position_mm = 0.0;
  /// Orientation (pose) or tool-axis (position_axis) angle error; zero for position measurements.
  double rms_orientation_rad = 0.0;
  double max_orientation_rad = 0.0;
  /// sqrt(sum of squared noise-weighted residuals / number of rows).
  double rms_weighted = 0.0;
};

/// One model of the choice by cross-validation (model_choice.h): its joint terms, how many parameters it has
/// (the model's, geometric and joint terms), and its held-out position error over the folds.
struct ModelCandidate {
  JointErrorTerms terms;
  int num_parameters = 0;
  /// Mean and RMS over every held-out measurement of the distance between measured and predicted position
  /// (E_xyz, mm), and the standard error of the mean: the standard deviation of the folds' means over
  /// sqrt(folds).
  double cv_mean_mm = 0.0;
  double cv_rms_mm = 0.0;
  double cv_standard_error_mm = 0.0;
  /// Folds whose training fit failed (FAILURE) or found an implausible joint term (kImplausibleCompliance...):
  /// a candidate with any is not eligible, and `note` says why.
  int failed_folds = 0;
  std::string note;
};

/// One candidate of priors: auto (model_choice.h): a scale of the priors and its held-out position error over the
/// folds (as ModelCandidate's).
struct PriorScaleCandidate {
  /// ParameterPriors::scale; +infinity is the fit without priors (the limit of priors infinitely wide).
  double scale = 0.0;
  double cv_mean_mm = 0.0;
  double cv_rms_mm = 0.0;
  double cv_standard_error_mm = 0.0;
  int failed_folds = 0;
  std::string note;
};

struct Calibration;

/// The model error a fit estimated (IdentificationOptions::estimate_model_error): whether it was estimated, and
/// its RMS as a 3-D position error (mm, sqrt(3) times the 1-sigma per axis) and as an angle (rad: sqrt(3), or
/// sqrt(2) for axis rows, times the 1-sigma per row; 0 for position measurements). Beside them the tracker's own
/// RMS over the same measurements, from the noise model.
struct ModelErrorEstimate {
  bool estimated = false;
  double model_error_mm = 0.0;
  double model_error_rad = 0.0;
  double tracker_rms_mm = 0.0;
  double tracker_rms_rad = 0.0;
};

struct IdentificationSummary {
  Termination termination = Termination::kFailure;
  std::string message = "not run";
  /// options.progress asked to stop: NO_CONVERGENCE with the best solution so far (message "cancelled ...").
  bool cancelled = false;
  MeasurementType measurement_type = MeasurementType::kPose;
  /// Measurements the fit used: the ones given less the excluded outliers.
  int num_measurements = 0;
  /// Distinct joint configurations among the measurements (repeated shots count once).
  int num_poses = 0;
  int num_residuals = 0;
  int num_parameters = 0;
  int iterations = 0;
  double initial_cost = 0.0;  // 0.5 * sum of squared weighted residuals, after base registration
  double final_cost = 0.0;
  /// Unit-weight standard deviation estimated from the residuals: sqrt(2 final_cost / (rows - parameters)).
  double sigma_hat = 0.0;
  /// Residuals of the nominal model (with the registered base) and of the calibrated model.
  ResidualStatistics before;
  ResidualStatistics after;
  /// Condition number of the weighted, column-norm-scaled Jacobian at the solution, and its scaling
  /// (DescribeScaling of options.noise with ColumnScaling::kColumnNorm).
  double condition_number = 0.0;
  /// That Jacobian's singular values, descending (condition_number is the first over the last); empty on FAILURE.
  Eigen::VectorXd singular_values;
  std::string scaling;
  /// Parameters not estimated (unidentifiable) and why.
  std::vector<DroppedParameter> dropped;
  /// The robust fit (IdentificationOptions::reject_outliers): the excluded measurements in index order, the
  /// threshold on the normalised residual (sqrt of the chi-square quantile), the robust scale (median-based,
  /// 1 when the noise model's sigmas are right), the number of fits, and the parameters of the plain
  /// least-squares fit over every measurement (empty when nothing was excluded).
  std::vector<OutlierMeasurement> outliers;
  double outlier_threshold = 0.0;
  double robust_scale = 0.0;
  int rejection_rounds = 0;
  std::vector<IdentifiedParameter> parameters_with_outliers;
  /// The model error (IdentificationOptions::estimate_model_error).
  ModelErrorEstimate model_error;
  /// The model the fit used (the nominal model's RobotModelSpec::error_terms) and, when it was chosen by
  /// cross-validation (IdentifyWithModelChoice), every candidate's held-out error, the folds and the chosen
  /// candidate's index; empty candidates otherwise.
  JointErrorTerms model;
  /// Joint terms beyond kImplausibleComplianceRadPerNm / kImplausibleHarmonicRad ("name value unit").
  std::vector<std::string> implausible_joint_terms;
  std::vector<ModelCandidate> model_candidates;
  int model_folds = 0;
  int model_chosen = -1;
  /// The effective number of parameters: the trace of the hat matrix, n - tr(N^-1 P'P) with N the information
  /// with the penalty rows P of the priors and the joint maps (num_parameters without either). sigma_hat's
  /// degrees of freedom are the residual rows less it.
  double effective_parameters = 0.0;
  /// Parameter priors (IdentificationOptions::priors): how many estimated parameters had one, and those the prior
  /// rather than the data determined (PriorDeterminedParameter: posterior variance at unit variance factor above
  /// half the prior variance), in index order.
  int num_priors = 0;
  std::vector<PriorDeterminedParameter> prior_determined;
  /// priors: auto (IdentifyWithPriorChoice, model_choice.h): every candidate scale's held-out error over the folds,
  /// the folds and the chosen candidate's index; empty candidates otherwise.
  std::vector<PriorScaleCandidate> prior_candidates;
  int prior_folds = 0;
  int prior_chosen = -1;
  double seconds = 0.0;

  std::string BriefReport() const;
  /// The figures of the fit; with `estimates` (its calibration: Calibration::FullReport) also the estimated base
  /// and tool frames and the parameter table, which the calibration holds and the summary does not repeat.
  std::string FullReport(const Calibration* estimates = nullptr) const;
};

/// A calibrated robot: the nominal geometry with the registered tracker -> base frame, plus the identified
/// error parameters. Forward kinematics of the calibrated robot is ForwardKinematics(model, q, errors, &ws).
struct Calibration {
  /// The nominal model with T_world_base replaced by the registered tracker -> base transform.
  RobotModel model;
  /// All error parameters (num_error_parameters; mm, rad); zero where not estimated.
  Eigen::VectorXd errors;
  /// The estimated parameters with standard deviations (sigma_hat^2 (J'J)^-1, weighted J).
  std::vector<IdentifiedParameter> parameters;
  /// Covariance of the estimated parameters, in the order of `parameters`.
  Eigen::MatrixXd covariance;
  /// Effective tracker -> base and flange -> tool transforms including the identified base and tool errors.
  Transform T_world_base = Transform::Identity();
  Transform T_flange_tool = Transform::Identity();
  /// The fit's reflectors with their identified positions (flange frame, relative to the NOMINAL tool
  /// frame: a point of reflector k is at ForwardKinematics(model, q, errors) * ReflectorsInTool(model,
  /// reflectors, {})[k]); empty without reflectors.
  std::vector<Reflector> reflectors;
  IdentificationSummary summary;

  /// The summary's full report with the estimated frames and the parameter table.
  std::string FullReport() const { return summary.FullReport(this); }
};

/// Identifies `nominal`'s error parameters from `measurements` (tracker frame).
///
/// Programmer errors (wrong joint vector sizes, invalid options) throw std::invalid_argument. Problems of the
/// data give summary.termination = FAILURE and a message saying what is wrong, never NaN: non-finite values
/// (naming the measurement), too few poses for the parameters, degenerate (rank-deficient) configurations.
/// On FAILURE `errors` is zero and `model` the nominal one.
Calibration Identify(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                     const IdentificationOptions& options = {});

/// `robot` with the joint error terms `terms` for a fit over `measurements`: with joint maps (JointMapTerms),
/// each map's grid is placed over the range its joint takes in the measurements (knots every knot_spacing_rad,
/// centred on that range; one interval at least), or, when the joint already holds a map of that spacing, on the
/// held map's grid (so the fitted coefficients add to the held ones). Without maps: robot.WithErrorTerms(terms).
/// Throws InvalidModelError for terms the robot cannot take (an unknown or prismatic joint, a spacing out of range).
RobotModel WithTermsFor(const RobotModel& robot, const JointErrorTerms& terms,
                        const std::vector<Measurement>& measurements);

/// The noise a fit weighted with: `noise` with the model error `summary` estimated (model_error_mm over sqrt(3)
/// per position axis; model_error_rad over sqrt(3), or sqrt(2) for axis rows, per orientation row); `noise`
/// itself when the summary estimated none.
MeasurementNoise FittedNoise(const IdentificationSummary& summary, MeasurementNoise noise);

/// The upper tail probability of the chi-square distribution with `dof` degrees of freedom at x (exact, closed
/// form for integer dof), and its quantile: the x with ChiSquareSurvival(dof, x) = probability.
double ChiSquareSurvival(int dof, double x);
double ChiSquareQuantile(int dof, double upper_probability);

/// The key of a measurement's pose, a configuration under a payload: its joints, then the payload's mass and centre
/// of mass (a payload of no mass is none, wherever its centre). Shots with equal keys are shots of one pose.
Eigen::VectorXd PoseKey(const Measurement& measurement);
/// Lexicographic order on joint vectors and pose keys.
struct LexicographicLess {
  bool operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const {
    return std::lexicographical_compare(a.data(), a.data() + a.size(), b.data(), b.data() + b.size());
  }
};

/// Residual statistics of (model, errors) against measurements of `type`.
/// With reflectors, `reflectors_in_tool` (ReflectorsInTool) gives each Measurement::reflector's point.
ResidualStatistics ComputeResidualStatistics(const RobotModel& model, const Eigen::VectorXd& errors,
                                             const std::vector<Measurement>& measurements, MeasurementType type,
                                             const MeasurementNoise& noise,
                                             const std::vector<Eigen::Vector3d>& reflectors_in_tool = {});

}  // namespace robocal
