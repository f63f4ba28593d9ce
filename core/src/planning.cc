// Measurement configuration optimisers: Solis & Wets, random selection, exchange.
#include "robocal/core/planning.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include <Eigen/Cholesky>

#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A non-finite objective (a singular set) ranks worst.
double Finite(double value) {
  return std::isfinite(value) ? value : std::numeric_limits<double>::infinity();
}

// a x b and a + b for non-negative bounds, saturated rather than overflowing: bounds are only compared with
// limits.
std::int64_t SaturatingProduct(std::int64_t a, std::int64_t b) {
  if (a == 0 || b == 0) return 0;
  return a > std::numeric_limits<std::int64_t>::max() / b ? std::numeric_limits<std::int64_t>::max() : a * b;
}

std::int64_t SaturatingSum(std::int64_t a, std::int64_t b) {
  return a > std::numeric_limits<std::int64_t>::max() - b ? std::numeric_limits<std::int64_t>::max() : a + b;
}

// Configurations the predicted_error objective draws for its validation sample (none for the other objectives).
std::int64_t ValidationDraws(ObservabilityIndex objective, int num_validation) {
  return objective == ObservabilityIndex::kPredictedError ? num_validation : 0;
}

// The rejection-sampling account of a plan that draws at most `configurations`.
FeasibleDraws DrawBudget(int max_draws_per_configuration, std::int64_t configurations) {
  FeasibleDraws account;
  account.max_draws = SaturatingProduct(max_draws_per_configuration, configurations);
  return account;
}

// Gives the evaluator the predicted_error objective's validation sample, drawn (feasible) from its own generator
// so that the planner's draws do not depend on the objective. False when rejection sampling ran out.
bool SetUpObjective(const RobotModel& model, ObservabilityIndex objective, int num_validation, std::uint64_t seed,
                    const FeasibilityPredicate& feasible, FeasibleDraws* account, ObservabilityEvaluator* evaluator) {
  if (objective != ObservabilityIndex::kPredictedError) return true;
  Rng rng(seed + kPredictedErrorSeedOffset);
  std::vector<Eigen::VectorXd> validation;
  if (!DrawFeasibleConfigurations(model, num_validation, feasible, &rng, account, &validation)) return false;
  evaluator->SetValidation(validation);
  return true;
}

