// Observability indices of configuration sets, by SVD (reference) and by incremental normal matrices.
#include "robocal/core/observability.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "robocal/core/column_scaling.h"

namespace robocal {
namespace {

// A full refresh of A from the stored contributions every this many updates bounds the round-off drift of
// repeated add/subtract updates.
constexpr int kRefreshInterval = 64;

// The predicted error's singularity cut on the LDLT pivots of the unit-column normal matrix (see PredictedError).
constexpr double kNormalPivotTolerance = 1e-12;

Eigen::VectorXd ColumnScale(const ObservabilityOptions& options, const Eigen::VectorXd& column_norms,
                            int num_model_parameters) {
  const int l = static_cast<int>(options.parameters.size());
  if (options.scaling == ColumnScaling::kColumnNorm) return UnitColumnFactors(column_norms);
  Eigen::VectorXd d(l);
  for (int k = 0; k < l; ++k) {
    switch (options.scaling) {
      case ColumnScaling::kColumnNorm:
        break;
      case ColumnScaling::kExpectedDeviation:
        // A reflector's offsets (after the model's parameters) are translations.
        d[k] = options.parameters[k] >= num_model_parameters || RobotModel::IsTranslationParameter(options.parameters[k])
                   ? options.expected_translation_mm
                   : options.expected_rotation_rad;
        break;
      case ColumnScaling::kNone:
        d[k] = 1.0;
        break;
    }
  }
  return d;
}

}  // namespace

ObservabilityIndices IndicesFromSingularValues(const Eigen::VectorXd& singular_values, int num_configurations,
                                               const std::string& scaling) {
  Eigen::VectorXd sv = singular_values;
  ObservabilityIndices out;
  out.num_configurations = num_configurations;
  out.num_parameters = static_cast<int>(sv.size());
  out.scaling = scaling;
  std::sort(sv.data(), sv.data() + sv.size(), std::greater<double>());
  out.singular_values = sv;
  const int l = static_cast<int>(sv.size());
  const double s1 = sv[0];
  const double sl = sv[l - 1];
  const double inf = std::numeric_limits<double>::infinity();
  out.condition_number = sl > 0.0 ? s1 / sl : inf;
  double log_sum = 0.0, inv_sum = 0.0;
  for (int i = 0; i < l; ++i) {
    log_sum += sv[i] > 0.0 ? std::log(sv[i]) : -inf;
    inv_sum += sv[i] > 0.0 ? 1.0 / sv[i] : inf;
  }
  out.o1 = std::exp(log_sum / l) / std::sqrt(static_cast<double>(num_configurations));
  out.o2 = s1 > 0.0 ? sl / s1 : 0.0;
  out.o3 = sl;
  out.o4 = s1 > 0.0 ? sl * sl / s1 : 0.0;
  out.o5 = 1.0 / inv_sum;
  out.log_det = 2.0 * log_sum;
  return out;
}

const char* ToString(ObservabilityIndex index) {
  switch (index) {
    case ObservabilityIndex::kConditionNumber:
      return "condition_number";
    case ObservabilityIndex::kO1:
      return "o1";
    case ObservabilityIndex::kO2:
      return "o2";
    case ObservabilityIndex::kO3:
      return "o3";
    case ObservabilityIndex::kO4:
      return "o4";
    case ObservabilityIndex::kO5:
      return "o5";
    case ObservabilityIndex::kLogDet:
      return "log_det";
    case ObservabilityIndex::kPredictedError:
      return "predicted_error";
  }
  return "?";
}

bool ParseObservabilityIndex(const std::string& text, ObservabilityIndex* index) {
  for (int i = 0; i <= static_cast<int>(ObservabilityIndex::kPredictedError); ++i) {
    const auto candidate = static_cast<ObservabilityIndex>(i);
    if (text == ToString(candidate)) {
      *index = candidate;
      return true;
    }
  }
  return false;
}

bool ObservabilityOptions::IsValid(const RobotModel& model, std::string* error) const {
  if (parameters.empty()) {
    *error = "parameters must list at least one error parameter (normally the identifiable set)";
    return false;
  }
  if (!ValidateReflectors(reflectors, error)) return false;
  if (!reflectors.empty() && measurement_type != MeasurementType::kPosition) {
    *error = "reflectors need position measurements";
    return false;
  }
  const int n_fit = model.num_error_parameters() + 3 * static_cast<int>(reflectors.size());
  for (size_t k = 0; k < parameters.size(); ++k) {
    if (parameters[k] < 0 || parameters[k] >= n_fit) {
      *error = "parameters[" + std::to_string(k) + "] = " + std::to_string(parameters[k]) + " is out of range";
      return false;
    }
    if (k > 0 && parameters[k] <= parameters[k - 1]) {
      *error = "parameters must be strictly ascending";
      return false;
    }
  }
  if (!noise.IsValid(error)) return false;
  if (!(expected_translation_mm > 0.0) || !(expected_rotation_rad > 0.0) ||
      !std::isfinite(expected_translation_mm) || !std::isfinite(expected_rotation_rad)) {
    *error = "expected_translation_mm and expected_rotation_rad must be positive and finite";
    return false;
  }
  if (!(orientation_length_mm > 0.0) || !std::isfinite(orientation_length_mm)) {
    *error = "orientation_length_mm must be positive and finite";
    return false;
  }
  if (!(model_error_mm >= 0.0) || !std::isfinite(model_error_mm)) {
    *error = "model_error_mm must be finite and >= 0";
    return false;
  }
  return true;
}

int ObservabilityOptions::RowsPerConfiguration() const {
  return reflectors.empty() ? MeasurementRows(measurement_type) : 3 * static_cast<int>(reflectors.size());
}

std::string ObservabilityOptions::ScalingDescription() const {
  return DescribeScaling(noise, scaling, expected_translation_mm, expected_rotation_rad);
}

double ObservabilityIndices::Get(ObservabilityIndex index) const {
  switch (index) {
    case ObservabilityIndex::kConditionNumber:
      return condition_number;
    case ObservabilityIndex::kO1:
      return o1;
    case ObservabilityIndex::kO2:
      return o2;
    case ObservabilityIndex::kO3:
      return o3;
    case ObservabilityIndex::kO4:
      return o4;
    case ObservabilityIndex::kO5:
      return o5;
    case ObservabilityIndex::kLogDet:
      return log_det;
    case ObservabilityIndex::kPredictedError:
      return predicted_error_mm;
  }
  return 0.0;
}

double ObjectiveValue(const ObservabilityIndices& indices, ObservabilityIndex index) {
  const double value = indices.Get(index);
  const bool minimised = index == ObservabilityIndex::kConditionNumber || index == ObservabilityIndex::kPredictedError;
  return minimised ? value : -value;
}

ObservabilityIndices ComputeIndicesBySvd(const RobotModel& model, const std::vector<Eigen::VectorXd>& configurations,
                                         const ObservabilityOptions& options) {
  if (configurations.empty()) throw std::invalid_argument("ComputeIndicesBySvd: no configurations");
  // The evaluator validates the options and builds each configuration's weighted, reduced block; only the
  // way the indices are taken from the blocks (SVD of the stack, not the normal matrix) differs.
  ObservabilityEvaluator evaluator(model, options);
  const int rows = options.RowsPerConfiguration();
  Eigen::MatrixXd stacked(rows * configurations.size(), options.parameters.size());
  for (size_t m = 0; m < configurations.size(); ++m) stacked.middleRows(m * rows, rows) = evaluator.Block(configurations[m]);
  const Eigen::VectorXd d = ColumnScale(options, stacked.colwise().norm(), model.num_error_parameters());
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(stacked * d.asDiagonal());
  return IndicesFromSingularValues(svd.singularValues(), static_cast<int>(configurations.size()),
                                   options.ScalingDescription());
}

int NumericalRank(const RobotModel& model, const std::vector<Eigen::VectorXd>& configurations,
                  const ObservabilityOptions& options) {
  if (configurations.empty()) return 0;
  ObservabilityOptions unit_columns = options;
  unit_columns.scaling = ColumnScaling::kColumnNorm;
  return PivotRank(ComputeIndicesBySvd(model, configurations, unit_columns).singular_values, kRankTolerance);
}

ObservabilityEvaluator::ObservabilityEvaluator(const RobotModel& model, ObservabilityOptions options)
    : model_(model), options_(std::move(options)), ws_(model_) {
  std::string error;
  if (!options_.IsValid(model_, &error)) throw std::invalid_argument("ObservabilityOptions: " + error);
  full_jacobian_.resize(MeasurementRows(options_.measurement_type), model_.num_error_parameters());
  pose_jacobian_.resize(6, model_.num_error_parameters());
  row_weights_ = options_.noise.RowWeights(options_.measurement_type);
  reflectors_in_tool_ = ReflectorsInTool(model_, options_.reflectors, Eigen::VectorXd());
  const int l = static_cast<int>(options_.parameters.size());
  normal_ = Eigen::MatrixXd::Zero(l, l);
}

Eigen::MatrixXd ObservabilityEvaluator::Block(const Eigen::VectorXd& q) {
  if (!options_.reflectors.empty()) return ReflectorBlock(q);
  IdentificationJacobian(model_, q, Eigen::VectorXd(), options_.measurement_type, &ws_, full_jacobian_);
  const int l = static_cast<int>(options_.parameters.size());
  Eigen::MatrixXd block(full_jacobian_.rows(), l);
  if (options_.noise.tracker && options_.tracker_position_mm) {
    const int rows = static_cast<int>(full_jacobian_.rows());
    Eigen::MatrixXd w(rows, rows);
    options_.noise.Whitening(options_.measurement_type, ws_.T_world_tool.translation() - *options_.tracker_position_mm,
                             w);
    Eigen::MatrixXd reduced(rows, l);
    for (int k = 0; k < l; ++k) reduced.col(k) = full_jacobian_.col(options_.parameters[k]);
    block.noalias() = w * reduced;
    return block;
  }
  for (int k = 0; k < l; ++k) block.col(k) = row_weights_.cwiseProduct(full_jacobian_.col(options_.parameters[k]));
  return block;
}

Eigen::MatrixXd ObservabilityEvaluator::ReflectorBlock(const Eigen::VectorXd& q) {
  // As identifiability and the fit do (reflectors.h): each reflector's point rows from the tool's pose rows, its
  // own offset columns for a free reflector, whitened at its point.
  IdentificationJacobian(model_, q, Eigen::VectorXd(), MeasurementType::kPose, &ws_, pose_jacobian_);
  const int n = model_.num_error_parameters();
  const int l = static_cast<int>(options_.parameters.size());
  const int count = static_cast<int>(options_.reflectors.size());
  Eigen::MatrixXd block(3 * count, l), point(3, n), reduced(3, l), w(3, 3);
  const Eigen::Matrix3d offset = ReflectorOffsetRows(model_, ws_.T_world_tool);
  for (int r = 0; r < count; ++r) {
    const Eigen::Vector3d& in_tool = reflectors_in_tool_[r];
    ReflectorRows(ws_.T_world_tool, in_tool, pose_jacobian_, point);
    for (int k = 0; k < l; ++k) {
      const int j = options_.parameters[k];
      if (j < n) {
        reduced.col(k) = point.col(j);
      } else if ((j - n) / 3 == r && !options_.reflectors[r].fixed) {
        reduced.col(k) = offset.col((j - n) % 3);
      } else {
        reduced.col(k).setZero();
      }
    }
    if (options_.noise.tracker && options_.tracker_position_mm) {
      options_.noise.Whitening(MeasurementType::kPosition,
                               AtReflector(ws_.T_world_tool, in_tool).translation() - *options_.tracker_position_mm, w);
    } else {
      w = Eigen::Matrix3d(row_weights_.head<3>().asDiagonal());
    }
    block.middleRows(3 * r, 3).noalias() = w * reduced;
  }
  return block;
}

ObservabilityIndices ObservabilityEvaluator::IndicesOf(const Eigen::MatrixXd& normal, int num_configurations) const {
  // Singular values of E* D are the square roots of the eigenvalues of D A D.
  const Eigen::VectorXd d =
      ColumnScale(options_, normal.diagonal().cwiseMax(0.0).cwiseSqrt(), model_.num_error_parameters());
  const Eigen::MatrixXd scaled = d.asDiagonal() * normal * d.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled, Eigen::EigenvaluesOnly);
  ObservabilityIndices out = IndicesFromSingularValues(eig.eigenvalues().cwiseMax(0.0).cwiseSqrt(), num_configurations,
                                                       options_.ScalingDescription());
  if (num_validation_ > 0) out.predicted_error_mm = PredictedError(normal);
  return out;
}

