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

// Levenberg-Marquardt, written here rather than taken from Eigen's unsupported module because (a) the
// Summary promises the Ceres-style tests of IdentificationOptions (relative cost change, max |J'r|, step
// relative to |x|), which MINPACK's ftol/xtol/gtol define differently (gtol there is a cosine), (b) shots of
// one pose share one Jacobian evaluation (Problem), and (c) the loop is 40 lines with Nielsen's damping update
// and Marquardt's diag(J'J) scaling, so it is scale invariant in mm and rad. Normal equations are safe here:
// they are formed from column-scaled J, whose condition number is checked before the loop (rank test).
LmResult LevenbergMarquardt(Problem* problem, const IdentificationOptions& o, const Eigen::VectorXd* start) {
  LmResult out;
  const int n = problem->num_parameters();
  out.x = start != nullptr && start->size() == n && start->allFinite() ? *start : Eigen::VectorXd::Zero(n);
  problem->Evaluate(out.x, &out.residual, &out.jacobian);
  double cost = 0.5 * out.residual.squaredNorm();
  double lambda = 1e-4;
  double nu = 2.0;
  Eigen::VectorXd candidate_residual;
  Eigen::MatrixXd candidate_jacobian;
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
Eigen::MatrixXd NormalMatrix(const Eigen::MatrixXd& jacobian) {
  const Eigen::Index n = jacobian.cols();
  if (n <= kDenseParameterLimit) return jacobian.transpose() * jacobian;
  // Written here rather than with Eigen's sparse product: the Jacobian is dense storage with mostly zero map
  // columns, and converting it costs as much as this sum. Rows are copied to row-major blocks for the scan; each
  // row adds the products of its non-zero entries.
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(n, n);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block;
  std::vector<Eigen::Index> index;
  std::vector<double> value;
  index.reserve(static_cast<std::size_t>(n));
  value.reserve(static_cast<std::size_t>(n));
  constexpr Eigen::Index kBlockRows = 64;
  for (Eigen::Index start = 0; start < jacobian.rows(); start += kBlockRows) {
    const Eigen::Index rows = std::min(kBlockRows, jacobian.rows() - start);
    block = jacobian.middleRows(start, rows);
    for (Eigen::Index r = 0; r < rows; ++r) {
      index.clear();
      value.clear();
      const double* row = block.data() + r * n;
      for (Eigen::Index c = 0; c < n; ++c) {
        if (row[c] == 0.0) continue;
        index.push_back(c);
        value.push_back(row[c]);
      }
      // The lower triangle: element (index[b], index[a]) for b >= a, column index[a] contiguous.
      for (std::size_t a = 0; a < index.size(); ++a) {
        double* column = normal.data() + index[a] * n;
        const double va = value[a];
        for (std::size_t b = a; b < index.size(); ++b) column[index[b]] += va * value[b];
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
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(scaled, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  if (PivotRank(sv, rank_tolerance) < jacobian.cols()) return false;
  const Eigen::MatrixXd v_scaled = svd.matrixV() * sv.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd inverse_scaled = v_scaled * v_scaled.transpose();
  *covariance = sigma_hat * sigma_hat * d.asDiagonal() * inverse_scaled * d.asDiagonal();
  *singular_values = sv;
  return true;
}

}  // namespace robocal::identification_detail
