// Identification: ur5e from 50 and 500 full-pose measurements (distinct poses), 500 as 50 poses x 10 shots,
// and the same fits with the identifiable set given, to separate the identifiability probe from the fit.
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "robocal/core/identification.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"

namespace robocal {
namespace {

std::vector<Measurement> Measurements(const RobotModel& model, int poses, int shots) {
  VirtualCellOptions o;
  o.seed = 1;
  o.shots_per_pose = shots;
  VirtualCell cell(model, o);
  Rng rng(2);
  std::vector<Eigen::VectorXd> configurations;
  for (int i = 0; i < poses; ++i) configurations.push_back(RandomConfiguration(model, &rng));
  return cell.MeasureAll(configurations);
}

// Args: distinct poses, shots per pose, 1 if the identifiable set is given (no identifiability probe).
void BM_IdentifyUr5ePose(benchmark::State& state) {
  const RobotModel model = Preset("ur5e");
  const int poses = static_cast<int>(state.range(0)), shots = static_cast<int>(state.range(1));
  const std::vector<Measurement> measurements = Measurements(model, poses, shots);
  IdentificationOptions o;
  if (state.range(2) == 1) o.parameters = FindIdentifiableParameters(model, MeasurementType::kPose).identifiable;
  int iterations = 0;
  for (auto _ : state) {
    const Calibration cal = Identify(model, measurements, o);
    if (cal.summary.termination == Termination::kFailure) state.SkipWithError(cal.summary.message.c_str());
    iterations = cal.summary.iterations;
    benchmark::DoNotOptimize(cal.errors.data());
  }
  state.counters["lm_iterations"] = iterations;
  state.SetLabel("ur5e pose " + std::to_string(poses) + " poses x " + std::to_string(shots) + " shots" +
                 (state.range(2) == 1 ? ", parameters given" : ""));
}
BENCHMARK(BM_IdentifyUr5ePose)
    ->Args({50, 1, 0})
    ->Args({500, 1, 0})
    ->Args({50, 10, 0})
    ->Args({50, 1, 1})
    ->Args({500, 1, 1})
    ->Unit(benchmark::kMillisecond);

// For scale: the point-set registration alone, 500 points.
void BM_RegisterPoints(benchmark::State& state) {
  const RobotModel model = Preset("ur5e");
  const std::vector<Measurement> measurements = Measurements(model, 500, 1);
  std::vector<Eigen::Vector3d> from, to;
  for (const Measurement& m : measurements) {
    from.push_back(ForwardKinematics(model, m.joints).translation());
    to.push_back(m.T_world_tool.translation());
  }
  for (auto _ : state) benchmark::DoNotOptimize(RegisterPoints(from, to));
}
BENCHMARK(BM_RegisterPoints)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace robocal