Eigen::MatrixXd ObservabilityEvaluator::PoseJacobian(const Eigen::VectorXd& q) {
  IdentificationJacobian(model_, q, Eigen::VectorXd(), MeasurementType::kPose, &ws_, pose_jacobian_);
  const int l = static_cast<int>(options_.parameters.size());
  const int n = model_.num_error_parameters();
  Eigen::MatrixXd reduced(6, l);
  for (int k = 0; k < l; ++k) {
    // The tool's pose does not depend on a reflector's offset.
    if (options_.parameters[k] < n) {
      reduced.col(k) = pose_jacobian_.col(options_.parameters[k]);
    } else {
      reduced.col(k).setZero();
    }
  }
  return reduced;
}

void ObservabilityEvaluator::SetValidation(const std::vector<Eigen::VectorXd>& validation) {
  const int l = static_cast<int>(options_.parameters.size());
  // Orientation rows count h times (variance h^2) for the types that observe orientation, not at all otherwise.
  const double h = options_.measurement_type == MeasurementType::kPosition ? 0.0 : options_.orientation_length_mm;
  validation_information_ = Eigen::MatrixXd::Zero(l, l);
  for (const Eigen::VectorXd& q : validation) {
    const Eigen::MatrixXd j = PoseJacobian(q);
    validation_information_.noalias() += j.topRows<3>().transpose() * j.topRows<3>();
    if (h > 0.0) validation_information_.noalias() += (h * h) * (j.bottomRows<3>().transpose() * j.bottomRows<3>());
  }
  num_validation_ = static_cast<int>(validation.size());
  if (!configurations_.empty()) indices_ = IndicesOf(normal_, size());
}

