// Identification: point-set registration of the tracker -> base frame, then weighted Levenberg-Marquardt over
// the identifiable error parameters, with covariance, residual statistics and reports.
#include "robocal/core/identification.h"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

#include "robocal/core/column_scaling.h"
#include "robocal/core/fit_diagnostics.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/units.h"

namespace robocal {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

bool AllFinite(const Eigen::MatrixXd& m) { return m.allFinite(); }

// Shortest readable form (1e-12, not std::to_string's 0.000000).
std::string Num(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}


// Checks the parts of a measurement that `type` uses; an empty string if it is usable.
std::string CheckMeasurement(const Measurement& m, MeasurementType type) {
  if (!m.joints.allFinite()) return "non-finite joint values";
  std::string payload;
  if (!m.payload.IsValid("payload", &payload)) return payload;
  if (!m.T_world_tool.translation().allFinite()) return "non-finite position";
  const Eigen::Matrix3d r = m.T_world_tool.linear();
  if (type == MeasurementType::kPositionAxis) {
    if (!r.col(2).allFinite()) return "non-finite tool axis";
    if (std::abs(r.col(2).norm() - 1.0) > 1e-6) return "tool axis is not a unit vector";
  }
  if (type == MeasurementType::kPose) {
    if (!r.allFinite()) return "non-finite orientation";
    if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-6) ||
        !(r.determinant() > 0.0)) {
      return "orientation is not a rotation matrix";
    }
  }
  return "";
}

// Shots grouped by joint configuration and reflector: a group shares its kinematics (and its robot
// repeatability error); distinct groups bound the information.
struct ShotGroups {
  struct Group {
    int pose = 0;
    int reflector = -1;
    std::vector<int> shots;
  };
  std::vector<Eigen::VectorXd> poses;  // distinct joint configurations (under distinct payloads)
  std::vector<Payload> payloads;       // per pose
  std::vector<Group> groups;
  std::vector<int> group_of;  // per measurement

  explicit ShotGroups(const std::vector<Measurement>& measurements) {
    std::map<Eigen::VectorXd, int, LexicographicLess> pose_index;
    std::map<std::pair<int, int>, int> group_index;
    group_of.reserve(measurements.size());
    for (size_t i = 0; i < measurements.size(); ++i) {
      const Measurement& m = measurements[i];
      // A pose is a configuration under a payload: the same joints under another payload deflect otherwise.
      const auto [pose, new_pose] = pose_index.emplace(PoseKey(m), static_cast<int>(poses.size()));
      if (new_pose) {
        poses.push_back(m.joints);
        payloads.push_back(m.payload);
      }
      const auto [group, new_group] =
          group_index.emplace(std::make_pair(pose->second, m.reflector), static_cast<int>(groups.size()));
      if (new_group) groups.push_back({pose->second, m.reflector, {}});
      groups[group->second].shots.push_back(static_cast<int>(i));
      group_of.push_back(group->second);
    }
  }
};

// The least-squares problem over the chosen parameters (the model's error parameters, then 3 offset errors per
// reflector: reflectors.h's index space). Shots are grouped by joint configuration and reflector; a group
// shares its kinematics and Jacobian, so the cost of an evaluation grows with the groups, not with the shots.
class Problem {
 public:
  Problem(const RobotModel& model, const std::vector<Measurement>& measurements, const ShotGroups& shot_groups,
          const IdentificationOptions& o, const std::vector<int>& parameters)
      : model_(model),
        measurements_(measurements),
        type_(o.measurement_type),
        rows_(MeasurementRows(o.measurement_type)),
        weights_(o.noise.RowWeights(o.measurement_type)),
        parameters_(parameters),
        reflectors_(o.reflectors),
        n_model_(model.num_error_parameters()),
        ws_(model),
        poses_(shot_groups.poses),
        payloads_(shot_groups.payloads),
        groups_(shot_groups.groups),
        group_of_(shot_groups.group_of) {
    if (o.noise.HasSharedError()) {
      // The shots of one group share the robot's repeatability error and its model error: their residuals are correlated. With H
      // an orthonormal (Helmert) basis of the shots whose first vector is the mean direction, the covariance
      // of the n shots becomes block diagonal: sqrt(n) times their mean has the tracker's covariance plus n
      // times the shared one, and the n - 1 Helmert contrasts the tracker's alone (the shots of a group
      // are measured at the same point to within the noise, so one tracker covariance, at their mean, serves
      // them). Only the mean depends on the parameters; the contrasts carry the scatter of the shots.
      for (const Group& g : groups_) {
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (int i : g.shots) mean += measurements[i].T_world_tool.translation();
        mean /= static_cast<double>(g.shots.size());
        Eigen::MatrixXd w_mean(rows_, rows_), w_contrast(rows_, rows_);
        o.noise.Whitening(type_, mean, w_mean, static_cast<int>(g.shots.size()));
        o.noise.Whitening(type_, mean, w_contrast, 0);
        group_whitening_.push_back({std::move(w_mean), std::move(w_contrast)});
      }
    } else if (o.noise.tracker) {
      // A tracker model whitens each measurement by the covariance at its measured point (fixed during the fit,
      // so the cost is one function of the parameters); without one every row has its constant weight.
      whitening_.reserve(measurements.size());
      for (const Measurement& m : measurements) {
        Eigen::MatrixXd w(rows_, rows_);
        o.noise.Whitening(type_, m.T_world_tool.translation(), w);
        whitening_.push_back(std::move(w));
      }
    }
  }

  int num_rows() const { return rows_ * static_cast<int>(measurements_.size()); }
  int num_parameters() const { return static_cast<int>(parameters_.size()); }

  // The model's error parameters (num_error_parameters) and the reflectors' offset errors (3 each) at x.
  Eigen::VectorXd FullErrors(const Eigen::VectorXd& x) const {
    Eigen::VectorXd eps = Eigen::VectorXd::Zero(n_model_);
    for (int k = 0; k < num_parameters(); ++k)
      if (parameters_[k] < n_model_) eps[parameters_[k]] = x[k];
    return eps;
  }
  Eigen::VectorXd ReflectorErrors(const Eigen::VectorXd& x) const {
    Eigen::VectorXd out = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(reflectors_.size()));
    for (int k = 0; k < num_parameters(); ++k)
      if (parameters_[k] >= n_model_) out[parameters_[k] - n_model_] = x[k];
    return out;
  }

  const std::vector<ShotGroups::Group>& groups() const { return groups_; }
  const std::vector<int>& group_of() const { return group_of_; }

  // Weighted residuals r (num_rows) at reduced parameters x and, if `jacobian` is not null, the weighted
  // Jacobian of the model prediction (num_rows x num_parameters), so that r(x + d) ~= r(x) - J d.
  void Evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* residual, Eigen::MatrixXd* jacobian) {
    std::vector<Transform> prediction;
    std::vector<Eigen::MatrixXd> group_jacobian;
    Predict(x, &prediction, jacobian != nullptr ? &group_jacobian : nullptr);
    residual->resize(num_rows());
    if (jacobian != nullptr) jacobian->resize(num_rows(), num_parameters());
    if (!group_whitening_.empty()) {
      EvaluateByGroup(prediction, group_jacobian, residual, jacobian);
      return;
    }
    Eigen::VectorXd r(rows_);
    for (size_t i = 0; i < measurements_.size(); ++i) {
      const int g = group_of_[i];
      MeasurementResidual(type_, measurements_[i].T_world_tool, prediction[g], r);
      if (whitening_.empty()) {
        residual->segment(rows_ * i, rows_) = weights_.cwiseProduct(r);
        if (jacobian != nullptr) jacobian->middleRows(rows_ * i, rows_) = weights_.asDiagonal() * group_jacobian[g];
      } else {
        residual->segment(rows_ * i, rows_) = whitening_[i] * r;
        if (jacobian != nullptr) jacobian->middleRows(rows_ * i, rows_) = whitening_[i] * group_jacobian[g];
      }
    }
  }

  // Per group: the model's prediction at reduced parameters x and, if `group_jacobian` is not null, its
  // Jacobian over the chosen parameters, unweighted (rows x num_parameters).
  void Predict(const Eigen::VectorXd& x, std::vector<Transform>* prediction,
               std::vector<Eigen::MatrixXd>* group_jacobian) {
    const Eigen::VectorXd eps = FullErrors(x);
    const std::vector<Eigen::Vector3d> in_tool = ReflectorsInTool(model_, reflectors_, ReflectorErrors(x));
    const bool with_jacobian = group_jacobian != nullptr;
    const bool by_reflector = !reflectors_.empty();
    // Per pose: the tool's kinematics and, for the Jacobian, its rows (the type's, or the pose's 6 for
    // reflectors, whose points move with the tool's position and orientation).
    const int pose_rows = by_reflector ? 6 : rows_;
    Eigen::MatrixXd full(pose_rows, n_model_);
    std::vector<Transform> pose_model(poses_.size());
    std::vector<Eigen::MatrixXd> pose_full(with_jacobian ? poses_.size() : 0);
    for (size_t p = 0; p < poses_.size(); ++p) {
      if (with_jacobian) {
        IdentificationJacobian(model_, poses_[p], eps, by_reflector ? MeasurementType::kPose : type_, &ws_, full,
                               payloads_[p]);
        pose_full[p] = full;
        pose_model[p] = ws_.T_world_tool;
      } else {
        pose_model[p] = ForwardKinematics(model_, poses_[p], eps, &ws_, payloads_[p]);
      }
    }
    prediction->resize(groups_.size());
    if (with_jacobian) group_jacobian->resize(groups_.size());
    Eigen::MatrixXd point(3, n_model_);
    for (size_t g = 0; g < groups_.size(); ++g) {
      const Group& group = groups_[g];
      const Transform& tool = pose_model[group.pose];
      (*prediction)[g] = group.reflector < 0 ? tool : AtReflector(tool, in_tool[group.reflector]);
      if (!with_jacobian) continue;
      Eigen::MatrixXd reduced = Eigen::MatrixXd::Zero(rows_, num_parameters());
      if (group.reflector < 0) {
        for (int k = 0; k < num_parameters(); ++k) reduced.col(k) = pose_full[group.pose].col(parameters_[k]);
      } else {
        ReflectorRows(tool, in_tool[group.reflector], pose_full[group.pose], point);
        const Eigen::Matrix3d offset = ReflectorOffsetRows(model_, tool);
        for (int k = 0; k < num_parameters(); ++k) {
          const int j = parameters_[k];
          if (j < n_model_) {
            reduced.col(k) = point.col(j);
          } else if ((j - n_model_) / 3 == group.reflector) {
            reduced.col(k) = offset.col((j - n_model_) % 3);
          }
        }
      }
      (*group_jacobian)[g] = std::move(reduced);
    }
  }

 private:
  using Group = ShotGroups::Group;
  struct GroupWhitening {
    Eigen::MatrixXd mean;
    Eigen::MatrixXd contrast;
  };

  // Rows of the repeatability model (see the constructor): per group, sqrt(n) times the mean residual of its n
  // shots whitened by `mean`, then the n - 1 Helmert contrasts whitened by `contrast` (no parameter moves them).
  void EvaluateByGroup(const std::vector<Transform>& prediction, const std::vector<Eigen::MatrixXd>& group_jacobian,
                       Eigen::VectorXd* residual, Eigen::MatrixXd* jacobian) const {
    Eigen::VectorXd r(rows_), sum(rows_), contrast(rows_);
    Eigen::Index row = 0;
    for (size_t g = 0; g < groups_.size(); ++g) {
      const std::vector<int>& shots = groups_[g].shots;
      const double n = static_cast<double>(shots.size());
      sum.setZero();
      for (size_t k = 0; k < shots.size(); ++k) {
        MeasurementResidual(type_, measurements_[shots[k]].T_world_tool, prediction[g], r);
        if (k > 0) {
          // Helmert contrast k: (r_0 + ... + r_{k-1} - k r_k) / sqrt(k (k + 1)).
          const double kk = static_cast<double>(k);
          contrast = (sum - kk * r) / std::sqrt(kk * (kk + 1.0));
          const Eigen::Index at = row + rows_ * static_cast<Eigen::Index>(k);
          residual->segment(at, rows_) = group_whitening_[g].contrast * contrast;
          if (jacobian != nullptr) jacobian->middleRows(at, rows_).setZero();
        }
        sum += r;
      }
      residual->segment(row, rows_) = group_whitening_[g].mean * (sum / std::sqrt(n));
      if (jacobian != nullptr) {
        jacobian->middleRows(row, rows_) = std::sqrt(n) * (group_whitening_[g].mean * group_jacobian[g]);
      }
      row += rows_ * static_cast<Eigen::Index>(shots.size());
    }
  }

  const RobotModel& model_;
  const std::vector<Measurement>& measurements_;
  MeasurementType type_;
  int rows_;
  Eigen::VectorXd weights_;
  std::vector<int> parameters_;
  std::vector<Reflector> reflectors_;
  int n_model_;
  KinematicsWorkspace ws_;
  const std::vector<Eigen::VectorXd>& poses_;
  const std::vector<Payload>& payloads_;
  const std::vector<Group>& groups_;
  const std::vector<int>& group_of_;
  std::vector<Eigen::MatrixXd> whitening_;       // per measurement, with a tracker model and no repeatability
  std::vector<GroupWhitening> group_whitening_;  // per group, with repeatability
};

