// What a finished fit looks like from the inside, recomputed from a calibration and its measurements: each
// measurement's residual, and the fit's linearisation at the solution (singular values of the weighted,
// column-scaled Jacobian, covariance). A report's per-pose residuals are computed here with the fit's own
// weighting. (The tests recompute a fit's covariance from its problem at the solution: tests/unit/
// fit_linearization.h.)
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

/// Correlation coefficients rho_ij = C_ij / sqrt(C_ii C_jj) of a covariance (0 where a variance is 0).
Eigen::MatrixXd CorrelationOf(const Eigen::MatrixXd& covariance);

}  // namespace robocal
