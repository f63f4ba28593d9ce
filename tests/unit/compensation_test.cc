// Compensation: the calibrated robot driven by the compensated joints lands on the nominal targets (6R: full
// pose, 5-axis: position and tool axis with the free rotation reported), the two target frames agree, limits
// hold, unreachable targets fail cleanly, and options are validated.
#include "robocal/core/compensation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "robocal/core/arm_kinematics.h"
#include "robocal/core/compensation_study.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/units.h"
#include "robocal/core/virtual_cell.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

// A calibration as identification would hand it back: the robot with its base moved 3 m away and turned
// (the tracker frame), and errors of realistic size on every site.
Calibration MakeCalibration(RobotModelSpec spec, std::uint64_t seed) {
  spec.T_world_base = TransformFromXyzRpy({3000.0, -1200.0, 500.0}, {0.1, -0.05, 2.0});
  const RobotModel model = RobotModel::Build(spec);
  Rng rng(seed);
  Eigen::VectorXd errors(model.num_error_parameters());
  for (int k = 0; k < errors.size(); ++k) {
    errors[k] = RobotModel::IsTranslationParameter(k) ? 0.3 * rng.Normal() : 1e-3 * rng.Normal();
  }
  const int tool_site = 6 * (model.num_error_sites() - 1);
  return Calibration{.model = model,
                     .errors = errors,
                     .parameters = {},
                     .covariance = {},
                     .T_world_base = model.T_world_base() * ErrorTransform(errors.data()),
                     .T_flange_tool = model.T_flange_tool() * ErrorTransform(errors.data() + tool_site),
                     .reflectors = {},
                     .summary = {}};
}

Calibration MakeCalibration(const std::string& preset, std::uint64_t seed) {
  return MakeCalibration(PresetSpec(preset), seed);
}


RobotModelSpec DhSpec(const std::string& name, const std::vector<std::array<double, 6>>& rows) {
  RobotModelSpec s;
  s.name = name;
  s.convention = GeometryConvention::kStandardDh;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& [a_mm, alpha_deg, d_mm, theta_deg, min_deg, max_deg] = rows[i];
    JointSpec j;
    j.name = "joint" + std::to_string(i + 1);
    j.a_mm = a_mm;
    j.alpha_rad = alpha_deg * kRadPerDeg;
    j.d_mm = d_mm;
    j.theta_rad = theta_deg * kRadPerDeg;
    j.min = min_deg * kRadPerDeg;
    j.max = max_deg * kRadPerDeg;
    s.joints.push_back(j);
  }
  s.T_flange_tool = Translation(30.0, 0.0, 120.0);
  return s;
}

// A 6R arm of the size of a KUKA KR 16 (spherical wrist; standard DH rows a, alpha, d, theta, limits): shoulder
// offset 260 mm, upper arm 680 mm, forearm 670 mm with a 35 mm elbow offset, so that the arm is stretched at
// joint 3 = -atan(35 / 670) = -2.99 deg.
RobotModelSpec Kr16LikeSpec() {
  return DhSpec("kr16_like", {{260.0, 90.0, 675.0, 0.0, -185.0, 185.0},
                              {680.0, 0.0, 0.0, 0.0, -155.0, 35.0},
                              {35.0, 90.0, 0.0, 90.0, -130.0, 154.0},
                              {0.0, -90.0, 670.0, 0.0, -350.0, 350.0},
                              {0.0, 90.0, 0.0, 0.0, -130.0, 130.0},
                              {0.0, 0.0, 115.0, 0.0, -350.0, 350.0}});
}

// The UR10's published standard DH (offset wrist), joints +-360 deg as on the robot.
RobotModelSpec Ur10Spec() {
  return DhSpec("ur10", {{0.0, 90.0, 127.3, 0.0, -360.0, 360.0},
                         {-612.0, 0.0, 0.0, 0.0, -360.0, 360.0},
                         {-572.3, 0.0, 0.0, 0.0, -360.0, 360.0},
                         {0.0, 90.0, 163.941, 0.0, -360.0, 360.0},
                         {0.0, -90.0, 115.7, 0.0, -360.0, 360.0},
                         {0.0, 0.0, 92.2, 0.0, -360.0, 360.0}});
}

// Uniform in the middle 80 % of each joint's range, so that compensation has room on both sides.
Eigen::VectorXd InteriorConfiguration(const RobotModel& model, Rng* rng) {
  const Eigen::VectorXd range = model.upper_limits() - model.lower_limits();
  Eigen::VectorXd q(model.num_joints());
  for (int i = 0; i < q.size(); ++i) q[i] = model.lower_limits()[i] + range[i] * rng->Uniform(0.1, 0.9);
  return q;
}

// An interior configuration away from singularities. Near one, the map from joints to pose folds over, and a
// target just reachable by the nominal robot can lie beyond the fold for the robot with errors: no nearby
// joints reach it (about 3 % of uniform draws for the 6R presets with these errors; the solver then reports
// the best it can, see UnreachableTargetFailsCleanlyWithinLimits). The measure: smallest singular value of
// the solver's weighted joint Jacobian with unit columns (scale free); every failure seen was below 0.07.
Eigen::VectorXd WellConditionedConfiguration(const RobotModel& model, Rng* rng) {
  const MeasurementType type = model.num_joints() >= 6 ? MeasurementType::kPose : MeasurementType::kPositionAxis;
  const int rows = MeasurementRows(type);
  KinematicsWorkspace ws(model);
  Eigen::MatrixXd jacobian(rows, model.num_joints());
  for (;;) {
    const Eigen::VectorXd q = InteriorConfiguration(model, rng);
    JointJacobian(model, q, Eigen::VectorXd(), type, &ws, jacobian);
    jacobian.bottomRows(rows - 3) *= CompensationOptions{}.orientation_weight_mm_per_rad;
    jacobian.colwise().normalize();
    if (Eigen::JacobiSVD<Eigen::MatrixXd>(jacobian).singularValues().minCoeff() >= 0.1) return q;
  }
}

Transform TrueToolPose(const Calibration& c, const Eigen::VectorXd& q) {
  KinematicsWorkspace ws(c.model);
  return ForwardKinematics(c.model, q, c.errors, &ws);
}

