// Compensation: joint commands on the calibrated model that bring the real robot to its targets, by damped
// least squares inverse kinematics within the joint limits.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "robocal/core/arm_kinematics.h"
#include "robocal/core/identification.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"
#include "robocal/core/transforms.h"
#include "robocal/core/units.h"

namespace robocal {

/// The frame a pose target is given in.
enum class TargetFrame {
  /// The tracker (world) frame of the calibration.
  kTracker,
  /// The robot base frame: the calibrated T_world_base (registered frame with identified base errors).
  kBase,
};

const char* ToString(TargetFrame frame);
bool ParseTargetFrame(const std::string& text, TargetFrame* frame);

struct CompensationOptions {
  /// Levenberg-Marquardt: dq = (J'J + mu I)^-1 J'r (rows weighted, see below) with the gain-ratio damping
  /// schedule of Nielsen (docs/compensation.md). mu starts at initial_damping x the largest diagonal element
  /// of J'J (a scale-free start); when it would exceed max_damping^2 no step lowers the error any more and
  /// the first phase stops (not converged).
  double initial_damping = 1e-9;
  /// The same start of mu for the run from start joints (or the previous result in a sequence) towards a pose
  /// target, whose solution on the start's branch is wanted nearest the start. Near a singularity a nearly
  /// undamped first step follows the Jacobian's nearly null directions far along the branch, to another of its
  /// solutions; a damped one goes down the error's steep directions first. 1e-3 is the start Madsen, Nielsen &
  /// Tingleff (2004, section 3.2) suggest for a start not known to be close.
  double start_damping = 1e-3;
  /// Start joints (or the previous result in a sequence) are taught joints where a converged solution lies within
  /// this distance of them (Euclidean over the joints, rad): only the solutions within this distance beyond the
  /// nearest one are answers then, the start's branch first among them (see Compensate). A start a few degrees
  /// across a branch boundary (a singularity) would otherwise swing the robot to the far solution of its own flags:
  /// across the wrist's, joints 4 and 6 turn by 180 deg. Start joints farther than this from every solution name
  /// the branch only, and the result's message says how far it is from them.
  double start_radius_rad = 10.0 * kRadPerDeg;
  double max_damping = 1e6;
  int max_iterations = 100;
  /// Converged when the position error <= position_tolerance_mm and the matched orientation error <=
  /// orientation_tolerance_rad: the one test for every result, whatever the Jacobian's conditioning there.
  double position_tolerance_mm = 1e-7;
  double orientation_tolerance_rad = 1e-9;
  /// How 1 rad of orientation error weighs against 1 mm of position error in the solver (mm / rad).
  double orientation_weight_mm_per_rad = 100.0;

