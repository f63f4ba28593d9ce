// Choosing measurement configurations: Solis & Wets random search (the paper), random selection (the paper's
// baseline) and an exchange optimiser over a candidate pool (a stronger baseline); each either draws joint vectors
// itself or chooses from the cell's own candidate configurations (CandidatePool).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "robocal/core/observability.h"
#include "robocal/core/random.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"

namespace robocal {

/// Whether a configuration (rad / mm per joint, within the model's limits) can be measured and reached safely in
/// the cell, e.g. IsFeasible(model, cell, q) of cell.h. Empty: every configuration is feasible (the planners then
/// behave exactly as without one). Planners call it from their own thread, many times per plan: it must be cheap,
/// deterministic and must not throw.
using FeasibilityPredicate = std::function<bool(const Eigen::VectorXd& q)>;

/// The default of every planner's max_draws_per_configuration: a cell must leave about 1 % of the joint ranges
/// feasible for rejection sampling to find its configurations.
inline constexpr int kDefaultMaxDrawsPerConfiguration = 100;

/// The predicted_error objective's validation sample is drawn from Rng(seed + kPredictedErrorSeedOffset), apart
/// from the planner's own draws: planners given the same seed optimise the same sample.
inline constexpr std::uint64_t kPredictedErrorSeedOffset = 0x9A11DA7EULL;

/// The account of rejection sampling: configurations drawn uniformly within the limits, how many the predicate
/// rejected, and the most draws allowed.
struct FeasibleDraws {
  std::int64_t max_draws = std::numeric_limits<std::int64_t>::max();
  std::int64_t draws = 0;
  std::int64_t rejections = 0;
  /// "37 of 2000 random configurations within the joint limits were feasible".
  std::string Describe() const;
};

/// Draws uniformly within the model's limits (RandomConfiguration) until a configuration satisfies `feasible`
/// (the first draw when it is empty: then exactly RandomConfiguration), counting in *account. Returns false, with
/// *q unspecified, when account->draws has reached account->max_draws first.
bool DrawFeasibleConfiguration(const RobotModel& model, const FeasibilityPredicate& feasible, Rng* rng,
                               FeasibleDraws* account, Eigen::VectorXd* q);
/// Appends `count` such configurations to *out (with an empty predicate exactly RandomConfigurations). Returns
/// false when the draws ran out first; *out then holds the feasible ones found.
bool DrawFeasibleConfigurations(const RobotModel& model, int count, const FeasibilityPredicate& feasible, Rng* rng,
                                FeasibleDraws* account, std::vector<Eigen::VectorXd>* out);

/// What a planner does with a candidate it cannot use as given: the wrong number of joints, a value that is not
/// finite, or a value beyond the model's limits.
enum class MalformedCandidates {
  /// std::invalid_argument naming the first such candidate's index: the caller's list is wrong.
  kThrow,
  /// Counted as rejected with its reason, as an infeasible candidate is (a file of taught poses may hold a few).
  kReject,
};

/// At most this many indices of the candidates rejected for one reason are kept (the first ones).
inline constexpr int kRejectedIndicesKept = 5;

/// The candidates rejected for one reason.
struct CandidateRejections {
  /// "joint_count", "not_finite", "beyond_limits" (malformed); "infeasible" (the feasibility predicate), or the
  /// names CandidatePool::infeasibility_reasons gives instead (a cell's rules: "obstacle", "beam", ...).
  std::string reason;
  int count = 0;
  /// The first kRejectedIndicesKept indices (into the caller's list) rejected for it, ascending.
  std::vector<int> first_indices;
};

/// The check of a candidate pool: how many were given, how many the planner could choose from, and why the
/// others were not.
struct CandidateAccount {
  int num_candidates = 0;
  /// Well-formed, within the limits and feasible: the pool the planner chose from.
  int num_usable = 0;
  /// The malformed reasons first (joint_count, not_finite, beyond_limits; a candidate counts for the first it
  /// fails), then the feasibility reasons in order of first occurrence. A candidate the predicate rejects counts
  /// once for each reason infeasibility_reasons names (as a cell's census counts rules), so the counts may add up
  /// to more than num_candidates - num_usable.
  std::vector<CandidateRejections> rejected;
  /// "1994 of 2000 candidates usable; rejected: beyond_limits 2 (#3, #17), obstacle 4 (#8, #9, #40, #41)".
  std::string Describe() const;
};

/// The cell's own configurations (taught, measured before, or from a file) for a planner to choose from instead
/// of drawing joint vectors itself (docs/planning.md, "Plans from the cell's own configurations"). Every
/// candidate is checked first: joint count, finite values, the model's limits (give planners the robot's model,
/// not Cell::PlanningModel, if a candidate beyond the cell's joint ranges should count as the cell's
/// joint_range rule rather than as malformed), then the options' feasibility predicate. The plan's
/// configurations are then exactly candidates, and Plan::candidate_indices maps them back to this list.
struct CandidatePool {
  /// Joint vectors (rad / mm per joint). Null: the planner draws (every option below is then unused). Shared,
  /// not copied, by options that are copied around.
  std::shared_ptr<const std::vector<Eigen::VectorXd>> configurations;
  MalformedCandidates malformed = MalformedCandidates::kThrow;
  /// Names why the feasibility predicate rejected a candidate (CellRuleReasons of candidates.h for a cell: the
  /// rules CheckConfiguration finds). Called for rejected candidates only. Empty, or an empty answer: "infeasible".
  std::function<std::vector<std::string>(const Eigen::VectorXd& q)> infeasibility_reasons;