struct LmResult {
  Eigen::VectorXd x;
  Eigen::VectorXd residual;
  Eigen::MatrixXd jacobian;
  int iterations = 0;
  Termination termination = Termination::kNoConvergence;
  std::string reason;
};

// Levenberg-Marquardt, written here rather than taken from Eigen's unsupported module because (a) the
// Summary promises the Ceres-style tests of IdentificationOptions (relative cost change, max |J'r|, step
// relative to |x|), which MINPACK's ftol/xtol/gtol define differently (gtol there is a cosine), (b) shots of
// one pose share one Jacobian evaluation (Problem), and (c) the loop is 40 lines with Nielsen's damping update
// and Marquardt's diag(J'J) scaling, so it is scale invariant in mm and rad. Normal equations are safe here:
// they are formed from column-scaled J, whose condition number is checked before the loop (rank test).
LmResult LevenbergMarquardt(Problem* problem, const IdentificationOptions& o) {
  LmResult out;
  const int n = problem->num_parameters();
  out.x = Eigen::VectorXd::Zero(n);
  problem->Evaluate(out.x, &out.residual, &out.jacobian);
  double cost = 0.5 * out.residual.squaredNorm();
  double lambda = 1e-4;
  double nu = 2.0;
  Eigen::VectorXd candidate_residual;
  Eigen::MatrixXd candidate_jacobian;
  while (true) {
    const Eigen::VectorXd gradient = out.jacobian.transpose() * out.residual;
    if (gradient.cwiseAbs().maxCoeff() <= o.gradient_tolerance) {
      out.termination = Termination::kConvergence;
      out.reason = "gradient tolerance reached (max |J'r| <= " + Num(o.gradient_tolerance) + ")";
      return out;
    }
    if (cost == 0.0) {
      out.termination = Termination::kConvergence;
      out.reason = "zero residual";
      return out;
    }
    if (out.iterations >= o.max_iterations) {
      out.termination = Termination::kNoConvergence;
      out.reason = "max_iterations (" + std::to_string(o.max_iterations) + ") reached";
      return out;
    }
    ++out.iterations;
    const Eigen::MatrixXd normal = out.jacobian.transpose() * out.jacobian;
    const Eigen::VectorXd diag = normal.diagonal().cwiseMax(1e-300);
    Eigen::MatrixXd damped = normal;
    damped.diagonal() += lambda * diag;
    const Eigen::VectorXd step = damped.ldlt().solve(gradient);
    if (!step.allFinite()) {
      out.termination = Termination::kFailure;
      out.reason = "non-finite step (singular normal equations)";
      return out;
    }
    if (step.norm() <= o.parameter_tolerance * (out.x.norm() + o.parameter_tolerance)) {
      out.termination = Termination::kConvergence;
      out.reason = "parameter tolerance reached (|step| <= " + Num(o.parameter_tolerance) + " (|x| + tol))";
      return out;
    }
    const Eigen::VectorXd x_new = out.x + step;
    problem->Evaluate(x_new, &candidate_residual, &candidate_jacobian);
    const double new_cost = 0.5 * candidate_residual.squaredNorm();
    // Predicted decrease of the linear model: 0.5 step' (lambda D step + g), positive for any lambda > 0.
    const double predicted = 0.5 * step.dot(lambda * diag.cwiseProduct(step) + gradient);
    const double rho = std::isfinite(new_cost) && predicted > 0.0 ? (cost - new_cost) / predicted : -1.0;
    if (rho > 0.0) {
      const double change = cost - new_cost;
      out.x = x_new;
      out.residual.swap(candidate_residual);
      out.jacobian.swap(candidate_jacobian);
      const double old_cost = cost;
      cost = new_cost;
      lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
      nu = 2.0;
      if (change <= o.function_tolerance * old_cost) {
        out.termination = Termination::kConvergence;
        out.reason = "function tolerance reached (relative cost change <= " + Num(o.function_tolerance) + ")";
        return out;
      }
    } else {
      lambda *= nu;
      nu *= 2.0;
      if (lambda > 1e32) {
        // Only reachable when round-off hides every descent direction: the point is as good as it gets.
        out.termination = Termination::kConvergence;
        out.reason = "no further decrease possible (damping exhausted)";
        return out;
      }
    }
    // After the convergence tests, so that a fit which converged in this iteration reports that instead.
    if (o.progress && !o.progress(static_cast<double>(out.iterations) / o.max_iterations)) {
      out.termination = Termination::kNoConvergence;
      out.reason = "cancelled";
      return out;
    }
  }
}

// Singular values and covariance of a weighted Jacobian through its column-scaled form Js = J D (unit columns):
// (J'J)^-1 = D (Js'Js)^-1 D. False, with nothing written, when Js is rank deficient: no covariance exists.
// The fit and LinearizeFit share it, so a report's recomputed figures are the fit's.
bool ScaledCovariance(const Eigen::MatrixXd& jacobian, double sigma_hat, double rank_tolerance,
                      Eigen::VectorXd* singular_values, Eigen::MatrixXd* covariance) {
  const Eigen::VectorXd d = UnitColumnFactorsOf(jacobian);
  const Eigen::MatrixXd scaled = jacobian * d.asDiagonal();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(scaled, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  if (PivotRank(sv, rank_tolerance) < jacobian.cols()) return false;
  const Eigen::MatrixXd v_scaled = svd.matrixV() * sv.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd inverse_scaled = v_scaled * v_scaled.transpose();
  *covariance = sigma_hat * sigma_hat * d.asDiagonal() * inverse_scaled * d.asDiagonal();
  *singular_values = sv;
  return true;
}

}  // namespace

Transform RegisterPoints(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to) {
  if (from.size() != to.size()) {
    throw std::invalid_argument("RegisterPoints: " + std::to_string(from.size()) + " source and " +
                                std::to_string(to.size()) + " target points");
  }
  if (from.size() < 3) {
    throw std::invalid_argument("RegisterPoints: needs at least 3 points, got " + std::to_string(from.size()));
  }
  const Eigen::Index n = static_cast<Eigen::Index>(from.size());
  Eigen::Matrix3Xd a(3, n), b(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    a.col(i) = from[i];
    b.col(i) = to[i];
  }
  if (!a.allFinite() || !b.allFinite()) throw std::invalid_argument("RegisterPoints: non-finite point");
  const Eigen::Vector3d ca = a.rowwise().mean();
  const Eigen::Vector3d cb = b.rowwise().mean();
  a.colwise() -= ca;
  b.colwise() -= cb;
  // The rotation is determined only if each point set spans a plane: collinear (or coincident) points leave a
  // free rotation about their line.
  const auto spread = [](const Eigen::Matrix3Xd& m) {
    const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(m * m.transpose()).singularValues();
    return s[0] > 0.0 && s[1] > 1e-18 * s[0];  // squared singular values of m: 1e-9 relative in length
  };
  if (!spread(a) || !spread(b)) {
    throw std::invalid_argument("RegisterPoints: points are collinear or coincident; the rotation is undetermined");
  }
  const Eigen::Matrix3d h = a * b.transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // Umeyama's correction: flip the weakest direction if the best orthogonal matrix is a reflection.
  Eigen::Vector3d d(1.0, 1.0, 1.0);
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) d[2] = -1.0;
  Transform t = Transform::Identity();
  t.linear() = svd.matrixV() * d.asDiagonal() * svd.matrixU().transpose();
  t.translation() = cb - t.linear() * ca;
  return t;
}

