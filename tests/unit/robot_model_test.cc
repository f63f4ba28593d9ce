// RobotModel factory validation, parameter naming and preset structure.
#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/robot_model.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

RobotModelSpec TwoLinkSpec() {
  RobotModelSpec spec;
  spec.name = "two_link";
  spec.convention = GeometryConvention::kStandardDh;
  JointSpec j1;
  j1.name = "shoulder";
  j1.a_mm = 300;
  j1.min = -1;
  j1.max = 1;
  JointSpec j2 = j1;
  j2.name = "elbow";
  j2.a_mm = 200;
  spec.joints = {j1, j2};
  return spec;
}

// Builds `spec`, expecting failure, and returns the field errors.
std::vector<FieldError> BuildErrors(const RobotModelSpec& spec) {
  try {
    RobotModel::Build(spec);
  } catch (const InvalidModelError& e) {
    return e.errors();
  }
  ADD_FAILURE() << "spec was accepted";
  return {};
}

bool HasError(const std::vector<FieldError>& errors, const std::string& field, const std::string& reason_part) {
  for (const FieldError& e : errors) {
    if (e.field == field && e.reason.find(reason_part) != std::string::npos) return true;
  }
  return false;
}

TEST(RobotModelTest, BuildsValidSpecAndNamesParameters) {
  const RobotModel model = RobotModel::Build(TwoLinkSpec());
  EXPECT_EQ(model.num_joints(), 2);
  EXPECT_EQ(model.num_error_parameters(), 24);
  EXPECT_EQ(model.parameter_name(0), "base.dx");
  EXPECT_EQ(model.parameter_name(6 + 5), "shoulder.rz");
  EXPECT_EQ(model.parameter_name(12 + 2), "elbow.dz");
  EXPECT_EQ(model.parameter_name(23), "tool.rz");
  EXPECT_EQ(model.ParameterIndex("elbow.dz"), 14);
  EXPECT_EQ(model.ParameterIndex("nope.dz"), -1);
}

TEST(RobotModelTest, RejectsLimitsWithMinNotBelowMaxNamingJointAndField) {
  RobotModelSpec spec = TwoLinkSpec();
  spec.joints[1].min = 2.0;
  spec.joints[1].max = 0.5;
  const auto errors = BuildErrors(spec);
  EXPECT_TRUE(HasError(errors, "joints[1].max", "must be greater than min")) << errors.size();
}

TEST(RobotModelTest, RejectsNonFiniteNumbers) {
  RobotModelSpec spec = TwoLinkSpec();
  spec.joints[0].a_mm = std::nan("");
  spec.joints[1].min = -INFINITY;
  const auto errors = BuildErrors(spec);
  EXPECT_TRUE(HasError(errors, "joints[0].a_mm", "finite"));
  EXPECT_TRUE(HasError(errors, "joints[1].min", "finite"));
}

TEST(RobotModelTest, RejectsBadNames) {
  RobotModelSpec spec = TwoLinkSpec();
  spec.name = "";
  spec.joints[1].name = "shoulder";
  auto errors = BuildErrors(spec);
  EXPECT_TRUE(HasError(errors, "name", "must not be empty"));
  EXPECT_TRUE(HasError(errors, "joints[1].name", "duplicate"));

  spec = TwoLinkSpec();
  spec.joints[0].name = "tool";
  spec.joints[1].name = "a.b";
  errors = BuildErrors(spec);
  EXPECT_TRUE(HasError(errors, "joints[0].name", "reserved"));
  EXPECT_TRUE(HasError(errors, "joints[1].name", "'.'"));
}

TEST(RobotModelTest, RejectsEmptyAndOversizedJointLists) {
  RobotModelSpec spec = TwoLinkSpec();
  spec.joints.clear();
  EXPECT_TRUE(HasError(BuildErrors(spec), "joints", "at least one"));
  spec = TwoLinkSpec();
  spec.joints.resize(kMaxJoints + 1, spec.joints[0]);
  for (size_t i = 0; i < spec.joints.size(); ++i) spec.joints[i].name = "j" + std::to_string(i);
  EXPECT_TRUE(HasError(BuildErrors(spec), "joints", "at most"));
}