  bool given() const { return configurations != nullptr; }
};

/// The configurations a robot will work in, for the predicted_error objective (its validation sample): joint
/// vectors (rad / mm; finite, the model's joint count; the cell need not see them). Null: num_validation drawn.
using TaskConfigurations = std::shared_ptr<const std::vector<Eigen::VectorXd>>;

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
  /// Stop before the objective evaluations of all runs would exceed this many (0 = no limit beyond k_max and
  /// restarts); a restart is not begun without one evaluation left for its starting set.
  int max_evaluations = 0;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  std::uint64_t seed = 1;
  PlanProgressCallback progress;
  /// Feasibility in a cell (empty: everything). Starting sets are drawn from feasible configurations; a given
  /// initial set must be feasible. What a step does with configurations it would make infeasible: `cell_step`.
  FeasibilityPredicate feasible;
  /// How a step (forward or reversed) treats a candidate set in which some configurations are infeasible.
  /// kFeasibleConfigurations (the default): the configurations whose move stays feasible move, the others stay
  /// where they are; a candidate in which none moves is a failed step without an evaluation. kWholeSet: the
  /// candidate is not evaluated and counts as a failed step, as if its objective were +inf. In both, a failed
  /// forward step is followed by the reversed step, and when that fails too the iteration is a failure (mu
  /// halves, fcent counts it, scent restarts), so infeasibility contracts sigma and never expands it. In a cell
  /// that leaves a share p of the joint space feasible, a whole-set step of M configurations survives with
  /// probability about p^M: with M = 10 and p of a few percent, never (docs/planning.md, "Solis & Wets in a
  /// cell").
  enum class CellStep { kFeasibleConfigurations, kWholeSet };
  CellStep cell_step = CellStep::kFeasibleConfigurations;
  /// Rejection sampling stops, and the plan fails (FAILURE, no configurations), after this many draws per
  /// configuration the plan draws: (restarts + 1) x M starting configurations (M fewer with a given initial set),
  /// plus num_validation for predicted_error.
  int max_draws_per_configuration = kDefaultMaxDrawsPerConfiguration;
  /// Validation configurations of the predicted_error objective (drawn once, feasible, from
  /// Rng(seed + kPredictedErrorSeedOffset)); unused by the other objectives.
  int num_validation = 50;
  /// predicted_error over these configurations instead of num_validation drawn ones.
  TaskConfigurations task;
  /// Choose from these instead of searching the joint space: the search then runs over candidate indices (each
  /// moved configuration snaps to the nearest unused candidate, docs/planning.md); no initial set may be given.
  CandidatePool candidates;

