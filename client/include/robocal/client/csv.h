// The CSV formats of the CLI and the mock tracker (see docs/client.md): joint vectors (plans, compensation)
// and tracker measurements. Units are the wire's: revolute joints in degrees, prismatic joints and positions
// in mm. A header line is required; lines starting with '#' and blank lines are skipped.
#pragma once

#include <istream>
#include <ostream>
#include <string>
#include <vector>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/robots.h"

namespace robocal::client {

/// "x_mm", "b_deg": a joint's column name (its name and unit), the joints being those of api::Robot.
std::string JointColumn(const api::RobotJoint& joint);

/// Joint vectors: header "<joint>_<unit>,..." then one row per configuration with num_joints values.
/// Throws std::runtime_error ("line 4: expected 5 values, got 4") on malformed input.
std::vector<std::vector<double>> ReadJointsCsv(std::istream& in, int num_joints);
void WriteJointsCsv(std::ostream& out, const std::vector<api::RobotJoint>& joints,
                    const std::vector<std::vector<double>>& rows);

/// Measurements: the joint columns, then x_mm,y_mm,z_mm (tool position, tracker frame) and optionally
/// qw,qx,qy,qz (tool orientation, tracker frame; required unless the campaign measures position only). One
/// row per tracker shot. Throws std::runtime_error on malformed input.
std::vector<api::MeasurementWire> ReadMeasurementsCsv(std::istream& in, int num_joints);
/// Writes the quaternion columns only if every measurement has an orientation.
void WriteMeasurementsCsv(std::ostream& out, const std::vector<api::RobotJoint>& joints,
                          const std::vector<api::MeasurementWire>& measurements);

/// Compensation targets: either the robot's joint columns (nominal joint commands), or pose targets
/// x_mm,y_mm,z_mm,qw,qx,qy,qz (in `frame`), optionally followed by shoulder, elbow, wrist columns (any of them,
/// any order; a cell front/back, up/down, noflip/flip, or empty to leave the flag free). Throws
/// std::runtime_error naming the line and column of a malformed value.
std::vector<api::CompensationTargetWire> ReadCompensationTargetsCsv(std::istream& in, int num_joints,
                                                                   TargetFrame frame = TargetFrame::kTracker);
/// Compensation results: the compensated joint columns, then position_error_mm, orientation_error_deg,
/// predicted_error_mm (the 95 % bound on the position error at the joints; empty where the reply has none),
/// converged (0/1); for a robot with named branches shoulder, elbow, wrist (empty without joints); with
/// `sequence` also joint_jump_deg (empty on the first row) and joint_jump (0/1), and for a robot with named
/// branches branch_change (0/1).
void WriteCompensationCsv(std::ostream& out, const std::vector<api::RobotJoint>& joints,
                          const std::vector<api::Compensation>& results, bool sequence = false);

}  // namespace robocal::client
