// The model of a calibration chosen by k-fold cross-validation: geometric only, or with joint compliance and
// joint harmonics (joint_errors.h), whichever predicts held-out measurements best for its simplicity.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "robocal/core/identification.h"
#include "robocal/core/measurement.h"
#include "robocal/core/priors.h"
#include "robocal/core/robot_model.h"

namespace robocal {

/// The knot spacings a model choice with maps tries: 8, 4 and 2 degrees.
inline const std::vector<double> kMapKnotSpacingsRad = {8.0 * 3.14159265358979323846 / 180.0,
                                                        4.0 * 3.14159265358979323846 / 180.0,
                                                        2.0 * 3.14159265358979323846 / 180.0};

struct ModelChoiceOptions {
  /// Folds of the cross-validation (2..20). The calibration set's distinct poses (a configuration under a
  /// payload, with all its shots and reflectors) are shuffled with `seed` and dealt to the folds in turn.
  int folds = 5;
  std::uint64_t seed = 1;
  /// The candidates: the geometric model, with compliance (robots with masses only), with joint harmonics of
  /// order 1 .. max_joint_harmonics, and compliance with each harmonic order.
  int max_joint_harmonics = kMaxJointHarmonics;
  /// Then joint error maps on every revolute joint (with compliance for a robot with masses), one candidate per
  /// knot spacing here (rad; coarsest first), each with `map_smoothness`. Empty (the default): no maps; the
  /// service's "cross_validation": {"joint_maps": true} asks for kMapKnotSpacingsRad.
  std::vector<double> map_knot_spacings_rad;
  double map_smoothness = 0.01;

  bool IsValid(std::string* error) const;
};

/// A model by name: "auto" (*automatic true), "geometric", or a comma list of "compliance" and "harmonics=N"
/// (e.g. "compliance,harmonics=2"); false (and the reason in *error) for anything else. The CLI's and the
/// experiment's --model.
bool ParseModelName(const std::string& text, JointErrorTerms* terms, bool* automatic, std::string* error);

/// The candidates of `nominal` for these options, simplest first (fewest parameters).
std::vector<JointErrorTerms> ModelCandidates(const RobotModel& nominal, const ModelChoiceOptions& options);

struct ModelChoice {
  std::vector<ModelCandidate> candidates;  // simplest first
  /// The candidate with the lowest cross-validated mean error, and the chosen one: the simplest candidate whose
  /// mean is within one standard error of the best's (the one-standard-error rule, Hastie, Tibshirani & Friedman,
  /// The Elements of Statistical Learning, 2009, section 7.10). -1 when none could be evaluated.
  int best = -1;
  int chosen = -1;
  int folds = 0;
  /// Why the choice is what it is, or why there is none.
  std::string message;
  /// The options' progress callback asked to stop.
  bool cancelled = false;
};

/// Fits every candidate model on all folds but one and measures its position error on the fold left out, in
/// turn. Each fit uses `options` (noise, outliers, model error; `options.parameters` must be empty, since the
/// parameters differ between models; options.progress sees the fraction of all fits, the final fit on every pose
/// of IdentifyWithModelChoice counted). Throws
/// std::invalid_argument for invalid options or a nominal model that already has joint terms.
ModelChoice ChooseModel(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                        const IdentificationOptions& options, const ModelChoiceOptions& choice = {});

/// ChooseModel, then Identify with the chosen model on every measurement; the calibration's summary holds the
/// comparison (model_candidates, model_folds, model_chosen). With no candidate evaluated the fit is FAILURE
/// and says why.
Calibration IdentifyWithModelChoice(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                                    const IdentificationOptions& options, const ModelChoiceOptions& choice = {});

/// priors: auto (docs/identification.md, "Parameter priors"): the scale of a set of priors chosen by k-fold
/// cross-validation, as the model is.
struct PriorChoiceOptions {
  /// Folds (2..20) and the seed of their shuffle, as ModelChoiceOptions' (the same seed deals the same folds).
  int folds = 5;
  std::uint64_t seed = 1;
  /// The priors whose scale is chosen: the defaults (ParameterPriors{}) unless given.
  ParameterPriors priors;
  /// The candidate scales of `priors` (multiplying priors.scale), each > 0; +infinity is the fit without priors.
  /// Tried and reported in descending order (the fit without priors first, the narrowest prior last).
  std::vector<double> scales = {0.25, 0.5, 1.0, 2.0, 4.0, std::numeric_limits<double>::infinity()};

  bool IsValid(std::string* error) const;
};

struct PriorChoice {
  /// Every scale's held-out error, the fit without priors first (descending scale).
  std::vector<PriorScaleCandidate> candidates;
  /// The candidate with the lowest cross-validated mean error, which is the one chosen: the scale is a continuous
  /// weight of one prior rather than a choice among nested models, and the one-standard-error rule's preference for
  /// the fit without priors gave up most of the gain on the IPA UR10 (docs/identification.md, "Parameter priors").
  /// -1 when none could be evaluated.
  int best = -1;
  int chosen = -1;
  int folds = 0;
  std::string message;
  bool cancelled = false;
};

/// Fits `nominal` with each candidate scale of the priors on all folds but one and measures the position error on
/// the fold left out, in turn (the folds of ChooseModel). Each fit uses `options` with its priors replaced by the
/// candidate's (options.priors is not read); options.progress sees the fraction of all fits, the final fit of
/// IdentifyWithPriorChoice counted. Throws std::invalid_argument for invalid options or a prior naming no
/// parameter.
PriorChoice ChoosePriorScale(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                             const IdentificationOptions& options, const PriorChoiceOptions& choice = {});

/// ChoosePriorScale, then Identify with the chosen priors on every measurement; the summary holds the comparison
/// (prior_candidates, prior_folds, prior_chosen). With no candidate evaluated it fits without priors, DEGRADED,
/// and says why.
Calibration IdentifyWithPriorChoice(const RobotModel& nominal, const std::vector<Measurement>& measurements,
                                    const IdentificationOptions& options, const PriorChoiceOptions& choice = {});

}  // namespace robocal
