// Accuracy statistics: hand-computed statistics, E_xyz, E_cos and E_tot for known poses, the table's units,
// rejected input, and improvement percentages.
#include "robocal/core/accuracy.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace robocal {
namespace {

using ::testing::HasSubstr;

TEST(ErrorStatisticsTest, MatchesHandComputedValues) {
  const ErrorStatistics s = ComputeErrorStatistics({1.0, 2.0, 3.0, 4.0});
  EXPECT_EQ(s.count, 4);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  // Squared deviations 2.25 + 0.25 + 0.25 + 2.25 = 5, divided by N - 1 = 3.
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(5.0 / 3.0));
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(s.rp, 2.5 + 3.0 * std::sqrt(5.0 / 3.0));
}

TEST(ErrorStatisticsTest, SingleValueHasZeroStd) {
  const ErrorStatistics s = ComputeErrorStatistics({0.054});
  EXPECT_EQ(s.count, 1);
  EXPECT_DOUBLE_EQ(s.mean, 0.054);
  EXPECT_EQ(s.std, 0.0);
  EXPECT_DOUBLE_EQ(s.max, 0.054);
  EXPECT_DOUBLE_EQ(s.rp, 0.054);
}

TEST(ErrorStatisticsTest, SmallSpreadOnALargeOffsetIsNotLost) {
  // A naive sum-of-squares formula loses these digits entirely.
  const ErrorStatistics s = ComputeErrorStatistics({1e8 + 1.0, 1e8 + 2.0, 1e8 + 3.0});
  EXPECT_NEAR(s.std, 1.0, 1e-9);
}

TEST(ErrorStatisticsTest, RejectsEmptyAndNonFiniteSamples) {
  EXPECT_THROW(ComputeErrorStatistics({}), std::invalid_argument);
  EXPECT_THROW(ComputeErrorStatistics({1.0, std::nan("")}), std::invalid_argument);
  EXPECT_THROW(ComputeErrorStatistics({std::numeric_limits<double>::infinity()}), std::invalid_argument);
}

Transform PoseWithAxisTilt(const Eigen::Vector3d& position_mm, double tilt_rad) {
  Transform t = Transform::Identity();
  t.linear() = RotY(tilt_rad);
  t.translation() = position_mm;
  return t;
}

TEST(MedianTest, OddEvenEmptyAndNaN) {
  EXPECT_DOUBLE_EQ(Median({3.0, 1.0, 2.0}), 2.0);
  EXPECT_DOUBLE_EQ(Median({4.0, 1.0, 3.0, 2.0}), 2.5);
  EXPECT_DOUBLE_EQ(Median({7.0}), 7.0);
  EXPECT_TRUE(std::isnan(Median({})));
  EXPECT_TRUE(std::isnan(Median({1.0, std::nan(""), 2.0})));
}

TEST(AccuracyTest, PositionAndAxisErrorsOfKnownPoses) {
  const Transform target = Transform::Identity();
  const std::vector<Transform> reached = {
      PoseWithAxisTilt({3.0, 4.0, 0.0}, 0.0),      // 5 mm, axis exact
      PoseWithAxisTilt({0.0, 0.0, 0.0}, 1e-3),     // axis tilted by 1 mrad
      PoseWithAxisTilt({0.0, 0.0, 0.0}, M_PI / 2)  // axis perpendicular
  };
  const AccuracyReport r = ComputeAccuracy(reached, {target, target, target});
  ASSERT_EQ(r.e_xyz_values_mm.size(), 3u);
  EXPECT_DOUBLE_EQ(r.e_xyz_values_mm[0], 5.0);
  EXPECT_NEAR(r.e_cos_values_rad[0], 0.0, 1e-15);
  EXPECT_NEAR(r.e_cos_values_rad[1], 1e-3, 1e-15);
  EXPECT_NEAR(r.e_cos_values_rad[2], M_PI / 2, 1e-15);
  EXPECT_DOUBLE_EQ(r.h_mm, 30.0);
  EXPECT_NEAR(r.e_tot_values_mm[1], 30.0 * 1e-3, 1e-12);
  EXPECT_DOUBLE_EQ(r.e_xyz_mm.mean, 5.0 / 3.0);
  EXPECT_DOUBLE_EQ(r.e_xyz_mm.max, 5.0);
}

TEST(AccuracyTest, RotationAboutTheToolAxisIsNoAxisError) {
  Transform reached = Transform::Identity();
  reached.linear() = RotZ(0.7);
  const AccuracyReport r = ComputeAccuracy({reached}, {Transform::Identity()});
  EXPECT_NEAR(r.e_cos_values_rad[0], 0.0, 1e-15);
}

TEST(AccuracyTest, TinyAxisAnglesAreResolved) {
  // arccos of the dot product could not tell 1e-9 rad from 0.
  const AccuracyReport r = ComputeAccuracy({PoseWithAxisTilt(Eigen::Vector3d::Zero(), 1e-9)}, {Transform::Identity()});
  EXPECT_NEAR(r.e_cos_values_rad[0], 1e-9, 1e-15);
}

