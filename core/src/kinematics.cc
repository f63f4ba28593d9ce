// Forward kinematics through the chain of fixed transforms, error transforms and joint motions.
#include "robocal/core/kinematics.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "robocal/core/joint_errors.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

Transform JointMotion(JointType type, double q) {
  return type == JointType::kRevolute ? Rotation(RotZ(q)) : Translation(0, 0, q);
}

// t * JointMotion(type, q), for a revolute joint without the general product's terms that multiply a zero of RotZ:
// each column of t's rotation is the one of t * Rotation(RotZ(q)), with RotZ(q)'s entries as RotZ writes them (the
// axis-angle formula: cos, sin, and (1 - cos) + cos on the axis), summed in the product's order. The chain takes
// this step at every joint of every pose of every evaluation of a fit.
void ApplyJointMotion(JointType type, double q, Transform* t) {
  if (type != JointType::kRevolute) {
    *t = *t * JointMotion(type, q);
    return;
  }
  const double c = std::cos(q), s = std::sin(q), on_axis = (1.0 - c) + c;
  auto rotation = t->linear();
  const Eigen::Vector3d x = rotation.col(0), y = rotation.col(1);
  rotation.col(0) = x * c + y * s;
  rotation.col(1) = x * -s + y * c;
  rotation.col(2) *= on_axis;
}

void CheckSizes(const RobotModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& eps) {
  if (q.size() != model.num_joints()) {
    throw std::invalid_argument("ForwardKinematics: q has " + std::to_string(q.size()) + " values, robot '" +
                                model.name() + "' has " + std::to_string(model.num_joints()) + " joints");
  }
  if (eps.size() != 0 && eps.size() != model.num_error_parameters()) {
    throw std::invalid_argument("ForwardKinematics: eps has " + std::to_string(eps.size()) + " values, expected " +
                                std::to_string(model.num_error_parameters()) + " or 0");
  }
}

}  // namespace

KinematicsWorkspace::KinematicsWorkspace(const RobotModel& model)
    : T_world_site(model.num_error_sites(), Transform::Identity()),
      T_world_joint(model.num_joints(), Transform::Identity()) {}

Transform ErrorTransform(const double* delta) {
  Transform t = Transform::Identity();
  t.translation() = Eigen::Vector3d(delta[0], delta[1], delta[2]);
  t.linear() = RotX(delta[3]) * RotY(delta[4]) * RotZ(delta[5]);
  return t;
}

const KinematicsWorkspace::SiteErrors& SiteErrorsFor(const RobotModel& model, const Eigen::VectorXd& eps,
                                                     KinematicsWorkspace* ws) {
  KinematicsWorkspace::SiteErrors& e = ws->site_errors;
  const int sites = model.num_error_sites();
  const auto values = eps.head(6 * sites);
  if (e.values.size() == values.size() && (e.values.array() == values.array()).all()) return e;
  e.values = values;
  e.transform.resize(static_cast<size_t>(sites));
  e.rx.resize(static_cast<size_t>(sites));
  e.ry.resize(static_cast<size_t>(sites));
  for (int s = 0; s < sites; ++s) {
    const double* delta = eps.data() + 6 * s;
    e.transform[static_cast<size_t>(s)] = ErrorTransform(delta);
    e.rx[static_cast<size_t>(s)] = RotX(delta[3]);
    e.ry[static_cast<size_t>(s)] = RotY(delta[4]);
  }
  return e;
}

namespace {

// The chain at the joints in ws->q_effective (ForwardKinematics, once the deflection is added).
const Transform& ChainAtEffectiveJoints(const RobotModel& model, const Eigen::VectorXd& eps, KinematicsWorkspace* ws) {
  const bool with_errors = eps.size() != 0;
  const Eigen::VectorXd& q = ws->q_effective;
  const int n = model.num_joints();
  const std::vector<Transform>* errors = with_errors ? &SiteErrorsFor(model, eps, ws).transform : nullptr;
  auto apply_error = [&](int site, Transform* t) {
    if (with_errors) *t = *t * (*errors)[static_cast<size_t>(site)];
  };
  Transform t = model.T_world_base();
  ws->T_world_site[0] = t;
  apply_error(0, &t);
  for (int i = 0; i < n; ++i) {
    t = t * model.fixed_transform(i);
    ws->T_world_site[i + 1] = t;
    apply_error(i + 1, &t);
    ws->T_world_joint[i] = t;
    ApplyJointMotion(model.joint_type(i), q[i], &t);
  }
  t = t * model.T_lastjoint_flange() * model.T_flange_tool();
  ws->T_world_site[n + 1] = t;
  apply_error(n + 1, &t);
  ws->T_world_tool = t;
  return ws->T_world_tool;
}

}  // namespace

