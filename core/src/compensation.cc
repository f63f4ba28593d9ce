// Compensation: damped least squares inverse kinematics on the calibrated model, within the joint limits.
#include "robocal/core/compensation.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <atomic>
#include <exception>
#include <stdexcept>
#include <thread>

#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"

namespace robocal {
namespace {

// Damping never goes below this: a singular J'J (e.g. the 5-axis robot's C axis parallel to the tool axis) must
// still give a finite step.
constexpr double kMinDamping = 1e-9;
constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// Rows matched: the full pose for 6 or more joints; position and tool axis for fewer, since a 5-joint robot
// cannot reach an arbitrary 6-D pose (the rotation about the tool axis is then free).
MeasurementType MatchedRows(const RobotModel& model) {
  return model.num_joints() >= 6 ? MeasurementType::kPose : MeasurementType::kPositionAxis;
}

struct Errors {
  double position_mm = 0.0;
  double orientation_rad = 0.0;
};

// The position error and the angle over the matched rotations, computed exactly (not from the linearised rows).
Errors MatchedErrors(MeasurementType type, const Transform& reached, const Transform& target) {
  Errors e;
  e.position_mm = (target.translation() - reached.translation()).norm();
  if (type == MeasurementType::kPose) {
    e.orientation_rad = RotationVector(target.linear() * reached.linear().transpose()).norm();
  } else {
    const Eigen::Vector3d u = reached.linear().col(2), u_target = target.linear().col(2);
    e.orientation_rad = AngleBetween(u, u_target);
  }
  return e;
}

// Angle about the tool axis from the target's x axis to the reached x axis, both projected on the plane
// perpendicular to the reached tool axis (rad, in (-pi, pi]).
double FreeRotation(const Transform& reached, const Transform& target) {
  const Eigen::Matrix3d r = reached.linear();
  const Eigen::Vector3d x_target = target.linear().col(0);
  return -std::atan2(r.col(1).dot(x_target), r.col(0).dot(x_target));
}

// The solver's rows for one target: the position error (mm) and the weighted orientation error (mm per rad
// times rad), with their exact derivatives. MeasurementResidual's rows are not used here: their Jacobian is
// exact only at zero residual, and near a singularity that small mismatch, multiplied by a large inverse,
// turns Gauss-Newton's quadratic convergence into a crawl.
class Rows {
 public:
  Rows(MeasurementType type, const Transform& T_world_target, double orientation_weight)
      : type_(type), target_(T_world_target), weight_(orientation_weight) {
    // Axis rows use a tangent basis of the fixed target axis, so the residual -t_k . u has the exact
    // derivative -t_k . (omega x u) and vanishes exactly when the axes coincide.
    if (type_ == MeasurementType::kPositionAxis) TangentBasis(target_.linear().col(2), &t1_, &t2_);
  }

  int size() const { return MeasurementRows(type_); }

  // r = target - reached, weighted.
  void Residual(const Transform& reached, Eigen::VectorXd* r) const {
    r->head<3>() = target_.translation() - reached.translation();
    if (type_ == MeasurementType::kPose) {
      r->tail<3>() = weight_ * RotationVector(target_.linear() * reached.linear().transpose());
    } else {
      const Eigen::Vector3d u = reached.linear().col(2);
      (*r)[3] = -weight_ * t1_.dot(u);
      (*r)[4] = -weight_ * t2_.dot(u);
    }
  }

  // J with r(q + dq) ~= r(q) - J dq, from the joint twists (JointJacobian kPose: dp rows, omega rows) at the
  // reached pose and the current residual r.
  void Jacobian(const Transform& reached, const Eigen::VectorXd& r, const Eigen::MatrixXd& twists,
                Eigen::MatrixXd* jacobian) const {
    jacobian->topRows<3>() = twists.topRows<3>();
    if (type_ == MeasurementType::kPose) {
      // r = log(R_t R^T); turning R by omega changes it by -Jr^-1(r) omega (Jr: the right Jacobian of SO(3)).
      jacobian->bottomRows<3>() = weight_ * InverseRightJacobian(r.tail<3>() / weight_) * twists.bottomRows<3>();
    } else {
      const Eigen::Vector3d u = reached.linear().col(2);
      for (int j = 0; j < twists.cols(); ++j) {
        const Eigen::Vector3d du = twists.col(j).tail<3>().cross(u);
        (*jacobian)(3, j) = weight_ * t1_.dot(du);
        (*jacobian)(4, j) = weight_ * t2_.dot(du);
      }
    }
  }

