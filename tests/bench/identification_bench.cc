// Identification: ur5e from 50 and 500 full-pose measurements (distinct poses), 500 as 50 poses x 10 shots,
// and the same fits with the identifiable set given, to separate the identifiability probe from the fit.
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <vector>

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

// The fit beyond geometry at the size of a real calibration: ur5e, 400 full poses with joints within +-180 deg,
// the robot erring by compliance and joint harmonics up to order 4. Arg 0: compliance + harmonics 2 (the model
// the maps replace); arg 1: compliance + error maps every 4 deg on joints 1-5 (about 5 x 93 coefficients).
void BM_IdentifyJointTerms(benchmark::State& state) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 3;
  o.compliance_deflection_mm = 0.3;
  o.joint_harmonic_sigma_rad = 5e-5;
  VirtualCell cell(model, o);
  Rng rng(4);
  std::vector<Eigen::VectorXd> configurations;
  for (int i = 0; i < 400; ++i) {
    configurations.push_back(RandomConfiguration(model, &rng).cwiseMax(-M_PI).cwiseMin(M_PI));
  }
  const std::vector<Measurement> measurements = cell.MeasureAll(configurations);
  IdentificationOptions options;
  options.measurement_type = MeasurementType::kPose;
  JointErrorTerms terms{.compliance = true, .joint_harmonics = 2};
  if (state.range(0) == 1) {
    terms.joint_harmonics = 0;
    terms.maps.joints = {0, 1, 2, 3, 4};
    terms.maps.knot_spacing_rad = 4.0 * M_PI / 180.0;
  }
  const RobotModel fitted = WithTermsFor(model, terms, measurements);
  int iterations = 0;
  for (auto _ : state) {
    const Calibration cal = Identify(fitted, measurements, options);
    if (cal.summary.termination == Termination::kFailure) state.SkipWithError(cal.summary.message.c_str());
    iterations = cal.summary.iterations;
    benchmark::DoNotOptimize(cal.errors.data());
  }
  state.counters["lm_iterations"] = iterations;
  state.counters["parameters"] = fitted.num_error_parameters();
  state.SetLabel(state.range(0) == 1 ? "compliance + maps 4 deg, joints 1-5" : "compliance + harmonics 2");
}
BENCHMARK(BM_IdentifyJointTerms)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

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
