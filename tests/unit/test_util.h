// Shared helpers for the core tests: finite differences and random draws.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/error_model.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/observability.h"
#include "robocal/core/random.h"
#include "robocal/core/robot_model.h"

namespace robocal::test {

/// Random error parameters of realistic size: translations N(0, sigma_mm), rotations N(0, sigma_rad).
inline Eigen::VectorXd RandomErrors(const RobotModel& model, Rng* rng, double sigma_mm = 0.5,
                                    double sigma_rad = 2e-3) {
  Eigen::VectorXd eps(model.num_error_parameters());
  for (int k = 0; k < eps.size(); ++k) {
    eps[k] = (RobotModel::IsTranslationParameter(k) ? sigma_mm : sigma_rad) * rng->Normal();
  }
  return eps;
}

/// `count` configurations drawn uniformly within the joint limits from `seed`.
inline std::vector<Eigen::VectorXd> RandomConfigurations(const RobotModel& model, int count, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<Eigen::VectorXd> out;
  for (int i = 0; i < count; ++i) out.push_back(RandomConfiguration(model, &rng));
  return out;
}

/// Observability options over the identifiable set of `model` for measurements of `type`.
inline ObservabilityOptions IdentifiableSetOptions(const RobotModel& model, MeasurementType type) {
  ObservabilityOptions o;
  o.measurement_type = type;
  o.parameters = FindIdentifiableParameters(model, type).identifiable;
  return o;
}

/// Central differences of f: R^n -> R^m around x with per-coordinate steps h.
inline Eigen::MatrixXd CentralDifferences(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                                          const Eigen::VectorXd& x, const Eigen::VectorXd& h) {
  const Eigen::Index m = f(x).size();
  Eigen::MatrixXd jac(m, x.size());
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    Eigen::VectorXd plus = x, minus = x;
    plus[k] += h[k];
    minus[k] -= h[k];
    jac.col(k) = (f(plus) - f(minus)) / (2.0 * h[k]);
  }
  return jac;
}

/// Largest column-wise relative difference |a_k - b_k| / max(|a_k|, floor), floor = 1e-3 * max column norm
/// (so that columns which are zero in theory are compared against the matrix's scale).
inline double MaxRelativeColumnError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  const double floor = 1e-3 * a.colwise().norm().maxCoeff();
  double worst = 0.0;
  for (Eigen::Index k = 0; k < a.cols(); ++k) {
    const double scale = std::max(a.col(k).norm(), floor);
    worst = std::max(worst, (a.col(k) - b.col(k)).norm() / scale);
  }
  return worst;
}

}  // namespace robocal::test