 private:
  static Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
    Eigen::Matrix3d m;
    m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return m;
  }

  // Jr^-1(phi) = I + [phi]/2 + (1/theta^2 - (1 + cos theta) / (2 theta sin theta)) [phi]^2.
  static Eigen::Matrix3d InverseRightJacobian(const Eigen::Vector3d& phi) {
    const double theta = phi.norm();
    const Eigen::Matrix3d hat = Hat(phi);
    // Series below 1e-4 rad: the closed form loses all its digits there; the next term is theta^2 / 720.
    const double c =
        theta < 1e-4 ? 1.0 / 12.0 : 1.0 / (theta * theta) - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta));
    return Eigen::Matrix3d::Identity() + 0.5 * hat + c * hat * hat;
  }

  MeasurementType type_;
  Transform target_;
  double weight_;
  Eigen::Vector3d t1_ = Eigen::Vector3d::Zero(), t2_ = Eigen::Vector3d::Zero();
};

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", value);
  return text;
}

// Damped least squares on the calibrated model, within the joint limits.
class Solver {
 public:
  struct Outcome {
    Eigen::VectorXd q;
    double cost = HUGE_VAL;
    int iterations = 0;
    bool converged = false;
    /// No step lowered the error any more (as opposed to running out of iterations).
    bool stalled = false;
  };
  Solver(const Calibration& calibration, MeasurementType type, const CompensationOptions& options)
      : calibration_(calibration),
        model_(calibration.model),
        type_(type),
        options_(options),
        ws_(model_),
        twists_(6, model_.num_joints()) {}

  Transform Reached(const Eigen::VectorXd& q) { return ForwardKinematics(model_, q, calibration_.errors, &ws_); }

