// Reflectors on the tool: a position-only laser tracker sees points, not the tool's orientation; two or three
// reflector nests on the tool, each measured at every pose, give the fit the orientation one point cannot.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "robocal/core/robot_model.h"
#include "robocal/core/transforms.h"

namespace robocal {

/// At most this many reflectors in a fit (a tool carries two to four nests).
inline constexpr int kMaxFitReflectors = 16;

/// A reflector the fit knows: where it sits on the flange (mm, FLANGE frame, as a cell's ReflectorSpec) and
/// whether that position is known (fixed: measured on a coordinate measuring machine, held) or its offset
/// error is to be identified (parameters reflector.<id>.dx, .dy, .dz, flange frame, mm).
struct Reflector {
  std::string id;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  bool fixed = false;
};

/// Ids non-empty (at most 64 characters), unique; positions finite; at most kMaxFitReflectors. Else false and
/// the field ("reflectors[1].id ...").
bool ValidateReflectors(const std::vector<Reflector>& reflectors, std::string* error);

/// The fit's parameter index space with reflectors: the model's error parameters 0 .. n - 1, then
/// n + 3 k + axis for reflector k's offset error along flange x, y, z. Names: the model's, then
/// "reflector.<id>.dx" / ".dy" / ".dz". Throws std::out_of_range for an index beyond both.
std::string ParameterName(const RobotModel& model, const std::vector<Reflector>& reflectors, int index);

/// The index of a name of that space ("joint2.dz", "reflector.smr2.dy"), or -1 for none.
int ParameterIndex(const RobotModel& model, const std::vector<Reflector>& reflectors, const std::string& name);

/// Each reflector's point in the nominal tool frame (T_flange_tool^-1 (position + offset error)); offset_errors
/// holds 3 per reflector (flange frame), or is empty for none.
std::vector<Eigen::Vector3d> ReflectorsInTool(const RobotModel& nominal, const std::vector<Reflector>& reflectors,
                                              const Eigen::VectorXd& offset_errors);

/// The pose a shot of a reflector at `in_tool` (tool frame) measures: the tool's orientation at the reflector's
/// point (only the position counts for position measurements).
Transform AtReflector(const Transform& T_world_tool, const Eigen::Vector3d& in_tool);

/// The reflector point's rows of the identification Jacobian: from the tool's pose rows (IdentificationJacobian
/// with MeasurementType::kPose: 3 position rows of the tool point, 3 rotation rows), the point moves by
/// J_pos - [R in_tool]x J_rot. `pose_jacobian` is 6 x n, `rows` 3 x n.
void ReflectorRows(const Transform& T_world_tool, const Eigen::Vector3d& in_tool,
                   const Eigen::Ref<const Eigen::MatrixXd>& pose_jacobian, Eigen::Ref<Eigen::MatrixXd> rows);

/// The point's derivative by its offset error (flange frame): R_world_tool R_flange_tool'.
Eigen::Matrix3d ReflectorOffsetRows(const RobotModel& nominal, const Transform& T_world_tool);

}  // namespace robocal
