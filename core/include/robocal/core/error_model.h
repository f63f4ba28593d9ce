// The geometric error model: measurement types, their residual rows, and the identification Jacobian.
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>

#include "robocal/core/kinematics.h"
#include "robocal/core/robot_model.h"

namespace robocal {

/// What the tracker measures at each configuration.
enum class MeasurementType {
  /// Tool point position: 3 rows (mm).
  kPosition,
  /// Position plus the tool axis direction (the tool frame's z axis, the paper's u_x, u_y, u_z): 3 rows (mm)
  /// plus the 2 independent components of the axis error (rad), in a tangent basis of the model's axis.
  kPositionAxis,
  /// Full pose: 3 position rows (mm) and 3 orientation rows (rotation vector, rad, tracker frame).
  kPose,
};

const char* ToString(MeasurementType type);
/// Parses "position", "position_axis", "pose"; returns false for anything else.
bool ParseMeasurementType(const std::string& text, MeasurementType* type);

/// Residual rows per measurement: 3, 5 or 6.
int MeasurementRows(MeasurementType type);

/// A laser tracker's uncertainty as its datasheet states it: maximum permissible errors (MPE, ISO 10360-10)
/// that grow with the distance from the tracker, different along the beam (the distance meter, ADM or
/// interferometer) and across it (the angle encoders). Typical datasheet figures for a 1.5" SMR are
/// +-(10 um + 0.3 um/m) radial and +-(15 um + 6 um/m) transverse, and typical errors are about half the MPE
/// (mpe_sigmas = 2). These are the defaults.
///
/// The 1-sigma position covariance of a point p (mm, tracker frame: the tracker's beam origin at 0) is
///   C(p) = s_r^2 u u' + s_t^2 (I - u u'),  u = p / |p|,
///   s_r = (radial_um + radial_um_per_m * |p| / 1000) / 1000 / mpe_sigmas (mm), s_t likewise with transverse_*,
/// and a 6-DoF probe's orientation error is orientation_deg / mpe_sigmas per axis. Figures that are already
/// 1-sigma values are given with mpe_sigmas = 1.
struct TrackerUncertainty {
  double radial_um = 10.0;
  double radial_um_per_m = 0.3;
  double transverse_um = 15.0;
  double transverse_um_per_m = 6.0;
  double orientation_deg = 0.01;
  double mpe_sigmas = 2.0;

  /// 1-sigma along the beam / across it (mm) at `distance_mm` from the tracker.
  double RadialSigmaMm(double distance_mm) const;
  double TransverseSigmaMm(double distance_mm) const;
  /// 1-sigma orientation error per axis (rad).
  double OrientationSigmaRad() const;
  /// C(p) above (mm^2). At the tracker's own origin (|p| = 0, no beam direction) it is s_t^2 I.
  Eigen::Matrix3d PositionCovariance(const Eigen::Vector3d& point_mm) const;
  /// L with L L' = C(p) (symmetric: s_r u u' + s_t (I - u u')), to draw errors as L n, n ~ N(0, I).
  Eigen::Matrix3d PositionSqrt(const Eigen::Vector3d& point_mm) const;
  /// W with W' W = C(p)^-1 (symmetric: u u' / s_r + (I - u u') / s_t): W r is a residual in sigmas.
  Eigen::Matrix3d PositionWhitening(const Eigen::Vector3d& point_mm) const;
  /// The constants in [kMinTrackerUm, 1000] um, the slopes in [0, 1000] um/m, the orientation in
  /// [kMinTrackerOrientationDeg, 90] deg, mpe_sigmas in [0.1, 10]; else false and the field.
  bool IsValid(std::string* error) const;
};

/// The smallest constants TrackerUncertainty takes (um; deg): a thousandth of a micrometre, a nanodegree.
inline constexpr double kMinTrackerUm = 1e-3;
inline constexpr double kMinTrackerOrientationDeg = 1e-9;

/// Where a tracker is assumed to stand when a covariance is needed without knowing where it stands (planning
/// without a cell): 3 m, the distance of the preset cells and of the virtual cell.
inline constexpr double kAssumedTrackerDistanceMm = 3000.0;

/// ISO 9283 repeatability RP (mean + 3 std of the distances to the mean position) over the 1-sigma per axis of an
/// isotropic 3-D Gaussian: the distance is sigma times a chi variable of 3 degrees of freedom, mean
/// 2 sqrt(2 / pi) = 1.5958, std sqrt(3 - 8 / pi) = 0.6734, and 1.5958 + 3 * 0.6734 = 3.615.
inline constexpr double kRepeatabilityPerSigma = 3.615;

/// The noise of a measurement, used to weight (whiten) residual rows: the tracker's, and the robot's
/// repeatability.
///
/// Without `tracker` every position row has 1-sigma position_mm and every orientation or axis row
/// orientation_rad (row weight = 1 / sigma). With `tracker`, position_mm and orientation_rad are unused: a
/// measurement's three position rows are whitened by the tracker model's covariance at the measured point and
/// its orientation rows divided by the tracker's orientation sigma.
///
/// repeatability_mm > 0 (ISO 9283 RP of the robot) adds an isotropic 1-sigma RP / kRepeatabilityPerSigma per
/// position axis that the shots of one visit share: the robot stands where it stands while the tracker shoots
/// it several times. The fit treats the shots of one joint configuration as one visit.
///
/// model_error_mm and model_error_rad (1-sigma per position axis, per orientation or axis row) are the robot's
/// error that the geometric model does not explain (compliance, gear and encoder errors, thermal drift): like
/// the repeatability, the shots of one visit share it, since it depends on the configuration. The fit
/// estimates them (IdentificationOptions::estimate_model_error); zero by default.
struct MeasurementNoise {
  double position_mm = 0.015;
  double orientation_rad = 1e-4;
  std::optional<TrackerUncertainty> tracker{};
  double repeatability_mm = 0.0;
  double model_error_mm = 0.0;
  double model_error_rad = 0.0;