double AxisAngle(const Transform& a, const Transform& b) {
  const Eigen::Vector3d u = a.linear().col(2), v = b.linear().col(2);
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

class CompensationPresetTest : public ::testing::TestWithParam<std::string> {};

TEST_P(CompensationPresetTest, CompensatedJointsBringTheTrueRobotOntoTheNominalTargets) {
  const RobotModel nominal = Preset(GetParam());
  const Calibration calibration = MakeCalibration(GetParam(), 7);
  const bool full_pose = nominal.num_joints() >= 6;
  Rng rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::VectorXd q_nominal = WellConditionedConfiguration(nominal, &rng);
    const Transform target =
        calibration.T_world_base * nominal.T_world_base().inverse() * ForwardKinematics(nominal, q_nominal);
    // The errors matter: commanding the nominal joints misses by a visible amount.
    ASSERT_GT((TrueToolPose(calibration, q_nominal).translation() - target.translation()).norm(), 0.05);

    const CompensationResult r = CompensateJoints(calibration, nominal, q_nominal);
    ASSERT_TRUE(r.converged) << "trial " << trial << ": " << r.message;
    EXPECT_EQ(r.termination, Termination::kConvergence);
    EXPECT_TRUE(r.message.empty());
    EXPECT_TRUE(nominal.WithinLimits(r.joints)) << r.joints.transpose();
    EXPECT_LE(r.position_error_mm, 1e-6);
    EXPECT_LE(r.orientation_error_rad, 1e-9);
    EXPECT_GT(r.iterations, 0);
    EXPECT_LT(r.iterations, 20);
    const Transform reached = TrueToolPose(calibration, r.joints);
    EXPECT_LT((reached.translation() - target.translation()).norm(), 1e-6);
    if (full_pose) {
      EXPECT_LT(RotationVector(reached.linear() * target.linear().transpose()).norm(), 1e-9);
      EXPECT_EQ(r.free_rotation_rad, 0.0);
    } else {
      EXPECT_LT(AxisAngle(reached, target), 1e-9);
    }
  }
}

TEST_P(CompensationPresetTest, TrackerAndBaseFrameTargetsAgree) {
  const RobotModel nominal = Preset(GetParam());
  const Calibration calibration = MakeCalibration(GetParam(), 3);
  Rng rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q = WellConditionedConfiguration(nominal, &rng);
    const Transform T_base_tool = nominal.T_world_base().inverse() * ForwardKinematics(nominal, q);
    const CompensationResult in_base = CompensatePose(calibration, T_base_tool, TargetFrame::kBase, q);
    const CompensationResult in_tracker =
        CompensatePose(calibration, calibration.T_world_base * T_base_tool, TargetFrame::kTracker, q);
    ASSERT_TRUE(in_base.converged) << in_base.message;
    ASSERT_TRUE(in_tracker.converged) << in_tracker.message;
    EXPECT_LT((in_base.joints - in_tracker.joints).cwiseAbs().maxCoeff(), 1e-8);
    // CompensateJoints is the base-frame form.
    const CompensationResult joints = CompensateJoints(calibration, nominal, q);
    EXPECT_LT((joints.joints - in_base.joints).cwiseAbs().maxCoeff(), 1e-8);
  }
}

TEST_P(CompensationPresetTest, UnreachableTargetFailsCleanlyWithinLimits) {
  const RobotModel nominal = Preset(GetParam());
  const Calibration calibration = MakeCalibration(GetParam(), 9);
  Rng rng(13);
  const Eigen::VectorXd q = InteriorConfiguration(nominal, &rng);
  Transform target = nominal.T_world_base().inverse() * ForwardKinematics(nominal, q);
  target.translation() += Eigen::Vector3d(5000.0, 3000.0, -2000.0);
  const CompensationResult r = CompensatePose(calibration, target, TargetFrame::kBase, q);
  EXPECT_FALSE(r.converged);
  // Written either way; DEGRADED exactly when a joint ends held at a limit (the grinder's slides do).
  EXPECT_EQ(r.termination,
            r.message.find(" at its ") != std::string::npos ? Termination::kDegraded : Termination::kNoConvergence)
      << r.message;
  EXPECT_FALSE(r.message.empty());
  EXPECT_THAT(r.message, HasSubstr("remaining error"));
  EXPECT_TRUE(r.joints.allFinite());
  EXPECT_TRUE(nominal.WithinLimits(r.joints)) << r.joints.transpose();
  EXPECT_TRUE(std::isfinite(r.position_error_mm));
  EXPECT_TRUE(std::isfinite(r.orientation_error_rad));
  EXPECT_TRUE(std::isfinite(r.free_rotation_rad));
  EXPECT_GT(r.position_error_mm, 1000.0);
}

INSTANTIATE_TEST_SUITE_P(Presets, CompensationPresetTest, ::testing::Values("grinder5", "puma560", "ur5e"));

// The whole chain without noise: a virtual cell measures the hidden robot, Identify calibrates it, and the
// compensated joints bring the TRUE robot (not the calibrated model) onto its targets. Pose measurements for
// both; the 5-axis grinder5 matches position and tool axis, the 6R ur5e the full pose. Position measurements
// leave the tool's orientation errors unidentified, so there only the tool point is promised.
using EndToEndCase = std::tuple<std::string, MeasurementType>;

class NoiseFreeEndToEndTest : public ::testing::TestWithParam<EndToEndCase> {
 protected:
  void SetUp() override {
    const auto& [preset, type] = GetParam();
    nominal_ = Preset(preset);
    type_ = type;
    VirtualCellOptions o;
    o.seed = 29;
    o.noise = {0.0, 0.0};
    o.shots_per_pose = 1;
    cell_ = std::make_unique<VirtualCell>(nominal_, o);
    Rng rng(31);
    std::vector<Eigen::VectorXd> configurations;
    for (int i = 0; i < 30; ++i) configurations.push_back(RandomConfiguration(nominal_, &rng));
    IdentificationOptions io;
    io.measurement_type = type;
    calibration_ = std::make_unique<Calibration>(Identify(nominal_, cell_->MeasureAll(configurations), io));
  }

  // Where the true robot stands in the tracker frame (the cell draws no base errors, but compose them anyway).
  Transform TrueBase() const {
    return cell_->true_model().T_world_base() * ErrorTransform(cell_->true_errors().data());
  }

  // The true robot at `joints` against the world target: position always, then what the robot and the
  // measurements make promisable.
  void ExpectTrueRobotOnTarget(const Eigen::VectorXd& joints, const Transform& world_target, int trial) {
    const Transform reached = cell_->TruePose(joints);
    EXPECT_LT((reached.translation() - world_target.translation()).norm(), 1e-6) << "trial " << trial;
    if (type_ != MeasurementType::kPose) return;
    if (nominal_.num_joints() >= 6) {
      EXPECT_LT(RotationVector(reached.linear() * world_target.linear().transpose()).norm(), 1e-9) << trial;
    } else {
      EXPECT_LT(AxisAngle(reached, world_target), 1e-9) << "trial " << trial;
    }
  }

  RobotModel nominal_ = Preset("grinder5");
  MeasurementType type_ = MeasurementType::kPose;
  std::unique_ptr<VirtualCell> cell_;
  std::unique_ptr<Calibration> calibration_;  // RobotModel has no default state: made in SetUp
};

TEST_P(NoiseFreeEndToEndTest, TrackerFrameTargetsAreReachedByTheTrueRobot) {
  ASSERT_EQ(calibration_->summary.termination, Termination::kConvergence) << calibration_->summary.FullReport();
  Rng rng(37);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::VectorXd q = WellConditionedConfiguration(nominal_, &rng);
    // The program's pose relative to the robot's true base, as the experiment places its validation targets.
    const Transform target = TrueBase() * nominal_.T_world_base().inverse() * ForwardKinematics(nominal_, q);
    // Without compensation the hidden errors put the tool visibly off.
    ASSERT_GT((cell_->TruePose(q).translation() - target.translation()).norm(), 0.05);
    const CompensationResult r = CompensatePose(*calibration_, target, TargetFrame::kTracker, q);
    ASSERT_TRUE(r.converged) << "trial " << trial << ": " << r.message;
    EXPECT_TRUE(nominal_.WithinLimits(r.joints));
    ExpectTrueRobotOnTarget(r.joints, target, trial);
  }
}