bool IdentificationOptions::IsValid(std::string* error) const {
  if (!noise.IsValid(error)) return false;
  for (size_t k = 0; k < parameters.size(); ++k) {
    if (parameters[k] < 0 || (k > 0 && parameters[k] <= parameters[k - 1])) {
      *error = "parameters must be non-negative and strictly ascending (parameters[" + std::to_string(k) + "])";
      return false;
    }
  }
  std::string sub;
  // Checked even with explicit parameters: the rank test of the data uses identifiability.rank_tolerance.
  if (!identifiability.IsValid(&sub)) {
    *error = "identifiability." + sub;
    return false;
  }
  const struct {
    const char* name;
    double value;
  } tolerances[] = {{"function_tolerance", function_tolerance},
                    {"gradient_tolerance", gradient_tolerance},
                    {"parameter_tolerance", parameter_tolerance}};
  for (const auto& t : tolerances) {
    if (!(t.value >= 0.0) || !std::isfinite(t.value)) {
      *error = std::string(t.name) + " must be finite and >= 0";
      return false;
    }
  }
  if (!ValidateReflectors(reflectors, error)) return false;
  if (!reflectors.empty() && measurement_type != MeasurementType::kPosition) {
    *error = "reflectors need position measurements (a 6-DoF probe measures the tool's orientation itself)";
    return false;
  }
  if (!(outlier_probability > 0.0 && outlier_probability <= 0.1)) {
    *error = "outlier_probability must be in (0, 0.1]";
    return false;
  }
  if (max_iterations < 1 || max_iterations > 100000) {
    *error = "max_iterations must be in [1, 100000]";
    return false;
  }
  return true;
}

namespace {

// Calls visit(m, predicted, r, w) for every measurement: the model's prediction at its reflector, the residual
// and the whitening at the measured point. The one loop behind the residual statistics and the robust fit's
// normalised residuals.
template <typename Visit>
void ForEachResidual(const RobotModel& model, const Eigen::VectorXd& errors,
                     const std::vector<Measurement>& measurements, MeasurementType type,
                     const MeasurementNoise& noise, const std::vector<Eigen::Vector3d>& reflectors_in_tool,
                     Visit&& visit) {
  const int rows = MeasurementRows(type);
  Eigen::MatrixXd w(rows, rows);
  KinematicsWorkspace ws(model);
  Eigen::VectorXd r(rows);
  for (const Measurement& m : measurements) {
    const Transform& tool = ForwardKinematics(model, m.joints, errors, &ws, m.payload);
    const Transform predicted = m.reflector < 0 ? tool : AtReflector(tool, reflectors_in_tool.at(m.reflector));
    MeasurementResidual(type, m.T_world_tool, predicted, r);
    noise.Whitening(type, m.T_world_tool.translation(), w);
    visit(m, predicted, r, w);
  }
}

}  // namespace

std::vector<MeasurementResidualNorms> ComputeMeasurementResiduals(const RobotModel& model,
                                                                  const Eigen::VectorXd& errors,
                                                                  const std::vector<Measurement>& measurements,
                                                                  MeasurementType type, const MeasurementNoise& noise,
                                                                  const std::vector<Eigen::Vector3d>& reflectors_in_tool) {
  std::vector<MeasurementResidualNorms> out;
  out.reserve(measurements.size());
  const auto visit = [&](const Measurement& m, const Transform& predicted, const Eigen::VectorXd& r,
                         const Eigen::MatrixXd& w) {
    MeasurementResidualNorms n;
    n.position_mm = r.head<3>().norm();
    if (type == MeasurementType::kPose) {
      n.orientation_rad = r.tail<3>().norm();
    } else if (type == MeasurementType::kPositionAxis) {
      // The exact angle between the axes; the residual's tangent rows are its first-order form.
      n.orientation_rad = AngleBetween(m.T_world_tool.linear().col(2), predicted.linear().col(2));
    }
    n.weighted = (w * r).norm();
    out.push_back(n);
  };
  ForEachResidual(model, errors, measurements, type, noise, reflectors_in_tool, visit);
  return out;
}

ResidualStatistics ComputeResidualStatistics(const RobotModel& model, const Eigen::VectorXd& errors,
                                             const std::vector<Measurement>& measurements, MeasurementType type,
                                             const MeasurementNoise& noise,
                                             const std::vector<Eigen::Vector3d>& reflectors_in_tool) {
  ResidualStatistics s;
  s.num_measurements = static_cast<int>(measurements.size());
  if (measurements.empty()) return s;
  const int rows = MeasurementRows(type);
  double sum_position = 0.0, sum_orientation = 0.0, sum_weighted = 0.0;
  for (const MeasurementResidualNorms& n :
       ComputeMeasurementResiduals(model, errors, measurements, type, noise, reflectors_in_tool)) {
    sum_position += n.position_mm * n.position_mm;
    s.max_position_mm = std::max(s.max_position_mm, n.position_mm);
    sum_orientation += n.orientation_rad * n.orientation_rad;
    s.max_orientation_rad = std::max(s.max_orientation_rad, n.orientation_rad);
    sum_weighted += n.weighted * n.weighted;
  }
  const double count = static_cast<double>(measurements.size());
  s.rms_position_mm = std::sqrt(sum_position / count);
  s.rms_orientation_rad = std::sqrt(sum_orientation / count);
  s.rms_weighted = std::sqrt(sum_weighted / (count * rows));
  return s;
}

Eigen::VectorXd PoseKey(const Measurement& m) {
  Eigen::VectorXd key(m.joints.size() + 4);
  key << m.joints, m.payload.mass_kg, (m.payload.mass_kg > 0.0 ? m.payload.com_mm : Eigen::Vector3d::Zero());
  return key;
}

MeasurementNoise FittedNoise(const IdentificationSummary& summary, MeasurementNoise noise) {
  if (!summary.model_error_estimated) return noise;
  const int angle_rows = MeasurementRows(summary.measurement_type) - 3;
  noise.model_error_mm = summary.model_error_mm / std::sqrt(3.0);
  noise.model_error_rad = angle_rows > 0 ? summary.model_error_rad / std::sqrt(static_cast<double>(angle_rows)) : 0.0;
  return noise;
}

FitLinearization LinearizeFit(const Calibration& calibration, const std::vector<Measurement>& measurements,
                              const IdentificationOptions& fit_options) {
  // The fit's weights: the noise model with the model error it estimated.
  IdentificationOptions options = fit_options;
  options.noise = FittedNoise(calibration.summary, fit_options.noise);
  const RobotModel& model = calibration.model;
  const int n_model = model.num_error_parameters();
  const int num_reflectors = static_cast<int>(options.reflectors.size());
  const std::vector<int>& parameters = options.parameters;
  if (parameters.empty()) throw std::invalid_argument("LinearizeFit: options.parameters is empty: name the estimated set");
  if (calibration.errors.size() != n_model) {
    throw std::invalid_argument("LinearizeFit: calibration.errors has " + std::to_string(calibration.errors.size()) +
                                " values, the model has " + std::to_string(n_model) + " error parameters");
  }
  if (static_cast<int>(calibration.reflectors.size()) != num_reflectors) {
    throw std::invalid_argument("LinearizeFit: the calibration has " + std::to_string(calibration.reflectors.size()) +
                                " reflectors, options.reflectors " + std::to_string(num_reflectors));
  }
  for (size_t k = 0; k < parameters.size(); ++k) {
    if (parameters[k] < 0 || parameters[k] >= n_model + 3 * num_reflectors || (k > 0 && parameters[k] <= parameters[k - 1])) {
      throw std::invalid_argument("LinearizeFit: options.parameters[" + std::to_string(k) +
                                  "] is out of range or not ascending");
    }
  }
  for (size_t i = 0; i < measurements.size(); ++i) {
    const int reflector = measurements[i].reflector;
    if (measurements[i].joints.size() != model.num_joints() || reflector >= num_reflectors ||
        (num_reflectors > 0 && reflector < 0)) {
      throw std::invalid_argument("LinearizeFit: measurements[" + std::to_string(i) +
                                  "] does not fit the model (joints) or the reflectors");
    }
  }
  const int n = static_cast<int>(parameters.size());
  if (MeasurementRows(options.measurement_type) * static_cast<int>(measurements.size()) <= n) {
    throw std::invalid_argument("LinearizeFit: " + std::to_string(measurements.size()) +
                                " measurements have too few rows for " + std::to_string(n) + " parameters");
  }
  // The solution in the fit's reduced space: the model's errors, and each free reflector's offset from its
  // given position.
  Eigen::VectorXd x(n);
  for (int k = 0; k < n; ++k) {
    const int j = parameters[k];
    x[k] = j < n_model ? calibration.errors[j]
                       : calibration.reflectors[(j - n_model) / 3].position_mm[(j - n_model) % 3] -
                             options.reflectors[(j - n_model) / 3].position_mm[(j - n_model) % 3];
  }
  const ShotGroups groups(measurements);
  Problem problem(model, measurements, groups, options, parameters);
  Eigen::VectorXd residual;
  Eigen::MatrixXd jacobian;
  problem.Evaluate(x, &residual, &jacobian);
  FitLinearization out;
  out.parameters = parameters;
  out.sigma_hat = std::sqrt(residual.squaredNorm() / (problem.num_rows() - n));
  if (!residual.allFinite() || !jacobian.allFinite() ||
      !ScaledCovariance(jacobian, out.sigma_hat, options.identifiability.rank_tolerance, &out.singular_values,
                        &out.covariance)) {
    throw std::invalid_argument("LinearizeFit: rank-deficient or non-finite Jacobian at the solution");
  }
  out.condition_number = out.singular_values[0] / out.singular_values[out.singular_values.size() - 1];
  return out;
}

Eigen::MatrixXd CorrelationOf(const Eigen::MatrixXd& covariance) {
  const Eigen::VectorXd sigma = covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  Eigen::MatrixXd rho = Eigen::MatrixXd::Zero(covariance.rows(), covariance.cols());
  for (Eigen::Index i = 0; i < covariance.rows(); ++i) {
    for (Eigen::Index j = 0; j < covariance.cols(); ++j) {
      if (sigma[i] > 0.0 && sigma[j] > 0.0) rho(i, j) = covariance(i, j) / (sigma[i] * sigma[j]);
    }
  }
  return rho;
}

double ChiSquareSurvival(int dof, double x) {
  if (dof < 1) throw std::invalid_argument("ChiSquareSurvival: dof must be >= 1");
  if (!(x > 0.0)) return 1.0;
  if (std::isinf(x)) return 0.0;
  const double half = 0.5 * x;
  double sum = 0.0, term = 0.0;
  if (dof % 2 == 0) {
    // exp(-x/2) sum_{j < dof/2} (x/2)^j / j!
    term = 1.0;
    for (int j = 0; j < dof / 2; ++j) {
      if (j > 0) term *= half / j;
      sum += term;
    }
    return std::exp(-half) * sum;
  }
  // erfc(sqrt(x/2)) + sqrt(2x/pi) exp(-x/2) sum_{j=1}^{(dof-1)/2} x^(j-1) / (1 * 3 * ... * (2j-1))
  term = 1.0;
  for (int j = 1; j <= (dof - 1) / 2; ++j) {
    if (j > 1) term *= x / (2 * j - 1);
    sum += term;
  }
  return std::erfc(std::sqrt(half)) + std::sqrt(2.0 * x / M_PI) * std::exp(-half) * sum;
}

