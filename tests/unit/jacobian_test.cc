// The analytic identification and joint Jacobians against central finite differences.
#include <cmath>
#include <string>
#include <tuple>

#include <gtest/gtest.h>

#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "test_util.h"

namespace robocal {
namespace {

// Residual of the model at (q, eps) against a fixed "measurement" T_ref; the Jacobian is -d residual/d eps.
Eigen::VectorXd Residual(const RobotModel& model, MeasurementType type, const Transform& t_ref,
                         const Eigen::VectorXd& q, const Eigen::VectorXd& eps) {
  KinematicsWorkspace ws(model);
  const Transform t = ForwardKinematics(model, q, eps, &ws);
  Eigen::VectorXd r(MeasurementRows(type));
  MeasurementResidual(type, t_ref, t, r);
  return r;
}

using Case = std::tuple<std::string, MeasurementType, bool>;  // preset, type, at random non-zero eps

class JacobianTest : public ::testing::TestWithParam<Case> {};

TEST_P(JacobianTest, IdentificationJacobianMatchesCentralDifferences) {
  const auto& [preset, type, nonzero_eps] = GetParam();
  const RobotModel model = Preset(preset);
  KinematicsWorkspace ws(model);
  Rng rng(1234);
  const int n = model.num_error_parameters();
  Eigen::VectorXd steps(n);
  for (int k = 0; k < n; ++k) steps[k] = RobotModel::IsTranslationParameter(k) ? 1e-3 : 1e-5;
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    const Eigen::VectorXd eps = nonzero_eps ? test::RandomErrors(model, &rng) : Eigen::VectorXd::Zero(n);
    Eigen::MatrixXd jac(MeasurementRows(type), n);
    IdentificationJacobian(model, q, eps, type, &ws, jac);
    const Transform t_ref = ws.T_world_tool;
    // `type` is captured by name: clang before 16 cannot capture a structured binding implicitly.
    const Eigen::MatrixXd fd = -test::CentralDifferences(
        [&, type = type](const Eigen::VectorXd& e) { return Residual(model, type, t_ref, q, e); }, eps, steps);
    EXPECT_LT(test::MaxRelativeColumnError(jac, fd), 1e-6) << "trial " << trial;
  }
}

TEST_P(JacobianTest, JointJacobianMatchesCentralDifferences) {
  const auto& [preset, type, nonzero_eps] = GetParam();
  const RobotModel model = Preset(preset);
  KinematicsWorkspace ws(model);
  Rng rng(99);
  Eigen::VectorXd steps(model.num_joints());
  for (int i = 0; i < model.num_joints(); ++i) steps[i] = model.joint_type(i) == JointType::kRevolute ? 1e-5 : 1e-3;
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    const Eigen::VectorXd eps = nonzero_eps ? test::RandomErrors(model, &rng) : Eigen::VectorXd();
    Eigen::MatrixXd jac(MeasurementRows(type), model.num_joints());
    JointJacobian(model, q, eps, type, &ws, jac);
    const Transform t_ref = ws.T_world_tool;
    const Eigen::MatrixXd fd = -test::CentralDifferences(
        [&, type = type](const Eigen::VectorXd& qq) { return Residual(model, type, t_ref, qq, eps); }, q, steps);
    EXPECT_LT(test::MaxRelativeColumnError(jac, fd), 1e-6) << "trial " << trial;
  }
}

INSTANTIATE_TEST_SUITE_P(
    AllPresetsAndTypes, JacobianTest,
    ::testing::Combine(::testing::Values("grinder5", "puma560", "ur5e"),
                       ::testing::Values(MeasurementType::kPosition, MeasurementType::kPositionAxis,
                                         MeasurementType::kPose),
                       ::testing::Bool()),
    [](const ::testing::TestParamInfo<Case>& info) {
      return std::get<0>(info.param) + "_" + ToString(std::get<1>(info.param)) +
             (std::get<2>(info.param) ? "_with_errors" : "_nominal");
    });

// The paper's statement dX ~= e(q) eps: for small errors the first-order prediction matches the true change
// of the pose to second order.
TEST(JacobianTest, LinearisationPredictsSmallErrors) {
  const RobotModel model = Preset("ur5e");
  KinematicsWorkspace ws(model);
  Rng rng(5);
  const Eigen::VectorXd q = RandomConfiguration(model, &rng);
  const Eigen::VectorXd eps = test::RandomErrors(model, &rng, 0.05, 2e-4);
  Eigen::MatrixXd jac(6, model.num_error_parameters());
  IdentificationJacobian(model, q, Eigen::VectorXd(), MeasurementType::kPose, &ws, jac);
  const Transform nominal = ws.T_world_tool;
  const Transform actual = ForwardKinematics(model, q, eps, &ws);
  Eigen::VectorXd dx(6);
  MeasurementResidual(MeasurementType::kPose, actual, nominal, dx);
  const Eigen::VectorXd predicted = jac * eps;
  // Second-order terms: about |eps_rot|^2 * reach ~ (1e-3)^2 * 1000 mm.
  EXPECT_LT((dx - predicted).norm(), 1e-2 * predicted.norm());
}

TEST(JacobianTest, WrongSizeThrows) {
  const RobotModel model = Preset("grinder5");
  KinematicsWorkspace ws(model);
  Eigen::MatrixXd jac(5, 10);
  EXPECT_THROW(IdentificationJacobian(model, Eigen::VectorXd::Zero(5), Eigen::VectorXd(), MeasurementType::kPose,
                                      &ws, jac),
               std::invalid_argument);
}

}  // namespace
}  // namespace robocal
