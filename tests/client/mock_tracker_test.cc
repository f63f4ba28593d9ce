// The mock tracker end to end against the real server in-process: the calibrated robot must be more accurate
// than the nominal one on its validation poses, and the run must be reproducible from its seed.
#include "mock_tracker.h"

#include <gtest/gtest.h>

#include "robocal/api/calibration.h"
#include "robocal/core/cell.h"
#include "robocal/core/presets.h"
#include "test_server.h"

namespace robocal {
namespace {

// Each test runs against its own in-process server.
class MockTrackerTest : public ::testing::Test {
 protected:
  static ClientOptions OptionsFor(const std::string& url) {
    ClientOptions options;
    options.server_url = url;
    return options;
  }
  testing::TestServer server;
  Client client{OptionsFor(server.url())};
};

TEST_F(MockTrackerTest, CalibrationImprovesAccuracy) {
  mock::MockTrackerOptions options;  // grinder5, 10 pose configurations, seed 1
  const mock::MockTrackerReport report = mock::RunMockTracker(client, options, nullptr);
  EXPECT_TRUE(report.improved);
  ASSERT_EQ(report.trials.size(), 1u);
  const AccuracyReport& before = report.planned.before;
  const AccuracyReport& after = report.planned.after;
  // One trial: the pooled numbers are that trial's.
  EXPECT_DOUBLE_EQ(report.trials[0].planned.after.e_xyz_mm.mean, after.e_xyz_mm.mean);
  EXPECT_EQ(before.e_xyz_mm.count, 36);
  // Hidden errors of tenths of a mm leave the nominal robot off by about a mm; the calibrated one should be
  // within a few tenths.
  EXPECT_LT(after.e_xyz_mm.mean, 0.5 * before.e_xyz_mm.mean);
  EXPECT_LT(after.e_tot_mm.rp, before.e_tot_mm.rp);
  // The service's evaluation on the uploaded validation shots agrees in direction.
  const api::Evaluation& evaluation = report.trials[0].planned.evaluation;
  EXPECT_LT(evaluation.calibrated.e_xyz_mm.mean, evaluation.nominal.e_xyz_mm.mean);
  const std::string table = mock::FormatReport(report, options);
  EXPECT_NE(table.find("E_xyz"), std::string::npos);

  // Same seed, same result (a second campaign on the same server).
  const mock::MockTrackerReport again = mock::RunMockTracker(client, options, nullptr);
  EXPECT_EQ(again.trials[0].planned.plan.configurations, report.trials[0].planned.plan.configurations);
  EXPECT_DOUBLE_EQ(again.planned.after.e_xyz_mm.mean, after.e_xyz_mm.mean);
}

// A realistic position campaign shoots three nests held at their plate positions: the fit calibrates the tool
// point through them (the landing check is at the tool point), excludes the outliers of the chosen size, and
// free nests instead leave the tool point where the nominal tool says.
TEST_F(MockTrackerTest, RealisticPositionCampaignShootsThreeHeldNests) {
  mock::MockTrackerOptions options;
  options.robot = "ur5e";
  options.measurement_type = MeasurementType::kPosition;
  options.realistic = true;
  options.cell = "";  // every configuration measurable: the nests, not the cell, are under test
  options.shots_per_pose = 2;
  options.count = 12;
  options.outlier_rate = 0.05;
  options.outlier_size_mm = std::array<double, 2>{8.0, 9.0};
  options.seed = 2;
  ASSERT_EQ(options.NumReflectors(), 3);
  const mock::MockTrackerReport held = mock::RunMockTracker(client, options, nullptr);
  const mock::CampaignOutcome& run = held.trials[0].planned;
  ASSERT_EQ(run.campaign.reflectors.size(), 3u);
  EXPECT_TRUE(run.campaign.reflectors[0].fixed);
  EXPECT_FALSE(run.injected_outliers.empty());
  EXPECT_EQ(run.outliers_found, static_cast<int>(run.injected_outliers.size()));
  for (const api::OutlierWire& o : run.calibration.outliers) EXPECT_GT(o.normalized_residual, 10.0);
  // Repeatability (0.03 mm RP) bounds the landing; the nominal robot is off by about a mm.
  EXPECT_LT(held.planned.after.e_xyz_mm.mean, 0.1);
  EXPECT_GT(held.planned.before.e_xyz_mm.mean, 0.3);

  options.free_nests = true;
  const mock::MockTrackerReport free = mock::RunMockTracker(client, options, nullptr);
  EXPECT_FALSE(free.trials[0].planned.campaign.reflectors[0].fixed);
  EXPECT_NE(free.trials[0].planned.calibration.summary.message.find("not the tool point"), std::string::npos);
  // The tool's own error (0.5 mm per axis hidden in the cell) stays: the landing check sees it.
  EXPECT_GT(free.planned.after.e_xyz_mm.mean, 3.0 * held.planned.after.e_xyz_mm.mean);
}

TEST_F(MockTrackerTest, CompareRandom) {
  mock::MockTrackerOptions options;
  options.compare_random = true;
  options.shots_per_pose = 3;
  const mock::MockTrackerReport report = mock::RunMockTracker(client, options, nullptr);
  ASSERT_TRUE(report.random.has_value());
  EXPECT_TRUE(report.improved);
  EXPECT_LT(report.random->after.e_xyz_mm.mean, report.random->before.e_xyz_mm.mean);
  // The report's JSON is made of the API's shapes: it reads back as them, with the core's numbers.
  const nlohmann::json j = mock::ReportToJson(report);
  const auto over = api::FromWire<api::Improvement>(j.at("improvement_over_random_percent"));
  EXPECT_DOUBLE_EQ(over.e_tot_mean, api::ImprovementOf(report.random->after, report.planned.after).e_tot_mean);
  const auto after = api::FromWire<api::Accuracy>(j.at("planned").at("after"));
  EXPECT_EQ(after.e_xyz_mm.count, report.planned.after.e_xyz_mm.count);
  EXPECT_DOUBLE_EQ(after.e_xyz_mm.mean, report.planned.after.e_xyz_mm.mean);
  EXPECT_NEAR(after.e_cos_deg.mean, report.planned.after.e_cos_rad.mean * kDegPerRad, 1e-12);
  const auto evaluation = api::FromWire<api::Evaluation>(j.at("trials")[0].at("planned").at("service_evaluation"));
  EXPECT_EQ(evaluation.campaign, report.trials[0].planned.campaign.id);
  EXPECT_NE(mock::FormatReport(report, options).find("note: one trial"), std::string::npos);
}

TEST_F(MockTrackerTest, TrialsArePooled) {
  mock::MockTrackerOptions options;
  options.compare_random = true;
  options.trials = 2;
  options.shots_per_pose = 2;
  options.num_validation = 12;
  const mock::MockTrackerReport report = mock::RunMockTracker(client, options, nullptr);
  ASSERT_EQ(report.trials.size(), 2u);
  EXPECT_EQ(report.trials[1].seed, options.seed + 1);
  // Each trial is a new cell with its own plans.
  EXPECT_NE(report.trials[0].planned.plan.configurations, report.trials[1].planned.plan.configurations);
  EXPECT_NE(report.trials[0].planned.before.e_xyz_mm.mean, report.trials[1].planned.before.e_xyz_mm.mean);
  ASSERT_TRUE(report.random.has_value());
  for (const mock::PooledAccuracy* pooled : {&report.planned, &*report.random}) {
    EXPECT_EQ(pooled->before.e_xyz_mm.count, 24);
    EXPECT_EQ(pooled->after.e_xyz_mm.count, 24);
  }
  // Trials of equal size: the pooled mean is the mean of the trials' means.
  EXPECT_NEAR(report.planned.after.e_xyz_mm.mean,
              0.5 * (report.trials[0].planned.after.e_xyz_mm.mean + report.trials[1].planned.after.e_xyz_mm.mean),
              1e-9);
  EXPECT_NEAR(report.random->before.e_tot_mm.mean,
              0.5 * (report.trials[0].random->before.e_tot_mm.mean + report.trials[1].random->before.e_tot_mm.mean),
              1e-9);
  EXPECT_EQ(mock::FormatReport(report, options).find("note: one trial"), std::string::npos);
  EXPECT_EQ(mock::ReportToJson(report).at("trials").size(), 2u);
  // Trial 2 is the one-trial run of seed + 1.
  mock::MockTrackerOptions second = options;
  second.trials = 1;
  second.seed = options.seed + 1;
  const mock::MockTrackerReport alone = mock::RunMockTracker(client, second, nullptr);
  EXPECT_EQ(alone.trials[0].planned.plan.configurations, report.trials[1].planned.plan.configurations);
  EXPECT_DOUBLE_EQ(alone.planned.after.e_xyz_mm.mean, report.trials[1].planned.after.e_xyz_mm.mean);
}

// End to end over HTTP in the preset cell: the cell is created on the server, the plan is made in it, the mock
// tracker measures every planned pose (none lost), the fit succeeds and calibration helps.
TEST_F(MockTrackerTest, InThePresetCellEveryPlannedPoseIsMeasured) {
  mock::MockTrackerOptions options;
  options.robot = "ur5e";
  options.cell = "preset";
  options.compare_random = true;
  options.shots_per_pose = 2;
  options.num_validation = 12;
  const mock::MockTrackerReport report = mock::RunMockTracker(client, options, nullptr);
  ASSERT_EQ(report.trials.size(), 1u);
  const Cell reference = Cell::Build(Preset("ur5e"), PresetCellSpec("ur5e"));
  for (const mock::CampaignOutcome* o : {&report.trials[0].planned, &*report.trials[0].random}) {
    EXPECT_EQ(o->plan.cell, std::optional<std::string>("preset-ur5e"));
    EXPECT_EQ(o->unmeasured_poses, 0);
    // Re-checked here against a cell built from the spec: every planned pose is feasible in it.
    for (const auto& wire_q : o->plan.configurations) {
      EXPECT_TRUE(IsFeasible(Preset("ur5e"), reference, api::JointsToCore(Preset("ur5e"), wire_q)));
    }
    EXPECT_EQ(o->calibration.summary.termination, Termination::kConvergence) << o->calibration.summary.brief;
  }
  EXPECT_TRUE(report.improved);
  EXPECT_LT(report.planned.after.e_xyz_mm.mean, 0.5 * report.planned.before.e_xyz_mm.mean);
  const std::string text = mock::FormatReport(report, options);
  EXPECT_NE(text.find("measured in cell preset-ur5e"), std::string::npos) << text;
  EXPECT_NE(text.find("0 of 10 planned poses could not be measured"), std::string::npos) << text;
  EXPECT_EQ(mock::ReportToJson(report).at("trials")[0].at("planned").at("unmeasured_poses"), 0);

  // A second run finds the preset cell on the server, and a cell named by id works the same way.
  options.compare_random = false;
  EXPECT_EQ(mock::ResolveCell(client, options)->id, "preset-ur5e");
  options.cell = "preset-ur5e";
  EXPECT_EQ(mock::RunMockTracker(client, options, nullptr).trials[0].planned.unmeasured_poses, 0);
  // A cell of another robot is refused.
  options.robot = "puma560";
  EXPECT_THROW(mock::ResolveCell(client, options), std::invalid_argument);
}

// Without planning in the cell, the tracker loses the poses it cannot see: measured in the preset cell, a plan
// made for the whole joint space loses most of them.
TEST_F(MockTrackerTest, APlanThatIgnoresTheCellLosesPoses) {
  mock::MockTrackerOptions options;
  options.robot = "puma560";
  api::PlanRequest request;
  request.robot = "puma560";
  request.num_configurations = 20;
  request.optimiser = api::Optimiser::kRandom;
  const api::PlanResult plan = client.CreatePlan(request);
  options.cell = "preset";
  VirtualCell cell = mock::MakeCell(options, mock::ResolveCell(client, options));
  const api::MeasurementBatchRequest batch =
      mock::MeasurementBatch(&cell, plan.configurations, api::MeasurementRole::kCalibration, options);
  EXPECT_GT(cell.unmeasured(), 10);
  EXPECT_EQ(static_cast<int>(batch.measurements.size()), options.shots_per_pose * (20 - cell.unmeasured()));
}

}  // namespace
}  // namespace robocal
