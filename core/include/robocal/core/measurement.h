// A tracker measurement of the tool at one commanded joint configuration, as the core consumes it.
#pragma once

#include <Eigen/Core>

#include "robocal/core/robot_model.h"
#include "robocal/core/transforms.h"

namespace robocal {

/// One tracker shot: the joints the robot was commanded to and the tool pose the tracker saw.
///
/// Which parts of `T_world_tool` count depends on the MeasurementType of the campaign: kPosition uses the
/// translation only (mm, tracker frame); kPositionAxis the translation and the z column (the tool axis);
/// kPose all of it. The world frame is the tracker's. Repeated shots of one pose are separate Measurements
/// with equal `joints`.
struct Measurement {
  /// Commanded joint values (rad for revolute, mm for prismatic joints), size num_joints.
  Eigen::VectorXd joints;
  /// Measured tool pose in the tracker frame.
  Transform T_world_tool = Transform::Identity();
  /// With several reflectors on the tool (IdentificationOptions::reflectors, position measurements): the index
  /// of the reflector this shot measured, whose point is T_world_tool's translation. -1: the tool point.
  int reflector = -1;
  /// The payload on the flange during the shot (mass 0: none). With a compliance model it sets the gravity
  /// torques the joints deflect under (joint_errors.h).
  Payload payload{};
  /// A stale tracker reading (FlagStaleShots): it repeats the shot before it although the robot moved. A fit
  /// leaves it out and lists it among its outliers with its cause.
  bool stale = false;
};

}  // namespace robocal
