// The robust fit (Identify): rounds of fits that estimate the model error (variance components) and exclude
// gross errors by their studentised residuals, until the set of excluded measurements settles.
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <iomanip>
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

double Median(std::vector<double> values) {
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  if (values.size() % 2 == 1) return values[mid];
  return 0.5 * (values[mid] + *std::max_element(values.begin(), values.begin() + mid));
}

// The model error's components (1-sigma per row; EstimateModelError) and the tracker's mean variance per
// measurement beside them (3-D position, mm^2; angle, rad^2).
struct ModelErrorComponents {
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

// Per pose (group) of a fit: its mean residual, the covariance of that mean from the tracker (over its shots) and
// the repeatability, and that covariance's eigenvalues with the squared projections of the position residual on its
// eigenvectors: with C_g = U diag(lambda) U', d' (C_g + s^2 I)^-1 d = sum_k (u_k' d)^2 / (lambda_k + s^2), so that
// a bisection step costs three divisions per pose instead of a factorisation.
struct PoseResiduals {
  std::vector<Eigen::VectorXd> mean;
  std::vector<Eigen::Matrix3d> covariance;
  std::vector<double> shots;
  std::vector<Eigen::Vector3d> eigenvalues, projected_squares;
};

PoseResiduals MeanResiduals(const std::vector<Measurement>& measurements, const ShotGroups& groups,
                            const std::vector<Transform>& prediction, const IdentificationOptions& options,
                            ModelErrorComponents* out) {
  const MeasurementType type = options.measurement_type;
  const int rows = MeasurementRows(type);
  const MeasurementNoise& noise = options.noise;
  const double repeatability = noise.RepeatabilitySigmaMm();
  const size_t num_groups = groups.groups.size();
  PoseResiduals p{.mean = std::vector<Eigen::VectorXd>(num_groups, Eigen::VectorXd::Zero(rows)),
                  .covariance = std::vector<Eigen::Matrix3d>(num_groups),
                  .shots = std::vector<double>(num_groups),
                  .eigenvalues = std::vector<Eigen::Vector3d>(num_groups),
                  .projected_squares = std::vector<Eigen::Vector3d>(num_groups)};
  Eigen::VectorXd r(rows);
  for (size_t g = 0; g < num_groups; ++g) {
    const std::vector<int>& members = groups.groups[g].shots;
    Eigen::Vector3d at = Eigen::Vector3d::Zero();
    for (int i : members) {
      MeasurementResidual(type, measurements[i].T_world_tool, prediction[g], r);
      p.mean[g] += r;
      at += measurements[i].T_world_tool.translation();
    }
    const double n = static_cast<double>(members.size());
    p.shots[g] = n;
    p.mean[g] /= n;
    at /= n;
    const Eigen::Matrix3d c =
        noise.tracker ? noise.tracker->PositionCovariance(at)
                      : Eigen::Matrix3d(noise.position_mm * noise.position_mm * Eigen::Matrix3d::Identity());
    out->tracker_variance_mm2 += c.trace() * n;
    p.covariance[g] = c / n + repeatability * repeatability * Eigen::Matrix3d::Identity();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(p.covariance[g]);
    p.eigenvalues[g] = eig.eigenvalues();
    p.projected_squares[g] = (eig.eigenvectors().transpose() * p.mean[g].head<3>()).cwiseAbs2();
  }
  out->tracker_variance_mm2 /= static_cast<double>(measurements.size());
  const double t = noise.OrientationSigmaRad();
  out->tracker_variance_rad2 = (rows - 3) * t * t;
  return p;
}

// The leverages of the poses at the components sp2 (position) and so2 (orientation): the hat matrix's traces per
// pose and component, from each pose's Jacobian on its non-zero columns (`columns`, `compact`) and the information
// with the maps' rows (without them a map's coefficients leave it singular). The redundancies are the rows less
// the leverages. False if the information is not positive definite (no leverages).
struct Leverages {
  std::vector<double> position, orientation;
  double redundancy_position = 0.0, redundancy_orientation = 0.0;
};

// LeveragesAt for a few parameters (at most kDenseParameterLimit): every pose's rows whitened, W_g = L L' on the
// position rows (the 3 x 3 inverse covariance) and the orientation's scalar weight, stacked into one matrix A, so
// that the information is A'A (NormalMatrix) and the leverages are the row sums of (A N^-1) o A, each one product of
// the whole (instead of a small product, an allocation and a copy per pose).
bool DenseLeveragesAt(double sp2, double so2, const PoseResiduals& poses, double t, int angle_rows,
                      const std::vector<std::vector<int>>& columns, const std::vector<Eigen::MatrixXd>& compact,
                      const Eigen::MatrixXd& penalty_normal, int p, Leverages* out) {
  const size_t num_groups = compact.size();
  const Eigen::Index rows = 3 + angle_rows;
  Eigen::MatrixXd whitened = Eigen::MatrixXd::Zero(rows * static_cast<Eigen::Index>(num_groups), p);
  for (size_t g = 0; g < num_groups; ++g) {
    const Eigen::Matrix3d inverse_p = (poses.covariance[g] + sp2 * Eigen::Matrix3d::Identity()).inverse();
    const Eigen::Matrix3d l_transposed = Eigen::LLT<Eigen::Matrix3d>(inverse_p).matrixU();
    const double orientation_weight = 1.0 / std::sqrt(t * t / poses.shots[g] + so2);
    const Eigen::MatrixXd& j = compact[g];
    const Eigen::Index first = rows * static_cast<Eigen::Index>(g);
    for (size_t a = 0; a < columns[g].size(); ++a) {
      const auto column = j.col(static_cast<Eigen::Index>(a));
      auto target = whitened.col(columns[g][a]).segment(first, rows);
      target.head<3>() = l_transposed * column.head<3>();
      if (angle_rows > 0) target.tail(angle_rows) = orientation_weight * column.tail(angle_rows);
    }
  }
  Eigen::MatrixXd information = NormalMatrix(whitened);
  if (penalty_normal.size() > 0) information += penalty_normal;
  const Eigen::LLT<Eigen::MatrixXd> llt(information);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(p, p));
  const Eigen::VectorXd hat = (whitened * inverse).cwiseProduct(whitened).rowwise().sum();
  out->position.assign(num_groups, 0.0);
  out->orientation.assign(num_groups, 0.0);
  out->redundancy_position = out->redundancy_orientation = 0.0;
  for (size_t g = 0; g < num_groups; ++g) {
    const Eigen::Index first = rows * static_cast<Eigen::Index>(g);
    out->position[g] = hat.segment<3>(first).sum();
    out->redundancy_position += 3.0 - out->position[g];
    if (angle_rows > 0) {
      out->orientation[g] = hat.segment(first + 3, angle_rows).sum();
      out->redundancy_orientation += angle_rows - out->orientation[g];
    }
  }
  return true;
}

