// The predicted position error of a calibrated robot (prediction.h): the parameter covariance carried to the
// tool through the position Jacobian, the unexplained error added, and the quantile of |e| for an anisotropic
// Gaussian.
#include "robocal/core/prediction.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "parallel_internal.h"
#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"

namespace robocal {
namespace {

// The product rule on the octant u_1, u_2, u_3 >= 0 of the unit sphere: u_3 = x in [0, 1] (the area element is
// dx dphi, so Gauss-Legendre in x is exact for polynomials in u_3), phi in [0, pi/2] by the midpoint rule
// (exponentially accurate for the smooth periodic integrand in phi). Against a 64 x 64 rule over 300 random
// eigenvalue ratios and the degenerate ones, 10 x 10 nodes give a relative error of the quantile below 1.7e-5 for
// probabilities from 0.8 up (3e-6 at 0.95), 8 x 8 nodes 1.5e-4 at 0.8; lower probabilities need more nodes (the
// integrand's step sharpens), hence PredictionOptions' range. About 8 us per quantile.
constexpr int kPolarNodes = 10;
constexpr int kAzimuthNodes = 10;
constexpr int kNodes = kPolarNodes * kAzimuthNodes;

struct SphereRule {
  // u_1^2, u_2^2, u_3^2 and the weight (summing to 1) of each node.
  std::array<double, kNodes> u1_sq, u2_sq, u3_sq, weight;
};

// Gauss-Legendre nodes and weights on [0, 1] by Newton's method on the Legendre polynomial (Numerical Recipes'
// gauleg): a handful of nodes, computed once.
void GaussLegendreUnitInterval(int n, std::vector<double>* x, std::vector<double>* w) {
  x->assign(n, 0.0);
  w->assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(M_PI * (i + 0.75) / (n + 0.5));
    double derivative = 1.0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p0 = 1.0, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      derivative = n * (z * p1 - p0) / (z * z - 1.0);
      const double step = p1 / derivative;
      z -= step;
      if (std::abs(step) < 1e-15) break;
    }
    (*x)[i] = 0.5 * (z + 1.0);
    (*w)[i] = 1.0 / ((1.0 - z * z) * derivative * derivative);  // 2 / ((1 - z^2) P'^2), halved for [0, 1]
  }
}

const SphereRule& OctantRule() {
  static const SphereRule rule = [] {
    SphereRule r;
    std::vector<double> x, w;
    GaussLegendreUnitInterval(kPolarNodes, &x, &w);
    for (int i = 0; i < kPolarNodes; ++i) {
      for (int j = 0; j < kAzimuthNodes; ++j) {
        const int k = i * kAzimuthNodes + j;
        const double phi = (j + 0.5) * (M_PI / 2.0) / kAzimuthNodes;
        const double s_sq = 1.0 - x[i] * x[i];
        r.u1_sq[k] = s_sq * std::cos(phi) * std::cos(phi);
        r.u2_sq[k] = s_sq * std::sin(phi) * std::sin(phi);
        r.u3_sq[k] = x[i] * x[i];
        r.weight[k] = w[i] / kAzimuthNodes;
      }
    }
    return r;
  }();
  return rule;
}

// The chi distribution of 3 degrees of freedom (|n| for n ~ N(0, I_3)): distribution function and density.
double Chi3Cdf(double a) { return std::erf(a / M_SQRT2) - std::sqrt(2.0 / M_PI) * a * std::exp(-0.5 * a * a); }
double Chi3Pdf(double a) { return std::sqrt(2.0 / M_PI) * a * a * std::exp(-0.5 * a * a); }

// Chi-square quantiles of 1, 2 and 3 degrees of freedom at `probability`, kept for the last probability asked on
// this thread (a request asks one probability for every target; ChiSquareQuantile bisects).
struct ChiSquareQuantiles {
  double probability = -1.0;
  double q1 = 0.0, q2 = 0.0, q3 = 0.0;
};
const ChiSquareQuantiles& QuantilesAt(double probability) {
  thread_local ChiSquareQuantiles cache;
  if (cache.probability != probability) {
    cache.q1 = ChiSquareQuantile(1, 1.0 - probability);
    cache.q2 = ChiSquareQuantile(2, 1.0 - probability);
    cache.q3 = ChiSquareQuantile(3, 1.0 - probability);
    cache.probability = probability;
  }
  return cache;
}

}  // namespace

