// A reproducible study of compensation, the figures of docs/compensation.md (`robocal-compensation-study`):
// per robot, how many random nominal joint commands converge (and why the others do not), how many Cartesian
// targets without joints are solved on the branch their configuration names, and whether a program along a
// smooth path keeps its branch.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "robocal/core/robot_model.h"

namespace robocal {

/// A UR10-like arm described in modified DH (the UR10's published lengths, joints +-170 deg): a robot that is
/// no preset, registered the way a user would, for the study's "every description of a family" case.
RobotModelSpec Ur10LikeMdhSpec();

struct CompensationStudyOptions {
  /// Presets (presets.h) and "ur10_mdh" (Ur10LikeMdhSpec).
  std::vector<std::string> robots = {"grinder5", "puma560", "ur5e", "ur10_mdh"};
  /// Random nominal joint commands per robot.
  int joint_targets = 10000;
  /// Random Cartesian targets (poses the calibrated robot reaches) per robot with named branches.
  int cartesian_targets = 2000;
  /// Targets of the smooth path per robot with named branches.
  int path_targets = 1000;
  std::uint64_t seed = 1;
  /// 1-sigma size of the calibration's error parameters: lengths (mm) and angles (rad), every site.
  double error_mm = 0.3;
  double error_rad = 3.5e-4;
  /// Threads of CompensateAll (0: the machine's); results do not depend on it.
  int threads = 0;

  bool IsValid(std::string* error) const;
};

struct CompensationStudyRow {
  std::string robot;
  bool named_branches = false;
  // Joint commands.
  int joint_targets = 0;
  int joint_converged = 0;
  int joint_degraded = 0;
  int joint_no_convergence = 0;
  /// Median iterations (Jacobian evaluations) of the converged ones.
  double joint_median_iterations = 0.0;
  /// The smallest singular value of the nominal joint Jacobian in the solver's rows (orientation weighted
  /// 100 mm/rad, columns scaled to unit length; scale free, zero at a singularity) at the command: the median
  /// over converged commands and over NO_CONVERGENCE ones.
  double converged_median_min_singular = 0.0;
  double no_convergence_median_min_singular = 0.0;
  /// NO_CONVERGENCE commands with a singularity (that singular value below 1 % of the converged median, found
  /// by descending it from the command, at most 10 deg away in any joint) within 1 deg and within 5 deg of the
  /// command (max over joints), and the largest such distance (-1 when one has none within 10 deg).
  int no_convergence_within_1deg = 0;
  int no_convergence_within_5deg = 0;
  double no_convergence_max_distance_deg = 0.0;
  /// Robots with named branches: NO_CONVERGENCE commands with a branch boundary (a singularity: some flag of
  /// ArmSolver changes) within 1 deg and within 5 deg of the command, moving one joint at a time (steps of
  /// 0.02 deg up to 10 deg), and the largest such distance (-1 when one has none within 10 deg).
  int boundary_within_1deg = 0;
  int boundary_within_5deg = 0;
  double boundary_max_distance_deg = 0.0;
  // Cartesian targets (robots with named branches).
  int cartesian_targets = 0;
  int cartesian_on_branch = 0;
  /// Solved on a branch other than the one named: never allowed.
  int cartesian_other_branch = 0;
  /// Without any hint: solved on shoulder front, elbow up, wrist noflip, and solved at all.
  int cartesian_default_branch = 0;
  int cartesian_default_solved = 0;
  // The smooth path (a sequence).
  int path_targets = 0;
  int path_converged = 0;
  int path_branch_changes = 0;
  double path_max_joint_step_deg = 0.0;
  double path_max_deviation_deg = 0.0;
};

struct CompensationStudyResult {
  std::vector<CompensationStudyRow> rows;
  double seconds = 0.0;
};

/// Runs the study. Throws std::invalid_argument for invalid options or an unknown robot.
CompensationStudyResult RunCompensationStudy(const CompensationStudyOptions& options);

/// The study as text: one table, then one line per robot and test.
std::string FormatCompensationStudy(const CompensationStudyResult& result);

}  // namespace robocal
