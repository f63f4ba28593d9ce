// The virtual cell: reproducibility, the hidden placement and errors, and the statistics of its noise.
#include <algorithm>
#include <cmath>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/cell.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

Eigen::VectorXd Config(const RobotModel& model, std::uint64_t seed) {
  Rng rng(seed);
  return RandomConfiguration(model, &rng);
}

TEST(VirtualCellTest, SameSeedGivesTheSameCellAndShots) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 42;
  VirtualCell a(model, o), b(model, o);
  EXPECT_EQ(a.true_errors(), b.true_errors());
  EXPECT_TRUE(a.true_model().T_world_base().isApprox(b.true_model().T_world_base(), 0.0));
  const Eigen::VectorXd q = Config(model, 1);
  const auto shots_a = a.Measure(q, 3);
  const auto shots_b = b.Measure(q, 3);
  ASSERT_EQ(shots_a.size(), 3u);
  for (size_t i = 0; i < shots_a.size(); ++i) {
    EXPECT_EQ(shots_a[i].T_world_tool.matrix(), shots_b[i].T_world_tool.matrix());
  }
  o.seed = 43;
  VirtualCell c(model, o);
  EXPECT_NE(a.true_errors(), c.true_errors());
}

// A noise stream keeps the hidden robot and draws other, reproducible noise (a validation dump made by another
// process must not repeat the calibration dump's draws).
TEST(VirtualCellTest, NoiseStreamsDrawOtherNoiseForTheSameRobot) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 42;
  VirtualCell first(model, o), second(model, o), again(model, o);
  second.StartNoiseStream(1);
  again.StartNoiseStream(1);
  EXPECT_EQ(first.true_errors(), second.true_errors());
  const Eigen::VectorXd q = Config(model, 1);
  const auto a = first.Measure(q, 2), b = second.Measure(q, 2), c = again.Measure(q, 2);
  ASSERT_EQ(b.size(), 2u);
  for (size_t i = 0; i < b.size(); ++i) {
    EXPECT_EQ(b[i].T_world_tool.matrix(), c[i].T_world_tool.matrix());
    // Both are noisy shots of one true pose: apart by about the noise (0.015 mm per axis), not equal.
    const double apart = (a[i].T_world_tool.translation() - b[i].T_world_tool.translation()).norm();
    EXPECT_GT(apart, 1e-6);
    EXPECT_LT(apart, 0.2);
  }
}

TEST(VirtualCellTest, NoiseSettingsDoNotChangeTheHiddenRobot) {
  const RobotModel model = Preset("puma560");
  VirtualCellOptions noisy, exact;
  noisy.seed = exact.seed = 7;
  exact.noise = {0.0, 0.0};
  exact.shots_per_pose = 1;
  VirtualCell a(model, noisy), b(model, exact);
  EXPECT_EQ(a.true_errors(), b.true_errors());
  EXPECT_EQ(a.true_model().T_world_base().matrix(), b.true_model().T_world_base().matrix());
}

TEST(VirtualCellTest, TrackerStandsAtTheConfiguredDistanceWithATiltedVerticalAxis) {
  const RobotModel model = Preset("ur5e");  // nominal T_world_base is the identity
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    VirtualCellOptions o;
    o.seed = seed;
    const VirtualCell cell(model, o);
    const Transform T_tracker_base = cell.true_model().T_world_base();
    EXPECT_NEAR(T_tracker_base.translation().norm(), o.tracker_distance_mm, 1e-9);
    // Tilt only: the base z axis seen from the tracker is near vertical (5 sigma of 0.05 rad per axis).
    const double tilt = std::acos(std::clamp(T_tracker_base.linear()(2, 2), -1.0, 1.0));
    EXPECT_LT(tilt, 0.35) << "seed " << seed;
  }
}

TEST(VirtualCellTest, HiddenErrorsHaveTheConfiguredMagnitudes) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  double joint_mm = 0.0, joint_rad = 0.0, tool_mm = 0.0, tool_rad = 0.0;
  int n_joint = 0, n_tool = 0;
  const int tool_site = model.num_error_sites() - 1;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    o.seed = seed;
    const VirtualCell cell(model, o);
    const Eigen::VectorXd& e = cell.true_errors();
    EXPECT_TRUE(e.head<6>().isZero(0.0)) << "base errors are left to the tracker placement";
    for (int site = 1; site <= tool_site; ++site) {
      const double mm2 = e.segment<3>(6 * site).squaredNorm(), rad2 = e.segment<3>(6 * site + 3).squaredNorm();
      if (site == tool_site) {
        tool_mm += mm2, tool_rad += rad2, n_tool += 3;
      } else {
        joint_mm += mm2, joint_rad += rad2, n_joint += 3;
      }
    }
  }
  // 720 joint and 120 tool samples: sample sigmas within 10 % and 25 % (about 4 standard errors).
  EXPECT_NEAR(std::sqrt(joint_mm / n_joint), o.joint_translation_sigma_mm, 0.1 * o.joint_translation_sigma_mm);
  EXPECT_NEAR(std::sqrt(joint_rad / n_joint), o.joint_rotation_sigma_rad, 0.1 * o.joint_rotation_sigma_rad);
  EXPECT_NEAR(std::sqrt(tool_mm / n_tool), o.tool_translation_sigma_mm, 0.25 * o.tool_translation_sigma_mm);
  EXPECT_NEAR(std::sqrt(tool_rad / n_tool), o.tool_rotation_sigma_rad, 0.25 * o.tool_rotation_sigma_rad);
}

