// Observability of a set of measurement configurations: the scaled, reduced identification matrix E*, its
// singular values and the indices built from them, evaluated incrementally when one configuration changes.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/column_scaling.h"
#include "robocal/core/error_model.h"
#include "robocal/core/reflectors.h"
#include "robocal/core/robot_model.h"

namespace robocal {

/// The observability indices (the first is the paper's objective).
enum class ObservabilityIndex {
  kConditionNumber,  ///< sigma_1 / sigma_L (paper eq. 9), minimised.
  kO1,               ///< (prod sigma_i)^(1/L) / sqrt(M) (Borm & Menq), maximised.
  kO2,               ///< sigma_L / sigma_1 (Driels & Pathre), maximised.
  kO3,               ///< sigma_L (minimum singular value), maximised.
  kO4,               ///< sigma_L^2 / sigma_1 (noise amplification, Nahvi & Hollerbach), maximised.
  kO5,               ///< 1 / sum(1 / sigma_i) (Sun & Hollerbach), maximised.
  kLogDet,           ///< log det(E*' E*) (D-optimality), maximised.
  /// RMS predicted pose error over fixed validation configurations (I-optimality; ObservabilityIndices::
  /// predicted_error_mm), minimised. Needs the evaluator's validation sample (SetValidation).
  kPredictedError,
};

/// "condition_number", "o1" .. "o5", "log_det", "predicted_error".
const char* ToString(ObservabilityIndex index);
bool ParseObservabilityIndex(const std::string& text, ObservabilityIndex* index);

struct ObservabilityOptions {
  MeasurementType measurement_type = MeasurementType::kPose;
  MeasurementNoise noise;
  /// Where the tracker stands, in the model's world frame (a cell's tracker). With noise.tracker, each
  /// configuration's rows are whitened by the tracker model at its tool point's distance and direction from
  /// here (MeasurementNoise::Whitening); unset, by the model's isotropic equivalent (RowWeights).
  std::optional<Eigen::Vector3d> tracker_position_mm;
  ColumnScaling scaling = ColumnScaling::kColumnNorm;
  /// Expected size of the geometric errors, used by kExpectedDeviation (and nothing else).
  double expected_translation_mm = 0.1;
  double expected_rotation_rad = 1e-3;
  /// predicted_error only, and only for measurement types that observe orientation: orientation errors count as
  /// the position error they cause this far from the tool point (mm per rad), the h of E_tot = E_xyz + h E_cos
  /// in accuracy.h (30 mm there too).
  double orientation_length_mm = 30.0;
  /// predicted_error only: the robot's model error (mm, 1-sigma RMS of the tool position error the geometric model
  /// does not explain, IdentificationSummary::model_error_mm of an earlier fit), added in quadrature: predicted
  /// error^2 = the parameter part + model_error_mm^2 (the total of prediction.h's unmodelled variance over the
  /// three axes). More poses shrink only the parameter part, so the prediction flattens at the model error. 0:
  /// tracker noise only. Finite, >= 0. It does not change which set is best, only the value reported.
  double model_error_mm = 0.0;
  /// Reflector nests on the tool (position measurements only; reflectors.h): every configuration gives 3 rows
  /// per reflector, at its point (whitened there with a tracker model), and `parameters` index the fit's space:
  /// the model's error parameters, then 3 offset errors per reflector (a fixed reflector's have no effect).
  /// Empty: the tool point.
  std::vector<Reflector> reflectors;
  /// The parameters kept in E* (indices into the model's error parameters, and the reflectors' offsets after
  /// them), normally FindIdentifiableParameters(...).identifiable. Must be non-empty, ascending, in range.
  std::vector<int> parameters;

  /// Rows of E* per configuration: MeasurementRows(measurement_type), or 3 per reflector.
  int RowsPerConfiguration() const;