  // Levenberg-Marquardt with the gain-ratio damping schedule of Nielsen (1999), as given by Madsen, Nielsen &
  // Tingleff, "Methods for non-linear least squares problems" (2004), section 3.2: mu starts at 1e-6 x the
  // largest diagonal element of J'J, shrinks by max(1/3, 1 - (2 rho - 1)^3) after a step that lowers the error
  // (rho: actual over predicted decrease), and grows by nu (doubling each time) after one that does not. A
  // joint at a limit whose descent direction points out of the range is held there (an active set), so the
  // other joints still make the progress they can.
  Outcome Solve(const Transform& T_world_target, const Eigen::VectorXd& q0, int max_iterations) {
    const Rows rows(type_, T_world_target, options_.orientation_weight_mm_per_rad);
    const int n = model_.num_joints();
    const Eigen::VectorXd& lower = model_.lower_limits();
    const Eigen::VectorXd& upper = model_.upper_limits();
    Eigen::MatrixXd jacobian(rows.size(), n);
    Eigen::VectorXd residual(rows.size()), trial_residual(rows.size());
    auto cost_at = [&](const Eigen::VectorXd& joints, Eigen::VectorXd* r) {
      rows.Residual(Reached(joints), r);
      return r->squaredNorm();
    };
    Outcome out;
    out.q = q0;
    out.cost = cost_at(out.q, &residual);
    double mu = -1.0, nu = 2.0;
    for (;; ++out.iterations) {
      const Errors e = MatchedErrors(type_, ws_.T_world_tool, T_world_target);
      if (e.position_mm < options_.position_tolerance_mm && e.orientation_rad < options_.orientation_tolerance_rad) {
        out.converged = true;
        return out;
      }
      if (out.iterations >= max_iterations) return out;
      JointJacobian(model_, out.q, calibration_.errors, MeasurementType::kPose, &ws_, twists_);
      rows.Jacobian(ws_.T_world_tool, residual, twists_, &jacobian);
      // The joint-sized work is in matrices of at most kMaxJoints rows on the stack: no allocation per
      // iteration (the solver runs for every target of a request).
      const JointVector gradient = jacobian.transpose() * residual;
      std::array<bool, kMaxJoints> held{};
      for (int i = 0; i < n; ++i) held[i] = AtLowerLimit(out.q, gradient, i) || AtUpperLimit(out.q, gradient, i);
      const JointMatrix normal = jacobian.transpose() * jacobian;
      if (mu < 0.0) mu = std::max(options_.initial_damping * normal.diagonal().maxCoeff(), kMinDamping);
      bool accepted = false;
      while (!accepted) {
        JointMatrix a = normal;
        a.diagonal().array() += mu;
        JointVector b = gradient;
        for (int i = 0; i < n; ++i) {
          if (!held[i]) continue;
          a.row(i).setZero();
          a.col(i).setZero();
          a(i, i) = 1.0;
          b[i] = 0.0;
        }
        ldlt_.compute(a);
        const JointVector dq = ldlt_.solve(b);
        q_trial_ = (out.q + dq).cwiseMax(lower).cwiseMin(upper);
        const double trial_cost = dq.allFinite() ? cost_at(q_trial_, &trial_residual) : HUGE_VAL;
        const JointVector step = q_trial_ - out.q;
        // The decrease the linear model predicts: |r|^2 - |r - J s|^2 = 2 s'J'r - s'J'J s.
        const double predicted = 2.0 * step.dot(gradient) - step.dot(normal * step);
        if (trial_cost < out.cost) {
          const double rho = predicted > 0.0 ? (out.cost - trial_cost) / predicted : 1.0;
          out.q = q_trial_;
          out.cost = trial_cost;
          residual = trial_residual;
          mu = std::max(mu * std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3)), kMinDamping);
          nu = 2.0;
          accepted = true;
        } else {
          mu *= nu;
          nu *= 2.0;
          if (mu > options_.max_damping * options_.max_damping) break;
        }
      }
      if (!accepted) {
        Reached(out.q);  // leave the workspace at the best point
        out.stalled = true;
        ++out.iterations;
        return out;
      }
    }
  }

  // Whether a joint is held at a limit that the error at q pulls outward, and the message naming them.
  std::string HeldLimits(const Transform& T_world_target, const Eigen::VectorXd& q) {
    Eigen::VectorXd r;
    const Eigen::MatrixXd jacobian = MatchedJacobian(T_world_target, q, &r);
    const Eigen::VectorXd gradient = jacobian.transpose() * r;
    std::string limits;
    for (int i = 0; i < model_.num_joints(); ++i) {
      const bool at_lower = AtLowerLimit(q, gradient, i);
      if (!at_lower && !AtUpperLimit(q, gradient, i)) continue;
      limits += "joint " + std::to_string(i + 1) + " (" + model_.joint_name(i) + ") at its " +
                (at_lower ? "lower limit " + LimitText(i, model_.lower_limits()[i])
                          : "upper limit " + LimitText(i, model_.upper_limits()[i])) +
                "; ";
    }
    return limits;
  }

  // The singular values of the matched Jacobian at q (mm/rad, orientation rows weighted).
  Eigen::VectorXd SingularValues(const Transform& T_world_target, const Eigen::VectorXd& q) {
    Eigen::VectorXd r;
    return Eigen::JacobiSVD<Eigen::MatrixXd>(MatchedJacobian(T_world_target, q, &r)).singularValues();
  }

 private:
  // The solver's rows at q: the residual *r against the target and its Jacobian.
  Eigen::MatrixXd MatchedJacobian(const Transform& T_world_target, const Eigen::VectorXd& q, Eigen::VectorXd* r) {
    const Rows rows(type_, T_world_target, options_.orientation_weight_mm_per_rad);
    r->resize(rows.size());
    rows.Residual(Reached(q), r);
    Eigen::MatrixXd jacobian(rows.size(), model_.num_joints());
    JointJacobian(model_, q, calibration_.errors, MeasurementType::kPose, &ws_, twists_);
    rows.Jacobian(ws_.T_world_tool, *r, twists_, &jacobian);
    return jacobian;
  }

  // Joint i sits at a limit that the descent direction (gradient = J'r) pulls it out of.
  template <typename Gradient>
  bool AtLowerLimit(const Eigen::VectorXd& q, const Gradient& gradient, int i) const {
    return q[i] <= model_.lower_limits()[i] && gradient[i] < 0.0;
  }
  template <typename Gradient>
  bool AtUpperLimit(const Eigen::VectorXd& q, const Gradient& gradient, int i) const {
    return q[i] >= model_.upper_limits()[i] && gradient[i] > 0.0;
  }

  // A limit in the joint's wire unit (deg for revolute joints, mm for prismatic ones).
  std::string LimitText(int joint, double value) const {
    return model_.joint_type(joint) == JointType::kRevolute ? Number(value * kDegPerRad) + " deg"
                                                            : Number(value) + " mm";
  }

  using JointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxJoints, 1>;
  using JointMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxJoints, kMaxJoints>;

  const Calibration& calibration_;
  const RobotModel& model_;
  MeasurementType type_;
  const CompensationOptions& options_;
  KinematicsWorkspace ws_;
  Eigen::MatrixXd twists_;
  Eigen::LDLT<JointMatrix> ldlt_;
  Eigen::VectorXd q_trial_;
};

}  // namespace

