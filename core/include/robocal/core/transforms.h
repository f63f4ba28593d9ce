// Rigid transforms: construction from position + roll/pitch/yaw, the rotation-vector (log) map, checks.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace robocal {

/// A rigid transform T_a_b: maps coordinates in frame b to frame a. Translation in mm.
using Transform = Eigen::Isometry3d;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// Rotation about x, y or z by an angle in rad.
Eigen::Matrix3d RotX(double angle_rad);
Eigen::Matrix3d RotY(double angle_rad);
Eigen::Matrix3d RotZ(double angle_rad);

/// R = Rz(yaw) * Ry(pitch) * Rx(roll): fixed-axis x-y-z roll, pitch, yaw (rad), the URDF convention.
Eigen::Matrix3d RotationFromRpy(const Eigen::Vector3d& rpy_rad);

/// Inverse of RotationFromRpy; pitch in [-pi/2, pi/2]. At pitch = +-pi/2 roll is set to 0.
Eigen::Vector3d RpyFromRotation(const Eigen::Matrix3d& rotation);

/// Transform with translation xyz_mm and rotation RotationFromRpy(rpy_rad).
Transform TransformFromXyzRpy(const Eigen::Vector3d& xyz_mm, const Eigen::Vector3d& rpy_rad);

/// Pure translation / rotation transforms.
Transform Translation(double x_mm, double y_mm, double z_mm);
Transform Rotation(const Eigen::Matrix3d& rotation);

/// Rotation vector (axis * angle, rad, angle in [0, pi]) of a rotation matrix: the SO(3) log map.
Eigen::Vector3d RotationVector(const Eigen::Matrix3d& rotation);

/// Angle between two nonzero vectors (rad, in [0, pi]), as atan2(|u x v|, u . v): arccos(u . v) near 1
/// resolves no better than ~2e-8 rad, too coarse for a calibrated tool axis. No clamping is needed in this form.
double AngleBetween(const Eigen::Vector3d& u, const Eigen::Vector3d& v);

/// True if every entry is finite and the rotation part is orthonormal with det +1 (to `tolerance`).
bool IsValidRigidTransform(const Transform& transform, double tolerance = 1e-9);

}  // namespace robocal