double ChiSquareQuantile(int dof, double upper_probability) {
  if (!(upper_probability > 0.0 && upper_probability < 1.0)) {
    throw std::invalid_argument("ChiSquareQuantile: probability must be in (0, 1)");
  }
  // The survival function falls monotonically: bisection to round-off, after bracketing.
  double lo = 0.0, hi = dof + 10.0;
  while (ChiSquareSurvival(dof, hi) > upper_probability) hi *= 2.0;
  for (int k = 0; k < 200 && hi - lo > 1e-12 * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    (ChiSquareSurvival(dof, mid) > upper_probability ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

namespace {

// Which parameters a fit estimates, chosen once for the robust fit's rounds.
struct ParameterSelection {
  std::vector<int> parameters;
  std::vector<DroppedParameter> dropped;
  Termination termination = Termination::kConvergence;
  std::string failure;  // non-empty: no set could be chosen
  std::string note;     // said in the fit's message
};

ParameterSelection SelectParameters(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                                    const IdentificationOptions& options);

Calibration IdentifyOnce(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                         const IdentificationOptions& options, const ParameterSelection& selection);

double Median(std::vector<double> values) {
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  if (values.size() % 2 == 1) return values[mid];
  return 0.5 * (values[mid] + *std::max_element(values.begin(), values.begin() + mid));
}

// The model error's components (1-sigma per row; EstimateModelError) and the tracker's mean variance per
// measurement beside them (3-D position, mm^2; angle, rad^2).
struct ModelErrorEstimate {
  double position_mm = 0.0;
  double orientation_rad = 0.0;
  double tracker_variance_mm2 = 0.0;
  double tracker_variance_rad2 = 0.0;
};

// The fit's reduced parameter vector of a calibration (its parameters' values, in the selection's order).
Eigen::VectorXd ReducedParameters(const Calibration& cal) {
  Eigen::VectorXd x(static_cast<Eigen::Index>(cal.parameters.size()));
  for (size_t k = 0; k < cal.parameters.size(); ++k) x[static_cast<Eigen::Index>(k)] = cal.parameters[k].value;
  return x;
}

// The inverse of the information matrix N = J' J of the weighted fit over `measurements` at the calibration,
// with the noise (model error included) of `options`; false if it is singular.
bool InverseInformation(const Calibration& cal, const std::vector<Measurement>& measurements,
                        const IdentificationOptions& options, const std::vector<int>& parameters,
                        Eigen::MatrixXd* inverse) {
  const ShotGroups groups(measurements);
  Problem problem(cal.model, measurements, groups, options, parameters);
  Eigen::VectorXd r;
  Eigen::MatrixXd j;
  problem.Evaluate(ReducedParameters(cal), &r, &j);
  Eigen::VectorXd sv;
  if (!ScaledCovariance(j, 1.0, options.identifiability.rank_tolerance, &sv, inverse)) return false;
  return true;
}

// Variance-component estimation of the model error (Foerstner 1979, "Ein Verfahren zur Schaetzung von Varianz-
// und Kovarianzkomponenten"; Koch 1999, "Parameter Estimation and Hypothesis Testing in Linear Models", 3.6):
// the residual of a pose's mean has the covariance C_g (the tracker's, over the shots; the repeatability) plus
// s_p^2 I on its position rows and s_o^2 I on its orientation rows. Each component is chosen so that the sum
// of its squared whitened residuals equals its redundancy (its rows less their share of the parameters, the
// traces of the hat matrix), the fixed point of Foerstner's iteration; with `robust`, so that their median,
// corrected for the leverage, is the chi-square median instead (Rousseeuw & Leroy 1987): the first round,
// before gross errors are excluded, must not take them for model error. The leverages depend on the
// components; they are recomputed until the components settle.
ModelErrorEstimate EstimateModelError(const Calibration& cal, const std::vector<Measurement>& measurements,
                                      const IdentificationOptions& options, const std::vector<int>& parameters,
                                      bool robust) {
  const MeasurementType type = options.measurement_type;
  const int rows = MeasurementRows(type);
  const int angle_rows = rows - 3;
  const ShotGroups groups(measurements);
  Problem problem(cal.model, measurements, groups, options, parameters);
  std::vector<Transform> prediction;
  std::vector<Eigen::MatrixXd> jacobian;
  problem.Predict(ReducedParameters(cal), &prediction, &jacobian);
  const MeasurementNoise& noise = options.noise;
  const double repeatability = noise.RepeatabilitySigmaMm();
  const double t = noise.OrientationSigmaRad();
  // Per pose (group): the mean residual and the tracker's covariance of the mean.
  const size_t num_groups = groups.groups.size();
  std::vector<Eigen::VectorXd> mean(num_groups, Eigen::VectorXd::Zero(rows));
  std::vector<Eigen::Matrix3d> tracker(num_groups);
  std::vector<double> shots(num_groups);
  ModelErrorEstimate out;
  Eigen::VectorXd r(rows);
  for (size_t g = 0; g < num_groups; ++g) {
    const std::vector<int>& members = groups.groups[g].shots;
    Eigen::Vector3d at = Eigen::Vector3d::Zero();
    for (int i : members) {
      MeasurementResidual(type, measurements[i].T_world_tool, prediction[g], r);
      mean[g] += r;
      at += measurements[i].T_world_tool.translation();
    }
    const double n = static_cast<double>(members.size());
    shots[g] = n;
    mean[g] /= n;
    at /= n;
    const Eigen::Matrix3d c = noise.tracker ? noise.tracker->PositionCovariance(at)
                                            : Eigen::Matrix3d(noise.position_mm * noise.position_mm *
                                                              Eigen::Matrix3d::Identity());
    out.tracker_variance_mm2 += c.trace() * n;
    tracker[g] = c / n + repeatability * repeatability * Eigen::Matrix3d::Identity();
  }
  out.tracker_variance_mm2 /= static_cast<double>(measurements.size());
  out.tracker_variance_rad2 = angle_rows * t * t;

  double sp2 = 0.0, so2 = 0.0;
  const double median3 = ChiSquareQuantile(3, 0.5);
  const double median_angle = angle_rows > 0 ? ChiSquareQuantile(angle_rows, 0.5) : 0.0;
  std::vector<double> lever_p(num_groups), lever_o(num_groups);
  const int p = static_cast<int>(parameters.size());
  for (int cycle = 0; cycle < 20; ++cycle) {
    // Leverages at the current components: the hat matrix's traces per pose and component.
    std::vector<Eigen::Matrix3d> inverse_p(num_groups);
    std::vector<double> inverse_o(num_groups);
    Eigen::MatrixXd information = Eigen::MatrixXd::Zero(p, p);
    for (size_t g = 0; g < num_groups; ++g) {
      inverse_p[g] = (tracker[g] + sp2 * Eigen::Matrix3d::Identity()).inverse();
      inverse_o[g] = 1.0 / (t * t / shots[g] + so2);
      const Eigen::MatrixXd& j = jacobian[g];
      information += j.topRows(3).transpose() * inverse_p[g] * j.topRows(3);
      if (angle_rows > 0) information += inverse_o[g] * j.bottomRows(angle_rows).transpose() * j.bottomRows(angle_rows);
    }
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(information);
    if (ldlt.info() != Eigen::Success) break;
    double redundancy_p = 0.0, redundancy_o = 0.0;
    for (size_t g = 0; g < num_groups; ++g) {
      const Eigen::MatrixXd& j = jacobian[g];
      const Eigen::MatrixXd solved = ldlt.solve(j.transpose());  // N^-1 J_g'
      lever_p[g] = (inverse_p[g] * j.topRows(3) * solved.leftCols(3)).trace();
      redundancy_p += 3.0 - lever_p[g];
      if (angle_rows > 0) {
        lever_o[g] = inverse_o[g] * (j.bottomRows(angle_rows) * solved.rightCols(angle_rows)).trace();
        redundancy_o += angle_rows - lever_o[g];
      }
    }
    // One component: the variance s^2 >= 0 at which the (mean or median) condition holds, by bisection (the
    // whitened squares fall as s^2 grows).
    const auto solve = [&](int dim, double redundancy, const std::function<double(size_t, double)>& square,
                           const std::vector<double>& lever, double median) {
      if (redundancy <= 0.5) return 0.0;
      const auto excess = [&](double v) {
        if (!robust) {
          double sum = 0.0;
          for (size_t g = 0; g < num_groups; ++g) sum += square(g, v);
          return sum - redundancy;
        }
        std::vector<double> q(num_groups);
        for (size_t g = 0; g < num_groups; ++g) q[g] = square(g, v) / std::max(1.0 - lever[g] / dim, 1e-3);
        return Median(q) - median;
      };
      if (excess(0.0) <= 0.0) return 0.0;
      double hi = 1e-12;
      while (excess(hi) > 0.0 && hi < 1e12) hi *= 4.0;
      double lo = hi / 4.0 < 1e-12 ? 0.0 : hi / 4.0;
      for (int k = 0; k < 60 && hi - lo > 1e-9 * hi; ++k) {
        const double mid = 0.5 * (lo + hi);
        (excess(mid) > 0.0 ? lo : hi) = mid;
      }
      return 0.5 * (lo + hi);
    };
    const double new_sp2 = solve(
        3, redundancy_p,
        [&](size_t g, double v) {
          const Eigen::Vector3d d = mean[g].head<3>();
          return d.dot((tracker[g] + v * Eigen::Matrix3d::Identity()).ldlt().solve(d));
        },
        lever_p, median3);
    const double new_so2 =
        angle_rows == 0 ? 0.0
                        : solve(angle_rows, redundancy_o,
                                [&](size_t g, double v) {
                                  return mean[g].tail(angle_rows).squaredNorm() / (t * t / shots[g] + v);
                                },
                                lever_o, median_angle);
    const bool settled = std::abs(new_sp2 - sp2) <= 1e-4 * (new_sp2 + out.tracker_variance_mm2 / 3.0) &&
                         std::abs(new_so2 - so2) <= 1e-4 * (new_so2 + t * t);
    sp2 = new_sp2;
    so2 = new_so2;
    if (settled) break;
  }
  out.position_mm = std::sqrt(sp2);
  out.orientation_rad = std::sqrt(so2);
  return out;
}

// The studentised residual of every measurement against a calibration fitted to the measurements not
// `excluded`: its whitened residual a (noise of `options`, model error included) against the covariance of a
// least-squares residual, I - H for a measurement in the fit and I + H for one left out, H = W J N^-1 J' W'
// (the generalised least-squares residual covariance, exact also for the shots of one pose that share an
// error). z = sqrt(a' (I -+ H)^-1 a); a leverage near 1 is floored.
std::vector<double> StudentizedResiduals(const Calibration& cal, const std::vector<Measurement>& measurements,
                                         const std::vector<char>& excluded, const IdentificationOptions& options,
                                         const std::vector<int>& parameters) {
  std::vector<Measurement> kept;
  for (size_t i = 0; i < measurements.size(); ++i)
    if (!excluded[i]) kept.push_back(measurements[i]);
  Eigen::MatrixXd inverse;
  const bool have_leverage = InverseInformation(cal, kept, options, parameters, &inverse);
  const ShotGroups groups(measurements);
  Problem problem(cal.model, measurements, groups, options, parameters);
  std::vector<Transform> prediction;
  std::vector<Eigen::MatrixXd> jacobian;
  problem.Predict(ReducedParameters(cal), &prediction, &jacobian);
  const MeasurementType type = options.measurement_type;
  const int rows = MeasurementRows(type);
  Eigen::MatrixXd w(rows, rows);
  Eigen::VectorXd r(rows);
  std::vector<double> out(measurements.size());
  for (size_t i = 0; i < measurements.size(); ++i) {
    const int g = groups.group_of[i];
    MeasurementResidual(type, measurements[i].T_world_tool, prediction[g], r);
    options.noise.Whitening(type, measurements[i].T_world_tool.translation(), w);
    const Eigen::VectorXd a = w * r;
    if (!have_leverage) {
      out[i] = a.norm();
      continue;
    }
    const Eigen::MatrixXd b = w * jacobian[g];
    const Eigen::MatrixXd h = b * inverse * b.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (h + h.transpose()));
    const Eigen::VectorXd u = eig.eigenvectors().transpose() * a;
    double z2 = 0.0;
    for (int k = 0; k < rows; ++k) {
      const double lambda = std::max(eig.eigenvalues()[k], 0.0);
      z2 += u[k] * u[k] / (excluded[i] ? 1.0 + lambda : std::max(1.0 - lambda, 1e-6));
    }
    out[i] = std::sqrt(z2);
  }
  return out;
}


// A fit parameter is a translation (mm) by its name's axis: the model's and the reflectors' offsets (past the
// model's parameters, where RobotModel::IsTranslationParameter's index rule does not reach) end in .dx/.dy/.dz.
bool IsTranslationName(const std::string& name) {
  return name.size() > 3 && name.compare(name.size() - 3, 2, ".d") == 0;
}

constexpr double kMinRobustScale = 1e-3;
// A measurement the fit used must exceed the outlier threshold by this factor to be excluded (Identify).
constexpr double kNewOutlierMargin = 1.03;
// Fewer measurements than this leave the residuals' distribution to the noise model (ResidualDistribution).
constexpr size_t kMinMeasurementsForShape = 30;

// The q-quantile of `values` (0 <= q <= 1), linearly interpolated between order statistics.
double Quantile(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  const double at = q * static_cast<double>(values.size() - 1);
  const size_t below = static_cast<size_t>(at);
  if (below + 1 >= values.size()) return values.back();
  return values[below] + (at - static_cast<double>(below)) * (values[below + 1] - values[below]);
}

// c chi^2(nu): the distribution of the squared studentised residuals of clean measurements.
struct ScaledChiSquare {
  int dof = 1;
  double scale = 1.0;
};

// With a Gaussian noise model that is right, z^2 ~ chi^2(rows). Robot error the geometric model does not explain
// is not Gaussian per row: one joint's error moves a pose along one direction and turns it about one axis at
// once, so z^2 (whose mean the model error's estimate makes right) has a heavier tail than chi^2(rows), and a
// chi^2(rows) threshold flags a few percent of clean poses. With the model error estimated (and at least
// kMinMeasurementsForShape measurements), the distribution is therefore taken as the scaled chi-square
// c chi^2(nu) of Satterthwaite's approximation (Satterthwaite 1946, "An approximate distribution of estimates of
// variance components"), fitted to the median and the 90 % quantile of z^2 (quantiles, so that up to a tenth of
// gross errors do not move it): nu the largest number of degrees of freedom, at most rows, whose quantile ratio
// is at least the observed one (the heavier tail when between two), c the median over chi^2(nu)'s. Gaussian
// data give nu = rows and c the robust scale squared. Otherwise chi^2(rows) with c the robust scale squared,
// capped at 1 when the model error is estimated (data more precise than the noise model are judged by their own
// scatter; less precise ones are the model error's).
ScaledChiSquare ResidualDistribution(const std::vector<double>& squares, int rows, double scale, bool estimated) {
  ScaledChiSquare out;
  out.dof = rows;
  out.scale = estimated ? std::min(scale, 1.0) * std::min(scale, 1.0) : scale * scale;
  if (!estimated || squares.size() < kMinMeasurementsForShape) return out;
  const double median = Quantile(squares, 0.5);
  const double upper = Quantile(squares, 0.9);
  if (!(median > 0.0)) return out;
  const double ratio = upper / median;
  int dof = rows;
  while (dof > 1 && ChiSquareQuantile(dof, 0.1) / ChiSquareQuantile(dof, 0.5) < ratio) --dof;
  out.dof = dof;
  out.scale = std::max(median / ChiSquareQuantile(dof, 0.5), kMinRobustScale * kMinRobustScale);
  return out;
}
// A robust scale beyond this factor either way is said in the message (above it: DEGRADED).
constexpr double kScaleWarning = 3.0;
// Fit and estimate cycles of the model error, and the relative change of a row's total variance at which
// they stop.
constexpr int kMaxModelErrorCycles = 8;
constexpr double kModelErrorSettled = 0.02;
// Rounds of the robust fit before it stops with the set it has (an oscillating set is reported as such).
constexpr int kMaxRejectionRounds = 10;
// More than this fraction flagged means the noise model or the data are wrong, not a few gross errors.
constexpr double kSuspiciousOutlierFraction = 0.2;

}  // namespace

Calibration Identify(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                     const IdentificationOptions& options) {
  const Clock::time_point start = Clock::now();
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("IdentificationOptions: " + error);
  const int n_fit = nominal.num_error_parameters() + 3 * static_cast<int>(options.reflectors.size());
  if (!options.parameters.empty() && options.parameters.back() >= n_fit) {
    throw std::invalid_argument("IdentificationOptions: parameters[" + std::to_string(options.parameters.size() - 1) +
                                "] = " + std::to_string(options.parameters.back()) + " but '" + nominal.name() +
                                "' has " + std::to_string(nominal.num_error_parameters()) + " error parameters and " +
                                std::to_string(options.reflectors.size()) + " reflector(s)");
  }
  const ParameterSelection selection = SelectParameters(nominal, measurements, options);
  // A cancelled fit (progress returned false) is not refitted.
  const auto cancelled = [](const Calibration& c) { return c.summary.message.rfind("cancelled", 0) == 0; };
  // The options of the fits: the model error's components are the estimate so far.
  IdentificationOptions current_options = options;
  // Identify makes several fits (the model error's cycles, the robust rounds): the progress it reports is the
  // furthest any of them got, so that it never goes back.
  double progress_so_far = 0.0;
  if (options.progress) {
    current_options.progress = [&](double fraction) {
      progress_so_far = std::max(progress_so_far, fraction);
      return options.progress(progress_so_far);
    };
  }
  ModelErrorEstimate model_error;
  // One fit over `data`, with the model error estimated beside it (estimate_model_error): fit, estimate the
  // components from its residuals, refit with them, until they settle.
  const auto fit = [&](const std::vector<Measurement>& data, bool robust) {
    Calibration cal = IdentifyOnce(nominal, data, current_options, selection);
    if (!options.estimate_model_error) return cal;
    for (int cycle = 0; cycle < kMaxModelErrorCycles; ++cycle) {
      if (cal.summary.termination == Termination::kFailure || cancelled(cal)) return cal;
      model_error = EstimateModelError(cal, data, current_options, selection.parameters, robust);
      MeasurementNoise& noise = current_options.noise;
      const double dp = model_error.position_mm * model_error.position_mm - noise.model_error_mm * noise.model_error_mm;
      const double dor =
          model_error.orientation_rad * model_error.orientation_rad - noise.model_error_rad * noise.model_error_rad;
      // Settled when the total variance per row moves by less than 2 %: the weights no longer change the fit.
      const bool settled =
          std::abs(dp) <= kModelErrorSettled * (model_error.tracker_variance_mm2 / 3.0 +
                                                model_error.position_mm * model_error.position_mm) &&
          std::abs(dor) <= kModelErrorSettled * (noise.OrientationSigmaRad() * noise.OrientationSigmaRad() +
                                                 model_error.orientation_rad * model_error.orientation_rad);
      // Settled: the fit's own weights stay the answer's (the estimate moved them by less than the tolerance).
      if (settled) break;
      noise.model_error_mm = model_error.position_mm;
      noise.model_error_rad = model_error.orientation_rad;
      cal = IdentifyOnce(nominal, data, current_options, selection);
    }
    return cal;
  };
  // Writes the model error into a summary (and the sentence into its message).
  const auto report_model_error = [&](IdentificationSummary* s) {
    if (!options.estimate_model_error || s->termination == Termination::kFailure || s->message.rfind("cancelled", 0) == 0) {
      return;
    }
    const int angle_rows = MeasurementRows(options.measurement_type) - 3;
    s->model_error_estimated = true;
    s->model_error_mm = std::sqrt(3.0) * current_options.noise.model_error_mm;
    s->model_error_rad = std::sqrt(static_cast<double>(angle_rows)) * current_options.noise.model_error_rad;
    s->tracker_rms_mm = std::sqrt(model_error.tracker_variance_mm2);
    s->tracker_rms_rad = std::sqrt(model_error.tracker_variance_rad2);
    std::ostringstream note;
    note << std::setprecision(2) << "; robot error the geometric model does not explain: " << s->model_error_mm
         << " mm";
    if (angle_rows > 0) note << ", " << s->model_error_rad * kDegPerRad << " deg";
    note << " RMS (tracker: " << s->tracker_rms_mm << " mm";
    if (angle_rows > 0) note << ", " << s->tracker_rms_rad * kDegPerRad << " deg";
    note << ")";
    s->message += note.str();
  };

  Calibration all = fit(measurements, options.reject_outliers);
  if (!options.reject_outliers || all.summary.termination == Termination::kFailure || cancelled(all)) {
    report_model_error(&all.summary);
    return all;
  }

  // The robust fit: iterative rejection on studentised residuals, refitting without the flagged measurements
  // until the flagged set repeats.
  const int rows = MeasurementRows(options.measurement_type);
  const double median_chi2 = ChiSquareQuantile(rows, 0.5);
  const size_t n = measurements.size();
  std::vector<char> excluded(n, 0), previous(n, 0);
  std::string stopped;
  Calibration current = all;
  std::vector<double> z;
  double scale = 0.0;
  double threshold = 0.0;
  int rounds = 1;
  bool settled = false;
  // The first fit's model error is the robust (median) one; the answer's is the mean one over the measurements
  // kept, so the set is only settled after a fit with it.
  bool robust_estimate = options.estimate_model_error;
  // The excluded sets fitted so far, and whether the current fit is the last (a cycle was resolved).
  std::vector<std::vector<char>> fitted_sets = {excluded};
  bool last_round = false;
  for (; rounds <= kMaxRejectionRounds; ++rounds) {
    z = StudentizedResiduals(current, measurements, excluded, current_options, selection.parameters);
    std::vector<double> squares(n);
    for (size_t i = 0; i < n; ++i) squares[i] = z[i] * z[i];
    // A median-based scale, robust to up to half the data being gross errors (Rousseeuw & Leroy 1987); floored:
    // data a thousand times more precise than the noise model says (a noise-free simulation) are exact, and
    // their round-off is no outlier.
    scale = std::max(std::sqrt(Median(squares) / median_chi2), kMinRobustScale);
    // The distribution the clean residuals follow, c chi^2(nu) (ResidualDistribution): without the model
    // error's estimate chi^2(rows) over the robust scale, as the noise model says; with it, fitted.
    const ScaledChiSquare shape = ResidualDistribution(squares, rows, scale, options.estimate_model_error);
    threshold = std::sqrt(ChiSquareQuantile(shape.dof, options.outlier_probability));
    // A measurement in the fit is flagged above kNewOutlierMargin times the threshold, one out of it stays out
    // above the threshold: a measurement on the threshold, which each refit's model error moves a little, would
    // otherwise go in and out forever.
    std::vector<char> flagged(n, 0);
    for (size_t i = 0; i < n; ++i) {
      z[i] /= std::sqrt(shape.scale);
      flagged[i] = z[i] > threshold * (excluded[i] ? 1.0 : kNewOutlierMargin) ? 1 : 0;
    }
    if ((flagged == excluded && !robust_estimate) || last_round) {
      settled = true;
      break;
    }
    if (rounds == kMaxRejectionRounds) break;
    // A set fitted before (not the last one): the rejection cycles through sets that differ in measurements on
    // the threshold, which each refit moves across it. Those stay in: the answer excludes what every set of the
    // cycle excluded.
    if (!robust_estimate) {
      for (size_t k = 0; k + 1 < fitted_sets.size(); ++k) {
        if (fitted_sets[k] != flagged) continue;
        for (size_t j = k; j < fitted_sets.size(); ++j) {
          for (size_t i = 0; i < n; ++i) flagged[i] = flagged[i] && fitted_sets[j][i];
        }
        last_round = true;
        break;
      }
    }
    excluded = flagged;
    fitted_sets.push_back(excluded);
    std::vector<Measurement> kept;
    kept.reserve(n);
    for (size_t i = 0; i < n; ++i)
      if (!excluded[i]) kept.push_back(measurements[i]);
    const IdentificationOptions before = current_options;
    const ModelErrorEstimate estimate_before = model_error;
    Calibration next = fit(kept, false);
    robust_estimate = false;
    if (cancelled(next)) return next;
    if (next.summary.termination == Termination::kFailure) {
      // Too few measurements left to fit (the flagged ones took whole poses with them): the rejection cannot
      // go on, and the last fit that worked is the answer, DEGRADED and saying why; its own outliers (the
      // previous round's) stay listed below.
      const int count = static_cast<int>(n - kept.size());
      stopped = "the robust fit stopped: excluding " + std::to_string(count) + " measurement(s) left " +
                next.summary.message + "; this is the fit before that round";
      for (size_t i = 0; i < n; ++i) excluded[i] = previous[i];
      current_options = before;
      model_error = estimate_before;
      break;
    }
    previous = excluded;
    current = std::move(next);
  }
  IdentificationSummary& s = current.summary;
  s.outlier_threshold = threshold;
  s.robust_scale = scale;
  s.rejection_rounds = rounds;
  for (size_t i = 0; i < n; ++i) {
    if (excluded[i]) s.outliers.push_back({static_cast<int>(i), measurements[i].reflector, z[i]});
  }
  if (!s.outliers.empty()) s.parameters_with_outliers = all.parameters;
  if (!stopped.empty()) {
    if (s.termination == Termination::kConvergence) s.termination = Termination::kDegraded;
    s.message += "; " + stopped;
  } else if (!settled) {
    if (s.termination == Termination::kConvergence) s.termination = Termination::kDegraded;
    s.message += "; the outlier set did not settle in " + std::to_string(kMaxRejectionRounds) + " rounds";
  }
  // The scale is 1 when the noise model is right. Without the model error's estimate, far above, the data
  // scatter more than the model says and gross errors can hide in the scatter (or more than half the data are
  // gross errors); far below, the model is too pessimistic, and where its proportions are wrong (e.g. across
  // against along the beam) the whitened residuals are no longer chi-square shaped and clean shots get flagged.
  if (scale > kScaleWarning && !options.estimate_model_error) {
    if (s.termination == Termination::kConvergence) s.termination = Termination::kDegraded;
    std::ostringstream note;
    note << "; the residuals scatter " << std::setprecision(3) << scale
         << " times what the noise model says (robust scale): outliers may be missed; check the tracker figures, "
            "the repeatability and the data, or estimate the model error";
    s.message += note.str();
  } else if (scale < 1.0 / kScaleWarning && scale > kMinRobustScale) {
    std::ostringstream note;
    note << "; the residuals scatter only " << std::setprecision(3) << scale
         << " times what the noise model says (robust scale): the model is pessimistic";
    s.message += note.str();
  }
  report_model_error(&s);
  if (static_cast<double>(s.outliers.size()) > kSuspiciousOutlierFraction * static_cast<double>(n)) {
    if (s.termination == Termination::kConvergence) s.termination = Termination::kDegraded;
    s.message += "; " + std::to_string(s.outliers.size()) + " of " + std::to_string(n) +
                 " measurements are outliers: check the noise model and the reflector";
  }
  s.seconds = Seconds(start);
  return current;
}

namespace {

// A joint term whose column at the measured configurations keeps less than this fraction of its norm outside
// the span of the other chosen columns is not observed by the data: its standard deviation would be over 100
// times that of a parameter observed on its own, and its value whatever the noise makes it (then extrapolated to
// other poses). A harmonic of order 1 of a joint measured over only a degree or two, or one of order 2 over a few
// degrees, stays below it; so does a compliance whose gravity torque hardly changes between the measured poses.
constexpr double kJointTermObservedFraction = 1e-2;

// The joint terms (compliance, harmonics) the measurements observe: structural identifiability (random
// configurations, no payload) cannot know which payloads and configurations a campaign holds, so their
// columns are tested again at the measured poses. `parameters` (ascending) loses the unobserved ones, which join
// `dropped`.
void DropUnobservedJointTerms(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                              const IdentificationOptions& options, std::vector<int>* parameters,
                              std::vector<DroppedParameter>* dropped) {
  const int first_term = nominal.num_geometric_parameters();
  const int n_all = nominal.num_error_parameters();
  if (nominal.joint_terms().empty()) return;
  const ShotGroups groups(measurements);
  // With reflector nests the fit sees the tool's whole pose through them (nests off the tool point see it turn):
  // the pose rows then stand for them, as in the fit's own Jacobian before it is carried to each nest.
  const MeasurementType type = options.reflectors.empty() ? options.measurement_type : MeasurementType::kPose;
  const int rows = MeasurementRows(type);
  const Eigen::VectorXd weights = options.noise.RowWeights(type);
  const Eigen::Index num_rows = static_cast<Eigen::Index>(groups.poses.size()) * rows;
  std::vector<int> model_columns;
  for (int j : *parameters) {
    if (j < n_all) model_columns.push_back(j);
  }
  Eigen::MatrixXd full(rows, n_all);
  Eigen::MatrixXd a(num_rows, static_cast<Eigen::Index>(model_columns.size()));
  KinematicsWorkspace ws(nominal);
  for (size_t p = 0; p < groups.poses.size(); ++p) {
    IdentificationJacobian(nominal, groups.poses[p], Eigen::VectorXd(), type, &ws, full, groups.payloads[p]);
    for (size_t c = 0; c < model_columns.size(); ++c) {
      a.block(static_cast<Eigen::Index>(p) * rows, static_cast<Eigen::Index>(c), rows, 1) =
          weights.cwiseProduct(full.col(model_columns[c]));
    }
  }
  std::vector<int> geometric, terms;
  for (size_t c = 0; c < model_columns.size(); ++c) (model_columns[c] < first_term ? geometric : terms).push_back(c);
  if (terms.empty()) return;
  // Unit columns; the terms' parts outside the geometric span, then a pivoted QR among those parts.
  for (Eigen::Index c = 0; c < a.cols(); ++c) {
    const double norm = a.col(c).norm();
    if (norm > 0.0) a.col(c) /= norm;
  }
  Eigen::MatrixXd g(num_rows, static_cast<Eigen::Index>(geometric.size()));
  for (size_t c = 0; c < geometric.size(); ++c) g.col(static_cast<Eigen::Index>(c)) = a.col(geometric[c]);
  Eigen::MatrixXd t(num_rows, static_cast<Eigen::Index>(terms.size()));
  for (size_t c = 0; c < terms.size(); ++c) t.col(static_cast<Eigen::Index>(c)) = a.col(terms[c]);
  if (g.cols() > 0) {
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(g);
    const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(num_rows, g.cols());
    t -= q * (q.transpose() * t);
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> pivoted(t);
  const Eigen::MatrixXd r = pivoted.matrixR().template triangularView<Eigen::Upper>();
  std::vector<int> unobserved;
  for (Eigen::Index k = 0; k < std::min(r.rows(), r.cols()); ++k) {
    if (std::abs(r(k, k)) < kJointTermObservedFraction) {
      for (Eigen::Index rest = k; rest < r.cols(); ++rest) {
        unobserved.push_back(model_columns[terms[pivoted.colsPermutation().indices()[rest]]]);
      }
      break;
    }
  }
  if (r.rows() < r.cols()) {
    for (Eigen::Index rest = r.rows(); rest < r.cols(); ++rest)
      unobserved.push_back(model_columns[terms[pivoted.colsPermutation().indices()[rest]]]);
  }
  if (unobserved.empty()) return;
  std::sort(unobserved.begin(), unobserved.end());
  unobserved.erase(std::unique(unobserved.begin(), unobserved.end()), unobserved.end());
  for (int j : unobserved) {
    const JointTermParameter& term = nominal.joint_terms()[static_cast<size_t>(j - first_term)];
    dropped->push_back(
        {j, nominal.parameter_name(j),
         term.kind == JointTermParameter::Kind::kCompliance
             ? "not observed by these measurements: its gravity torques move the tool as the other parameters do "
               "(measure under a second payload, or at more varied arm postures)"
             : "not observed by these measurements: its effect is that of the other parameters (measure the joint "
               "over more of its range)"});
    parameters->erase(std::find(parameters->begin(), parameters->end(), j));
  }
}

ParameterSelection SelectParameters(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                                    const IdentificationOptions& options) {
  ParameterSelection out;
  if (nominal.error_terms().compliance && !nominal.has_masses()) {
    out.failure = "model.compliance: robot '" + nominal.name() +
                  "' has no link masses (set joints[].mass_kg and com_mm, or import a URDF with <inertial> "
                  "elements): its gravity torques are unknown";
    return out;
  }
  const int n_all = nominal.num_error_parameters();
  const int num_reflectors = static_cast<int>(options.reflectors.size());
  // The fit's index space: the model's parameters, then 3 offset errors per reflector.
  const int n_fit = n_all + 3 * num_reflectors;
  const auto name = [&](int index) { return ParameterName(nominal, options.reflectors, index); };
  if (!options.parameters.empty()) {
    out.parameters = options.parameters;
    for (int k = 0, next = 0; k < n_fit; ++k) {
      if (next < static_cast<int>(out.parameters.size()) && out.parameters[next] == k)
        ++next;
      else
        out.dropped.push_back({k, name(k), "not requested"});
    }
    return out;
  }
  // A nest without shots has nothing to say: the identifiability probe leaves it out (its rows would be
  // information the data do not hold) and its offset is dropped by name.
  std::vector<char> measured(num_reflectors, 0);
  for (const Measurement& m : measurements) {
    if (m.reflector >= 0 && m.reflector < num_reflectors) measured[m.reflector] = 1;
  }
  IdentifiabilityOptions identifiability = options.identifiability;
  std::vector<int> original;  // probe reflector -> the fit's reflector
  bool free_nests = false;
  for (int k = 0; k < num_reflectors; ++k) {
    if (!measured[k]) continue;
    identifiability.reflectors.push_back(options.reflectors[k]);
    original.push_back(k);
    free_nests = free_nests || !options.reflectors[k].fixed;
  }
  const IdentifiabilitySummary id = FindIdentifiableParameters(nominal, options.measurement_type, identifiability);
  if (id.termination == Termination::kFailure) {
    out.failure = "identifiability: " + id.message;
    return out;
  }
  out.termination = id.termination;
  const auto fit_index = [&](int j) { return j < n_all ? j : n_all + 3 * original[(j - n_all) / 3] + (j - n_all) % 3; };
  for (int j : id.identifiable) out.parameters.push_back(fit_index(j));
  for (DroppedParameter d : id.dropped) {
    d.index = fit_index(d.index);
    out.dropped.push_back(std::move(d));
  }
  for (int k = 0; k < num_reflectors; ++k) {
    if (measured[k]) continue;
    for (int axis = 0; axis < 3; ++axis) {
      const int j = n_all + 3 * k + axis;
      out.dropped.push_back({j, name(j),
                             options.reflectors[k].fixed
                                 ? "held at its given position (fixed reflector)"
                                 : "reflector '" + options.reflectors[k].id + "' has no measurements"});
    }
  }
  std::sort(out.parameters.begin(), out.parameters.end());
  DropUnobservedJointTerms(nominal, measurements, options, &out.parameters, &out.dropped);
  std::sort(out.dropped.begin(), out.dropped.end(),
            [](const DroppedParameter& a, const DroppedParameter& b) { return a.index < b.index; });
  if (!free_nests && !original.empty()) {
    // Held nests on one line (two nests, or three in a row) leave the tool's turn about that line unobserved:
    // fewer of the model's parameters than pose measurements would identify.
    IdentifiabilityOptions pose_options = options.identifiability;
    const IdentifiabilitySummary pose = FindIdentifiableParameters(nominal, MeasurementType::kPose, pose_options);
    const auto model_kept = std::count_if(out.parameters.begin(), out.parameters.end(), [&](int j) { return j < n_all; });
    if (pose.termination != Termination::kFailure && model_kept < static_cast<long>(pose.identifiable.size())) {
      out.note = "the reflector nests do not observe the tool's full orientation (" + std::to_string(model_kept) +
                 " parameters against " + std::to_string(pose.identifiable.size()) +
                 " from pose measurements): nests on one line leave the turn about it open, and a tool point off "
                 "that line is not calibrated (three nests not on one line observe it)";
    }
  }
  if (free_nests) {
    // The parameters the nests' offsets took over (FindIdentifiableParameters' gauge): they stay nominal.
    std::string held;
    for (const DroppedParameter& d : out.dropped) {
      if (d.index < n_all && d.reason.find("reflector.") != std::string::npos) held += (held.empty() ? "" : ", ") + d.name;
    }
    out.note = "free reflector nests locate themselves, not the tool point: " +
               (held.empty() ? std::string("nothing") : held) +
               " stay nominal (hold the nests at measured positions to calibrate the tool point)";
  }
  return out;
}

Calibration IdentifyOnce(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                         const IdentificationOptions& options, const ParameterSelection& selection) {
  const Clock::time_point start = Clock::now();
  const int n_all = nominal.num_error_parameters();
  const int num_reflectors = static_cast<int>(options.reflectors.size());
  const auto name = [&](int index) { return ParameterName(nominal, options.reflectors, index); };
  for (size_t i = 0; i < measurements.size(); ++i) {
    if (measurements[i].joints.size() != nominal.num_joints()) {
      throw std::invalid_argument("Identify: measurements[" + std::to_string(i) + "].joints has " +
                                  std::to_string(measurements[i].joints.size()) + " values, robot '" + nominal.name() +
                                  "' has " + std::to_string(nominal.num_joints()) + " joints");
    }
  }

  const MeasurementType type = options.measurement_type;
  Calibration cal{nominal,
                  Eigen::VectorXd::Zero(n_all),
                  {},
                  Eigen::MatrixXd(),
                  nominal.T_world_base(),
                  nominal.T_flange_tool(),
                  options.reflectors,
                  {}};
  IdentificationSummary& s = cal.summary;
  s.measurement_type = type;
  s.model = nominal.error_terms();
  s.num_measurements = static_cast<int>(measurements.size());
  s.num_residuals = MeasurementRows(type) * s.num_measurements;
  s.scaling = DescribeScaling(options.noise);
  s.T_world_base = cal.T_world_base;
  s.T_flange_tool = cal.T_flange_tool;
  const auto fail = [&](const std::string& message) {
    s.termination = Termination::kFailure;
    s.message = message;
    s.seconds = Seconds(start);
    return cal;
  };

  if (measurements.empty()) return fail("no measurements");
  for (size_t i = 0; i < measurements.size(); ++i) {
    const std::string problem = CheckMeasurement(measurements[i], type);
    if (!problem.empty()) return fail("measurements[" + std::to_string(i) + "]: " + problem);
    const int reflector = measurements[i].reflector;
    if (num_reflectors == 0 && reflector != -1) {
      return fail("measurements[" + std::to_string(i) + "]: names reflector " + std::to_string(reflector) +
                  " but the fit has no reflectors");
    }
    if (num_reflectors > 0 && (reflector < 0 || reflector >= num_reflectors)) {
      return fail("measurements[" + std::to_string(i) + "]: reflector " + std::to_string(reflector) +
                  " is not one of the " + std::to_string(num_reflectors) + " reflectors (0.." +
                  std::to_string(num_reflectors - 1) + ")");
    }
  }

  // Which parameters to estimate.
  if (!selection.failure.empty()) return fail(selection.failure);
  const std::vector<int>& parameters = selection.parameters;
  const Termination identifiability_termination = selection.termination;
  s.dropped = selection.dropped;
  s.num_parameters = static_cast<int>(parameters.size());

  // Distinct poses (and reflectors) bound the information; repeated shots only average the noise.
  const ShotGroups groups(measurements);
  s.num_poses = static_cast<int>(groups.poses.size());
  const int rows = MeasurementRows(type);
  // Rows from distinct poses must exceed the parameters: with equality the fit interpolates the pose means and
  // only the scatter of repeated shots would be left to estimate sigma_hat from.
  const int num_groups = static_cast<int>(groups.groups.size());
  if (rows * num_groups <= s.num_parameters) {
    std::ostringstream msg;
    msg << "too few distinct poses: " << s.num_poses << " distinct joint configuration(s) among " << s.num_measurements
        << " measurements give " << rows * num_groups << " independent " << ToString(type) << " rows for "
        << s.num_parameters << " parameters; need at least " << s.num_parameters / rows + 1 << " distinct poses";
    return fail(msg.str());
  }

  // Each reflector's nominal point in the tool frame (empty without reflectors).
  const std::vector<Eigen::Vector3d> nominal_in_tool = ReflectorsInTool(nominal, options.reflectors, Eigen::VectorXd());
  // Tracker -> base registration: nominal tool (or reflector) positions (nominal world frame) onto the measured
  // ones.
  RobotModel model = nominal;
  if (options.register_base) {
    std::vector<Eigen::Vector3d> from, to;
    from.reserve(measurements.size());
    to.reserve(measurements.size());
    KinematicsWorkspace ws(nominal);
    for (const Measurement& m : measurements) {
      // Under the shot's payload: a robot holding compliances sags under it.
      const Transform& tool = ForwardKinematics(nominal, m.joints, Eigen::VectorXd(), &ws, m.payload);
      from.push_back(m.reflector < 0 ? tool.translation() : tool * nominal_in_tool.at(m.reflector));
      to.push_back(m.T_world_tool.translation());
    }
    Transform T;
    try {
      T = RegisterPoints(from, to);
    } catch (const std::invalid_argument&) {
      return fail(
          "degenerate configurations: the tool positions are collinear or coincident, so the tracker -> "
          "base frame cannot be registered");
    }
    RobotModelSpec spec = nominal.spec();
    spec.T_world_base = T * nominal.T_world_base();
    model = RobotModel::Build(spec);
  }

  Problem problem(model, measurements, groups, options, parameters);
  s.before = ComputeResidualStatistics(model, Eigen::VectorXd(), measurements, type, options.noise, nominal_in_tool);

  // Rank test on the scaled Jacobian at the start: degenerate configurations fail here, with the parameters
  // they cannot determine named, instead of producing a meaningless fit.
  {
    Eigen::VectorXd r;
    Eigen::MatrixXd j;
    problem.Evaluate(Eigen::VectorXd::Zero(s.num_parameters), &r, &j);
    s.initial_cost = 0.5 * r.squaredNorm();
    if (!std::isfinite(s.initial_cost) || !AllFinite(j)) return fail("non-finite residuals at the start");
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(j * UnitColumnFactorsOf(j).asDiagonal());
    const int rank = PivotRank(qr.matrixQR().diagonal().cwiseAbs(), options.identifiability.rank_tolerance);
    if (rank < s.num_parameters) {
      std::ostringstream msg;
      msg << "degenerate configurations: rank-deficient Jacobian, the " << s.num_poses << " poses determine only "
          << rank << " of " << s.num_parameters << " parameters (undetermined:";
      const auto& perm = qr.colsPermutation().indices();
      for (int k = rank; k < std::min(s.num_parameters, rank + 4); ++k) {
        msg << " " << name(parameters[perm[k]]);
      }
      msg << (s.num_parameters - rank > 4 ? " ...)" : ")");
      return fail(msg.str());
    }
  }

  LmResult lm = LevenbergMarquardt(&problem, options);
  s.iterations = lm.iterations;
  if (lm.termination == Termination::kFailure || !lm.x.allFinite()) return fail("optimisation failed: " + lm.reason);

  const Eigen::VectorXd errors = problem.FullErrors(lm.x);
  s.final_cost = 0.5 * lm.residual.squaredNorm();
  const int dof = s.num_residuals - s.num_parameters;
  s.sigma_hat = std::sqrt(2.0 * s.final_cost / dof);

  // Covariance and condition number from the column-scaled Jacobian; the rank test of the start, on the
  // singular values at the solution: the covariance needs every one.
  Eigen::VectorXd sv;
  if (!ScaledCovariance(lm.jacobian, s.sigma_hat, options.identifiability.rank_tolerance, &sv, &cal.covariance)) {
    return fail("degenerate configurations: rank-deficient Jacobian at the solution");
  }
  s.condition_number = sv[0] / sv[sv.size() - 1];

  for (int k = 0; k < s.num_parameters; ++k) {
    cal.parameters.push_back({parameters[k], name(parameters[k]), lm.x[k], std::sqrt(cal.covariance(k, k))});
  }
  s.parameters = cal.parameters;
  const Eigen::VectorXd reflector_errors = problem.ReflectorErrors(lm.x);
  s.after = ComputeResidualStatistics(model, errors, measurements, type, options.noise,
                                      ReflectorsInTool(nominal, options.reflectors, reflector_errors));
  for (int k = 0; k < num_reflectors; ++k) cal.reflectors[k].position_mm += reflector_errors.segment<3>(3 * k);

  cal.T_world_base = model.T_world_base() * ErrorTransform(errors.data());
  cal.T_flange_tool = model.T_flange_tool() * ErrorTransform(errors.data() + 6 * (model.num_error_sites() - 1));
  s.T_world_base = cal.T_world_base;
  s.T_flange_tool = cal.T_flange_tool;
  cal.errors = errors;
  cal.model = std::move(model);

  std::ostringstream msg;
  msg << lm.reason;
  s.termination = lm.termination;
  if (lm.termination == Termination::kConvergence && identifiability_termination == Termination::kDegraded) {
    s.termination = Termination::kDegraded;
    msg << "; the identifiable set was unclear (see FindIdentifiableParameters)";
  }
  if (!selection.note.empty()) msg << "; " << selection.note;
  // Geometric errors are tenths of a mm and hundredths of a degree; a fit that needs metres or tens of degrees
  // matched the shots with a wrong nominal geometry (a tool, a reflector position, a table typed wrong).
  std::string implausible;
  int count = 0;
  for (const IdentifiedParameter& p : cal.parameters) {
    const bool mm = IsTranslationName(p.name);
    if (p.index >= nominal.num_geometric_parameters() && p.index < nominal.num_error_parameters()) {
      // A joint term: a compliance beyond kImplausibleComplianceRadPerNm is no robot joint, a harmonic beyond
      // kImplausibleHarmonicRad no gear; the data then hold too little of its effect to say what it is (a term
      // that is nearly constant over the measured poses, fitted to the noise), and it extrapolates wildly.
      // Judged on the joint's whole term: what the robot holds (a calibration registered as a robot) and the
      // fitted correction on top.
      const bool compliance = nominal.parameter_unit(p.index) == ParameterUnit::kRadPerNm;
      const double held = HeldJointTerm(nominal, nominal.joint_terms()[p.index - nominal.num_geometric_parameters()]);
      if (std::abs(held + p.value) > (compliance ? kImplausibleComplianceRadPerNm : kImplausibleHarmonicRad)) {
        std::ostringstream one;
        one << std::setprecision(4) << p.name << " " << (held + p.value) * kDegPerRad
            << (compliance ? " deg/(N*m)" : " deg");
        if (held != 0.0) one << " (held " << held * kDegPerRad << " + fitted " << p.value * kDegPerRad << ")";
        s.implausible_joint_terms.push_back(one.str());
      }
      continue;
    }
    if (std::abs(p.value) > (mm ? kImplausibleErrorMm : kImplausibleErrorRad)) {
      if (++count <= 3) {
        std::ostringstream one;
        one << std::setprecision(4) << p.name << " " << (mm ? p.value : p.value * kDegPerRad) << (mm ? " mm" : " deg");
        implausible += (implausible.empty() ? "" : ", ") + one.str();
      }
    }
  }
  if (count > 0) {
    if (s.termination == Termination::kConvergence) s.termination = Termination::kDegraded;
    msg << "; implausible geometric errors (" << implausible << (count > 3 ? ", ..." : "")
        << "): the nominal geometry, the tool or a reflector position is likely wrong";
  }
  if (!s.implausible_joint_terms.empty()) {
    if (s.termination == Termination::kConvergence) s.termination = Termination::kDegraded;
    msg << "; implausible joint terms (";
    for (size_t k = 0; k < s.implausible_joint_terms.size(); ++k) msg << (k ? ", " : "") << s.implausible_joint_terms[k];
    msg << "): the measured poses hardly vary what drives them (a payload, the arm's posture, the joint's angle); "
           "fit a simpler model or measure more varied poses";
  }
  s.message = msg.str();
  s.seconds = Seconds(start);
  return cal;
}

}  // namespace

std::string IdentificationSummary::BriefReport() const {
  std::ostringstream out;
  out << "Identification (" << ToString(measurement_type) << "): " << ToString(termination) << ", " << message;
  if (termination == Termination::kFailure) return out.str();
  out << "; " << num_parameters << " parameters from " << num_poses << " poses (" << num_measurements
      << " measurements";
  if (!outliers.empty()) out << ", " << outliers.size() << " outlier(s) excluded";
  out << "), rms position " << std::setprecision(4) << before.rms_position_mm << " -> " << after.rms_position_mm
      << " mm, sigma_hat " << sigma_hat << ", cond " << condition_number << ", " << iterations << " iterations, "
      << std::setprecision(3) << seconds << " s";
  return out.str();
}

std::string IdentificationSummary::FullReport() const {
  std::ostringstream out;
  out << BriefReport() << "\n";
  out << "  measurements: " << num_measurements << " (" << num_poses << " distinct poses), residual rows "
      << num_residuals << ", parameters " << num_parameters << "\n";
  out << std::setprecision(4);
  const auto stats = [&](const char* label, const ResidualStatistics& r) {
    out << "  " << label << ": position rms " << r.rms_position_mm << " mm, max " << r.max_position_mm << " mm";
    if (measurement_type != MeasurementType::kPosition) {
      out << "; angle rms " << r.rms_orientation_rad << " rad, max " << r.max_orientation_rad << " rad";
    }
    out << "; weighted rms " << r.rms_weighted << "\n";
  };
  stats("before", before);
  stats("after ", after);
  out << "  cost " << initial_cost << " -> " << final_cost << ", sigma_hat " << sigma_hat << ", iterations "
      << iterations << "\n";
  out << "  condition number " << condition_number << " (" << scaling << ")\n";
  // Printed as position (mm) and roll, pitch, yaw (rad): what cell software that knows nothing of the error
  // model takes over.
  const auto frame = [&](const char* label, const Transform& t) {
    const Eigen::Vector3d p = t.translation(), rpy = RpyFromRotation(t.linear());
    out << "  " << label << ": xyz " << std::setprecision(10) << p.x() << " " << p.y() << " " << p.z() << " mm, rpy "
        << std::setprecision(8) << rpy.x() << " " << rpy.y() << " " << rpy.z() << " rad\n";
  };
  frame("T_world_base ", T_world_base);
  frame("T_flange_tool", T_flange_tool);
  if (!parameters.empty()) {
    out << "  " << std::left << std::setw(12) << "parameter" << std::right << std::setw(14) << "value" << std::setw(14)
        << "std"
        << "  units\n";
    for (const IdentifiedParameter& p : parameters) {
      const bool mm = IsTranslationName(p.name);
      const bool compliance = p.name.size() > 11 && p.name.compare(p.name.size() - 11, 11, ".compliance") == 0;
      out << "  " << std::left << std::setw(12) << p.name << std::right << std::setw(14) << std::setprecision(6)
          << p.value << std::setw(14) << p.std << "  " << (mm ? "mm" : compliance ? "rad/(N*m)" : "rad") << "\n";
    }
  }
  if (rejection_rounds > 0) {
    out << "  robust fit: " << rejection_rounds << " round(s), scale " << std::setprecision(4) << robust_scale
        << ", threshold " << outlier_threshold << " sigma, " << outliers.size() << " outlier(s)";
    for (const OutlierMeasurement& o : outliers) {
      out << (&o == &outliers.front() ? ": " : ", ") << "#" << o.measurement << " (" << o.normalized_residual << ")";
    }
    out << "\n";
  }
  out << "  model: " << model.Describe() << "\n";
  for (size_t k = 0; k < model_candidates.size(); ++k) {
    const ModelCandidate& c = model_candidates[k];
    out << "    " << (static_cast<int>(k) == model_chosen ? "* " : "  ") << std::left << std::setw(28)
        << c.terms.Describe() << std::right << std::setw(5) << c.num_parameters << " parameters";
    if (c.failed_folds > 0) {
      out << ", " << c.failed_folds << " of " << model_folds << " folds failed: " << c.note << "\n";
    } else {
      out << ", held-out mean " << std::setprecision(4) << c.cv_mean_mm << " +- " << c.cv_standard_error_mm
          << " mm, RMS " << c.cv_rms_mm << " mm\n";
    }
  }
  out << "  dropped (" << dropped.size() << "):\n";
  for (const DroppedParameter& d : dropped) out << "    " << d.name << ": " << d.reason << "\n";
  return out.str();
}

}  // namespace robocal
