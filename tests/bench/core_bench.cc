// Forward kinematics and the identification Jacobian per configuration, for each preset and measurement type.
#include <benchmark/benchmark.h>

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

}  // namespace
}  // namespace robocal
