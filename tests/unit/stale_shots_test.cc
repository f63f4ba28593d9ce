// Stale tracker readings (FlagStaleShots): a shot that repeats the one before it although the robot moved is
// flagged, and no other; a fit leaves it out and lists it with its cause.
#include <gtest/gtest.h>

#include <vector>

#include "robocal/core/identification.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"
#include "test_util.h"

namespace robocal {
namespace {

std::vector<Measurement> Shots(const RobotModel& model, int count, std::uint64_t seed) {
  VirtualCellOptions o;
  o.seed = seed;
  o.shots_per_pose = 1;
  VirtualCell cell(model, o);
  return cell.MeasureAll(test::RandomConfigurations(model, count, seed + 1));
}

TEST(StaleShotTest, AnInjectedRepeatIsFlaggedAndNothingElse) {
  const RobotModel model = Preset("ur5e");
  for (MeasurementType type : {MeasurementType::kPosition, MeasurementType::kPositionAxis, MeasurementType::kPose}) {
    std::vector<Measurement> shots = Shots(model, 120, 7);
    // Shot 40 reads what shot 39 read (the tracker had not updated), within its noise.
    shots[40].T_world_tool = shots[39].T_world_tool;
    shots[40].T_world_tool.translation() += Eigen::Vector3d(0.03, -0.02, 0.01);
    const std::vector<char> flags = FlagStaleShots(model, shots, type, 0.05);
    for (size_t i = 0; i < shots.size(); ++i) EXPECT_EQ(flags[i] != 0, i == 40) << ToString(type) << " shot " << i;
  }
}

TEST(StaleShotTest, ARepeatedPoseOrAReadingJustBeyondTheToleranceIsNotStale) {
  const RobotModel model = Preset("ur5e");
  std::vector<Measurement> shots = Shots(model, 30, 9);
  // A second shot of the same configuration: the robot did not move, so a repeat is what it should read.
  shots[11] = shots[10];
  // A reading 0.15 mm from the one before it, the robot having moved: beyond the 0.1 mm tolerance.
  shots[21].T_world_tool = shots[20].T_world_tool;
  shots[21].T_world_tool.translation() += Eigen::Vector3d(0.15, 0, 0);
  const std::vector<char> flags = FlagStaleShots(model, shots, MeasurementType::kPosition, 0.05);
  for (size_t i = 0; i < shots.size(); ++i) EXPECT_EQ(flags[i], 0) << "shot " << i;
  // The first shot of a batch is compared with the shot before the batch.
  std::vector<Measurement> batch(shots.begin() + 22, shots.end());
  batch[0].T_world_tool = shots[21].T_world_tool;
  EXPECT_EQ(FlagStaleShots(model, batch, MeasurementType::kPosition, 0.05, {}, &shots[21])[0], 1);
  EXPECT_EQ(FlagStaleShots(model, batch, MeasurementType::kPosition, 0.05)[0], 0);
}

TEST(StaleShotTest, AFitLeavesAStaleShotOutAndListsItsCause) {
  const RobotModel model = Preset("ur5e");
  std::vector<Measurement> shots = Shots(model, 80, 11);
  std::vector<Measurement> without = shots;
  without.erase(without.begin() + 30);
  shots[30].T_world_tool = shots[29].T_world_tool;
  shots[30].stale = true;
  IdentificationOptions options;
  options.measurement_type = MeasurementType::kPosition;
  const Calibration with_stale = Identify(model, shots, options);
  const Calibration clean = Identify(model, without, options);
  ASSERT_NE(with_stale.summary.termination, Termination::kFailure) << with_stale.summary.message;
  EXPECT_LT((with_stale.errors - clean.errors).cwiseAbs().maxCoeff(), 1e-12);
  bool listed = false;
  for (const OutlierMeasurement& o : with_stale.summary.outliers) {
    if (o.measurement != 30) continue;
    listed = true;
    EXPECT_EQ(o.cause, OutlierMeasurement::Cause::kStale);
    EXPECT_GT(o.normalized_residual, 3.0);  // it is off: the robot moved and the reading did not
  }
  EXPECT_TRUE(listed) << with_stale.summary.message;
  for (const OutlierMeasurement& o : with_stale.summary.outliers) {
    if (o.measurement != 30) {
      EXPECT_EQ(o.cause, OutlierMeasurement::Cause::kResidual);
    }
  }
  EXPECT_NE(with_stale.summary.message.find("1 stale tracker reading(s) left out"), std::string::npos);
}

}  // namespace
}  // namespace robocal