bool LeveragesAt(double sp2, double so2, const PoseResiduals& poses, double t, int angle_rows,
                 const std::vector<std::vector<int>>& columns, const std::vector<Eigen::MatrixXd>& compact,
                 const Eigen::MatrixXd& penalty_normal, int p, Leverages* out) {
  if (p <= kDenseParameterLimit) {
    return DenseLeveragesAt(sp2, so2, poses, t, angle_rows, columns, compact, penalty_normal, p, out);
  }
  const size_t num_groups = compact.size();
  std::vector<Eigen::Matrix3d> inverse_p(num_groups);
  std::vector<double> inverse_o(num_groups);
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(p, p);
  for (size_t g = 0; g < num_groups; ++g) {
    inverse_p[g] = (poses.covariance[g] + sp2 * Eigen::Matrix3d::Identity()).inverse();
    inverse_o[g] = 1.0 / (t * t / poses.shots[g] + so2);
    const Eigen::MatrixXd& j = compact[g];
    Eigen::MatrixXd block = j.topRows(3).transpose() * inverse_p[g] * j.topRows(3);
    if (angle_rows > 0) block += inverse_o[g] * j.bottomRows(angle_rows).transpose() * j.bottomRows(angle_rows);
    for (size_t a = 0; a < columns[g].size(); ++a) {
      for (size_t b = 0; b < columns[g].size(); ++b) information(columns[g][a], columns[g][b]) += block(a, b);
    }
  }
  if (penalty_normal.size() > 0) information += penalty_normal;
  // Cholesky (blocked, unlike LDLT); an information that is not positive definite has no leverages.
  const Eigen::LLT<Eigen::MatrixXd> llt(information);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(p, p));
  out->position.assign(num_groups, 0.0);
  out->orientation.assign(num_groups, 0.0);
  out->redundancy_position = out->redundancy_orientation = 0.0;
  for (size_t g = 0; g < num_groups; ++g) {
    const Eigen::MatrixXd& j = compact[g];
    const Eigen::MatrixXd solved = inverse(columns[g], columns[g]) * j.transpose();  // (N^-1 J_g') on its columns
    out->position[g] = (inverse_p[g] * j.topRows(3) * solved.leftCols(3)).trace();
    out->redundancy_position += 3.0 - out->position[g];
    if (angle_rows > 0) {
      out->orientation[g] = inverse_o[g] * (j.bottomRows(angle_rows) * solved.rightCols(angle_rows)).trace();
      out->redundancy_orientation += angle_rows - out->orientation[g];
    }
  }
  return true;
}

