// The Solis & Wets random search over whole configuration sets (Solis & Wets 1981; Wang & Zhang 2007).
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

namespace {

// The initial set a caller gives: num_configurations configurations, each within the joint limits and feasible
// as the search sees it (after the round trip through normalised coordinates). Throws std::invalid_argument.
void CheckInitialSet(const RobotModel& model, int num_configurations, const std::vector<Eigen::VectorXd>& initial,
                     const Normaliser& normaliser, const FeasibilityPredicate& feasible) {
  if (static_cast<int>(initial.size()) != num_configurations) {
    throw std::invalid_argument("initial set has " + std::to_string(initial.size()) + " configurations, expected " +
                                std::to_string(num_configurations));
  }
  for (size_t m = 0; m < initial.size(); ++m) {
    if (!model.WithinLimits(initial[m])) {
      throw std::invalid_argument("initial[" + std::to_string(m) + "] is outside the joint limits");
    }
    if (feasible && !feasible(normaliser.RoundTrip(initial[m]))) {
      throw std::invalid_argument("initial[" + std::to_string(m) + "] is infeasible (options.feasible)");
    }
  }
}

// One search in normalised coordinates: the objective of candidate sets (counted in the summary), the cell's
// rule for infeasible configurations, the evaluation budget, and the best set over its runs. Run() is one run of
// k_max Solis & Wets iterations from a starting set; the planner restarts it.
class SolisWetsSearch {
 public:
  SolisWetsSearch(const RobotModel& model, const SolisWetsOptions& options, const Normaliser& normaliser,
                  ObservabilityEvaluator* evaluator, Rng* rng, PlanSummary* summary)
      : options_(options),
        normaliser_(normaliser),
        evaluator_(*evaluator),
        rng_(*rng),
        s_(*summary),
        n_(model.num_joints()),
        total_iterations_(options.k_max * (options.restarts + 1)),
        whole_set_(options.cell_step == SolisWetsOptions::CellStep::kWholeSet),
        hold_(options.feasible && !whole_set_) {}

  bool budget_left() const { return options_.max_evaluations == 0 || s_.evaluations < options_.max_evaluations; }

  // One run from `start_set` (`first`: the plan's first, whose indices are the summary's initial ones). False
  // when the budget ran out or the caller cancelled (summary.cancelled).
  bool Run(const std::vector<Eigen::VectorXd>& start_set, bool first) {
    Eigen::VectorXd x = normaliser_.ToZ(start_set);
    double fx = Evaluate(x, false);
    ObservabilityIndices x_indices = evaluator_.indices();
    if (first) s_.initial = x_indices;
    if (fx < best_f_ || best_z_.size() == 0) Keep(x, fx, x_indices);
    Eigen::VectorXd mu = Eigen::VectorXd::Zero(x.size());
    double sigma = options_.sigma0;
    int scent = 0, fcent = 0;
    for (int k = 1; k <= options_.k_max; ++k) {
      if (!budget_left()) return false;
      // (1) step size.
      if (scent > options_.scent_threshold) {
        sigma *= options_.expansion;
        if (options_.reset_counters) scent = 0;
      } else if (fcent > options_.fcent_threshold) {
        sigma *= options_.contraction;
        if (options_.reset_counters) fcent = 0;
      } else if (sigma < options_.sigma_lb) {
        sigma = options_.sigma_ub;
      }
      // (2) Gaussian step d ~ N(mu, sigma^2 I), in sigma units; one unit is step_fraction of a joint range.
      Eigen::VectorXd d(x.size());
      for (Eigen::Index i = 0; i < d.size(); ++i) d[i] = mu[i] + sigma * rng_.Normal();
      bool moved = true;
      Eigen::VectorXd xi = Project(x + options_.step_fraction * d, options_.limits);
      if (hold_) xi = HoldInfeasible(x, xi, &moved);
      const Eigen::VectorXd d_taken = (xi - x) / options_.step_fraction;
      // (3) forward step, then the reversed step.
      const double f_xi = EvaluateStep(xi, moved);
      if (f_xi < fx) {
        x = xi;
        fx = f_xi;
        x_indices = evaluator_.indices();
        mu = 0.2 * mu + 0.4 * d_taken;
        ++scent;
        fcent = 0;
      } else {
        Eigen::VectorXd reverse = Project(2.0 * x - xi, options_.limits);
        bool reverse_moved = true;
        if (hold_) reverse = HoldInfeasible(x, reverse, &reverse_moved);
        const double f_reverse =
            budget_left() ? EvaluateStep(reverse, reverse_moved) : std::numeric_limits<double>::infinity();
        if (f_reverse < fx) {
          mu = mu - 0.4 * d_taken;
          x = reverse;
          fx = f_reverse;
          x_indices = evaluator_.indices();
          ++scent;
          fcent = 0;
        } else {
          mu = 0.5 * mu;
          ++fcent;
          scent = 0;
        }
      }
      if (fx < best_f_) Keep(x, fx, x_indices);
      ++s_.iterations;
      s_.objective_trace.push_back(best_f_);
      if (options_.progress && !options_.progress(FractionDone())) {
        s_.message = "cancelled";
        s_.cancelled = true;
        return false;
      }
    }
    return true;
  }

