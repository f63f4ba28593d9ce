// LinearizeFit (fit_linearization.h): the fit's problem evaluated at its solution.
#include "fit_linearization.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "identification_internal.h"
#include "robocal/core/fit_diagnostics.h"

namespace robocal {

using namespace identification_detail;

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
  if (!residual.allFinite() || !jacobian.allFinite() ||
      !ScaledCovariance(jacobian, 1.0, options.identifiability.rank_tolerance, &out.singular_values,
                        &out.covariance)) {
    throw std::invalid_argument("LinearizeFit: rank-deficient or non-finite Jacobian at the solution");
  }
  // As the fit computes them (IdentifyOnce): the measurements' rows over their redundancy.
  const double dof = problem.num_measurement_rows() - EffectiveParameters(out.covariance, problem.penalty_normal());
  out.sigma_hat = std::sqrt(residual.head(problem.num_measurement_rows()).squaredNorm() / dof);
  out.covariance *= out.sigma_hat * out.sigma_hat;
  out.condition_number = out.singular_values[0] / out.singular_values[out.singular_values.size() - 1];
  return out;
}

}  // namespace robocal