TEST(VirtualCellTest, NoiseFreeShotsAreTheTruePose) {
  const RobotModel model = Preset("grinder5");
  VirtualCellOptions o;
  o.noise = {0.0, 0.0};
  VirtualCell cell(model, o);
  const Eigen::VectorXd q = Config(model, 3);
  const auto shots = cell.Measure(q);
  ASSERT_EQ(static_cast<int>(shots.size()), o.shots_per_pose);
  for (const Measurement& m : shots) {
    EXPECT_EQ(m.joints, q);
    EXPECT_TRUE(m.T_world_tool.isApprox(cell.TruePose(q), 1e-15));
  }
  // The true pose differs from the nominal model's with the true placement by the hidden errors (> 0.1 mm).
  KinematicsWorkspace ws(model);
  const Transform without_errors = ForwardKinematics(cell.true_model(), q, Eigen::VectorXd(), &ws);
  EXPECT_GT((without_errors.translation() - cell.TruePose(q).translation()).norm(), 0.1);
}

TEST(VirtualCellTest, ShotNoiseHasTheConfiguredSigmaPerAxis) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 11;
  VirtualCell cell(model, o);
  const Eigen::VectorXd q = Config(model, 5);
  const Transform truth = cell.TruePose(q);
  const int shots = 2000;
  Eigen::Vector3d sum_p = Eigen::Vector3d::Zero(), sum_p2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_w2 = Eigen::Vector3d::Zero();
  for (const Measurement& m : cell.Measure(q, shots)) {
    const Eigen::Vector3d dp = m.T_world_tool.translation() - truth.translation();
    const Eigen::Vector3d dw = RotationVector(m.T_world_tool.linear() * truth.linear().transpose());
    sum_p += dp;
    sum_p2 += dp.cwiseProduct(dp);
    sum_w2 += dw.cwiseProduct(dw);
  }
  for (int k = 0; k < 3; ++k) {
    // Standard error of a sample sigma from 2000 draws: 1.6 %; of the mean: sigma / 45.
    EXPECT_NEAR(std::sqrt(sum_p2[k] / shots), o.noise.position_mm, 0.07 * o.noise.position_mm) << k;
    EXPECT_NEAR(sum_p[k] / shots, 0.0, 0.1 * o.noise.position_mm) << k;
    EXPECT_NEAR(std::sqrt(sum_w2[k] / shots), o.noise.orientation_rad, 0.07 * o.noise.orientation_rad) << k;
  }
}

TEST(VirtualCellTest, MeasureAllConcatenatesShotsInOrder) {
  const RobotModel model = Preset("puma560");
  VirtualCellOptions o;
  o.shots_per_pose = 2;
  VirtualCell cell(model, o);
  const std::vector<Eigen::VectorXd> configurations = {Config(model, 1), Config(model, 2), Config(model, 3)};
  const auto all = cell.MeasureAll(configurations);
  ASSERT_EQ(all.size(), 6u);
  for (size_t i = 0; i < all.size(); ++i) EXPECT_EQ(all[i].joints, configurations[i / 2]);
  EXPECT_EQ(cell.MeasureAll(configurations, 4).size(), 12u);
  EXPECT_THROW(cell.Measure(Eigen::VectorXd::Zero(2)), std::invalid_argument);
}

TEST(VirtualCellTest, NonFiniteJointsAreRejectedNotMeasuredAsNan) {
  const RobotModel model = Preset("grinder5");
  VirtualCell cell(model);
  Eigen::VectorXd q = Config(model, 1);
  q[3] = NAN;
  for (int call = 0; call < 2; ++call) {
    try {
      if (call == 0) {
        cell.Measure(q, 1);
      } else {
        cell.TruePose(q);
      }
      ADD_FAILURE() << "no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("q is not finite"));
    }
  }
}

TEST(VirtualCellTest, InvalidOptionsAreRejectedByName) {
  const RobotModel model = Preset("ur5e");
  const auto expect_rejected = [&](VirtualCellOptions o, const std::string& name) {
    std::string error;
    EXPECT_FALSE(o.IsValid(&error)) << name;
    EXPECT_THAT(error, HasSubstr(name));
    try {
      VirtualCell cell(model, o);
      ADD_FAILURE() << "no exception for " << name;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr(name));
    }
  };
  VirtualCellOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error)) << error;
  o.joint_translation_sigma_mm = -1.0;
  expect_rejected(o, "joint_translation_sigma_mm");
  o = {};
  o.tool_rotation_sigma_rad = NAN;
  expect_rejected(o, "tool_rotation_sigma_rad");
  o = {};
  o.tracker_distance_mm = INFINITY;
  expect_rejected(o, "tracker_distance_mm");
  o = {};
  o.noise.position_mm = -0.01;
  expect_rejected(o, "noise.position_mm");
  o = {};
  o.noise.orientation_rad = NAN;
  expect_rejected(o, "noise.orientation_rad");
  o = {};
  o.shots_per_pose = 0;
  expect_rejected(o, "shots_per_pose");
  o = {};
  o.joint_rotation_sigma_rad = 0.5;
  expect_rejected(o, "joint_rotation_sigma_rad");
}

