// Observability indices: hand-computed values, scaling, incremental evaluation against a full SVD, and the
// predicted accuracy of a plan.
#include <cmath>

#include <Eigen/SVD>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/identifiability.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/observability.h"
#include "robocal/core/column_scaling.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "test_util.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

// sigma = (4, 2, 1), M = 2, L = 3.
TEST(ObservabilityIndicesTest, MatchHandComputedValues) {
  const ObservabilityIndices x = IndicesFromSingularValues(Eigen::Vector3d(1, 4, 2), 2, "test");
  EXPECT_EQ(x.singular_values, Eigen::Vector3d(4, 2, 1));
  EXPECT_DOUBLE_EQ(x.condition_number, 4.0);
  // O1 takes the L-th root of the product (8^(1/3) = 2), not the M-th (8^(1/2)), then divides by sqrt(M).
  EXPECT_NEAR(x.o1, 2.0 / std::sqrt(2.0), 1e-15);
  EXPECT_DOUBLE_EQ(x.o2, 0.25);
  EXPECT_DOUBLE_EQ(x.o3, 1.0);
  EXPECT_DOUBLE_EQ(x.o4, 0.25);
  EXPECT_NEAR(x.o5, 1.0 / 1.75, 1e-15);
  EXPECT_NEAR(x.log_det, std::log(64.0), 1e-14);
  EXPECT_DOUBLE_EQ(ObjectiveValue(x, ObservabilityIndex::kConditionNumber), 4.0);
  EXPECT_DOUBLE_EQ(ObjectiveValue(x, ObservabilityIndex::kO3), -1.0);
}

TEST(ObservabilityIndicesTest, RankDeficientSetIsInfinitelyBad) {
  const ObservabilityIndices x = IndicesFromSingularValues(Eigen::Vector2d(3, 0), 1, "test");
  EXPECT_TRUE(std::isinf(x.condition_number));
  EXPECT_EQ(x.o1, 0.0);
  EXPECT_EQ(x.o5, 0.0);
  EXPECT_TRUE(std::isinf(x.log_det) && x.log_det < 0);
}

// A = diag(9, 1) standing for E* = diag(3, 1), two translation parameters.
TEST(ObservabilityIndicesTest, ColumnScalingsOnASmallMatrix) {
  const RobotModel model = Preset("grinder5");
  ObservabilityOptions o;
  o.parameters = {0, 1};
  const Eigen::Matrix2d normal = Eigen::Vector2d(9, 1).asDiagonal();
  o.scaling = ColumnScaling::kNone;
  EXPECT_NEAR(ObservabilityEvaluator(model, o).IndicesOf(normal, 1).condition_number, 3.0, 1e-12);
  o.scaling = ColumnScaling::kColumnNorm;
  EXPECT_NEAR(ObservabilityEvaluator(model, o).IndicesOf(normal, 1).condition_number, 1.0, 1e-12);
  o.scaling = ColumnScaling::kExpectedDeviation;
  o.expected_translation_mm = 0.1;
  const ObservabilityIndices x = ObservabilityEvaluator(model, o).IndicesOf(normal, 1);
  EXPECT_NEAR(x.singular_values[0], 0.3, 1e-12);
  EXPECT_NEAR(x.singular_values[1], 0.1, 1e-12);
  EXPECT_THAT(x.scaling, HasSubstr("expected_deviation"));
}

class IncrementalTest : public ::testing::TestWithParam<std::tuple<std::string, int, ColumnScaling>> {};

