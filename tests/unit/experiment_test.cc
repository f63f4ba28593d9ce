// The simulated experiment: calibration by every method beats the nominal commands by far, the report is
// reproducible from the seed, and options are validated.
#include "robocal/core/experiment.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

namespace robocal {
namespace {

using ::testing::HasSubstr;

ExperimentOptions Small(const std::string& robot, MeasurementType type) {
  ExperimentOptions o;
  o.robot = robot;
  o.measurement_type = type;
  o.trials = 2;
  o.num_validation = 12;
  o.seed = 17;
  return o;
}

void ExpectCalibrationHelps(const ExperimentResult& r, int trials, int validation) {
  ASSERT_EQ(r.before.e_xyz_mm.count, trials * validation);
  // The cell's errors (0.2 mm, 0.02 deg per site) put the nominal robot about a millimetre off.
  EXPECT_GT(r.before.e_xyz_mm.mean, 0.3);
  ASSERT_EQ(r.methods.size(), 3u);
  const char* names[] = {"solis_wets", "random", "exchange"};
  for (int k = 0; k < 3; ++k) {
    const MethodResult& m = r.methods[k];
    EXPECT_EQ(m.method, names[k]);
    EXPECT_EQ(m.failed_trials, 0) << m.method;
    ASSERT_EQ(m.after.e_xyz_mm.count, trials * validation) << m.method;
    EXPECT_LT(m.after.e_xyz_mm.mean, 0.1 * r.before.e_xyz_mm.mean) << m.method;
    EXPECT_LT(m.after.e_xyz_mm.rp, 0.2 * r.before.e_xyz_mm.rp) << m.method;
    EXPECT_GE(m.median_condition_number, 1.0) << m.method;
    EXPECT_LE(m.unconverged_targets, trials * validation / 4) << m.method;
  }
}

TEST(ExperimentTest, CalibrationBeatsNominalCommandsForEveryMethodGrinder5Pose) {
  const ExperimentOptions o = Small("grinder5", MeasurementType::kPose);
  int calls = 0;
  ExperimentOptions with_progress = o;
  with_progress.progress = [&](int done, int total) {
    ++calls;
    EXPECT_EQ(done, calls);
    EXPECT_EQ(total, 2);
  };
  const ExperimentResult r = RunExperiment(with_progress);
  EXPECT_EQ(calls, 2);
  ExpectCalibrationHelps(r, 2, 12);
  // Paired plans: Solis & Wets starts from the random set and only accepts improvements.
  EXPECT_LE(r.methods[0].median_condition_number, r.methods[1].median_condition_number);
  // The grinder matches its tool axis, and calibration improves that too.
  for (const MethodResult& m : r.methods) EXPECT_LT(m.after.e_cos_rad.mean, 0.2 * r.before.e_cos_rad.mean);
}

TEST(ExperimentTest, CalibrationBeatsNominalCommandsUr5ePositionAxis) {
  ExperimentOptions o = Small("ur5e", MeasurementType::kPositionAxis);
  o.trials = 1;
  ExpectCalibrationHelps(RunExperiment(o), 1, 12);
}

TEST(ExperimentTest, SameSeedSameReportOtherSeedOtherReport) {
  ExperimentOptions o = Small("grinder5", MeasurementType::kPosition);
  o.trials = 1;
  const std::string first = FormatExperimentReport(RunExperiment(o));
  EXPECT_EQ(first, FormatExperimentReport(RunExperiment(o)));
  o.seed = 18;
  EXPECT_NE(first, FormatExperimentReport(RunExperiment(o)));

  EXPECT_THAT(first, HasSubstr("robot grinder5, position measurements, M = 10 configurations"));
  EXPECT_THAT(first, HasSubstr("Before calibration"));
  for (const char* method : {"solis_wets", "random", "exchange"}) {
    EXPECT_THAT(first, HasSubstr(std::string("After calibration, ") + method));
  }
  EXPECT_THAT(first, HasSubstr("Solis & Wets against random selection"));
  EXPECT_THAT(first, HasSubstr("E_xyz: mean "));
  EXPECT_THAT(first, HasSubstr("median cond"));
}

TEST(ExperimentTest, RejectsInvalidOptionsByName) {
  const auto expect_invalid = [](const ExperimentOptions& o, const std::string& name) {
    std::string error;
    EXPECT_FALSE(o.IsValid(&error)) << name;
    EXPECT_THAT(error, HasSubstr(name));
    EXPECT_THROW(RunExperiment(o), std::invalid_argument) << name;
  };
  std::string error;
  EXPECT_TRUE(ExperimentOptions{}.IsValid(&error)) << error;
  ExperimentOptions o;
  o.robot = "kuka";
  expect_invalid(o, "robot");
  o = {};
  o.num_configurations = 0;
  expect_invalid(o, "num_configurations");
  o = {};
  o.trials = 0;
  expect_invalid(o, "trials");
  o = {};
  o.num_validation = 0;
  expect_invalid(o, "num_validation");
  o = {};
  o.h_mm = -30.0;
  expect_invalid(o, "h_mm");
  o = {};
  o.cell.noise.position_mm = -1.0;
  expect_invalid(o, "cell.noise.position_mm");
}

}  // namespace
}  // namespace robocal
