// Identifiability: which error parameters the measurements can tell apart, and which are dropped and why.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/column_scaling.h"
#include "robocal/core/error_model.h"
#include "robocal/core/reflectors.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"

namespace robocal {

struct IdentifiabilityOptions {
  /// Random configurations (uniform within joint limits) stacked to probe the parameter space. Must give at
  /// least as many rows as parameters; more makes the rank decision safer. Default 100.
  int num_configurations = 100;
  /// Seed of the configuration draw.
  std::uint64_t seed = 1;
  /// Row weighting: each row divided by its 1-sigma noise (position mm, orientation rad).
  MeasurementNoise noise;
  /// Several reflectors on the tool (position measurements only): every probe configuration measures each of
  /// them, and the parameters are the model's followed by 3 offset errors per reflector (reflectors.h's index
  /// space); a fixed reflector's are dropped ("held at its given position"). Empty: the tool point.
  std::vector<Reflector> reflectors;
  /// A parameter is kept while |R_kk| > rank_tolerance * |R_00| in the column-pivoted QR of the
  /// row-weighted, unit-column-norm Jacobian. Columns are unit norm, so the test is scale free.
  double rank_tolerance = kRankTolerance;
  /// The rank decision is called clear when the smallest kept |R_kk| exceeds the largest dropped one by this
  /// factor; otherwise the result is DEGRADED.
  double min_rank_gap = 1e3;

  /// False (and a reason in *error) if an option is out of range.
  bool IsValid(std::string* error) const;
};

/// A parameter that was dropped and why.
struct DroppedParameter {
  int index = -1;
  std::string name;
  /// E.g. "no effect on position measurements" or "indistinguishable from +1.000 joint1.rz".
  std::string reason = {};
  /// The kept parameter it is indistinguishable from (one parameter, any coefficient), which absorbs its error
  /// in the fit; -1 when none is (no effect, or a combination of several).
  int alias = -1;
};

struct IdentifiabilitySummary {
  Termination termination = Termination::kFailure;
  std::string message = "not run";
  MeasurementType measurement_type = MeasurementType::kPose;
  int num_parameters = 0;
  int num_configurations = 0;
  /// Indices of the kept (identifiable) parameters, ascending; their names.
  std::vector<int> identifiable;
  std::vector<std::string> identifiable_names;
  std::vector<DroppedParameter> dropped;
  /// |R_kk| of the pivoted QR (relative to |R_00|) at the last kept and the first dropped pivot.
  double smallest_kept_pivot = 0.0;
  double largest_dropped_pivot = 0.0;
  /// Condition number of the kept columns (row-weighted, unit column norm) over the probe configurations.
  double condition_number = 0.0;
  /// Which scaling produced condition_number (DescribeScaling of options.noise, ColumnScaling::kColumnNorm).
  std::string scaling;

  std::string BriefReport() const;
  std::string FullReport() const;
};

/// Finds the identifiable subset of `model`'s error parameters for measurements of `type`.
///
/// Stacks the identification Jacobian (at eps = 0) over random configurations, weights rows by the noise,
/// scales columns to unit norm, and runs a column-pivoted QR: pivots are real named parameters (not
/// combinations), so the result reads as "joint3.dz is identified". Each dropped parameter is explained by a
/// least-squares fit of its column onto the kept ones.
IdentifiabilitySummary FindIdentifiableParameters(const RobotModel& model, MeasurementType type,
                                                  const IdentifiabilityOptions& options = {});

}  // namespace robocal
