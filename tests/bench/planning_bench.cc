// Planning: one index evaluation after a single-configuration change (M = 10 and 200), the paper's Solis &
// Wets preset on grinder5, and exchange selecting 50 of 5,000 candidates on ur5e; the paper preset and the
// exchange optimiser in a cell; plans of 30 from 2,000 given candidates in the cell, and the predicted error against
// N from them.
#include <benchmark/benchmark.h>

#include "robocal/core/candidates.h"
#include "robocal/core/cell.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"

namespace robocal {
namespace {

ObservabilityOptions OptionsFor(const RobotModel& model, MeasurementType type) {
  ObservabilityOptions o;
  o.measurement_type = type;
  o.parameters = FindIdentifiableParameters(model, type).identifiable;
  return o;
}

// Args: preset (0 grinder5, 1 ur5e), M.
void BM_IncrementalEvaluation(benchmark::State& state) {
  const RobotModel model = Preset(state.range(0) == 0 ? "grinder5" : "ur5e");
  const int m = static_cast<int>(state.range(1));
  ObservabilityEvaluator evaluator(model, OptionsFor(model, MeasurementType::kPose));
  Rng rng(1);
  evaluator.SetConfigurations(RandomConfigurations(model, m, &rng));
  const auto candidates = RandomConfigurations(model, 64, &rng);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(evaluator.EvaluateReplacement(static_cast<int>(i % m), candidates[i % 64]));
    ++i;
  }
  state.SetLabel(model.name() + " pose M=" + std::to_string(m));
}
BENCHMARK(BM_IncrementalEvaluation)->ArgsProduct({{0, 1}, {10, 200}})->Unit(benchmark::kMicrosecond);

// For contrast: the full recomputation by SVD of the stacked matrix that the incremental path avoids.
void BM_FullSvdEvaluation(benchmark::State& state) {
  const RobotModel model = Preset(state.range(0) == 0 ? "grinder5" : "ur5e");
  const int m = static_cast<int>(state.range(1));
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  Rng rng(1);
  const auto configurations = RandomConfigurations(model, m, &rng);
  for (auto _ : state) benchmark::DoNotOptimize(ComputeIndicesBySvd(model, configurations, o));
  state.SetLabel(model.name() + " pose M=" + std::to_string(m));
}
BENCHMARK(BM_FullSvdEvaluation)->ArgsProduct({{0, 1}, {10, 200}})->Unit(benchmark::kMicrosecond);

// Arg: measurement type (0 position, 2 pose).
void BM_SolisWetsPaperGrinder5(benchmark::State& state) {
  const RobotModel model = Preset("grinder5");
  const auto type = static_cast<MeasurementType>(state.range(0));
  const ObservabilityOptions o = OptionsFor(model, type);
  std::uint64_t seed = 1;
  for (auto _ : state) {
    SolisWetsOptions options = SolisWetsOptions::Paper();
    options.seed = seed++;
    benchmark::DoNotOptimize(PlanSolisWets(model, 10, o, options));
  }
  state.SetLabel(std::string("grinder5 M=10 ") + ToString(type));
}
BENCHMARK(BM_SolisWetsPaperGrinder5)->Arg(0)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_ExchangeUr5e(benchmark::State& state) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  for (auto _ : state) {
    ExchangeOptions options;
    options.num_candidates = 5000;
    const Plan plan = PlanExchange(model, 50, o, options);
    state.counters["iterations"] = plan.summary.iterations;
    state.counters["cond"] = plan.summary.final.condition_number;
  }
  state.SetLabel("ur5e pose M=50 of 5000");
}
BENCHMARK(BM_ExchangeUr5e)->Unit(benchmark::kMillisecond)->Iterations(1);

