// A robot program compensated on a calibration: its targets read by the dialect's reader, each solved on the
// calibrated robot (core compensation), and written back into the same bytes in the same number format, with
// intermediate targets where a straight move's path would leave the calibrated robot's path by too much.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "robocal/core/compensation.h"
#include "robocal/core/identification.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/prediction.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"
#include "robocal/core/transforms.h"
#include "robocal/programs/program.h"

namespace robocal::programs {

/// The pose of a dialect's Cartesian values (x, y, z in the dialect's length unit, then the rotation in its
/// convention) as a transform in mm. Throws std::invalid_argument for the wrong number of values or a quaternion
/// far from unit length (more than 1e-3).
Transform PoseFromValues(const DialectSyntax& syntax, const std::vector<double>& values);
/// The values of `pose` in the dialect's units and convention, each rotation component nearest `near` (the
/// values as written, same layout): the Euler set (of the two) and each angle's turn, the quaternion's sign and
/// the rotation vector's turn that change the written numbers least.
std::vector<double> ValuesFromPose(const DialectSyntax& syntax, const Transform& pose, const std::vector<double>& near);

/// What the program should do with a target that cannot be compensated as it is (no convergence, a limit, or the
/// calibrated solution needing other configuration flags or turns than the target's).
enum class OnFailure {
  /// Keep the target as written and report it.
  kKeep,
  /// Refuse the whole program (ProgramRefused): nothing is written.
  kRefuse,
};
const char* ToString(OnFailure on_failure);
bool ParseOnFailure(const std::string& text, OnFailure* on_failure);

struct ProgramCompensationOptions {
  /// The program's tools and bases / work objects, by the name or number the program uses (ProgramTarget::tool,
  /// ProgramTarget::base), each as the dialect's Cartesian values (as a target's: x, y, z, then the rotation in
  /// the dialect's convention and units): a tool is T_flange_tool, a base T_base_frame in the robot's base frame.
  /// A target whose tool has no entry uses the calibrated robot's tool; a target whose base has no entry (other
  /// than the identity frames, which the readers name "") is refused.
  std::map<std::string, std::vector<double>> tools;
  std::map<std::string, std::vector<double>> bases;
  /// Straight moves (Motion::kLinear) whose path, as the controller interpolates it on its nominal model between
  /// the compensated endpoints, leaves the straight path between the programmed targets by more than this at a
  /// midpoint (mm, on the calibrated model) get intermediate targets until every piece is within it; a circular
  /// move (Motion::kCircular, its via point and end) beyond it is split once into two circles on the programmed
  /// arc. Unset: no path is checked.
  std::optional<double> max_path_deviation_mm;
  /// At most 2^max_split_depth - 1 targets are inserted into one segment.
  int max_split_depth = 6;
  OnFailure on_failure = OnFailure::kKeep;
  /// The payload the robot carries (a calibration with a compliance model deflects under it).
  Payload payload;
  CompensationOptions solver;
  /// How each compensated target's predicted_error_mm is computed (the probability, the robot's repeatability).
  PredictionOptions prediction;
  /// Threads the targets are solved on (0: as many as the hardware runs at once).
  int threads = 0;

  bool IsValid(std::string* error) const;
};

/// One target of the program, compensated (or not: see termination).
struct CompensatedTarget {
  /// As the reader found it (ProgramTarget): file index, line (in the file as sent), name, kind.
  int file = 0;
  int line = 0;
  int column = 0;
  std::optional<std::string> name;
  TargetKind kind = TargetKind::kJoint;
  /// An intermediate target the path check inserted (before the motion at `line`).
  bool inserted = false;
  /// The compensated joints (rad / mm per joint); empty when the solver found none.
  Eigen::VectorXd joints;
  /// How far the written target moved: the tool point (mm) and the tool's rotation (rad), in the target's frame
  /// (for a joint target, on the nominal model between the written and the compensated joints).
  double correction_mm = 0.0;
  double correction_rad = 0.0;
  /// The largest change of a revolute joint (rad) from the joints the controller would have used for the target
  /// as written (the written joints, or the nominal solution of the written pose on its configuration); NaN for
  /// a robot without revolute joints or without a solution.
  double joint_change_rad = 0.0;
  /// The compensated joints have the configuration flags and turns the target names (or, where the target
  /// names none that apply, the branch the controller would use). False: the target was not rewritten, or the
  /// program refused, by on_failure.
  bool configuration_kept = true;
  /// Whether its numbers were rewritten (false: kept as written because it failed, or nothing to change).
  bool rewritten = false;
  /// The bound on the robot's position error at the compensated joints (PredictPositionError with
  /// options.prediction: 95 % by default; mm, NaN without joints or without the fit's covariance).
  double predicted_error_mm = std::numeric_limits<double>::quiet_NaN();
  Termination termination = Termination::kFailure;
  std::string message;
};

struct ProgramCompensationSummary {
  int targets = 0;
  int joint_targets = 0;
  int cartesian_targets = 0;
  /// Targets whose numbers were rewritten.
  int rewritten = 0;
  /// Targets that could not be compensated as they are (termination not CONVERGENCE, or configuration_kept
  /// false), kept as written or refusing the program.
  int failed = 0;
  int configuration_changes = 0;
  /// Intermediate targets inserted by the path check, and the straight segments it checked.
  int inserted = 0;
  int segments_checked = 0;
  /// Straight segments still beyond max_path_deviation_mm after the deepest split allowed.
  int segments_over_deviation = 0;
  double max_correction_mm = 0.0;
  double max_predicted_error_mm = std::numeric_limits<double>::quiet_NaN();
  /// CONVERGENCE: every target compensated; DEGRADED: some kept as written (on_failure keep) or a segment over
  /// the deviation; FAILURE: refused (on_failure refuse).
  Termination termination = Termination::kFailure;
  std::string message = "not run";
};

struct ProgramCompensationResult {
  Dialect dialect = Dialect::kKrl;
  /// The files, rewritten (in the order given); empty when refused.
  std::vector<ProgramFile> files;
  /// Every target in the order of the files and their text, inserted ones before the motion they precede.
  std::vector<CompensatedTarget> targets;
  ProgramCompensationSummary summary;
};

/// The targets of a program that refer to a frame the request does not give, or a tool / base entry of the
/// wrong size, are refused before anything is solved: ProgramError naming the file, line and column of the
/// first such target (a base), or std::invalid_argument naming the entry ("tools.3: ...").
///
/// Compensates every target of `files` (one program in `dialect`) on `calibration`, as docs/programs.md
/// describes: joint targets to the calibrated solution nearest the written joints; Cartesian targets solved on
/// the branch their configuration names (or the previous target's) and written back as the nominal model's pose
/// at the compensated joints, so that the controller's own inverse kinematics lands the real robot. `nominal`
/// is the robot as its controller knows it. Throws ProgramError for a program the reader cannot read, and
/// std::invalid_argument for invalid options. With OnFailure::kRefuse and a target that fails, the result has
/// no files and summary.termination FAILURE.
ProgramCompensationResult CompensateProgram(const Calibration& calibration, const RobotModel& nominal, Dialect dialect,
                                            const std::vector<ProgramFile>& files,
                                            const ProgramCompensationOptions& options = {});
/// The same for a dialect given by its row (a test's own dialect, say).
ProgramCompensationResult CompensateProgram(const Calibration& calibration, const RobotModel& nominal,
                                            const DialectSyntax& syntax, const std::vector<ProgramFile>& files,
                                            const ProgramCompensationOptions& options = {});

}  // namespace robocal::programs