const char* ToString(TargetFrame frame) { return frame == TargetFrame::kBase ? "base" : "tracker"; }

bool ParseTargetFrame(const std::string& text, TargetFrame* frame) {
  for (TargetFrame f : {TargetFrame::kTracker, TargetFrame::kBase}) {
    if (text == ToString(f)) {
      *frame = f;
      return true;
    }
  }
  return false;
}

bool CompensationOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    *error = message;
    return false;
  };
  if (!(initial_damping > 0.0) || !std::isfinite(initial_damping)) {
    return fail("initial_damping must be positive and finite");
  }
  if (!(max_damping > initial_damping) || !std::isfinite(max_damping)) {
    return fail("max_damping must be finite and greater than initial_damping");
  }
  if (max_iterations < 1 || max_iterations > 100000) return fail("max_iterations must be in [1, 100000]");
  if (!(position_tolerance_mm > 0.0) || !std::isfinite(position_tolerance_mm)) {
    return fail("position_tolerance_mm must be positive and finite");
  }
  if (!(orientation_tolerance_rad > 0.0) || !std::isfinite(orientation_tolerance_rad)) {
    return fail("orientation_tolerance_rad must be positive and finite");
  }
  if (!(orientation_weight_mm_per_rad > 0.0) || !std::isfinite(orientation_weight_mm_per_rad)) {
    return fail("orientation_weight_mm_per_rad must be positive and finite");
  }
  return true;
}

CompensationResult CompensatePose(const Calibration& calibration, const Transform& target, TargetFrame frame,
                                  const Eigen::VectorXd& q_start, const CompensationOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("CompensationOptions: " + error);
  const RobotModel& model = calibration.model;
  const int n = model.num_joints();
  if (q_start.size() != n) {
    throw std::invalid_argument("CompensatePose: q_start has " + std::to_string(q_start.size()) +
                                " values, the robot " + std::to_string(n) + " joints");
  }
  if (!q_start.allFinite()) throw std::invalid_argument("CompensatePose: q_start is not finite");
  if (calibration.errors.size() != 0 && calibration.errors.size() != model.num_error_parameters()) {
    throw std::invalid_argument("CompensatePose: calibration.errors has " + std::to_string(calibration.errors.size()) +
                                " values, expected " + std::to_string(model.num_error_parameters()));
  }
  // A NaN error parameter would otherwise surface as NaN joints, the one output compensation must never give.
  if (!calibration.errors.allFinite()) throw std::invalid_argument("CompensatePose: calibration.errors is not finite");
  if (!IsValidRigidTransform(target, 1e-6)) {
    throw std::invalid_argument("CompensatePose: target is not a finite rigid transform");
  }
  if (frame == TargetFrame::kBase && !IsValidRigidTransform(calibration.T_world_base, 1e-6)) {
    throw std::invalid_argument("CompensatePose: calibration.T_world_base is not a finite rigid transform");
  }

  const Transform T_world_target = frame == TargetFrame::kBase ? calibration.T_world_base * target : target;
  const MeasurementType type = MatchedRows(model);
  Solver solver(calibration, type, options);
  CompensationResult result;
  // A start outside the limits (e.g. a nominal command at a limit plus round-off) is projected inside.
  const Eigen::VectorXd start = q_start.cwiseMax(model.lower_limits()).cwiseMin(model.upper_limits());
  const Solver::Outcome outcome = solver.Solve(T_world_target, start, options.max_iterations);
  const Eigen::VectorXd& q = outcome.q;
  result.converged = outcome.converged;
  result.joints = q;
  result.iterations = outcome.iterations;
  const Transform reached = solver.Reached(q);
  const Errors e = MatchedErrors(type, reached, T_world_target);
  result.position_error_mm = e.position_mm;
  result.orientation_error_rad = e.orientation_rad;
  if (type == MeasurementType::kPositionAxis) result.free_rotation_rad = FreeRotation(reached, T_world_target);
  // Not expected (inputs are checked and every accepted step has a finite cost), but never handed out as usable.
  if (!q.allFinite() || !std::isfinite(e.position_mm) || !std::isfinite(e.orientation_rad)) {
    result.converged = false;
    result.termination = Termination::kFailure;
    result.message = "non-finite joints or errors";
    return result;
  }
  if (result.converged) {
    result.termination = Termination::kConvergence;
    return result;
  }

  // Say why: joints held at a limit first, then whether the solver ran out of iterations or of descent.
  const std::string limits = solver.HeldLimits(T_world_target, q);
  // A joint held at a limit is what keeps the robot from the target: weaker than asked, whatever stopped the loop.
  result.termination = limits.empty() ? Termination::kNoConvergence : Termination::kDegraded;
  result.message = limits + (outcome.stalled ? "no step lowers the error (target out of reach, or a singularity)"
                                             : "max_iterations (" + std::to_string(options.max_iterations) + ") reached");
  // How close to a singularity it ended: the smallest singular value of the matched Jacobian (orientation rows
  // weighted), against the largest.
  const Eigen::VectorXd sigma = solver.SingularValues(T_world_target, q);
  result.message += "; singular values of the Jacobian there " + Number(sigma.minCoeff()) + " to " +
                    Number(sigma.maxCoeff()) + " mm/rad";
  result.message += "; remaining error " + Number(e.position_mm) + " mm, " + Number(e.orientation_rad * kDegPerRad) +
                    " deg";
  return result;
}