// A cell around ur5e: tracker 2.6 m away, a floor, a table and a wall, one reflector on the tool.
Cell BenchCell(const RobotModel& model) {
  CellSpec spec;
  spec.tracker.position_mm = Eigen::Vector3d(2500, -800, 300);
  spec.tracker.min_distance_mm = 1500;
  spec.tracker.max_distance_mm = 15000;
  spec.reflectors.push_back({"smr1", Eigen::Vector3d(0, 0, 120), Eigen::Vector3d::UnitZ(), 0.5235987755982988});
  spec.obstacles.push_back({"floor", Eigen::Vector3d(-3000, -3000, -500), Eigen::Vector3d(3000, 3000, -10)});
  spec.obstacles.push_back({"table", Eigen::Vector3d(300, 400, -10), Eigen::Vector3d(900, 1000, 200)});
  spec.obstacles.push_back({"wall", Eigen::Vector3d(-1500, -3000, -500), Eigen::Vector3d(-1400, 3000, 2500)});
  spec.clearance_mm = 20;
  return Cell::Build(model, spec);
}

// The paper preset (Solis & Wets, M = 10, pose) on ur5e without and with a cell (Arg 1): the cell's cost is its
// feasibility checks and the shorter steps near the feasible region's boundary.
void BM_SolisWetsPaperInCell(benchmark::State& state) {
  const RobotModel nominal = Preset("ur5e");
  const Cell cell = BenchCell(nominal);
  // 0: no cell; 1: in the cell, steps hold infeasible configurations back (the default); 2: in the cell, a
  // step with any infeasible configuration fails whole.
  const bool in_cell = state.range(0) != 0;
  const RobotModel model = in_cell ? cell.PlanningModel(nominal) : nominal;
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  std::uint64_t seed = 1;
  // Sums over the iterations (seeds), reported as means; start_cond: the random (feasible) starting set's.
  double cond = 0.0, start_cond = 0.0, evaluations = 0.0, infeasible = 0.0;
  for (auto _ : state) {
    SolisWetsOptions options = SolisWetsOptions::Paper();
    options.seed = seed++;
    if (in_cell) options.feasible = [&](const Eigen::VectorXd& q) { return IsFeasible(nominal, cell, q); };
    if (state.range(0) == 2) options.cell_step = SolisWetsOptions::CellStep::kWholeSet;
    const Plan plan = PlanSolisWets(model, 10, o, options);
    cond += plan.summary.final.condition_number;
    start_cond += plan.summary.initial.condition_number;
    evaluations += plan.summary.evaluations;
    infeasible += plan.summary.infeasible_candidates;
  }
  state.counters["cond"] = benchmark::Counter(cond, benchmark::Counter::kAvgIterations);
  state.counters["start_cond"] = benchmark::Counter(start_cond, benchmark::Counter::kAvgIterations);
  state.counters["evaluations"] = benchmark::Counter(evaluations, benchmark::Counter::kAvgIterations);
  state.counters["infeasible"] = benchmark::Counter(infeasible, benchmark::Counter::kAvgIterations);
  state.SetLabel(!in_cell                ? "ur5e pose M=10"
                 : state.range(0) == 1 ? "ur5e pose M=10 in a cell, infeasible configurations held"
                                       : "ur5e pose M=10 in a cell, whole-set steps");
}
BENCHMARK(BM_SolisWetsPaperInCell)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// The exchange optimiser over 5,000 candidates that are all feasible in the cell.
void BM_ExchangeUr5eInCell(benchmark::State& state) {
  const RobotModel nominal = Preset("ur5e");
  const Cell cell = BenchCell(nominal);
  const RobotModel model = cell.PlanningModel(nominal);
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  for (auto _ : state) {
    ExchangeOptions options;
    options.num_candidates = 5000;
    options.feasible = [&](const Eigen::VectorXd& q) { return IsFeasible(nominal, cell, q); };
    const Plan plan = PlanExchange(model, 50, o, options);
    state.counters["iterations"] = plan.summary.iterations;
    state.counters["draws"] = static_cast<double>(plan.summary.feasibility_draws);
  }
  state.SetLabel("ur5e pose M=50 of 5000 feasible");
}
BENCHMARK(BM_ExchangeUr5eInCell)->Unit(benchmark::kMillisecond)->Iterations(1);