// After many single-configuration changes (several refresh intervals), the incrementally kept indices equal a
// full SVD of the stacked, scaled E* to 1e-9 relative.
TEST_P(IncrementalTest, EqualsFullRecomputation) {
  const auto& [preset, m, scaling] = GetParam();
  const RobotModel model = Preset(preset);
  ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  o.scaling = scaling;
  ObservabilityEvaluator evaluator(model, o);
  Rng rng(8);
  evaluator.SetConfigurations(RandomConfigurations(model, m, &rng));
  for (int step = 0; step < 150; ++step) {
    const int k = static_cast<int>(rng.Index(m));
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    const ObservabilityIndices predicted = evaluator.EvaluateReplacement(k, q);
    evaluator.Replace(k, q);
    EXPECT_NEAR(predicted.condition_number, evaluator.indices().condition_number,
                1e-12 * evaluator.indices().condition_number);
  }
  const ObservabilityIndices incremental = evaluator.indices();
  const ObservabilityIndices full = ComputeIndicesBySvd(model, evaluator.configurations(), o);
  auto rel = [](double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-300); };
  EXPECT_LT(rel(incremental.condition_number, full.condition_number), 1e-9);
  EXPECT_LT(rel(incremental.o1, full.o1), 1e-9);
  EXPECT_LT(rel(incremental.o2, full.o2), 1e-9);
  EXPECT_LT(rel(incremental.o3, full.o3), 1e-9);
  EXPECT_LT(rel(incremental.o4, full.o4), 1e-9);
  EXPECT_LT(rel(incremental.o5, full.o5), 1e-9);
  EXPECT_LT(rel(incremental.log_det, full.log_det), 1e-9);
  for (int i = 0; i < full.num_parameters; ++i) {
    EXPECT_LT(rel(incremental.singular_values[i], full.singular_values[i]), 1e-9);
  }
  // Add and remove keep the same agreement.
  evaluator.Add(RandomConfiguration(model, &rng));
  evaluator.Remove(0);
  EXPECT_LT(rel(evaluator.indices().condition_number,
                ComputeIndicesBySvd(model, evaluator.configurations(), o).condition_number),
            1e-9);
}

INSTANTIATE_TEST_SUITE_P(Sizes, IncrementalTest,
                         ::testing::Combine(::testing::Values("grinder5", "ur5e"), ::testing::Values(10, 200),
                                            ::testing::Values(ColumnScaling::kColumnNorm,
                                                              ColumnScaling::kExpectedDeviation)));

TEST(ObservabilityOptionsTest, RejectsBadParameterLists) {
  const RobotModel model = Preset("grinder5");
  ObservabilityOptions o;
  std::string error;
  EXPECT_FALSE(o.IsValid(model, &error));
  EXPECT_THAT(error, HasSubstr("at least one"));
  o.parameters = {3, 2};
  EXPECT_FALSE(o.IsValid(model, &error));
  EXPECT_THAT(error, HasSubstr("ascending"));
  o.parameters = {1, 42};
  EXPECT_FALSE(o.IsValid(model, &error));
  EXPECT_THAT(error, HasSubstr("parameters[1]"));
  EXPECT_THROW(ObservabilityEvaluator(model, o), std::invalid_argument);
}

// Planning with reflector nests sees what the fit sees: over random configurations the evaluator's E* has the
// rank of the identifiable set with three nests (held: as many as pose measurements; free: 3 more), the rows are
// each nest's (3 per nest), and two nests on a line cannot determine that set. With a tracker model the rows are
// whitened at each nest's point: the same rank, other numbers.
TEST(ObservabilityReflectorTest, NestsGiveTheirRowsAndTheIdentifiableRank) {
  const RobotModel model = Preset("ur5e");
  Rng rng(6);
  const auto configurations = RandomConfigurations(model, 30, &rng);
  for (const bool fixed : {true, false}) {
    SCOPED_TRACE(fixed ? "held" : "free");
    std::vector<Reflector> nests = {{"a", {60.0, 0.0, 20.0}, fixed}, {"b", {-30.0, 52.0, 20.0}, fixed},
                                    {"c", {-30.0, -52.0, 20.0}, fixed}};
    IdentifiabilityOptions probe;
    probe.reflectors = nests;
    const IdentifiabilitySummary id = FindIdentifiableParameters(model, MeasurementType::kPosition, probe);
    ASSERT_EQ(id.termination, Termination::kConvergence);
    ObservabilityOptions o;
    o.measurement_type = MeasurementType::kPosition;
    o.reflectors = nests;
    o.parameters = id.identifiable;
    EXPECT_EQ(o.RowsPerConfiguration(), 9);
    ObservabilityEvaluator evaluator(model, o);
    EXPECT_EQ(evaluator.Block(configurations[0]).rows(), 9);
    EXPECT_EQ(NumericalRank(model, configurations, o), static_cast<int>(id.identifiable.size()));
    EXPECT_EQ(id.identifiable.size(), fixed ? 30u : 33u);
    o.noise.tracker = TrackerUncertainty{};
    o.tracker_position_mm = Eigen::Vector3d(2500.0, -800.0, 300.0);
    EXPECT_EQ(NumericalRank(model, configurations, o), static_cast<int>(id.identifiable.size()));
    // The set three nests identify is too much for two (their line's turn is open).
    if (fixed) {
      o.reflectors.pop_back();
      EXPECT_LT(NumericalRank(model, configurations, o), static_cast<int>(id.identifiable.size()));
    }
  }
  // Reflectors and parameters beyond the model's are checked.
  ObservabilityOptions bad;
  bad.measurement_type = MeasurementType::kPose;
  bad.reflectors = {{"a", {60.0, 0.0, 20.0}, false}};
  bad.parameters = {0};
  std::string error;
  EXPECT_FALSE(bad.IsValid(model, &error));
  EXPECT_THAT(error, HasSubstr("reflectors need position measurements"));
}

