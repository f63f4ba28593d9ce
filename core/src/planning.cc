// Measurement configuration planning: the options, the work bounds, feasible draws, random selection and the
// reports. Solis & Wets is solis_wets.cc, exchange exchange.cc; what they share is planning_internal.h.
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

#include "planning_internal.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"

namespace robocal {

using namespace planning_detail;

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
  const std::int64_t validation = ValidationDrawsOf(options);
  PlanWork work;
  work.evaluations = CappedBy(SaturatingProduct(options.restarts + 1, per_run), options.max_evaluations);
  if (options.candidates.given()) {
    // Over candidates: each candidate's block once, every set's normal matrix from them; the predicate once per
    // candidate (and for the drawn validation sample).
    const std::int64_t pool = static_cast<std::int64_t>(options.candidates.configurations->size());
    work.jacobians = SaturatingSum(pool, ValidationJacobiansOf(options));
    if (options.feasible) {
      work.feasibility_checks = SaturatingSum(pool, SaturatingProduct(options.max_draws_per_configuration, validation));
    }
    return work;
  }
  work.jacobians =
      SaturatingSum(SaturatingProduct(work.evaluations, num_configurations), ValidationJacobiansOf(options));
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
  const std::int64_t validation = ValidationDrawsOf(options);
  const std::int64_t drawn = SaturatingProduct(options.num_sets, num_configurations);
  PlanWork work;
  work.evaluations = options.num_sets;
  work.jacobians = SaturatingSum(drawn, ValidationJacobiansOf(options));
  if (options.candidates.given()) {
    if (options.feasible) {
      work.feasibility_checks = SaturatingSum(static_cast<std::int64_t>(options.candidates.configurations->size()),
                                              SaturatingProduct(options.max_draws_per_configuration, validation));
    }
    return work;
  }
  if (options.feasible) {
    work.feasibility_checks = SaturatingProduct(options.max_draws_per_configuration, SaturatingSum(drawn, validation));
  }
  return work;
}

PlanWork MaxPlanWork(int num_configurations, const ExchangeOptions& options) {
  const bool given = options.candidates.given();
  // A plan from candidates has at most the given candidates in its pool.
  const std::int64_t pool =
      given ? static_cast<std::int64_t>(options.candidates.configurations->size()) : options.num_candidates;
  const std::int64_t outside = std::max<std::int64_t>(0, pool - num_configurations);
  const std::int64_t per_iteration = pool + std::min<std::int64_t>(options.screen, outside);
  PlanWork work;
  work.evaluations = CappedBy(
      std::min(SaturatingProduct(options.max_iterations, per_iteration), std::numeric_limits<std::int64_t>::max() - 1) +
          1,
      options.max_evaluations);
  const std::int64_t validation = ValidationDrawsOf(options);
  work.jacobians = SaturatingSum(pool, ValidationJacobiansOf(options));
  if (options.feasible) {
    work.feasibility_checks =
        given ? SaturatingSum(pool, SaturatingProduct(options.max_draws_per_configuration, validation))
              : SaturatingProduct(options.max_draws_per_configuration, SaturatingSum(pool, validation));
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


Plan PlanRandom(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                const RandomSelectionOptions& options) {
  std::string error;
  const bool valid = options.IsValid(&error);
  CheckCommon(model, num_configurations, observability, valid, "RandomSelectionOptions: " + error);
  CheckTask(model, options.task);
  const bool from_candidates = options.candidates.given();
  const auto start_time = Clock::now();
  Plan plan = StartPlan("random", options.objective);
  PlanSummary& s = plan.summary;
  UsableCandidates usable;
  if (!CheckCandidatesForPlan(model, options.candidates, options.feasible, num_configurations, start_time, &usable,
                              &plan)) {
    return plan;
  }
  ObservabilityEvaluator evaluator(model, observability);
  Rng rng(options.seed);
  FeasibleDraws account;
  const std::int64_t drawn =
      PrepareDraws(model, options, from_candidates ? 0 : SaturatingProduct(options.num_sets, num_configurations),
                   start_time, &evaluator, &account, &plan);
  if (drawn < 0) return plan;
  double best_f = std::numeric_limits<double>::infinity();
  bool cancelled = false;
  for (int set = 0; set < options.num_sets; ++set) {
    std::vector<Eigen::VectorXd> configurations;
    std::vector<int> indices;
    if (from_candidates) {
      // M distinct usable candidates, drawn as the exchange optimiser draws its start.
      indices = DrawDistinct(usable.indices, num_configurations, &rng);
      for (int i : indices) configurations.push_back((*options.candidates.configurations)[i]);
    } else if (!DrawFeasibleConfigurations(model, num_configurations, options.feasible, &rng, &account,
                                           &configurations)) {
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
      plan.candidate_indices = std::move(indices);
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
  s.cancelled = cancelled;
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
  if (candidates.num_candidates > 0) out << "  candidates: " << candidates.Describe() << "\n";
  return out.str();
}

}  // namespace robocal