  bool IsValid(const RobotModel& model, std::string* error) const;
  /// DescribeScaling of these options, e.g. "rows / noise (0.015 mm, 0.0001 rad); columns: column_norm".
  std::string ScalingDescription() const;
};

/// All indices of one configuration set.
struct ObservabilityIndices {
  int num_configurations = 0;
  int num_parameters = 0;
  /// Singular values of the scaled E*, descending (size num_parameters).
  Eigen::VectorXd singular_values;
  double condition_number = 0.0;
  double o1 = 0.0, o2 = 0.0, o3 = 0.0, o4 = 0.0, o5 = 0.0;
  double log_det = 0.0;
  /// The predicted_error index (mm): with C = (E*' W E*)^-1 the parameter covariance of the set (rows weighted by
  /// the noise, so C is in parameter units for that noise) and J_v the tool's pose Jacobian at validation
  /// configuration v (reduced to the parameters), sqrt(mean_v [trace(J_pos C J_pos') + h^2 trace(J_rot C J_rot')]
  /// + model_error_mm^2) (ObservabilityOptions::model_error_mm),
  /// h = orientation_length_mm for types that observe orientation and 0 for kPosition. +inf for a set that does
  /// not determine every parameter; NaN when no validation sample was given (ComputeIndicesBySvd,
  /// IndicesFromSingularValues, an evaluator without SetValidation).
  double predicted_error_mm = std::numeric_limits<double>::quiet_NaN();
  /// Which scaling produced these numbers.
  std::string scaling;

  double Get(ObservabilityIndex index) const;
};

/// The value an optimiser minimises for `index`: the condition number or the predicted error itself, or minus a
/// maximised index.
double ObjectiveValue(const ObservabilityIndices& indices, ObservabilityIndex index);

/// The indices from singular values (any order; sorted descending in the result) of a set of
/// `num_configurations` configurations. A zero singular value gives cond = inf, O1 = O3 = O4 = O5 = 0 and
/// log det = -inf.
ObservabilityIndices IndicesFromSingularValues(const Eigen::VectorXd& singular_values, int num_configurations,
                                               const std::string& scaling);

/// Indices from the stacked matrix by a full SVD of the scaled E* (the reference computation; O(M) memory).
ObservabilityIndices ComputeIndicesBySvd(const RobotModel& model, const std::vector<Eigen::VectorXd>& configurations,
                                         const ObservabilityOptions& options);

/// The numerical rank of E* for `configurations` by the library's one rank cut, whatever options.scaling says:
/// columns to unit norm (UnitColumnFactors), singular values by SVD of the stack (not the normal matrix, whose
/// squared condition number would hide the cut), PivotRank at kRankTolerance. options.parameters.size() when
/// the set determines every parameter; 0 for no configurations.
int NumericalRank(const RobotModel& model, const std::vector<Eigen::VectorXd>& configurations,
                  const ObservabilityOptions& options);

/// Keeps A = E*' W E* (unscaled, L x L) of a configuration set and each configuration's contribution, so that
/// changing one configuration costs one Jacobian, a rank-r update of A and an L x L symmetric eigenproblem,
/// whatever the number of configurations M.
///
/// Holds its own copy of the (immutable) model. Numerically it works on the normal matrix: the indices agree
/// with the SVD of E* to ~1e-16 cond(E*)^2 relative, ample for the cond < 1e6 of any useful plan.
class ObservabilityEvaluator {
 public:
  /// Throws std::invalid_argument if options are invalid for the model.
  ObservabilityEvaluator(const RobotModel& model, ObservabilityOptions options);

  /// Replaces the whole set (each q within sizes; limits are the caller's business). Recomputes A.
  void SetConfigurations(const std::vector<Eigen::VectorXd>& configurations);
  const std::vector<Eigen::VectorXd>& configurations() const { return configurations_; }
  int size() const { return static_cast<int>(configurations_.size()); }

  /// Indices of the current set.
  const ObservabilityIndices& indices() const { return indices_; }

  /// Indices if configuration m were replaced by q; the set is unchanged.
  ObservabilityIndices EvaluateReplacement(int m, const Eigen::VectorXd& q);
  /// Replaces configuration m by q.
  void Replace(int m, const Eigen::VectorXd& q);
  /// Appends q to the set.
  void Add(const Eigen::VectorXd& q);
  /// Removes configuration m (the last one takes its place).
  void Remove(int m);

