// The geometric error model: measurement types, their residual rows, and the identification Jacobian.
#pragma once

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

/// 1-sigma tracker noise, used to weight residual rows (row weight = 1 / sigma).
struct MeasurementNoise {
  double position_mm = 0.015;
  double orientation_rad = 1e-4;
  /// Row weights for one measurement of `type` (size MeasurementRows(type)).
  Eigen::VectorXd RowWeights(MeasurementType type) const;
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
/// in the twist form), not only at eps = 0. Fills `ws` with the forward kinematics of (q, eps).
void IdentificationJacobian(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                            MeasurementType type, KinematicsWorkspace* ws, Eigen::Ref<Eigen::MatrixXd> jacobian);

/// The joint Jacobian at (q, eps): d(model prediction)/dq in the same rows, MeasurementRows(type) x
/// num_joints. Used by compensation (inverse kinematics on the calibrated model).
void JointJacobian(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                   MeasurementType type, KinematicsWorkspace* ws, Eigen::Ref<Eigen::MatrixXd> jacobian);

}  // namespace robocal
