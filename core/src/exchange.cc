// The exchange optimiser (Fedorov-style exchange of configurations from a candidate pool, planning.h): its addition
// step and iterations (shared with the pose count of candidates.h), over a drawn pool or the cell's candidates.
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

namespace planning_detail {

Addition BestAddition(const PoolBlocks& pool, const Eigen::MatrixXd& normal, const std::vector<char>& in_set, int size,
                      const ObservabilityEvaluator& evaluator, ObservabilityIndex objective, int screen,
                      int* evaluations) {
  const int l = pool.l;
  const int rows = static_cast<int>(pool.blocks.rows());
  const bool i_optimal = objective == ObservabilityIndex::kPredictedError;
  // Screen additions by the D-optimal gain log det(I + B A^-1 B') (a small ridge keeps A invertible while
  // the set is still rank deficient), then evaluate the most promising exactly. For predicted_error the gain is
  // the objective's own: adding B lowers trace(A^-1 G) by trace((I + B A^-1 B')^-1 B A^-1 G A^-1 B')
  // (Woodbury), with H = A^-1 G A^-1 formed once per addition.
  const double ridge = 1e-9 * std::max(normal.trace() / l, 1e-300);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal + ridge * Eigen::MatrixXd::Identity(l, l));
  Eigen::MatrixXd h;
  if (i_optimal) {
    const Eigen::MatrixXd a_inv_g = ldlt.solve(evaluator.validation_information());
    h = ldlt.solve(a_inv_g.transpose());
  }
  std::vector<std::pair<double, int>> gains;
  gains.reserve(pool.count());
  for (int c = 0; c < pool.count(); ++c) {
    if (in_set[c]) continue;
    const Eigen::MatrixXd u = ldlt.solve(pool.block(c).transpose());
    const Eigen::MatrixXd m = Eigen::MatrixXd::Identity(rows, rows) + pool.block(c) * u;
    ++*evaluations;
    if (i_optimal) {
      gains.emplace_back(Eigen::LDLT<Eigen::MatrixXd>(m).solve(pool.block(c) * h * pool.block(c).transpose()).trace(),
                         c);
    } else {
      gains.emplace_back(Eigen::LDLT<Eigen::MatrixXd>(m).vectorD().array().log().sum(), c);
    }
  }
  const size_t screened = std::min<size_t>(screen, gains.size());
  std::partial_sort(gains.begin(), gains.begin() + screened, gains.end(), std::greater<>());
  Addition best;
  for (size_t i = 0; i < screened; ++i) {
    ++*evaluations;
    const double f =
        Finite(ObjectiveValue(evaluator.IndicesOf(normal + pool.Contribution(gains[i].second), size), objective));
    if (best.candidate < 0 || f < best.value) {
      best.value = f;
      best.candidate = gains[i].second;
    }
  }
  return best;
}

ExchangeOutcome RunExchange(const PoolBlocks& pool, std::vector<int> members, const ExchangeOptions& options,
                            const ObservabilityEvaluator& evaluator, PlanSummary* s) {
  const int count = pool.count();
  const int num_configurations = static_cast<int>(members.size());
  std::vector<char> in_set(count, 0);
  for (int j : members) in_set[j] = 1;
  Eigen::MatrixXd normal = pool.Normal(members);
  auto evaluate = [&](const Eigen::MatrixXd& a, int size) {
    ++s->evaluations;
    return evaluator.IndicesOf(a, size);
  };
  auto value = [&](const ObservabilityIndices& x) { return Finite(ObjectiveValue(x, options.objective)); };
  ExchangeOutcome out;
  ObservabilityIndices current_indices = evaluate(normal, num_configurations);
  s->initial = current_indices;
  double current = value(current_indices);
  const int outside = count - num_configurations;
  const std::int64_t per_iteration = static_cast<std::int64_t>(count) + std::min(options.screen, outside);
  while (s->iterations < options.max_iterations) {
    if (options.max_evaluations > 0 && s->evaluations + per_iteration > options.max_evaluations) {
      out.budget_reached = true;
      break;
    }
    const int best_add = BestAddition(pool, normal, in_set, num_configurations + 1, evaluator, options.objective,
                                      options.screen, &s->evaluations)
                             .candidate;
    if (best_add < 0) break;
    // Remove whichever member (the new one included) leaves the best set of M.
    const Eigen::MatrixXd enlarged = normal + pool.Contribution(best_add);
    members.push_back(best_add);
    int best_remove = static_cast<int>(members.size()) - 1;
    double best_remove_f = current;
    ObservabilityIndices best_remove_indices;
    for (size_t i = 0; i + 1 < members.size(); ++i) {
      ObservabilityIndices x = evaluate(enlarged - pool.Contribution(members[i]), num_configurations);
      const double f = value(x);
      if (f < best_remove_f) {
        best_remove_f = f;
        best_remove = static_cast<int>(i);
        best_remove_indices = std::move(x);
      }
    }
    ++s->iterations;
    if (best_remove == static_cast<int>(members.size()) - 1 ||
        !(best_remove_f < current - 1e-12 * std::abs(current))) {
      members.pop_back();
      s->objective_trace.push_back(current);
      out.converged = true;
      break;
    }
    in_set[best_add] = 1;
    in_set[members[best_remove]] = 0;
    normal = enlarged - pool.Contribution(members[best_remove]);
    members[best_remove] = members.back();
    members.pop_back();
    current = best_remove_f;
    current_indices = std::move(best_remove_indices);
    s->objective_trace.push_back(current);
    if (options.progress) {
      double fraction = static_cast<double>(s->iterations) / std::max(1, options.max_iterations);
      if (options.max_evaluations > 0) {
        fraction = std::max(fraction, static_cast<double>(s->evaluations) / options.max_evaluations);
      }
      if (!options.progress(fraction)) {
        out.cancelled = true;
        break;
      }
    }
  }
  out.members = std::move(members);
  out.indices = std::move(current_indices);
  return out;
}

}  // namespace planning_detail

