// The solver loop of a fit and its covariance (identification_internal.h).
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "identification_internal.h"
#include "robocal/core/column_scaling.h"
#include "robocal/core/fit_diagnostics.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/units.h"

namespace robocal::identification_detail {

FitStart EvaluateStart(Problem* problem, const Eigen::VectorXd* x0) {
  FitStart start;
  const int n = problem->num_parameters();
  start.x = x0 != nullptr && x0->size() == n && x0->allFinite() ? *x0 : Eigen::VectorXd::Zero(n);
  problem->Evaluate(start.x, &start.residual, &start.jacobian);
  return start;
}

// Levenberg-Marquardt, written here rather than taken from Eigen's unsupported module because (a) the
// Summary promises the Ceres-style tests of IdentificationOptions (relative cost change, max |J'r|, step
// relative to |x|), which MINPACK's ftol/xtol/gtol define differently (gtol there is a cosine), (b) shots of
// one pose share one Jacobian evaluation (Problem), and (c) the loop is 40 lines with Nielsen's damping update
// and Marquardt's diag(J'J) scaling, so it is scale invariant in mm and rad. Normal equations are safe here:
// they are formed from column-scaled J, whose condition number is checked before the loop (rank test).
LmResult LevenbergMarquardt(Problem* problem, const IdentificationOptions& o, FitStart start) {
  LmResult out;
  out.x.swap(start.x);
  out.residual.swap(start.residual);
  out.jacobian.swap(start.jacobian);
  const int n = problem->num_parameters();
  double cost = 0.5 * out.residual.squaredNorm();
  double lambda = 1e-4;
  double nu = 2.0;
  // A candidate step is judged by its residual alone; the Jacobian is evaluated once a step is taken (the
  // kinematics twice then, which costs less than a second Jacobian's storage and a rejected step's Jacobian).
  Eigen::VectorXd candidate_residual;
  while (true) {
    // Beyond kDenseParameterLimit formed before the tests, so that a loop that ends here leaves it for the
    // covariance (which, with fewer parameters, comes from the SVD of J instead).
    const bool many = n > kDenseParameterLimit;
    if (many) out.normal = NormalMatrix(out.jacobian);
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
    if (!many) out.normal = NormalMatrix(out.jacobian);
    const Eigen::MatrixXd& normal = out.normal;
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
    problem->Evaluate(x_new, &candidate_residual, nullptr);
    const double new_cost = 0.5 * candidate_residual.squaredNorm();
    // Predicted decrease of the linear model: 0.5 step' (lambda D step + g), positive for any lambda > 0.
    const double predicted = 0.5 * step.dot(lambda * diag.cwiseProduct(step) + gradient);
    const double rho = std::isfinite(new_cost) && predicted > 0.0 ? (cost - new_cost) / predicted : -1.0;
    if (rho > 0.0) {
      const double change = cost - new_cost;
      out.x = x_new;
      problem->Evaluate(out.x, &out.residual, &out.jacobian);
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
      out.cancelled = true;
      return out;
    }
  }
}

// Singular values and covariance of a weighted Jacobian through its column-scaled form Js = J D (unit columns):
// (J'J)^-1 = D (Js'Js)^-1 D. False, with nothing written, when Js is rank deficient: no covariance exists.
// The fit and LinearizeFit share it, so a report's recomputed figures are the fit's.
Eigen::MatrixXd NormalMatrix(const Eigen::MatrixXd& jacobian) {
  const Eigen::Index n = jacobian.cols();
  if (n <= kDenseParameterLimit) {
    // The lower triangle (a symmetric rank update, half the general product's work), mirrored.
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(n, n);
    normal.selfadjointView<Eigen::Lower>().rankUpdate(jacobian.transpose());
    normal.triangularView<Eigen::StrictlyUpper>() = normal.transpose();
    return normal;
  }
  // Written here rather than with Eigen's sparse product: the Jacobian is dense storage with mostly zero map
  // columns, and converting it costs as much as this sum. The rows go in blocks of kBlockRows (a pose's rows
  // share their non-zero columns): one pass down the columns finds each block's non-zero columns, and each block
  // adds the product of its compacted rows (a few dozen columns) to the lower triangle.
  constexpr Eigen::Index kBlockRows = 6;
  const Eigen::Index rows = jacobian.rows();
  const Eigen::Index blocks = (rows + kBlockRows - 1) / kBlockRows;
  std::vector<std::vector<Eigen::Index>> columns(static_cast<std::size_t>(blocks));
  for (Eigen::Index c = 0; c < n; ++c) {
    const double* column = jacobian.data() + c * rows;
    for (Eigen::Index b = 0; b < blocks; ++b) {
      const Eigen::Index first = b * kBlockRows, last = std::min(first + kBlockRows, rows);
      for (Eigen::Index r = first; r < last; ++r) {
        if (column[r] != 0.0) {
          columns[static_cast<std::size_t>(b)].push_back(c);
          break;
        }
      }
    }
  }
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd compact, product;
  for (Eigen::Index b = 0; b < blocks; ++b) {
    const std::vector<Eigen::Index>& at = columns[static_cast<std::size_t>(b)];
    if (at.empty()) continue;
    const Eigen::Index first = b * kBlockRows, count = std::min(kBlockRows, rows - first);
    compact = jacobian(Eigen::seqN(first, count), at);
    product.noalias() = compact.transpose() * compact;
    for (std::size_t a = 0; a < at.size(); ++a) {
      double* column = normal.data() + at[a] * n;
      for (std::size_t k = a; k < at.size(); ++k) {
        column[at[k]] += product(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(a));
      }
    }
  }
  normal.triangularView<Eigen::StrictlyUpper>() = normal.transpose();
  return normal;
}

bool ScaledCovarianceOfNormal(const Eigen::MatrixXd& normal, double sigma_hat, double rank_tolerance,
                              Eigen::VectorXd* singular_values, Eigen::MatrixXd* covariance) {
  const Eigen::VectorXd d = UnitColumnFactors(normal.diagonal().cwiseMax(0.0).cwiseSqrt());
  const Eigen::MatrixXd scaled = d.asDiagonal() * normal * d.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled, Eigen::EigenvaluesOnly);
  const Eigen::VectorXd sv = eig.eigenvalues().reverse().cwiseMax(0.0).cwiseSqrt();
  if (PivotRank(sv, std::max(rank_tolerance, kNormalRankTolerance)) < normal.cols()) return false;
  const Eigen::LLT<Eigen::MatrixXd> llt(scaled);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::MatrixXd inverse_scaled = llt.solve(Eigen::MatrixXd::Identity(scaled.rows(), scaled.cols()));
  *covariance = sigma_hat * sigma_hat * d.asDiagonal() * inverse_scaled * d.asDiagonal();
  *singular_values = sv;
  return true;
}