// ---- With a measurement cell ----------------------------------------------------------------------------

VirtualCellOptions InPresetCell(const std::string& robot, std::uint64_t seed) {
  VirtualCellOptions o;
  o.seed = seed;
  o.measurement_cell = PresetCellSpec(robot);
  return o;
}

TEST(VirtualCellInACellTest, MeasuresOnlyFeasibleConfigurationsAndCountsTheOthers) {
  const RobotModel model = Preset("ur5e");
  VirtualCell cell(model, InPresetCell("ur5e", 3));
  ASSERT_NE(cell.measurement_cell(), nullptr);
  // An independent cell built from the same spec decides.
  const Cell reference = Cell::Build(model, PresetCellSpec("ur5e"));
  const RobotModel planning = reference.PlanningModel(model);
  int feasible = 0;
  for (std::uint64_t seed = 1; seed <= 300; ++seed) {
    const Eigen::VectorXd q = Config(planning, seed);
    const bool expected = CheckConfiguration(model, reference, q).feasible;
    EXPECT_EQ(cell.Measurable(q), expected) << seed;
    EXPECT_EQ(cell.Measure(q, 2).size(), expected ? 2u : 0u) << seed;
    feasible += expected;
  }
  EXPECT_GT(feasible, 0);  // both outcomes seen
  EXPECT_EQ(cell.unmeasured(), 300 - feasible);
}

TEST(VirtualCellInACellTest, MeasureAllReportsTheLostConfigurations) {
  const RobotModel model = Preset("puma560");
  VirtualCell cell(model, InPresetCell("puma560", 5));
  const Cell reference = Cell::Build(model, PresetCellSpec("puma560"));
  std::vector<Eigen::VectorXd> configurations;
  std::vector<int> expected_lost;
  Rng rng(17);
  for (int i = 0; i < 60; ++i) {
    configurations.push_back(RandomConfiguration(model, &rng));
    if (!IsFeasible(model, reference, configurations.back())) expected_lost.push_back(i);
  }
  ASSERT_FALSE(expected_lost.empty());
  ASSERT_LT(expected_lost.size(), configurations.size());
  std::vector<int> lost = {99};  // replaced, not appended to
  const std::vector<Measurement> shots = cell.MeasureAll(configurations, 3, &lost);
  EXPECT_EQ(lost, expected_lost);
  EXPECT_EQ(shots.size(), 3 * (configurations.size() - lost.size()));
  EXPECT_EQ(cell.unmeasured(), static_cast<int>(lost.size()));
  // Shots come in order, only of the measurable configurations.
  size_t next = 0;
  for (size_t i = 0, k = 0; i < configurations.size(); ++i) {
    if (k < lost.size() && lost[k] == static_cast<int>(i)) {
      ++k;
      continue;
    }
    EXPECT_EQ(shots[next].joints, configurations[i]);
    next += 3;
  }
}

TEST(VirtualCellInACellTest, TheTrackerStandsWhereTheCellSaysAndTheHiddenRobotIsKept) {
  const RobotModel model = Preset("grinder5");
  VirtualCellOptions no_cell = InPresetCell("grinder5", 9);
  no_cell.measurement_cell.reset();
  const VirtualCell in_cell(model, InPresetCell("grinder5", 9)), anywhere(model, no_cell);
  EXPECT_EQ(in_cell.true_errors(), anywhere.true_errors());
  // The tracker's origin, seen from the base, is the cell's tracker position; its orientation is the drawn one.
  const Transform T_base_tracker = in_cell.true_model().T_world_base().inverse();
  EXPECT_TRUE(T_base_tracker.translation().isApprox(PresetCellSpec("grinder5").tracker.position_mm, 1e-12));
  EXPECT_TRUE(T_base_tracker.linear().isApprox(anywhere.true_model().T_world_base().inverse().linear(), 1e-12));
  // Without a cell everything is measured.
  EXPECT_EQ(anywhere.measurement_cell(), nullptr);
  VirtualCell counting(model, no_cell);
  for (std::uint64_t seed = 1; seed <= 20; ++seed) EXPECT_TRUE(counting.Measurable(Config(model, seed)));
  EXPECT_EQ(counting.MeasureAll({Config(model, 1), Config(model, 2)}, 1).size(), 2u);
  EXPECT_EQ(counting.unmeasured(), 0);
}

TEST(VirtualCellInACellTest, AnInvalidCellIsRejected) {
  VirtualCellOptions o = InPresetCell("ur5e", 1);
  o.measurement_cell->clearance_mm = -1.0;
  EXPECT_THROW(VirtualCell(Preset("ur5e"), o), std::invalid_argument);
}

}  // namespace
}  // namespace robocal