bool CheckDrawOptions(int max_draws_per_configuration, int num_validation, std::string* error) {
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

void CheckCommon(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
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

Eigen::VectorXd Project(Eigen::VectorXd z, LimitHandling handling) {
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
Plan StartPlan(const char* method, ObservabilityIndex objective) {
  Plan plan;
  plan.summary.method = method;
  plan.summary.objective = objective;
  return plan;
}

// The common end: elapsed time, and DEGRADED when the result is still rank deficient (by the rank cut of
// identification, not only when the condition number is infinite).
void FinishPlan(Clock::time_point start_time, const RobotModel& model, const ObservabilityOptions& observability,
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
void RecordDraws(const FeasibleDraws& account, PlanSummary* s) {
  s->feasibility_draws = account.draws;
  s->feasibility_rejections = account.rejections;
}

// The end of a plan whose rejection sampling ran out of draws: FAILURE and no configurations (the cell leaves too
// little of the joint ranges feasible; a caller can name the rule from a census of the cell).
void FailForFeasibility(Clock::time_point start_time, const FeasibleDraws& account, std::int64_t configurations,
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

std::string IndicesLine(const ObservabilityIndices& x) {
  std::ostringstream out;
  out << std::setprecision(5) << "cond " << x.condition_number << ", O1 " << x.o1 << ", O2 " << x.o2 << ", O3 "
      << x.o3 << ", O4 " << x.o4 << ", O5 " << x.o5 << ", log det " << x.log_det;
  if (!std::isnan(x.predicted_error_mm)) out << ", predicted error " << x.predicted_error_mm << " mm";
  return out.str();
}

}  // namespace

const char* ToString(LimitHandling handling) { return handling == LimitHandling::kReflect ? "reflect" : "clamp"; }

SolisWetsOptions SolisWetsOptions::Paper() {
  // Set one by one, not taken from the defaults: changing a default must never change the paper's preset.
  SolisWetsOptions o;
  o.k_max = 100;           // Wang & Zhang (2007), section 3
  o.scent_threshold = 5;   // Scent
  o.fcent_threshold = 3;   // Fcent
  o.sigma0 = 1.0;          // sigma_0
  o.sigma_ub = 3.0;        // sigma_ub
  o.sigma_lb = 0.1;        // sigma_lb
  o.expansion = 2.0;       // ex
  o.contraction = 0.5;     // ct
  o.restarts = 0;          // one run
  o.max_evaluations = 0;   // no budget beyond k_max
  o.objective = ObservabilityIndex::kConditionNumber;
  // What the paper leaves open, decided as docs/planning.md says: sigma in tenths of each joint's range,
  // counters reset after they change sigma, joint limits by reflection.
  o.step_fraction = 0.1;
  o.reset_counters = true;
  o.limits = LimitHandling::kReflect;
  return o;
}

bool SolisWetsOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    *error = message;
    return false;
  };
  if (k_max < 1 || k_max > 10000000) return fail("k_max must be in [1, 10000000]");
  if (scent_threshold < 0 || fcent_threshold < 0) return fail("scent_threshold and fcent_threshold must be >= 0");
  if (!(sigma_lb > 0.0) || !(sigma_ub > sigma_lb) || !std::isfinite(sigma_ub)) {
    return fail("sigma bounds must satisfy 0 < sigma_lb < sigma_ub < inf");
  }
  if (!(sigma0 > 0.0) || !std::isfinite(sigma0)) return fail("sigma0 must be positive and finite");
  if (!(expansion > 1.0) || !std::isfinite(expansion)) return fail("expansion must be > 1");
  if (!(contraction > 0.0 && contraction < 1.0)) return fail("contraction must be in (0, 1)");
  if (!(step_fraction > 0.0 && step_fraction <= 1.0)) return fail("step_fraction must be in (0, 1]");
  if (restarts < 0 || restarts > 10000) return fail("restarts must be in [0, 10000]");
  if (max_evaluations < 0) return fail("max_evaluations must be >= 0");
  return CheckDrawOptions(max_draws_per_configuration, num_validation, error);
}

bool RandomSelectionOptions::IsValid(std::string* error) const {
  if (num_sets < 1 || num_sets > 10000000) {
    *error = "num_sets must be in [1, 10000000]";
    return false;
  }
  return CheckDrawOptions(max_draws_per_configuration, num_validation, error);
}

bool ExchangeOptions::IsValid(std::string* error) const {
  if (num_candidates < 1 || num_candidates > 1000000) {
    *error = "num_candidates must be in [1, 1000000]";
    return false;
  }
  if (screen < 1) {
    *error = "screen must be >= 1";
    return false;
  }
  if (max_iterations < 0) {
    *error = "max_iterations must be >= 0";
    return false;
  }
  if (max_evaluations < 0) {
    *error = "max_evaluations must be >= 0";
    return false;
  }
  return CheckDrawOptions(max_draws_per_configuration, num_validation, error);
}

namespace {
std::int64_t CappedBy(std::int64_t evaluations, int max_evaluations) {
  return max_evaluations > 0 ? std::min<std::int64_t>(evaluations, max_evaluations) : evaluations;
}
}  // namespace

PlanWork MaxPlanWork(int num_configurations, const SolisWetsOptions& options) {
  // Each run evaluates its starting set, then at most a forward and a reversed step per iteration.
  const std::int64_t per_run = 2 * static_cast<std::int64_t>(options.k_max) + 1;
  const std::int64_t validation = ValidationDraws(options.objective, options.num_validation);
  PlanWork work;
  work.evaluations = CappedBy(SaturatingProduct(options.restarts + 1, per_run), options.max_evaluations);
  work.jacobians = SaturatingSum(SaturatingProduct(work.evaluations, num_configurations), validation);
  if (options.feasible) {
    // Rejection sampling of the starting sets and the validation sample, then M checks per candidate set. An
    // infeasible candidate costs no evaluation, so the candidates are bounded by the iterations, not the budget.
    const std::int64_t starts = SaturatingProduct(options.restarts + 1, num_configurations);
    const std::int64_t candidates =
        SaturatingProduct(SaturatingProduct(options.restarts + 1, 2 * options.k_max), num_configurations);
    work.feasibility_checks = SaturatingSum(
        SaturatingProduct(options.max_draws_per_configuration, SaturatingSum(starts, validation)), candidates);
  }
  return work;
}

PlanWork MaxPlanWork(int num_configurations, const RandomSelectionOptions& options) {
  const std::int64_t validation = ValidationDraws(options.objective, options.num_validation);
  const std::int64_t drawn = SaturatingProduct(options.num_sets, num_configurations);
  PlanWork work;
  work.evaluations = options.num_sets;
  work.jacobians = SaturatingSum(drawn, validation);
  if (options.feasible) {
    work.feasibility_checks = SaturatingProduct(options.max_draws_per_configuration, SaturatingSum(drawn, validation));
  }
  return work;
}

PlanWork MaxPlanWork(int num_configurations, const ExchangeOptions& options) {
  const std::int64_t outside = std::max(0, options.num_candidates - num_configurations);
  const std::int64_t per_iteration = options.num_candidates + std::min<std::int64_t>(options.screen, outside);
  PlanWork work;
  work.evaluations = CappedBy(
      std::min(SaturatingProduct(options.max_iterations, per_iteration), std::numeric_limits<std::int64_t>::max() - 1) +
          1,
      options.max_evaluations);
  const std::int64_t validation = ValidationDraws(options.objective, options.num_validation);
  work.jacobians = SaturatingSum(options.num_candidates, validation);
  if (options.feasible) {
    work.feasibility_checks =
        SaturatingProduct(options.max_draws_per_configuration, SaturatingSum(options.num_candidates, validation));
  }
  return work;
}

std::vector<Eigen::VectorXd> RandomConfigurations(const RobotModel& model, int count, Rng* rng) {
  std::vector<Eigen::VectorXd> out;
  out.reserve(count);
  for (int i = 0; i < count; ++i) out.push_back(RandomConfiguration(model, rng));
  return out;
}

std::string FeasibleDraws::Describe() const {
  return std::to_string(draws - rejections) + " of " + std::to_string(draws) +
         " random configurations within the joint limits were feasible";
}

bool DrawFeasibleConfiguration(const RobotModel& model, const FeasibilityPredicate& feasible, Rng* rng,
                               FeasibleDraws* account, Eigen::VectorXd* q) {
  while (account->draws < account->max_draws) {
    *q = RandomConfiguration(model, rng);
    ++account->draws;
    if (!feasible || feasible(*q)) return true;
    ++account->rejections;
  }
  return false;
}

bool DrawFeasibleConfigurations(const RobotModel& model, int count, const FeasibilityPredicate& feasible, Rng* rng,
                                FeasibleDraws* account, std::vector<Eigen::VectorXd>* out) {
  out->reserve(out->size() + std::max(count, 0));
  Eigen::VectorXd q;
  for (int i = 0; i < count; ++i) {
    if (!DrawFeasibleConfiguration(model, feasible, rng, account, &q)) return false;
    out->push_back(q);
  }
  return true;
}

Plan PlanSolisWets(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                   const SolisWetsOptions& options, const std::vector<Eigen::VectorXd>& initial) {
  std::string error;
  const bool valid = options.IsValid(&error);
  CheckCommon(model, num_configurations, observability, valid, "SolisWetsOptions: " + error);
  const Normaliser normaliser{model};
  if (!initial.empty()) {
    if (static_cast<int>(initial.size()) != num_configurations) {
      throw std::invalid_argument("initial set has " + std::to_string(initial.size()) + " configurations, expected " +
                                  std::to_string(num_configurations));
    }
    for (size_t m = 0; m < initial.size(); ++m) {
      if (!model.WithinLimits(initial[m])) {
        throw std::invalid_argument("initial[" + std::to_string(m) + "] is outside the joint limits");
      }
      if (options.feasible && !options.feasible(normaliser.RoundTrip(initial[m]))) {
        throw std::invalid_argument("initial[" + std::to_string(m) + "] is infeasible (options.feasible)");
      }
    }
  }
  const auto start_time = Clock::now();
  Plan plan = StartPlan("solis_wets", options.objective);
  PlanSummary& s = plan.summary;
  ObservabilityEvaluator evaluator(model, observability);
  Rng rng(options.seed);
  const int total_iterations = options.k_max * (options.restarts + 1);
  bool stopped = false;
  const std::int64_t drawn_sets = options.restarts + (initial.empty() ? 1 : 0);
  const std::int64_t drawn = SaturatingSum(SaturatingProduct(drawn_sets, num_configurations),
                                           ValidationDraws(options.objective, options.num_validation));
  FeasibleDraws account = DrawBudget(options.max_draws_per_configuration, drawn);
  if (!SetUpObjective(model, options.objective, options.num_validation, options.seed, options.feasible, &account,
                      &evaluator)) {
    FailForFeasibility(start_time, account, drawn, options.max_draws_per_configuration, &plan);
    return plan;
  }
  // The search runs in normalised coordinates: a starting configuration must be feasible after that round trip.
  FeasibilityPredicate start_feasible;
  if (options.feasible) {
    start_feasible = [&](const Eigen::VectorXd& q) { return options.feasible(normaliser.RoundTrip(q)); };
  }

  // kWholeSet: a candidate set with an infeasible configuration is not evaluated and ranks as +inf, a failed
  // step. Starting sets and candidates restricted by HoldInfeasible are feasible by construction and need no
  // check.
  const bool whole_set = options.cell_step == SolisWetsOptions::CellStep::kWholeSet;
  auto evaluate = [&](const Eigen::VectorXd& z, bool check) {
    const std::vector<Eigen::VectorXd> configurations = normaliser.FromZ(z);
    if (check && options.feasible && whole_set) {
      for (const Eigen::VectorXd& q : configurations) {
        if (!options.feasible(q)) {
          ++s.infeasible_candidates;
          return std::numeric_limits<double>::infinity();
        }
      }
    }
    evaluator.SetConfigurations(configurations);
    ++s.evaluations;
    return Finite(ObjectiveValue(evaluator.indices(), options.objective));
  };
  // kFeasibleConfigurations: the candidate `to` with every configuration whose move from `from` (a feasible
  // set) would be infeasible held at its place in `from`. Sets *moved to whether any configuration moved.
  const int n = model.num_joints();
  auto hold_infeasible = [&](const Eigen::VectorXd& from, Eigen::VectorXd to, bool* moved) {
    const std::vector<Eigen::VectorXd> configurations = normaliser.FromZ(to);
    bool held = false;
    *moved = false;
    for (size_t m = 0; m < configurations.size(); ++m) {
      if (options.feasible(configurations[m])) {
        *moved = *moved || to.segment(m * n, n) != from.segment(m * n, n);
      } else {
        to.segment(m * n, n) = from.segment(m * n, n);
        held = true;
      }
    }
    if (held) ++s.infeasible_candidates;
    return to;
  };
  const bool hold = options.feasible && !whole_set;
  // A step's objective: +inf (a failed step, no evaluation) when holding back left nothing to move.
  auto evaluate_step = [&](const Eigen::VectorXd& z, bool moved) {
    return hold && !moved ? std::numeric_limits<double>::infinity() : evaluate(z, true);
  };
  auto budget_left = [&] { return options.max_evaluations == 0 || s.evaluations < options.max_evaluations; };

  // The fraction done by iterations, or by the evaluation budget when that ends the search sooner.
  auto fraction_done = [&] {
    const double by_iterations = static_cast<double>(s.iterations) / total_iterations;
    return options.max_evaluations > 0
               ? std::max(by_iterations, static_cast<double>(s.evaluations) / options.max_evaluations)
               : by_iterations;
  };

  double best_f = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_z;
  // Indices are kept with their sets (x_indices with x), so that the result needs no evaluation beyond the
  // counted ones.
  ObservabilityIndices best_indices;
  for (int run = 0; run <= options.restarts && !stopped; ++run) {
    if (run > 0 && !budget_left()) {
      stopped = true;
      break;
    }
    std::vector<Eigen::VectorXd> start_set;
    if (run == 0 && !initial.empty()) {
      start_set = initial;
    } else if (!DrawFeasibleConfigurations(model, num_configurations, start_feasible, &rng, &account, &start_set)) {
      FailForFeasibility(start_time, account, drawn, options.max_draws_per_configuration, &plan);
      return plan;
    }
    Eigen::VectorXd x = normaliser.ToZ(start_set);
    double fx = evaluate(x, false);
    ObservabilityIndices x_indices = evaluator.indices();
    if (run == 0) s.initial = x_indices;
    if (fx < best_f || best_z.size() == 0) {
      best_f = fx;
      best_z = x;
      best_indices = x_indices;
    }
    Eigen::VectorXd mu = Eigen::VectorXd::Zero(x.size());
    double sigma = options.sigma0;
    int scent = 0, fcent = 0;
    for (int k = 1; k <= options.k_max; ++k) {
      if (!budget_left()) {
        stopped = true;
        break;
      }
      // (1) step size.
      if (scent > options.scent_threshold) {
        sigma *= options.expansion;
        if (options.reset_counters) scent = 0;
      } else if (fcent > options.fcent_threshold) {
        sigma *= options.contraction;
        if (options.reset_counters) fcent = 0;
      } else if (sigma < options.sigma_lb) {
        sigma = options.sigma_ub;
      }
      // (2) Gaussian step d ~ N(mu, sigma^2 I), in sigma units; one unit is step_fraction of a joint range.
      Eigen::VectorXd d(x.size());
      for (Eigen::Index i = 0; i < d.size(); ++i) d[i] = mu[i] + sigma * rng.Normal();
      bool moved = true;
      Eigen::VectorXd xi = Project(x + options.step_fraction * d, options.limits);
      if (hold) xi = hold_infeasible(x, xi, &moved);
      const Eigen::VectorXd d_taken = (xi - x) / options.step_fraction;
      // (3) forward step, then the reversed step.
      const double f_xi = evaluate_step(xi, moved);
      if (f_xi < fx) {
        x = xi;
        fx = f_xi;
        x_indices = evaluator.indices();
        mu = 0.2 * mu + 0.4 * d_taken;
        ++scent;
        fcent = 0;
      } else {
        Eigen::VectorXd reverse = Project(2.0 * x - xi, options.limits);
        bool reverse_moved = true;
        if (hold) reverse = hold_infeasible(x, reverse, &reverse_moved);
        const double f_reverse =
            budget_left() ? evaluate_step(reverse, reverse_moved) : std::numeric_limits<double>::infinity();
        if (f_reverse < fx) {
          mu = mu - 0.4 * d_taken;
          x = reverse;
          fx = f_reverse;
          x_indices = evaluator.indices();
          ++scent;
          fcent = 0;
        } else {
          mu = 0.5 * mu;
          ++fcent;
          scent = 0;
        }
      }
      if (fx < best_f) {
        best_f = fx;
        best_z = x;
        best_indices = x_indices;
      }
      ++s.iterations;
      s.objective_trace.push_back(best_f);
      if (options.progress && !options.progress(fraction_done())) {
        stopped = true;
        s.message = "cancelled";
        break;
      }
    }
  }
  plan.configurations = normaliser.FromZ(best_z);
  s.final = std::move(best_indices);
  if (stopped) {
    s.termination = Termination::kNoConvergence;
    if (s.message != "cancelled") s.message = "evaluation budget reached";
  } else {
    // Solis & Wets has no convergence test: finishing its k_max iterations is its normal end.
    s.termination = Termination::kConvergence;
    s.message = "completed " + std::to_string(s.iterations) + " iterations";
  }
  RecordDraws(account, &s);
  FinishPlan(start_time, model, observability, &plan);
  return plan;
}

Plan PlanRandom(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                const RandomSelectionOptions& options) {
  std::string error;
  const bool valid = options.IsValid(&error);
  CheckCommon(model, num_configurations, observability, valid, "RandomSelectionOptions: " + error);
  const auto start_time = Clock::now();
  Plan plan = StartPlan("random", options.objective);
  PlanSummary& s = plan.summary;
  ObservabilityEvaluator evaluator(model, observability);
  Rng rng(options.seed);
  const std::int64_t drawn = SaturatingSum(SaturatingProduct(options.num_sets, num_configurations),
                                           ValidationDraws(options.objective, options.num_validation));
  FeasibleDraws account = DrawBudget(options.max_draws_per_configuration, drawn);
  if (!SetUpObjective(model, options.objective, options.num_validation, options.seed, options.feasible, &account,
                      &evaluator)) {
    FailForFeasibility(start_time, account, drawn, options.max_draws_per_configuration, &plan);
    return plan;
  }
  double best_f = std::numeric_limits<double>::infinity();
  bool cancelled = false;
  for (int set = 0; set < options.num_sets; ++set) {
    std::vector<Eigen::VectorXd> configurations;
    if (!DrawFeasibleConfigurations(model, num_configurations, options.feasible, &rng, &account, &configurations)) {
      FailForFeasibility(start_time, account, drawn, options.max_draws_per_configuration, &plan);
      return plan;
    }
    evaluator.SetConfigurations(configurations);
    ++s.evaluations;
    if (set == 0) s.initial = evaluator.indices();
    const double f = Finite(ObjectiveValue(evaluator.indices(), options.objective));
    if (f < best_f || plan.configurations.empty()) {
      best_f = f;
      plan.configurations = std::move(configurations);
      s.final = evaluator.indices();
    }
    ++s.iterations;
    s.objective_trace.push_back(best_f);
    if (options.progress && !options.progress(static_cast<double>(set + 1) / options.num_sets)) {
      cancelled = true;
      break;
    }
  }
  s.termination = cancelled ? Termination::kNoConvergence : Termination::kConvergence;
  s.message = cancelled ? "cancelled" : "best of " + std::to_string(s.evaluations) + " random sets";
  RecordDraws(account, &s);
  FinishPlan(start_time, model, observability, &plan);
  return plan;
}

Plan PlanExchange(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                  const ExchangeOptions& options) {
  std::string error;
  const bool valid = options.IsValid(&error);
  CheckCommon(model, num_configurations, observability, valid, "ExchangeOptions: " + error);
  if (options.num_candidates < num_configurations) {
    throw std::invalid_argument("ExchangeOptions: num_candidates (" + std::to_string(options.num_candidates) +
                                ") must be at least the number of configurations (" +
                                std::to_string(num_configurations) + ")");
  }
  const auto start_time = Clock::now();
  Plan plan = StartPlan("exchange", options.objective);
  PlanSummary& s = plan.summary;
  ObservabilityEvaluator evaluator(model, observability);
  Rng rng(options.seed);
  const int count = options.num_candidates;
  const int l = static_cast<int>(observability.parameters.size());
  const int rows = observability.RowsPerConfiguration();
  // The pool and every candidate's weighted, reduced block, each in one allocation: they are the optimiser's
  // memory, and a single large block goes back to the system when the plan ends. Contributions B'B are formed
  // when needed (rows x L^2 flops, against the L^3 eigenproblem of every evaluation) instead of being stored
  // (L^2 doubles per candidate, several times the blocks).
  const std::int64_t drawn = SaturatingSum(count, ValidationDraws(options.objective, options.num_validation));
  FeasibleDraws account = DrawBudget(options.max_draws_per_configuration, drawn);
  if (!SetUpObjective(model, options.objective, options.num_validation, options.seed, options.feasible, &account,
                      &evaluator)) {
    FailForFeasibility(start_time, account, drawn, options.max_draws_per_configuration, &plan);
    return plan;
  }
  Eigen::MatrixXd pool(model.num_joints(), count);
  Eigen::MatrixXd blocks(rows, static_cast<Eigen::Index>(count) * l);
  Eigen::VectorXd q;
  for (int c = 0; c < count; ++c) {
    if (!DrawFeasibleConfiguration(model, options.feasible, &rng, &account, &q)) {
      FailForFeasibility(start_time, account, drawn, options.max_draws_per_configuration, &plan);
      return plan;
    }
    pool.col(c) = q;
    blocks.middleCols(static_cast<Eigen::Index>(c) * l, l) = evaluator.Block(q);
  }
  auto block = [&](int c) { return blocks.middleCols(static_cast<Eigen::Index>(c) * l, l); };
  auto contribution = [&](int c) -> Eigen::MatrixXd { return block(c).transpose() * block(c); };
  // Random starting subset (partial Fisher-Yates).
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  for (int i = 0; i < num_configurations; ++i) {
    std::swap(order[i], order[i + rng.Index(order.size() - i)]);
  }
  std::vector<int> members(order.begin(), order.begin() + num_configurations);
  std::vector<char> in_set(count, 0);
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(l, l);
  for (int j : members) {
    normal += contribution(j);
    in_set[j] = 1;
  }
  auto evaluate = [&](const Eigen::MatrixXd& a, int size) {
    ++s.evaluations;
    return evaluator.IndicesOf(a, size);
  };
  auto value = [&](const ObservabilityIndices& x) { return Finite(ObjectiveValue(x, options.objective)); };
  ObservabilityIndices current_indices = evaluate(normal, num_configurations);
  s.initial = current_indices;
  double current = value(current_indices);
  const int outside = count - num_configurations;
  const bool i_optimal = options.objective == ObservabilityIndex::kPredictedError;
  const std::int64_t per_iteration = static_cast<std::int64_t>(count) + std::min(options.screen, outside);
  bool cancelled = false, converged = false, budget_reached = false;
  while (s.iterations < options.max_iterations) {
    if (options.max_evaluations > 0 && s.evaluations + per_iteration > options.max_evaluations) {
      budget_reached = true;
      break;
    }
    // Screen additions by the D-optimal gain log det(I + B A^-1 B') (a small ridge keeps A invertible while
    // the set is still rank deficient), then evaluate the most promising exactly. For predicted_error the gain is
    // the objective's own: adding B lowers trace(A^-1 G) by trace((I + B A^-1 B')^-1 B A^-1 G A^-1 B')
    // (Woodbury), with H = A^-1 G A^-1 formed once per iteration.
    const double ridge = 1e-9 * std::max(normal.trace() / l, 1e-300);
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal + ridge * Eigen::MatrixXd::Identity(l, l));
    Eigen::MatrixXd h;
    if (i_optimal) {
      const Eigen::MatrixXd a_inv_g = ldlt.solve(evaluator.validation_information());
      h = ldlt.solve(a_inv_g.transpose());
    }
    std::vector<std::pair<double, int>> gains;
    gains.reserve(outside);
    for (int c = 0; c < count; ++c) {
      if (in_set[c]) continue;
      const Eigen::MatrixXd u = ldlt.solve(block(c).transpose());
      const Eigen::MatrixXd m = Eigen::MatrixXd::Identity(rows, rows) + block(c) * u;
      ++s.evaluations;
      if (i_optimal) {
        gains.emplace_back(Eigen::LDLT<Eigen::MatrixXd>(m).solve(block(c) * h * block(c).transpose()).trace(), c);
      } else {
        gains.emplace_back(Eigen::LDLT<Eigen::MatrixXd>(m).vectorD().array().log().sum(), c);
      }
    }
    const size_t screened = std::min<size_t>(options.screen, gains.size());
    std::partial_sort(gains.begin(), gains.begin() + screened, gains.end(), std::greater<>());
    int best_add = -1;
    double best_add_f = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < screened; ++i) {
      const double f = value(evaluate(normal + contribution(gains[i].second), num_configurations + 1));
      if (best_add < 0 || f < best_add_f) {
        best_add_f = f;
        best_add = gains[i].second;
      }
    }
    if (best_add < 0) break;
    // Remove whichever member (the new one included) leaves the best set of M.
    const Eigen::MatrixXd enlarged = normal + contribution(best_add);
    members.push_back(best_add);
    int best_remove = static_cast<int>(members.size()) - 1;
    double best_remove_f = current;
    ObservabilityIndices best_remove_indices;
    for (size_t i = 0; i + 1 < members.size(); ++i) {
      ObservabilityIndices x = evaluate(enlarged - contribution(members[i]), num_configurations);
      const double f = value(x);
      if (f < best_remove_f) {
        best_remove_f = f;
        best_remove = static_cast<int>(i);
        best_remove_indices = std::move(x);
      }
    }
    ++s.iterations;
    if (best_remove == static_cast<int>(members.size()) - 1 ||
        !(best_remove_f < current - 1e-12 * std::abs(current))) {
      members.pop_back();
      s.objective_trace.push_back(current);
      converged = true;
      break;
    }
    in_set[best_add] = 1;
    in_set[members[best_remove]] = 0;
    normal = enlarged - contribution(members[best_remove]);
    members[best_remove] = members.back();
    members.pop_back();
    current = best_remove_f;
    current_indices = std::move(best_remove_indices);
    s.objective_trace.push_back(current);
    if (options.progress) {
      double fraction = static_cast<double>(s.iterations) / std::max(1, options.max_iterations);
      if (options.max_evaluations > 0) {
        fraction = std::max(fraction, static_cast<double>(s.evaluations) / options.max_evaluations);
      }
      if (!options.progress(fraction)) {
        cancelled = true;
        break;
      }
    }
  }
  for (int j : members) plan.configurations.push_back(pool.col(j));
  s.final = std::move(current_indices);
  if (cancelled) {
    s.termination = Termination::kNoConvergence;
    s.message = "cancelled";
  } else if (converged) {
    s.termination = Termination::kConvergence;
    s.message = "no exchange improves the objective after " + std::to_string(s.iterations) + " iterations";
  } else if (budget_reached) {
    s.termination = Termination::kNoConvergence;
    s.message = "evaluation budget reached after " + std::to_string(s.iterations) + " iterations";
  } else {
    s.termination = Termination::kNoConvergence;
    s.message = "max_iterations reached";
  }
  RecordDraws(account, &s);
  FinishPlan(start_time, model, observability, &plan);
  return plan;
}

std::string PlanSummary::BriefReport() const {
  std::ostringstream out;
  out << "Plan (" << method << ", objective " << ToString(objective) << "): " << ToString(termination) << ", "
      << message << "; " << ToString(objective) << " " << std::setprecision(5) << initial.Get(objective) << " -> "
      << final.Get(objective) << ", " << evaluations << " evaluations, " << std::setprecision(3) << seconds << " s";
  return out.str();
}

std::string PlanSummary::FullReport() const {
  std::ostringstream out;
  out << BriefReport() << "\n";
  out << "  scaling: " << final.scaling << "\n";
  out << "  initial: " << IndicesLine(initial) << "\n";
  out << "  final:   " << IndicesLine(final) << "\n";
  out << "  iterations: " << iterations << ", evaluations: " << evaluations << "\n";
  out << "  random configurations drawn: " << feasibility_draws
      << ", rejected as infeasible: " << feasibility_rejections
      << "; infeasible candidate sets: " << infeasible_candidates << "\n";
  return out.str();
}

}  // namespace robocal