// Base-frame targets (and CompensateJoints, their "go where the nominal model says" form) are placed by the
// calibrated T_world_base. That frame is a convention where base errors cannot be told from joint offsets, so
// what is promised is: the true robot lands on calibration.T_world_base * target exactly, and the calibrated
// base differs from the true one by one fixed transform of the size of the robot's errors (not the
// registration's metres), the same for every target.
TEST_P(NoiseFreeEndToEndTest, BaseFrameTargetsAreReachedInTheCalibratedBaseFrame) {
  ASSERT_EQ(calibration_->summary.termination, Termination::kConvergence) << calibration_->summary.FullReport();
  const Transform convention = TrueBase().inverse() * calibration_->T_world_base;
  EXPECT_LT(convention.translation().norm(), 2.0) << convention.matrix();
  EXPECT_LT(RotationVector(convention.linear()).norm(), 5e-3) << convention.matrix();
  Rng rng(41);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::VectorXd q = WellConditionedConfiguration(nominal_, &rng);
    const Transform T_base_tool = nominal_.T_world_base().inverse() * ForwardKinematics(nominal_, q);
    const CompensationResult joints = CompensateJoints(*calibration_, nominal_, q);
    ASSERT_TRUE(joints.converged) << "trial " << trial << ": " << joints.message;
    ExpectTrueRobotOnTarget(joints.joints, calibration_->T_world_base * T_base_tool, trial);
    // The same target through CompensatePose in the base frame, and relative to the true base it is off by
    // exactly the fixed convention transform.
    const CompensationResult pose = CompensatePose(*calibration_, T_base_tool, TargetFrame::kBase, q);
    ASSERT_TRUE(pose.converged) << pose.message;
    ExpectTrueRobotOnTarget(pose.joints, TrueBase() * convention * T_base_tool, trial);
  }
}

INSTANTIATE_TEST_SUITE_P(Presets, NoiseFreeEndToEndTest,
                         ::testing::Values(EndToEndCase{"grinder5", MeasurementType::kPose},
                                           EndToEndCase{"ur5e", MeasurementType::kPose},
                                           EndToEndCase{"grinder5", MeasurementType::kPosition},
                                           EndToEndCase{"ur5e", MeasurementType::kPosition}),
                         [](const ::testing::TestParamInfo<EndToEndCase>& info) {
                           return std::get<0>(info.param) + "_" + ToString(std::get<1>(info.param));
                         });

TEST(CompensationTest, FiveAxisRobotLeavesTheRotationAboutTheToolAxisFree) {
  const RobotModel nominal = Preset("grinder5");
  const Calibration calibration = MakeCalibration("grinder5", 21);
  Rng rng(23);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q = WellConditionedConfiguration(nominal, &rng);
    const Transform target = nominal.T_world_base().inverse() * ForwardKinematics(nominal, q);
    const CompensationResult r = CompensatePose(calibration, target, TargetFrame::kBase, q);
    ASSERT_TRUE(r.converged) << r.message;

    // The reported free rotation is the angle about the tool axis from the target's x axis to the reached one.
    const Transform world_target = calibration.T_world_base * target;
    const Transform reached = TrueToolPose(calibration, r.joints);
    const Eigen::Matrix3d relative = world_target.linear().transpose() * reached.linear();
    EXPECT_NEAR(r.free_rotation_rad, std::atan2(relative(1, 0), relative(0, 0)), 1e-9);
    // Errors of ~1e-3 rad leave a free rotation of that order, not zero.
    EXPECT_GT(std::abs(r.free_rotation_rad), 1e-6);
    EXPECT_LT(std::abs(r.free_rotation_rad), 0.05);

    // Turning the target about its own tool axis changes nothing but the free rotation.
    Transform turned = target;
    turned.linear() = target.linear() * RotZ(0.3);
    const CompensationResult t = CompensatePose(calibration, turned, TargetFrame::kBase, q);
    ASSERT_TRUE(t.converged) << t.message;
    EXPECT_LT((t.joints - r.joints).cwiseAbs().maxCoeff(), 1e-8);
    EXPECT_NEAR(t.free_rotation_rad, r.free_rotation_rad - 0.3, 1e-9);
  }
}

TEST(CompensationTest, JointHeldAtItsLimitIsNamed) {
  const RobotModel nominal = Preset("grinder5");
  const Calibration calibration = MakeCalibration("grinder5", 31);
  Eigen::VectorXd q(5);
  q << 750.0, 300.0, 200.0, 0.4, 0.6;
  Transform target = nominal.T_world_base().inverse() * ForwardKinematics(nominal, q);
  // The X slide (joint 1) moves along the base x axis and ends at 800 mm: 300 mm further is out of reach.
  target.translation().x() += 300.0;
  const CompensationResult r = CompensatePose(calibration, target, TargetFrame::kBase, q);
  EXPECT_FALSE(r.converged);
  // The limit, not the solver, keeps it from the target: the best within the limits, weaker than asked.
  EXPECT_EQ(r.termination, Termination::kDegraded);
  EXPECT_THAT(r.message, HasSubstr("joint 1 (X) at its upper limit 800"));
  EXPECT_DOUBLE_EQ(r.joints[0], 800.0);
  EXPECT_TRUE(nominal.WithinLimits(r.joints));
  // Tilting the A axis buys back part of the distance at the cost of tool-axis error: a compromise, not 0.
  EXPECT_GT(r.position_error_mm, 50.0);
}

// Termination for the three ends of the solver on a 6R arm whose limits (+-2 pi) do not bind: a reachable
// target converges; one out of reach, or one the iteration budget is too small for, is NO_CONVERGENCE with the
// best joints written. (A joint held at its limit, DEGRADED: JointHeldAtItsLimitIsNamed.)
TEST(CompensationTest, TerminationSaysHowTheSolverEnded) {
  const RobotModel nominal = Preset("ur5e");
  const Calibration calibration = MakeCalibration("ur5e", 9);
  Rng rng(13);
  const Eigen::VectorXd q = WellConditionedConfiguration(nominal, &rng);
  const Transform target = nominal.T_world_base().inverse() * ForwardKinematics(nominal, q);

  const CompensationResult reached = CompensatePose(calibration, target, TargetFrame::kBase, q);
  EXPECT_EQ(reached.termination, Termination::kConvergence) << reached.message;
  EXPECT_TRUE(reached.converged);

  // 2 m further out along the arm's horizontal reach: the arm stretches towards it with no joint turned to a
  // limit (a target off to the side can wind joint 1 to its limit: DEGRADED).
  Transform far = target;
  const Eigen::Vector3d outward(target.translation().x(), target.translation().y(), 0.0);
  far.translation() += 2000.0 * outward.normalized();
  const CompensationResult unreachable = CompensatePose(calibration, far, TargetFrame::kBase, q);
  EXPECT_EQ(unreachable.termination, Termination::kNoConvergence) << unreachable.message;
  EXPECT_FALSE(unreachable.converged);
  EXPECT_THAT(unreachable.message, ::testing::Not(HasSubstr(" at its "))) << unreachable.message;
  EXPECT_TRUE(unreachable.joints.allFinite());

  CompensationOptions one_step;
  one_step.max_iterations = 1;
  const CompensationResult budget = CompensatePose(calibration, target, TargetFrame::kBase, q, one_step);
  EXPECT_EQ(budget.termination, Termination::kNoConvergence) << budget.message;
  EXPECT_FALSE(budget.converged);
  EXPECT_THAT(budget.message, HasSubstr("max_iterations (1) reached"));

  EXPECT_EQ(CompensationResult{}.termination, Termination::kFailure);
}

