// What the URDF import and export share: parsing (liburdfdom, errors collected), poses in mm, axis alignment.
#pragma once

#include <urdf_parser/urdf_parser.h>

#include <string>

#include <Eigen/Core>

#include "robocal/core/transforms.h"

namespace robocal::urdf::internal {

/// Throws api::ApiError kInvalidArgument naming `field`.
[[noreturn]] void Refuse(const std::string& field, const std::string& reason);
/// The parsed document (nesting checked first); refuses naming "urdf" with liburdfdom's messages.
::urdf::ModelInterfaceSharedPtr Parse(const std::string& xml);
/// A URDF pose (m) as a transform (mm).
Transform ToTransform(const ::urdf::Pose& pose);
/// The fixed rotation that turns z onto `axis` (unit).
Eigen::Matrix3d AxisAlignment(const Eigen::Vector3d& axis);

}  // namespace robocal::urdf::internal
