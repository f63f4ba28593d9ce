// The Solis & Wets random search over whole configuration sets (Solis & Wets 1981; Wang & Zhang 2007), in the joint
// space or over a candidate pool.
#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "planning_internal.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/planning.h"
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

// Solis & Wets over a candidate pool: the usable candidates in normalised coordinates (one column each, as the
// pool's blocks are ordered) and their blocks. Snap puts each configuration of a step on the nearest candidate
// (Euclidean in normalised coordinates, ties to the lower index) that no earlier configuration of the same set took:
// a configuration the step moved less than half the distance to a neighbour stays on its own candidate, one moved
// far lands near where the step sent it, so sigma keeps its meaning (a fraction of each joint's range).
struct CandidateSnap {
  Eigen::MatrixXd z;  // num_joints x pool size
  const PoolBlocks* blocks = nullptr;

  Eigen::VectorXd Snap(Eigen::VectorXd to, std::vector<int>* members) const {
    const Eigen::Index n = z.rows();
    const int m_count = static_cast<int>(to.size() / n);
    members->assign(m_count, -1);
    std::vector<char> taken(z.cols(), 0);
    for (int m = 0; m < m_count; ++m) {
      const Eigen::VectorXd distance = (z.colwise() - to.segment(m * n, n)).colwise().squaredNorm().transpose();
      int best = -1;
      for (Eigen::Index c = 0; c < z.cols(); ++c) {
        if (!taken[c] && (best < 0 || distance[c] < distance[best])) best = static_cast<int>(c);
      }
      taken[best] = 1;
      (*members)[m] = best;
      to.segment(m * n, n) = z.col(best);
    }
    return to;
  }
};

// One search in normalised coordinates: the objective of candidate sets (counted in the summary), the cell's
// rule for infeasible configurations, the evaluation budget, and the best set over its runs. Run() is one run of
// k_max Solis & Wets iterations from a starting set; the planner restarts it.
class SolisWetsSearch {
 public:
  // `snap`: the search over candidates (null: the joint space).
  SolisWetsSearch(const RobotModel& model, const SolisWetsOptions& options, const Normaliser& normaliser,
                  ObservabilityEvaluator* evaluator, Rng* rng, PlanSummary* summary, const CandidateSnap* snap)
      : options_(options),
        snap_(snap),
        normaliser_(normaliser),
        evaluator_(*evaluator),
        rng_(*rng),
        s_(*summary),
        n_(model.num_joints()),
        total_iterations_(options.k_max * (options.restarts + 1)),
        whole_set_(options.cell_step == SolisWetsOptions::CellStep::kWholeSet),
        hold_(options.feasible && !whole_set_ && snap == nullptr) {}

  bool budget_left() const { return options_.max_evaluations == 0 || s_.evaluations < options_.max_evaluations; }