TEST(AccuracyTest, TotalErrorUsesTheGivenLever) {
  Transform target = Transform::Identity();
  target.translation() = Eigen::Vector3d(100, 200, 300);
  Transform reached = target;
  reached.translation() += Eigen::Vector3d(0.0, 0.0, 0.02);
  reached.linear() = RotX(2e-4);
  const AccuracyReport r = ComputeAccuracy({reached}, {target}, 150.0);
  EXPECT_DOUBLE_EQ(r.h_mm, 150.0);
  EXPECT_NEAR(r.e_tot_values_mm[0], 0.02 + 150.0 * 2e-4, 1e-12);
  EXPECT_NEAR(r.e_tot_mm.mean, 0.05, 1e-12);
}

// The statistics of all three errors against values worked out by hand: position errors 10, 20, 30 um and
// axis tilts 1, 2, 3 mrad (about different axes, so only the angle counts), h = 30 mm.
TEST(AccuracyTest, StatisticsOfAllThreeErrorsMatchHandComputedValues) {
  const std::vector<Transform> target(3, Transform::Identity());
  std::vector<Transform> reached(3, Transform::Identity());
  reached[0].translation() = Eigen::Vector3d(0.010, 0.0, 0.0);
  reached[0].linear() = RotX(1e-3);
  reached[1].translation() = Eigen::Vector3d(0.0, 0.012, 0.016);  // |(0, 12, 16)| = 20 um
  reached[1].linear() = RotY(-2e-3);
  reached[2].translation() = Eigen::Vector3d(0.0, 0.0, -0.030);
  // A tilt of 3 mrad about the diagonal (1, 1, 0) / sqrt(2).
  reached[2].linear() = Eigen::AngleAxisd(3e-3, Eigen::Vector3d(1.0, 1.0, 0.0).normalized()).toRotationMatrix();
  const AccuracyReport r = ComputeAccuracy(reached, target);

  // E_xyz: 0.01, 0.02, 0.03 mm -> mean 0.02, std sqrt((1e-4 + 0 + 1e-4) / 2) = 0.01, max 0.03, RP 0.05.
  EXPECT_NEAR(r.e_xyz_mm.mean, 0.02, 1e-15);
  EXPECT_NEAR(r.e_xyz_mm.std, 0.01, 1e-15);
  EXPECT_NEAR(r.e_xyz_mm.max, 0.03, 1e-15);
  EXPECT_NEAR(r.e_xyz_mm.rp, 0.05, 1e-15);
  // E_cos: 1, 2, 3 mrad -> mean 2e-3, std 1e-3, max 3e-3, RP 5e-3.
  EXPECT_NEAR(r.e_cos_rad.mean, 2e-3, 1e-15);
  EXPECT_NEAR(r.e_cos_rad.std, 1e-3, 1e-15);
  EXPECT_NEAR(r.e_cos_rad.max, 3e-3, 1e-15);
  EXPECT_NEAR(r.e_cos_rad.rp, 5e-3, 1e-15);
  // E_tot = E_xyz + 30 E_cos: 0.04, 0.08, 0.12 mm -> mean 0.08, std 0.04, max 0.12, RP 0.2.
  EXPECT_NEAR(r.e_tot_values_mm[1], 0.08, 1e-14);
  EXPECT_NEAR(r.e_tot_mm.mean, 0.08, 1e-14);
  EXPECT_NEAR(r.e_tot_mm.std, 0.04, 1e-14);
  EXPECT_NEAR(r.e_tot_mm.max, 0.12, 1e-14);
  EXPECT_NEAR(r.e_tot_mm.rp, 0.2, 1e-14);
  EXPECT_EQ(r.e_tot_mm.count, 3);

  // The table prints them in um and arc-seconds: E_tot RP 200.0 um, E_cos mean 2e-3 rad = 412.5 arcsec.
  const std::string table = FormatAccuracyTable(r, "hand");
  EXPECT_THAT(table, HasSubstr("200.0"));
  EXPECT_THAT(table, HasSubstr("412.5"));
}

TEST(AccuracyTest, RejectsMismatchedOrEmptyInputAndBadLever) {
  const Transform t = Transform::Identity();
  EXPECT_THROW(ComputeAccuracy({}, {}), std::invalid_argument);
  EXPECT_THROW(ComputeAccuracy({t, t}, {t}), std::invalid_argument);
  EXPECT_THROW(ComputeAccuracy({t}, {t}, 0.0), std::invalid_argument);
  EXPECT_THROW(ComputeAccuracy({t}, {t}, std::nan("")), std::invalid_argument);
}

