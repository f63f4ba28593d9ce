// The exchange optimiser (Fedorov-style exchange of configurations from a candidate pool, planning.h).
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
  FeasibleDraws account;
  const std::int64_t drawn = PrepareDraws(model, options, count, start_time, &evaluator, &account, &plan);
  if (drawn < 0) return plan;
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
    s.cancelled = true;
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

}  // namespace robocal
