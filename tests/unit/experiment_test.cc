// The simulated experiment: calibration by every method beats the nominal commands by far, the report is
// reproducible from the seed, and options are validated.
#include "robocal/core/experiment.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "robocal/core/cell.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

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

TEST(ExperimentTest, DefaultsAreThePapersSetUp) {
  const ExperimentOptions o;
  EXPECT_EQ(o.robot, "grinder5");
  EXPECT_EQ(o.measurement_type, MeasurementType::kPose);
  EXPECT_EQ(o.num_configurations, 10);
  EXPECT_EQ(o.num_validation, 36);
  EXPECT_EQ(o.h_mm, 30.0);
  EXPECT_EQ(o.cell.shots_per_pose, 10);
}

// Without tracker noise every plan identifies the hidden robot exactly, so after calibration the true robot
// lands on every validation target (plans, cell, identification and compensation chained as in the paper).
TEST(ExperimentTest, NoiseFreeCellCalibratesEveryMethodExactly) {
  ExperimentOptions o = Small("grinder5", MeasurementType::kPose);
  o.trials = 1;
  o.cell.noise = {0.0, 0.0};
  o.cell.shots_per_pose = 1;
  const ExperimentResult r = RunExperiment(o);
  EXPECT_GT(r.before.e_xyz_mm.mean, 0.3);
  for (const MethodResult& m : r.methods) {
    SCOPED_TRACE(m.method);
    EXPECT_EQ(m.failed_trials, 0);
    ASSERT_EQ(m.unconverged_targets, 0);
    EXPECT_LT(m.after.e_xyz_mm.max, 1e-6);
    EXPECT_LT(m.after.e_cos_rad.max, 1e-9);
  }
  const std::string report = FormatExperimentReport(r);
  EXPECT_THAT(report, ::testing::Not(HasSubstr("nan")));
  EXPECT_THAT(report, ::testing::Not(HasSubstr("inf")));
}

// In the preset cell: every method but random_ignoring_cell plans in it, so the tracker measures every pose;
// random configurations that ignore the cell lose most (about 95 % of uniform ones are infeasible).
TEST(ExperimentTest, InAMeasurementCellOnlyPosesThatIgnoreItAreLost) {
  ExperimentOptions o = Small("ur5e", MeasurementType::kPose);
  o.trials = 1;
  o.num_validation = 4;
  o.cell.measurement_cell = PresetCellSpec("ur5e");
  const ExperimentResult r = RunExperiment(o);
  const std::vector<std::string> names = {"solis_wets",         "random",
                                          "exchange",           "random_ignoring_cell",
                                          "solis_wets_log_det", "solis_wets_predicted_error",
                                          "exchange_log_det",   "exchange_predicted_error"};
  ASSERT_EQ(r.methods.size(), names.size());
  for (size_t k = 0; k < names.size(); ++k) {
    const MethodResult& m = r.methods[k];
    EXPECT_EQ(m.method, names[k]);
    EXPECT_EQ(m.planned_poses, 10) << m.method;
    if (m.method == "random_ignoring_cell") {
      EXPECT_GE(m.unmeasured_poses, 5);
      continue;
    }
    EXPECT_EQ(m.unmeasured_poses, 0) << m.method;
    EXPECT_EQ(m.failed_trials, 0) << m.method;
    EXPECT_LT(m.after.e_xyz_mm.mean, 0.2 * r.before.e_xyz_mm.mean) << m.method;
  }
  const std::string report = FormatExperimentReport(r);
  EXPECT_THAT(report, HasSubstr("in a measurement cell: tracker at (2300, -1400, 1400) mm, 2 obstacles"));
  EXPECT_THAT(report, HasSubstr("exchange_log_det: 0 of 10 planned poses could not be measured"));
  // Without a cell: the paper's three methods, nothing lost, no word of a cell.
  o.cell.measurement_cell.reset();
  const ExperimentResult plain = RunExperiment(o);
  ASSERT_EQ(plain.methods.size(), 3u);
  for (const MethodResult& m : plain.methods) EXPECT_EQ(m.unmeasured_poses, 0);
  EXPECT_THAT(FormatExperimentReport(plain), Not(HasSubstr("measurement cell")));
  // A cell that does not fit the robot is refused by IsValid.
  o.cell.measurement_cell = PresetCellSpec("grinder5");
  o.cell.measurement_cell->link_radii_mm = {40, 40, 50, 50, 40};
  std::string error;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("cell.measurement_cell"));
}