// CompensateAll: every result is the single-target function's, bit for bit, in target order, whatever the
// thread count; joint and pose targets mixed; a target that throws is rethrown.
TEST(CompensationTest, CompensateAllIsTheSameOnAnyNumberOfThreads) {
  const RobotModel nominal = Preset("ur5e");
  const Calibration calibration = MakeCalibration("ur5e", 9);
  Rng rng(21);
  std::vector<CompensationTarget> targets;
  for (int i = 0; i < 203; ++i) {
    CompensationTarget t;
    t.joints = RandomConfiguration(nominal, &rng);
    if (i % 3 == 0) {
      t.pose = ForwardKinematics(nominal, RandomConfiguration(nominal, &rng));
      t.frame = TargetFrame::kTracker;
      t.start = t.joints;
    }
    targets.push_back(t);
  }
  std::vector<CompensationResult> single;
  for (const CompensationTarget& t : targets) single.push_back(Compensate(calibration, nominal, t));
  for (const int threads : {1, 2, 5, 0}) {
    const std::vector<CompensationResult> all = CompensateAll(calibration, nominal, targets, {}, threads);
    ASSERT_EQ(all.size(), targets.size());
    for (std::size_t i = 0; i < all.size(); ++i) {
      ASSERT_EQ(all[i].joints.size(), single[i].joints.size());
      EXPECT_EQ(all[i].joints, single[i].joints) << threads << " threads, target " << i;
      EXPECT_EQ(all[i].termination, single[i].termination);
      EXPECT_EQ(all[i].message, single[i].message);
    }
  }
  targets[151].joints = Eigen::VectorXd::Constant(6, std::nan(""));  // a joint target (151 % 3 != 0)
  EXPECT_THROW(CompensateAll(calibration, nominal, targets, {}, 2), std::invalid_argument);
  EXPECT_TRUE(CompensateAll(calibration, nominal, {}, {}, 2).empty());
}

TEST(CompensationTest, StartOutsideTheLimitsIsProjectedInside) {
  const RobotModel nominal = Preset("ur5e");
  const Calibration calibration = MakeCalibration("ur5e", 41);
  Rng rng(43);
  const Eigen::VectorXd q = InteriorConfiguration(nominal, &rng);
  const Transform target = nominal.T_world_base().inverse() * ForwardKinematics(nominal, q);
  Eigen::VectorXd start = q;
  start[0] = 100.0;  // far beyond +2 pi
  const CompensationResult r = CompensatePose(calibration, target, TargetFrame::kBase, start);
  EXPECT_TRUE(nominal.WithinLimits(r.joints));
  EXPECT_TRUE(r.joints.allFinite());
}

TEST(CompensationTest, RejectsInvalidOptionsByName) {
  const auto expect_invalid = [](CompensationOptions o, const std::string& name) {
    std::string error;
    EXPECT_FALSE(o.IsValid(&error)) << name;
    EXPECT_THAT(error, HasSubstr(name));
  };
  std::string error;
  EXPECT_TRUE(CompensationOptions{}.IsValid(&error)) << error;
  CompensationOptions o;
  o.initial_damping = 0.0;
  expect_invalid(o, "initial_damping");
  o = {};
  o.initial_damping = std::nan("");
  expect_invalid(o, "initial_damping");
  o = {};
  o.start_damping = -1.0;
  expect_invalid(o, "start_damping");
  o = {};
  o.start_radius_rad = -0.1;
  expect_invalid(o, "start_radius_rad");
  o = {};
  o.start_radius_rad = HUGE_VAL;
  expect_invalid(o, "start_radius_rad");
  o = {};
  o.start_radius_rad = 0.0;
  EXPECT_TRUE(o.IsValid(&error)) << error;
  o = {};
  o.max_damping = o.initial_damping;
  expect_invalid(o, "max_damping");
  o = {};
  o.max_damping = o.start_damping;
  expect_invalid(o, "max_damping");
  o = {};
  o.max_iterations = 0;
  expect_invalid(o, "max_iterations");
  o = {};
  o.position_tolerance_mm = -1.0;
  expect_invalid(o, "position_tolerance_mm");
  o = {};
  o.orientation_tolerance_rad = 0.0;
  expect_invalid(o, "orientation_tolerance_rad");
  o = {};
  o.orientation_weight_mm_per_rad = HUGE_VAL;
  expect_invalid(o, "orientation_weight_mm_per_rad");

  const Calibration calibration = MakeCalibration("ur5e", 1);
  o = {};
  o.max_iterations = -3;
  try {
    CompensatePose(calibration, Transform::Identity(), TargetFrame::kBase, Eigen::VectorXd::Zero(6), o);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("CompensationOptions: max_iterations"));
  }
}

// Each bad input throws, and the message names the argument (and the function) so a caller can find it.
template <typename F>
void ExpectInvalidArgument(F&& call, const std::string& fragment) {
  try {
    call();
    ADD_FAILURE() << "no exception; expected one naming '" << fragment << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(fragment));
  }
}

