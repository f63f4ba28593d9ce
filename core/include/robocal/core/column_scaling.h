// Column scaling of Jacobians and the numerical rank: the one definition that every condition number, rank
// decision and identifiability reduction in robocal uses, so that they agree on which columns count.
#pragma once

#include <Eigen/Dense>

namespace robocal {

/// A column whose norm is at most this fraction of the largest column norm has no effect: it is treated as a
/// zero column (scaling it to unit norm would only amplify round-off).
inline constexpr double kNoEffectColumn = 1e-12;

/// Factors d, one per column, such that the columns of J diag(d) have unit norm, from the column norms of J
/// (size n, non-negative). d_k = 0 for a column without effect (see kNoEffectColumn), which stays zero.
Eigen::VectorXd UnitColumnFactors(const Eigen::VectorXd& column_norms);
/// The same from the matrix J itself.
Eigen::VectorXd UnitColumnFactorsOf(const Eigen::MatrixXd& j);

/// The numerical rank read off the absolute diagonal of a column-pivoted QR (non-increasing): the number of
/// leading pivots larger than `tolerance` times the first. 0 for an empty or all-zero diagonal.
int PivotRank(const Eigen::VectorXd& abs_diagonal, double tolerance);

}  // namespace robocal
