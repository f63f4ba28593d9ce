// Column scaling and numerical rank.
#include "robocal/core/column_scaling.h"

namespace robocal {

Eigen::VectorXd UnitColumnFactors(const Eigen::VectorXd& column_norms) {
  const double largest = column_norms.size() > 0 ? column_norms.maxCoeff() : 0.0;
  Eigen::VectorXd d = Eigen::VectorXd::Zero(column_norms.size());
  for (Eigen::Index k = 0; k < column_norms.size(); ++k) {
    if (column_norms[k] > kNoEffectColumn * largest && column_norms[k] > 0.0) d[k] = 1.0 / column_norms[k];
  }
  return d;
}

Eigen::VectorXd UnitColumnFactorsOf(const Eigen::MatrixXd& j) {
  return UnitColumnFactors(Eigen::VectorXd(j.colwise().norm().transpose()));
}

int PivotRank(const Eigen::VectorXd& abs_diagonal, double tolerance) {
  if (abs_diagonal.size() == 0 || !(abs_diagonal[0] > 0.0)) return 0;
  int rank = 0;
  while (rank < abs_diagonal.size() && abs_diagonal[rank] > tolerance * abs_diagonal[0]) ++rank;
  return rank;
}

}  // namespace robocal