  const Eigen::VectorXd& best_z() const { return best_z_; }
  // The best set's indices, kept with it so that the result needs no evaluation beyond the counted ones.
  ObservabilityIndices& best_indices() { return best_indices_; }

 private:
  // The objective of the set z; +inf without an evaluation when `check` finds an infeasible configuration and
  // the cell's rule is kWholeSet (a failed step). Starting sets and candidates restricted by HoldInfeasible are
  // feasible by construction and need no check.
  double Evaluate(const Eigen::VectorXd& z, bool check) {
    const std::vector<Eigen::VectorXd> configurations = normaliser_.FromZ(z);
    if (check && options_.feasible && whole_set_) {
      for (const Eigen::VectorXd& q : configurations) {
        if (!options_.feasible(q)) {
          ++s_.infeasible_candidates;
          return std::numeric_limits<double>::infinity();
        }
      }
    }
    evaluator_.SetConfigurations(configurations);
    ++s_.evaluations;
    return Finite(ObjectiveValue(evaluator_.indices(), options_.objective));
  }

  // kFeasibleConfigurations: the candidate `to` with every configuration whose move from `from` (a feasible
  // set) would be infeasible held at its place in `from`. Sets *moved to whether any configuration moved.
  Eigen::VectorXd HoldInfeasible(const Eigen::VectorXd& from, Eigen::VectorXd to, bool* moved) {
    const std::vector<Eigen::VectorXd> configurations = normaliser_.FromZ(to);
    bool held = false;
    *moved = false;
    for (size_t m = 0; m < configurations.size(); ++m) {
      if (options_.feasible(configurations[m])) {
        *moved = *moved || to.segment(m * n_, n_) != from.segment(m * n_, n_);
      } else {
        to.segment(m * n_, n_) = from.segment(m * n_, n_);
        held = true;
      }
    }
    if (held) ++s_.infeasible_candidates;
    return to;
  }

  // A step's objective: +inf (a failed step, no evaluation) when holding back left nothing to move.
  double EvaluateStep(const Eigen::VectorXd& z, bool moved) {
    return hold_ && !moved ? std::numeric_limits<double>::infinity() : Evaluate(z, true);
  }

  // The fraction done by iterations, or by the evaluation budget when that ends the search sooner.
  double FractionDone() const {
    const double by_iterations = static_cast<double>(s_.iterations) / total_iterations_;
    return options_.max_evaluations > 0
               ? std::max(by_iterations, static_cast<double>(s_.evaluations) / options_.max_evaluations)
               : by_iterations;
  }

  void Keep(const Eigen::VectorXd& z, double f, const ObservabilityIndices& indices) {
    best_f_ = f;
    best_z_ = z;
    best_indices_ = indices;
  }

  const SolisWetsOptions& options_;
  const Normaliser& normaliser_;
  ObservabilityEvaluator& evaluator_;
  Rng& rng_;
  PlanSummary& s_;
  const int n_;
  const int total_iterations_;
  const bool whole_set_;
  const bool hold_;
  double best_f_ = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_z_;
  ObservabilityIndices best_indices_;
};

}  // namespace

Plan PlanSolisWets(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                   const SolisWetsOptions& options, const std::vector<Eigen::VectorXd>& initial) {
  std::string error;
  const bool valid = options.IsValid(&error);
  CheckCommon(model, num_configurations, observability, valid, "SolisWetsOptions: " + error);
  const Normaliser normaliser{model};
  if (!initial.empty()) CheckInitialSet(model, num_configurations, initial, normaliser, options.feasible);
  const auto start_time = Clock::now();
  Plan plan = StartPlan("solis_wets", options.objective);
  PlanSummary& s = plan.summary;
  ObservabilityEvaluator evaluator(model, observability);
  Rng rng(options.seed);
  const std::int64_t drawn_sets = options.restarts + (initial.empty() ? 1 : 0);
  FeasibleDraws account;
  const std::int64_t drawn = PrepareDraws(model, options, SaturatingProduct(drawn_sets, num_configurations),
                                          start_time, &evaluator, &account, &plan);
  if (drawn < 0) return plan;
  // The search runs in normalised coordinates: a starting configuration must be feasible after that round trip.
  FeasibilityPredicate start_feasible;
  if (options.feasible) {
    start_feasible = [&](const Eigen::VectorXd& q) { return options.feasible(normaliser.RoundTrip(q)); };
  }

  SolisWetsSearch search(model, options, normaliser, &evaluator, &rng, &s);
  bool stopped = false;
  for (int run = 0; run <= options.restarts; ++run) {
    if (run > 0 && !search.budget_left()) {
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
    if (!search.Run(start_set, run == 0)) {
      stopped = true;
      break;
    }
  }
  plan.configurations = normaliser.FromZ(search.best_z());
  s.final = std::move(search.best_indices());
  if (stopped) {
    s.termination = Termination::kNoConvergence;
    if (!s.cancelled) s.message = "evaluation budget reached";
  } else {
    // Solis & Wets has no convergence test: finishing its k_max iterations is its normal end.
    s.termination = Termination::kConvergence;
    s.message = "completed " + std::to_string(s.iterations) + " iterations";
  }
  RecordDraws(account, &s);
  FinishPlan(start_time, model, observability, &plan);
  return plan;
}

}  // namespace robocal
