// The weighted least-squares problem of a fit (identification_internal.h): residuals and Jacobians of the shots,
// grouped by pose, whitened by the noise model.
#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

#include "identification_internal.h"
#include "robocal/core/column_scaling.h"
#include "robocal/core/fit_diagnostics.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/units.h"

namespace robocal::identification_detail {

std::string Num(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

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

Problem::Problem(const RobotModel& model, const std::vector<Measurement>& measurements, const ShotGroups& shot_groups,
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
      groups_(shot_groups.groups),
      group_of_(shot_groups.group_of) {
  prepared_.reserve(poses_.size());
  for (size_t p = 0; p < poses_.size(); ++p)
    prepared_.push_back(PrepareDeflection(model_, poses_[p], shot_groups.payloads[p]));
  if (o.noise.HasSharedError()) {
    // The shots of one group share the robot's repeatability error and its model error: their residuals are correlated.
    // With H an orthonormal (Helmert) basis of the shots whose first vector is the mean direction, the covariance of
    // the n shots becomes block diagonal: sqrt(n) times their mean has the tracker's covariance plus n times the shared
    // one, and the n - 1 Helmert contrasts the tracker's alone (the shots of a group are measured at the same point to
    // within the noise, so one tracker covariance, at their mean, serves them). Only the mean depends on the
    // parameters; the contrasts carry the scatter of the shots.
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
  // The maps' rows: per map, its constant held at zero (the joint's offset is a geometric parameter's) by a row
  // of kMapConstantWeight times the information's root on the mean of its coefficients, and the penalty,
  // sqrt(smoothness x information) times each second difference c_k - 2 c_k+1 + c_k+2 (a row whose coefficients
  // are not all chosen is left out: those are held at zero). The information is the measurements' mean per
  // coefficient under this problem's weights (its Jacobian at zero), so that the smoothness keeps its meaning as
  // the weights change (the model error's estimate).
  std::vector<Eigen::RowVectorXd> rows;
  AddMapRows(&rows);
  // The priors' rows (IdentificationOptions::priors): the prior's "measurement" of x_k is zero with standard
  // deviation sigma_k, a row of 1 / sigma_k in the whitened units of the measurements' rows (sigmas), so that the
  // cost is the negative log posterior and everything that reads the penalty (the covariance, the effective
  // parameters, the model error's leverages) reads the prior with it. Unlike the maps' rows they do not scale
  // with the weights: a prior is in mm and rad, whatever the noise.
  if (o.priors) {
    const Eigen::VectorXd all = PriorStd(model, *o.priors, o.reflectors);
    prior_std_.resize(num_parameters());
    for (int k = 0; k < num_parameters(); ++k) {
      prior_std_[k] = all[parameters_[k]];
      if (!std::isfinite(prior_std_[k])) continue;
      Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(num_parameters());
      row[k] = 1.0 / prior_std_[k];
      rows.push_back(std::move(row));
    }
  }
  if (!rows.empty()) {
    penalty_.setZero(static_cast<Eigen::Index>(rows.size()), num_parameters());
    for (size_t r = 0; r < rows.size(); ++r) penalty_.row(static_cast<Eigen::Index>(r)) = rows[r];
    penalty_normal_ = NormalMatrix(penalty_);
  }
}

void Problem::AddMapRows(std::vector<Eigen::RowVectorXd>* rows) {
  const JointMapTerms& maps = model_.error_terms().maps;
  if (maps.empty()) return;
  const Eigen::VectorXd column_information = ColumnInformation();
  constexpr double kMapConstantWeight = 1e3;
  std::map<int, int> reduced;
  for (int k = 0; k < num_parameters(); ++k) reduced[parameters_[k]] = k;
  for (size_t m = 0; m < maps.joints.size(); ++m) {
    const int first = model_.map_parameter(maps.joints[m]);
    const int count = maps.intervals[m] + 3;
    double information = 0.0;
    int counted = 0;
    for (int k = 0; k < count; ++k) {
      const auto at = reduced.find(first + k);
      if (at == reduced.end()) continue;
      information += column_information[at->second];
      ++counted;
    }
    information = counted > 0 ? information / counted : 0.0;
    const double scale = information > 0.0 ? std::sqrt(information) : 1.0;
    Eigen::RowVectorXd constant = Eigen::RowVectorXd::Zero(num_parameters());
    for (int k = 0; k < count; ++k) {
      const auto at = reduced.find(first + k);
      if (at != reduced.end()) constant[at->second] = kMapConstantWeight * scale / count;
    }
    if (!constant.isZero(0.0)) rows->push_back(std::move(constant));
    const double w = std::sqrt(maps.smoothness * information);
    if (w == 0.0) continue;
    for (int k = 0; k + 2 < count; ++k) {
      const auto a = reduced.find(first + k), b = reduced.find(first + k + 1), c = reduced.find(first + k + 2);
      if (a == reduced.end() || b == reduced.end() || c == reduced.end()) continue;
      Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(num_parameters());
      row[a->second] = w;
      row[b->second] = -2.0 * w;
      row[c->second] = w;
      rows->push_back(std::move(row));
    }
  }
}

void Problem::Evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* residual, Eigen::MatrixXd* jacobian) {
  Predict(x, &prediction_, jacobian != nullptr ? &group_jacobian_ : nullptr);
  if (jacobian != nullptr) {
    jacobian_x_ = x;
    jacobian_prediction_ = prediction_;
  }
  residual->resize(num_rows());
  if (jacobian != nullptr) jacobian->resize(num_rows(), num_parameters());
  if (penalty_.rows() > 0) {
    // The penalty's "measurement" is zero: its residual is -P x and its Jacobian P (r(x + d) ~= r(x) - P d).
    const Eigen::Index first = num_measurement_rows();
    residual->segment(first, penalty_.rows()) = -(penalty_ * x);
    if (jacobian != nullptr) jacobian->bottomRows(penalty_.rows()) = penalty_;
  }
  if (!group_whitening_.empty()) {
    EvaluateByGroup(prediction_, group_jacobian_, residual, jacobian);
    return;
  }
  Eigen::VectorXd r(rows_);
  for (size_t i = 0; i < measurements_.size(); ++i) {
    const int g = group_of_[i];
    MeasurementResidual(type_, measurements_[i].T_world_tool, prediction_[g], r);
    if (whitening_.empty()) {
      residual->segment(rows_ * i, rows_) = weights_.cwiseProduct(r);
      if (jacobian != nullptr) jacobian->middleRows(rows_ * i, rows_) = weights_.asDiagonal() * group_jacobian_[g];
    } else {
      residual->segment(rows_ * i, rows_) = whitening_[i] * r;
      // A product of a few rows: coefficient by coefficient (the general product packs its operands first, which
      // costs more than the arithmetic at this size).
      if (jacobian != nullptr)
        jacobian->middleRows(rows_ * i, rows_).noalias() = whitening_[i].lazyProduct(group_jacobian_[g]);
    }
  }
}

void Problem::Predict(const Eigen::VectorXd& x, std::vector<Transform>* prediction,
                      std::vector<Eigen::MatrixXd>* group_jacobian) {
  const Eigen::VectorXd eps = FullErrors(x);
  const std::vector<Eigen::Vector3d> in_tool = ReflectorsInTool(model_, reflectors_, ReflectorErrors(x));
  const bool with_jacobian = group_jacobian != nullptr;
  const bool by_reflector = !reflectors_.empty();
  // Per pose: the tool's kinematics and, for the Jacobian, its rows (the type's, or the pose's 6 for
  // reflectors, whose points move with the tool's position and orientation), side by side in pose_full_.
  const int pose_rows = by_reflector ? 6 : rows_;
  pose_model_.resize(poses_.size());
  if (with_jacobian) pose_full_.resize(pose_rows, n_model_ * static_cast<Eigen::Index>(poses_.size()));
  const auto full = [&](size_t p) { return pose_full_.middleCols(n_model_ * static_cast<Eigen::Index>(p), n_model_); };
  for (size_t p = 0; p < poses_.size(); ++p) {
    if (with_jacobian) {
      IdentificationJacobian(model_, poses_[p], eps, by_reflector ? MeasurementType::kPose : type_, &ws_, full(p),
                             prepared_[p]);
      pose_model_[p] = ws_.T_world_tool;
    } else {
      pose_model_[p] = ForwardKinematics(model_, poses_[p], eps, &ws_, prepared_[p]);
    }
  }
  prediction->resize(groups_.size());
  if (with_jacobian) group_jacobian->resize(groups_.size());
  Eigen::MatrixXd point(3, n_model_);
  for (size_t g = 0; g < groups_.size(); ++g) {
    const Group& group = groups_[g];
    const Transform& tool = pose_model_[group.pose];
    (*prediction)[g] = group.reflector < 0 ? tool : AtReflector(tool, in_tool[group.reflector]);
    if (!with_jacobian) continue;
    Eigen::MatrixXd& reduced = (*group_jacobian)[g];
    reduced.setZero(rows_, num_parameters());  // allocates only on the first evaluation
    if (group.reflector < 0) {
      for (int k = 0; k < num_parameters(); ++k) reduced.col(k) = full(group.pose).col(parameters_[k]);
    } else {
      ReflectorRows(tool, in_tool[group.reflector], full(group.pose), point);
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
  }
}

bool Problem::TakeJacobianAt(const Eigen::VectorXd& x, std::vector<Transform>* prediction,
                             std::vector<Eigen::MatrixXd>* group_jacobian) {
  if (jacobian_x_.size() != x.size() || group_jacobian_.empty() || !(jacobian_x_.array() == x.array()).all()) {
    return false;
  }
  prediction->swap(jacobian_prediction_);
  group_jacobian->swap(group_jacobian_);
  jacobian_x_.resize(0);
  return true;
}

void Problem::EvaluateByGroup(const std::vector<Transform>& prediction,
                              const std::vector<Eigen::MatrixXd>& group_jacobian, Eigen::VectorXd* residual,
                              Eigen::MatrixXd* jacobian) const {
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
      jacobian->middleRows(row, rows_).noalias() =
          std::sqrt(n) * group_whitening_[g].mean.lazyProduct(group_jacobian[g]);
    }
    row += rows_ * static_cast<Eigen::Index>(shots.size());
  }
}

Eigen::VectorXd Problem::ColumnInformation() {
  // The squared norms of the weighted Jacobian's columns at zero, as Evaluate weights them, from the groups'
  // Jacobians (without building the whole weighted Jacobian).
  Predict(Eigen::VectorXd::Zero(num_parameters()), &prediction_, &group_jacobian_);
  jacobian_x_.resize(0);  // not Evaluate's
  Eigen::VectorXd out = Eigen::VectorXd::Zero(num_parameters());
  if (!group_whitening_.empty()) {
    for (size_t g = 0; g < groups_.size(); ++g) {
      const double n = static_cast<double>(groups_[g].shots.size());
      out += n * (group_whitening_[g].mean * group_jacobian_[g]).colwise().squaredNorm().transpose();
    }
    return out;
  }
  for (size_t i = 0; i < measurements_.size(); ++i) {
    const Eigen::MatrixXd& j = group_jacobian_[group_of_[i]];
    out += (whitening_.empty() ? Eigen::MatrixXd(weights_.asDiagonal() * j) : Eigen::MatrixXd(whitening_[i] * j))
               .colwise()
               .squaredNorm()
               .transpose();
  }
  return out;
}

double EffectiveParameters(const Eigen::MatrixXd& inverse, const Eigen::MatrixXd& penalty_normal) {
  if (penalty_normal.size() == 0) return static_cast<double>(inverse.rows());
  // tr(A B) for symmetric A and B is the sum of their elementwise product (no matrix product).
  return static_cast<double>(inverse.rows()) - inverse.cwiseProduct(penalty_normal).sum();
}

}  // namespace robocal::identification_detail