TEST(CompensationTest, RejectsWrongSizesAndNonFiniteInputByName) {
  const Calibration calibration = MakeCalibration("ur5e", 1);
  const RobotModel ur5e = Preset("ur5e");
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(6);
  const Transform identity = Transform::Identity();
  ExpectInvalidArgument([&] { CompensatePose(calibration, identity, TargetFrame::kBase, Eigen::VectorXd::Zero(5)); },
                        "Compensate: q_start has 5 values");
  Eigen::VectorXd q = zero;
  q[2] = std::nan("");
  ExpectInvalidArgument([&] { CompensatePose(calibration, identity, TargetFrame::kBase, q); }, "q_start is not finite");
  Transform sheared = identity;
  sheared.linear()(0, 1) = 0.5;
  ExpectInvalidArgument([&] { CompensatePose(calibration, sheared, TargetFrame::kBase, zero); }, "target");
  Transform nan_target = identity;
  nan_target.translation().x() = std::nan("");
  ExpectInvalidArgument([&] { CompensatePose(calibration, nan_target, TargetFrame::kTracker, zero); },
                        "target is not a finite rigid transform");

  Calibration bad = calibration;
  bad.errors = Eigen::VectorXd::Zero(7);
  ExpectInvalidArgument([&] { CompensatePose(bad, identity, TargetFrame::kTracker, zero); },
                        "calibration.errors has 7 values");
  bad = calibration;
  bad.errors[4] = INFINITY;
  ExpectInvalidArgument([&] { CompensatePose(bad, identity, TargetFrame::kTracker, zero); },
                        "calibration.errors is not finite");
  bad = calibration;
  bad.T_world_base.translation().y() = std::nan("");
  ExpectInvalidArgument([&] { CompensatePose(bad, identity, TargetFrame::kBase, zero); }, "calibration.T_world_base");
  // Every target needs it (branches are solved in the base frame), so a tracker-frame one is refused as well.
  ExpectInvalidArgument([&] { CompensatePose(bad, identity, TargetFrame::kTracker, zero); }, "calibration.T_world_base");

  ExpectInvalidArgument([&] { CompensateJoints(calibration, Preset("grinder5"), Eigen::VectorXd::Zero(5)); },
                        "the nominal model has 5 joints, the calibrated one 6");
  ExpectInvalidArgument([&] { CompensateJoints(calibration, ur5e, Eigen::VectorXd::Zero(5)); },
                        "Compensate: q_nominal has 5 values");
  ExpectInvalidArgument([&] { CompensateJoints(calibration, ur5e, q); }, "Compensate: q_nominal is not finite");
}

// A calibration whose identification failed is the nominal robot (errors zero): compensating on it is defined
// and gives the nominal joints back for a nominal target, with no NaN.
TEST(CompensationTest, FailedCalibrationCompensatesAsTheNominalRobot) {
  const RobotModel nominal = Preset("grinder5");
  const Calibration failed = Identify(nominal, {});
  ASSERT_EQ(failed.summary.termination, Termination::kFailure);
  Rng rng(47);
  const Eigen::VectorXd q = WellConditionedConfiguration(nominal, &rng);
  const CompensationResult r = CompensateJoints(failed, nominal, q);
  EXPECT_TRUE(r.converged) << r.message;
  EXPECT_LT((r.joints - q).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(r.iterations, 0);
}

TEST(CompensationTest, TargetFrameNamesRoundTrip) {
  for (TargetFrame f : {TargetFrame::kTracker, TargetFrame::kBase}) {
    TargetFrame parsed = f == TargetFrame::kBase ? TargetFrame::kTracker : TargetFrame::kBase;
    EXPECT_TRUE(ParseTargetFrame(ToString(f), &parsed));
    EXPECT_EQ(parsed, f);
  }
  TargetFrame f = TargetFrame::kBase;
  EXPECT_FALSE(ParseTargetFrame("world", &f));
  EXPECT_EQ(f, TargetFrame::kBase);
}

}  // namespace
}  // namespace robocal