  bool IsValid(std::string* error) const;
};

/// Result for one target.
struct CompensationResult {
  /// Joints for the robot (within limits; rad / mm per joint).
  Eigen::VectorXd joints;
  /// Remaining error of the calibrated model at `joints` against the target (NaN for a result without joints).
  double position_error_mm = 0.0;
  /// Angle between the reached and target orientations over the matched rotations (rad): the full rotation
  /// for 6+ joints, the tool axis for robots with fewer joints.
  double orientation_error_rad = 0.0;
  /// For robots with fewer than 6 joints: the rotation about the tool axis that was left free (rad, in
  /// (-pi, pi]): the angle about the reached tool axis from the target's x axis to the reached one. 0 otherwise.
  double free_rotation_rad = 0.0;
  /// How the solver ended; `joints` are written unless kFailure.
  /// - kConvergence: both tolerances met (near a singularity too: the conditioning decides nothing).
  /// - kDegraded: not met, and a joint is held at a limit that the error pulls outward: the limits, not the
  ///   solver, keep the robot from the target; `joints` are the closest it found within the limits.
  /// - kNoConvergence: not met, with no joint held at a limit: max_iterations reached, or no step lowers the
  ///   error any more (damping above max_damping: a target out of reach, or beyond a singularity's fold);
  ///   `joints` are the best found, and the message gives the Jacobian's singular values there.
  /// - kFailure: no usable joints: a pose target whose demanded branch has no solution at all (beyond the
  ///   arm's reach on it; Compensate), or joints not finite (inputs that could lead there throw instead, so
  ///   CompensatePose does not return it in practice). It is also the value of a result not computed.
  Termination termination = Termination::kFailure;
  /// termination == kConvergence (kept for existing callers).
  bool converged = false;
  /// Joint Jacobian evaluations.
  int iterations = 0;
  /// Empty when converged, except for a pose target whose start joints lie farther than
  /// CompensationOptions::start_radius_rad from every solution, which says how far the answer is from them;
  /// otherwise why not (e.g. "joint 3 (Z) at its upper limit 400; ...").
  std::string message;
  /// For a 6R arm of a known family (ArmSolver::For): the branch of `joints` (flags of the nominal chain
  /// there); nullopt otherwise or without joints.
  std::optional<ArmConfiguration> configuration;
};

/// Joints on the calibrated robot that reach the tool pose `target` (given in `frame`), starting from
/// `q_start` (nominal joints; size num_joints; projected into the limits first). A robot with fewer than 6
/// joints cannot match an arbitrary 6-D pose: it matches the position and the tool (z) axis (the rows of
/// MeasurementType::kPositionAxis), and the rotation about the tool axis is free (reported, not matched).
/// kBase targets are placed in the world by calibration.T_world_base. Every step is kept within the joint
/// limits; a joint at a limit that the error pulls outward is held there and named in the message (and the
/// result is kDegraded if it is still held at the end).
/// Throws std::invalid_argument for invalid options, wrong sizes, a non-finite start or a non-rigid target.
/// A calibration with a compliance model deflects under `payload` (joint_errors.h): the joints returned bring the
/// loaded robot to the target.
CompensationResult CompensatePose(const Calibration& calibration, const Transform& target, TargetFrame frame,
                                  const Eigen::VectorXd& q_start, const CompensationOptions& options = {},
                                  const Payload& payload = Payload());

/// "Go where the nominal model says": the target is the nominal model's tool pose at `q_nominal`, in the base
/// frame, and the answer is the joints that take the calibrated robot there.
CompensationResult CompensateJoints(const Calibration& calibration, const RobotModel& nominal,
                                    const Eigen::VectorXd& q_nominal, const CompensationOptions& options = {});

/// One target: a nominal joint command (as CompensateJoints) unless `pose` is set, then a pose in `frame`.
///
/// A pose target is solved on a branch chosen by, in order: `configuration` (a demand: a flag given is never given
/// up; a target the calibrated robot does not reach with it ends NO_CONVERGENCE or, with no nominal solution on it
/// at all, FAILURE, saying so), then the branch of `start` if given, then that of the previous target's result in a
/// sequence, else shoulder front, elbow up, wrist noflip. With `start` (or a previous result) the answer is the
/// converged solution on that branch nearest those joints, every revolute joint at its turn nearest them within the
/// limits; failing that branch, the converged one with the fewest and least important other flags (shoulder before
/// elbow before wrist), nearest. Where a solution lies within options.start_radius_rad of those joints, only those
/// within that radius beyond the nearest count: the start's branch first, but a far solution of it never wins over
/// a near one of another branch (the robot does not swing from taught joints); start joints farther than that from
/// every solution get an answer whose message says how far it is from them. It is looked for from those joints
/// first (with options.start_damping; joints that reach the target come back as they are), then from the branches'
/// nominal closed-form solutions (ArmSolver), each placed in the joint limits nearest the reference joints (start,
/// previous, or DefaultJoints) and refined on the calibrated model in that order of preference; without start or
/// previous joints the first of those to converge with the demanded flags is the answer. A converged result is
/// never given up for one that did not converge. A robot of no known family has no named branches: its pose target
/// is solved from `start`, else from the previous result, else from DefaultJoints and then a fixed grid of starts
/// (the quarter and three-quarter points of every joint range, nearest first) until one converges.
struct CompensationTarget {
  Eigen::VectorXd joints;
  std::optional<Transform> pose;
  TargetFrame frame = TargetFrame::kTracker;
  /// Start joints for a pose target (nominal joints); empty when not given.
  Eigen::VectorXd start;
  /// Demanded flags of a pose target (0: not demanded). Only for a robot with named branches (ArmSolver::For).
  ArmConfiguration configuration;
  /// The payload the robot carries at this target (mass 0: none): a calibration with a compliance model
  /// deflects under it, and the joints returned bring the loaded robot to the target.
  Payload payload;
};

/// The nominal model as a calibration (no errors, the model's own base and tool frames): compensating on it solves
/// the nominal robot's inverse kinematics, with every branch and limit rule of Compensate.
Calibration NominalCalibration(const RobotModel& nominal);

/// Zero (the robot's home) for every joint whose range holds it, else the middle of the range.
Eigen::VectorXd DefaultJoints(const RobotModel& model);

/// One target, as CompensationTarget describes; `previous` is the previous target's joints in a program (empty
/// if none). Throws std::invalid_argument for invalid inputs, including a configuration for a robot without
/// named branches.
CompensationResult Compensate(const Calibration& calibration, const RobotModel& nominal,
                              const CompensationTarget& target, const CompensationOptions& options = {},
                              const Eigen::VectorXd& previous = Eigen::VectorXd());

/// Compensates every target on its own, on `threads` threads (0: as many as the hardware runs at once), and
/// returns the results in target order. Each result is exactly what Compensate returns for that target
/// alone, so neither the results nor their order depend on the thread count. Throws what the
/// single-target functions throw, for the first target (in order) that throws.
std::vector<CompensationResult> CompensateAll(const Calibration& calibration, const RobotModel& nominal,
                                              const std::vector<CompensationTarget>& targets,
                                              const CompensationOptions& options = {}, int threads = 0);

/// The targets as one program, in order: each is Compensate with the previous result's joints as `previous`
/// (none for the first, or after a result without joints).
std::vector<CompensationResult> CompensateSequence(const Calibration& calibration, const RobotModel& nominal,
                                                   const std::vector<CompensationTarget>& targets,
                                                   const CompensationOptions& options = {});

}  // namespace robocal