  /// The paper's settings: k_max 100, Scent 5, Fcent 3, sigma_0 1, sigma_ub 3, sigma_lb 0.1, ex 2, ct 0.5,
  /// mu_0 0, objective the condition number.
  static SolisWetsOptions Paper();
  bool IsValid(std::string* error) const;
};

/// Random selection: the best of `num_sets` sets of M configurations drawn uniformly within the limits
/// (num_sets = 1 is the paper's random baseline); with a predicate, from the feasible configurations.
struct RandomSelectionOptions {
  int num_sets = 1;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  std::uint64_t seed = 1;
  PlanProgressCallback progress;
  /// Feasibility in a cell (empty: everything): every set is drawn from feasible configurations.
  FeasibilityPredicate feasible;
  /// Rejection sampling stops, and the plan fails, after this many draws per configuration the plan draws:
  /// num_sets x M, plus num_validation for predicted_error.
  int max_draws_per_configuration = kDefaultMaxDrawsPerConfiguration;
  /// Validation configurations of the predicted_error objective (as SolisWetsOptions::num_validation).
  int num_validation = 50;
  /// As SolisWetsOptions::task.
  TaskConfigurations task;
  /// Draw each set's M configurations from these (distinct candidates) instead of the joint space.
  CandidatePool candidates;
  bool IsValid(std::string* error) const;
};

/// Exchange (DETMAX-style, Mitchell 1974): from a seeded random candidate pool, start with M random
/// candidates; each iteration adds the candidate that most improves the objective (screened by the
/// D-optimal gain det(I + B A^-1 B'), the top `screen` then evaluated exactly) and removes the configuration
/// whose removal leaves the best objective; stops when an exchange no longer improves it. With predicted_error as
/// objective the screening gain is instead the exact decrease of trace(A^-1 G) that adding the candidate brings
/// (G: the validation sample's information, see ObservabilityEvaluator::SetValidation), by the Woodbury identity.
///
/// One iteration costs num_candidates + min(screen, num_candidates - M) evaluations: a screening gain for each
/// candidate outside the set, the screened ones exactly, and one removal per member. The pool's blocks are
/// its memory: num_candidates x (rows x L + joints) doubles.
struct ExchangeOptions {
  int num_candidates = 2000;
  /// Candidates per addition evaluated exactly after D-optimal screening.
  int screen = 16;
  /// Exchanges at most; on the presets the optimiser converges after 8-35 (M = 10 and 50, 2000 candidates).
  int max_iterations = 200;
  /// Stop before an iteration that would take the evaluations past this many (0 = no limit beyond
  /// max_iterations).
  int max_evaluations = 0;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  std::uint64_t seed = 1;
  PlanProgressCallback progress;
  /// Feasibility in a cell (empty: everything): the candidate pool is drawn from feasible configurations.
  FeasibilityPredicate feasible;
  /// Rejection sampling stops, and the plan fails, after this many draws per configuration the plan draws:
  /// num_candidates, plus num_validation for predicted_error.
  int max_draws_per_configuration = kDefaultMaxDrawsPerConfiguration;
  /// Validation configurations of the predicted_error objective (as SolisWetsOptions::num_validation).
  int num_validation = 50;
  /// As SolisWetsOptions::task.
  TaskConfigurations task;
  /// The pool is these instead of num_candidates drawn configurations.
  CandidatePool candidates;
  bool IsValid(std::string* error) const;
};

