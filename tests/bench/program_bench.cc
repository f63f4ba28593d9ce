// A robot program compensated whole (CompensateProgram): a KUKA KRL program of N targets, half E6AXIS and half
// E6POS with S and T, each moved to by a PTP in the .src, on puma560 with errors of an industrial robot.
// docs/programs.md quotes the figures (the bar: 10,000 targets within 1 s on 2 cores).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_calibration.h"
#include "robocal/core/arm_kinematics.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/units.h"
#include "robocal/programs/compensate_program.h"

namespace robocal::programs {
namespace {

std::string Number(double v, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, v);
  return buffer;
}

// The .src and .dat of `targets` targets at random joints away from the wrist's singularity.
std::vector<ProgramFile> MakeKrlProgram(const RobotModel& model, int targets) {
  const ArmSolver arm = *ArmSolver::For(model);
  Rng rng(2);
  std::string src = "DEF bench( )\r\n", dat = "DEFDAT bench\r\n";
  for (int i = 0; i < targets; ++i) {
    Eigen::VectorXd q = RandomConfiguration(model, &rng);
    if (std::abs(q[4]) < 0.2) q[4] = 0.2;
    const std::string name = "XP" + std::to_string(i);
    src += "  PTP " + name + " C_PTP\r\n";
    if (i % 2 == 0) {
      dat += "DECL E6AXIS " + name + "={";
      for (int k = 0; k < 6; ++k) dat += (k ? ",A" : "A") + std::to_string(k + 1) + " " + Number(q[k] * kDegPerRad, 3);
      dat += ",E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}\r\n";
      continue;
    }
    const Transform pose = model.T_world_base().inverse() * ForwardKinematics(model, q);
    const Eigen::Matrix3d R = pose.linear();
    const double b = std::asin(-R(2, 0)), a = std::atan2(R(1, 0), R(0, 0)), c = std::atan2(R(2, 1), R(2, 2));
    const ArmConfiguration flags = arm.ConfigurationOf(q);
    // S as the KRL reader reads it (docs/programs.md): bit 1 names the elbow relative to the shoulder's side.
    const int s = (flags.shoulder < 0 ? 1 : 0) | (flags.elbow * flags.shoulder < 0 ? 2 : 0) | (flags.wrist < 0 ? 4 : 0);
    int t = 0;
    for (int k = 0; k < 6; ++k) t |= q[k] < 0 ? 1 << k : 0;
    dat += "DECL E6POS " + name + "={X " + Number(pose.translation().x(), 3) + ",Y " +
           Number(pose.translation().y(), 3) + ",Z " + Number(pose.translation().z(), 3) + ",A " +
           Number(a * kDegPerRad, 4) + ",B " + Number(b * kDegPerRad, 4) + ",C " + Number(c * kDegPerRad, 4) + ",S " +
           std::to_string(s) + ",T " + std::to_string(t) + ",E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}\r\n";
  }
  return {{"bench.src", src + "END\r\n"}, {"bench.dat", dat + "ENDDAT\r\n"}};
}

// Arg: the number of targets.
void BM_CompensateKrlProgram(benchmark::State& state) {
  const RobotModel model = Preset("puma560");
  const Calibration calibration = bench::IndustrialCalibration(model);
  const std::vector<ProgramFile> files = MakeKrlProgram(model, static_cast<int>(state.range(0)));
  int failed = 0, targets = 0;
  for (auto _ : state) {
    const ProgramCompensationResult r = CompensateProgram(calibration, model, Dialect::kKrl, files);
    benchmark::DoNotOptimize(r.files.data());
    failed = r.summary.failed;
    targets = r.summary.targets;
  }
  state.counters["targets"] = targets;
  state.counters["kept_as_written"] = failed;
  state.SetItemsProcessed(state.iterations() * targets);
}
BENCHMARK(BM_CompensateKrlProgram)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond)->UseRealTime();

// Reading alone: the reader's share of the time.
void BM_ReadKrlProgram(benchmark::State& state) {
  const RobotModel model = Preset("puma560");
  const std::vector<ProgramFile> files = MakeKrlProgram(model, static_cast<int>(state.range(0)));
  for (auto _ : state) {
    const ParsedProgram p = SyntaxOf(Dialect::kKrl).read(files);
    benchmark::DoNotOptimize(p.targets.data());
  }
}
BENCHMARK(BM_ReadKrlProgram)->Arg(10000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace robocal::programs