const Transform& ForwardKinematics(const RobotModel& model, const Eigen::VectorXd& q_command,
                                   const Eigen::VectorXd& eps, KinematicsWorkspace* ws, const Payload& payload) {
  CheckSizes(model, q_command, eps);
  ws->q_effective = q_command;
  if (model.deflects()) ws->q_effective += JointDeflection(model, q_command, eps, payload);
  return ChainAtEffectiveJoints(model, eps, ws);
}

const Transform& ForwardKinematics(const RobotModel& model, const Eigen::VectorXd& q_command,
                                   const Eigen::VectorXd& eps, KinematicsWorkspace* ws,
                                   const PreparedDeflection& prepared) {
  CheckSizes(model, q_command, eps);
  ws->q_effective = q_command;
  if (model.deflects()) ws->q_effective += JointDeflection(model, prepared, eps);
  return ChainAtEffectiveJoints(model, eps, ws);
}

Transform ForwardKinematics(const RobotModel& model, const Eigen::VectorXd& q) {
  KinematicsWorkspace ws(model);
  return ForwardKinematics(model, q, Eigen::VectorXd(), &ws);
}

void NominalChainInBase(const RobotModel& model, const Eigen::VectorXd& q, Transform* T_base_joint,
                        Transform* T_base_flange) {
  CheckSizes(model, q, Eigen::VectorXd());
  Transform t = Transform::Identity();
  for (int i = 0; i < model.num_joints(); ++i) {
    t = t * model.fixed_transform(i);
    T_base_joint[i] = t;
    t = t * JointMotion(model.joint_type(i), q[i]);
  }
  *T_base_flange = t * model.T_lastjoint_flange();
}

FoldedChain::FoldedChain(const RobotModel& model, const Eigen::VectorXd& eps, const Payload& payload) {
  const int n = model.num_joints();
  CheckSizes(model, Eigen::VectorXd::Zero(n), eps);
  const bool with_errors = eps.size() != 0;
  if (model.deflects()) {
    model_ = std::make_shared<const RobotModel>(model);
    eps_ = eps;
    payload_ = payload;
  }
  auto error = [&](int site) { return with_errors ? ErrorTransform(eps.data() + 6 * site) : Transform::Identity(); };
  Transform t = model.T_world_base() * error(0);
  for (int i = 0; i < n; ++i) {
    before_.push_back(t * model.fixed_transform(i) * error(i + 1));
    types_.push_back(model.joint_type(i));
    t = Transform::Identity();
  }
  after_ = model.T_lastjoint_flange() * model.T_flange_tool() * error(n + 1);
  if (n == 0) after_ = t * after_;
}

FoldedChain FoldedChain::WithPayload(const Payload& payload) const {
  FoldedChain out = *this;
  out.payload_ = payload;
  return out;
}

Transform FoldedChain::Forward(const Eigen::Ref<const Eigen::VectorXd>& q, Transform* T_world_joint) const {
  if (model_ == nullptr) return ForwardAt(q, T_world_joint);
  const Eigen::VectorXd command = q;
  const Eigen::VectorXd deflected = command + JointDeflection(*model_, command, eps_, payload_);
  return ForwardAt(deflected, T_world_joint);
}

Transform FoldedChain::ForwardAt(const Eigen::Ref<const Eigen::VectorXd>& q, Transform* T_world_joint) const {
  const int n = num_joints();
  Transform t = before_.empty() ? Transform::Identity() : before_[0];
  for (int i = 0; i < n; ++i) {
    if (i > 0) t = t * before_[i];
    if (T_world_joint != nullptr) T_world_joint[i] = t;
    // The joint's motion applied in place: a rotation about z mixes the frame's x and y columns, a translation
    // along z moves the origin along the z column (cheaper than a general transform product).
    if (types_[i] == JointType::kRevolute) {
      const double c = std::cos(q[i]), s = std::sin(q[i]);
      const Eigen::Vector3d x = t.linear().col(0), y = t.linear().col(1);
      t.linear().col(0) = c * x + s * y;
      t.linear().col(1) = c * y - s * x;
    } else {
      t.translation() += q[i] * t.linear().col(2);
    }
  }
  return t * after_;
}

Eigen::VectorXd RandomConfiguration(const RobotModel& model, Rng* rng) {
  Eigen::VectorXd q(model.num_joints());
  for (int i = 0; i < model.num_joints(); ++i) q[i] = rng->Uniform(model.lower_limits()[i], model.upper_limits()[i]);
  return q;
}

}  // namespace robocal