double ObservabilityEvaluator::PredictedError(const Eigen::MatrixXd& normal) const {
  if (num_validation_ == 0) return std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  // trace(A^-1 G) = trace(S^-1 D G D) with S = D A D, D scaling A's columns (of E*) to unit norm.
  const Eigen::VectorXd d = UnitColumnFactors(normal.diagonal().cwiseMax(0.0).cwiseSqrt());
  if ((d.array() == 0.0).any()) return inf;  // a parameter without effect on the set
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(d.asDiagonal() * normal * d.asDiagonal());
  if (ldlt.info() != Eigen::Success) return inf;
  const Eigen::VectorXd pivots = ldlt.vectorD();
  if (!(pivots.minCoeff() > kNormalPivotTolerance * pivots.maxCoeff())) return inf;
  const double variance =
      ldlt.solve(d.asDiagonal() * validation_information_ * d.asDiagonal()).trace() / num_validation_;
  // The model error adds in quadrature: no set of poses removes it (ObservabilityOptions::model_error_mm).
  const double model_variance = options_.model_error_mm * options_.model_error_mm;
  return variance >= 0.0 && std::isfinite(variance) ? std::sqrt(variance + model_variance) : inf;
}

void ObservabilityEvaluator::Refresh() {
  normal_.setZero();
  for (const Eigen::MatrixXd& c : contributions_) normal_ += c;
  updates_since_refresh_ = 0;
  indices_ = configurations_.empty() ? ObservabilityIndices{} : IndicesOf(normal_, size());
}

