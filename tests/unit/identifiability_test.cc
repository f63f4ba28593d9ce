// Identifiable parameter counts, explanations of dropped parameters, and behaviour at parallel axes.
#include <string>
#include <tuple>

#include <Eigen/SVD>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/identifiability.h"
#include "robocal/core/presets.h"
#include "test_util.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

using CountCase = std::tuple<std::string, MeasurementType, int>;

class IdentifiableCountTest : public ::testing::TestWithParam<CountCase> {};

// The 4R + 2P + 6 rule (minus 3 without orientation): grinder5 (3P 2R) 20 / 17, 6R robots 30 / 27.
TEST_P(IdentifiableCountTest, MatchesTheCompletenessRule) {
  const auto& [preset, type, expected] = GetParam();
  const RobotModel model = Preset(preset);
  const IdentifiabilitySummary s = FindIdentifiableParameters(model, type);
  EXPECT_EQ(s.termination, Termination::kConvergence) << s.FullReport();
  EXPECT_EQ(static_cast<int>(s.identifiable.size()), expected) << s.FullReport();
  EXPECT_EQ(s.identifiable.size() + s.dropped.size(), static_cast<size_t>(model.num_error_parameters()));
  // The rank decision has a wide margin.
  EXPECT_GT(s.smallest_kept_pivot, 1e6 * s.largest_dropped_pivot) << s.FullReport();
  for (const DroppedParameter& d : s.dropped) EXPECT_FALSE(d.reason.empty()) << d.name;
}

INSTANTIATE_TEST_SUITE_P(Presets, IdentifiableCountTest,
                         ::testing::Values(CountCase{"grinder5", MeasurementType::kPose, 20},
                                           CountCase{"grinder5", MeasurementType::kPosition, 17},
                                           CountCase{"puma560", MeasurementType::kPose, 30},
                                           CountCase{"puma560", MeasurementType::kPosition, 27},
                                           CountCase{"ur5e", MeasurementType::kPose, 30},
                                           CountCase{"ur5e", MeasurementType::kPosition, 27}),
                         [](const ::testing::TestParamInfo<CountCase>& info) {
                           return std::get<0>(info.param) + "_" + ToString(std::get<1>(info.param));
                         });

TEST(IdentifiabilityTest, ExplainsWhyParametersAreDropped) {
  const RobotModel model = Preset("puma560");
  const IdentifiabilitySummary s = FindIdentifiableParameters(model, MeasurementType::kPosition);
  // Tool rotations do not move the measured point.
  bool saw_tool_rotation = false;
  for (const DroppedParameter& d : s.dropped) {
    if (d.name == "tool.rx" || d.name == "tool.ry" || d.name == "tool.rz") {
      saw_tool_rotation = true;
      EXPECT_THAT(d.reason, HasSubstr("no effect on position"));
    }
  }
  EXPECT_TRUE(saw_tool_rotation) << s.FullReport();
  // In standard DH the first joint's fixed transform is the identity, so base and joint1 errors are the same
  // small transform: one of each such pair is dropped as indistinguishable from the other.
  bool saw_pair = false;
  for (const DroppedParameter& d : s.dropped) {
    if (d.reason.find("indistinguishable from") != std::string::npos) saw_pair = true;
  }
  EXPECT_TRUE(saw_pair) << s.FullReport();
  EXPECT_THAT(s.FullReport(), HasSubstr("identifiable (27)"));
}

TEST(IdentifiabilityTest, SameSeedSameResult) {
  const RobotModel model = Preset("ur5e");
  IdentifiabilityOptions options;
  options.seed = 17;
  const auto a = FindIdentifiableParameters(model, MeasurementType::kPose, options);
  const auto b = FindIdentifiableParameters(model, MeasurementType::kPose, options);
  EXPECT_EQ(a.identifiable, b.identifiable);
  EXPECT_EQ(a.condition_number, b.condition_number);
}

TEST(IdentifiabilityTest, InvalidOptionsFailWithAMessage) {
  const RobotModel model = Preset("grinder5");
  IdentifiabilityOptions options;
  options.num_configurations = 0;
  auto s = FindIdentifiableParameters(model, MeasurementType::kPose, options);
  EXPECT_EQ(s.termination, Termination::kFailure);
  EXPECT_THAT(s.message, HasSubstr("num_configurations"));

  options = {};
  options.num_configurations = 2;  // 6 rows for 42 parameters
  s = FindIdentifiableParameters(model, MeasurementType::kPosition, options);
  EXPECT_EQ(s.termination, Termination::kFailure);
  EXPECT_THAT(s.message, HasSubstr("too few configurations"));

  options = {};
  options.noise.position_mm = -1;
  std::string error;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("noise"));
}

// Parallel consecutive axes (puma560 joints 2-3, ur5e joints 2-4) make the classic DH parameterisation
// singular: a tiny axis misalignment needs a huge d. The complete error model has no such singularity: over
// random configurations the kept parameters are well conditioned, and fitting a random true error
// (linearised, noise-free) gives parameters of the same size as the truth.
class ParallelAxesTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ParallelAxesTest, KeptParametersAreWellConditionedAndBounded) {
  const RobotModel model = Preset(GetParam());
  const MeasurementType type = MeasurementType::kPose;
  const IdentifiabilitySummary s = FindIdentifiableParameters(model, type);
  ASSERT_EQ(s.identifiable.size(), 30u);
  EXPECT_LT(s.condition_number, 1e3) << s.FullReport();

  Rng rng(21);
  const Eigen::VectorXd truth = test::RandomErrors(model, &rng, 0.1, 1e-4);
  const int m = 60;
  const int rows = MeasurementRows(type);
  Eigen::MatrixXd jac_all(rows * m, model.num_error_parameters());
  KinematicsWorkspace ws(model);
  Eigen::MatrixXd block(rows, model.num_error_parameters());
  for (int i = 0; i < m; ++i) {
    IdentificationJacobian(model, RandomConfiguration(model, &rng), Eigen::VectorXd(), type, &ws, block);
    jac_all.middleRows(i * rows, rows) = block;
  }
  const Eigen::VectorXd y = jac_all * truth;
  Eigen::MatrixXd jac_kept(jac_all.rows(), static_cast<Eigen::Index>(s.identifiable.size()));
  for (size_t k = 0; k < s.identifiable.size(); ++k) jac_kept.col(k) = jac_all.col(s.identifiable[k]);
  const Eigen::VectorXd fit = jac_kept.colPivHouseholderQr().solve(y);
  EXPECT_LT((jac_kept * fit - y).norm(), 1e-9 * y.norm());  // the reduced model explains every error
  for (size_t k = 0; k < s.identifiable.size(); ++k) {
    const bool translation = RobotModel::IsTranslationParameter(s.identifiable[k]);
    // Dropped parameters fold into kept ones through lever arms of at most the robot's reach (~1 m).
    const double bound = translation ? 2000.0 * 1e-4 * 6 + 0.1 * 6 : 1e-4 * 6;
    EXPECT_LT(std::abs(fit[k]), bound) << model.parameter_name(s.identifiable[k]) << " = " << fit[k];
  }
}

INSTANTIATE_TEST_SUITE_P(SixAxis, ParallelAxesTest, ::testing::Values("puma560", "ur5e"));

}  // namespace
}  // namespace robocal
