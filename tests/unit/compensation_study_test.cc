// The compensation study on a small scale: counts add up, no Cartesian target is solved on a branch it did not
// ask for, the smooth path keeps its branch, and the figures do not depend on the thread count.
#include "robocal/core/compensation_study.h"

#include <gtest/gtest.h>

#include "robocal/core/arm_kinematics.h"
#include "robocal/core/robot_model.h"

namespace robocal {
namespace {

TEST(CompensationStudyTest, SmallRunHoldsTheStudysProperties) {
  CompensationStudyOptions o;
  o.robots = {"grinder5", "ur10_mdh"};
  o.joint_targets = 300;
  o.cartesian_targets = 150;
  o.path_targets = 120;
  o.threads = 1;
  const CompensationStudyResult one = RunCompensationStudy(o);
  ASSERT_EQ(one.rows.size(), 2u);
  const CompensationStudyRow& grinder = one.rows[0];
  EXPECT_FALSE(grinder.named_branches);
  EXPECT_EQ(grinder.cartesian_targets, 0);
  EXPECT_EQ(grinder.joint_converged + grinder.joint_degraded + grinder.joint_no_convergence, 300);
  EXPECT_GE(grinder.joint_converged, 290);
  const CompensationStudyRow& ur10 = one.rows[1];
  EXPECT_TRUE(ur10.named_branches);
  EXPECT_EQ(ur10.joint_converged + ur10.joint_degraded + ur10.joint_no_convergence, 300);
  EXPECT_GE(ur10.joint_converged, 280);
  EXPECT_EQ(ur10.cartesian_other_branch, 0);
  EXPECT_GE(ur10.cartesian_on_branch, 147);
  EXPECT_LE(ur10.cartesian_default_branch, ur10.cartesian_default_solved);
  EXPECT_EQ(ur10.path_targets, 120);
  EXPECT_EQ(ur10.path_converged, 120);
  EXPECT_EQ(ur10.path_branch_changes, 0);
  EXPECT_LT(ur10.path_max_joint_step_deg, 5.0);
  EXPECT_LT(ur10.path_max_deviation_deg, 1.0);

  o.threads = 2;
  const CompensationStudyResult two = RunCompensationStudy(o);
  EXPECT_EQ(FormatCompensationStudy(two), FormatCompensationStudy(one));
}

TEST(CompensationStudyTest, TheMdhArmIsAnOffsetWristArm) {
  const RobotModel model = RobotModel::Build(Ur10LikeMdhSpec());
  ASSERT_TRUE(ArmSolver::For(model).has_value());
  EXPECT_EQ(ArmSolver::For(model)->family(), ArmFamily::kOffsetWrist);
}

TEST(CompensationStudyTest, RefusesBadOptionsAndUnknownRobots) {
  CompensationStudyOptions o;
  o.joint_targets = -1;
  EXPECT_THROW(RunCompensationStudy(o), std::invalid_argument);
  o = {};
  o.robots = {"nosuch"};
  EXPECT_THROW(RunCompensationStudy(o), std::invalid_argument);
}

}  // namespace
}  // namespace robocal
