// Rigid transform helpers.
#include "robocal/core/transforms.h"

#include <cmath>

namespace robocal {

Eigen::Matrix3d RotX(double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitX()).toRotationMatrix();
}
Eigen::Matrix3d RotY(double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
}
Eigen::Matrix3d RotZ(double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Eigen::Matrix3d RotationFromRpy(const Eigen::Vector3d& rpy_rad) {
  return RotZ(rpy_rad.z()) * RotY(rpy_rad.y()) * RotX(rpy_rad.x());
}

Eigen::Vector3d RpyFromRotation(const Eigen::Matrix3d& r) {
  const double pitch = std::atan2(-r(2, 0), std::hypot(r(0, 0), r(1, 0)));
  if (std::abs(std::cos(pitch)) < 1e-12) {
    // Gimbal lock: only roll - yaw (or roll + yaw) is defined; put it all in yaw.
    const double yaw = std::atan2(-r(0, 1), r(1, 1));
    return {0.0, pitch, yaw};
  }
  // Near the lock roll and yaw are each ill-determined (r(2,1), r(2,2), r(1,0), r(0,0) are all of the size of
  // cos(pitch)); taken separately, their errors would not cancel. So yaw is taken first and roll and pitch from
  // M = Rz(-yaw) R = Ry(pitch) Rx(roll), whose row 1 is (0, cos roll, -sin roll): the three angles then
  // rebuild R to round-off whatever the yaw's own error.
  const double yaw = std::atan2(r(1, 0), r(0, 0));
  const double cy = std::cos(yaw), sy = std::sin(yaw);
  const double roll = std::atan2(sy * r(0, 2) - cy * r(1, 2), cy * r(1, 1) - sy * r(0, 1));
  return {roll, std::atan2(-r(2, 0), cy * r(0, 0) + sy * r(1, 0)), yaw};
}

Transform TransformFromXyzRpy(const Eigen::Vector3d& xyz_mm, const Eigen::Vector3d& rpy_rad) {
  Transform t = Transform::Identity();
  t.linear() = RotationFromRpy(rpy_rad);
  t.translation() = xyz_mm;
  return t;
}

Transform Translation(double x_mm, double y_mm, double z_mm) {
  Transform t = Transform::Identity();
  t.translation() = Eigen::Vector3d(x_mm, y_mm, z_mm);
  return t;
}

Transform Rotation(const Eigen::Matrix3d& rotation) {
  Transform t = Transform::Identity();
  t.linear() = rotation;
  return t;
}

Eigen::Vector3d RotationVector(const Eigen::Matrix3d& rotation) {
  // Eigen's AngleAxis handles the angle-near-pi case through the symmetric part of R.
  const Eigen::AngleAxisd aa(rotation);
  return aa.angle() * aa.axis();
}

double AngleBetween(const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

bool IsValidRigidTransform(const Transform& transform, double tolerance) {
  if (!transform.matrix().allFinite()) return false;
  const Eigen::Matrix3d r = transform.linear();
  if (!(r.transpose() * r - Eigen::Matrix3d::Identity()).isZero(tolerance)) return false;
  return std::abs(r.determinant() - 1.0) < tolerance;
}

}  // namespace robocal
