// Forward kinematics against published reference values and across geometry conventions.
#include <cmath>

#include <gtest/gtest.h>

#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/units.h"
#include "test_util.h"

namespace robocal {
namespace {


RobotModel WithoutTool(const std::string& preset) {
  RobotModelSpec spec = PresetSpec(preset);
  spec.T_flange_tool = Transform::Identity();
  return RobotModel::Build(spec);
}

void ExpectPose(const Transform& t, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& position_mm) {
  EXPECT_LT((t.linear() - rotation).cwiseAbs().maxCoeff(), 1e-12) << t.linear();
  EXPECT_LT((t.translation() - position_mm).cwiseAbs().maxCoeff(), 1e-9) << t.translation().transpose();
}

// Corke, Robotics Toolbox, p560.fkine(qz), fkine(qr) and fkine(qs) (metres there, mm here).
TEST(KinematicsTest, Puma560MatchesRoboticsToolboxAtZero) {
  const RobotModel puma = WithoutTool("puma560");
  ExpectPose(ForwardKinematics(puma, Eigen::VectorXd::Zero(6)), Eigen::Matrix3d::Identity(),
             {452.1, -150.05, 431.8});
}

TEST(KinematicsTest, Puma560MatchesRoboticsToolboxAtReady) {
  const RobotModel puma = WithoutTool("puma560");
  Eigen::VectorXd qr(6);
  qr << 0, 90 * kRadPerDeg, -90 * kRadPerDeg, 0, 0, 0;
  // Upper arm and forearm straight up: joints 2 and 3 cancel in rotation.
  ExpectPose(ForwardKinematics(puma, qr), Eigen::Matrix3d::Identity(), {20.3, -150.05, 863.6});
}

TEST(KinematicsTest, Puma560MatchesRoboticsToolboxAtStretch) {
  const RobotModel puma = WithoutTool("puma560");
  Eigen::VectorXd qs(6);
  qs << 0, 0, -90 * kRadPerDeg, 0, 0, 0;
  Eigen::Matrix3d r;
  r << 0, 0, 1, 0, 1, 0, -1, 0, 0;
  ExpectPose(ForwardKinematics(puma, qs), r, {863.6, -150.05, -20.3});
}

// Universal Robots' zero pose of the UR5e flange: x = a2 + a3, y = -(d4 + d6), z = d1 - d5.
TEST(KinematicsTest, Ur5eZeroPose) {
  const RobotModel ur = WithoutTool("ur5e");
  Eigen::Matrix3d r;
  r << 1, 0, 0, 0, 0, -1, 0, 1, 0;  // all alphas sum to +90 deg about x, all thetas zero
  ExpectPose(ForwardKinematics(ur, Eigen::VectorXd::Zero(6)), r, {-817.2, -232.9, 62.8});
}

// A standard DH robot rewritten as modified DH (Craig): row i of MDH takes alpha_{i-1}, a_{i-1} from the
// previous DH row and theta_i, d_i from its own; the last row's a_n, alpha_n move into the tool.
RobotModelSpec AsModifiedDh(const RobotModelSpec& dh) {
  RobotModelSpec mdh = dh;
  mdh.name = dh.name + "_mdh";
  mdh.convention = GeometryConvention::kModifiedDh;
  for (size_t i = 0; i < dh.joints.size(); ++i) {
    mdh.joints[i].a_mm = i == 0 ? 0.0 : dh.joints[i - 1].a_mm;
    mdh.joints[i].alpha_rad = i == 0 ? 0.0 : dh.joints[i - 1].alpha_rad;
  }
  const JointSpec& last = dh.joints.back();
  mdh.T_flange_tool = Translation(last.a_mm, 0, 0) * Rotation(RotX(last.alpha_rad)) * dh.T_flange_tool;
  return mdh;
}

// The same robot as per-joint fixed transforms (the "transform" convention).
RobotModelSpec AsTransforms(const RobotModel& model) {
  RobotModelSpec spec = model.spec();
  spec.name += "_transform";
  spec.convention = GeometryConvention::kTransform;
  for (int i = 0; i < model.num_joints(); ++i) {
    spec.joints[i].xyz_mm = model.fixed_transform(i).translation();
    spec.joints[i].rpy_rad = RpyFromRotation(model.fixed_transform(i).linear());
  }
  spec.T_flange_tool = model.T_lastjoint_flange() * model.T_flange_tool();
  return spec;
}

class ConventionTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ConventionTest, DhModifiedDhAndTransformsGiveTheSamePoses) {
  const RobotModel dh = Preset(GetParam());
  const RobotModel mdh = RobotModel::Build(AsModifiedDh(dh.spec()));
  const RobotModel tf = RobotModel::Build(AsTransforms(dh));
  Rng rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::VectorXd q = RandomConfiguration(dh, &rng);
    const Transform a = ForwardKinematics(dh, q);
    const Transform b = ForwardKinematics(mdh, q);
    const Transform c = ForwardKinematics(tf, q);
    EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((a.matrix() - c.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(SixAxis, ConventionTest, ::testing::Values("puma560", "ur5e"));

TEST(KinematicsTest, PrismaticJointsTranslateAlongTheirAxes) {
  const RobotModel g = Preset("grinder5");
  Eigen::VectorXd q = Eigen::VectorXd::Zero(5);
  const Eigen::Vector3d p0 = ForwardKinematics(g, q).translation();
  q << 100, 50, 25, 0, 0;
  const Eigen::Vector3d p1 = ForwardKinematics(g, q).translation();
  EXPECT_LT((p1 - p0 - Eigen::Vector3d(100, 50, 25)).norm(), 1e-9);
}

TEST(KinematicsTest, ZeroErrorsEqualNominal) {
  const RobotModel model = Preset("ur5e");
  KinematicsWorkspace ws(model);
  Rng rng(3);
  const Eigen::VectorXd q = RandomConfiguration(model, &rng);
  const Transform a = ForwardKinematics(model, q);
  const Transform b = ForwardKinematics(model, q, Eigen::VectorXd::Zero(model.num_error_parameters()), &ws);
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), 1e-12);
}

// Error parameters act where their names say: base.dz shifts the whole robot along the world z; tool.dz
// moves the measured point along the tool axis; a revolute joint's rz equals a joint offset.
TEST(KinematicsTest, ErrorParametersMeanWhatTheirNamesSay) {
  const RobotModel model = Preset("puma560");
  KinematicsWorkspace ws(model);
  Rng rng(5);
  const Eigen::VectorXd q = RandomConfiguration(model, &rng);
  const Transform nominal = ForwardKinematics(model, q);
  Eigen::VectorXd eps = Eigen::VectorXd::Zero(model.num_error_parameters());

  eps[model.ParameterIndex("base.dz")] = 0.7;
  Transform t = ForwardKinematics(model, q, eps, &ws);
  EXPECT_LT((t.translation() - nominal.translation() - Eigen::Vector3d(0, 0, 0.7)).norm(), 1e-12);

  eps.setZero();
  eps[model.ParameterIndex("tool.dz")] = 0.4;
  t = ForwardKinematics(model, q, eps, &ws);
  EXPECT_LT((t.translation() - nominal.translation() - 0.4 * nominal.linear().col(2)).norm(), 1e-12);

  eps.setZero();
  eps[model.ParameterIndex("joint3.rz")] = 0.01;
  Eigen::VectorXd q_offset = q;
  q_offset[2] += 0.01;
  t = ForwardKinematics(model, q, eps, &ws);
  EXPECT_LT((t.matrix() - ForwardKinematics(model, q_offset).matrix()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(KinematicsTest, WrongSizesThrow) {
  const RobotModel model = Preset("grinder5");
  KinematicsWorkspace ws(model);
  EXPECT_THROW(ForwardKinematics(model, Eigen::VectorXd::Zero(4)), std::invalid_argument);
  EXPECT_THROW(ForwardKinematics(model, Eigen::VectorXd::Zero(5), Eigen::VectorXd::Zero(7), &ws),
               std::invalid_argument);
}

TEST(KinematicsTest, RandomConfigurationsAreWithinLimitsAndReproducible) {
  const RobotModel model = Preset("puma560");
  Rng a(42), b(42);
  for (int i = 0; i < 100; ++i) {
    const Eigen::VectorXd qa = RandomConfiguration(model, &a);
    EXPECT_TRUE(model.WithinLimits(qa));
    EXPECT_EQ(qa, RandomConfiguration(model, &b));
  }
}

// The base-frame chain is ForwardKinematics without T_world_base and the tool, for every preset.
TEST(KinematicsTest, NominalChainInBaseMatchesForwardKinematics) {
  for (const std::string& name : PresetNames()) {
    RobotModelSpec spec = PresetSpec(name);
    spec.T_world_base = TransformFromXyzRpy({100, -200, 300}, {0.1, -0.2, 0.3});
    const RobotModel model = RobotModel::Build(spec);
    KinematicsWorkspace ws(model);
    Rng rng(3);
    for (int i = 0; i < 10; ++i) {
      const Eigen::VectorXd q = RandomConfiguration(model, &rng);
      const Transform T_world_tool = ForwardKinematics(model, q, Eigen::VectorXd(), &ws);
      std::vector<Transform> T_base_joint(model.num_joints());
      Transform T_base_flange;
      NominalChainInBase(model, q, T_base_joint.data(), &T_base_flange);
      EXPECT_TRUE(T_world_tool.isApprox(model.T_world_base() * T_base_flange * model.T_flange_tool(), 1e-12)) << name;
      for (int j = 0; j < model.num_joints(); ++j) {
        EXPECT_TRUE(ws.T_world_joint[j].isApprox(model.T_world_base() * T_base_joint[j], 1e-12)) << name << j;
      }
    }
  }
  Transform frames[2], flange;
  EXPECT_THROW(NominalChainInBase(Preset("ur5e"), Eigen::VectorXd::Zero(2), frames, &flange), std::invalid_argument);
}

TEST(TransformsTest, RpyRoundTripAndRotationVector) {
  Rng rng(9);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d rpy(rng.Uniform(-M_PI, M_PI), rng.Uniform(-1.5, 1.5), rng.Uniform(-M_PI, M_PI));
    EXPECT_LT((RpyFromRotation(RotationFromRpy(rpy)) - rpy).norm(), 1e-12);
    const Eigen::Vector3d v = Eigen::Vector3d(rng.Normal(), rng.Normal(), rng.Normal()).normalized() *
                              rng.Uniform(0.0, 3.1);
    EXPECT_LT((RotationVector(Eigen::AngleAxisd(v.norm(), v.normalized()).toRotationMatrix()) - v).norm(), 1e-9);
  }
  // Gimbal lock keeps the rotation even though rpy is not unique.
  const Eigen::Matrix3d r = RotationFromRpy({0.3, M_PI / 2, -0.2});
  EXPECT_LT((RotationFromRpy(RpyFromRotation(r)) - r).norm(), 1e-12);
  // Near the lock roll and yaw are each ill-determined; the rotation they give back must not be (pitch within
  // 1e-9 .. 1e-6 rad of 90 degrees, as a URDF's rounded pi/2 next to a small calibrated turn puts it).
  for (const double off : {1e-9, 1.8e-9, 1e-7, 1e-6}) {
    for (const double sign : {1.0, -1.0}) {
      const Eigen::Matrix3d near = RotationFromRpy({0.3, sign * (M_PI / 2 - off), -0.2}) * RotationFromRpy({1e-5, -2e-5, 3e-5});
      EXPECT_LT((RotationFromRpy(RpyFromRotation(near)) - near).norm(), 1e-14) << off << " " << sign;
    }
  }
}

}  // namespace
}  // namespace robocal
