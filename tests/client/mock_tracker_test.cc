// The mock tracker end to end against the real server in-process: the calibrated robot must be more accurate
// than the nominal one on its validation poses, and the run must be reproducible from its seed.
#include "mock_tracker.h"

#include <gtest/gtest.h>

#include "test_server.h"

namespace robocal {
namespace {

TEST(MockTrackerTest, CalibrationImprovesAccuracy) {
  testing::TestServer server;
  ClientOptions client_options;
  client_options.server_url = server.url();
  Client client(client_options);
  mock::MockTrackerOptions options;  // grinder5, 10 pose configurations, seed 1
  const mock::MockTrackerReport report = mock::RunMockTracker(client, options, nullptr);
  EXPECT_TRUE(report.improved);
  const AccuracyReport& before = report.planned.before;
  const AccuracyReport& after = report.planned.after;
  EXPECT_EQ(before.e_xyz_mm.count, 36);
  // Hidden errors of tenths of a mm leave the nominal robot off by about a mm; the calibrated one should be
  // within a few tenths.
  EXPECT_LT(after.e_xyz_mm.mean, 0.5 * before.e_xyz_mm.mean);
  EXPECT_LT(after.e_tot_mm.rp, before.e_tot_mm.rp);
  // The service's evaluation on the uploaded validation shots agrees in direction.
  EXPECT_LT(report.planned.evaluation.calibrated.e_xyz_mm.mean, report.planned.evaluation.nominal.e_xyz_mm.mean);
  const std::string table = mock::FormatReport(report, options);
  EXPECT_NE(table.find("E_xyz"), std::string::npos);

  // Same seed, same result (a second campaign on the same server).
  const mock::MockTrackerReport again = mock::RunMockTracker(client, options, nullptr);
  EXPECT_EQ(again.planned.plan.configurations, report.planned.plan.configurations);
  EXPECT_DOUBLE_EQ(again.planned.after.e_xyz_mm.mean, after.e_xyz_mm.mean);
}

TEST(MockTrackerTest, CompareRandom) {
  testing::TestServer server;
  ClientOptions client_options;
  client_options.server_url = server.url();
  Client client(client_options);
  mock::MockTrackerOptions options;
  options.compare_random = true;
  options.shots_per_pose = 3;
  const mock::MockTrackerReport report = mock::RunMockTracker(client, options, nullptr);
  ASSERT_TRUE(report.random.has_value());
  EXPECT_TRUE(report.improved);
  EXPECT_LT(report.random->after.e_xyz_mm.mean, report.random->before.e_xyz_mm.mean);
  EXPECT_TRUE(mock::ReportToJson(report).contains("improvement_over_random_percent"));
}

}  // namespace
}  // namespace robocal
