// Closed-form inverse kinematics of the 6R families: the families are recognised from the axes, every
// solution reaches its pose on the nominal chain, the eight branches of a pose are distinct and the
// configuration's own branch is among them, and the flags mean what docs/compensation.md says (elbow above the
// shoulder-wrist line, wrist flip by joint 5's sign, shoulder kept along a path that stays off the singularity).
#include "robocal/core/arm_kinematics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>
#include <tuple>

#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

constexpr double kPi = std::numbers::pi;

// The base-frame tool pose of the nominal chain.
Transform BaseTool(const RobotModel& model, const Eigen::VectorXd& q) {
  return model.T_world_base().inverse() * ForwardKinematics(model, q);
}

// Random joints in (-pi, pi] (the closed form's range), within the limits where the limits allow.
Eigen::VectorXd RandomJoints(const RobotModel& model, Rng* rng) {
  Eigen::VectorXd q(6);
  for (int i = 0; i < 6; ++i) {
    q[i] = rng->Uniform(std::max(-kPi, model.lower_limits()[i]), std::min(kPi, model.upper_limits()[i]));
  }
  return q;
}

double AngleDistance(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  double most = 0.0;
  for (int i = 0; i < a.size(); ++i) most = std::max(most, std::abs(std::remainder(a[i] - b[i], 2.0 * kPi)));
  return most;
}

TEST(ArmSolverTest, RecognisesTheFamiliesFromTheAxes) {
  ASSERT_TRUE(ArmSolver::For(Preset("puma560")).has_value());
  EXPECT_EQ(ArmSolver::For(Preset("puma560"))->family(), ArmFamily::kSphericalWrist);
  ASSERT_TRUE(ArmSolver::For(Preset("ur5e")).has_value());
  EXPECT_EQ(ArmSolver::For(Preset("ur5e"))->family(), ArmFamily::kOffsetWrist);
  EXPECT_FALSE(ArmSolver::For(Preset("grinder5")).has_value());
  // The same UR geometry with a wrist offset that keeps axes 5 and 6 apart is no known family.
  RobotModelSpec spec = PresetSpec("ur5e");
  spec.joints[4].a_mm = 10.0;
  EXPECT_FALSE(ArmSolver::For(RobotModel::Build(spec)).has_value());
}

class ArmSolverPresetTest : public ::testing::TestWithParam<const char*> {};

TEST_P(ArmSolverPresetTest, EveryBranchReachesThePoseAndTheConfigurationsOwnIsAmongThem) {
  const RobotModel model = Preset(GetParam());
  const ArmSolver arm = *ArmSolver::For(model);
  Rng rng(11);
  int eight = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::VectorXd q = RandomJoints(model, &rng);
    const Transform pose = BaseTool(model, q);
    const std::vector<ArmSolution> solutions = arm.Solve(pose, Eigen::VectorXd::Zero(6));
    std::set<std::tuple<int, int, int>> branches;
    bool own = false;
    int exact = 0;
    for (const ArmSolution& s : solutions) {
      const Transform reached = BaseTool(model, s.joints);
      const double miss = (reached.translation() - pose.translation()).norm();
      EXPECT_NEAR(s.position_error_mm, miss, 1e-9);
      EXPECT_EQ(s.configuration, arm.ConfigurationOf(s.joints));
      // A branch just out of reach gives its stretched configuration as a start (a few mm off), no more.
      EXPECT_LE(s.position_error_mm, 20.0);
      if (s.position_error_mm > 1e-6) continue;
      ++exact;
      EXPECT_LT(RotationVector(pose.linear() * reached.linear().transpose()).norm(), 1e-9);
      branches.insert({s.configuration.shoulder, s.configuration.elbow, s.configuration.wrist});
      own = own || AngleDistance(s.joints, q) < 1e-6;
    }
    EXPECT_TRUE(own) << "trial " << trial;
    EXPECT_EQ(branches.size(), exact) << "trial " << trial;
    if (exact == 8) ++eight;
  }
  // The spherical wrist reaches a pose on all eight branches unless a singularity is near (rare in a uniform
  // draw); the offset wrist's branches of the other shoulder or wrist often leave the elbow out of reach.
  if (arm.family() == ArmFamily::kSphericalWrist) {
    EXPECT_GE(eight, 490);
  }
  RecordProperty("poses_with_eight_solutions", eight);
}

// The wrist flag is joint 5's sign for the presets (docs/compensation.md), and a flag that is not on its
// singularity does not change when the other joints move.
TEST_P(ArmSolverPresetTest, WristFlagIsTheSignOfJointFive) {
  const RobotModel model = Preset(GetParam());
  const ArmSolver arm = *ArmSolver::For(model);
  Rng rng(12);
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::VectorXd q = RandomJoints(model, &rng);
    if (std::abs(std::sin(q[4])) < 1e-6) continue;
    EXPECT_EQ(arm.ConfigurationOf(q).wrist, std::sin(q[4]) > 0.0 ? 1 : -1) << q.transpose();
  }
}

