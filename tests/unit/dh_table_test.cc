// The calibrated DH table: the same forward kinematics as the calibrated model, the nominal table back from a DH
// model without errors, and the refusal where axes parallel in the model are tilted apart.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "robocal/core/dh_table.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/units.h"

namespace robocal {
namespace {


// The largest position (mm) and rotation (rad) difference between the model with errors and the rebuilt table,
// over `count` random configurations.
std::pair<double, double> LargestDifference(const RobotModel& model, const Eigen::VectorXd& errors,
                                            const RobotModel& table, int count) {
  Rng rng(7);
  KinematicsWorkspace ws(model), ws_table(table);
  double position = 0.0, rotation = 0.0;
  for (int k = 0; k < count; ++k) {
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    const Transform a = ForwardKinematics(model, q, errors, &ws);
    const Transform b = ForwardKinematics(table, q, Eigen::VectorXd(), &ws_table);
    position = std::max(position, (a.translation() - b.translation()).norm());
    rotation = std::max(rotation, RotationVector(a.linear() * b.linear().transpose()).norm());
  }
  return {position, rotation};
}

Eigen::VectorXd RandomErrors(const RobotModel& model, std::uint64_t seed, double mm, double rad) {
  Rng rng(seed);
  Eigen::VectorXd errors(model.num_error_parameters());
  for (int k = 0; k < errors.size(); ++k) {
    errors[k] = rng.Uniform(-1.0, 1.0) * (RobotModel::IsTranslationParameter(k) ? mm : rad);
  }
  return errors;
}

// A 6R arm without parallel neighbouring axes (every alpha +-90 degrees) and a tool, standing off the origin.
RobotModel SkewArm() {
  RobotModelSpec spec;
  spec.name = "skew";
  spec.convention = GeometryConvention::kStandardDh;
  const double a[6] = {50, 300, 40, 10, 0, 5}, d[6] = {400, 30, -20, 350, 15, 90};
  const double alpha[6] = {90, -90, 90, -90, 90, 0}, theta[6] = {0, 10, -20, 0, 30, 0};
  for (int i = 0; i < 6; ++i) {
    JointSpec j;
    j.name = "j" + std::to_string(i + 1);
    j.a_mm = a[i];
    j.d_mm = d[i];
    j.alpha_rad = alpha[i] * kRadPerDeg;
    j.theta_rad = theta[i] * kRadPerDeg;
    j.min = -170 * kRadPerDeg;
    j.max = 170 * kRadPerDeg;
    spec.joints.push_back(j);
  }
  spec.T_world_base = TransformFromXyzRpy({2000, -500, 300}, {0.1, -0.2, 0.7});
  spec.T_flange_tool = TransformFromXyzRpy({10, 20, 120}, {0.0, 0.3, 0.0});
  return RobotModel::Build(spec);
}

TEST(DhTableTest, ADhModelWithoutErrorsGetsItsOwnTable) {
  for (const std::string name : {"puma560", "ur5e"}) {
    SCOPED_TRACE(name);
    const RobotModel model = Preset(name);
    const RobotModelSpec spec = CalibratedDhSpec(model, Eigen::VectorXd(), GeometryConvention::kStandardDh);
    ASSERT_EQ(spec.joints.size(), model.spec().joints.size());
    for (int i = 0; i < model.num_joints(); ++i) {
      const JointSpec& got = spec.joints[i];
      const JointSpec& want = model.spec().joints[i];
      EXPECT_EQ(got.name, want.name);
      EXPECT_NEAR(got.a_mm, want.a_mm, 1e-9) << i;
      EXPECT_NEAR(got.d_mm, want.d_mm, 1e-9) << i;
      EXPECT_NEAR(got.alpha_rad, want.alpha_rad, 1e-12) << i;
      EXPECT_NEAR(got.theta_rad, want.theta_rad, 1e-12) << i;
      EXPECT_EQ(got.min, want.min);
      EXPECT_EQ(got.max, want.max);
    }
    EXPECT_TRUE(spec.T_world_base.isApprox(model.T_world_base(), 1e-12));
    EXPECT_TRUE(spec.T_flange_tool.isApprox(model.T_flange_tool(), 1e-12));
  }
}

TEST(DhTableTest, AModifiedDhModelWithoutErrorsGetsItsOwnTable) {
  // Craig's PUMA 560 table (modified DH), with alpha_0 = a_0 = 0 so that frame 0 is on the first axis.
  RobotModelSpec spec;
  spec.name = "craig";
  spec.convention = GeometryConvention::kModifiedDh;
  const double alpha[6] = {0, -90, 0, -90, 90, -90}, a[6] = {0, 0, 431.8, 20.3, 0, 0};
  const double d[6] = {0, 0, 150.05, 431.8, 0, 0}, theta[6] = {0, 0, 0, 0, 0, 0};
  for (int i = 0; i < 6; ++i) {
    JointSpec j;
    j.name = "j" + std::to_string(i + 1);
    j.alpha_rad = alpha[i] * kRadPerDeg;
    j.a_mm = a[i];
    j.d_mm = d[i];
    j.theta_rad = theta[i] * kRadPerDeg;
    j.min = -170 * kRadPerDeg;
    j.max = 170 * kRadPerDeg;
    spec.joints.push_back(j);
  }
  spec.T_world_base = TransformFromXyzRpy({100, 200, 300}, {0.0, 0.0, 0.5});
  spec.T_flange_tool = Translation(0, 0, 100);
  const RobotModel model = RobotModel::Build(spec);
  const RobotModelSpec out = CalibratedDhSpec(model, Eigen::VectorXd(), GeometryConvention::kModifiedDh);
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(out.joints[i].a_mm, a[i], 1e-9) << i;
    EXPECT_NEAR(out.joints[i].d_mm, d[i], 1e-9) << i;
    EXPECT_NEAR(out.joints[i].alpha_rad, alpha[i] * kRadPerDeg, 1e-12) << i;
    EXPECT_NEAR(out.joints[i].theta_rad, theta[i] * kRadPerDeg, 1e-12) << i;
  }
  EXPECT_TRUE(out.T_world_base.isApprox(spec.T_world_base, 1e-12));
  EXPECT_TRUE(out.T_flange_tool.isApprox(spec.T_flange_tool, 1e-12));
}

TEST(DhTableTest, CalibratedTablesHaveTheCalibratedKinematics) {
  const RobotModel model = SkewArm();
  for (std::uint64_t seed : {1, 2, 3}) {
    // 0.5 mm and 3 mrad on every parameter: no DH row can hold a joint's y errors as they are, the table is
    // rebuilt from the axes.
    const Eigen::VectorXd errors = RandomErrors(model, seed, 0.5, 3e-3);
    for (GeometryConvention convention : {GeometryConvention::kStandardDh, GeometryConvention::kModifiedDh}) {
      SCOPED_TRACE(std::string(ToString(convention)) + " seed " + std::to_string(seed));
      const RobotModelSpec spec = CalibratedDhSpec(model, errors, convention);
      EXPECT_EQ(spec.convention, convention);
      const RobotModel table = RobotModel::Build(spec);
      const auto [position, rotation] = LargestDifference(model, errors, table, 200);
      EXPECT_LT(position, 1e-9);
      EXPECT_LT(rotation, 1e-12);
      // A calibration, not a new robot: every row next to the nominal one.
      const RobotModelSpec nominal = CalibratedDhSpec(model, Eigen::VectorXd(), convention);
      for (int i = 0; i < 6; ++i) {
        EXPECT_LT(std::abs(spec.joints[i].a_mm - nominal.joints[i].a_mm), 5.0) << i;
        EXPECT_LT(std::abs(spec.joints[i].d_mm - nominal.joints[i].d_mm), 5.0) << i;
        EXPECT_LT(std::abs(spec.joints[i].alpha_rad - nominal.joints[i].alpha_rad), 0.05) << i;
        EXPECT_LT(std::abs(spec.joints[i].theta_rad - nominal.joints[i].theta_rad), 0.05) << i;
      }
    }
  }
}

// The transform convention takes every calibrated geometry, parallel axes tilted apart included: the presets
// (standard DH, modified DH, a transform chain) with errors on every parameter keep their calibrated kinematics,
// names and limits.
TEST(DhTableTest, CalibratedTransformSpecsHaveTheCalibratedKinematics) {
  for (const std::string& name : PresetNames()) {
    const RobotModel model = Preset(name);
    for (std::uint64_t seed : {1, 2}) {
      SCOPED_TRACE(name + " seed " + std::to_string(seed));
      const Eigen::VectorXd errors = RandomErrors(model, seed, 0.5, 3e-3);
      const RobotModelSpec spec = CalibratedTransformSpec(model, errors);
      EXPECT_EQ(spec.convention, GeometryConvention::kTransform);
      const RobotModel calibrated = RobotModel::Build(spec);
      const auto [position, rotation] = LargestDifference(model, errors, calibrated, 200);
      EXPECT_LT(position, 1e-9);
      EXPECT_LT(rotation, 1e-12);
      for (int i = 0; i < model.num_joints(); ++i) {
        EXPECT_EQ(spec.joints[i].name, model.spec().joints[i].name);
        EXPECT_EQ(spec.joints[i].min, model.spec().joints[i].min);
        EXPECT_EQ(spec.joints[i].max, model.spec().joints[i].max);
      }
    }
  }
  EXPECT_THROW(CalibratedTransformSpec(Preset("ur5e"), Eigen::VectorXd::Zero(3)), std::invalid_argument);
}

TEST(DhTableTest, ParallelAxesThatStayParallelAreWritten) {
  // ur5e: axes 2, 3 and 4 are parallel. Errors that keep them parallel (all but the tilts of axes 3 and 4,
  // joint3.rx/ry and joint4.rx/ry) have a table, in both conventions.
  const RobotModel model = Preset("ur5e");
  Eigen::VectorXd errors = RandomErrors(model, 11, 0.5, 3e-3);
  for (const char* tilt : {"joint3.rx", "joint3.ry", "joint4.rx", "joint4.ry"}) errors[model.ParameterIndex(tilt)] = 0;
  for (GeometryConvention convention : {GeometryConvention::kStandardDh, GeometryConvention::kModifiedDh}) {
    SCOPED_TRACE(ToString(convention));
    const RobotModel table = RobotModel::Build(CalibratedDhSpec(model, errors, convention));
    const auto [position, rotation] = LargestDifference(model, errors, table, 200);
    EXPECT_LT(position, 1e-9);
    EXPECT_LT(rotation, 1e-12);
  }
}

TEST(DhTableTest, AxesTiltedOutOfParallelAreRefusedNamingTheParameter) {
  const RobotModel model = Preset("ur5e");
  for (const std::string parameter : {"joint3.ry", "joint4.ry"}) {
    for (GeometryConvention convention : {GeometryConvention::kStandardDh, GeometryConvention::kModifiedDh}) {
      SCOPED_TRACE(parameter + " " + ToString(convention));
      Eigen::VectorXd errors = Eigen::VectorXd::Zero(model.num_error_parameters());
      errors[model.ParameterIndex("joint2.dx")] = 0.3;  // an error a row holds, beside the tilt
      errors[model.ParameterIndex(parameter)] = 1e-3;
      try {
        CalibratedDhSpec(model, errors, convention);
        FAIL() << "no refusal";
      } catch (const DhTableError& e) {
        ASSERT_EQ(e.parameters().size(), 1u) << e.what();
        EXPECT_EQ(e.parameters()[0], parameter);
        EXPECT_NE(std::string(e.what()).find("are parallel in the nominal model"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(parameter + " = 0.0573 deg puts it there"), std::string::npos)
            << e.what();
        EXPECT_EQ(e.field().rfind("joints[", 0), 0u) << e.field();
      }
    }
  }
}

TEST(DhTableTest, TransformModelsAndPrismaticJointsHaveTables) {
  // grinder5: three prismatic joints and two revolute ones, in the transform convention; the Z and C axes are
  // the same line. Errors that keep them one line (all but C's tilts and offsets across the axis) have a table.
  const RobotModel model = Preset("grinder5");
  Eigen::VectorXd errors = RandomErrors(model, 5, 0.2, 1e-3);
  for (const char* across : {"C.dx", "C.dy", "C.rx", "C.ry"}) errors[model.ParameterIndex(across)] = 0.0;
  for (GeometryConvention convention : {GeometryConvention::kStandardDh, GeometryConvention::kModifiedDh}) {
    SCOPED_TRACE(ToString(convention));
    const RobotModel table = RobotModel::Build(CalibratedDhSpec(model, errors, convention));
    const auto [position, rotation] = LargestDifference(model, errors, table, 200);
    EXPECT_LT(position, 1e-9);
    EXPECT_LT(rotation, 1e-12);
    for (int i = 0; i < model.num_joints(); ++i) EXPECT_EQ(table.joint_type(i), model.joint_type(i));
  }
}

TEST(DhTableTest, TheNamedParametersAreTheCause) {
  // Every error, C's tilts included: refused, and without the parameters it names the table exists.
  const RobotModel model = Preset("grinder5");
  for (std::uint64_t seed : {5, 6, 7, 8}) {
    SCOPED_TRACE(seed);
    Eigen::VectorXd errors = RandomErrors(model, seed, 0.2, 1e-3);
    try {
      CalibratedDhSpec(model, errors, GeometryConvention::kStandardDh);
      FAIL() << "no refusal";
    } catch (const DhTableError& e) {
      ASSERT_FALSE(e.parameters().empty()) << e.what();
      EXPECT_NE(std::string(e.what()).find("joint 'Z' and joint 'C' are "), std::string::npos) << e.what();
      if (std::string(e.what()).find("the table would exist") == std::string::npos) continue;
      errors[model.ParameterIndex(e.parameters()[0])] = 0.0;
      // This field now stays within bounds: a refusal, if any, names another field.
      try {
        CalibratedDhSpec(model, errors, GeometryConvention::kStandardDh);
      } catch (const DhTableError& again) {
        EXPECT_NE(again.field(), e.field()) << again.what();
      }
    }
  }
}

// Craig's PUMA 560 in modified DH (axes 2 and 3 parallel, d3 = 150.05 mm).
RobotModel CraigPuma() {
  RobotModelSpec spec;
  spec.name = "craig";
  spec.convention = GeometryConvention::kModifiedDh;
  const double alpha[6] = {0, -90, 0, -90, 90, -90}, a[6] = {0, 0, 431.8, 20.3, 0, 0};
  const double d[6] = {0, 0, 150.05, 431.8, 0, 0};
  for (int i = 0; i < 6; ++i) {
    JointSpec j;
    j.name = "j" + std::to_string(i + 1);
    j.alpha_rad = alpha[i] * kRadPerDeg;
    j.a_mm = a[i];
    j.d_mm = d[i];
    j.min = -170 * kRadPerDeg;
    j.max = 170 * kRadPerDeg;
    spec.joints.push_back(j);
  }
  return RobotModel::Build(spec);
}

// A twist of two parallel axes about their common normal (a change of alpha) is a DH row's own error: both
// conventions write it, whichever convention the model has.
TEST(DhTableTest, TwistsOfParallelAxesAreWrittenInBothConventions) {
  const double twist = 1e-3;
  // puma560 (standard DH): joint3's site is DH frame 2, on axis 3 with x along the normal: rx is the twist.
  const RobotModel puma = Preset("puma560");
  Eigen::VectorXd puma_errors = Eigen::VectorXd::Zero(puma.num_error_parameters());
  puma_errors[puma.ParameterIndex("joint3.rx")] = twist;
  puma_errors[puma.ParameterIndex("joint2.dx")] = 0.3;
  // Craig's table: joint j3's site is d3 above the normal's foot on axis 3, so the twist about the normal is rx
  // there with the site carried round the normal: dy = -d3 sin, dz = d3 (cos - 1).
  const RobotModel craig = CraigPuma();
  Eigen::VectorXd craig_errors = Eigen::VectorXd::Zero(craig.num_error_parameters());
  craig_errors[craig.ParameterIndex("j3.rx")] = twist;
  craig_errors[craig.ParameterIndex("j3.dy")] = -150.05 * std::sin(twist);
  craig_errors[craig.ParameterIndex("j3.dz")] = 150.05 * (std::cos(twist) - 1.0);
  for (const auto& [model, errors] : {std::pair{puma, puma_errors}, std::pair{craig, craig_errors}}) {
    for (GeometryConvention convention : {GeometryConvention::kStandardDh, GeometryConvention::kModifiedDh}) {
      SCOPED_TRACE(model.name() + " -> " + ToString(convention));
      const RobotModel table = RobotModel::Build(CalibratedDhSpec(model, errors, convention));
      const auto [position, rotation] = LargestDifference(model, errors, table, 200);
      EXPECT_LT(position, 1e-9);
      EXPECT_LT(rotation, 1e-12);
    }
  }
}

TEST(DhTableTest, AntiParallelAxesAreParallelToo) {
  // alpha 180 degrees: axes 1 and 2 point opposite ways; a tilt of joint2 is reported by its angle from parallel.
  RobotModelSpec spec = PresetSpec("puma560");
  spec.joints[0].alpha_rad = M_PI;
  spec.joints[0].a_mm = 100;
  const RobotModel model = RobotModel::Build(spec);
  Eigen::VectorXd errors = Eigen::VectorXd::Zero(model.num_error_parameters());
  errors[model.ParameterIndex("joint2.ry")] = 1e-3;
  try {
    CalibratedDhSpec(model, errors, GeometryConvention::kStandardDh);
    FAIL() << "no refusal";
  } catch (const DhTableError& e) {
    EXPECT_NE(std::string(e.what()).find("0.0573 deg from parallel in the calibrated one"), std::string::npos)
        << e.what();
  }
}

TEST(DhTableTest, NearlyParallelNominalAxesHaveNoTable) {
  // Axes 2 and 3 1e-7 degrees from parallel, tilted across their normal: their common normal lies hundreds of
  // km away. No table at all, and never a body that a registration would refuse.
  RobotModelSpec spec;
  spec.name = "nearly";
  spec.convention = GeometryConvention::kTransform;
  const Eigen::Vector3d xyz[4] = {{0, 0, 0}, {0, 0, 300}, {400, 0, 0}, {0, 0, 100}};
  const Eigen::Vector3d rpy[4] = {{0, 0, 0}, {M_PI / 2, 0, 0}, {0, 1e-7 * kRadPerDeg, 0}, {-M_PI / 2, 0, 0}};
  for (int i = 0; i < 4; ++i) {
    JointSpec j;
    j.name = "joint" + std::to_string(i + 1);
    j.xyz_mm = xyz[i];
    j.rpy_rad = rpy[i];
    j.min = -M_PI;
    j.max = M_PI;
    spec.joints.push_back(j);
  }
  const RobotModel model = RobotModel::Build(spec);
  for (GeometryConvention convention : {GeometryConvention::kStandardDh, GeometryConvention::kModifiedDh}) {
    try {
      CalibratedDhSpec(model, Eigen::VectorXd(), convention);
      FAIL() << "no refusal";
    } catch (const DhTableError& e) {
      EXPECT_NE(std::string(e.what()).find("joint 'joint2' and joint 'joint3' are 1e-07 deg from parallel in the "
                                           "nominal model"),
                std::string::npos)
          << e.what();
      EXPECT_TRUE(e.parameters().empty());
    }
  }
}

TEST(DhTableTest, OtherConventionsAndSizesAreProgrammerErrors) {
  const RobotModel model = Preset("ur5e");
  EXPECT_THROW(CalibratedDhSpec(model, Eigen::VectorXd(), GeometryConvention::kTransform), std::invalid_argument);
  EXPECT_THROW(CalibratedDhSpec(model, Eigen::VectorXd::Zero(5), GeometryConvention::kStandardDh),
               std::invalid_argument);
}

}  // namespace
}  // namespace robocal

namespace robocal {
namespace {

// The calibrated robot in the transform convention keeps the masses where they are: its gravity torques are the
// nominal ones (standard DH centres of mass, given in DH frame i, are carried into the joint frame).
TEST(CalibratedTransformSpecTest, MassesStayWhereTheyAre) {
  for (const char* name : {"ur5e", "puma560", "grinder5"}) {
    const RobotModel model = Preset(name);
    const RobotModel transform =
        RobotModel::Build(CalibratedTransformSpec(model, Eigen::VectorXd::Zero(model.num_error_parameters())));
    Rng rng(12);
    for (int k = 0; k < 10; ++k) {
      const Eigen::VectorXd q = RandomConfiguration(model, &rng);
      const Payload payload{2.0, Eigen::Vector3d(10, 20, 30)};
      EXPECT_LT((GravityTorques(transform, q, payload) - GravityTorques(model, q, payload)).cwiseAbs().maxCoeff(), 1e-9)
          << name;
    }
  }
}

}  // namespace
}  // namespace robocal
