// Calibrated URDF out: an imported robot's URDF document with the identified geometric errors folded into the
// chain's joint origins and the calibrated tool as a fixed joint (docs/formats.md).
#pragma once

#include <string>

#include <Eigen/Core>

#include "robocal/api/robots.h"
#include "robocal/core/robot_model.h"

namespace robocal::urdf {

/// The link and joint the export adds below the tip link: the calibrated tool (measured point).
inline constexpr const char* kToolLink = "robocal_tool";
inline constexpr const char* kToolJoint = "robocal_tool_joint";

/// `source` (the document the robot was imported from, api::RegisterRobotRequest::urdf) with, for `model`'s
/// error parameters `errors` (mm, rad; num_error_parameters), every moving joint's <origin> of the chain
/// rewritten so that the URDF's kinematics from the base link are the calibrated robot's in its base frame
/// (the base site's error folded into the first moving joint, each joint site's error into its joint), and a
/// fixed joint kToolJoint from the tip link to a new link kToolLink at the calibrated tool. Everything else
/// in the document (links, visuals, other joints) is kept as it is; numbers are written with 17 significant
/// digits, so that importing the result (base link -> kToolLink) reproduces the calibrated forward kinematics
/// to round-off. The tracker -> base registration is not part of a URDF; it is said in a comment.
///
/// Throws api::ApiError (kFailedPrecondition) if the document no longer matches the model (a joint missing)
/// or already has a kToolLink.
std::string ExportCalibratedUrdf(const api::UrdfSource& source, const RobotModel& model, const Eigen::VectorXd& errors,
                                 const Transform& T_world_base);

/// A URDF of `model` with `errors` folded in, for a robot that did not come from a URDF (a preset, a DH or
/// transform table): links base_link, <joint>_link per joint, flange and kToolLink; each joint's origin its
/// fixed transform with its site's error (the base site's folded into the first), axis z, limits in rad / m
/// (effort and velocity 0: robocal knows neither); fixed joints robocal_flange_joint and kToolJoint. Imported again
/// (base_link -> kToolLink) it reproduces the calibrated forward kinematics in the base frame to round-off.
std::string GenerateCalibratedUrdf(const RobotModel& model, const Eigen::VectorXd& errors,
                                   const Transform& T_world_base);

}  // namespace robocal::urdf