TEST(AccuracyTest, BadInputMessagesNameTheArgument) {
  const auto message = [](auto&& call) -> std::string {
    try {
      call();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no exception";
  };
  const Transform t = Transform::Identity();
  Transform nan_pose = t;
  nan_pose.translation().z() = std::nan("");
  EXPECT_THAT(message([&] { ComputeAccuracy({t, nan_pose}, {t, t}); }), HasSubstr("reached[1] is not finite"));
  EXPECT_THAT(message([&] { ComputeAccuracy({t, t}, {nan_pose, t}); }), HasSubstr("target[0] is not finite"));
  EXPECT_THAT(message([&] { ComputeAccuracy({t, t}, {t}); }), HasSubstr("got 2 and 1"));
  EXPECT_THAT(message([&] { ComputeAccuracy({t}, {t}, -1.0); }), HasSubstr("h_mm"));
  EXPECT_THAT(message([&] { ComputeErrorStatistics({}); }), HasSubstr("empty sample"));
  EXPECT_THAT(message([&] { ComputeErrorStatistics({1.0, 2.0, INFINITY}); }), HasSubstr("values[2] is not finite"));
}

TEST(AccuracyTest, TableIsInMicrometresAndArcSeconds) {
  Transform reached = Transform::Identity();
  reached.translation() = Eigen::Vector3d(0.0547, 0.0, 0.0);
  reached.linear() = RotX(M_PI / (180.0 * 3600.0));  // one arc-second
  const AccuracyReport r = ComputeAccuracy({reached}, {Transform::Identity()});
  const std::string table = FormatAccuracyTable(r, "Optimal configurations");
  EXPECT_THAT(table, HasSubstr("Optimal configurations (N = 1, E_tot = E_xyz + 30 mm * E_cos)"));
  EXPECT_THAT(table, HasSubstr("E_xyz um"));
  EXPECT_THAT(table, HasSubstr("54.7"));
  EXPECT_THAT(table, HasSubstr("E_cos arcsec"));
  EXPECT_THAT(table, HasSubstr("1.0"));
  EXPECT_THAT(table, HasSubstr("E_tot um"));
  for (const char* column : {"mean", "std", "max", "RP"}) EXPECT_THAT(table, HasSubstr(column));
}

TEST(ImprovementTest, PercentOfTheBaselineMatchesHandComputedValues) {
  // (8 - 6) / 8 = 25 %; (4 - 5) / 4 = -25 % (worse); (2 - 0) / 2 = 100 %; (0.03 - 0.0255) / 0.03 = 15 %.
  EXPECT_DOUBLE_EQ(ImprovementPercent(8.0, 6.0), 25.0);
  EXPECT_DOUBLE_EQ(ImprovementPercent(4.0, 5.0), -25.0);
  EXPECT_DOUBLE_EQ(ImprovementPercent(2.0, 0.0), 100.0);
  EXPECT_DOUBLE_EQ(ImprovementPercent(1.0, 1.0), 0.0);
  EXPECT_NEAR(ImprovementPercent(0.03, 0.0255), 15.0, 1e-12);
}

TEST(ImprovementTest, NoBaselineOrNonFiniteValuesGiveNaN) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(std::isnan(ImprovementPercent(0.0, 0.0)));
  EXPECT_TRUE(std::isnan(ImprovementPercent(0.0, 1.0)));
  EXPECT_TRUE(std::isnan(ImprovementPercent(-1.0, 0.5)));
  EXPECT_TRUE(std::isnan(ImprovementPercent(inf, 1.0)));
  EXPECT_TRUE(std::isnan(ImprovementPercent(std::nan(""), 1.0)));
  EXPECT_TRUE(std::isnan(ImprovementPercent(1.0, inf)));
  EXPECT_TRUE(std::isnan(ImprovementPercent(1.0, std::nan(""))));
  EXPECT_TRUE(std::isnan(AccuracyImprovement{}.e_tot_rp));
}

TEST(ImprovementTest, ReportsCompareEachErrorsMeanAndRp) {
  // before: E_xyz 1 and 3 mm on the z axis (mean 2, std sqrt 2), after: 0.5 and 1.5 (mean 1, std sqrt 0.5):
  // every position figure halves, 50 %. Orientation is exact in both: E_cos has no baseline, so E_tot is E_xyz.
  const Transform target = Transform::Identity();
  const auto at = [&](double z_mm) {
    Transform t = target;
    t.translation().z() = z_mm;
    return t;
  };
  const AccuracyReport before = ComputeAccuracy({at(1.0), at(3.0)}, {target, target});
  const AccuracyReport after = ComputeAccuracy({at(0.5), at(1.5)}, {target, target});
  const AccuracyImprovement x = ComputeImprovement(before, after);
  EXPECT_DOUBLE_EQ(x.e_xyz_mean, 50.0);
  EXPECT_DOUBLE_EQ(x.e_xyz_rp, 50.0);
  EXPECT_DOUBLE_EQ(x.e_tot_mean, 50.0);
  EXPECT_DOUBLE_EQ(x.e_tot_rp, 50.0);
  EXPECT_TRUE(std::isnan(x.e_cos_mean));
  EXPECT_TRUE(std::isnan(x.e_cos_rp));
  // The other way round: twice the error, -100 %.
  EXPECT_DOUBLE_EQ(ComputeImprovement(after, before).e_xyz_mean, -100.0);
}

}  // namespace
}  // namespace robocal
