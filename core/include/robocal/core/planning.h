// Choosing measurement configurations: Solis & Wets random search (the paper), random selection (the paper's
// baseline) and an exchange optimiser over a candidate pool (a stronger baseline).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/observability.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"

namespace robocal {

/// Called after every iteration with the fraction done (0..1); return false to cancel the optimisation (it
/// then stops with NO_CONVERGENCE and the best set so far).
using PlanProgressCallback = std::function<bool(double fraction_done)>;

/// How a candidate that leaves the joint limits is brought back.
enum class LimitHandling {
  /// Mirror at the violated bound (repeatedly, so any step lands inside): keeps the step's randomness.
  kReflect,
  /// Clamp to the bound: piles candidates up on the limits.
  kClamp,
};

const char* ToString(LimitHandling handling);

/// Solis & Wets (1981) random search over the concatenated joint vector of all M configurations, as given in
/// Wang & Zhang (2007), section 3. Defaults are the paper's constants (preset `Paper()`).
struct SolisWetsOptions {
  /// Iterations k = 1..k_max (paper: 100). Each iteration costs one or two objective evaluations.
  int k_max = 100;
  /// Expand sigma when more than `scent_threshold` consecutive successes (paper: Scent = 5).
  int scent_threshold = 5;
  /// Contract sigma when more than `fcent_threshold` consecutive failures (paper: Fcent = 3).
  int fcent_threshold = 3;
  /// Initial step sigma_0 (paper: 1), and the bounds: if sigma < sigma_lb it is reset to sigma_ub (paper: 0.1, 3).
  double sigma0 = 1.0;
  double sigma_ub = 3.0;
  double sigma_lb = 0.1;
  /// Expansion and contraction factors (paper: ex = 2, ct = 0.5).
  double expansion = 2.0;
  double contraction = 0.5;
  /// The paper leaves sigma's unit open (joint values mix mm and rad). robocal searches in normalised joint
  /// coordinates: one unit of sigma is `step_fraction` of each joint's range (default 0.1, so sigma_0 = 1 is
  /// a 10 % step and the paper's [0.1, 3] spans 1 % .. 30 %).
  double step_fraction = 0.1;
  /// The paper does not say whether scent / fcent restart after they change sigma. robocal resets the
  /// counter that triggered (as in Solis & Wets' original algorithm), so sigma changes at most once per run of
  /// Scent successes or Fcent failures; false keeps counting (sigma then changes every further iteration).
  bool reset_counters = true;
  LimitHandling limits = LimitHandling::kReflect;
  /// Independent restarts from new random starting sets after the first run (0 = the paper); best kept.
  int restarts = 0;
  /// Stop after this many objective evaluations in all (0 = no limit beyond k_max and restarts).
  int max_evaluations = 0;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  std::uint64_t seed = 1;
  PlanProgressCallback progress;

  /// The paper's settings: k_max 100, Scent 5, Fcent 3, sigma_0 1, sigma_ub 3, sigma_lb 0.1, ex 2, ct 0.5,
  /// mu_0 0, objective the condition number.
  static SolisWetsOptions Paper();
  bool IsValid(std::string* error) const;
};

/// Random selection: the best of `num_sets` sets of M configurations drawn uniformly within the limits
/// (num_sets = 1 is the paper's random baseline).
struct RandomSelectionOptions {
  int num_sets = 1;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  std::uint64_t seed = 1;
  PlanProgressCallback progress;
  bool IsValid(std::string* error) const;
};

/// Exchange (DETMAX-style, Mitchell 1974): from a seeded random candidate pool, start with M random
/// candidates; each iteration adds the candidate that most improves the objective (screened by the
/// D-optimal gain det(I + B A^-1 B'), the top `screen` then evaluated exactly) and removes the configuration
/// whose removal leaves the best objective; stops when an exchange no longer improves it.
struct ExchangeOptions {
  int num_candidates = 2000;
  /// Candidates per addition evaluated exactly after D-optimal screening.
  int screen = 16;
  int max_iterations = 500;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  std::uint64_t seed = 1;
  PlanProgressCallback progress;
  bool IsValid(std::string* error) const;
};

struct PlanSummary {
  Termination termination = Termination::kFailure;
  std::string message = "not run";
  /// "solis_wets", "random" or "exchange".
  std::string method;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  int iterations = 0;
  int evaluations = 0;
  /// Objective value (ObjectiveValue: the index, negated if maximised) of the best set after each iteration.
  std::vector<double> objective_trace;
  double seconds = 0.0;
  /// Indices of the starting set and of the result.
  ObservabilityIndices initial;
  ObservabilityIndices final;

  std::string BriefReport() const;
  std::string FullReport() const;
};

struct Plan {
  /// M configurations, each within the model's joint limits (rad / mm per joint).
  std::vector<Eigen::VectorXd> configurations;
  PlanSummary summary;
};

/// Solis & Wets from `initial` (M configurations within limits) or, if empty, from a random set.
/// Throws std::invalid_argument for invalid options, M < 1 or a wrongly sized initial set.
Plan PlanSolisWets(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                   const SolisWetsOptions& options, const std::vector<Eigen::VectorXd>& initial = {});

Plan PlanRandom(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                const RandomSelectionOptions& options);

Plan PlanExchange(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                  const ExchangeOptions& options);

/// M configurations drawn uniformly within the joint limits.
std::vector<Eigen::VectorXd> RandomConfigurations(const RobotModel& model, int count, Rng* rng);

}  // namespace robocal
