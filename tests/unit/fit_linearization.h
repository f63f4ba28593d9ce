// The fit's linearisation at a finished calibration, recomputed from the least-squares problem the fit solved
// (core/src/identification_internal.h): a white-box check that Identify's covariance, singular values and
// condition number are those of its solution (fit_diagnostics_test.cc). Only the tests use it.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "robocal/core/identification.h"

namespace robocal {

/// The fit's linearisation at its solution.
struct FitLinearization {
  /// The estimated parameters (IdentificationOptions::parameters' index space), the order of everything below.
  std::vector<int> parameters;
  /// Singular values of the weighted Jacobian with unit-norm columns (ColumnScaling::kColumnNorm), descending.
  Eigen::VectorXd singular_values;
  /// singular_values' first over last (IdentificationSummary::condition_number).
  double condition_number = 0.0;
  /// sqrt(|r_weighted|^2 / (rows - parameters)) (IdentificationSummary::sigma_hat).
  double sigma_hat = 0.0;
  /// sigma_hat^2 (J'J)^-1 of the weighted J (mm and rad; Calibration::covariance).
  Eigen::MatrixXd covariance;
};

/// Recomputes Identify's covariance, singular values and condition number at a finished calibration:
/// `calibration` as Identify returned it or as a stored one is restored (its model with the registered base,
/// its errors, its reflectors at their identified positions); `measurements` the ones the fit used (the
/// calibration measurements less the robust fit's outliers); `options` the fit's, with the reflectors at their
/// GIVEN positions and `parameters` the estimated set (ascending, non-empty); its noise is weighted with the
/// model error the calibration's summary estimated (FittedNoise). For the same inputs the results
/// equal Identify's to round-off. Throws std::invalid_argument for empty parameters, sizes that do not match,
/// too few rows, or a rank-deficient Jacobian (no covariance exists then).
FitLinearization LinearizeFit(const Calibration& calibration, const std::vector<Measurement>& measurements,
                              const IdentificationOptions& options);

}  // namespace robocal