CompensationResult CompensateJoints(const Calibration& calibration, const RobotModel& nominal,
                                    const Eigen::VectorXd& q_nominal, const CompensationOptions& options) {
  if (nominal.num_joints() != calibration.model.num_joints()) {
    throw std::invalid_argument("CompensateJoints: the nominal model has " + std::to_string(nominal.num_joints()) +
                                " joints, the calibrated one " + std::to_string(calibration.model.num_joints()));
  }
  if (q_nominal.size() != nominal.num_joints()) {
    throw std::invalid_argument("CompensateJoints: q_nominal has " + std::to_string(q_nominal.size()) +
                                " values, the robot " + std::to_string(nominal.num_joints()) + " joints");
  }
  // Checked here, not left to CompensatePose, whose complaint would be about the target made from it.
  if (!q_nominal.allFinite()) throw std::invalid_argument("CompensateJoints: q_nominal is not finite");
  // Where the program expects the tool, relative to the robot base: independent of where the tracker stands.
  const Transform T_base_tool = nominal.T_world_base().inverse() * ForwardKinematics(nominal, q_nominal);
  return CompensatePose(calibration, T_base_tool, TargetFrame::kBase, q_nominal, options);
}

CompensationResult Compensate(const Calibration& calibration, const RobotModel& nominal,
                              const CompensationTarget& target, const CompensationOptions& options) {
  return target.pose ? CompensatePose(calibration, *target.pose, target.frame, target.start, options)
                     : CompensateJoints(calibration, nominal, target.joints, options);
}

std::vector<CompensationResult> CompensateAll(const Calibration& calibration, const RobotModel& nominal,
                                              const std::vector<CompensationTarget>& targets,
                                              const CompensationOptions& options, int threads) {
  if (threads < 0) throw std::invalid_argument("CompensateAll: threads must be >= 0");
  std::vector<CompensationResult> results(targets.size());
  std::vector<std::exception_ptr> errors(targets.size());
  auto solve = [&](std::size_t i) {
    try {
      results[i] = Compensate(calibration, nominal, targets[i], options);
    } catch (...) {
      errors[i] = std::current_exception();
    }
  };
  // Targets are handed out in chunks from a shared counter; each result goes to its own slot, so the order
  // of the results is the order of the targets whatever thread solved them.
  constexpr std::size_t kChunk = 16;
  const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t wanted = threads == 0 ? hardware : static_cast<std::size_t>(threads);
  const std::size_t workers = std::min(wanted, (targets.size() + kChunk - 1) / kChunk);
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t begin = next.fetch_add(kChunk); begin < targets.size(); begin = next.fetch_add(kChunk)) {
      for (std::size_t i = begin; i < std::min(begin + kChunk, targets.size()); ++i) solve(i);
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  return results;
}

}  // namespace robocal