  /// Diagonal row weights for one measurement of `type` (size MeasurementRows(type)), repeatability included.
  /// With `tracker`: the isotropic equivalent at kAssumedTrackerDistanceMm (position variance
  /// (s_r^2 + 2 s_t^2) / 3), for callers that do not know where the tracker is.
  Eigen::VectorXd RowWeights(MeasurementType type) const;
  /// The whitening matrix of one measurement whose tool point is `point_mm` (tracker frame), rows x rows with
  /// rows = MeasurementRows(type): W' W is the inverse covariance of the residual rows, whose position part is
  /// the tracker's plus `repeatability_visits` times the shared variance per axis (repeatability and model
  /// error; the orientation rows likewise add the model error's): 1 for a shot on its own, 0 for the tracker
  /// alone (the differences between shots of one visit), n for sqrt(n) times the mean of n shots of one visit.
  /// Without `tracker`, repeatability and model error it is diag(RowWeights(type)).
  void Whitening(MeasurementType type, const Eigen::Vector3d& point_mm, Eigen::Ref<Eigen::MatrixXd> w,
                 int repeatability_visits = 1) const;
  /// 1-sigma per position axis of the repeatability (mm).
  double RepeatabilitySigmaMm() const { return repeatability_mm / kRepeatabilityPerSigma; }
  /// Whether the shots of one visit share an error (repeatability or model error): the fit then whitens a
  /// visit's shots together.
  bool HasSharedError() const { return repeatability_mm > 0.0 || model_error_mm > 0.0 || model_error_rad > 0.0; }
  /// The 1-sigma orientation error (rad) the rows use.
  double OrientationSigmaRad() const { return tracker ? tracker->OrientationSigmaRad() : orientation_rad; }
  /// Positive, finite sigmas (and a valid tracker); else false and the field ("noise.position_mm",
  /// "tracker.radial_um", ...).
  bool IsValid(std::string* error) const;
};

/// Residual r = measured - model for one measurement (size MeasurementRows(type)).
/// Position rows: p_measured - p_model (mm, world/tracker frame).
/// Axis rows: t_k . (u_measured - u_model), t_1, t_2 an orthonormal basis perpendicular to u_model
///   (TangentBasis), u the tool z axis; to first order the axis tilt in rad.
/// Orientation rows (pose): RotationVector(R_measured * R_model^T), rad, world frame.
void MeasurementResidual(MeasurementType type, const Transform& T_world_tool_measured,
                         const Transform& T_world_tool_model, Eigen::Ref<Eigen::VectorXd> residual);

/// Two unit vectors t1, t2 with (t1, t2, u) right-handed and orthonormal; u must be a unit vector.
void TangentBasis(const Eigen::Vector3d& u, Eigen::Vector3d* t1, Eigen::Vector3d* t2);

/// The identification Jacobian e(q) at error parameters eps: d(model prediction)/d(eps), in the rows of
/// MeasurementResidual, so that residual(eps + d) ~= residual(eps) - J d.
/// J must be MeasurementRows(type) x model.num_error_parameters(); eps empty means eps = 0 (the paper's e).
/// Columns are exact at any eps (each error parameter is one elementary screw motion, differentiated
/// in the twist form), not only at eps = 0. A joint term's column (compliance, harmonic) is its joint's motion
/// times its factor (JointTermFactors at q under `payload`). Fills `ws` with the forward kinematics of (q, eps).
void IdentificationJacobian(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                            MeasurementType type, KinematicsWorkspace* ws, Eigen::Ref<Eigen::MatrixXd> jacobian,
                            const Payload& payload = Payload());
/// The same, with the deflection's parts that depend on the command alone prepared for q and its payload
/// (PrepareDeflection): a fit's poses, evaluated at many eps.
void IdentificationJacobian(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                            MeasurementType type, KinematicsWorkspace* ws, Eigen::Ref<Eigen::MatrixXd> jacobian,
                            const PreparedDeflection& prepared);

/// The joint Jacobian at (q, eps): d(model prediction)/dq in the same rows, MeasurementRows(type) x
/// num_joints, including the joint terms' dependence on q (under `payload`). Used by compensation (inverse
/// kinematics on the calibrated model).
void JointJacobian(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                   MeasurementType type, KinematicsWorkspace* ws, Eigen::Ref<Eigen::MatrixXd> jacobian,
                   const Payload& payload = Payload());

}  // namespace robocal
