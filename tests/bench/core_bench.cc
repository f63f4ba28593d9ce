// Forward kinematics and the identification Jacobian per configuration, for each preset and measurement type;
// the feasibility of one configuration in a measurement cell.
#include <benchmark/benchmark.h>

#include "robocal/core/cell.h"
#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

const char* PresetOf(int index) {
  static const char* const kNames[] = {"grinder5", "puma560", "ur5e"};
  return kNames[index];
}

std::vector<Eigen::VectorXd> Configurations(const RobotModel& model, int count) {
  Rng rng(1);
  std::vector<Eigen::VectorXd> qs;
  for (int i = 0; i < count; ++i) qs.push_back(RandomConfiguration(model, &rng));
  return qs;
}

void BM_ForwardKinematics(benchmark::State& state) {
  const RobotModel model = Preset(PresetOf(static_cast<int>(state.range(0))));
  KinematicsWorkspace ws(model);
  const auto qs = Configurations(model, 64);
  const Eigen::VectorXd eps = state.range(1) ? Eigen::VectorXd::Constant(model.num_error_parameters(), 1e-4)
                                             : Eigen::VectorXd();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(ForwardKinematics(model, qs[i++ % qs.size()], eps, &ws).matrix().data());
  }
  state.SetLabel(std::string(model.name()) + (state.range(1) ? " with errors" : " nominal"));
}
BENCHMARK(BM_ForwardKinematics)->ArgsProduct({{0, 1, 2}, {0, 1}});

void BM_IdentificationJacobian(benchmark::State& state) {
  const RobotModel model = Preset(PresetOf(static_cast<int>(state.range(0))));
  const auto type = static_cast<MeasurementType>(state.range(1));
  KinematicsWorkspace ws(model);
  const auto qs = Configurations(model, 64);
  Eigen::MatrixXd jac(MeasurementRows(type), model.num_error_parameters());
  size_t i = 0;
  for (auto _ : state) {
    IdentificationJacobian(model, qs[i++ % qs.size()], Eigen::VectorXd(), type, &ws, jac);
    benchmark::DoNotOptimize(jac.data());
  }
  state.SetLabel(std::string(model.name()) + " " + ToString(type));
}
BENCHMARK(BM_IdentificationJacobian)->ArgsProduct({{0, 1, 2}, {0, 1, 2}});

void BM_JointJacobian(benchmark::State& state) {
  const RobotModel model = Preset(PresetOf(static_cast<int>(state.range(0))));
  KinematicsWorkspace ws(model);
  const auto qs = Configurations(model, 64);
  Eigen::MatrixXd jac(6, model.num_joints());
  size_t i = 0;
  for (auto _ : state) {
    JointJacobian(model, qs[i++ % qs.size()], Eigen::VectorXd(), MeasurementType::kPose, &ws, jac);
    benchmark::DoNotOptimize(jac.data());
  }
  state.SetLabel(model.name());
}
BENCHMARK(BM_JointJacobian)->DenseRange(0, 2);

// The cell: a UR5e, 8 capsules (6 links, 2 tool capsules), 5 boxes, 2 reflectors; target <= 5 us.
Cell BenchCell(const RobotModel& model) {
  CellSpec spec;
  spec.tracker.position_mm = Eigen::Vector3d(2500, -800, 300);
  spec.tracker.min_distance_mm = 1500;
  spec.tracker.max_distance_mm = 15000;
  ReflectorSpec smr1, smr2;
  smr1.id = "smr1";
  smr1.position_mm = Eigen::Vector3d(30, 0, 120);
  smr2.id = "smr2";
  smr2.position_mm = Eigen::Vector3d(-30, 0, 120);
  smr2.normal = Eigen::Vector3d(-0.5, 0, std::sqrt(0.75));
  spec.reflectors = {smr1, smr2};
  auto box = [](const char* id, Eigen::Vector3d lo, Eigen::Vector3d hi) { return BoxObstacle{id, lo, hi}; };
  spec.obstacles = {box("floor", {-3000, -3000, -500}, {3000, 3000, -10}),
                    box("table", {400, -600, -10}, {1000, 600, 150}),
                    box("fence", {-1200, -3000, -10}, {-1150, 3000, 2000}),
                    box("pillar", {-700, 600, -10}, {-500, 800, 2000}),
                    box("tracker_stand", {2400, -900, -10}, {2600, -700, 200})};
  spec.clearance_mm = 20;
  return Cell::Build(model, spec);
}

// range(0) = 1: feasible configurations only (every check runs to the end: the slowest case);
// 0: uniform configurations (most rejected early, as a planner's candidates are).
void BM_IsFeasible(benchmark::State& state) {
  const RobotModel model = Preset("ur5e");
  const Cell cell = BenchCell(model);
  std::vector<Eigen::VectorXd> qs;
  Rng rng(1);
  while (qs.size() < 256) {
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    if (!state.range(0) || IsFeasible(model, cell, q)) qs.push_back(q);
  }
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(IsFeasible(model, cell, qs[i++ % qs.size()]));
  state.SetLabel(state.range(0) ? "ur5e, feasible configurations" : "ur5e, uniform configurations");
}
BENCHMARK(BM_IsFeasible)->Arg(1)->Arg(0);

void BM_CheckConfiguration(benchmark::State& state) {
  const RobotModel model = Preset("ur5e");
  const Cell cell = BenchCell(model);
  const auto qs = Configurations(model, 256);
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(CheckConfiguration(model, cell, qs[i++ % qs.size()]).feasible);
  state.SetLabel("ur5e, uniform configurations, full report");
}
BENCHMARK(BM_CheckConfiguration);

}  // namespace
}  // namespace robocal
