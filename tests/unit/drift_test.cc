// Drift checks in the virtual cell: a calibrated robot holds on new poses at about the stated false alarm rate; a
// joint offset of 0.05 deg is found and named.
#include "robocal/core/drift.h"

#include <gtest/gtest.h>

#include <cmath>

#include "robocal/core/dh_table.h"
#include "robocal/core/fit_diagnostics.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/reflectors.h"
#include "robocal/core/units.h"
#include "robocal/core/virtual_cell.h"

namespace robocal {
namespace {

// A UR5e with hidden geometric errors and unmodelled joint harmonics (the model error a geometric calibration
// leaves), calibrated from 60 poses; the calibrated robot as a robot of its own at the registered base.
struct Calibrated {
  VirtualCell cell;
  RobotModel robot;
  DriftCheckOptions options;

  Calibrated()
      : cell(Preset("ur5e"), [] {
          VirtualCellOptions o;
          o.seed = 5;
          o.noise.position_mm = 0.01;
          o.noise.orientation_rad = 2e-5;
          o.joint_harmonic_sigma_rad = 1.5e-4;
          return o;
        }()),
        robot(Preset("ur5e")) {
    Rng rng(1);
    const std::vector<Measurement> shots = cell.MeasureAll(RandomConfigurations(cell.nominal(), 60, &rng), 1);
    IdentificationOptions io;
    io.noise = cell.options().noise;
    const Calibration cal = Identify(cell.nominal(), shots, io);
    EXPECT_EQ(cal.summary.termination, Termination::kConvergence) << cal.summary.message;
    RobotModelSpec spec = CalibratedTransformSpec(cal.model, cal.errors);
    spec.T_world_base = cal.model.T_world_base();
    robot = RobotModel::Build(spec);
    options.measurement_type = MeasurementType::kPose;
    options.noise = cell.options().noise;
    options.noise.model_error_mm = cal.summary.model_error.model_error_mm / std::sqrt(3.0);
    options.noise.model_error_rad = cal.summary.model_error.model_error_rad / std::sqrt(3.0);
    options.reference = shots;
    options.reference_T_world_base = cal.model.T_world_base();
    const double rows = 6.0 * static_cast<double>(shots.size());
    const double p = static_cast<double>(cal.parameters.size());
    options.null_correction = (rows + p) / (rows - p);
  }
};

TEST(DriftTest, AnUnchangedRobotHoldsAtTheStatedRateAndAJointOffsetIsFoundAndNamed) {
  Calibrated c;
  constexpr int kSets = 40;
  int false_alarms = 0, found = 0, named = 0;
  Rng rng(7);
  for (int set = 0; set < kSets; ++set) {
    const std::vector<Eigen::VectorXd> poses = RandomConfigurations(c.robot, 12, &rng);
    std::vector<Measurement> shots = c.cell.MeasureAll(poses, 1);
    DriftCheckOptions options = c.options;
    options.seed = static_cast<std::uint64_t>(set + 1);
    const DriftCheck holds = CheckDrift(c.robot, shots, options);
    if (holds.drifted) ++false_alarms;
    if (holds.drifted || set < 3) std::printf("holds? %s\n", holds.message.c_str());
    // Re-mastered joint 3: its reported angle 0.05 deg off what it is.
    for (Measurement& m : shots) m.joints[2] += 0.05 * kRadPerDeg;
    const DriftCheck drifted = CheckDrift(c.robot, shots, options);
    if (drifted.drifted) ++found;
    if (set < 3) std::printf("offset: %s; %s %g +- %g\n", drifted.message.c_str(), drifted.suspects.empty() ? "" : drifted.suspects[0].name.c_str(), drifted.suspects.empty() ? 0.0 : drifted.suspects[0].change, drifted.suspects.empty() ? 0.0 : drifted.suspects[0].std);
    if (!drifted.suspects.empty() && drifted.suspects.front().name == ParameterName(c.robot, {}, 6 * 3 + 5)) {
      ++named;
      EXPECT_NEAR(drifted.suspects.front().change, -0.05 * kRadPerDeg, 4.0 * drifted.suspects.front().std);
    }
  }
  std::printf("%d sets of 12: false alarms %d, offset found %d, named %d\n", kSets, false_alarms, found, named);
  // Stated 5 %: at most twice that (8 of 40 is 20 %: the binomial's 99.9 % bound at 5 % and 40 sets is 7).
  EXPECT_LE(false_alarms, 7);
  EXPECT_GE(found, kSets * 95 / 100);
  EXPECT_GE(named, kSets * 90 / 100);
}

TEST(DriftTest, TooFewShotsSayWhyAndBadOptionsThrow) {
  Calibrated c;
  Rng rng(3);
  const std::vector<Measurement> shots = c.cell.MeasureAll(RandomConfigurations(c.robot, 2, &rng), 1);
  const DriftCheck few = CheckDrift(c.robot, shots, c.options);
  EXPECT_FALSE(few.drifted);
  EXPECT_TRUE(std::isnan(few.statistic));
  EXPECT_NE(few.message.find("too few"), std::string::npos) << few.message;
  DriftCheckOptions bad = c.options;
  bad.false_alarm_rate = 0.7;
  EXPECT_THROW(CheckDrift(c.robot, shots, bad), std::invalid_argument);
  bad = c.options;
  bad.reference.resize(3);
  EXPECT_THROW(CheckDrift(c.robot, shots, bad), std::invalid_argument);
}

}  // namespace
}  // namespace robocal