TEST(RobotModelTest, RejectsNonRigidBaseAndToolAndExcessiveRevoluteRange) {
  RobotModelSpec spec = TwoLinkSpec();
  spec.T_world_base.linear() *= 2.0;
  spec.T_flange_tool.translation().x() = INFINITY;
  spec.joints[0].min = -4.5 * M_PI;  // 1620 degrees: more than four turns
  spec.joints[0].max = 4.5 * M_PI;
  const auto errors = BuildErrors(spec);
  EXPECT_TRUE(HasError(errors, "base", "orthonormal"));
  EXPECT_TRUE(HasError(errors, "tool", "finite"));
  EXPECT_TRUE(HasError(errors, "joints[0].max", "1440"));
}

TEST(RobotModelTest, ErrorMessageListsEveryProblem) {
  RobotModelSpec spec = TwoLinkSpec();
  spec.joints[0].max = -5;
  spec.joints[1].d_mm = NAN;
  try {
    RobotModel::Build(spec);
    FAIL();
  } catch (const InvalidModelError& e) {
    EXPECT_THAT(e.what(), HasSubstr("joints[0].max"));
    EXPECT_THAT(e.what(), HasSubstr("joints[1].d_mm"));
  }
}

TEST(RobotModelTest, WithinLimits) {
  const RobotModel model = RobotModel::Build(TwoLinkSpec());
  EXPECT_TRUE(model.WithinLimits(Eigen::Vector2d(0.5, -1.0)));
  EXPECT_FALSE(model.WithinLimits(Eigen::Vector2d(0.5, 1.01)));
  EXPECT_FALSE(model.WithinLimits(Eigen::Vector2d(NAN, 0.0)));
  EXPECT_FALSE(model.WithinLimits(Eigen::Vector3d(0, 0, 0)));
}

TEST(PresetsTest, AllPresetsBuild) {
  for (const std::string& name : PresetNames()) {
    const RobotModel model = Preset(name);
    EXPECT_EQ(model.name(), name);
    EXPECT_FALSE(PresetDescription(name).empty());
  }
  EXPECT_THROW(PresetSpec("kuka"), std::invalid_argument);
}

// The paper's robot: three mutually perpendicular prismatic joints, then two revolute joints whose axes
// intersect perpendicularly; at any configuration, not only at zero.
TEST(PresetsTest, Grinder5HasThePapersStructure) {
  const RobotModel model = Preset("grinder5");
  ASSERT_EQ(model.num_joints(), 5);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(model.joint_type(i), JointType::kPrismatic);
  for (int i = 3; i < 5; ++i) EXPECT_EQ(model.joint_type(i), JointType::kRevolute);
  KinematicsWorkspace ws(model);
  Rng rng(7);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    ForwardKinematics(model, q, Eigen::VectorXd(), &ws);
    Eigen::Vector3d axis[5];
    for (int i = 0; i < 5; ++i) axis[i] = ws.T_world_joint[i].linear().col(2);
    EXPECT_NEAR(axis[0].dot(axis[1]), 0.0, 1e-12);
    EXPECT_NEAR(axis[0].dot(axis[2]), 0.0, 1e-12);
    EXPECT_NEAR(axis[1].dot(axis[2]), 0.0, 1e-12);
    EXPECT_NEAR(axis[3].dot(axis[4]), 0.0, 1e-12);
    // Intersecting axes: the C axis line passes through the A joint frame's origin.
    const Eigen::Vector3d c_origin = ws.T_world_joint[3].translation();
    const Eigen::Vector3d a_origin = ws.T_world_joint[4].translation();
    EXPECT_LT((a_origin - c_origin).cross(axis[3]).norm(), 1e-9);
    // Tool of about 150 mm from the A axis.
    const Eigen::Vector3d tool = ws.T_world_tool.translation();
    EXPECT_NEAR((tool - a_origin).norm(), std::hypot(150.0, 20.0), 1e-9);
  }
}

TEST(MeasurementTypeTest, RowsAndNames) {
  EXPECT_EQ(MeasurementRows(MeasurementType::kPosition), 3);
  EXPECT_EQ(MeasurementRows(MeasurementType::kPositionAxis), 5);
  EXPECT_EQ(MeasurementRows(MeasurementType::kPose), 6);
  MeasurementType t;
  ASSERT_TRUE(ParseMeasurementType("position_axis", &t));
  EXPECT_EQ(t, MeasurementType::kPositionAxis);
  EXPECT_FALSE(ParseMeasurementType("orientation", &t));
}

}  // namespace
}  // namespace robocal