  /// The weighted, reduced Jacobian block of one configuration (rows x L) and its contribution B'B.
  Eigen::MatrixXd Block(const Eigen::VectorXd& q);
  /// Indices of an arbitrary normal matrix standing for `num_configurations` configurations.
  ObservabilityIndices IndicesOf(const Eigen::MatrixXd& normal, int num_configurations) const;

  /// Fixes the validation configurations of the predicted_error index: from now on every set's indices carry
  /// predicted_error_mm. Computes their pose Jacobians once, summed into G = sum_v J_pos'J_pos + h^2 J_rot'J_rot
  /// (L x L), so that the mean predicted variance is trace(C G) / V and an evaluation costs an L x L LDLT and
  /// solve on top of the eigenproblem, whatever V. Recomputes the current set's indices. Empty: no predicted
  /// error (NaN).
  void SetValidation(const std::vector<Eigen::VectorXd>& validation);
  int num_validation() const { return num_validation_; }
  /// G of SetValidation (L x L, unweighted: mm^2 per squared parameter unit).
  const Eigen::MatrixXd& validation_information() const { return validation_information_; }
  /// The predicted_error index of a normal matrix A = E*' W E* (as ObservabilityIndices::predicted_error_mm):
  /// sqrt(trace(A^-1 G) / V + model_error_mm^2), with A^-1 from an LDLT of the unit-column-scaled A (C does not depend
  /// on the scaling; the unit columns keep the factorisation accurate). +inf when the LDLT fails or its smallest pivot
  /// is at most 1e-12 of its largest: the normal matrix resolves no finer (cond(E*) ~1e6), and such a set
  /// predicts errors ~10^6 times the noise. NaN without a validation sample.
  double PredictedError(const Eigen::MatrixXd& normal) const;

  /// The tool's pose Jacobian at q (6 x L: position rows mm, orientation rows rad; unweighted, reduced to the
  /// parameters), the validation Jacobian of PredictAccuracy and predicted_error.
  Eigen::MatrixXd PoseJacobian(const Eigen::VectorXd& q);

  const Eigen::MatrixXd& normal() const { return normal_; }
  const ObservabilityOptions& options() const { return options_; }
  const RobotModel& model() const { return model_; }

 private:
  void Refresh();

  RobotModel model_;
  ObservabilityOptions options_;
  KinematicsWorkspace ws_;
  Eigen::MatrixXd full_jacobian_;
  Eigen::VectorXd row_weights_;
  std::vector<Eigen::Vector3d> reflectors_in_tool_;
  Eigen::MatrixXd ReflectorBlock(const Eigen::VectorXd& q);
  std::vector<Eigen::VectorXd> configurations_;
  std::vector<Eigen::MatrixXd> contributions_;  // B'B per configuration
  Eigen::MatrixXd normal_;
  ObservabilityIndices indices_;
  int updates_since_refresh_ = 0;
  Eigen::MatrixXd pose_jacobian_;
  Eigen::MatrixXd validation_information_;
  int num_validation_ = 0;
};

/// What a plan buys before anything is measured: propagating the tracker noise through the identification,
/// with parameter covariance C = (E*' W E*)^-1, to the pose error at validation configurations.
struct PredictedAccuracy {
  int num_validation = 0;
  /// sqrt(mean over validation configurations of trace(J_pos C J_pos')), mm.
  double rms_position_mm = 0.0;
  /// Largest per-configuration RMS position error, mm.
  double max_position_mm = 0.0;
  /// Same for the tool orientation (rad); only when the measurement type observes orientation.
  bool has_orientation = false;
  double rms_orientation_rad = 0.0;
  /// The predicted_error index of the plan at these validation configurations (mm): position and, when the type
  /// observes orientation, orientation weighted by options.orientation_length_mm; the quantity a plan with
  /// predicted_error as objective minimises.
  double rms_error_mm = 0.0;
};

/// Predicted accuracy after calibrating from `plan` (noise-only: unmodelled errors are not included).
/// Returns num_validation = 0 and zeros if the plan does not determine every parameter (NumericalRank below
/// the number of parameters).
PredictedAccuracy PredictAccuracy(const RobotModel& model, const ObservabilityOptions& options,
                                  const std::vector<Eigen::VectorXd>& plan,
                                  const std::vector<Eigen::VectorXd>& validation);

}  // namespace robocal
