// Closed-form inverse kinematics of the common 6R arm families, and the configuration (branch) flags that name
// their solutions: shoulder front/back, elbow up/down, wrist noflip/flip.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/robot_model.h"
#include "robocal/core/transforms.h"

namespace robocal {

/// The 6R families with a closed-form solution, recognised from the nominal model's joint axes at the zero
/// configuration (any DH / MDH / URDF description of the same geometry is the same family).
enum class ArmFamily {
  /// Joints 2 and 3 parallel, joint 1 not parallel to them, joints 4, 5 and 6 meeting in one point (the wrist
  /// centre): PUMA, most 6-axis industrial arms.
  kSphericalWrist,
  /// Joints 2, 3 and 4 parallel, joint 1 not parallel to them, joints 5 and 6 meeting in one point: the
  /// Universal Robots geometry.
  kOffsetWrist,
};

const char* ToString(ArmFamily family);

/// One configuration flag: +1 (front, up, noflip), -1 (back, down, flip), 0 (not given).
struct ArmConfiguration {
  int shoulder = 0;
  int elbow = 0;
  int wrist = 0;

  bool operator==(const ArmConfiguration&) const = default;
  /// No flag given (nothing demanded).
  bool empty() const { return shoulder == 0 && elbow == 0 && wrist == 0; }
  /// Every flag given (+1 or -1).
  bool Complete() const { return shoulder != 0 && elbow != 0 && wrist != 0; }
  /// Every flag this one gives matches `other`'s.
  bool Admits(const ArmConfiguration& other) const;
  /// "shoulder front, elbow up, wrist noflip" (flags not given are left out).
  std::string ToString() const;
};

/// The flag names on the wire.
const char* ShoulderName(int flag);  // "front" / "back"
const char* ElbowName(int flag);     // "up" / "down"
const char* WristName(int flag);     // "noflip" / "flip"
/// Parses a flag name for its flag ("shoulder", "elbow", "wrist"); false if the name is not one of its two.
bool ParseConfigurationFlag(const std::string& flag, const std::string& name, int* value);

/// One nominal solution: joints in [-pi, pi] (not yet placed in the limits), its flags, and how closely the
/// nominal chain reaches the pose with them (round-off for a reachable pose; up to a few mm for a pose just
/// beyond reach, whose stretched configuration is still a useful start for the calibrated model).
struct ArmSolution {
  Eigen::VectorXd joints;
  ArmConfiguration configuration;
  double position_error_mm = 0.0;
  double orientation_error_rad = 0.0;
};

/// The closed-form solver and the flags of a nominal model of a known family.
///
/// The flags are signs of geometric quantities of the nominal chain at q (base frame), each zero exactly on
/// the singularity between its two branches, so a path that does not cross a singularity keeps its flags:
/// - shoulder: the wrist point's reach r = (z1 x z2) . (w - p1) (z1, z2: joint 1 and 2 axes, p1 a point on
///   axis 1, w the wrist centre, or for the offset wrist the point where axes 5 and 6 meet); "front" when r
///   has the sign it has at the zero configuration (where the presets stretch the arm forward).
/// - elbow: in the plane of the parallel joints, "up" when the elbow (axis 3) lies above the line from the
///   shoulder (axis 2) to the wrist (the wrist centre, or axis 4 for the offset wrist), "above" meaning
///   towards joint 1's axis direction, with the line directed outward from axis 1.
/// - wrist: s = z5 . (z4 x z6); "noflip" when s has the sign it has with joint 5 at +90 deg and every other
///   joint at zero (for the presets: joint 5 in (0, 180) deg).
class ArmSolver {
 public:
  /// The solver of `model`'s family, or nullopt when the model is not a 6R arm of a known family.
  static std::optional<ArmSolver> For(const RobotModel& model);

  ArmFamily family() const { return family_; }

  /// The flags of the nominal chain at q (num_joints values). A flag exactly on its singularity counts as +1.
  ArmConfiguration ConfigurationOf(const Eigen::VectorXd& q) const;

  /// Every nominal solution for the tool pose T_base_tool (robot base frame): one per branch (at most 8), with
  /// how closely it reaches the pose on the nominal forward kinematics. A joint the pose leaves free (a singular
  /// pose) takes its value from `reference` (num_joints values). Within about 3 deg of the offset wrist's
  /// singularity, where joint 6 is ill-determined, inexact starts with joint 6 at the reference and every
  /// 30 deg are added.
  std::vector<ArmSolution> Solve(const Transform& T_base_tool, const Eigen::VectorXd& reference) const;

 private:
  struct Axis {
    Eigen::Vector3d w;  // unit direction
    Eigen::Vector3d p;  // a point on the axis
  };
  ArmSolver(const RobotModel& model, ArmFamily family);
  // The nominal chain in the base frame at q: each joint's axis, and the tool pose.
  void Axes(const Eigen::VectorXd& q, Axis* axes, Transform* T_base_tool) const;
  double ShoulderReach(const Axis* axes, const Eigen::Vector3d& wrist) const;
  ArmConfiguration Flags(const Axis* axes, const Eigen::Vector3d& wrist, const Eigen::Vector3d& elbow_end) const;

  RobotModel model_;
  ArmFamily family_;
  Axis axes0_[6];
  Transform T_base_tool0_ = Transform::Identity();
  // The wrist point (wrist centre, or axes 5 and 6 meeting) and the end of the planar elbow chain, in the frame
  // of the joint that carries them.
  int wrist_frame_ = 3;
  Eigen::Vector3d wrist_local_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d wrist0_ = Eigen::Vector3d::Zero();
  double shoulder_sign_ = 1.0;
  double wrist_sign_ = 1.0;
};

}  // namespace robocal
