// Column scaling, numerical rank, and the description of a scaling.
#include "robocal/core/column_scaling.h"

#include <sstream>

namespace robocal {

const char* ToString(ColumnScaling scaling) {
  switch (scaling) {
    case ColumnScaling::kColumnNorm:
      return "column_norm";
    case ColumnScaling::kExpectedDeviation:
      return "expected_deviation";
    case ColumnScaling::kNone:
      return "none";
  }
  return "?";
}

bool ParseColumnScaling(const std::string& text, ColumnScaling* scaling) {
  for (ColumnScaling s : {ColumnScaling::kColumnNorm, ColumnScaling::kExpectedDeviation, ColumnScaling::kNone}) {
    if (text == ToString(s)) {
      *scaling = s;
      return true;
    }
  }
  return false;
}

std::string DescribeScaling(const MeasurementNoise& noise, ColumnScaling columns, double expected_translation_mm,
                            double expected_rotation_rad) {
  // The stream's shortest form (0.015, not std::to_string's 0.015000).
  std::ostringstream out;
  if (noise.tracker) {
    const TrackerUncertainty& t = *noise.tracker;
    out << "rows whitened by the tracker model (radial " << t.radial_um << " um + " << t.radial_um_per_m
        << " um/m, transverse " << t.transverse_um << " um + " << t.transverse_um_per_m << " um/m, orientation "
        << t.orientation_deg << " deg, MPE = " << t.mpe_sigmas << " sigma); columns: " << ToString(columns);
  } else {
    out << "rows / noise (" << noise.position_mm << " mm, " << noise.orientation_rad
        << " rad); columns: " << ToString(columns);
  }
  if (columns == ColumnScaling::kExpectedDeviation) {
    out << " (" << expected_translation_mm << " mm, " << expected_rotation_rad << " rad)";
  }
  return out.str();
}

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