bool PredictionOptions::IsValid(std::string* error) const {
  if (!(probability >= 0.8 && probability <= 0.9999)) {
    *error = "PredictionOptions: probability must be in [0.8, 0.9999]";
    return false;
  }
  if (!(repeatability_mm >= 0.0 && repeatability_mm <= 100.0)) {
    *error = "PredictionOptions: repeatability_mm must be in [0, 100]";
    return false;
  }
  return true;
}

double PositionErrorQuantile(const Eigen::Matrix3d& covariance_mm2, double probability) {
  if (!(probability >= 0.8 && probability <= 0.9999)) {
    throw std::invalid_argument("PositionErrorQuantile: probability must be in [0.8, 0.9999]");
  }
  if (!covariance_mm2.allFinite()) throw std::invalid_argument("PositionErrorQuantile: covariance is not finite");
  const double scale = covariance_mm2.cwiseAbs().maxCoeff();
  if (scale == 0.0) return 0.0;
  if ((covariance_mm2 - covariance_mm2.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    throw std::invalid_argument("PositionErrorQuantile: covariance is not symmetric");
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance_mm2, Eigen::EigenvaluesOnly);
  Eigen::Vector3d l = eigen.eigenvalues();  // ascending
  if (l[0] < -1e-9 * scale) {
    throw std::invalid_argument("PositionErrorQuantile: covariance has a negative eigenvalue (" + std::to_string(l[0]) +
                                ")");
  }
  l = l.cwiseMax(0.0);
  const double l_max = l[2];

  // 1 / sqrt(u' L u) per node; a direction without variance (a rank-deficient S) is inside at every radius.
  const SphereRule& rule = OctantRule();
  std::array<double, kNodes> inverse_sigma;
  double weight_inside_always = 0.0;
  for (int k = 0; k < kNodes; ++k) {
    const double variance = rule.u1_sq[k] * l[0] + rule.u2_sq[k] * l[1] + rule.u3_sq[k] * l[2];
    inverse_sigma[k] = variance > 0.0 ? 1.0 / std::sqrt(variance) : 0.0;
    if (!(variance > 0.0)) weight_inside_always += rule.weight[k];
  }

  // |e| >= sqrt(l_max) |n_max| and |e| <= sqrt(l_max) |n|: the quantile lies between the chi(1) and the chi(3)
  // quantiles times sqrt(l_max).
  const ChiSquareQuantiles& chi = QuantilesAt(probability);
  double lo = std::sqrt(chi.q1 * l_max), hi = std::sqrt(chi.q3 * l_max);
  // Start from the moment-matched c chi-square(nu) (Satterthwaite / Patnaik: c = sum l^2 / sum l, nu = (sum l)^2 /
  // sum l^2 in [1, 3]), its quantile interpolated between the integer degrees of freedom: Newton then needs about
  // 3 steps instead of 7 from the bracket's middle.
  const double sum = l.sum(), sum_sq = l.squaredNorm();
  const double nu = sum * sum / sum_sq;
  const double q_nu = nu < 2.0 ? chi.q1 + (chi.q2 - chi.q1) * (nu - 1.0) : chi.q2 + (chi.q3 - chi.q2) * (nu - 2.0);
  double r = std::sqrt(sum_sq / sum * q_nu);
  if (!(r > lo && r < hi)) r = 0.5 * (lo + hi);
  for (int iteration = 0; iteration < 60; ++iteration) {
    double p = weight_inside_always, dp = 0.0;
    for (int k = 0; k < kNodes; ++k) {
      if (inverse_sigma[k] == 0.0) continue;
      const double a = r * inverse_sigma[k];
      p += rule.weight[k] * Chi3Cdf(a);
      dp += rule.weight[k] * Chi3Pdf(a) * inverse_sigma[k];
    }
    const double f = p - probability;
    (f > 0.0 ? hi : lo) = r;
    double next = dp > 0.0 ? r - f / dp : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);  // Newton left the bracket: bisect
    // 1e-8 relative: well below the rule's own error, and one evaluation (of about four) earlier than round-off.
    const bool done = std::abs(next - r) <= 1e-8 * r || hi - lo <= 1e-12 * hi;
    r = next;
    if (done) break;
  }
  return r;
}

