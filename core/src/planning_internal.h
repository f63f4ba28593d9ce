// What the planners share (core/src only; the public interface is planning.h): the normalised coordinates of
// a set, the draw budget of rejection sampling, the objective's validation sample, and the common start and end
// of a plan. The planners: solis_wets.cc, exchange.cc, and random selection in planning.cc.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "robocal/core/planning.h"
#include "robocal/core/random.h"

namespace robocal::planning_detail {

using Clock = std::chrono::steady_clock;

inline double Seconds(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A non-finite objective (a singular set) ranks worst.
inline double Finite(double value) {
  return std::isfinite(value) ? value : std::numeric_limits<double>::infinity();
}

// a x b and a + b for non-negative bounds, saturated rather than overflowing: bounds are only compared with
// limits.
inline std::int64_t SaturatingProduct(std::int64_t a, std::int64_t b) {
  if (a == 0 || b == 0) return 0;
  return a > std::numeric_limits<std::int64_t>::max() / b ? std::numeric_limits<std::int64_t>::max() : a * b;
}

inline std::int64_t SaturatingSum(std::int64_t a, std::int64_t b) {
  return a > std::numeric_limits<std::int64_t>::max() - b ? std::numeric_limits<std::int64_t>::max() : a + b;
}

// Configurations the predicted_error objective draws for its validation sample (none for the other objectives).
inline std::int64_t ValidationDraws(ObservabilityIndex objective, int num_validation) {
  return objective == ObservabilityIndex::kPredictedError ? num_validation : 0;
}

// The same for a planner's options: none when the caller gave the task.
template <typename Options>
std::int64_t ValidationDrawsOf(const Options& options) {
  return options.task ? 0 : ValidationDraws(options.objective, options.num_validation);
}

// The validation Jacobians of the predicted_error objective: the task's, or the drawn sample's.
template <typename Options>
std::int64_t ValidationJacobiansOf(const Options& options) {
  if (options.objective != ObservabilityIndex::kPredictedError) return 0;
  return options.task ? static_cast<std::int64_t>(options.task->size()) : options.num_validation;
}

// A task a caller gives: non-empty, each configuration of the model's joint count and finite (within the limits
// or not: a cell's planning ranges need not cover where the robot works). Throws std::invalid_argument.
void CheckTask(const RobotModel& model, const TaskConfigurations& task);

// q's revolute joints shifted by whole turns into the limits (the first turn that fits, from the value itself);
// false when some joint fits no turn.
bool ShiftIntoLimits(const RobotModel& model, Eigen::VectorXd* q);

// The candidates a planner may choose from (ascending indices into the caller's list) and the account of the
// others. Throws std::invalid_argument for the first malformed candidate under MalformedCandidates::kThrow.
struct UsableCandidates {
  std::vector<int> indices;
  CandidateAccount account;
};
UsableCandidates CheckCandidates(const RobotModel& model, const CandidatePool& pool,
                                 const FeasibilityPredicate& feasible);

// The start of a plan from candidates, shared by the planners: the candidates checked (nothing when the pool is not
// given), their account in the plan's summary, and false with the plan a FAILURE (no configurations, both counts in
// the message) when fewer than num_configurations are usable.
bool CheckCandidatesForPlan(const RobotModel& model, const CandidatePool& pool, const FeasibilityPredicate& feasible,
                            int num_configurations, Clock::time_point start_time, UsableCandidates* usable, Plan* plan);

// The weighted, reduced blocks (rows x L) of a candidate pool in one allocation: they are the exchange optimiser's
// memory, and a single large block goes back to the system when the plan ends. Contributions B'B are formed when
// needed (rows x L^2 flops, against the L^3 eigenproblem of every evaluation) instead of being stored (L^2
// doubles per candidate, several times the blocks).
struct PoolBlocks {
  PoolBlocks(int rows, int l, int count) : l(l), blocks(rows, static_cast<Eigen::Index>(count) * l) {}
  int count() const { return static_cast<int>(blocks.cols() / l); }
  auto block(int c) const { return blocks.middleCols(static_cast<Eigen::Index>(c) * l, l); }
  auto block(int c) { return blocks.middleCols(static_cast<Eigen::Index>(c) * l, l); }
  Eigen::MatrixXd Contribution(int c) const { return block(c).transpose() * block(c); }
  Eigen::MatrixXd Normal(const std::vector<int>& members) const {
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(l, l);
    for (int c : members) normal += Contribution(c);
    return normal;
  }

  int l;
  Eigen::MatrixXd blocks;
};

// The blocks of the usable candidates, in the order of `usable.indices`.
PoolBlocks CandidateBlocks(const std::vector<Eigen::VectorXd>& candidates, const std::vector<int>& usable,
                           ObservabilityEvaluator* evaluator);

// The exchange optimiser's addition step: the pool member outside the set (in_set[c] == 0) whose addition to the
// set with normal matrix `normal` gives the best objective for `size` configurations, screened as PlanExchange
// says (every screening gain and every exact evaluation counted in *evaluations). -1 when none is outside.
struct Addition {
  int candidate = -1;
  double value = std::numeric_limits<double>::infinity();
};
Addition BestAddition(const PoolBlocks& pool, const Eigen::MatrixXd& normal, const std::vector<char>& in_set, int size,
                      const ObservabilityEvaluator& evaluator, ObservabilityIndex objective, int screen,
                      int* evaluations);

// The exchange iterations of PlanExchange from `members` (distinct pool members): counts iterations, evaluations
// and the trace in *s, sets s->initial.
struct ExchangeOutcome {
  std::vector<int> members;
  ObservabilityIndices indices;
  bool cancelled = false;
  bool converged = false;
  bool budget_reached = false;
};
ExchangeOutcome RunExchange(const PoolBlocks& pool, std::vector<int> members, const ExchangeOptions& options,
                            const ObservabilityEvaluator& evaluator, PlanSummary* s);

// The rejection-sampling account of a plan that draws at most `configurations`.
inline FeasibleDraws DrawBudget(int max_draws_per_configuration, std::int64_t configurations) {
  FeasibleDraws account;
  account.max_draws = SaturatingProduct(max_draws_per_configuration, configurations);
  return account;
}

// Gives the evaluator the predicted_error objective's validation sample, drawn (feasible) from its own generator
// so that the planner's draws do not depend on the objective. False when rejection sampling ran out.
// A caller's task replaces the sample. `always`: set it up whatever the objective (the predicted error against N of
// the pose count reports it beside any objective).
inline bool SetUpObjective(const RobotModel& model, ObservabilityIndex objective, int num_validation,
                           std::uint64_t seed, const FeasibilityPredicate& feasible, const TaskConfigurations& task,
                           FeasibleDraws* account, ObservabilityEvaluator* evaluator, bool always = false) {
  if (objective != ObservabilityIndex::kPredictedError && !always) return true;
  if (task) {
    evaluator->SetValidation(*task);
    return true;
  }
  Rng rng(seed + kPredictedErrorSeedOffset);
  std::vector<Eigen::VectorXd> validation;
  if (!DrawFeasibleConfigurations(model, num_validation, feasible, &rng, account, &validation)) return false;
  evaluator->SetValidation(validation);
  return true;
}

// The opening of a planner that will draw `configurations` configurations: its rejection-sampling budget in
// `account`, with the objective's validation sample drawn into `evaluator`. Returns what the budget covers
// (the validation sample included); -1 when rejection sampling ran out: the plan has then failed
// (FailForFeasibility). Options: any planner's options (objective, num_validation, seed, feasible,
// max_draws_per_configuration).
template <typename Options>
std::int64_t PrepareDraws(const RobotModel& model, const Options& options, std::int64_t configurations,
                          Clock::time_point start_time, ObservabilityEvaluator* evaluator, FeasibleDraws* account,
                          Plan* plan);

inline bool CheckDrawOptions(int max_draws_per_configuration, int num_validation, std::string* error) {
  if (max_draws_per_configuration < 1 || max_draws_per_configuration > 1000000) {
    *error = "max_draws_per_configuration must be in [1, 1000000]";
    return false;
  }
  if (num_validation < 1 || num_validation > 100000) {
    *error = "num_validation must be in [1, 100000]";
    return false;
  }
  return true;
}

inline void CheckCommon(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                        bool options_valid, const std::string& options_error) {
  if (num_configurations < 1) throw std::invalid_argument("num_configurations must be at least 1");
  if (!options_valid) throw std::invalid_argument(options_error);
  std::string error;
  if (!observability.IsValid(model, &error)) throw std::invalid_argument("ObservabilityOptions: " + error);
}

// Maps between joint values and normalised coordinates z in [0, 1] per joint range.
struct Normaliser {
  const RobotModel& model;

  Eigen::VectorXd ToZ(const std::vector<Eigen::VectorXd>& configurations) const {
    const int n = model.num_joints();
    Eigen::VectorXd z(n * configurations.size());
    for (size_t m = 0; m < configurations.size(); ++m) {
      z.segment(m * n, n) = (configurations[m] - model.lower_limits())
                                .cwiseQuotient(model.upper_limits() - model.lower_limits());
    }
    return z;
  }

  std::vector<Eigen::VectorXd> FromZ(const Eigen::VectorXd& z) const {
    const int n = model.num_joints();
    std::vector<Eigen::VectorXd> configurations(z.size() / n);
    for (size_t m = 0; m < configurations.size(); ++m) {
      configurations[m] = model.lower_limits() +
                          z.segment(m * n, n).cwiseProduct(model.upper_limits() - model.lower_limits());
      // Round-off at the bounds must not leave the limits.
      configurations[m] = configurations[m].cwiseMax(model.lower_limits()).cwiseMin(model.upper_limits());
    }
    return configurations;
  }

  // A configuration as the search sees it after the trip through normalised coordinates (round-off only).
  Eigen::VectorXd RoundTrip(const Eigen::VectorXd& q) const { return FromZ(ToZ({q})).front(); }
};

inline Eigen::VectorXd Project(Eigen::VectorXd z, LimitHandling handling) {
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (handling == LimitHandling::kClamp) {
      z[i] = std::clamp(z[i], 0.0, 1.0);
    } else {
      // Triangle wave: mirror at 0 and 1 as often as needed.
      const double t = std::fmod(std::abs(z[i]), 2.0);
      z[i] = t > 1.0 ? 2.0 - t : t;
    }
  }
  return z;
}

// The common start of every planner: a summary naming method and objective.
inline Plan StartPlan(const char* method, ObservabilityIndex objective) {
  Plan plan;
  plan.summary.method = method;
  plan.summary.objective = objective;
  return plan;
}

// The common end: elapsed time, and DEGRADED when the result is still rank deficient (by the rank cut of
// identification, not only when the condition number is infinite).
inline void FinishPlan(Clock::time_point start_time, const RobotModel& model, const ObservabilityOptions& observability,
                       Plan* plan) {
  PlanSummary& s = plan->summary;
  const int l = static_cast<int>(observability.parameters.size());
  const int rank = NumericalRank(model, plan->configurations, observability);
  if (rank < l || !std::isfinite(s.final.condition_number)) {
    s.termination = Termination::kDegraded;
    s.message += "; the set is rank deficient (rank " + std::to_string(rank) + " of " + std::to_string(l) + ")";
  }
  s.seconds = Seconds(start_time);
}

// The summary's record of rejection sampling.
inline void RecordDraws(const FeasibleDraws& account, PlanSummary* s) {
  s->feasibility_draws = account.draws;
  s->feasibility_rejections = account.rejections;
}

// The end of a plan whose rejection sampling ran out of draws: FAILURE and no configurations (the cell leaves too
// little of the joint ranges feasible; a caller can name the rule from a census of the cell).
inline void FailForFeasibility(Clock::time_point start_time, const FeasibleDraws& account, std::int64_t configurations,
                               int max_draws_per_configuration, Plan* plan) {
  PlanSummary& s = plan->summary;
  plan->configurations.clear();
  s.termination = Termination::kFailure;
  std::ostringstream share;
  share << std::setprecision(3)
        << 100.0 * (account.draws - account.rejections) / std::max<std::int64_t>(1, account.draws);
  s.message = "too few feasible configurations: " + account.Describe() + " (" + share.str() + " %); the plan draws " +
              std::to_string(configurations) + " configurations, at most " +
              std::to_string(max_draws_per_configuration) + " draws each (max_draws_per_configuration)";
  RecordDraws(account, &s);
  s.seconds = Seconds(start_time);
}

template <typename Options>
std::int64_t PrepareDraws(const RobotModel& model, const Options& options, std::int64_t configurations,
                          Clock::time_point start_time, ObservabilityEvaluator* evaluator, FeasibleDraws* account,
                          Plan* plan) {
  const std::int64_t drawn = SaturatingSum(configurations, ValidationDrawsOf(options));
  *account = DrawBudget(options.max_draws_per_configuration, drawn);
  if (SetUpObjective(model, options.objective, options.num_validation, options.seed, options.feasible, options.task,
                     account, evaluator)) {
    return drawn;
  }
  FailForFeasibility(start_time, *account, drawn, options.max_draws_per_configuration, plan);
  return -1;
}

inline std::string IndicesLine(const ObservabilityIndices& x) {
  std::ostringstream out;
  out << std::setprecision(5) << "cond " << x.condition_number << ", O1 " << x.o1 << ", O2 " << x.o2 << ", O3 "
      << x.o3 << ", O4 " << x.o4 << ", O5 " << x.o5 << ", log det " << x.log_det;
  if (!std::isnan(x.predicted_error_mm)) out << ", predicted error " << x.predicted_error_mm << " mm";
  return out.str();
}

}  // namespace robocal::planning_detail