void ObservabilityEvaluator::SetConfigurations(const std::vector<Eigen::VectorXd>& configurations) {
  configurations_ = configurations;
  contributions_.clear();
  for (const Eigen::VectorXd& q : configurations_) {
    const Eigen::MatrixXd b = Block(q);
    contributions_.push_back(b.transpose() * b);
  }
  Refresh();
}

ObservabilityIndices ObservabilityEvaluator::EvaluateReplacement(int m, const Eigen::VectorXd& q) {
  const Eigen::MatrixXd b = Block(q);
  const Eigen::MatrixXd normal = normal_ - contributions_.at(m) + b.transpose() * b;
  return IndicesOf(normal, size());
}

void ObservabilityEvaluator::Replace(int m, const Eigen::VectorXd& q) {
  const Eigen::MatrixXd b = Block(q);
  Eigen::MatrixXd c = b.transpose() * b;
  normal_ += c - contributions_.at(m);
  contributions_[m] = std::move(c);
  configurations_[m] = q;
  if (++updates_since_refresh_ >= kRefreshInterval) {
    Refresh();
  } else {
    indices_ = IndicesOf(normal_, size());
  }
}

void ObservabilityEvaluator::Add(const Eigen::VectorXd& q) {
  const Eigen::MatrixXd b = Block(q);
  contributions_.push_back(b.transpose() * b);
  configurations_.push_back(q);
  normal_ += contributions_.back();
  if (++updates_since_refresh_ >= kRefreshInterval) {
    Refresh();
  } else {
    indices_ = IndicesOf(normal_, size());
  }
}