// One component: the variance s^2 >= 0 at which the condition holds (with `robust`, the median of the squares
// corrected for the leverage is the chi-square median `median`; else their sum is the redundancy), by bisection
// (the whitened squares fall as s^2 grows). `square(g, v)` is pose g's whitened square at variance v.
double SolveComponent(int dim, double redundancy, bool robust, const std::function<double(size_t, double)>& square,
                      const std::vector<double>& lever, double median) {
  if (redundancy <= 0.5) return 0.0;
  const size_t num_groups = lever.size();
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
}

// Variance-component estimation of the model error (Foerstner 1979, "Ein Verfahren zur Schaetzung von Varianz-
// und Kovarianzkomponenten"; Koch 1999, "Parameter Estimation and Hypothesis Testing in Linear Models", 3.6):
// the residual of a pose's mean has the covariance C_g (the tracker's, over the shots; the repeatability) plus
// s_p^2 I on its position rows and s_o^2 I on its orientation rows. Each component is chosen so that the sum
// of its squared whitened residuals equals its redundancy (its rows less their share of the parameters, the
// traces of the hat matrix), the fixed point of Foerstner's iteration; with `robust`, so that their median,
// corrected for the leverage, is the chi-square median instead (Rousseeuw & Leroy 1987): the first round,
// before gross errors are excluded, must not take them for model error. The leverages depend on the
// components; they are recomputed until the components settle, from the last estimate `start` (a fit's refits
// change it little: the cycles then settle in one or two).
ModelErrorComponents EstimateModelError(const Calibration& cal, const std::vector<Measurement>& measurements,
                                        const IdentificationOptions& options, const std::vector<int>& parameters,
                                        bool robust, const ModelErrorComponents& start,
                                        const SolutionLinearisation& at_solution) {
  const int angle_rows = MeasurementRows(options.measurement_type) - 3;
  const ShotGroups groups(measurements);
  Problem problem(cal.model, measurements, groups, options, parameters);
  // The fit's own predictions and Jacobians at its solution (the same problem, the same point), or evaluated here.
  const Eigen::VectorXd x = ReducedParameters(cal);
  const bool fitted = at_solution.At(x);
  std::vector<Transform> own_prediction;
  std::vector<Eigen::MatrixXd> own_jacobian;
  if (!fitted) problem.Predict(x, &own_prediction, &own_jacobian);
  const std::vector<Transform>& prediction = fitted ? at_solution.prediction : own_prediction;
  const std::vector<Eigen::MatrixXd>& jacobian = fitted ? at_solution.group_jacobian : own_jacobian;
  const double t = options.noise.OrientationSigmaRad();
  ModelErrorComponents out;
  const PoseResiduals poses = MeanResiduals(measurements, groups, prediction, options, &out);
  // Each pose's Jacobian touches few of a map's coefficients: its non-zero columns, and its part of them.
  const size_t num_groups = groups.groups.size();
  std::vector<std::vector<int>> columns(num_groups);
  std::vector<Eigen::MatrixXd> compact(num_groups);
  for (size_t g = 0; g < num_groups; ++g) {
    columns[g] = NonzeroColumns(jacobian[g]);
    compact[g] = ColumnsOf(jacobian[g], columns[g]);
  }
  const auto position_square = [&](size_t g, double v) {
    return (poses.projected_squares[g].array() / (poses.eigenvalues[g].array() + v)).sum();
  };
  const auto angle_square = [&](size_t g, double v) {
    return poses.mean[g].tail(angle_rows).squaredNorm() / (t * t / poses.shots[g] + v);
  };
  double sp2 = start.position_mm * start.position_mm, so2 = start.orientation_rad * start.orientation_rad;
  Leverages lever;
  for (int cycle = 0; cycle < 20; ++cycle) {
    if (!LeveragesAt(sp2, so2, poses, t, angle_rows, columns, compact, problem.penalty_normal(),
                     static_cast<int>(parameters.size()), &lever)) {
      break;
    }
    const double new_sp2 = SolveComponent(3, lever.redundancy_position, robust, position_square, lever.position,
                                          ChiSquareQuantile(3, 0.5));
    const double new_so2 = angle_rows == 0
                               ? 0.0
                               : SolveComponent(angle_rows, lever.redundancy_orientation, robust, angle_square,
                                                lever.orientation, ChiSquareQuantile(angle_rows, 0.5));
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
                                         const std::vector<int>& parameters, const SolutionLinearisation& at_solution) {
  // `at_solution`, when it is at the calibration's point, is its fit's over the measurements not excluded: its
  // inverse information is the one needed here, and with nothing excluded its predictions and Jacobians too.
  const Eigen::VectorXd x = ReducedParameters(cal);
  const bool fitted = at_solution.At(x);
  Eigen::MatrixXd own_inverse;
  bool have_leverage = fitted && at_solution.inverse_information.size() > 0;
  if (!have_leverage) {
    std::vector<Measurement> kept;
    for (size_t i = 0; i < measurements.size(); ++i)
      if (!excluded[i]) kept.push_back(measurements[i]);
    have_leverage = InverseInformation(cal, kept, options, parameters, &own_inverse);
  }
  const Eigen::MatrixXd& inverse = own_inverse.size() > 0 ? own_inverse : at_solution.inverse_information;
  const ShotGroups groups(measurements);
  Problem problem(cal.model, measurements, groups, options, parameters);
  const bool all_fitted = fitted && std::none_of(excluded.begin(), excluded.end(), [](char e) { return e != 0; });
  std::vector<Transform> own_prediction;
  std::vector<Eigen::MatrixXd> own_jacobian;
  if (!all_fitted) problem.Predict(x, &own_prediction, &own_jacobian);
  const std::vector<Transform>& prediction = all_fitted ? at_solution.prediction : own_prediction;
  const std::vector<Eigen::MatrixXd>& jacobian = all_fitted ? at_solution.group_jacobian : own_jacobian;
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
    // On the pose's non-zero columns only (a map's coefficients are mostly zero at a pose); products of a few rows
    // coefficient by coefficient (the general product's packing costs more than its arithmetic here).
    const std::vector<int> columns = NonzeroColumns(jacobian[g]);
    const bool every_column = columns.size() == static_cast<size_t>(inverse.cols());
    const Eigen::MatrixXd b =
        every_column ? w.lazyProduct(jacobian[g]) : w.lazyProduct(ColumnsOf(jacobian[g], columns));
    const Eigen::MatrixXd solved =
        every_column ? b.lazyProduct(inverse) : b.lazyProduct(Eigen::MatrixXd(inverse(columns, columns)));
    const Eigen::MatrixXd h = solved.lazyProduct(b.transpose());
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

Calibration IdentifyWithoutStale(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                                 const IdentificationOptions& options);

// The priors a fit applies: a kept parameter that a dropped one is indistinguishable from absorbs the dropped one's
// error (joint6.dz takes the tool's length error when tool.dz is dropped, joint1.rx the base's rx), so it takes the
// wider of the two priors. Without this a tool mounted 16 mm off its nominal length, which the tool's free prior
// allows, would be held near zero through the joint parameter that stands in for it (the IPA UR10: 2.5 mm
// cross-validated error at the default priors against 0.54 mm without). A name the caller gave keeps its value.
IdentificationOptions WithInheritedPriors(const RobotModel& nominal, const IdentificationOptions& options,
                                          const ParameterSelection& selection) {
  if (!options.priors) return options;
  IdentificationOptions out = options;
  ParameterPriors unscaled = *options.priors;
  unscaled.scale = 1.0;
  const Eigen::VectorXd prior = PriorStd(nominal, unscaled, options.reflectors);
  for (const DroppedParameter& d : selection.dropped) {
    if (d.alias < 0 || d.index >= prior.size() || d.alias >= prior.size() || !(prior[d.index] > prior[d.alias])) {
      continue;
    }
    const std::string name = ParameterName(nominal, options.reflectors, d.alias);
    if (options.priors->parameters.count(name) == 0) out.priors->parameters[name] = prior[d.index];
  }
  return out;
}

Calibration Identify(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                     const IdentificationOptions& options) {
  std::vector<int> kept_index, stale_index;
  std::vector<Measurement> kept;
  for (size_t i = 0; i < measurements.size(); ++i) {
    (measurements[i].stale ? stale_index : kept_index).push_back(static_cast<int>(i));
    if (!measurements[i].stale) kept.push_back(measurements[i]);
  }
  if (stale_index.empty()) return IdentifyWithoutStale(nominal, measurements, options);
  // Stale readings are wrong data, not noise: out before any fit, listed with their cause and their residual.
  Calibration c = IdentifyWithoutStale(nominal, kept, options);
  IdentificationSummary& s = c.summary;
  for (OutlierMeasurement& o : s.outliers) o.measurement = kept_index[static_cast<size_t>(o.measurement)];
  const MeasurementNoise noise = FittedNoise(s, options.noise);
  const std::vector<Eigen::Vector3d> in_tool = ReflectorsInTool(c.model, c.reflectors, Eigen::VectorXd());
  KinematicsWorkspace ws(c.model);
  const int rows = MeasurementRows(options.measurement_type);
  Eigen::VectorXd r(rows);
  Eigen::MatrixXd w(rows, rows);
  for (int i : stale_index) {
    const Measurement& m = measurements[static_cast<size_t>(i)];
    double z = 0.0;
    if (s.termination != Termination::kFailure && m.joints.size() == c.model.num_joints()) {
      const Transform& tool = ForwardKinematics(c.model, m.joints, c.errors, &ws, m.payload);
      const Transform predicted = m.reflector < 0 || m.reflector >= static_cast<int>(in_tool.size())
                                      ? tool
                                      : AtReflector(tool, in_tool[m.reflector]);
      MeasurementResidual(options.measurement_type, m.T_world_tool, predicted, r);
      noise.Whitening(options.measurement_type, m.T_world_tool.translation(), w);
      z = (w * r).norm();
    }
    s.outliers.push_back({.measurement = i,
                          .reflector = m.reflector,
                          .normalized_residual = z,
                          .cause = OutlierMeasurement::Cause::kStale});
  }
  std::sort(s.outliers.begin(), s.outliers.end(),
            [](const OutlierMeasurement& a, const OutlierMeasurement& b) { return a.measurement < b.measurement; });
  s.message += "; " + std::to_string(stale_index.size()) +
               " stale tracker reading(s) left out (each repeats the shot before it although the robot moved)";
  return c;
}

std::vector<char> FlagStaleShots(const RobotModel& nominal, const std::vector<Measurement>& shots, MeasurementType type,
                                 double repeatability_mm, const StaleShotTolerance& tolerance,
                                 const Measurement* before) {
  std::vector<char> out(shots.size(), 0);
  const double moved_mm = std::max(10.0 * tolerance.position_mm, 3.0 * repeatability_mm);
  const double turned_rad = 10.0 * tolerance.angle_rad;
  const bool angles = type != MeasurementType::kPosition;
  KinematicsWorkspace ws(nominal);
  Transform previous_nominal = Transform::Identity();
  const Measurement* previous = before;
  if (previous != nullptr && previous->joints.size() == nominal.num_joints()) {
    previous_nominal = ForwardKinematics(nominal, previous->joints, Eigen::VectorXd(), &ws);
  }
  for (size_t i = 0; i < shots.size(); ++i) {
    const Measurement& m = shots[i];
    if (m.joints.size() != nominal.num_joints()) {
      previous = nullptr;
      continue;
    }
    const Transform current = ForwardKinematics(nominal, m.joints, Eigen::VectorXd(), &ws);
    if (previous != nullptr && previous->joints.size() == nominal.num_joints() && previous->reflector == m.reflector) {
      const double measured_move = (m.T_world_tool.translation() - previous->T_world_tool.translation()).norm();
      const double nominal_move = (current.translation() - previous_nominal.translation()).norm();
      double measured_turn = 0.0;
      const double nominal_turn = Eigen::AngleAxisd(previous_nominal.linear().transpose() * current.linear()).angle();
      // The angle between the orientations (pose) or the tool axes (position_axis) of the two shots.
      const auto turn = [type](const Transform& a, const Transform& b) {
        if (type == MeasurementType::kPositionAxis) {
          const Eigen::Vector3d za = a.linear().col(2), zb = b.linear().col(2);
          return std::atan2(za.cross(zb).norm(), za.dot(zb));
        }
        return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
      };
      if (angles) {
        measured_turn = turn(previous->T_world_tool, m.T_world_tool);
      }
      const bool repeats = measured_move <= tolerance.position_mm && (!angles || measured_turn <= tolerance.angle_rad);
      // The joints moved: a joint's command changed by more than its tolerance (a shot of the same command again
      // repeats by right). Measuring positions only, the nominal robot must also move the point: a point on the
      // last joint's axis stays where it is as that joint turns.
      double joint_move = 0.0;
      for (int j = 0; j < nominal.num_joints(); ++j) {
        const double unit = nominal.joint_type(j) == JointType::kRevolute ? tolerance.joint_rad : tolerance.joint_mm;
        joint_move = std::max(joint_move, std::abs(m.joints[j] - previous->joints[j]) / unit);
      }
      const bool robot_moved = joint_move > 1.0 && (angles || nominal_move > moved_mm || nominal_turn > turned_rad);
      out[i] = repeats && robot_moved ? 1 : 0;
    }
    previous = &m;
    previous_nominal = current;
  }
  return out;
}

namespace {

// The robust fit (Identify): the model-error cycle around each fit, and the outlier rounds around that. Its state
// is the options of its fits (the model error's components so far) and the estimate.
class RobustFit {
 public:
  RobustFit(const RobotModel& nominal, const IdentificationOptions& options, const ParameterSelection& selection)
      : nominal_(nominal), options_(options), selection_(selection), current_(options) {
    // Identify makes several fits (the model error's cycles, the robust rounds): the progress it reports is the
    // furthest any of them got, so that it never goes back.
    if (options.progress) {
      current_.progress = [this](double fraction) {
        progress_so_far_ = std::max(progress_so_far_, fraction);
        return options_.progress(progress_so_far_);
      };
    }
  }
  RobustFit(const RobustFit&) = delete;
  RobustFit& operator=(const RobustFit&) = delete;

  // The model-error cycle: one fit over `data` with the model error estimated beside it (estimate_model_error):
  // fit, estimate the components from its residuals (`robust`: by their median), refit with them, until they
  // settle. Each fit after the first starts from the last solution (from `from`'s, when given).
  // The answer's linearisation at its solution goes to `at_solution`.
  Calibration Fit(const std::vector<Measurement>& data, bool robust, const Calibration* from,
                  SolutionLinearisation* at_solution) {
    const Eigen::VectorXd first_start = from != nullptr ? StartOf(*from) : Eigen::VectorXd();
    Calibration cal = IdentifyOnce(nominal_, data, current_, selection_, &first_start, at_solution);
    if (!options_.estimate_model_error) return cal;
    for (int cycle = 0; cycle < kMaxModelErrorCycles; ++cycle) {
      if (cal.summary.termination == Termination::kFailure || cal.summary.cancelled) return cal;
      model_error_ = EstimateModelError(cal, data, current_, selection_.parameters, robust, model_error_, *at_solution);
      // Settled: the fit's own weights stay the answer's (the estimate moved them by less than the tolerance).
      if (Settled()) break;
      current_.noise.model_error_mm = model_error_.position_mm;
      current_.noise.model_error_rad = model_error_.orientation_rad;
      const Eigen::VectorXd start = StartOf(cal);
      cal = IdentifyOnce(nominal_, data, current_, selection_, &start, at_solution);
    }
    return cal;
  }

  // Writes the model error into a summary (and the sentence into its message).
  void ReportModelError(IdentificationSummary* s) const {
    if (!options_.estimate_model_error || s->termination == Termination::kFailure || s->cancelled) return;
    const int angle_rows = MeasurementRows(options_.measurement_type) - 3;
    s->model_error.estimated = true;
    s->model_error.model_error_mm = std::sqrt(3.0) * current_.noise.model_error_mm;
    s->model_error.model_error_rad = std::sqrt(static_cast<double>(angle_rows)) * current_.noise.model_error_rad;
    s->model_error.tracker_rms_mm = std::sqrt(model_error_.tracker_variance_mm2);
    s->model_error.tracker_rms_rad = std::sqrt(model_error_.tracker_variance_rad2);
    std::ostringstream note;
    note << std::setprecision(2)
         << "; robot error the geometric model does not explain: " << s->model_error.model_error_mm << " mm";
    if (angle_rows > 0) note << ", " << s->model_error.model_error_rad * kDegPerRad << " deg";
    note << " RMS (tracker: " << s->model_error.tracker_rms_mm << " mm";
    if (angle_rows > 0) note << ", " << s->model_error.tracker_rms_rad * kDegPerRad << " deg";
    note << ")";
    s->message += note.str();
  }

  // The outlier rounds: iterative rejection on studentised residuals from the first fit `all`, refitting without
  // the flagged measurements until the flagged set repeats.
  Calibration RejectOutliers(const std::vector<Measurement>& measurements, const Calibration& all,
                             SolutionLinearisation all_at_solution) {
    const size_t n = measurements.size();
    Rejection state{.excluded = std::vector<char>(n, 0), .current = all};
    state.at_solution = std::move(all_at_solution);
    std::vector<char> previous(n, 0);
    // The first fit's model error is the robust (median) one; the answer's is the mean one over the measurements
    // kept, so the set is only settled after a fit with it.
    bool robust_estimate = options_.estimate_model_error;
    // The excluded sets fitted so far, and whether the current fit is the last (a cycle was resolved).
    std::vector<std::vector<char>> fitted_sets = {state.excluded};
    bool last_round = false;
    for (; state.rounds <= kMaxRejectionRounds; ++state.rounds) {
      std::vector<char> flagged = Flag(measurements, &state);
      if ((flagged == state.excluded && !robust_estimate) || last_round) {
        state.settled = true;
        break;
      }
      if (state.rounds == kMaxRejectionRounds) break;
      if (!robust_estimate) last_round = ResolveCycle(fitted_sets, &flagged);
      state.excluded = flagged;
      fitted_sets.push_back(state.excluded);
      std::vector<Measurement> kept;
      kept.reserve(n);
      for (size_t i = 0; i < n; ++i)
        if (!state.excluded[i]) kept.push_back(measurements[i]);
      const IdentificationOptions before = current_;
      const ModelErrorComponents estimate_before = model_error_;
      SolutionLinearisation next_at_solution;
      Calibration next = Fit(kept, false, &state.current, &next_at_solution);
      robust_estimate = false;
      if (next.summary.cancelled) return next;
      if (next.summary.termination == Termination::kFailure) {
        // Too few measurements left to fit (the flagged ones took whole poses with them): the rejection cannot
        // go on, and the last fit that worked is the answer, DEGRADED and saying why; its own outliers (the
        // previous round's) stay listed.
        const int count = static_cast<int>(n - kept.size());
        state.stopped = "the robust fit stopped: excluding " + std::to_string(count) + " measurement(s) left " +
                        next.summary.message + "; this is the fit before that round";
        state.excluded = previous;
        current_ = before;
        model_error_ = estimate_before;
        break;
      }
      previous = state.excluded;
      state.current = std::move(next);
      state.at_solution = std::move(next_at_solution);
    }
    Summarise(measurements, all, &state);
    return std::move(state.current);
  }

 private:
  // Where the outlier rounds are.
  struct Rejection {
    std::vector<char> excluded;
    Calibration current;
    std::vector<double> z;  // each measurement's studentised residual over the clean residuals' scale
    double scale = 0.0;
    double threshold = 0.0;
    int rounds = 1;
    bool settled = false;
    std::string stopped;  // why the rounds stopped early, if they did
    SolutionLinearisation at_solution;  // current's fit's
  };

  static Eigen::VectorXd StartOf(const Calibration& c) {
    return c.summary.termination == Termination::kFailure ? Eigen::VectorXd() : ReducedParameters(c);
  }

  // Whether the estimate moved the total variance per row by less than kModelErrorSettled (2 %): the weights no
  // longer change the fit.
  bool Settled() const {
    const MeasurementNoise& noise = current_.noise;
    const ModelErrorComponents& e = model_error_;
    const double dp = e.position_mm * e.position_mm - noise.model_error_mm * noise.model_error_mm;
    const double dor = e.orientation_rad * e.orientation_rad - noise.model_error_rad * noise.model_error_rad;
    return std::abs(dp) <= kModelErrorSettled * (e.tracker_variance_mm2 / 3.0 + e.position_mm * e.position_mm) &&
           std::abs(dor) <= kModelErrorSettled * (noise.OrientationSigmaRad() * noise.OrientationSigmaRad() +
                                                  e.orientation_rad * e.orientation_rad);
  }

  // One round's judgement: the studentised residuals of the current fit, their robust scale and distribution,
  // the threshold, and the measurements above it.
  std::vector<char> Flag(const std::vector<Measurement>& measurements, Rejection* state) const {
    const size_t n = measurements.size();
    const int rows = MeasurementRows(options_.measurement_type);
    state->z = StudentizedResiduals(state->current, measurements, state->excluded, current_, selection_.parameters,
                                    state->at_solution);
    std::vector<double> squares(n);
    for (size_t i = 0; i < n; ++i) squares[i] = state->z[i] * state->z[i];
    // A median-based scale, robust to up to half the data being gross errors (Rousseeuw & Leroy 1987); floored:
    // data a thousand times more precise than the noise model says (a noise-free simulation) are exact, and
    // their round-off is no outlier.
    state->scale = std::max(std::sqrt(Median(squares) / ChiSquareQuantile(rows, 0.5)), kMinRobustScale);
    // The distribution the clean residuals follow, c chi^2(nu) (ResidualDistribution): without the model
    // error's estimate chi^2(rows) over the robust scale, as the noise model says; with it, fitted.
    const ScaledChiSquare shape = ResidualDistribution(squares, rows, state->scale, options_.estimate_model_error);
    state->threshold = std::sqrt(ChiSquareQuantile(shape.dof, options_.outlier_probability));
    // A measurement in the fit is flagged above kNewOutlierMargin times the threshold, one out of it stays out
    // above the threshold: a measurement on the threshold, which each refit's model error moves a little, would
    // otherwise go in and out forever.
    std::vector<char> flagged(n, 0);
    for (size_t i = 0; i < n; ++i) {
      state->z[i] /= std::sqrt(shape.scale);
      flagged[i] = state->z[i] > state->threshold * (state->excluded[i] ? 1.0 : kNewOutlierMargin) ? 1 : 0;
    }
    return flagged;
  }

  // A set fitted before (not the last one): the rejection cycles through sets that differ in measurements on the
  // threshold, which each refit moves across it. Those stay in: `flagged` becomes what every set of the cycle
  // excluded, and true says that its fit is the last.
  static bool ResolveCycle(const std::vector<std::vector<char>>& fitted_sets, std::vector<char>* flagged) {
    for (size_t k = 0; k + 1 < fitted_sets.size(); ++k) {
      if (fitted_sets[k] != *flagged) continue;
      for (size_t j = k; j < fitted_sets.size(); ++j) {
        for (size_t i = 0; i < flagged->size(); ++i) (*flagged)[i] = (*flagged)[i] && fitted_sets[j][i];
      }
      return true;
    }
    return false;
  }

  // The answer's summary: the outliers and the rounds, and what the rounds and the robust scale say about the fit.
  void Summarise(const std::vector<Measurement>& measurements, const Calibration& all, Rejection* state) const {
    IdentificationSummary& s = state->current.summary;
    const size_t n = measurements.size();
    s.outlier_threshold = state->threshold;
    s.robust_scale = state->scale;
    s.rejection_rounds = state->rounds;
    for (size_t i = 0; i < n; ++i) {
      if (state->excluded[i]) s.outliers.push_back({static_cast<int>(i), measurements[i].reflector, state->z[i]});
    }
    if (!s.outliers.empty()) s.parameters_with_outliers = all.parameters;
    const auto degrade = [&s] {
      if (s.termination == Termination::kConvergence) s.termination = Termination::kDegraded;
    };
    if (!state->stopped.empty()) {
      degrade();
      s.message += "; " + state->stopped;
    } else if (!state->settled) {
      degrade();
      s.message += "; the outlier set did not settle in " + std::to_string(kMaxRejectionRounds) + " rounds";
    }
    // The scale is 1 when the noise model is right. Without the model error's estimate, far above, the data
    // scatter more than the model says and gross errors can hide in the scatter (or more than half the data are
    // gross errors); far below, the model is too pessimistic, and where its proportions are wrong (e.g. across
    // against along the beam) the whitened residuals are no longer chi-square shaped and clean shots get flagged.
    const double scale = state->scale;
    if (scale > kScaleWarning && !options_.estimate_model_error) {
      degrade();
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
    ReportModelError(&s);
    if (static_cast<double>(s.outliers.size()) > kSuspiciousOutlierFraction * static_cast<double>(n)) {
      degrade();
      s.message += "; " + std::to_string(s.outliers.size()) + " of " + std::to_string(n) +
                   " measurements are outliers: check the noise model and the reflector";
    }
  }

  const RobotModel& nominal_;
  const IdentificationOptions& options_;
  const ParameterSelection& selection_;
  IdentificationOptions current_;  // the options of the fits: the model error's components are the estimate so far
  ModelErrorComponents model_error_;
  double progress_so_far_ = 0.0;
};

}  // namespace

Calibration IdentifyWithoutStale(const RobotModel& nominal, const std::vector<Measurement>& measurements,
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
  // Every prior named must name a parameter: a mistyped name would otherwise leave it without one, silently.
  if (options.priors) PriorStd(nominal, *options.priors, options.reflectors);
  const ParameterSelection selection = SelectParameters(nominal, measurements, options);
  // RobustFit keeps a reference to its options (and its progress lambda captures them): a local, not a temporary.
  const IdentificationOptions fit_options = WithInheritedPriors(nominal, options, selection);
  RobustFit robust(nominal, fit_options, selection);
  SolutionLinearisation all_at_solution;
  Calibration all = robust.Fit(measurements, options.reject_outliers, nullptr, &all_at_solution);
  // A cancelled fit (progress returned false) is not refitted.
  if (!options.reject_outliers || all.summary.termination == Termination::kFailure || all.summary.cancelled) {
    robust.ReportModelError(&all.summary);
    return all;
  }
  Calibration out = robust.RejectOutliers(measurements, all, std::move(all_at_solution));
  if (!out.summary.cancelled) out.summary.seconds = Seconds(start);
  return out;
}

}  // namespace robocal