  // One run from the starting set x (normalised coordinates; over candidates, the candidates `members`) (`first`:
  // the plan's first, whose indices are the summary's initial ones). False when the budget ran out or the caller
  // cancelled (summary.cancelled).
  bool Run(Eigen::VectorXd x, std::vector<int> members, bool first) {
    double fx = Evaluate(x, false, members);
    ObservabilityIndices x_indices = last_indices_;
    if (first) s_.initial = x_indices;
    if (fx < best_f_ || best_z_.size() == 0) Keep(x, members, fx, x_indices);
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
      std::vector<int> xi_members;
      Eigen::VectorXd xi = Project(x + options_.step_fraction * d, options_.limits);
      if (snap_) {
        xi = snap_->Snap(xi, &xi_members);
        moved = xi_members != members;
      } else if (hold_) {
        xi = HoldInfeasible(x, xi, &moved);
      }
      // Over candidates the step taken is the snapped one: mu follows where the search went.
      const Eigen::VectorXd d_taken = (xi - x) / options_.step_fraction;
      // (3) forward step, then the reversed step.
      const double f_xi = EvaluateStep(xi, moved, xi_members);
      if (f_xi < fx) {
        x = xi;
        members = std::move(xi_members);
        fx = f_xi;
        x_indices = last_indices_;
        mu = 0.2 * mu + 0.4 * d_taken;
        ++scent;
        fcent = 0;
      } else {
        Eigen::VectorXd reverse = Project(2.0 * x - xi, options_.limits);
        bool reverse_moved = true;
        std::vector<int> reverse_members;
        if (snap_) {
          reverse = snap_->Snap(reverse, &reverse_members);
          reverse_moved = reverse_members != members;
        } else if (hold_) {
          reverse = HoldInfeasible(x, reverse, &reverse_moved);
        }
        const double f_reverse = budget_left() ? EvaluateStep(reverse, reverse_moved, reverse_members)
                                               : std::numeric_limits<double>::infinity();
        if (f_reverse < fx) {
          mu = mu - 0.4 * d_taken;
          x = reverse;
          members = std::move(reverse_members);
          fx = f_reverse;
          x_indices = last_indices_;
          ++scent;
          fcent = 0;
        } else {
          mu = 0.5 * mu;
          ++fcent;
          scent = 0;
        }
      }
      if (fx < best_f_) Keep(x, members, fx, x_indices);
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
  // Over candidates: the best set's pool members.
  const std::vector<int>& best_members() const { return best_members_; }
  // The best set's indices, kept with it so that the result needs no evaluation beyond the counted ones.
  ObservabilityIndices& best_indices() { return best_indices_; }

 private:
  // The objective of the set z; +inf without an evaluation when `check` finds an infeasible configuration and
  // the cell's rule is kWholeSet (a failed step). Starting sets and candidates restricted by HoldInfeasible are
  // feasible by construction and need no check.
  // Over candidates the set is `members`, evaluated from their blocks (every candidate is feasible).
  double Evaluate(const Eigen::VectorXd& z, bool check, const std::vector<int>& members) {
    if (snap_) {
      ++s_.evaluations;
      last_indices_ = evaluator_.IndicesOf(snap_->blocks->Normal(members), static_cast<int>(members.size()));
      return Finite(ObjectiveValue(last_indices_, options_.objective));
    }
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
    last_indices_ = evaluator_.indices();
    return Finite(ObjectiveValue(last_indices_, options_.objective));
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

  // A step's objective: +inf (a failed step, no evaluation) when holding back, or snapping to candidates, left
  // nothing moved.
  double EvaluateStep(const Eigen::VectorXd& z, bool moved, const std::vector<int>& members) {
    return (hold_ || snap_) && !moved ? std::numeric_limits<double>::infinity() : Evaluate(z, true, members);
  }

  // The fraction done by iterations, or by the evaluation budget when that ends the search sooner.
  double FractionDone() const {
    const double by_iterations = static_cast<double>(s_.iterations) / total_iterations_;
    return options_.max_evaluations > 0
               ? std::max(by_iterations, static_cast<double>(s_.evaluations) / options_.max_evaluations)
               : by_iterations;
  }

  void Keep(const Eigen::VectorXd& z, const std::vector<int>& members, double f, const ObservabilityIndices& indices) {
    best_f_ = f;
    best_z_ = z;
    best_members_ = members;
    best_indices_ = indices;
  }

  const SolisWetsOptions& options_;
  const CandidateSnap* snap_;
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
  std::vector<int> best_members_;
  ObservabilityIndices best_indices_;
  // The indices of the last set evaluated.
  ObservabilityIndices last_indices_;
};

}  // namespace

Plan PlanSolisWets(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                   const SolisWetsOptions& options, const std::vector<Eigen::VectorXd>& initial) {
  std::string error;
  const bool valid = options.IsValid(&error);
  CheckCommon(model, num_configurations, observability, valid, "SolisWetsOptions: " + error);
  CheckTask(model, options.task);
  const bool from_candidates = options.candidates.given();
  if (from_candidates && !initial.empty()) {
    throw std::invalid_argument(
        "PlanSolisWets: a plan from candidates starts from random candidates, not a given "
        "initial set");
  }
  const Normaliser normaliser{model};
  if (!initial.empty()) CheckInitialSet(model, num_configurations, initial, normaliser, options.feasible);
  const auto start_time = Clock::now();
  Plan plan = StartPlan("solis_wets", options.objective);
  PlanSummary& s = plan.summary;
  UsableCandidates usable;
  if (!CheckCandidatesForPlan(model, options.candidates, options.feasible, num_configurations, start_time, &usable,
                              &plan)) {
    return plan;
  }
  ObservabilityEvaluator evaluator(model, observability);
  Rng rng(options.seed);
  const std::int64_t drawn_sets = from_candidates ? 0 : options.restarts + (initial.empty() ? 1 : 0);
  FeasibleDraws account;
  const std::int64_t drawn = PrepareDraws(model, options, SaturatingProduct(drawn_sets, num_configurations),
                                          start_time, &evaluator, &account, &plan);
  if (drawn < 0) return plan;
  // Over candidates: their blocks once, and their normalised coordinates for the snap.
  std::optional<PoolBlocks> blocks;
  CandidateSnap snap;
  std::vector<int> all;
  if (from_candidates) {
    const std::vector<Eigen::VectorXd>& candidates = *options.candidates.configurations;
    blocks.emplace(CandidateBlocks(candidates, usable.indices, &evaluator));
    snap.blocks = &*blocks;
    snap.z.resize(model.num_joints(), static_cast<Eigen::Index>(usable.indices.size()));
    for (size_t c = 0; c < usable.indices.size(); ++c) snap.z.col(c) = normaliser.ToZ({candidates[usable.indices[c]]});
    all.resize(usable.indices.size());
    std::iota(all.begin(), all.end(), 0);
  }
  // The search runs in normalised coordinates: a starting configuration must be feasible after that round trip.
  FeasibilityPredicate start_feasible;
  if (options.feasible) {
    start_feasible = [&](const Eigen::VectorXd& q) { return options.feasible(normaliser.RoundTrip(q)); };
  }

  SolisWetsSearch search(model, options, normaliser, &evaluator, &rng, &s, from_candidates ? &snap : nullptr);
  bool stopped = false;
  for (int run = 0; run <= options.restarts; ++run) {
    if (run > 0 && !search.budget_left()) {
      stopped = true;
      break;
    }
    std::vector<Eigen::VectorXd> start_set;
    std::vector<int> start_members;
    Eigen::VectorXd start_z;
    if (from_candidates) {
      start_members = DrawDistinct(all, num_configurations, &rng);
      start_z.resize(static_cast<Eigen::Index>(num_configurations) * model.num_joints());
      for (int m = 0; m < num_configurations; ++m) {
        start_z.segment(static_cast<Eigen::Index>(m) * model.num_joints(), model.num_joints()) =
            snap.z.col(start_members[m]);
      }
    } else {
      if (run == 0 && !initial.empty()) {
        start_set = initial;
      } else if (!DrawFeasibleConfigurations(model, num_configurations, start_feasible, &rng, &account, &start_set)) {
        FailForFeasibility(start_time, account, drawn, options.max_draws_per_configuration, &plan);
        return plan;
      }
      start_z = normaliser.ToZ(start_set);
    }
    if (!search.Run(start_z, std::move(start_members), run == 0)) {
      stopped = true;
      break;
    }
  }
  if (from_candidates) {
    for (int j : search.best_members()) {
      plan.candidate_indices.push_back(usable.indices[j]);
      plan.configurations.push_back((*options.candidates.configurations)[usable.indices[j]]);
    }
  } else {
    plan.configurations = normaliser.FromZ(search.best_z());
  }
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
