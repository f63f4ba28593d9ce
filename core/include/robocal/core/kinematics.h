// Forward kinematics of a RobotModel with geometric error parameters, and the workspace it fills.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/random.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/transforms.h"

namespace robocal {

struct PreparedDeflection;  // joint_errors.h

/// Scratch space for kinematics on one model; reuse it across calls to avoid allocation.
struct KinematicsWorkspace {
  explicit KinematicsWorkspace(const RobotModel& model);
  /// World frame of each error site just before its error transform: [base, joint 1..n, tool].
  std::vector<Transform> T_world_site;
  /// World frame of each joint just before its motion (0-based joint index); equals the frame after the
  /// joint's error transform.
  std::vector<Transform> T_world_joint;
  /// Result of the last ForwardKinematics call.
  Transform T_world_tool = Transform::Identity();
  /// The joints the last ForwardKinematics call moved the chain to: q plus the joint terms' deflection.
  Eigen::VectorXd q_effective;
  /// The error sites' transforms (ErrorTransform) and the rotations Rx(rx), Ry(ry) of each site, for the site
  /// errors in `values`: they depend on the error vector alone, and a fit evaluates one error vector at every pose,
  /// so they are computed once per error vector instead of once per pose (SiteErrorsFor).
  struct SiteErrors {
    Eigen::VectorXd values;
    std::vector<Transform> transform;
    std::vector<Eigen::Matrix3d> rx, ry;
  };
  SiteErrors site_errors;
};

/// ws->site_errors for the site errors of eps (its first 6 x num_error_sites values; eps not empty), recomputed
/// only when they differ from the last ones.
const KinematicsWorkspace::SiteErrors& SiteErrorsFor(const RobotModel& model, const Eigen::VectorXd& eps,
                                                     KinematicsWorkspace* ws);

/// The small error transform of one site: Trans(dx, dy, dz) * Rx(rx) * Ry(ry) * Rz(rz).
/// `delta` points at 6 values: dx, dy, dz (mm), rx, ry, rz (rad).
Transform ErrorTransform(const double* delta);

/// Tool pose T_world_tool for joints q (num_joints: rad or mm per joint) and error parameters eps
/// (num_error_parameters, mm and rad; an empty vector means the nominal model). Fills `ws`.
/// A model with joint terms (fixed ones in its joints, or RobotModelSpec::error_terms) moves each joint by its
/// deflection first (JointDeflection: q + dq(q, eps, payload)); `ws` then holds the frames at the deflected
/// joints, and ws->q_effective those joints. Throws std::invalid_argument on wrong sizes.
const Transform& ForwardKinematics(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                                   KinematicsWorkspace* ws, const Payload& payload = Payload());
/// The same, with the deflection's parts that depend on the command alone prepared for q and its payload
/// (PrepareDeflection): for one command evaluated at many eps.
const Transform& ForwardKinematics(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps,
                                   KinematicsWorkspace* ws, const PreparedDeflection& prepared);

/// Nominal tool pose (no errors; the joint terms a robot holds, under no payload), convenience form that allocates
/// its own workspace.
Transform ForwardKinematics(const RobotModel& model, const Eigen::VectorXd& q);

/// The nominal chain in the robot's BASE frame (no T_world_base, no error parameters, no joint terms), allocating
/// nothing (the cell's per-candidate checks): T_base_joint[i], i < num_joints, is joint i's frame before its motion
/// (as T_world_joint of ForwardKinematics), *T_base_flange the flange (before T_flange_tool). `T_base_joint`
/// points at num_joints transforms. Throws std::invalid_argument if q does not have num_joints values.
void NominalChainInBase(const RobotModel& model, const Eigen::VectorXd& q, Transform* T_base_joint,
                        Transform* T_base_flange);

/// A model's chain with one set of error parameters folded into its fixed transforms: the same forward
/// kinematics as ForwardKinematics(model, q, eps) at the cost of the nominal chain (no error transforms to
/// rebuild per call), for evaluating one calibration many times (compensation). Immutable once built, so one
/// chain serves any number of threads.
class FoldedChain {
 public:
  /// eps: num_error_parameters values, or empty for the nominal model. With joint terms in the model (fixed or
  /// error parameters), Forward moves each joint by its deflection under `payload` first (as ForwardKinematics).
  /// Throws std::invalid_argument on a wrong size.
  FoldedChain(const RobotModel& model, const Eigen::VectorXd& eps, const Payload& payload = Payload());
  /// The same chain under another payload.
  FoldedChain WithPayload(const Payload& payload) const;

  int num_joints() const { return static_cast<int>(types_.size()); }
  JointType joint_type(int i) const { return types_[i]; }

  /// T_world_tool at q (num_joints values, not checked: callers own the size). T_world_joint, if not null,
  /// points at num_joints transforms and receives each joint's frame before its motion (as
  /// KinematicsWorkspace::T_world_joint).
  Transform Forward(const Eigen::Ref<const Eigen::VectorXd>& q, Transform* T_world_joint) const;
  /// Whether Forward deflects the joints (RobotModel::deflects()).
  bool deflects() const { return model_ != nullptr; }

 private:
  Transform ForwardAt(const Eigen::Ref<const Eigen::VectorXd>& q, Transform* T_world_joint) const;
  // With joint terms: the model (shared, immutable), its parameters and the payload, for the deflection.
  std::shared_ptr<const RobotModel> model_;
  Eigen::VectorXd eps_;
  Payload payload_;
  // before_[0] = T_world_base E_0 F_0 E_1, before_[i] = F_i E_(i+1): what precedes joint i's motion;
  // after_ = T_lastjoint_flange T_flange_tool E_(n+1).
  std::vector<Transform> before_;
  Transform after_ = Transform::Identity();
  std::vector<JointType> types_;
};

/// Uniformly random joint values within the model's limits.
Eigen::VectorXd RandomConfiguration(const RobotModel& model, Rng* rng);

}  // namespace robocal
