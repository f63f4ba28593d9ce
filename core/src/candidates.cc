// Plans from the cell's own configurations: the check of a candidate pool (shared by the planners), the cell's
// reasons, coverage, task configurations and the predicted error against the number of poses.
#include "robocal/core/candidates.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "planning_internal.h"
#include "robocal/core/arm_kinematics.h"
#include "robocal/core/column_scaling.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"

namespace robocal {

using namespace planning_detail;

namespace {

constexpr const char* kJointCount = "joint_count";
constexpr const char* kNotFinite = "not_finite";
constexpr const char* kBeyondLimits = "beyond_limits";
constexpr const char* kInfeasible = "infeasible";

// The coverage's cuts, those of the predicted_error index (observability.cc): an eigenvalue of the unit-column
// normal matrix at most this fraction of the largest determines nothing (cond(E*) ~1e6), and a parameter with a
// larger share than kNullShare in such directions is not determined.
constexpr double kNullEigenvalue = 1e-12;
constexpr double kNullShare = 1e-6;

// Why a candidate is malformed, or nullptr.
const char* Malformed(const RobotModel& model, const Eigen::VectorXd& q) {
  if (q.size() != model.num_joints()) return kJointCount;
  if (!q.allFinite()) return kNotFinite;
  if (!model.WithinLimits(q)) return kBeyondLimits;
  return nullptr;
}

std::string MalformedMessage(const char* reason, int index, const RobotModel& model, const Eigen::VectorXd& q) {
  const std::string name = "candidates[" + std::to_string(index) + "]";
  if (reason == kJointCount) {
    return name + " has " + std::to_string(q.size()) + " joint values, the model " + std::to_string(model.num_joints());
  }
  if (reason == kNotFinite) return name + " has a value that is not finite";
  return name + " is beyond the model's joint limits";
}

void Count(const std::string& reason, int index, std::vector<CandidateRejections>* rejected) {
  auto it = std::find_if(rejected->begin(), rejected->end(),
                         [&](const CandidateRejections& r) { return r.reason == reason; });
  if (it == rejected->end()) {
    rejected->push_back({reason, 0, {}});
    it = rejected->end() - 1;
  }
  ++it->count;
  if (static_cast<int>(it->first_indices.size()) < kRejectedIndicesKept) it->first_indices.push_back(index);
}

std::string DegreesOrMm(const RobotModel& model, int joint, double value) {
  std::ostringstream out;
  out << std::setprecision(3);
  if (model.joint_type(joint) == JointType::kRevolute) {
    out << value * 180.0 / std::numbers::pi << " deg";
  } else {
    out << value << " mm";
  }
  return out.str();
}

std::string ParameterName(const RobotModel& model, int k) {
  if (k < model.num_error_parameters()) return model.parameter_name(k);
  const int r = (k - model.num_error_parameters()) / 3;
  return "reflector " + std::to_string(r + 1) + " d" + std::string(1, "xyz"[(k - model.num_error_parameters()) % 3]);
}

// Predicted 1-sigma of each parameter from the normal matrix A (L x L), as ParameterDetermination::std says.
Eigen::VectorXd ParameterStd(const Eigen::MatrixXd& normal) {
  const Eigen::Index l = normal.rows();
  const double inf = std::numeric_limits<double>::infinity();
  const Eigen::VectorXd d = UnitColumnFactors(normal.diagonal().cwiseMax(0.0).cwiseSqrt());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(d.asDiagonal() * normal * d.asDiagonal());
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const Eigen::MatrixXd& v = eig.eigenvectors();
  const double cut = kNullEigenvalue * std::max(lambda.maxCoeff(), 0.0);
  Eigen::VectorXd out(l);
  for (Eigen::Index k = 0; k < l; ++k) {
    if (d[k] == 0.0) {
      out[k] = inf;
      continue;
    }
    double variance = 0.0, null_share = 0.0;
    for (Eigen::Index i = 0; i < l; ++i) {
      if (lambda[i] > cut) {
        variance += v(k, i) * v(k, i) / lambda[i];
      } else {
        null_share += v(k, i) * v(k, i);
      }
    }
    out[k] = null_share > kNullShare ? inf : d[k] * std::sqrt(variance);
  }
  return out;
}

Eigen::MatrixXd NormalOf(ObservabilityEvaluator* evaluator, const std::vector<Eigen::VectorXd>& configurations) {
  const int l = static_cast<int>(evaluator->options().parameters.size());
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(l, l);
  for (const Eigen::VectorXd& q : configurations) {
    const Eigen::MatrixXd b = evaluator->Block(q);
    normal.noalias() += b.transpose() * b;
  }
  return normal;
}

}  // namespace

namespace planning_detail {

void CheckTask(const RobotModel& model, const TaskConfigurations& task) {
  if (!task) return;
  if (task->empty()) throw std::invalid_argument("task: no configurations");
  for (size_t i = 0; i < task->size(); ++i) {
    const Eigen::VectorXd& q = (*task)[i];
    if (q.size() != model.num_joints()) {
      throw std::invalid_argument("task[" + std::to_string(i) + "] has " + std::to_string(q.size()) +
                                  " joint values, the model " + std::to_string(model.num_joints()));
    }
    if (!q.allFinite()) throw std::invalid_argument("task[" + std::to_string(i) + "] has a value that is not finite");
  }
}

UsableCandidates CheckCandidates(const RobotModel& model, const CandidatePool& pool,
                                 const FeasibilityPredicate& feasible) {
  UsableCandidates out;
  const std::vector<Eigen::VectorXd>& candidates = *pool.configurations;
  out.account.num_candidates = static_cast<int>(candidates.size());
  // The malformed reasons come first in the account, in this order, whatever order they occur in.
  std::vector<CandidateRejections> malformed, infeasible;
  for (size_t i = 0; i < candidates.size(); ++i) {
    const int index = static_cast<int>(i);
    const Eigen::VectorXd& q = candidates[i];
    if (const char* reason = Malformed(model, q)) {
      if (pool.malformed == MalformedCandidates::kThrow) {
        throw std::invalid_argument(MalformedMessage(reason, index, model, q));
      }
      Count(reason, index, &malformed);
      continue;
    }
    if (feasible && !feasible(q)) {
      std::vector<std::string> reasons;
      if (pool.infeasibility_reasons) reasons = pool.infeasibility_reasons(q);
      if (reasons.empty()) reasons.push_back(kInfeasible);
      for (const std::string& reason : reasons) Count(reason, index, &infeasible);
      continue;
    }
    out.indices.push_back(index);
  }
  for (const char* reason : {kJointCount, kNotFinite, kBeyondLimits}) {
    for (CandidateRejections& r : malformed) {
      if (r.reason == reason) out.account.rejected.push_back(std::move(r));
    }
  }
  for (CandidateRejections& r : infeasible) out.account.rejected.push_back(std::move(r));
  out.account.num_usable = static_cast<int>(out.indices.size());
  return out;
}

bool CheckCandidatesForPlan(const RobotModel& model, const CandidatePool& pool, const FeasibilityPredicate& feasible,
                            int num_configurations, Clock::time_point start_time, UsableCandidates* usable,
                            Plan* plan) {
  if (!pool.given()) return true;
  *usable = CheckCandidates(model, pool, feasible);
  PlanSummary& s = plan->summary;
  s.candidates = usable->account;
  if (static_cast<int>(usable->indices.size()) >= num_configurations) return true;
  plan->configurations.clear();
  plan->candidate_indices.clear();
  s.termination = Termination::kFailure;
  s.message = "too few usable candidates: " + std::to_string(num_configurations) + " configurations asked, " +
              usable->account.Describe();
  s.seconds = Seconds(start_time);
  return false;
}

PoolBlocks CandidateBlocks(const std::vector<Eigen::VectorXd>& candidates, const std::vector<int>& usable,
                           ObservabilityEvaluator* evaluator) {
  const ObservabilityOptions& o = evaluator->options();
  PoolBlocks pool(o.RowsPerConfiguration(), static_cast<int>(o.parameters.size()), static_cast<int>(usable.size()));
  for (size_t c = 0; c < usable.size(); ++c) pool.block(static_cast<int>(c)) = evaluator->Block(candidates[usable[c]]);
  return pool;
}

}  // namespace planning_detail

std::string CandidateAccount::Describe() const {
  std::ostringstream out;
  out << num_usable << " of " << num_candidates << " candidates usable";
  for (size_t r = 0; r < rejected.size(); ++r) {
    out << (r == 0 ? "; rejected: " : ", ") << rejected[r].reason << " " << rejected[r].count << " (";
    for (size_t i = 0; i < rejected[r].first_indices.size(); ++i) {
      out << (i == 0 ? "#" : ", #") << rejected[r].first_indices[i];
    }
    if (rejected[r].count > static_cast<int>(rejected[r].first_indices.size())) out << ", ...";
    out << ")";
  }
  return out.str();
}

std::function<std::vector<std::string>(const Eigen::VectorXd& q)> CellRuleReasons(const RobotModel& model,
                                                                                  const Cell& cell) {
  return [model, cell](const Eigen::VectorXd& q) {
    std::vector<std::string> names;
    for (CellRule rule : CheckConfiguration(model, cell, q).failed_rules) names.push_back(ToString(rule));
    return names;
  };
}

// ---- Coverage -----------------------------------------------------------------------------------------------

bool CoverageOptions::IsValid(std::string* error) const {
  if (!(max_std_ratio > 1.0) || !std::isfinite(max_std_ratio)) {
    *error = "max_std_ratio must be finite and > 1";
    return false;
  }
  if (num_reference < 1 || num_reference > 1000000) {
    *error = "num_reference must be in [1, 1000000]";
    return false;
  }
  return true;
}

CandidateCoverage AnalyseCoverage(const RobotModel& model, const ObservabilityOptions& observability,
                                  const std::vector<Eigen::VectorXd>& configurations, const CoverageOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("CoverageOptions: " + error);
  if (configurations.empty()) throw std::invalid_argument("AnalyseCoverage: no configurations");
  for (size_t i = 0; i < configurations.size(); ++i) {
    if (const char* reason = Malformed(model, configurations[i]); reason != nullptr && reason != kBeyondLimits) {
      throw std::invalid_argument(MalformedMessage(reason, static_cast<int>(i), model, configurations[i]));
    }
  }
  ObservabilityEvaluator evaluator(model, observability);
  const int n = model.num_joints();
  const int m = static_cast<int>(configurations.size());
  const int l = static_cast<int>(observability.parameters.size());
  CandidateCoverage out;
  out.num_configurations = m;
  for (int j = 0; j < n; ++j) {
    JointCoverage c;
    c.name = "joint " + std::to_string(j + 1);
    // The model's own name beside the number, unless it only repeats it ("joint2").
    if (model.joint_name(j) != "joint" + std::to_string(j + 1)) c.name += " (" + model.joint_name(j) + ")";
    c.min = c.max = configurations[0][j];
    for (const Eigen::VectorXd& q : configurations) {
      c.min = std::min(c.min, q[j]);
      c.max = std::max(c.max, q[j]);
    }
    c.lower_limit = model.lower_limits()[j];
    c.upper_limit = model.upper_limits()[j];
    c.fraction = (c.max - c.min) / (c.upper_limit - c.lower_limit);
    out.joints.push_back(c);
  }
  // The spread reference, scaled to M configurations (a standard deviation falls as 1 / sqrt(M)).
  Rng reference_rng(options.seed);
  const Eigen::VectorXd reference_std =
      ParameterStd(NormalOf(&evaluator, RandomConfigurations(model, options.num_reference, &reference_rng))) *
      std::sqrt(static_cast<double>(options.num_reference) / m);
  const Eigen::VectorXd stds = ParameterStd(NormalOf(&evaluator, configurations));
  for (int k = 0; k < l; ++k) {
    ParameterDetermination p;
    p.parameter = observability.parameters[k];
    p.name = ParameterName(model, p.parameter);
    p.std = stds[k];
    p.reference_std = reference_std[k];
    p.std_ratio = stds[k] / reference_std[k];
    if (!(p.std_ratio <= options.max_std_ratio)) out.poorly_determined.push_back(k);
    out.parameters.push_back(std::move(p));
  }
  if (out.poorly_determined.empty()) return out;
  // Which joint's narrow range is the cause: spread it alone and see which poorly determined parameters recover.
  for (int j = 0; j < n; ++j) {
    Rng rng(options.seed + 1 + j);
    std::vector<Eigen::VectorXd> spread = configurations;
    for (Eigen::VectorXd& q : spread) q[j] = rng.Uniform(model.lower_limits()[j], model.upper_limits()[j]);
    const Eigen::VectorXd spread_std = ParameterStd(NormalOf(&evaluator, spread));
    for (int k : out.poorly_determined) {
      if (spread_std[k] / reference_std[k] <= options.max_std_ratio) {
        out.parameters[k].joints.push_back(j);
        out.joints[j].too_narrow = true;
      }
    }
    if (out.joints[j].too_narrow) out.narrow_joints.push_back(j);
  }
  std::ostringstream w;
  w << std::setprecision(3);
  if (out.narrow_joints.empty()) {
    w << "no single joint's range explains it, but ";
  } else {
    for (size_t i = 0; i < out.narrow_joints.size(); ++i) {
      const JointCoverage& c = out.joints[out.narrow_joints[i]];
      w << (i == 0 ? "" : ", ") << c.name << " (" << DegreesOrMm(model, out.narrow_joints[i], c.max - c.min) << " of "
        << DegreesOrMm(model, out.narrow_joints[i], c.upper_limit - c.lower_limit) << ", " << 100.0 * c.fraction
        << " %)";
    }
    w << (out.narrow_joints.size() == 1 ? " is" : " are") << " too narrow: ";
  }
  w << out.poorly_determined.size() << " of " << l << " parameters are determined more than " << options.max_std_ratio
    << " times worse than by as many spread configurations: ";
  for (size_t i = 0; i < out.poorly_determined.size(); ++i) {
    const ParameterDetermination& p = out.parameters[out.poorly_determined[i]];
    w << (i == 0 ? "" : ", ") << p.name;
    if (std::isfinite(p.std_ratio)) {
      w << " (" << p.std_ratio << "x)";
    } else {
      w << " (undetermined)";
    }
  }
  out.warning = w.str();
  return out;
}

// ---- Task configurations ------------------------------------------------------------------------------------

bool planning_detail::ShiftIntoLimits(const RobotModel& model, Eigen::VectorXd* q) {
  constexpr double kTurn = 2.0 * std::numbers::pi;
  for (int j = 0; j < model.num_joints(); ++j) {
    const double lo = model.lower_limits()[j], hi = model.upper_limits()[j];
    double& v = (*q)[j];
    if (v >= lo && v <= hi) continue;
    if (model.joint_type(j) != JointType::kRevolute) return false;
    const double shifted = v + kTurn * std::ceil((lo - v) / kTurn);
    if (shifted > hi) return false;
    v = shifted;
  }
  return true;
}

namespace {

void CheckTaskBox(const TaskBox& box, int count, int max_attempts_per_configuration) {
  if (count < 1) throw std::invalid_argument("SampleTaskConfigurations: count must be >= 1");
  if (max_attempts_per_configuration < 1) {
    throw std::invalid_argument("SampleTaskConfigurations: max_attempts_per_configuration must be >= 1");
  }
  if (!box.min_mm.allFinite() || !box.max_mm.allFinite() || (box.min_mm.array() > box.max_mm.array()).any()) {
    throw std::invalid_argument("task box: min_mm and max_mm must be finite with min_mm <= max_mm");
  }
  for (size_t i = 0; i < box.orientations.size(); ++i) {
    const Eigen::Matrix3d& r = box.orientations[i];
    if (!r.allFinite() || !(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-6) ||
        std::abs(r.determinant() - 1.0) > 1e-6) {
      throw std::invalid_argument("task box: orientations[" + std::to_string(i) + "] is not a rotation");
    }
  }
}

}  // namespace

TaskSample SampleTaskConfigurations(const RobotModel& model, const TaskBox& box, int count, std::uint64_t seed,
                                    int max_attempts_per_configuration) {
  CheckTaskBox(box, count, max_attempts_per_configuration);
  TaskSample out;
  Rng rng(seed);
  const std::int64_t max_attempts = static_cast<std::int64_t>(max_attempts_per_configuration) * count;
  auto point_in_box = [&]() {
    Eigen::Vector3d p;
    for (int i = 0; i < 3; ++i) p[i] = rng.Uniform(box.min_mm[i], box.max_mm[i]);
    return p;
  };
  const std::optional<ArmSolver> solver = box.orientations.empty() ? std::nullopt : ArmSolver::For(model);
  if (solver) {
    out.method = kTaskByInverseKinematics;
    const Eigen::VectorXd reference = 0.5 * (model.lower_limits() + model.upper_limits());
    while (static_cast<int>(out.configurations.size()) < count && out.attempts < max_attempts) {
      ++out.attempts;
      Transform T_base_tool = Transform::Identity();
      T_base_tool.translation() = point_in_box();
      T_base_tool.linear() = box.orientations[rng.Index(box.orientations.size())];
      std::vector<Eigen::VectorXd> reachable;
      for (ArmSolution& s : solver->Solve(T_base_tool, reference)) {
        // Exact solutions only: the stretched ones just beyond reach are starts for compensation, not poses.
        if (s.position_error_mm > 1e-6 || s.orientation_error_rad > 1e-9) continue;
        if (ShiftIntoLimits(model, &s.joints)) reachable.push_back(std::move(s.joints));
      }
      if (reachable.empty()) {
        ++out.failures;
        continue;
      }
      out.configurations.push_back(reachable[rng.Index(reachable.size())]);
    }
  } else {
    out.method = kTaskByRejectionSampling;
    const Transform T_base_world = model.T_world_base().inverse();
    while (static_cast<int>(out.configurations.size()) < count && out.attempts < max_attempts) {
      ++out.attempts;
      const Eigen::VectorXd q = RandomConfiguration(model, &rng);
      const Eigen::Vector3d p = T_base_world * ForwardKinematics(model, q).translation();
      if ((p.array() >= box.min_mm.array()).all() && (p.array() <= box.max_mm.array()).all()) {
        out.configurations.push_back(q);
      } else {
        ++out.failures;
      }
    }
  }
  out.complete = static_cast<int>(out.configurations.size()) == count;
  std::ostringstream m;
  m << out.configurations.size() << " of " << count << " task configurations by " << out.method << " in "
    << out.attempts << " attempts";
  if (out.method == kTaskByRejectionSampling) {
    m << (box.orientations.empty() ? " (any orientation)"
                                   : " (the model has no closed-form inverse kinematics: orientations not imposed)");
  }
  if (!out.complete) m << "; the box is mostly out of reach";
  out.message = m.str();
  return out;
}

// ---- How many poses -----------------------------------------------------------------------------------------

bool PoseCountOptions::IsValid(std::string* error) const {
  for (size_t i = 0; i < num_configurations.size(); ++i) {
    if (num_configurations[i] < 1 || (i > 0 && num_configurations[i] <= num_configurations[i - 1])) {
      *error = "num_configurations must be strictly ascending, each >= 1";
      return false;
    }
  }
  if (!(accuracy_goal_mm >= 0.0) || !std::isfinite(accuracy_goal_mm)) {
    *error = "accuracy_goal_mm must be finite and >= 0";
    return false;
  }
  if (!exchange.candidates.given()) {
    *error = "exchange.candidates must be given";
    return false;
  }
  if (!exchange.IsValid(error)) {
    *error = "exchange: " + *error;
    return false;
  }
  return true;
}

namespace {

// The first N by the exchange optimiser, from a seeded random start as PlanExchange draws it (of `count`
// candidates); its summary in *summary.
ExchangeOutcome FirstPoseCountSet(const PoolBlocks& pool, int count, int n, const ExchangeOptions& x,
                                  const ObservabilityEvaluator& evaluator, PlanSummary* summary) {
  Rng rng(x.seed);
  std::vector<int> all(count);
  std::iota(all.begin(), all.end(), 0);
  summary->method = "exchange";
  summary->objective = x.objective;
  ExchangeOutcome first = RunExchange(pool, DrawDistinct(std::move(all), n, &rng), x, evaluator, summary);
  summary->final = first.indices;
  summary->termination = first.converged ? Termination::kConvergence : Termination::kNoConvergence;
  summary->message = first.cancelled ? "cancelled" : first.converged ? "converged" : "stopped by its limits";
  summary->cancelled = first.cancelled;
  return first;
}

// The smallest N that reaches the accuracy goal (out->chosen), or the curve's ends without one, said in *m.
void ChoosePoseCount(const PoseCountOptions& options, double model_error_mm, PoseCountCurve* out,
                     std::ostringstream* m) {
  if (options.accuracy_goal_mm > 0.0) {
    for (size_t i = 0; i < out->points.size() && out->chosen < 0; ++i) {
      if (out->points[i].predicted_error_mm <= options.accuracy_goal_mm) out->chosen = static_cast<int>(i);
    }
    if (out->chosen >= 0) {
      *m << "N = " << out->points[out->chosen].num_configurations << " reaches the goal of " << options.accuracy_goal_mm
         << " mm (predicted " << out->points[out->chosen].predicted_error_mm << " mm)";
    } else if (!out->points.empty()) {
      *m << "no N up to " << out->points.back().num_configurations << " reaches the goal of "
         << options.accuracy_goal_mm << " mm: the prediction is " << out->points.back().predicted_error_mm
         << " mm there (model error " << model_error_mm << " mm)";
    }
  } else if (!out->points.empty()) {
    *m << "predicted error " << out->points.front().predicted_error_mm
       << " mm at N = " << out->points.front().num_configurations << ", " << out->points.back().predicted_error_mm
       << " mm at N = " << out->points.back().num_configurations;
  }
}

}  // namespace

PoseCountCurve PlanPoseCount(const RobotModel& model, const ObservabilityOptions& observability,
                             const PoseCountOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("PoseCountOptions: " + error);
  if (!observability.IsValid(model, &error)) throw std::invalid_argument("ObservabilityOptions: " + error);
  const ExchangeOptions& x = options.exchange;
  CheckTask(model, x.task);
  std::vector<int> ns = options.num_configurations;
  if (ns.empty()) {
    for (int n = 6; n <= 60; ++n) ns.push_back(n);
  }
  const UsableCandidates usable = CheckCandidates(model, x.candidates, x.feasible);
  const auto start_time = Clock::now();
  PoseCountCurve out;
  out.candidates = usable.account;
  const int count = static_cast<int>(usable.indices.size());
  if (count < ns.front()) {
    out.message = "too few usable candidates: " + std::to_string(ns.front()) + " configurations asked, " +
                  usable.account.Describe();
    out.seconds = Seconds(start_time);
    return out;
  }
  ObservabilityEvaluator evaluator(model, observability);
  // The curve needs the validation sample whatever the objective.
  FeasibleDraws account = DrawBudget(x.max_draws_per_configuration, x.task ? 0 : x.num_validation);
  if (!SetUpObjective(model, x.objective, x.num_validation, x.seed, x.feasible, x.task, &account, &evaluator, true)) {
    out.message = "too few feasible configurations for the validation sample: " + account.Describe();
    out.seconds = Seconds(start_time);
    return out;
  }
  const std::vector<Eigen::VectorXd>& candidates = *x.candidates.configurations;
  const PoolBlocks pool = CandidateBlocks(candidates, usable.indices, &evaluator);
  ExchangeOutcome first = FirstPoseCountSet(pool, count, ns.front(), x, evaluator, &out.exchange);
  std::vector<int> members = std::move(first.members);
  std::vector<char> in_set(count, 0);
  for (int j : members) in_set[j] = 1;
  Eigen::MatrixXd normal = pool.Normal(members);
  // Then each further N by one addition: nested sets, so the predicted error cannot rise with N.
  for (int n : ns) {
    if (n > count || first.cancelled) break;
    while (static_cast<int>(members.size()) < n) {
      const int add = BestAddition(pool, normal, in_set, static_cast<int>(members.size()) + 1, evaluator, x.objective,
                                   x.screen, &out.addition_evaluations)
                          .candidate;
      members.push_back(add);
      in_set[add] = 1;
      normal += pool.Contribution(add);
    }
    PoseCountPoint point;
    point.num_configurations = n;
    point.predicted_error_mm = Finite(evaluator.PredictedError(normal));
    point.log_det = evaluator.IndicesOf(normal, n).log_det;
    for (int j : members) {
      point.candidate_indices.push_back(usable.indices[j]);
      point.configurations.push_back(candidates[usable.indices[j]]);
    }
    out.points.push_back(std::move(point));
  }
  std::ostringstream m;
  m << std::setprecision(3);
  ChoosePoseCount(options, observability.model_error_mm, &out, &m);
  if (first.cancelled) {
    out.termination = Termination::kNoConvergence;
    m << (m.tellp() > 0 ? "; " : "") << "cancelled";
  } else if (out.points.size() < ns.size()) {
    out.termination = Termination::kDegraded;
    m << (m.tellp() > 0 ? "; " : "") << "the curve stops at N = " << count << ": " << usable.account.Describe();
  } else {
    out.termination = Termination::kConvergence;
  }
  out.message = m.str();
  out.seconds = Seconds(start_time);
  return out;
}

}  // namespace robocal
