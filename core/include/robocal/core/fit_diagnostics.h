// What a finished fit looks like from the inside, recomputed from a calibration and its measurements: each
// measurement's residual, and the fit's linearisation at the solution (singular values of the weighted,
// column-scaled Jacobian, covariance). A report's per-pose residuals are computed here with the fit's own
// weighting; LinearizeFit recomputes what Identify returns in Calibration::covariance and
// IdentificationSummary::singular_values (a check of both, and the figures of a calibration moved to other data).
// Defined in identification.cc, next to the least-squares problem whose rows they must share.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "robocal/core/identification.h"

namespace robocal {

/// One measurement's residual (measured - model) in the sizes a reader looks at.
struct MeasurementResidualNorms {
  /// |p_measured - p_model| (mm), at the shot's reflector point.
  double position_mm = 0.0;
  /// Orientation error (pose) or the exact angle between the tool axes (position_axis), rad; 0 for position.
  double orientation_rad = 0.0;
  /// Norm of the whitened residual rows (noise sigmas; MeasurementNoise::Whitening at the measured point).
  double weighted = 0.0;
};

/// The residual of every measurement, in input order, of (model, errors) against `measurements` of `type`;
/// with reflectors `reflectors_in_tool` (ReflectorsInTool) gives each Measurement::reflector's point.
/// ComputeResidualStatistics is the summary of exactly these values.
std::vector<MeasurementResidualNorms> ComputeMeasurementResiduals(
    const RobotModel& model, const Eigen::VectorXd& errors, const std::vector<Measurement>& measurements,
    MeasurementType type, const MeasurementNoise& noise, const std::vector<Eigen::Vector3d>& reflectors_in_tool = {});

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

/// Correlation coefficients rho_ij = C_ij / sqrt(C_ii C_jj) of a covariance (0 where a variance is 0).
Eigen::MatrixXd CorrelationOf(const Eigen::MatrixXd& covariance);

}  // namespace robocal
