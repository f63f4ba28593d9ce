// The ISO 9283 pose test: where its five poses lie in the test cube, and the pose and distance characteristics
// (accuracy and repeatability) of the poses a robot attained over the test's cycles (docs/iso9283.md).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "robocal/core/arm_kinematics.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/transforms.h"

namespace robocal {

/// The test's poses P1..P5.
inline constexpr int kIso9283Poses = 5;

/// The test cube, its edges parallel to the robot base frame's axes (mm).
struct Iso9283Cube {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  double size_mm = 0.0;
};

/// The cube's corners, (x, y, z) = centre + h (sx, sy, sz) with h half the size, in the order sx, sy, sz =
/// (-,-,-), (+,-,-), (-,+,-), (+,+,-), (-,-,+), (+,-,+), (-,+,+), (+,+,+).
std::array<Eigen::Vector3d, 8> CubeCorners(const Iso9283Cube& cube);

/// The positions of P1..P5 (base frame, mm). P1 is the cube's centre. P2..P5 lie on the measuring plane, the
/// diagonal plane through the cube's top edge at -x and its bottom edge at +x (both parallel to y), each on a
/// diagonal of that plane at 10 % of the diagonal's length from its corner: P = P1 + 0.8 (C - P1) for the corners
/// C = (-,-,+), (-,+,+), (+,+,-), (+,-,-) in that order, so that P2 and P4, and P3 and P5, face each other across
/// P1. Throws std::invalid_argument for a non-finite centre or a size that is not positive.
std::array<Eigen::Vector3d, kIso9283Poses> Iso9283Positions(const Iso9283Cube& cube);

/// The tool poses of P1..P5 in the base frame: Iso9283Positions with the tool in `orientation` (R_base_tool).
std::array<Transform, kIso9283Poses> Iso9283Poses(const Iso9283Cube& cube, const Eigen::Matrix3d& orientation);

/// LargestIso9283Cube's search.
struct Iso9283CubeSearchOptions {
  /// Centres tried: the tool points of this many seeded random configurations within the limits.
  int centres = 100;
  std::uint64_t seed = 1;
  /// The size is bisected in (0, max_size_mm] down to resolution_mm; the cube found is rounded down to it.
  double max_size_mm = 2000.0;
  double resolution_mm = 1.0;
  /// Configurations the cell allows (its reach, the tracker's line of sight, obstacles); unset: all within limits.
  std::function<bool(const Eigen::VectorXd&)> feasible;
};

struct Iso9283CubeSearch {
  bool found = false;
  Iso9283Cube cube;
  /// The branch on which the robot reaches every pose and corner of the cube.
  ArmConfiguration configuration;
  int centres_tried = 0;
  std::string message;
};

/// The largest test cube (edges along the base frame's axes) found whose five poses and eight corners the nominal
/// robot reaches with the tool in `orientation`, on one branch, within its limits and `feasible`: for each seeded
/// centre and each branch the robot reaches it on, the size bisected (reachability is not convex, so a bisected size
/// is the largest of a connected range, not a proof). The model must have closed-form inverse kinematics
/// (ArmSolver::For); throws std::invalid_argument otherwise or for invalid options.
Iso9283CubeSearch LargestIso9283Cube(const RobotModel& model, const Eigen::Matrix3d& orientation,
                                     const Iso9283CubeSearchOptions& options = {});

/// The pose name "P1".."P5" of index 0..4, and back (-1 for another name).
std::string Iso9283PoseName(int pose);
int Iso9283PoseIndex(const std::string& name);

/// One shot of the test: the pose (0..4) and cycle (>= 1) it belongs to, the pose the robot attained and the pose
/// it was commanded to, both tool poses in the robot's base frame.
struct Iso9283Shot {
  int pose = 0;
  int cycle = 1;
  Transform attained = Transform::Identity();
  Transform commanded = Transform::Identity();
};

/// The pose characteristics at one pose. With the deviations d_j = attained_j - commanded_j of its n shots (the
/// standard's x_j - x_c when every cycle has the same command):
/// - AP_x, AP_y, AP_z = mean(d); AP = |AP_xyz|.
/// - l_j = |d_j - mean(d)|; RP_l = mean(l) + 3 S_l, S_l = sqrt(sum (l_j - mean l)^2 / (n - 1)).
/// - Orientation: the deviation's small angles (a_j, b_j, c_j) about the base frame's x, y, z axes (the rotation
///   vector of R_attained R_commanded^T); AP_a = mean(a), RP_a = 3 S_a with S_a the sample std of a_j.
/// Repeatability needs n >= 2: NaN below. Orientation figures are NaN without orientation.
struct Iso9283PoseFigures {
  int pose = 0;
  int cycles = 0;
  /// The command's position (mean over the cycles).
  Eigen::Vector3d command_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d ap_xyz_mm = Eigen::Vector3d::Zero();
  double ap_mm = 0.0;
  double mean_l_mm = std::numeric_limits<double>::quiet_NaN();
  double s_l_mm = std::numeric_limits<double>::quiet_NaN();
  double rp_l_mm = std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d ap_abc_rad = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d rp_abc_rad = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
};

/// The distance characteristics between two poses over the cycles that attained both. Per cycle j, D_j =
/// attained_from - attained_to and D_cj = commanded_from - commanded_to; AD = mean(|D_j| - |D_cj|) (the standard's
/// mean(D) - D_c), AD_x = mean(D_xj - D_cxj) and so on; RD = 3 S with S the sample std of |D_j| - |D_cj| (NaN for
/// fewer than 2 cycles).
struct Iso9283Distance {
  int from = 0;
  int to = 1;
  int cycles = 0;
  double command_mm = 0.0;
  double ad_mm = 0.0;
  Eigen::Vector3d ad_xyz_mm = Eigen::Vector3d::Zero();
  double rd_mm = std::numeric_limits<double>::quiet_NaN();
};

/// The pairs whose distance characteristics Iso9283Analyse reports: P1-P2, and P2-P4 (the measuring plane's
/// diagonal, the longest distance of the test).
inline constexpr std::array<std::array<int, 2>, 2> kIso9283DistancePairs{{{0, 1}, {1, 3}}};

struct Iso9283Result {
  /// The poses with at least one shot, in pose order.
  std::vector<Iso9283PoseFigures> poses;
  /// The kIso9283DistancePairs with at least one cycle that attained both poses.
  std::vector<Iso9283Distance> distances;
  /// The largest number of cycles at any pose.
  int cycles = 0;
};

/// The characteristics of `shots` (any order). `orientation`: whether the attained orientations were measured.
/// Throws std::invalid_argument for an empty list, a pose outside 0..4, a cycle < 1, the same pose and cycle
/// twice, or a non-finite pose.
Iso9283Result Iso9283Analyse(const std::vector<Iso9283Shot>& shots, bool orientation);

}  // namespace robocal