// Predicted accuracy is noise propagation: it scales linearly with the tracker noise, and measuring every
// configuration twice divides it by sqrt(2), exactly.
TEST(PredictedAccuracyTest, ScalesWithNoiseAndRepetition) {
  const RobotModel model = Preset("ur5e");
  ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  Rng rng(4);
  const auto plan = RandomConfigurations(model, 12, &rng);
  const auto validation = RandomConfigurations(model, 36, &rng);
  const PredictedAccuracy base = PredictAccuracy(model, o, plan, validation);
  ASSERT_EQ(base.num_validation, 36);
  EXPECT_GT(base.rms_position_mm, 0.0);
  EXPECT_TRUE(base.has_orientation);
  EXPECT_GE(base.max_position_mm, base.rms_position_mm * 0.999);

  ObservabilityOptions noisier = o;
  noisier.noise.position_mm *= 2;
  noisier.noise.orientation_rad *= 2;
  EXPECT_NEAR(PredictAccuracy(model, noisier, plan, validation).rms_position_mm, 2 * base.rms_position_mm,
              1e-9 * base.rms_position_mm);

  auto twice = plan;
  twice.insert(twice.end(), plan.begin(), plan.end());
  const PredictedAccuracy doubled = PredictAccuracy(model, o, twice, validation);
  EXPECT_NEAR(doubled.rms_position_mm, base.rms_position_mm / std::sqrt(2.0), 1e-9 * base.rms_position_mm);
  EXPECT_NEAR(doubled.rms_orientation_rad, base.rms_orientation_rad / std::sqrt(2.0),
              1e-9 * base.rms_orientation_rad);
}

TEST(PredictedAccuracyTest, SingularPlanPredictsNothing) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  Rng rng(4);
  const auto plan = RandomConfigurations(model, 2, &rng);  // 12 rows for 30 parameters
  EXPECT_EQ(PredictAccuracy(model, o, plan, RandomConfigurations(model, 5, &rng)).num_validation, 0);
}

// The one rank cut on a plan: unit columns and an SVD of the stack, whatever scaling the indices use.
TEST(NumericalRankTest, CountsWhatTheSetDetermines) {
  const RobotModel model = Preset("ur5e");
  ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  const int l = static_cast<int>(o.parameters.size());
  Rng rng(4);
  const auto plan = RandomConfigurations(model, 12, &rng);
  EXPECT_EQ(NumericalRank(model, plan, o), l);
  EXPECT_LE(NumericalRank(model, RandomConfigurations(model, 2, &rng), o), 12);  // 12 rows
  // One configuration twelve times: 6 independent rows. From the normal matrix's eigenvalues the lost
  // directions come out at its round-off, sigma up to ~4e-8 sigma_1, right at the cut; the SVD of the stack
  // puts them at ~1e-16.
  const std::vector<Eigen::VectorXd> repeated(12, plan.front());
  EXPECT_LE(NumericalRank(model, repeated, o), 6);
  EXPECT_EQ(NumericalRank(model, {}, o), 0);
  o.scaling = ColumnScaling::kNone;
  EXPECT_EQ(NumericalRank(model, plan, o), l);
  EXPECT_LE(NumericalRank(model, repeated, o), 6);
}