namespace robocal {
namespace {

// A pose target without joints, on the branch a configuration names: the pose the calibrated robot reaches at
// random joints, asked with those joints' flags, is solved there on that branch.
class CompensationBranchTest : public ::testing::TestWithParam<const char*> {};

TEST_P(CompensationBranchTest, CartesianTargetsLandOnTheNamedBranch) {
  const RobotModel nominal = Preset(GetParam());
  const Calibration calibration = MakeCalibration(GetParam(), 31);
  const ArmSolver arm = *ArmSolver::For(nominal);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  Rng rng(32);
  int converged = 0;
  const int n = 300;
  for (int i = 0; i < n; ++i) {
    const Eigen::VectorXd q = RandomConfiguration(nominal, &rng);
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    t.configuration = arm.ConfigurationOf(q);
    const CompensationResult r = Compensate(calibration, nominal, t);
    ASSERT_TRUE(r.configuration.has_value() || r.termination == Termination::kFailure);
    // Never another branch than the one asked for.
    if (r.configuration) {
      EXPECT_EQ(*r.configuration, t.configuration) << "target " << i;
    }
    if (!r.converged) {
      continue;
    }
    ++converged;
    EXPECT_LT((calibrated.Forward(r.joints, nullptr).translation() - t.pose->translation()).norm(), 1e-6);
  }
  // The study command measures this on 2000 targets per preset (docs/compensation.md); a few targets lie within
  // the errors' size of a branch boundary.
  EXPECT_GE(converged, n - 3);
}

// Every branch of one pose that the calibrated robot reaches is found when asked for, with its own joints.
TEST_P(CompensationBranchTest, EachBranchIsSolvedWhenAskedFor) {
  const RobotModel nominal = Preset(GetParam());
  const Calibration calibration = MakeCalibration(GetParam(), 33);
  const ArmSolver arm = *ArmSolver::For(nominal);
  CompensationTarget t;
  Eigen::VectorXd q(6);
  q << 0.3, 0.6, -1.2, 0.4, 0.9, -0.5;
  t.pose = FoldedChain(calibration.model, calibration.errors).Forward(q, nullptr);
  const std::vector<ArmSolution> nominal_solutions =
      arm.Solve(calibration.T_world_base.inverse() * *t.pose, Eigen::VectorXd::Zero(6));
  std::vector<Eigen::VectorXd> found;
  for (int shoulder : {1, -1}) {
    for (int elbow : {1, -1}) {
      for (int wrist : {1, -1}) {
        t.configuration = {shoulder, elbow, wrist};
        const CompensationResult r = Compensate(calibration, nominal, t);
        bool nominal_has_it = false;
        for (const ArmSolution& s : nominal_solutions) nominal_has_it = nominal_has_it || s.configuration == t.configuration;
        if (!r.converged) {
          // Only a branch that is not there, said so by name.
          EXPECT_THAT(r.message, HasSubstr(t.configuration.ToString()));
          continue;
        }
        EXPECT_TRUE(nominal_has_it);
        EXPECT_EQ(*r.configuration, t.configuration);
        for (const Eigen::VectorXd& other : found) EXPECT_GT((other - r.joints).cwiseAbs().maxCoeff(), 1e-3);
        found.push_back(r.joints);
      }
    }
  }
  // ur5e's joints turn +-360 deg, so every branch of the nominal chain is there; puma560's ranges leave out some.
  int exact = 0;
  for (const ArmSolution& s : nominal_solutions) exact += s.position_error_mm < 1e-6 ? 1 : 0;
  if (std::string(GetParam()) == "ur5e") {
    EXPECT_EQ(found.size(), static_cast<std::size_t>(exact));
  } else {
    EXPECT_GE(found.size(), 2u);
  }
}

INSTANTIATE_TEST_SUITE_P(SixAxisPresets, CompensationBranchTest, ::testing::Values("puma560", "ur5e"));

// Without a configuration the branch follows start_joints, else the previous target of a sequence, else it is
// shoulder front, elbow up, wrist noflip; the same request always gives the same joints.
TEST(CompensationTest, BranchRulesInOrder) {
  const RobotModel nominal = Preset("ur5e");
  const Calibration calibration = MakeCalibration("ur5e", 35);
  const ArmSolver arm = *ArmSolver::For(nominal);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  Eigen::VectorXd q(6);
  q << 0.3, -1.9, 1.2, -0.4, 1.1, -0.5;  // elbow and wrist as the preset's defaults would not choose
  Eigen::VectorXd flipped = q;
  flipped[4] = -1.1;
  const ArmConfiguration own = arm.ConfigurationOf(q);
  CompensationTarget t;
  t.pose = calibrated.Forward(q, nullptr);

  const CompensationResult none = Compensate(calibration, nominal, t);
  ASSERT_TRUE(none.converged);
  EXPECT_EQ(*none.configuration, (ArmConfiguration{1, 1, 1}));
  EXPECT_EQ(Compensate(calibration, nominal, t).joints, none.joints);

  t.start = q;
  const CompensationResult started = Compensate(calibration, nominal, t);
  ASSERT_TRUE(started.converged);
  EXPECT_EQ(*started.configuration, own);
  EXPECT_LT((started.joints - q).cwiseAbs().maxCoeff(), 0.01);

  // The previous target counts only without start_joints.
  t.start = Eigen::VectorXd();
  const CompensationResult chained = Compensate(calibration, nominal, t, {}, q);
  EXPECT_EQ(*chained.configuration, own);
  t.start = flipped;
  EXPECT_EQ(Compensate(calibration, nominal, t, {}, q).configuration->wrist, -own.wrist);

  // A configuration wins over both, flag by flag.
  t.configuration = {0, -own.elbow, 0};
  const CompensationResult asked = Compensate(calibration, nominal, t, {}, q);
  ASSERT_TRUE(asked.converged) << asked.message;
  EXPECT_EQ(asked.configuration->elbow, -own.elbow);
  EXPECT_EQ(asked.configuration->wrist, -own.wrist);  // the rest from start_joints
}

// A branch that cannot reach the target is never traded for another: a target beyond the arm's reach on the
// asked branch fails with the branch named, without joints.
TEST(CompensationTest, UnreachableBranchSaysSoAndGivesNoOtherBranch) {
  const RobotModel nominal = Preset("puma560");
  const Calibration calibration = MakeCalibration("puma560", 36);
  const ArmSolver arm = *ArmSolver::For(nominal);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  Rng rng(37);
  int refused = 0;
  for (int i = 0; i < 200 && refused < 20; ++i) {
    const Eigen::VectorXd q = RandomConfiguration(nominal, &rng);
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    for (int shoulder : {1, -1}) {
      for (int elbow : {1, -1}) {
        t.configuration = {shoulder, elbow, 0};
        const CompensationResult r = Compensate(calibration, nominal, t);
        if (r.converged) continue;
        ++refused;
        EXPECT_THAT(r.message, HasSubstr(t.configuration.ToString()));
        if (r.configuration) {
          EXPECT_TRUE(t.configuration.Admits(*r.configuration));
        }
        if (r.termination == Termination::kFailure) {
          EXPECT_EQ(r.joints.size(), 0);
        }
      }
    }
  }
  // puma560's joint 2 and 3 ranges leave some shoulder and elbow branches of a pose out of reach.
  EXPECT_GT(refused, 0);
  CompensationTarget far;
  far.pose = calibrated.Forward(Eigen::VectorXd::Zero(6), nullptr);
  far.pose->translation() *= 10.0;
  far.configuration = {1, 1, 1};
  const CompensationResult r = Compensate(calibration, nominal, far);
  EXPECT_EQ(r.termination, Termination::kFailure);
  EXPECT_THAT(r.message, HasSubstr("no solution with shoulder front, elbow up, wrist noflip"));
}

// Start joints that reach the target are given back as they are (no other turn of a joint, no neighbouring
// branch), near full stretch and near the wrist singularity too; at the offset wrist's singularity (joint 5 at
// 0, where joint 6 is ill-determined) a pose is still solved without any hint.
class CompensationStartTest : public ::testing::TestWithParam<const char*> {};

TEST_P(CompensationStartTest, StartJointsThatReachTheTargetComeBack) {
  const RobotModel nominal = Preset(GetParam());
  const Calibration calibration = MakeCalibration(GetParam(), 41);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  Rng rng(42);
  for (int i = 0; i < 300; ++i) {
    Eigen::VectorXd q = RandomConfiguration(nominal, &rng);
    if (i % 3 == 1) q[2] = rng.Uniform(-0.02, 0.02);  // near full stretch
    if (i % 3 == 2) q[4] = rng.Uniform(-0.02, 0.02);  // near the wrist singularity
    q = q.cwiseMax(nominal.lower_limits()).cwiseMin(nominal.upper_limits());
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    t.start = q;
    const CompensationResult r = Compensate(calibration, nominal, t);
    ASSERT_TRUE(r.converged) << i << ": " << r.message;
    EXPECT_LT((r.joints - q).cwiseAbs().maxCoeff(), 1e-6) << i << ": " << q.transpose() << " -> " << r.joints.transpose();
  }
}

TEST_P(CompensationStartTest, SingularWristIsSolvedWithoutAHint) {
  const RobotModel nominal = Preset(GetParam());
  const Calibration calibration = MakeCalibration(GetParam(), 43);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  Rng rng(44);
  for (int i = 0; i < 100; ++i) {
    Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
    for (int k = 0; k < 4; ++k) q[k] = rng.Uniform(-0.5, 0.5);
    q[1] -= 0.6;  // puma560's joint 2 range starts at -45 deg
    q[2] += i % 2 == 0 ? 0.8 : -0.8;
    q[4] = i % 4 < 2 ? 0.0 : rng.Uniform(-0.004, 0.004);  // on the singularity, or within 0.25 deg of it
    q[5] = rng.Uniform(-3.0, 3.0);
    // Inside the limits (a pose reached with a joint exactly at its limit ends DEGRADED by round-off).
    q = q.cwiseMax((nominal.lower_limits().array() + 0.05).matrix()).cwiseMin((nominal.upper_limits().array() - 0.05).matrix());
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    const CompensationResult r = Compensate(calibration, nominal, t);
    EXPECT_TRUE(r.converged) << i << ": " << q.transpose() << ": " << r.message;
  }
}

// Without a hint the branch is front, up, noflip whenever the robot reaches the target there.
TEST_P(CompensationStartTest, WithoutAHintFrontUpNoflipWheneverItReaches) {
  const RobotModel nominal = Preset(GetParam());
  const Calibration calibration = MakeCalibration(GetParam(), 45);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  Rng rng(46);
  int checked = 0;
  for (int i = 0; i < 200; ++i) {
    CompensationTarget t;
    t.pose = calibrated.Forward(RandomConfiguration(nominal, &rng), nullptr);
    const CompensationResult free = Compensate(calibration, nominal, t);
    t.configuration = {1, 1, 1};
    const CompensationResult asked = Compensate(calibration, nominal, t);
    if (!asked.converged) continue;
    ++checked;
    ASSERT_TRUE(free.converged);
    EXPECT_EQ(*free.configuration, (ArmConfiguration{1, 1, 1})) << i;
  }
  EXPECT_GT(checked, 50);
}

INSTANTIATE_TEST_SUITE_P(SixAxisPresets, CompensationStartTest, ::testing::Values("puma560", "ur5e"));

// A result without joints has no errors to report: NaN (null on the wire), not zero.
TEST(CompensationTest, FailureHasNoErrors) {
  const RobotModel nominal = Preset("ur5e");
  const Calibration calibration = MakeCalibration("ur5e", 47);
  CompensationTarget far;
  far.pose = TransformFromXyzRpy({9000.0, 0.0, 0.0}, {0.0, 0.0, 0.0});
  const CompensationResult r = Compensate(calibration, nominal, far);
  EXPECT_EQ(r.termination, Termination::kFailure);
  EXPECT_EQ(r.joints.size(), 0);
  EXPECT_TRUE(std::isnan(r.position_error_mm));
  EXPECT_TRUE(std::isnan(r.orientation_error_rad));
  EXPECT_FALSE(r.configuration.has_value());
}

// A robot without named branches: a pose target without start is solved from a fixed set of starts, and a
// configuration is refused.
TEST(CompensationTest, RobotWithoutBranchesUsesItsStartsAndRefusesAConfiguration) {
  const RobotModel nominal = Preset("grinder5");
  const Calibration calibration = MakeCalibration("grinder5", 38);
  EXPECT_FALSE(ArmSolver::For(nominal).has_value());
  const FoldedChain calibrated(calibration.model, calibration.errors);
  Rng rng(39);
  for (int i = 0; i < 20; ++i) {
    CompensationTarget t;
    t.pose = calibrated.Forward(RandomConfiguration(nominal, &rng), nullptr);
    const CompensationResult r = Compensate(calibration, nominal, t);
    EXPECT_TRUE(r.converged) << r.message;
    EXPECT_FALSE(r.configuration.has_value());
  }
  CompensationTarget t;
  t.pose = calibrated.Forward(DefaultJoints(nominal), nullptr);
  t.configuration.elbow = 1;
  ExpectInvalidArgument([&] { Compensate(calibration, nominal, t); }, "has no named configurations");
}

// A program along a smooth path keeps its branch: no result changes configuration, and each starts near the last.
TEST(CompensationTest, SequenceAlongASmoothPathKeepsItsBranch) {
  const RobotModel nominal = Preset("ur5e");
  const Calibration calibration = MakeCalibration("ur5e", 40);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  std::vector<CompensationTarget> program;
  for (int i = 0; i < 200; ++i) {
    const double s = i / 199.0;
    Eigen::VectorXd q(6);
    q << -0.8 + 1.6 * s, -1.2 + 0.3 * std::sin(3 * s), 1.4 - 0.4 * s, -1.7 + 0.5 * s, -1.3, 0.2 + s;
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    if (i == 0) t.start = q;
    program.push_back(t);
  }
  const std::vector<CompensationResult> results = CompensateSequence(calibration, nominal, program);
  for (std::size_t i = 0; i < results.size(); ++i) {
    ASSERT_TRUE(results[i].converged) << i << ": " << results[i].message;
    EXPECT_EQ(*results[i].configuration, *results[0].configuration) << i;
    if (i > 0) {
      EXPECT_LT((results[i].joints - results[i - 1].joints).cwiseAbs().maxCoeff(), 0.1) << i;
    }
  }
}

// A result within the solver's tolerances is converged, whatever the Jacobian's conditioning there. Here the arm
// is stretched (joint 3 within 0.05 deg of it) and upright (the wrist centre near joint 1's axis), and the start
// joints lie a hair across the elbow's nominal boundary, mirrored: from them the solver lands on the target within
// its tolerances, on the neighbouring branch (the calibrated robot's boundary lies within the errors' size of the
// nominal one). That result used to be given up for the start's branch, and where none of the nominal solutions
// converged either, the target came back with a stalled best 0.03 to 0.33 mm off: 4 of these 300 (3
// NO_CONVERGENCE, 1 DEGRADED).
TEST(CompensationTest, ResultWithinToleranceAtAStretchedElbowIsConverged) {
  const RobotModel nominal = RobotModel::Build(Kr16LikeSpec());
  const Calibration calibration = MakeCalibration(Kr16LikeSpec(), 8);
  ASSERT_TRUE(ArmSolver::For(nominal).has_value());
  const FoldedChain calibrated(calibration.model, calibration.errors);
  const CompensationOptions options;
  const double stretched = -std::atan2(35.0, 670.0);
  Rng rng(10);
  for (int i = 0; i < 300; ++i) {
    Eigen::VectorXd q(6);
    // Joint 2 at -101.1 deg puts the stretched arm's wrist centre on joint 1's axis.
    q << rng.Uniform(-3.0, 3.0), -(101.1 + rng.Uniform(-1.0, 1.0)) * kRadPerDeg, stretched + rng.Uniform(-0.05, 0.05) * kRadPerDeg,
        rng.Uniform(-3.0, 3.0), rng.Uniform(-2.0, 2.0), rng.Uniform(-3.0, 3.0);
    Eigen::VectorXd start = q;
    for (int k = 0; k < 6; ++k) start[k] += 0.1 * kRadPerDeg * rng.Normal();
    start[2] = 2.0 * stretched - q[2];
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    t.start = start;
    const CompensationResult r = Compensate(calibration, nominal, t);
    ASSERT_EQ(r.termination, Termination::kConvergence) << i << ": " << r.message;
    EXPECT_TRUE(r.converged);
    EXPECT_TRUE(r.message.empty()) << r.message;
    EXPECT_LE(r.position_error_mm, options.position_tolerance_mm) << i;
    EXPECT_LE(r.orientation_error_rad, options.orientation_tolerance_rad) << i;
    EXPECT_LT((calibrated.Forward(r.joints, nullptr).translation() - t.pose->translation()).norm(), 1e-6) << i;
  }
}

// Start joints a few degrees from the joints that reach a pose target (a taught program, touched up): on the same
// branch the answer is the solution nearest the start, the true joints (or, near a singularity where the errors
// put two solutions of one branch within a degree or two, one still nearer the start); across a branch boundary
// it is on the start's branch wherever the calibrated robot reaches the target there within start_radius_rad of the
// start (farther, the robot would swing: TaughtJointsAreKept). A third of the targets
// near the elbow's boundaries (joint 3 within 5 deg of 0 or 180), a third near the wrist's (joint 5).
// Before: 1 of the 494 same-branch targets came back 18.9 deg away (joints 2 to 4 moved along the near self-motion
// of the offset wrist's singularity, joint 5 at 179.9 deg), and 3 of the 106 across a boundary on a branch other
// than the start's, which reached the target.
TEST(CompensationTest, StartJointsGiveTheNearestSolutionOnTheirBranch) {
  const RobotModel nominal = RobotModel::Build(Ur10Spec());
  const Calibration calibration = MakeCalibration(Ur10Spec(), 61);
  const ArmSolver arm = *ArmSolver::For(nominal);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  const CompensationOptions options;
  Rng rng(62);
  int same = 0, across = 0, misses = 0, other_nearer = 0, left_branch = 0;
  for (int i = 0; i < 600; ++i) {
    Eigen::VectorXd q = InteriorConfiguration(nominal, &rng);
    if (i % 3 != 0) {
      const double side = rng.Uniform() < 0.5 ? -1.0 : 1.0;
      const double offset_deg = side * rng.Uniform(0.0, 5.0);
      const double boundary_deg = rng.Uniform() < 0.5 ? 0.0 : (rng.Uniform() < 0.5 ? 180.0 : -180.0);
      q[i % 3 == 1 ? 2 : 4] = (boundary_deg + offset_deg) * kRadPerDeg;
    }
    Eigen::VectorXd start = q;
    for (int k = 0; k < 6; ++k) start[k] += 3.0 * kRadPerDeg * rng.Normal();
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    t.start = start;
    const CompensationResult r = Compensate(calibration, nominal, t);
    ASSERT_TRUE(r.converged) << i << ": " << r.message;
    const ArmConfiguration own = arm.ConfigurationOf(start);
    if (own != arm.ConfigurationOf(q)) {
      ++across;
      if (*r.configuration != own) {
        t.configuration = own;
        const CompensationResult on_own = Compensate(calibration, nominal, t);
        if (on_own.converged && (on_own.joints - start).norm() <= options.start_radius_rad) {
          ++left_branch;
          ADD_FAILURE() << i << ": " << r.configuration->ToString() << " although " << own.ToString() << " reaches";
        }
      }
      continue;
    }
    ++same;
    EXPECT_EQ(*r.configuration, own) << i;
    if ((r.joints - q).cwiseAbs().maxCoeff() <= kRadPerDeg) continue;
    if ((r.joints - start).norm() < (q - start).norm()) {
      ++other_nearer;
      continue;
    }
    ++misses;
    ADD_FAILURE() << i << ": " << (r.joints - q).cwiseAbs().maxCoeff() / kRadPerDeg << " deg from the true joints\n  true "
                  << q.transpose() / kRadPerDeg << "\n start " << start.transpose() / kRadPerDeg << "\n   got "
                  << r.joints.transpose() / kRadPerDeg;
  }
  EXPECT_EQ(misses, 0);
  EXPECT_EQ(left_branch, 0);
  EXPECT_LE(other_nearer, 3);
  // Both kinds are there in numbers.
  EXPECT_GT(same, 450);
  EXPECT_GT(across, 50);
}


// Taught joints are kept: a pose target with start_joints a few degrees from joints that reach it (a taught program,
// touched up) comes back near them, never at another solution far away without saying so. A UR10-like arm
// registered in modified DH (the UR10's published lengths) with errors of a calibration's
// size; 600 targets at random joints q, each with start joints 5 deg from q (Euclidean over the joints) in a random
// direction. Since q reaches the target 5 deg from the start:
// - where the start has q's flags, the answer is on that branch within those 5 deg (it is the solution of the
//   start's branch nearest the start, and q is one);
// - where the start lies across a boundary (22 of the 600), within 15 deg: start_radius_rad (10 deg) beyond the
//   nearest solution, which lies within 5 deg; and on another branch than the start's only where the start's has
//   no solution within start_radius_rad. Seen: at most 8.6 deg.
// Before start_radius_rad, 14 of the 600 came back 17 to 260 deg from the start (all across a boundary: 11 at the
// far solution of the start's branch, 3 at one of another branch, chosen for its fewer differing flags).
// Start joints farther than start_radius_rad from every solution name the branch only; the answer then says how far
// it is from them.
TEST(CompensationTest, TaughtJointsAreKept) {
  const RobotModelSpec spec = Ur10LikeMdhSpec();
  const RobotModel nominal = RobotModel::Build(spec);
  const Calibration calibration = MakeCalibration(spec, 71);
  const ArmSolver arm = *ArmSolver::For(nominal);
  const FoldedChain calibrated(calibration.model, calibration.errors);
  const double radius = CompensationOptions{}.start_radius_rad;
  ASSERT_NEAR(radius, 10.0 * kRadPerDeg, 1e-12);
  const double offset = 5.0 * kRadPerDeg;
  Rng rng(72);
  int same = 0, across = 0, swung = 0;
  for (int i = 0; i < 600; ++i) {
    const Eigen::VectorXd q = InteriorConfiguration(nominal, &rng);
    Eigen::VectorXd direction(6);
    for (int k = 0; k < 6; ++k) direction[k] = rng.Normal();
    const Eigen::VectorXd start = q + offset * direction.normalized();
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    t.start = start;
    const CompensationResult r = Compensate(calibration, nominal, t);
    ASSERT_TRUE(r.converged) << i << ": " << r.message;
    EXPECT_TRUE(r.message.empty()) << i << ": " << r.message;
    const ArmConfiguration own = arm.ConfigurationOf(start);
    const double moved = (r.joints - start).norm();
    bool kept = true;
    if (own == arm.ConfigurationOf(q)) {
      ++same;
      kept = *r.configuration == own && moved <= offset + 1e-6;
    } else {
      ++across;
      kept = moved <= offset + radius;
      if (kept && *r.configuration != own) {
        t.configuration = own;
        const CompensationResult on_own = Compensate(calibration, nominal, t);
        kept = !on_own.converged || (on_own.joints - start).norm() > radius;
      }
    }
    if (!kept) {
      ++swung;
      ADD_FAILURE() << i << ": " << moved / kRadPerDeg << " deg from the start, " << r.configuration->ToString()
                    << " for a start with " << own.ToString() << "\n  true " << q.transpose() / kRadPerDeg
                    << "\n start " << start.transpose() / kRadPerDeg
                    << "\n   got " << r.joints.transpose() / kRadPerDeg;
    }
  }
  EXPECT_EQ(swung, 0);
  // Both kinds are there.
  EXPECT_GT(same, 500);
  EXPECT_GT(across, 10);

  // Start joints with joint 5 mirrored (the wrist's other branch, 20 deg or more from q): the answer is on their
  // branch wherever the robot reaches the target there (joints 4 and 6 turned by about 180 deg, often beyond the
  // limits of +-170 deg), and says how far it is from them.
  int far = 0, theirs = 0;
  for (int i = 0; i < 100; ++i) {
    const Eigen::VectorXd q = InteriorConfiguration(nominal, &rng);
    if (std::abs(q[4]) < 10.0 * kRadPerDeg) continue;
    Eigen::VectorXd start = q;
    start[4] = -q[4];
    CompensationTarget t;
    t.pose = calibrated.Forward(q, nullptr);
    t.start = start;
    const CompensationResult r = Compensate(calibration, nominal, t);
    ASSERT_TRUE(r.converged) << i << ": " << r.message;
    const ArmConfiguration own = arm.ConfigurationOf(start);
    if (*r.configuration == own) {
      ++theirs;
      EXPECT_THAT(r.message, HasSubstr(", theirs) is ")) << i;
    } else {
      t.configuration = own;
      EXPECT_FALSE(Compensate(calibration, nominal, t).converged) << i;
    }
    if ((r.joints - start).norm() <= radius) continue;
    ++far;
    EXPECT_THAT(r.message, HasSubstr("no solution within 10 deg of start_joints: this one (")) << i;
  }
  EXPECT_GT(theirs, 10);
  EXPECT_GT(far, 50);
}

}  // namespace
}  // namespace robocal
