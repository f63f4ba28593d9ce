// Column scaling of Jacobians and the numerical rank: the one definition that every condition number, rank
// decision and identifiability reduction in robocal uses, so that they agree on which columns count; and the
// one text that says how a reported condition number was scaled.
#pragma once

#include <string>

#include <Eigen/Dense>

#include "robocal/core/error_model.h"

namespace robocal {

/// How the columns of a row-weighted Jacobian (E*) are scaled before its singular values are taken. Rows are
/// always divided by the measurement noise (MeasurementNoise), so a row is in units of "noise sigmas".
enum class ColumnScaling {
  /// Each column divided by its norm over the configuration set (Hollerbach & Wampler's scaling): the index
  /// then does not depend on the parameters' units. Identifiability and identification always use this one.
  kColumnNorm,
  /// Each column multiplied by the parameter's expected deviation (expected_translation_mm,
  /// expected_rotation_rad): E* then maps "typical error sizes" to noise sigmas.
  kExpectedDeviation,
  /// No column scaling: mixes mm and rad, reported for completeness.
  kNone,
};

/// "column_norm", "expected_deviation", "none".
const char* ToString(ColumnScaling scaling);
bool ParseColumnScaling(const std::string& text, ColumnScaling* scaling);

/// The text every Summary reports next to a condition number to say how it was scaled, e.g.
/// "rows / noise (0.015 mm, 0.0001 rad); columns: column_norm"; for kExpectedDeviation the expected sizes
/// follow, "columns: expected_deviation (0.1 mm, 0.001 rad)" (the two sizes are used by that scaling only).
std::string DescribeScaling(const MeasurementNoise& noise, ColumnScaling columns = ColumnScaling::kColumnNorm,
                            double expected_translation_mm = 0.0, double expected_rotation_rad = 0.0);

/// A column whose norm is at most this fraction of the largest column norm has no effect: it is treated as a
/// zero column (scaling it to unit norm would only amplify round-off).
inline constexpr double kNoEffectColumn = 1e-12;

/// Factors d, one per column, such that the columns of J diag(d) have unit norm, from the column norms of J
/// (size n, non-negative). d_k = 0 for a column without effect (see kNoEffectColumn), which stays zero.
Eigen::VectorXd UnitColumnFactors(const Eigen::VectorXd& column_norms);
/// The same from the matrix J itself.
Eigen::VectorXd UnitColumnFactorsOf(const Eigen::MatrixXd& j);

/// The rank cut: of a row-weighted Jacobian with unit columns, a pivot or singular value at most this fraction
/// of the largest counts as zero (the default of IdentifiabilityOptions::rank_tolerance, which identification
/// also uses, and the cut of NumericalRank in observability.h).
inline constexpr double kRankTolerance = 1e-8;

/// The numerical rank read off a non-increasing sequence of non-negative values, the absolute diagonal of a
/// column-pivoted QR or the singular values: the number of leading values larger than `tolerance` times the
/// first. 0 for an empty or all-zero sequence.
int PivotRank(const Eigen::VectorXd& abs_diagonal, double tolerance);

}  // namespace robocal