struct PlanSummary {
  Termination termination = Termination::kFailure;
  std::string message = "not run";
  /// The options' progress callback asked to stop: NO_CONVERGENCE with the best set so far.
  bool cancelled = false;
  /// "solis_wets", "random" or "exchange".
  std::string method;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  int iterations = 0;
  /// Objective evaluations, each an L x L eigenproblem of a candidate set; the exchange optimiser also counts
  /// each candidate's D-optimal screening gain as one. Never more than MaxPlanWork(...).evaluations.
  int evaluations = 0;
  /// Objective value (ObjectiveValue: the index, negated if maximised) of the best set after each iteration.
  std::vector<double> objective_trace;
  /// Rejection sampling (starting sets, random sets, the exchange pool, the predicted_error validation sample):
  /// configurations drawn and how many of them the feasibility predicate rejected (0 without one). FAILURE with
  /// a message "... N of D random configurations within the joint limits were feasible ..." when the draws ran
  /// out.
  std::int64_t feasibility_draws = 0;
  std::int64_t feasibility_rejections = 0;
  /// Solis & Wets in a cell: candidate sets with an infeasible configuration (kWholeSet: not evaluated;
  /// kFeasibleConfigurations: those configurations held back).
  int infeasible_candidates = 0;
  double seconds = 0.0;
  /// Indices of the starting set and of the result.
  ObservabilityIndices initial;
  ObservabilityIndices final;
  /// A plan from candidates: the pool's check (num_candidates 0 for a plan that drew its configurations).
  CandidateAccount candidates;

  std::string BriefReport() const;
  std::string FullReport() const;
};

struct Plan {
  /// M configurations, each within the model's joint limits (rad / mm per joint).
  std::vector<Eigen::VectorXd> configurations;
  /// A plan from candidates: configurations[m] is exactly candidate candidate_indices[m] of the pool. Empty for a
  /// plan that drew its configurations.
  std::vector<int> candidate_indices;
  PlanSummary summary;
};

/// The most work a plan can do, from M and its options alone, so that a caller can refuse or schedule a plan
/// before it starts. Saturates at INT64_MAX.
struct PlanWork {
  /// Objective evaluations: Solis & Wets (restarts + 1) x (2 k_max + 1), or max_evaluations if smaller; random
  /// selection num_sets; exchange 1 + max_iterations x (num_candidates + min(screen, num_candidates - M)), or
  /// max_evaluations if smaller.
  std::int64_t evaluations = 0;
  /// Identification Jacobians of single configurations: an evaluation of a whole set computes M of them (Solis &
  /// Wets, random selection); the exchange optimiser computes one per candidate, once.
  /// The predicted_error objective adds its num_validation validation Jacobians, computed once.
  std::int64_t jacobians = 0;
  /// Calls of the feasibility predicate (0 without one): max_draws_per_configuration x the configurations the
  /// plan draws, and for Solis & Wets M per candidate set, 2 k_max per run. Not folded into `evaluations`: a
  /// cell's check (a few microseconds) costs about one Jacobian and far less than an evaluation, so a caller
  /// bounding work by evaluations and Jacobians may bound these separately, or not at all.
  std::int64_t feasibility_checks = 0;
};
PlanWork MaxPlanWork(int num_configurations, const SolisWetsOptions& options);
PlanWork MaxPlanWork(int num_configurations, const RandomSelectionOptions& options);
PlanWork MaxPlanWork(int num_configurations, const ExchangeOptions& options);

/// Solis & Wets from `initial` (M configurations within limits, feasible) or, if empty, from a random set.
/// Throws std::invalid_argument for invalid options, M < 1 or a wrongly sized, out-of-limits or infeasible initial
/// set. Every planner returns FAILURE with no configurations when rejection sampling runs out of draws (the cell
/// leaves too little feasible), and only configurations satisfying options.feasible otherwise.
///
/// From candidates (options.candidates): std::invalid_argument for a malformed candidate under
/// MalformedCandidates::kThrow, a task configuration of the wrong size or not finite, or an empty task; FAILURE
/// with no configurations, the account in summary.candidates and a message naming both counts ("30
/// configurations asked, 12 of 2000 candidates usable") when fewer than M candidates are usable.
Plan PlanSolisWets(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                   const SolisWetsOptions& options, const std::vector<Eigen::VectorXd>& initial = {});

Plan PlanRandom(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                const RandomSelectionOptions& options);

Plan PlanExchange(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                  const ExchangeOptions& options);

/// M configurations drawn uniformly within the joint limits (DrawFeasibleConfigurations for a cell).
std::vector<Eigen::VectorXd> RandomConfigurations(const RobotModel& model, int count, Rng* rng);

}  // namespace robocal
