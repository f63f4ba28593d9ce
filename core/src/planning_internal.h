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

// The rejection-sampling account of a plan that draws at most `configurations`.
inline FeasibleDraws DrawBudget(int max_draws_per_configuration, std::int64_t configurations) {
  FeasibleDraws account;
  account.max_draws = SaturatingProduct(max_draws_per_configuration, configurations);
  return account;
}

// Gives the evaluator the predicted_error objective's validation sample, drawn (feasible) from its own generator
// so that the planner's draws do not depend on the objective. False when rejection sampling ran out.
inline bool SetUpObjective(const RobotModel& model, ObservabilityIndex objective, int num_validation,
                           std::uint64_t seed, const FeasibilityPredicate& feasible, FeasibleDraws* account,
                           ObservabilityEvaluator* evaluator) {
  if (objective != ObservabilityIndex::kPredictedError) return true;
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
  const std::int64_t drawn = SaturatingSum(configurations, ValidationDraws(options.objective, options.num_validation));
  *account = DrawBudget(options.max_draws_per_configuration, drawn);
  if (SetUpObjective(model, options.objective, options.num_validation, options.seed, options.feasible, account,
                     evaluator)) {
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