// 2,000 of the cell's own configurations (here: feasible random ones, as a cell's taught or measured poses are, and
// checked against the cell again as any candidate list is), N = 30, log_det. Arg: 0 exchange, 1 Solis & Wets (paper
// preset) over the candidates, 2 random selection (best of 50 draws from the pool).
std::shared_ptr<const std::vector<Eigen::VectorXd>> FeasibleCandidates(const RobotModel& model,
                                                                       const FeasibilityPredicate& feasible,
                                                                       int count) {
  Rng rng(1);
  FeasibleDraws account;
  std::vector<Eigen::VectorXd> out;
  DrawFeasibleConfigurations(model, count, feasible, &rng, &account, &out);
  return std::make_shared<const std::vector<Eigen::VectorXd>>(std::move(out));
}

void BM_PlanFromCandidates(benchmark::State& state) {
  const RobotModel model = Preset("ur5e");
  const Cell cell = BenchCell(model);
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  const FeasibilityPredicate feasible = [&](const Eigen::VectorXd& q) { return IsFeasible(model, cell, q); };
  CandidatePool pool;
  pool.configurations = FeasibleCandidates(model, feasible, 2000);
  pool.infeasibility_reasons = CellRuleReasons(model, cell);
  for (auto _ : state) {
    Plan plan;
    if (state.range(0) == 0) {
      ExchangeOptions options;
      options.objective = ObservabilityIndex::kLogDet;
      options.feasible = feasible;
      options.candidates = pool;
      plan = PlanExchange(model, 30, o, options);
    } else if (state.range(0) == 1) {
      SolisWetsOptions options = SolisWetsOptions::Paper();
      options.objective = ObservabilityIndex::kLogDet;
      options.feasible = feasible;
      options.candidates = pool;
      plan = PlanSolisWets(model, 30, o, options);
    } else {
      RandomSelectionOptions options;
      options.num_sets = 50;
      options.objective = ObservabilityIndex::kLogDet;
      options.feasible = feasible;
      options.candidates = pool;
      plan = PlanRandom(model, 30, o, options);
    }
    state.counters["usable"] = plan.summary.candidates.num_usable;
    state.counters["iterations"] = plan.summary.iterations;
    state.counters["log_det"] = plan.summary.final.log_det;
    state.counters["start_log_det"] = plan.summary.initial.log_det;
  }
  state.SetLabel(state.range(0) == 0   ? "ur5e pose N=30 of 2000 candidates, exchange, log_det"
                 : state.range(0) == 1 ? "ur5e pose N=30 of 2000 candidates, Solis & Wets, log_det"
                                       : "ur5e pose N=30 of 2000 candidates, best of 50 random, log_det");
}
BENCHMARK(BM_PlanFromCandidates)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1);

// The predicted error against N = 6..60 from the same 2,000 candidates (the cell's checks on), predicted_error over
// 50 task configurations.
void BM_PoseCountFromCandidates(benchmark::State& state) {
  const RobotModel model = Preset("ur5e");
  const Cell cell = BenchCell(model);
  const ObservabilityOptions o = OptionsFor(model, MeasurementType::kPose);
  Rng rng(2);
  PoseCountOptions options;
  options.exchange.objective = ObservabilityIndex::kPredictedError;
  options.exchange.feasible = [&](const Eigen::VectorXd& q) { return IsFeasible(model, cell, q); };
  options.exchange.candidates.configurations = FeasibleCandidates(model, options.exchange.feasible, 2000);
  options.exchange.task = std::make_shared<const std::vector<Eigen::VectorXd>>(RandomConfigurations(model, 50, &rng));
  for (auto _ : state) {
    const PoseCountCurve curve = PlanPoseCount(model, o, options);
    state.counters["points"] = static_cast<double>(curve.points.size());
    state.counters["error_N6"] = curve.points.front().predicted_error_mm;
    state.counters["error_N60"] = curve.points.back().predicted_error_mm;
  }
  state.SetLabel("ur5e pose N=6..60 of 2000 candidates, predicted_error");
}
BENCHMARK(BM_PoseCountFromCandidates)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace robocal