Plan PlanExchange(const RobotModel& model, int num_configurations, const ObservabilityOptions& observability,
                  const ExchangeOptions& options) {
  std::string error;
  const bool valid = options.IsValid(&error);
  CheckCommon(model, num_configurations, observability, valid, "ExchangeOptions: " + error);
  CheckTask(model, options.task);
  const bool from_candidates = options.candidates.given();
  if (!from_candidates && options.num_candidates < num_configurations) {
    throw std::invalid_argument("ExchangeOptions: num_candidates (" + std::to_string(options.num_candidates) +
                                ") must be at least the number of configurations (" +
                                std::to_string(num_configurations) + ")");
  }
  const auto start_time = Clock::now();
  Plan plan = StartPlan("exchange", options.objective);
  PlanSummary& s = plan.summary;
  UsableCandidates usable;
  if (!CheckCandidatesForPlan(model, options.candidates, options.feasible, num_configurations, start_time, &usable,
                              &plan)) {
    return plan;
  }
  ObservabilityEvaluator evaluator(model, observability);
  Rng rng(options.seed);
  const int l = static_cast<int>(observability.parameters.size());
  const int rows = observability.RowsPerConfiguration();
  FeasibleDraws account;
  const std::int64_t drawn = PrepareDraws(model, options, from_candidates ? 0 : options.num_candidates, start_time,
                                          &evaluator, &account, &plan);
  if (drawn < 0) return plan;
  // The pool: the usable candidates, or num_candidates feasible draws.
  std::vector<Eigen::VectorXd> drawn_pool;
  std::optional<PoolBlocks> pool;
  if (from_candidates) {
    pool.emplace(CandidateBlocks(*options.candidates.configurations, usable.indices, &evaluator));
  } else {
    pool.emplace(rows, l, options.num_candidates);
    drawn_pool.reserve(options.num_candidates);
    Eigen::VectorXd q;
    for (int c = 0; c < options.num_candidates; ++c) {
      if (!DrawFeasibleConfiguration(model, options.feasible, &rng, &account, &q)) {
        FailForFeasibility(start_time, account, drawn, options.max_draws_per_configuration, &plan);
        return plan;
      }
      drawn_pool.push_back(q);
      pool->block(c) = evaluator.Block(q);
    }
  }
  std::vector<int> all(pool->count());
  std::iota(all.begin(), all.end(), 0);
  ExchangeOutcome outcome =
      RunExchange(*pool, DrawDistinct(std::move(all), num_configurations, &rng), options, evaluator, &s);
  for (int j : outcome.members) {
    if (from_candidates) {
      plan.candidate_indices.push_back(usable.indices[j]);
      plan.configurations.push_back((*options.candidates.configurations)[usable.indices[j]]);
    } else {
      plan.configurations.push_back(drawn_pool[j]);
    }
  }
  s.final = std::move(outcome.indices);
  if (outcome.cancelled) {
    s.termination = Termination::kNoConvergence;
    s.message = "cancelled";
    s.cancelled = true;
  } else if (outcome.converged) {
    s.termination = Termination::kConvergence;
    s.message = "no exchange improves the objective after " + std::to_string(s.iterations) + " iterations";
  } else if (outcome.budget_reached) {
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

}  // namespace robocal
