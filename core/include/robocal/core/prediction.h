// The accuracy a calibrated robot will have at given joints: a bound on its tool position error that holds with a
// given probability (95 % by default), from the fit's parameter covariance and its estimated model error
// (docs/compensation.md, "Predicted accuracy").
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "robocal/core/identification.h"
#include "robocal/core/robot_model.h"

namespace robocal {

struct PredictionOptions {
  /// The probability with which the bound holds: the bound is the quantile of |e| at it. In [0.8, 0.9999].
  double probability = 0.95;
  /// The robot's ISO 9283 repeatability RP (mm; the campaign's `repeatability_mm`): an isotropic 1-sigma of
  /// RP / kRepeatabilityPerSigma per axis is added, since the robot scatters by that much about where the model
  /// puts it however well it is calibrated. 0: none. In [0, 100].
  double repeatability_mm = 0.0;

  bool IsValid(std::string* error) const;
};

/// The predicted position error of the tool point at one joint vector, as a Gaussian e ~ N(0, S) in the
/// calibration's world (tracker) frame, and the bound on |e|.
struct PositionErrorPrediction {
  /// False when the calibration has no covariance of its parameters (a failed fit: the nominal robot, whose
  /// error nothing here knows; or a fit stored before fits kept their covariance). Everything below is then NaN.
  bool available = false;
  /// J C J': the identified parameters' covariance C (Calibration::covariance) carried to the tool position
  /// through the calibrated model's position Jacobian J at the joints (mm^2).
  Eigen::Matrix3d parameter_covariance_mm2 = Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// The variance per axis of what the geometric model does not explain: the fit's model error
  /// (IdentificationSummary::model_error_mm^2 / 3; zero when the fit did not estimate one) plus the repeatability's
  /// (mm^2). Isotropic: the fit estimates one variance for all position rows.
  double unmodelled_variance_mm2 = std::numeric_limits<double>::quiet_NaN();
  /// S = parameter_covariance_mm2 + unmodelled_variance_mm2 I (mm^2).
  Eigen::Matrix3d covariance_mm2 = Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// sqrt(trace S): the RMS of |e| (mm).
  double rms_mm = std::numeric_limits<double>::quiet_NaN();
  /// The options.probability quantile of |e| (mm): PositionErrorQuantile(S, probability).
  double bound_mm = std::numeric_limits<double>::quiet_NaN();
};

/// The prediction at joints `q` (rad / mm, the calibrated model's joint count) under `payload` (a calibration with
/// compliance deflects under it; the Jacobian is taken at the deflected joints). The tool point is the
/// calibration's (Calibration::T_flange_tool); the frame is the calibration's world (tracker) frame, whose
/// registration to the robot base is among the identified parameters (the base site's errors), so a tool
/// position in the tracker frame carries the base's uncertainty. Reflector offsets of the fit do not move the
/// tool point and do not enter.
///
/// Throws std::invalid_argument for invalid options, a q of the wrong size or not finite, or a covariance whose
/// size is not that of calibration.parameters (a calibration built by hand wrongly).
PositionErrorPrediction PredictPositionError(const Calibration& calibration, const Eigen::VectorXd& q,
                                             const Payload& payload = Payload(), const PredictionOptions& options = {});

/// PredictPositionError(...).bound_mm for every joint vector (NaN for one of the wrong size or not finite: a
/// result without joints), under payloads[i], or payloads[0] for all, or none when `payloads` is empty; on
/// `threads` threads (0: as many as the hardware runs at once). The bounds are in input order whatever the thread
/// count. Throws what PredictPositionError throws, for the first joint vector (in order) that throws.
std::vector<double> PredictPositionErrorBounds(const Calibration& calibration,
                                               const std::vector<Eigen::VectorXd>& joints,
                                               const std::vector<Payload>& payloads,
                                               const PredictionOptions& options = {}, int threads = 0);

/// The `probability` quantile r of |e| for e ~ N(0, S): P(|e| <= r) = probability. S is a symmetric positive
/// semidefinite 3x3 matrix (mm^2; r in mm). Computed for the anisotropic S as it is (not the isotropic chi
/// approximation): with S's eigenvalues l_i, e = sqrt(rho) u in S's eigenbasis, P(|e| <= r) is the mean over the
/// unit sphere's directions u of the chi(3) distribution function at r / sqrt(sum l_i u_i^2), integrated by a
/// product rule on one octant (Gauss-Legendre in u_3, the midpoint rule in the azimuth; the integrand is smooth
/// and periodic there), and solved for r by safeguarded Newton steps within the bracket
/// [chi(1) quantile, chi(3) quantile] * sqrt(max l_i). Relative error below 2e-5 for every S (against a fine rule,
/// and tested against closed forms and a Monte Carlo). Isotropic S = s^2 I gives the chi(3) quantile times s (2.7955 s
/// at 95 %), a rank-1 S the normal two-sided quantile times its sigma (1.9600 s). S = 0 gives 0. Throws
/// std::invalid_argument for a probability outside [0.8, 0.9999] or an S that is not finite, not symmetric, or has a
/// negative eigenvalue beyond rounding.
double PositionErrorQuantile(const Eigen::Matrix3d& covariance_mm2, double probability = 0.95);

}  // namespace robocal
