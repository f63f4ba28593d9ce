// Planning: one index evaluation after a single-configuration change (M = 10 and 200), the paper's Solis &
// Wets preset on grinder5, and exchange selecting 50 of 5,000 candidates on ur5e.
#include <benchmark/benchmark.h>

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

}  // namespace
}  // namespace robocal
