// Fit diagnostics (fit_diagnostics.h): per-measurement residuals and their statistics, the linearisation of a
// stored fit, correlations, the chi-square distribution.
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

namespace robocal {

using namespace identification_detail;

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
  if (!summary.model_error.estimated) return noise;
  const int angle_rows = MeasurementRows(summary.measurement_type) - 3;
  noise.model_error_mm = summary.model_error.model_error_mm / std::sqrt(3.0);
  noise.model_error_rad =
      angle_rows > 0 ? summary.model_error.model_error_rad / std::sqrt(static_cast<double>(angle_rows)) : 0.0;
  return noise;
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

}  // namespace robocal
