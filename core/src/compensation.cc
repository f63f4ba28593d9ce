// Compensation: damped least squares inverse kinematics on the calibrated model, within the joint limits.
#include "robocal/core/compensation.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/units.h"
#include "parallel_internal.h"

namespace robocal {
namespace {

// Damping never goes below this: a singular J'J (e.g. the 5-axis robot's C axis parallel to the tool axis) must
// still give a finite step.
constexpr double kMinDamping = 1e-9;

// Rows matched: the full pose for 6 or more joints; position and tool axis for fewer, since a 5-joint robot
// cannot reach an arbitrary 6-D pose (the rotation about the tool axis is then free).
MeasurementType MatchedRows(const RobotModel& model) {
  return model.num_joints() >= 6 ? MeasurementType::kPose : MeasurementType::kPositionAxis;
}

struct Errors {
  double position_mm = 0.0;
  double orientation_rad = 0.0;
};

// The one convergence test, wherever a result is judged: both remaining errors within the options' tolerances.
// The Jacobian's conditioning plays no part: a result this close to its target is an answer, singular or not.
bool WithinTolerance(const Errors& e, const CompensationOptions& options) {
  return e.position_mm <= options.position_tolerance_mm && e.orientation_rad <= options.orientation_tolerance_rad;
}

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

using JointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxJoints, 1>;
using JointMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxJoints, kMaxJoints>;
using TwistMatrix = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxJoints>;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 6, kMaxJoints>;
// Residual rows: all six for a pose, the first five for position and axis.
using RowVector = Eigen::Matrix<double, 6, 1>;

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
  void Residual(const Transform& reached, RowVector* r) const {
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
  void Jacobian(const Transform& reached, const RowVector& r, const TwistMatrix& twists, RowMatrix* jacobian) const {
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


// Damped least squares on the calibrated model (its error parameters folded into one chain), within the joint
// limits.
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
  Solver(const RobotModel& model, const FoldedChain& chain, MeasurementType type, const CompensationOptions& options)
      : model_(model), chain_(chain), type_(type), options_(options) {}

  Transform Reached(const Eigen::Ref<const Eigen::VectorXd>& q) { return chain_.Forward(q, frames_a_.data()); }

  // Levenberg-Marquardt with the gain-ratio damping schedule of Nielsen (1999), as given by Madsen, Nielsen &
  // Tingleff, "Methods for non-linear least squares problems" (2004), section 3.2: mu starts at initial_damping x
  // the largest diagonal element of J'J, shrinks by max(1/3, 1 - (2 rho - 1)^3) after a step that lowers the
  // error (rho: actual over predicted decrease), and grows by nu (doubling each time) after one that does not. A
  // joint at a limit whose descent direction points out of the range is held there (an active set), so the
  // other joints still make the progress they can.
  // `initial_damping` takes the place of options_.initial_damping (the start of mu, relative to J'J).
  Outcome Solve(const Transform& T_world_target, const Eigen::VectorXd& q0, int max_iterations,
                double initial_damping) {
    const Rows rows(type_, T_world_target, options_.orientation_weight_mm_per_rad);
    const int n = model_.num_joints();
    const Eigen::VectorXd& lower = model_.lower_limits();
    const Eigen::VectorXd& upper = model_.upper_limits();
    // The joint-sized work is in matrices of at most kMaxJoints columns on the stack: no allocation per
    // iteration (the solver runs for every target of a request).
    RowMatrix jacobian(rows.size(), n);
    RowVector residual = RowVector::Zero(), trial_residual = RowVector::Zero();
    JointVector q = q0, q_trial(n);
    // The joint frames at q and at the trial point; swapped when a trial is accepted.
    Transform* frames = frames_a_.data();
    Transform* trial_frames = frames_b_.data();
    Transform reached = chain_.Forward(q, frames);
    auto cost_of = [&](const Transform& pose, RowVector* r) {
      rows.Residual(pose, r);
      return r->head(rows.size()).squaredNorm();
    };
    Outcome out;
    out.cost = cost_of(reached, &residual);
    double mu = -1.0, nu = 2.0;
    for (;; ++out.iterations) {
      if (WithinTolerance(MatchedErrors(type_, reached, T_world_target), options_)) {
        out.converged = true;
        break;
      }
      if (out.iterations >= max_iterations) break;
      Twists(reached, frames);
      rows.Jacobian(reached, residual, twists_, &jacobian);
      const JointVector gradient = jacobian.transpose() * residual.head(rows.size());
      std::array<bool, kMaxJoints> held{};
      for (int i = 0; i < n; ++i) held[i] = AtLowerLimit(q, gradient, i) || AtUpperLimit(q, gradient, i);
      const JointMatrix normal = jacobian.transpose() * jacobian;
      if (mu < 0.0) mu = std::max(initial_damping * normal.diagonal().maxCoeff(), kMinDamping);
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
        q_trial = (q + dq).cwiseMax(lower).cwiseMin(upper);
        Transform trial = Transform::Identity();
        double trial_cost = HUGE_VAL;
        if (dq.allFinite()) {
          trial = chain_.Forward(q_trial, trial_frames);
          trial_cost = cost_of(trial, &trial_residual);
        }
        const JointVector step = q_trial - q;
        // The decrease the linear model predicts: |r|^2 - |r - J s|^2 = 2 s'J'r - s'J'J s.
        const double predicted = 2.0 * step.dot(gradient) - step.dot(normal * step);
        if (trial_cost < out.cost) {
          const double rho = predicted > 0.0 ? (out.cost - trial_cost) / predicted : 1.0;
          q = q_trial;
          reached = trial;
          std::swap(frames, trial_frames);
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
        out.stalled = true;
        ++out.iterations;
        break;
      }
    }
    out.q = q;
    return out;
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
  // The joint twists (position rows: velocity of the tool point; orientation rows: angular velocity) at the
  // reached pose, from the joint frames of the same forward kinematics.
  void Twists(const Transform& reached, const Transform* frames) {
    const int n = model_.num_joints();
    twists_.resize(6, n);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d axis = frames[i].linear().col(2);
      if (model_.joint_type(i) == JointType::kRevolute) {
        twists_.col(i) << axis.cross(reached.translation() - frames[i].translation()), axis;
      } else {
        twists_.col(i) << axis, Eigen::Vector3d::Zero();
      }
    }
  }

  // The solver's rows at q: the residual *r against the target and its Jacobian.
  Eigen::MatrixXd MatchedJacobian(const Transform& T_world_target, const Eigen::VectorXd& q, Eigen::VectorXd* r) {
    const Rows rows(type_, T_world_target, options_.orientation_weight_mm_per_rad);
    const Transform reached = Reached(q);
    RowVector residual = RowVector::Zero();
    rows.Residual(reached, &residual);
    *r = residual.head(rows.size());
    Twists(reached, frames_a_.data());
    RowMatrix jacobian(rows.size(), model_.num_joints());
    rows.Jacobian(reached, residual, twists_, &jacobian);
    return jacobian;
  }

  // Joint i sits at a limit that the descent direction (gradient = J'r) pulls it out of.
  template <typename Joints, typename Gradient>
  bool AtLowerLimit(const Joints& q, const Gradient& gradient, int i) const {
    return q[i] <= model_.lower_limits()[i] && gradient[i] < 0.0;
  }
  template <typename Joints, typename Gradient>
  bool AtUpperLimit(const Joints& q, const Gradient& gradient, int i) const {
    return q[i] >= model_.upper_limits()[i] && gradient[i] > 0.0;
  }

  // A limit in the joint's wire unit (deg for revolute joints, mm for prismatic ones).
  std::string LimitText(int joint, double value) const {
    return model_.joint_type(joint) == JointType::kRevolute ? Number(value * kDegPerRad) + " deg"
                                                            : Number(value) + " mm";
  }

  const RobotModel& model_;
  const FoldedChain& chain_;
  MeasurementType type_;
  const CompensationOptions& options_;
  std::array<Transform, kMaxJoints> frames_a_, frames_b_;
  TwistMatrix twists_;
  Eigen::LDLT<JointMatrix> ldlt_;
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
  if (!(start_damping > 0.0) || !std::isfinite(start_damping)) return fail("start_damping must be positive and finite");
  if (!(max_damping > initial_damping) || !(max_damping > start_damping) || !std::isfinite(max_damping)) {
    return fail("max_damping must be finite and greater than initial_damping and start_damping");
  }
  if (!(start_radius_rad >= 0.0) || !std::isfinite(start_radius_rad)) {
    return fail("start_radius_rad must be >= 0 and finite");
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

namespace {

// What every target of one request shares: the calibrated chain, the nominal one, the named branches.
struct Context {
  Context(const Calibration& c, const RobotModel& n, const CompensationOptions& o)
      : calibration(c),
        nominal(n),
        options(o),
        chain(c.model, c.errors),  // no payload: SolveTarget puts a target's own on it
        nominal_chain(n, Eigen::VectorXd()),
        T_base_world(n.T_world_base().inverse()),
        type(MatchedRows(c.model)),
        arm(ArmSolver::For(c.model)),
        default_joints(DefaultJoints(c.model)) {}
  const Calibration& calibration;
  const RobotModel& nominal;
  const CompensationOptions& options;
  FoldedChain chain;
  FoldedChain nominal_chain;
  Transform T_base_world;
  MeasurementType type;
  std::optional<ArmSolver> arm;
  Eigen::VectorXd default_joints;
};

void CheckCalibration(const Calibration& calibration, const CompensationOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("CompensationOptions: " + error);
  const RobotModel& model = calibration.model;
  if (calibration.errors.size() != 0 && calibration.errors.size() != model.num_error_parameters()) {
    throw std::invalid_argument("Compensate: calibration.errors has " + std::to_string(calibration.errors.size()) +
                                " values, expected " + std::to_string(model.num_error_parameters()));
  }
  // A NaN error parameter would otherwise surface as NaN joints, the one output compensation must never give.
  if (!calibration.errors.allFinite()) throw std::invalid_argument("Compensate: calibration.errors is not finite");
  if (!IsValidRigidTransform(calibration.T_world_base, 1e-6)) {
    throw std::invalid_argument("Compensate: calibration.T_world_base is not a finite rigid transform");
  }
}

void CheckJoints(const RobotModel& model, const Eigen::VectorXd& q, const char* what) {
  if (q.size() != model.num_joints()) {
    throw std::invalid_argument(std::string("Compensate: ") + what + " has " + std::to_string(q.size()) +
                                " values, the robot " + std::to_string(model.num_joints()) + " joints");
  }
  if (!q.allFinite()) throw std::invalid_argument(std::string("Compensate: ") + what + " is not finite");
}

// One solver run from `start` (projected into the limits first), with the result's errors and, when not
// converged, why not. `initial_damping`: options.initial_damping unless given.
CompensationResult SolveFrom(const Context& ctx, const Transform& T_world_target, const Eigen::VectorXd& q_start,
                             std::optional<double> initial_damping = std::nullopt) {
  const RobotModel& model = ctx.calibration.model;
  Solver solver(model, ctx.chain, ctx.type, ctx.options);
  CompensationResult result;
  // A start outside the limits (e.g. a nominal command at a limit plus round-off) is projected inside.
  const Eigen::VectorXd start = q_start.cwiseMax(model.lower_limits()).cwiseMin(model.upper_limits());
  const Solver::Outcome outcome = solver.Solve(T_world_target, start, ctx.options.max_iterations,
                                               initial_damping.value_or(ctx.options.initial_damping));
  const Eigen::VectorXd& q = outcome.q;
  result.joints = q;
  result.iterations = outcome.iterations;
  const Transform reached = solver.Reached(q);
  const Errors e = MatchedErrors(ctx.type, reached, T_world_target);
  result.position_error_mm = e.position_mm;
  result.orientation_error_rad = e.orientation_rad;
  if (ctx.type == MeasurementType::kPositionAxis) result.free_rotation_rad = FreeRotation(reached, T_world_target);
  // Judged on the errors handed out, by the solver's own test.
  result.converged = WithinTolerance(e, ctx.options);
  // Not expected (inputs are checked and every accepted step has a finite cost), but never handed out as usable.
  if (!q.allFinite() || !std::isfinite(e.position_mm) || !std::isfinite(e.orientation_rad)) {
    result.converged = false;
    result.termination = Termination::kFailure;
    result.message = "non-finite joints or errors";
    return result;
  }
  if (ctx.arm) result.configuration = ctx.arm->ConfigurationOf(q);
  if (result.converged) {
    result.termination = Termination::kConvergence;
    return result;
  }

  // Say why: joints held at a limit first, then whether the solver ran out of iterations or of descent.
  const std::string limits = solver.HeldLimits(T_world_target, q);
  // A joint held at a limit is what keeps the robot from the target: weaker than asked, whatever stopped the loop.
  result.termination = limits.empty() ? Termination::kNoConvergence : Termination::kDegraded;
  result.message = limits + (outcome.stalled ? "no step lowers the error (target out of reach, or a singularity)"
                                             : "max_iterations (" + std::to_string(ctx.options.max_iterations) +
                                                   ") reached");
  // How close to a singularity it ended: the smallest singular value of the matched Jacobian (orientation rows
  // weighted), against the largest.
  const Eigen::VectorXd sigma = solver.SingularValues(T_world_target, q);
  result.message += "; singular values of the Jacobian there " + Number(sigma.minCoeff()) + " to " +
                    Number(sigma.maxCoeff()) + " mm/rad";
  result.message += "; remaining error " + Number(e.position_mm) + " mm, " + Number(e.orientation_rad * kDegPerRad) +
                    " deg";
  return result;
}

// Of two results, the one nearer its target (converged first; then the weighted error).
bool Better(const CompensationResult& a, const CompensationResult& b, double weight) {
  if (a.converged != b.converged) return a.converged;
  return a.position_error_mm + weight * a.orientation_error_rad < b.position_error_mm + weight * b.orientation_error_rad;
}

// Revolute joint values of a closed-form solution placed in the limits: of q + 2 pi k, the one within the
// range nearest the reference; a joint with none within its range keeps the one nearest the range (the solver
// projects it in, and ends held at the limit). Returns the joints left outside.
int PlaceInLimits(const RobotModel& model, const Eigen::VectorXd& reference, Eigen::VectorXd* q) {
  int outside = 0;
  constexpr double kTurn = 2.0 * std::numbers::pi;
  for (int i = 0; i < model.num_joints(); ++i) {
    const double lower = model.lower_limits()[i], upper = model.upper_limits()[i];
    const double base = (*q)[i];
    double best = base, best_distance = HUGE_VAL;
    bool inside = false;
    // Every turn within the range (a joint range spans at most a few turns) and the nearest ones outside it.
    const double k_low = std::floor((lower - base) / kTurn), k_high = std::ceil((upper - base) / kTurn);
    for (double k = k_low; k <= k_high; ++k) {
      const double v = base + k * kTurn;
      const bool in = v >= lower - 1e-12 && v <= upper + 1e-12;
      const double distance = in ? std::abs(v - reference[i]) : std::max(lower - v, v - upper) + 1e6;
      if ((in && !inside) || (in == inside && distance < best_distance)) {
        best = std::clamp(v, lower, upper);
        best_distance = distance;
        inside = inside || in;
      }
    }
    (*q)[i] = best;
    if (!inside) ++outside;
  }
  return outside;
}

// A result without joints: FAILURE, its errors unknown (NaN, null on the wire), not zero.
CompensationResult NoSolution(int iterations, std::string message) {
  CompensationResult none;
  none.termination = Termination::kFailure;
  none.iterations = iterations;
  none.position_error_mm = std::numeric_limits<double>::quiet_NaN();
  none.orientation_error_rad = std::numeric_limits<double>::quiet_NaN();
  none.message = std::move(message);
  return none;
}

// A converged result with the demanded flags (SolveOnBranches): its joints at the turns nearest the reference (a
// revolute joint's other turns reach the same pose), its flags differing from the wanted ones, its squared distance.
struct BranchFound {
  CompensationResult result;
  Eigen::VectorXd joints;
  int mismatch = 0;
  double distance2 = 0.0;
};

// A nominal closed-form solution as a start of SolveOnBranches, with what orders the starts.
struct BranchStart {
  Eigen::VectorXd q;
  ArmConfiguration configuration;
  int other_branch = 0;
  int mismatch = 0;
  int outside = 0;
  int inexact = 0;
  double distance = 0.0;
};

// The branch wanted: the demanded flags, the rest from the hint (else front, up, noflip).
ArmConfiguration WantedBranch(const ArmSolver& arm, const Eigen::VectorXd* hint, const ArmConfiguration& demanded) {
  ArmConfiguration wanted = hint != nullptr ? arm.ConfigurationOf(*hint) : ArmConfiguration{1, 1, 1};
  if (demanded.shoulder != 0) wanted.shoulder = demanded.shoulder;
  if (demanded.elbow != 0) wanted.elbow = demanded.elbow;
  if (demanded.wrist != 0) wanted.wrist = demanded.wrist;
  return wanted;
}

// A pose target on a robot with named branches. With a hint (start or previous joints) the answer is, of the
// converged results with the demanded flags, the one on the wanted branch (else the one missing the fewest and
// least important wanted flags: shoulder before elbow before wrist) nearest the hint, each joint at its turn
// nearest it within the limits; when one of them lies within options.start_radius_rad of the hint, only those
// within that radius beyond the nearest count (the robot does not swing from taught joints). The runs that look
// for it:
// 1. from the hint, with options.start_damping: when it converges on the wanted branch within the start radius,
//    the solution the hint leads to is the answer (hint joints that reach the target come back as they are,
//    without an iteration);
// 2. else from the nominal closed-form solutions, in their order of preference: every one until a result is on
//    the wanted branch, then the rest of those on it, so that the nearest of its solutions is found (near a
//    singularity several converge on one branch; the offset wrist adds a start at every 30 deg of joint 6); and if
//    none of that branch's lies within the start radius, the other branches' near the hint.
// Without a hint, the first nominal solution in that order to converge with the demanded flags is the answer.
// A converged result is never given up for one that did not converge: the wanted branch is a preference, only
// the demanded flags are a condition.
class BranchSearch {
 public:
  BranchSearch(const Context& ctx, const Transform& T_world_target, const CompensationTarget& t,
               const Eigen::VectorXd& previous)
      : ctx_(ctx),
        T_world_target_(T_world_target),
        t_(t),
        demanded_(t.configuration),
        hint_(t.start.size() != 0    ? &t.start
              : previous.size() != 0 ? &previous
                                     : nullptr),
        reference_(hint_ != nullptr ? *hint_ : ctx.default_joints),
        wanted_(WantedBranch(*ctx.arm, hint_, demanded_)),
        radius_(ctx.options.start_radius_rad) {}

  CompensationResult Run() {
    if (hint_ != nullptr) {
      Consider(SolveFrom(ctx_, T_world_target_, *hint_, ctx_.options.start_damping));
      if (Settled()) return Finish();
    }
    int on_branch = 0;
    const std::vector<BranchStart> candidates = Starts(&on_branch);
    const std::string asked = demanded_.ToString();
    if (candidates.empty() && found_.empty()) {
      return NoSolution(iterations_, asked.empty()
                                         ? "no solution on any branch: the target is beyond the arm's reach"
                                         : "no solution with " + asked + ": the target is beyond the arm's reach");
    }
    for (const BranchStart& c : candidates) {
      // Without a hint the first result to converge is the answer (the order is the preference). With one, every
      // start is tried until the wanted branch is reached (near a boundary the stretched starts either side of it
      // often converge on the other side), then the rest of that branch's, for the nearest of its solutions (away
      // from boundaries the solver stays on a start's branch). If that is beyond the start radius, the other
      // branches' starts near the hint are tried too: one may end within it. Twice the radius, since near a
      // singularity the calibrated solution can lie degrees from the nominal one.
      const bool off_branch = c.other_branch > 0 || c.mismatch > 0;
      if (!found_.empty() && (hint_ == nullptr || (off_branch && Settled()))) break;
      if (off_branch && WantedReached() && c.distance > 4.0 * radius_ * radius_) continue;
      Consider(SolveFrom(ctx_, T_world_target_, c.q));
    }
    if (!found_.empty()) return Finish();
    if (!any_) {
      return NoSolution(iterations_,
                        on_branch == 0
                            ? "no solution with " + asked + ": the target is beyond the arm's reach on that branch"
                            : "no solution with " + asked + ": the solver left that branch from each of its " +
                                  std::to_string(on_branch) + " nominal solutions");
    }
    best_.iterations = iterations_;
    best_.message = (asked.empty() ? std::string("no branch reaches the target: ")
                                   : "the calibrated robot does not reach the target with " + asked + ": ") +
                    best_.message;
    return std::move(best_);
  }

 private:
  // Flags differing from the wanted ones, the shoulder weighing most.
  int Mismatch(const ArmConfiguration& c) const {
    return 4 * (c.shoulder != wanted_.shoulder) + 2 * (c.elbow != wanted_.elbow) + (c.wrist != wanted_.wrist);
  }

  // Hint joints within the start radius of a converged solution are taught joints, and the robot must not swing
  // from them: only the solutions within that radius beyond the nearest one are answers then. A start a few degrees
  // across a boundary otherwise gets its own branch's solution, which can be far (across the wrist's boundary
  // joints 4 and 6 turn by 180 deg). Squared distances throughout, as the candidates'.
  double Nearest2() const {
    double d2 = HUGE_VAL;
    for (const BranchFound& f : found_) d2 = std::min(d2, f.distance2);
    return d2;
  }
  bool Taught() const { return hint_ != nullptr && Nearest2() <= radius_ * radius_; }

  // The answer among the results found: without a hint the first (the order of the starts is the preference);
  // with one, of those not swinging the robot (see above) the wanted branch first, else the fewest and least
  // important other flags, then the nearest.
  BranchFound& Choose() {
    if (hint_ == nullptr) return found_.front();
    const double limit = Taught() ? std::pow(std::sqrt(Nearest2()) + radius_, 2) : HUGE_VAL;
    BranchFound* best_found = nullptr;
    for (BranchFound& f : found_) {
      if (f.distance2 > limit) continue;
      if (best_found == nullptr ||
          std::tie(f.mismatch, f.distance2) < std::tie(best_found->mismatch, best_found->distance2)) {
        best_found = &f;
      }
    }
    return *best_found;
  }

  // On the wanted branch within the start radius (with a hint), or any (without): no other start can change the
  // answer's branch.
  bool Settled() const {
    for (const BranchFound& f : found_) {
      if (hint_ == nullptr || (f.mismatch == 0 && f.distance2 <= radius_ * radius_)) return true;
    }
    return false;
  }
  bool WantedReached() const {
    return std::any_of(found_.begin(), found_.end(), [](const BranchFound& f) { return f.mismatch == 0; });
  }

  // A run's result: found when it converged with the demanded flags; else the best of those that did not (best_,
  // what is said when none converges).
  void Consider(CompensationResult r) {
    iterations_ += r.iterations;
    if (!r.configuration || !demanded_.Admits(*r.configuration)) return;
    if (!r.converged) {
      if (!any_ || Better(r, best_, ctx_.options.orientation_weight_mm_per_rad)) best_ = std::move(r);
      any_ = true;
      return;
    }
    Eigen::VectorXd q = r.joints;
    PlaceInLimits(ctx_.calibration.model, reference_, &q);
    const int flags = Mismatch(*r.configuration);
    const double distance2 = (q - reference_).squaredNorm();
    found_.push_back(
        BranchFound{.result = std::move(r), .joints = std::move(q), .mismatch = flags, .distance2 = distance2});
  }

  // The answer with its joints at their nearest turns, its errors evaluated there (the same pose to round-off, so
  // no iteration in practice), and every run's iterations.
  CompensationResult Finish() {
    const bool near = Taught();
    BranchFound& chosen = Choose();
    CompensationResult r = chosen.result;
    if (chosen.joints != r.joints) {
      CompensationResult placed = SolveFrom(ctx_, T_world_target_, chosen.joints);
      iterations_ += placed.iterations;
      if (placed.converged && placed.configuration == r.configuration) r = std::move(placed);
    }
    r.iterations = iterations_;
    // Not silent: the robot would move far from the joints it was taught. (In a sequence the previous target's
    // joints are no taught joints, and a jump from them is reported as joint_jump_deg.)
    if (t_.start.size() != 0 && !near) SayFarFromStart(&r);
    return r;
  }

  // The message of an answer beyond the start radius of start_joints: how far, and where the nearest found is.
  void SayFarFromStart(CompensationResult* r) const {
    const Eigen::VectorXd change = (r->joints - t_.start).cwiseAbs();
    int joint = 0;
    change.maxCoeff(&joint);
    const double distance = (r->joints - t_.start).norm();
    r->message = "no solution within " + Number(radius_ * kDegPerRad) + " deg of start_joints: this one (" +
                 r->configuration->ToString() + (*r->configuration == wanted_ ? ", theirs" : "") + ") is " +
                 Number(distance * kDegPerRad) + " deg from them, joint " + std::to_string(joint + 1) + " by " +
                 Number(change[joint] * kDegPerRad) + " deg";
    // The fallback order put another branch first: say where the nearest solution found is.
    const BranchFound& closest =
        *std::min_element(found_.begin(), found_.end(),
                          [](const BranchFound& a, const BranchFound& b) { return a.distance2 < b.distance2; });
    if (std::sqrt(closest.distance2) < distance - 1e-6) {
      r->message += "; the nearest found (" + closest.result.configuration->ToString() + ") is " +
                    Number(std::sqrt(closest.distance2) * kDegPerRad) + " deg from them";
    }
  }

  // The nominal closed-form solutions as starts: the demanded flags, then the wanted branch (whatever it takes to
  // reach it), within the limits, exact, and the nearest to the reference. *on_branch: how many have the demanded
  // flags.
  std::vector<BranchStart> Starts(int* on_branch) const {
    std::vector<BranchStart> candidates;
    for (ArmSolution& s : ctx_.arm->Solve(ctx_.calibration.T_world_base.inverse() * T_world_target_, reference_)) {
      BranchStart c{std::move(s.joints), s.configuration};
      // Solutions of other branches stay as starts of last resort: within the errors' size of a boundary the
      // nominal chain's branch and the calibrated robot's differ, and the solver may cross to the asked one.
      c.other_branch = demanded_.Admits(c.configuration) ? 0 : 1;
      *on_branch += 1 - c.other_branch;
      c.mismatch = Mismatch(c.configuration);
      c.outside = PlaceInLimits(ctx_.calibration.model, reference_, &c.q);
      // A pose just beyond the nominal reach gives a stretched start, tried after the exact solutions.
      c.inexact = s.position_error_mm > 1e-6 ? 1 : 0;
      c.distance = (c.q - reference_).squaredNorm();
      candidates.push_back(std::move(c));
    }
    std::stable_sort(candidates.begin(), candidates.end(), [](const BranchStart& a, const BranchStart& b) {
      return std::tie(a.other_branch, a.mismatch, a.outside, a.inexact, a.distance) <
             std::tie(b.other_branch, b.mismatch, b.outside, b.inexact, b.distance);
    });
    return candidates;
  }

  const Context& ctx_;
  const Transform& T_world_target_;
  const CompensationTarget& t_;
  const ArmConfiguration demanded_;
  const Eigen::VectorXd* const hint_;
  const Eigen::VectorXd& reference_;
  const ArmConfiguration wanted_;
  const double radius_;
  int iterations_ = 0;
  std::vector<BranchFound> found_;
  // The best result with the demanded flags that did not converge: what is said when none does.
  CompensationResult best_;
  bool any_ = false;
};

// A pose target on a robot with named branches (BranchSearch says how).
CompensationResult SolveOnBranches(const Context& ctx, const Transform& T_world_target, const CompensationTarget& t,
                                   const Eigen::VectorXd& previous) {
  return BranchSearch(ctx, T_world_target, t, previous).Run();
}

// Starts of a robot without named branches and without a start: DefaultJoints, then every combination of the
// quarter and three-quarter points of the joint ranges, nearest to DefaultJoints first (a fixed, documented
// order: the result does not depend on chance).
std::vector<Eigen::VectorXd> GridStarts(const Context& ctx) {
  const RobotModel& model = ctx.calibration.model;
  const int n = model.num_joints();
  std::vector<Eigen::VectorXd> starts;
  const int combinations = n <= 10 ? 1 << n : 1 << 10;
  for (int bits = 0; bits < combinations; ++bits) {
    Eigen::VectorXd q(n);
    for (int i = 0; i < n; ++i) {
      const double lower = model.lower_limits()[i], upper = model.upper_limits()[i];
      q[i] = lower + (upper - lower) * ((bits >> i) & 1 ? 0.75 : 0.25);
    }
    starts.push_back(std::move(q));
  }
  std::stable_sort(starts.begin(), starts.end(), [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return (a - ctx.default_joints).squaredNorm() < (b - ctx.default_joints).squaredNorm();
  });
  starts.insert(starts.begin(), ctx.default_joints);
  return starts;
}

CompensationResult SolvePose(const Context& ctx, const CompensationTarget& t, const Eigen::VectorXd& previous) {
  const RobotModel& model = ctx.calibration.model;
  if (t.start.size() != 0) CheckJoints(model, t.start, "start");
  if (previous.size() != 0) CheckJoints(model, previous, "previous");
  if (!IsValidRigidTransform(*t.pose, 1e-6)) {
    throw std::invalid_argument("Compensate: target is not a finite rigid transform");
  }
  const Transform T_world_target = t.frame == TargetFrame::kBase ? ctx.calibration.T_world_base * *t.pose : *t.pose;
  if (ctx.arm) return SolveOnBranches(ctx, T_world_target, t, previous);
  if (t.configuration != ArmConfiguration{}) {
    throw std::invalid_argument("Compensate: robot '" + model.name() +
                                "' has no named configurations (not a 6R arm of a known family)");
  }
  if (t.start.size() != 0) return SolveFrom(ctx, T_world_target, t.start);
  if (previous.size() != 0) return SolveFrom(ctx, T_world_target, previous);
  CompensationResult best;
  int iterations = 0, tried = 0;
  for (const Eigen::VectorXd& start : GridStarts(ctx)) {
    CompensationResult r = SolveFrom(ctx, T_world_target, start);
    iterations += r.iterations;
    ++tried;
    const bool done = r.converged;
    if (tried == 1 || Better(r, best, ctx.options.orientation_weight_mm_per_rad)) best = std::move(r);
    if (done) break;
  }
  best.iterations = iterations;
  if (!best.converged) best.message = "none of " + std::to_string(tried) + " starts converged; the best: " + best.message;
  return best;
}

CompensationResult SolveJoints(const Context& ctx, const Eigen::VectorXd& q_nominal) {
  CheckJoints(ctx.nominal, q_nominal, "q_nominal");
  // Where the program expects the tool, relative to the robot base: independent of where the tracker stands.
  const Transform T_base_tool = ctx.T_base_world * ctx.nominal_chain.Forward(q_nominal, nullptr);
  return SolveFrom(ctx, ctx.calibration.T_world_base * T_base_tool, q_nominal);
}

void CheckNominal(const Calibration& calibration, const RobotModel& nominal) {
  if (nominal.num_joints() != calibration.model.num_joints()) {
    throw std::invalid_argument("Compensate: the nominal model has " + std::to_string(nominal.num_joints()) +
                                " joints, the calibrated one " + std::to_string(calibration.model.num_joints()));
  }
}

CompensationResult SolveTarget(const Context& ctx, const CompensationTarget& t, const Eigen::VectorXd& previous) {
  std::string error;
  if (!t.payload.IsValid("payload", &error)) throw std::invalid_argument("Compensate: " + error);
  if (ctx.chain.deflects() && t.payload != Payload()) {
    // The calibrated robot deflects under this target's payload: its own chain.
    Context loaded = ctx;
    loaded.chain = ctx.chain.WithPayload(t.payload);
    return t.pose ? SolvePose(loaded, t, previous) : SolveJoints(loaded, t.joints);
  }
  return t.pose ? SolvePose(ctx, t, previous) : SolveJoints(ctx, t.joints);
}

}  // namespace

Calibration NominalCalibration(const RobotModel& nominal) {
  Calibration c{.model = nominal,
                .errors = Eigen::VectorXd::Zero(nominal.num_error_parameters()),
                .parameters = {},
                .covariance = {},
                .T_world_base = nominal.T_world_base(),
                .T_flange_tool = nominal.T_flange_tool(),
                .reflectors = {},
                .summary = {}};
  return c;
}

Eigen::VectorXd DefaultJoints(const RobotModel& model) {
  Eigen::VectorXd q = (model.lower_limits() + model.upper_limits()) / 2.0;
  for (int i = 0; i < model.num_joints(); ++i) {
    if (model.lower_limits()[i] <= 0.0 && model.upper_limits()[i] >= 0.0) q[i] = 0.0;
  }
  return q;
}

CompensationResult CompensatePose(const Calibration& calibration, const Transform& target, TargetFrame frame,
                                  const Eigen::VectorXd& q_start, const CompensationOptions& options,
                                  const Payload& payload) {
  CheckCalibration(calibration, options);
  CheckJoints(calibration.model, q_start, "q_start");
  if (!IsValidRigidTransform(target, 1e-6)) {
    throw std::invalid_argument("CompensatePose: target is not a finite rigid transform");
  }
  std::string error;
  if (!payload.IsValid("payload", &error)) throw std::invalid_argument("CompensatePose: " + error);
  Context ctx(calibration, calibration.model, options);
  ctx.chain = ctx.chain.WithPayload(payload);
  const Transform T_world_target = frame == TargetFrame::kBase ? calibration.T_world_base * target : target;
  return SolveFrom(ctx, T_world_target, q_start);
}

CompensationResult CompensateJoints(const Calibration& calibration, const RobotModel& nominal,
                                    const Eigen::VectorXd& q_nominal, const CompensationOptions& options) {
  CheckCalibration(calibration, options);
  CheckNominal(calibration, nominal);
  const Context ctx(calibration, nominal, options);
  return SolveJoints(ctx, q_nominal);
}

CompensationResult Compensate(const Calibration& calibration, const RobotModel& nominal,
                              const CompensationTarget& target, const CompensationOptions& options,
                              const Eigen::VectorXd& previous) {
  CheckCalibration(calibration, options);
  CheckNominal(calibration, nominal);
  const Context ctx(calibration, nominal, options);
  return SolveTarget(ctx, target, previous);
}

std::vector<CompensationResult> CompensateAll(const Calibration& calibration, const RobotModel& nominal,
                                              const std::vector<CompensationTarget>& targets,
                                              const CompensationOptions& options, int threads) {
  if (threads < 0) throw std::invalid_argument("CompensateAll: threads must be >= 0");
  CheckCalibration(calibration, options);
  CheckNominal(calibration, nominal);
  const Context ctx(calibration, nominal, options);
  std::vector<CompensationResult> results(targets.size());
  internal::ParallelFor(targets.size(), threads, 16,
                        [&](std::size_t i) { results[i] = SolveTarget(ctx, targets[i], Eigen::VectorXd()); });
  return results;
}

std::vector<CompensationResult> CompensateSequence(const Calibration& calibration, const RobotModel& nominal,
                                                   const std::vector<CompensationTarget>& targets,
                                                   const CompensationOptions& options) {
  CheckCalibration(calibration, options);
  CheckNominal(calibration, nominal);
  const Context ctx(calibration, nominal, options);
  std::vector<CompensationResult> results;
  results.reserve(targets.size());
  for (const CompensationTarget& t : targets) {
    const bool chained = !results.empty() && results.back().joints.size() == calibration.model.num_joints();
    results.push_back(SolveTarget(ctx, t, chained ? results.back().joints : Eigen::VectorXd()));
  }
  return results;
}

}  // namespace robocal