PositionErrorPrediction PredictPositionError(const Calibration& calibration, const Eigen::VectorXd& q,
                                             const Payload& payload, const PredictionOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("PredictPositionError: " + error);
  const RobotModel& model = calibration.model;
  if (q.size() != model.num_joints() || !q.allFinite()) {
    throw std::invalid_argument("PredictPositionError: q must hold " + std::to_string(model.num_joints()) +
                                " finite values, got " + std::to_string(q.size()));
  }
  const Eigen::Index num_parameters = static_cast<Eigen::Index>(calibration.parameters.size());
  PositionErrorPrediction out;
  if (num_parameters == 0 || calibration.covariance.size() == 0) return out;
  if (calibration.covariance.rows() != num_parameters || calibration.covariance.cols() != num_parameters) {
    throw std::invalid_argument("PredictPositionError: calibration.covariance is " +
                                std::to_string(calibration.covariance.rows()) + " x " +
                                std::to_string(calibration.covariance.cols()) + ", calibration.parameters has " +
                                std::to_string(num_parameters));
  }

  // The position rows of the identification Jacobian at the calibrated errors: d(tool position)/d(parameter),
  // exact at any errors, under the payload (the compliance columns depend on its torques).
  const int n_all = model.num_error_parameters();
  KinematicsWorkspace ws(model);
  Eigen::MatrixXd full(3, n_all);
  IdentificationJacobian(model, q, calibration.errors, MeasurementType::kPosition, &ws, full, payload);
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(3, num_parameters);
  for (Eigen::Index k = 0; k < num_parameters; ++k) {
    const int index = calibration.parameters[k].index;
    // A reflector's offset (index n_all and beyond) moves that reflector only, not the tool point.
    if (index >= 0 && index < n_all) jacobian.col(k) = full.col(index);
  }
  out.parameter_covariance_mm2 = jacobian * calibration.covariance * jacobian.transpose();
  out.parameter_covariance_mm2 = 0.5 * (out.parameter_covariance_mm2 + out.parameter_covariance_mm2.transpose());

  const IdentificationSummary& s = calibration.summary;
  const double model_error_mm = s.model_error.estimated ? s.model_error.model_error_mm / std::sqrt(3.0) : 0.0;
  const double repeatability_mm = options.repeatability_mm / kRepeatabilityPerSigma;
  out.unmodelled_variance_mm2 = model_error_mm * model_error_mm + repeatability_mm * repeatability_mm;
  out.covariance_mm2 = out.parameter_covariance_mm2 + out.unmodelled_variance_mm2 * Eigen::Matrix3d::Identity();
  out.rms_mm = std::sqrt(out.covariance_mm2.trace());
  out.bound_mm = PositionErrorQuantile(out.covariance_mm2, options.probability);
  out.available = true;
  return out;
}

std::vector<double> PredictPositionErrorBounds(const Calibration& calibration,
                                               const std::vector<Eigen::VectorXd>& joints,
                                               const std::vector<Payload>& payloads, const PredictionOptions& options,
                                               int threads) {
  if (threads < 0) throw std::invalid_argument("PredictPositionErrorBounds: threads must be >= 0");
  if (payloads.size() != joints.size() && payloads.size() > 1) {
    throw std::invalid_argument("PredictPositionErrorBounds: one payload, or one per joint vector");
  }
  std::vector<double> bounds(joints.size(), std::numeric_limits<double>::quiet_NaN());
  const Payload none;
  internal::ParallelFor(joints.size(), threads, 64, [&](std::size_t i) {
    const Eigen::VectorXd& q = joints[i];
    if (q.size() != calibration.model.num_joints() || !q.allFinite()) return;
    const Payload& payload = payloads.empty() ? none : payloads.size() == 1 ? payloads[0] : payloads[i];
    bounds[i] = PredictPositionError(calibration, q, payload, options).bound_mm;
  });
  return bounds;
}

}  // namespace robocal