// The report's form: the paper's four columns for each error, a block before calibration and one per method,
// and the improvement over random selection of both planners; a zero baseline gives "n/a", not inf or nan.
// A simulated robot with compliance and joint harmonics of orders 1-2: the model that holds them brings the
// compensated robot several times closer than the geometric one, reported side by side.
TEST(ExperimentTest, ModelsSideBySideTheRicherOneWinsOnARobotThatHasItsErrors) {
  ExperimentOptions o;
  o.robot = "ur5e";
  o.num_configurations = 40;
  o.trials = 1;
  o.num_validation = 40;
  o.cell.shots_per_pose = 1;
  o.cell.compliance_deflection_mm = 0.3;
  o.cell.joint_harmonic_sigma_rad = 1e-4;
  o.cell.joint_harmonic_min_order = 1;
  o.cell.joint_harmonic_max_order = 2;
  o.models = {"geometric", "compliance,harmonics=2"};
  const ExperimentResult r = RunExperiment(o);
  const auto find = [&](const std::string& model) -> const MethodResult& {
    for (const MethodResult& m : r.methods) {
      if (m.method == "solis_wets" && m.model == model) return m;
    }
    throw std::runtime_error("no solis_wets result for " + model);
  };
  const MethodResult& geometric = find("geometric");
  const MethodResult& richer = find("compliance,harmonics=2");
  ASSERT_EQ(richer.failed_trials, 0);
  EXPECT_LT(richer.after.e_xyz_mm.mean, 0.5 * geometric.after.e_xyz_mm.mean);
  EXPECT_EQ(r.methods.size(), 6u);  // three methods, two models
  EXPECT_THAT(FormatExperimentReport(r), HasSubstr("solis_wets configurations, model compliance,harmonics=2"));
}

TEST(ExperimentTest, ReportHasThePapersTableAndTheImprovementInPercent) {
  ExperimentResult r;
  const Transform target = Transform::Identity();
  const auto report_with_error = [&](double e_xyz_mm) {
    Transform reached = target;
    reached.translation().x() = e_xyz_mm;
    return ComputeAccuracy({reached, reached}, {target, target});
  };
  r.before = report_with_error(1.0);
  r.methods = {{"solis_wets", 8.0, report_with_error(0.006), 0, 0},
               {"random", 19.0, report_with_error(0.008), 0, 0},
               {"exchange", 7.0, report_with_error(0.005), 0, 0}};
  const std::string text = FormatExperimentReport(r);
  EXPECT_THAT(text, HasSubstr("Before calibration, nominal commands (N = 2"));
  EXPECT_THAT(text, HasSubstr("After calibration, solis_wets configurations"));
  // The table itself is FormatAccuracyTable's (accuracy_test.cc); here: it carries this method's numbers.
  EXPECT_THAT(text, HasSubstr("  E_xyz um            6.0        0.0        6.0        6.0"));
  // (8 - 6) / 8 = 25 %, (8 - 5) / 8 = 37.5 %; E_cos is zero for every method: no relative improvement.
  EXPECT_THAT(text, HasSubstr("Solis & Wets against random selection (positive: Solis & Wets better)\n"
                              "  E_xyz: mean +25.0 %, RP +25.0 %\n  E_cos: mean n/a, RP n/a\n"));
  EXPECT_THAT(text, HasSubstr("Exchange against random selection (positive: Exchange better)\n"
                              "  E_xyz: mean +37.5 %, RP +37.5 %"));
  EXPECT_THAT(text, HasSubstr("median cond 8 (Solis & Wets) against 19 (random)"));
  EXPECT_THAT(text, ::testing::Not(HasSubstr("nan")));
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
  o.models = {"geometric", "compliance,harmonics=3"};
  expect_invalid(o, "models");
  o.models = {};
  expect_invalid(o, "models");
  o = {};
  o.cell.noise.position_mm = -1.0;
  expect_invalid(o, "cell.noise.position_mm");
}

}  // namespace
}  // namespace robocal