void ObservabilityEvaluator::Remove(int m) {
  normal_ -= contributions_.at(m);
  contributions_[m] = std::move(contributions_.back());
  contributions_.pop_back();
  configurations_[m] = std::move(configurations_.back());
  configurations_.pop_back();
  if (++updates_since_refresh_ >= kRefreshInterval || configurations_.empty()) {
    Refresh();
  } else {
    indices_ = IndicesOf(normal_, size());
  }
}

PredictedAccuracy PredictAccuracy(const RobotModel& model, const ObservabilityOptions& options,
                                  const std::vector<Eigen::VectorXd>& plan,
                                  const std::vector<Eigen::VectorXd>& validation) {
  PredictedAccuracy out;
  ObservabilityEvaluator evaluator(model, options);
  evaluator.SetConfigurations(plan);
  const int l = static_cast<int>(options.parameters.size());
  if (NumericalRank(model, plan, options) < l) return out;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(evaluator.normal());
  if (ldlt.info() != Eigen::Success) return out;
  const Eigen::MatrixXd covariance = ldlt.solve(Eigen::MatrixXd::Identity(l, l));
  out.has_orientation = options.measurement_type != MeasurementType::kPosition;
  const double h = out.has_orientation ? options.orientation_length_mm : 0.0;
  double sum_position = 0.0, sum_orientation = 0.0;
  for (const Eigen::VectorXd& q : validation) {
    const Eigen::MatrixXd reduced = evaluator.PoseJacobian(q);
    const Eigen::MatrixXd pose_covariance = reduced * covariance * reduced.transpose();
    const double position_var = pose_covariance.topLeftCorner<3, 3>().trace();
    sum_position += position_var;
    sum_orientation += pose_covariance.bottomRightCorner<3, 3>().trace();
    out.max_position_mm = std::max(out.max_position_mm, std::sqrt(position_var));
  }
  out.num_validation = static_cast<int>(validation.size());
  if (out.num_validation > 0) {
    out.rms_position_mm = std::sqrt(sum_position / out.num_validation);
    if (out.has_orientation) out.rms_orientation_rad = std::sqrt(sum_orientation / out.num_validation);
    out.rms_error_mm =
        std::sqrt((sum_position + h * h * (out.has_orientation ? sum_orientation : 0.0)) / out.num_validation);
  }
  return out;
}

}  // namespace robocal
