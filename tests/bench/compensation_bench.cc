// Compensation: one target (CompensateJoints, nominal command -> calibrated joints) on grinder5 (position +
// tool axis) and ur5e (full pose), with errors of an industrial robot and the tracker 3 m away.
#include <benchmark/benchmark.h>

#include <numbers>

#include "bench_calibration.h"
#include "robocal/core/arm_kinematics.h"
#include "robocal/core/compensation.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

// The preset with the tracker 3 m away, and errors of an industrial robot.
Calibration MakeCalibration(const std::string& preset) {
  RobotModelSpec spec = PresetSpec(preset);
  spec.T_world_base = TransformFromXyzRpy({3000.0, -1200.0, 500.0}, {0.1, -0.05, 2.0});
  return bench::IndustrialCalibration(RobotModel::Build(spec));
}

// Arg: preset (0 grinder5, 1 ur5e). Cycles over 64 random nominal commands.
void BM_CompensateJoints(benchmark::State& state) {
  const std::string preset = state.range(0) == 0 ? "grinder5" : "ur5e";
  const RobotModel nominal = Preset(preset);
  const Calibration calibration = MakeCalibration(preset);
  Rng rng(2);
  std::vector<Eigen::VectorXd> commands;
  for (int i = 0; i < 64; ++i) commands.push_back(RandomConfiguration(nominal, &rng));
  size_t i = 0;
  long iterations = 0, converged = 0, targets = 0;
  for (auto _ : state) {
    const CompensationResult r = CompensateJoints(calibration, nominal, commands[i++ % commands.size()]);
    benchmark::DoNotOptimize(r.joints.data());
    iterations += r.iterations;
    converged += r.converged ? 1 : 0;
    ++targets;
  }
  state.counters["iterations"] = static_cast<double>(iterations) / static_cast<double>(targets);
  state.counters["converged"] = static_cast<double>(converged) / static_cast<double>(targets);
  state.SetLabel(preset);
}
BENCHMARK(BM_CompensateJoints)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// A Cartesian target without joints on a named branch (closed-form solutions on the nominal axes, refined on
// the calibrated model). Arg: preset (0 puma560, 1 ur5e). Cycles over 64 poses the calibrated robot reaches at
// random joints, each asked with those joints' flags.
void BM_CompensateCartesianOnBranch(benchmark::State& state) {
  const std::string preset = state.range(0) == 0 ? "puma560" : "ur5e";
  const RobotModel nominal = Preset(preset);
  const Calibration calibration = MakeCalibration(preset);
  const ArmSolver arm = *ArmSolver::For(nominal);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  Rng rng(3);
  std::vector<CompensationTarget> targets;
  for (int i = 0; i < 64; ++i) {
    const Eigen::VectorXd q = RandomConfiguration(nominal, &rng);
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    t.configuration = arm.ConfigurationOf(q);
    targets.push_back(t);
  }
  size_t i = 0;
  long converged = 0, count = 0;
  for (auto _ : state) {
    const CompensationResult r = Compensate(calibration, nominal, targets[i++ % targets.size()]);
    benchmark::DoNotOptimize(r.joints.data());
    converged += r.converged ? 1 : 0;
    ++count;
  }
  state.counters["converged"] = static_cast<double>(converged) / static_cast<double>(count);
  state.SetLabel(preset);
}
BENCHMARK(BM_CompensateCartesianOnBranch)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// A Cartesian target with start joints a few degrees off (a taught program touched up): the run from the start,
// and the nominal solutions where that does not end on the start's branch. Arg: preset (0 puma560, 1 ur5e).
// Cycles over 256 poses the calibrated robot reaches at random joints, each with those joints plus N(0, 3 deg)
// per joint as start (about 5 % of them across a branch boundary).
void BM_CompensateCartesianFromStart(benchmark::State& state) {
  const std::string preset = state.range(0) == 0 ? "puma560" : "ur5e";
  const RobotModel nominal = Preset(preset);
  const Calibration calibration = MakeCalibration(preset);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  Rng rng(4);
  std::vector<CompensationTarget> targets;
  for (int i = 0; i < 256; ++i) {
    const Eigen::VectorXd q = RandomConfiguration(nominal, &rng);
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    t.start = q;
    for (int k = 0; k < q.size(); ++k) t.start[k] += 3.0 * std::numbers::pi / 180.0 * rng.Normal();
    targets.push_back(t);
  }
  size_t i = 0;
  long iterations = 0, converged = 0, count = 0;
  for (auto _ : state) {
    const CompensationResult r = Compensate(calibration, nominal, targets[i++ % targets.size()]);
    benchmark::DoNotOptimize(r.joints.data());
    iterations += r.iterations;
    converged += r.converged ? 1 : 0;
    ++count;
  }
  state.counters["iterations"] = static_cast<double>(iterations) / static_cast<double>(count);
  state.counters["converged"] = static_cast<double>(converged) / static_cast<double>(count);
  state.SetLabel(preset);
}
BENCHMARK(BM_CompensateCartesianFromStart)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace robocal