TEST(PredictedAccuracyTest, RepeatedConfigurationPredictsNothing) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = test::IdentifiableSetOptions(model, MeasurementType::kPose);
  Rng rng(4);
  const std::vector<Eigen::VectorXd> repeated(12, RandomConfigurations(model, 1, &rng).front());
  EXPECT_EQ(PredictAccuracy(model, o, repeated, RandomConfigurations(model, 5, &rng)).num_validation, 0);
}

}  // namespace
}  // namespace robocal

namespace robocal {
namespace {

TEST(ColumnScalingTest, UnitColumnsAndColumnsWithoutEffect) {
  Eigen::MatrixXd j(2, 4);
  j << 3, 0, 1e-20, 0.5,  //
      4, 0, 0, 0;
  const Eigen::VectorXd d = UnitColumnFactorsOf(j);
  EXPECT_DOUBLE_EQ(d[0], 0.2);  // |(3, 4)| = 5
  EXPECT_EQ(d[1], 0.0);         // a zero column stays zero
  EXPECT_EQ(d[2], 0.0);         // 1e-20 is below 1e-12 of the largest norm: no effect, not amplified
  EXPECT_DOUBLE_EQ(d[3], 2.0);
  const Eigen::MatrixXd scaled = j * d.asDiagonal();
  EXPECT_NEAR(scaled.col(0).norm(), 1.0, 1e-15);
  EXPECT_NEAR(scaled.col(3).norm(), 1.0, 1e-15);
  EXPECT_EQ(scaled.col(2).norm(), 0.0);
}

TEST(ColumnScalingTest, PivotRankCountsPivotsAboveTheTolerance) {
  EXPECT_EQ(PivotRank(Eigen::Vector3d(10.0, 1.0, 1e-9), 1e-6), 2);
  EXPECT_EQ(PivotRank(Eigen::Vector3d(10.0, 1.0, 1e-5), 1e-6), 3);
  EXPECT_EQ(PivotRank(Eigen::Vector3d(0.0, 0.0, 0.0), 1e-6), 0);
  EXPECT_EQ(PivotRank(Eigen::VectorXd(), 1e-6), 0);
}

// One text for every Summary's scaling: identifiability and identification (unit columns) say what an
// observability evaluation with kColumnNorm says.
TEST(ColumnScalingTest, OneDescriptionOfTheScaling) {
  MeasurementNoise noise;
  noise.position_mm = 0.02;
  noise.orientation_rad = 1.5e-4;
  EXPECT_EQ(DescribeScaling(noise), "rows / noise (0.02 mm, 0.00015 rad); columns: column_norm");
  EXPECT_EQ(DescribeScaling(noise, ColumnScaling::kNone), "rows / noise (0.02 mm, 0.00015 rad); columns: none");
  EXPECT_EQ(DescribeScaling(noise, ColumnScaling::kExpectedDeviation, 0.2, 2e-3),
            "rows / noise (0.02 mm, 0.00015 rad); columns: expected_deviation (0.2 mm, 0.002 rad)");

  const RobotModel model = Preset("grinder5");
  IdentifiabilityOptions identifiability;
  identifiability.noise = noise;
  const IdentifiabilitySummary s = FindIdentifiableParameters(model, MeasurementType::kPose, identifiability);
  EXPECT_EQ(s.scaling, DescribeScaling(noise));
  ObservabilityOptions o;
  o.noise = noise;
  o.parameters = s.identifiable;
  EXPECT_EQ(o.ScalingDescription(), s.scaling);
  Rng rng(5);
  EXPECT_EQ(ComputeIndicesBySvd(model, RandomConfigurations(model, 10, &rng), o).scaling, s.scaling);
}

}  // namespace
}  // namespace robocal