bool FullRankByNormal(const Eigen::MatrixXd& jacobian, double tolerance) {
  const Eigen::VectorXd d = UnitColumnFactorsOf(jacobian);
  if ((d.array() == 0.0).any()) return false;
  const Eigen::LLT<Eigen::MatrixXd> llt(d.asDiagonal() * NormalMatrix(jacobian) * d.asDiagonal());
  return llt.info() == Eigen::Success && llt.rcond() > tolerance * tolerance;
}

std::vector<int> NonzeroColumns(const Eigen::MatrixXd& j) {
  std::vector<int> out;
  for (Eigen::Index c = 0; c < j.cols(); ++c) {
    if (!j.col(c).isZero(0.0)) out.push_back(static_cast<int>(c));
  }
  return out;
}

Eigen::MatrixXd ColumnsOf(const Eigen::MatrixXd& j, const std::vector<int>& columns) {
  Eigen::MatrixXd out(j.rows(), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k) out.col(static_cast<Eigen::Index>(k)) = j.col(columns[k]);
  return out;
}

bool ScaledCovariance(const Eigen::MatrixXd& jacobian, double sigma_hat, double rank_tolerance,
                      Eigen::VectorXd* singular_values, Eigen::MatrixXd* covariance) {
  const Eigen::VectorXd d = UnitColumnFactorsOf(jacobian);
  if (jacobian.cols() > kDenseParameterLimit) {
    return ScaledCovarianceOfNormal(NormalMatrix(jacobian), sigma_hat, rank_tolerance, singular_values, covariance);
  }
  const Eigen::MatrixXd scaled = jacobian * d.asDiagonal();
  // The SVD of J's R factor (unpivoted, blocked Householder QR): the columns are scaled to unit length already,
  // and the blocked QR of a tall Jacobian costs a third of the column-pivoting one.
  const Eigen::JacobiSVD<Eigen::MatrixXd, Eigen::HouseholderQRPreconditioner> svd(scaled, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  if (PivotRank(sv, rank_tolerance) < jacobian.cols()) return false;
  const Eigen::MatrixXd v_scaled = svd.matrixV() * sv.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd inverse_scaled = v_scaled * v_scaled.transpose();
  *covariance = sigma_hat * sigma_hat * d.asDiagonal() * inverse_scaled * d.asDiagonal();
  *singular_values = sv;
  return true;
}

}  // namespace robocal::identification_detail