// Elbow up means the elbow (axis 3) above the shoulder-wrist line, measured as height along joint 1's axis
// wherever that line is closer to horizontal than 30 deg and points outward from axis 1 (a check that shares
// nothing with the flag's formula).
TEST_P(ArmSolverPresetTest, ElbowUpIsAboveTheShoulderWristLine) {
  const RobotModel model = Preset(GetParam());
  const ArmSolver arm = *ArmSolver::For(model);
  const bool spherical = arm.family() == ArmFamily::kSphericalWrist;
  Rng rng(13);
  int checked = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::VectorXd q = RandomJoints(model, &rng);
    Transform frames[6], flange;
    NominalChainInBase(model, q, frames, &flange);
    const Eigen::Vector3d up = frames[0].linear().col(2), across = frames[1].linear().col(2);
    auto in_plane = [&](const Eigen::Vector3d& p) { return p - across * across.dot(p); };
    const Eigen::Vector3d shoulder = in_plane(frames[1].translation()), elbow = in_plane(frames[2].translation());
    // The spherical wrist's centre lies on axes 4, 5 and 6: joint 5's frame origin is on axis 5, and for these
    // presets on axis 4 as well; the offset wrist's line ends on axis 4.
    const Eigen::Vector3d wrist = in_plane(spherical ? frames[4].translation() : frames[3].translation());
    const Eigen::Vector3d line = wrist - shoulder;
    const double rise = up.dot(line), run = (line - up * rise).norm();
    if (run < 1.0 || std::abs(rise) > std::tan(kPi / 6) * run) continue;
    const Eigen::Vector3d horizontal = (line - up * rise) / run;
    // Only a wrist well out from axis 1 (200 mm: not folded over the base) and farther out than the shoulder
    // (the line directed outward).
    const Eigen::Vector3d axis1 = in_plane(frames[0].translation());
    const Eigen::Vector3d outward = (wrist - axis1) - up * up.dot(wrist - axis1);
    if (horizontal.dot(outward) <= 0.0 || outward.norm() < 200.0 ||
        outward.norm() < (shoulder - axis1 - up * up.dot(shoulder - axis1)).norm()) {
      continue;
    }
    const double t = horizontal.dot(elbow - shoulder) / run;
    const double height = up.dot(elbow - shoulder) - t * rise;
    if (std::abs(height) < 1.0) continue;
    EXPECT_EQ(arm.ConfigurationOf(q).elbow, height > 0.0 ? 1 : -1) << q.transpose();
    ++checked;
  }
  EXPECT_GT(checked, 200);
}

// Along a path whose joints stay away from every flag's singularity the flags do not change; the 8 branches of
// one pose each keep their flags when the pose moves a little.
TEST_P(ArmSolverPresetTest, BranchesFollowASmallMotion) {
  const RobotModel model = Preset(GetParam());
  const ArmSolver arm = *ArmSolver::For(model);
  Rng rng(14);
  for (int trial = 0; trial < 100; ++trial) {
    const Eigen::VectorXd q = RandomJoints(model, &rng);
    const Transform pose = BaseTool(model, q);
    const Transform moved = pose * TransformFromXyzRpy({0.01, -0.02, 0.01}, {1e-5, 2e-5, -1e-5});
    for (const ArmSolution& s : arm.Solve(pose, Eigen::VectorXd::Zero(6))) {
      if (s.position_error_mm > 1e-6) continue;
      // The nearest solution of the moved pose is the same branch, a small joint motion away (near a wrist
      // singularity joints 4 and 6 turn by up to 1 / sin(q5) times the motion).
      const std::vector<ArmSolution> after = arm.Solve(moved, Eigen::VectorXd::Zero(6));
      const ArmSolution* nearest = nullptr;
      for (const ArmSolution& m : after) {
        if (nearest == nullptr || AngleDistance(m.joints, s.joints) < AngleDistance(nearest->joints, s.joints)) {
          nearest = &m;
        }
      }
      ASSERT_NE(nearest, nullptr);
      EXPECT_EQ(nearest->configuration, s.configuration) << "trial " << trial;
      EXPECT_LT(AngleDistance(nearest->joints, s.joints), 0.05) << "trial " << trial;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(SixAxisPresets, ArmSolverPresetTest, ::testing::Values("puma560", "ur5e"));

TEST(ArmSolverTest, PoseBeyondReachHasNoSolution) {
  const RobotModel model = Preset("ur5e");
  const ArmSolver arm = *ArmSolver::For(model);
  Transform far = BaseTool(model, Eigen::VectorXd::Zero(6));
  far.translation() *= 3.0;
  EXPECT_TRUE(arm.Solve(far, Eigen::VectorXd::Zero(6)).empty());
}

TEST(ArmConfigurationTest, NamesAndParsing) {
  const ArmConfiguration c{1, -1, 1};
  EXPECT_EQ(c.ToString(), "shoulder front, elbow down, wrist noflip");
  EXPECT_EQ((ArmConfiguration{0, 1, 0}).ToString(), "elbow up");
  EXPECT_TRUE((ArmConfiguration{0, -1, 0}).Admits(c));
  EXPECT_FALSE((ArmConfiguration{-1, 0, 0}).Admits(c));
  int v = 0;
  EXPECT_TRUE(ParseConfigurationFlag("wrist", "flip", &v));
  EXPECT_EQ(v, -1);
  EXPECT_TRUE(ParseConfigurationFlag("shoulder", "front", &v));
  EXPECT_EQ(v, 1);
  EXPECT_FALSE(ParseConfigurationFlag("elbow", "front", &v));
  EXPECT_FALSE(ParseConfigurationFlag("knee", "up", &v));
}

}  // namespace
}  // namespace robocal