// The predicted_error index (I-optimality).
namespace robocal {
namespace {

ObservabilityOptions PredictedErrorOptions(const RobotModel& model, MeasurementType type) {
  ObservabilityOptions o;
  o.measurement_type = type;
  o.parameters = FindIdentifiableParameters(model, type).identifiable;
  return o;
}

// Assembled by hand: E* stacked from the Jacobians with rows divided by the noise, C = (E*'E*)^-1 by an SVD,
// then sqrt(mean_v trace(J_pos C J_pos') + h^2 trace(J_rot C J_rot')) from each validation pose Jacobian.
double HandPredictedError(const RobotModel& model, const ObservabilityOptions& o,
                          const std::vector<Eigen::VectorXd>& plan, const std::vector<Eigen::VectorXd>& validation) {
  const int rows = MeasurementRows(o.measurement_type);
  const int l = static_cast<int>(o.parameters.size());
  KinematicsWorkspace ws(model);
  Eigen::MatrixXd full(rows, model.num_error_parameters());
  Eigen::MatrixXd e(rows * plan.size(), l);
  const Eigen::VectorXd w = o.noise.RowWeights(o.measurement_type);
  for (size_t m = 0; m < plan.size(); ++m) {
    IdentificationJacobian(model, plan[m], Eigen::VectorXd(), o.measurement_type, &ws, full);
    for (int k = 0; k < l; ++k) e.block(m * rows, k, rows, 1) = w.cwiseProduct(full.col(o.parameters[k]));
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(e, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd s = svd.singularValues();
  const Eigen::MatrixXd c = svd.matrixV() * s.cwiseInverse().cwiseAbs2().asDiagonal() * svd.matrixV().transpose();
  const double h = o.measurement_type == MeasurementType::kPosition ? 0.0 : o.orientation_length_mm;
  Eigen::MatrixXd pose(6, model.num_error_parameters());
  double sum = 0.0;
  for (const Eigen::VectorXd& q : validation) {
    IdentificationJacobian(model, q, Eigen::VectorXd(), MeasurementType::kPose, &ws, pose);
    Eigen::MatrixXd j(6, l);
    for (int k = 0; k < l; ++k) j.col(k) = pose.col(o.parameters[k]);
    const Eigen::MatrixXd jp = j.topRows(3), jr = j.bottomRows(3);
    sum += (jp * c * jp.transpose()).trace() + h * h * (jr * c * jr.transpose()).trace();
  }
  return std::sqrt(sum / validation.size());
}

class PredictedErrorTest : public ::testing::TestWithParam<MeasurementType> {};

TEST_P(PredictedErrorTest, EqualsAHandAssembledComputation) {
  const RobotModel model = Preset("puma560");
  const ObservabilityOptions o = PredictedErrorOptions(model, GetParam());
  Rng rng(21);
  const auto plan = RandomConfigurations(model, 12, &rng);
  const auto validation = RandomConfigurations(model, 7, &rng);
  const double reference = HandPredictedError(model, o, plan, validation);
  ASSERT_GT(reference, 0.0);
  ObservabilityEvaluator evaluator(model, o);
  evaluator.SetConfigurations(plan);
  EXPECT_TRUE(std::isnan(evaluator.indices().predicted_error_mm));  // no validation sample yet
  evaluator.SetValidation(validation);
  EXPECT_EQ(evaluator.num_validation(), 7);
  EXPECT_NEAR(evaluator.indices().predicted_error_mm, reference, 1e-9 * reference);
  EXPECT_DOUBLE_EQ(evaluator.indices().Get(ObservabilityIndex::kPredictedError),
                   evaluator.indices().predicted_error_mm);
  EXPECT_DOUBLE_EQ(ObjectiveValue(evaluator.indices(), ObservabilityIndex::kPredictedError),
                   evaluator.indices().predicted_error_mm);  // minimised: not negated
  // PredictAccuracy reports the same quantity, per configuration instead of through G.
  const PredictedAccuracy predicted = PredictAccuracy(model, o, plan, validation);
  EXPECT_NEAR(predicted.rms_error_mm, reference, 1e-9 * reference);
  if (GetParam() == MeasurementType::kPosition) {
    EXPECT_NEAR(predicted.rms_error_mm, predicted.rms_position_mm, 1e-12 * reference);
  } else {
    EXPECT_NEAR(predicted.rms_error_mm,
                std::hypot(predicted.rms_position_mm, o.orientation_length_mm * predicted.rms_orientation_rad),
                1e-9 * reference);
  }
  // The column scaling of the other indices does not change it: C does not depend on it.
  ObservabilityOptions unscaled = o;
  unscaled.scaling = ColumnScaling::kNone;
  ObservabilityEvaluator other(model, unscaled);
  other.SetValidation(validation);
  other.SetConfigurations(plan);
  EXPECT_NEAR(other.indices().predicted_error_mm, reference, 1e-9 * reference);
  // Incremental updates carry it: replacing a configuration gives what a fresh evaluation gives.
  const Eigen::VectorXd q = RandomConfigurations(model, 1, &rng).front();
  const double replaced = evaluator.EvaluateReplacement(4, q).predicted_error_mm;
  auto changed = plan;
  changed[4] = q;
  EXPECT_NEAR(replaced, HandPredictedError(model, o, changed, validation), 1e-9 * replaced);
}

INSTANTIATE_TEST_SUITE_P(Types, PredictedErrorTest,
                         ::testing::Values(MeasurementType::kPosition, MeasurementType::kPositionAxis,
                                           MeasurementType::kPose),
                         [](const ::testing::TestParamInfo<MeasurementType>& info) { return ToString(info.param); });

TEST(PredictedErrorIndexTest, SingularSetsAreInfinitelyBad) {
  const RobotModel model = Preset("ur5e");
  const ObservabilityOptions o = PredictedErrorOptions(model, MeasurementType::kPose);
  Rng rng(4);
  const auto validation = RandomConfigurations(model, 5, &rng);
  ObservabilityEvaluator evaluator(model, o);
  evaluator.SetValidation(validation);
  evaluator.SetConfigurations(RandomConfigurations(model, 2, &rng));  // 12 rows for 30 parameters
  EXPECT_TRUE(std::isinf(evaluator.indices().predicted_error_mm));
  evaluator.SetConfigurations(std::vector<Eigen::VectorXd>(12, RandomConfigurations(model, 1, &rng).front()));
  EXPECT_TRUE(std::isinf(evaluator.indices().predicted_error_mm));
  EXPECT_TRUE(std::isinf(evaluator.PredictedError(Eigen::MatrixXd::Zero(30, 30))));
  // Other ways to indices know no validation sample.
  EXPECT_TRUE(std::isnan(ComputeIndicesBySvd(model, RandomConfigurations(model, 10, &rng), o).predicted_error_mm));
}

TEST(PredictedErrorIndexTest, NameParsesAndOrientationLengthIsValidated) {
  ObservabilityIndex index = ObservabilityIndex::kO1;
  EXPECT_STREQ(ToString(ObservabilityIndex::kPredictedError), "predicted_error");
  ASSERT_TRUE(ParseObservabilityIndex("predicted_error", &index));
  EXPECT_EQ(index, ObservabilityIndex::kPredictedError);
  ASSERT_TRUE(ParseObservabilityIndex("log_det", &index));
  EXPECT_EQ(index, ObservabilityIndex::kLogDet);
  const RobotModel model = Preset("grinder5");
  ObservabilityOptions o = PredictedErrorOptions(model, MeasurementType::kPose);
  o.orientation_length_mm = 0.0;
  std::string error;
  EXPECT_FALSE(o.IsValid(model, &error));
  EXPECT_THAT(error, HasSubstr("orientation_length_mm"));
}

// A longer lever arm weighs the orientation more; position-only types ignore it.
TEST(PredictedErrorIndexTest, OrientationLengthWeighsOrientationOnly) {
  const RobotModel model = Preset("grinder5");
  Rng rng(8);
  const auto plan = RandomConfigurations(model, 10, &rng);
  const auto validation = RandomConfigurations(model, 9, &rng);
  for (MeasurementType type : {MeasurementType::kPosition, MeasurementType::kPose}) {
    ObservabilityOptions o = PredictedErrorOptions(model, type);
    const double base = PredictAccuracy(model, o, plan, validation).rms_error_mm;
    o.orientation_length_mm = 300.0;
    const double longer = PredictAccuracy(model, o, plan, validation).rms_error_mm;
    if (type == MeasurementType::kPosition) {
      EXPECT_DOUBLE_EQ(longer, base);
    } else {
      EXPECT_GT(longer, base);
    }
  }
}

}  // namespace
}  // namespace robocal
