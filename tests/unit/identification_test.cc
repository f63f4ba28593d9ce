// Identification: registration, exact recovery from noise-free shots, the calibration of the reported standard
// deviations against the noise, and failures that name their cause.
#include <cmath>
#include <string>
#include <tuple>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/identification.h"

#include "robocal/core/column_scaling.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"
#include "test_util.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

VirtualCellOptions ExactCell(std::uint64_t seed) {
  VirtualCellOptions o;
  o.seed = seed;
  o.noise = {0.0, 0.0};
  o.shots_per_pose = 1;
  return o;
}

Transform RandomTransform(Rng* rng) {
  const Eigen::Vector3d xyz(rng->Uniform(-2000, 2000), rng->Uniform(-2000, 2000), rng->Uniform(-2000, 2000));
  const Eigen::Vector3d rpy(rng->Uniform(-3, 3), rng->Uniform(-1.5, 1.5), rng->Uniform(-3, 3));
  return TransformFromXyzRpy(xyz, rpy);
}

// The summary's figures and the calibration's parameter estimates are all finite.
bool FitIsFinite(const Calibration& cal) {
  const IdentificationSummary& s = cal.summary;
  const double values[] = {s.initial_cost,
                           s.final_cost,
                           s.sigma_hat,
                           s.condition_number,
                           s.seconds,
                           s.before.rms_position_mm,
                           s.before.max_position_mm,
                           s.before.rms_orientation_rad,
                           s.before.rms_weighted,
                           s.after.rms_position_mm,
                           s.after.max_position_mm,
                           s.after.rms_orientation_rad,
                           s.after.rms_weighted};
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  for (const IdentifiedParameter& p : cal.parameters) {
    if (!std::isfinite(p.value) || !std::isfinite(p.std)) return false;
  }
  return true;
}

TEST(RegisterPointsTest, RecoversAKnownTransformExactly) {
  Rng rng(3);
  for (int trial = 0; trial < 10; ++trial) {
    const Transform truth = RandomTransform(&rng);
    std::vector<Eigen::Vector3d> from, to;
    for (int i = 0; i < 3 + trial; ++i) {
      from.emplace_back(rng.Uniform(-1000, 1000), rng.Uniform(-1000, 1000), rng.Uniform(-1000, 1000));
      to.push_back(truth * from.back());
    }
    const Transform t = RegisterPoints(from, to);
    EXPECT_LT((t.linear() - truth.linear()).cwiseAbs().maxCoeff(), 1e-12) << trial;
    EXPECT_LT((t.translation() - truth.translation()).norm(), 1e-9) << trial;
    EXPECT_NEAR(t.linear().determinant(), 1.0, 1e-12);
  }
}

TEST(RegisterPointsTest, GivesAProperRotationForPlanarNoisyPoints) {
  // Planar point sets are where an unguarded SVD solution turns into a reflection.
  Rng rng(5);
  const Transform truth = RandomTransform(&rng);
  std::vector<Eigen::Vector3d> from, to;
  for (int i = 0; i < 6; ++i) {
    from.emplace_back(rng.Uniform(-500, 500), rng.Uniform(-500, 500), 0.0);
    to.push_back(truth * from.back() + Eigen::Vector3d(rng.Normal(), rng.Normal(), rng.Normal()) * 0.01);
  }
  const Transform t = RegisterPoints(from, to);
  EXPECT_NEAR(t.linear().determinant(), 1.0, 1e-12);
  EXPECT_LT(RotationVector(t.linear() * truth.linear().transpose()).norm(), 1e-3);
}

TEST(RegisterPointsTest, RejectsCollinearTooFewAndMismatchedPoints) {
  const std::vector<Eigen::Vector3d> line = {{0, 0, 0}, {1, 2, 3}, {2, 4, 6}, {-5, -10, -15}};
  EXPECT_THROW(RegisterPoints(line, line), std::invalid_argument);
  const std::vector<Eigen::Vector3d> same = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
  EXPECT_THROW(RegisterPoints(same, same), std::invalid_argument);
  const std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(RegisterPoints(two, two), std::invalid_argument);
  const std::vector<Eigen::Vector3d> triangle = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_THROW(RegisterPoints(triangle, line), std::invalid_argument);
  EXPECT_NO_THROW(RegisterPoints(triangle, triangle));
}

using RecoveryCase = std::tuple<std::string, MeasurementType, int>;

class NoiseFreeRecoveryTest : public ::testing::TestWithParam<RecoveryCase> {};

// With exact shots the identifiable parameters reproduce the true robot everywhere, not only at the fitted
// poses: the unidentifiable ones change nothing the tracker can see.
TEST_P(NoiseFreeRecoveryTest, CalibratedModelPredictsTheTrueRobotOnFreshConfigurations) {
  const auto& [preset, type, expected_parameters] = GetParam();
  const RobotModel model = Preset(preset);
  VirtualCell cell(model, ExactCell(17));
  const auto measurements = cell.MeasureAll(test::RandomConfigurations(model, 30, 100));
  IdentificationOptions o;
  o.measurement_type = type;
  const Calibration cal = Identify(model, measurements, o);
  const IdentificationSummary& s = cal.summary;
  ASSERT_EQ(s.termination, Termination::kConvergence) << s.FullReport();
  EXPECT_EQ(s.num_parameters, expected_parameters);
  EXPECT_EQ(static_cast<int>(cal.parameters.size() + s.dropped.size()), model.num_error_parameters());
  EXPECT_EQ(s.num_poses, 30);
  EXPECT_GT(s.before.rms_position_mm, 0.1) << "the hidden errors must be visible before the fit";
  EXPECT_LT(s.after.rms_position_mm, 1e-8) << s.FullReport();
  EXPECT_GT(s.iterations, 0);
  EXPECT_GT(s.condition_number, 1.0);
  EXPECT_EQ(s.scaling, DescribeScaling(IdentificationOptions{}.noise, ColumnScaling::kColumnNorm));

  // The effective frames: the nominal model with them and no base/tool errors predicts the same poses.
  RobotModelSpec spec = model.spec();
  spec.T_world_base = cal.T_world_base;
  spec.T_flange_tool = cal.T_flange_tool;
  const RobotModel effective = RobotModel::Build(spec);
  Eigen::VectorXd inner = cal.errors;
  inner.head<6>().setZero();
  inner.tail<6>().setZero();

  KinematicsWorkspace ws(model), ws_effective(model);
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 20, 999)) {
    const Transform truth = cell.TruePose(q);
    const Transform predicted = ForwardKinematics(cal.model, q, cal.errors, &ws);
    EXPECT_LT((predicted.translation() - truth.translation()).norm(), 1e-6);
    if (type == MeasurementType::kPose) {
      EXPECT_LT(RotationVector(predicted.linear() * truth.linear().transpose()).norm(), 1e-9);
      const Transform via_frames = ForwardKinematics(effective, q, inner, &ws_effective);
      EXPECT_LT((via_frames.translation() - truth.translation()).norm(), 1e-6);
      EXPECT_LT(RotationVector(via_frames.linear() * truth.linear().transpose()).norm(), 1e-9);
    } else if (type == MeasurementType::kPositionAxis) {
      const Eigen::Vector3d u = truth.linear().col(2), v = predicted.linear().col(2);
      EXPECT_LT(std::atan2(u.cross(v).norm(), u.dot(v)), 1e-9);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Presets, NoiseFreeRecoveryTest,
                         ::testing::Values(RecoveryCase{"grinder5", MeasurementType::kPose, 20},
                                           RecoveryCase{"grinder5", MeasurementType::kPosition, 17},
                                           RecoveryCase{"puma560", MeasurementType::kPose, 30},
                                           RecoveryCase{"puma560", MeasurementType::kPosition, 27},
                                           RecoveryCase{"ur5e", MeasurementType::kPose, 30},
                                           RecoveryCase{"ur5e", MeasurementType::kPosition, 27},
                                           RecoveryCase{"ur5e", MeasurementType::kPositionAxis, 29}),
                         [](const ::testing::TestParamInfo<RecoveryCase>& info) {
                           return std::get<0>(info.param) + "_" + ToString(std::get<1>(info.param));
                         });

// The reported standard deviations are honest: over many noise draws, (estimate - truth) / std behaves like
// N(0, 1). The truth is that of the reduced parameterisation (dropped parameters folded into kept ones), so it
// comes from a noise-free fit of the same poses, with the base frame fixed for both fits. The 6R ur5e and the
// paper's 5-axis grinder5, with full-pose and with position-only measurements; with isotropic noise, with the
// tracker model (noise drawn from it, residuals whitened by it: larger across the beam than along it, and
// growing with the distance), and with the tracker model and the robot's repeatability (3 shots per pose that
// share the robot's error: the fit must not count them as independent).
enum class NoiseModel { kIsotropic, kTracker, kTrackerAndRepeatability };
using NoiseCase = std::tuple<std::string, MeasurementType, NoiseModel>;

class IdentificationNoiseTest : public ::testing::TestWithParam<NoiseCase> {};

TEST_P(IdentificationNoiseTest, NormalisedParameterErrorsAreUnitGaussian) {
  const auto& [preset, type, noise_model] = GetParam();
  const RobotModel model = Preset(preset);
  const std::vector<int> parameters = FindIdentifiableParameters(model, type).identifiable;
  double sum_z2 = 0.0, sum_sigma_hat = 0.0;
  int count = 0;
  const int seeds = 50;
  for (int seed = 1; seed <= seeds; ++seed) {
    VirtualCellOptions cell_options;
    cell_options.seed = static_cast<std::uint64_t>(seed);
    cell_options.shots_per_pose = 1;
    if (noise_model != NoiseModel::kIsotropic) cell_options.noise.tracker = TrackerUncertainty{};
    if (noise_model == NoiseModel::kTrackerAndRepeatability) {
      cell_options.noise.repeatability_mm = 0.05;
      cell_options.shots_per_pose = 3;
    }
    VirtualCell cell(model, cell_options);
    const auto configurations = test::RandomConfigurations(model, 20, 1000 + seed);
    std::vector<Measurement> exact;
    for (const Eigen::VectorXd& q : configurations) exact.push_back({q, cell.TruePose(q)});
    const std::vector<Measurement> noisy = cell.MeasureAll(configurations);

    IdentificationOptions o;
    o.measurement_type = type;
    o.parameters = parameters;
    o.noise = cell_options.noise;
    const Calibration registered = Identify(model, exact, o);
    ASSERT_EQ(registered.summary.termination, Termination::kConvergence) << registered.summary.FullReport();
    o.register_base = false;
    const Calibration truth = Identify(registered.model, exact, o);
    const Calibration estimate = Identify(registered.model, noisy, o);
    ASSERT_EQ(truth.summary.termination, Termination::kConvergence) << truth.summary.FullReport();
    ASSERT_EQ(estimate.summary.termination, Termination::kConvergence) << estimate.summary.FullReport();
    ASSERT_EQ(estimate.parameters.size(), parameters.size());
    for (size_t k = 0; k < parameters.size(); ++k) {
      ASSERT_GT(estimate.parameters[k].std, 0.0);
      const double z = (estimate.parameters[k].value - truth.parameters[k].value) / estimate.parameters[k].std;
      sum_z2 += z * z;
      ++count;
    }
    sum_sigma_hat += estimate.summary.sigma_hat;
  }
  // 850 to 1500 values; the mean square of N(0, 1) has a standard error of at most 0.05, so 0.5..2 fails only
  // if the reported std is wrong.
  const double mean_z2 = sum_z2 / count;
  RecordProperty("mean_z2", std::to_string(mean_z2));
  RecordProperty("mean_sigma_hat", std::to_string(sum_sigma_hat / seeds));
  EXPECT_GT(mean_z2, 0.5);
  EXPECT_LT(mean_z2, 2.0);
  // The weights equal the simulated noise, so the unit-weight sigma is about 1.
  EXPECT_NEAR(sum_sigma_hat / seeds, 1.0, 0.15);
}

INSTANTIATE_TEST_SUITE_P(Presets, IdentificationNoiseTest,
                         ::testing::Values(NoiseCase{"ur5e", MeasurementType::kPose, NoiseModel::kIsotropic},
                                           NoiseCase{"grinder5", MeasurementType::kPose, NoiseModel::kIsotropic},
                                           NoiseCase{"grinder5", MeasurementType::kPosition, NoiseModel::kIsotropic},
                                           NoiseCase{"ur5e", MeasurementType::kPose, NoiseModel::kTracker},
                                           NoiseCase{"ur5e", MeasurementType::kPosition, NoiseModel::kTracker},
                                           NoiseCase{"grinder5", MeasurementType::kPosition, NoiseModel::kTracker},
                                           NoiseCase{"ur5e", MeasurementType::kPosition,
                                                     NoiseModel::kTrackerAndRepeatability},
                                           NoiseCase{"ur5e", MeasurementType::kPose,
                                                     NoiseModel::kTrackerAndRepeatability}),
                         [](const ::testing::TestParamInfo<NoiseCase>& info) {
                           const NoiseModel m = std::get<2>(info.param);
                           return std::get<0>(info.param) + "_" + ToString(std::get<1>(info.param)) +
                                  (m == NoiseModel::kTracker                   ? "_tracker_model"
                                   : m == NoiseModel::kTrackerAndRepeatability ? "_tracker_and_repeatability"
                                                                               : "");
                         });

TEST(IdentificationTest, RepeatedShotsAreMoreRowsOfOnePose) {
  const RobotModel model = Preset("grinder5");
  VirtualCellOptions co;
  co.shots_per_pose = 4;
  VirtualCell cell(model, co);
  const Calibration cal = Identify(model, cell.MeasureAll(test::RandomConfigurations(model, 10, 2)));
  const IdentificationSummary& s = cal.summary;
  ASSERT_NE(s.termination, Termination::kFailure) << s.FullReport();
  EXPECT_EQ(s.num_measurements, 40);
  EXPECT_EQ(s.num_poses, 10);
  EXPECT_EQ(s.num_residuals, 240);
  // Noise-level fit: the weighted rms is about 1 after, far above before.
  EXPECT_GT(s.before.rms_weighted, 5.0);
  EXPECT_LT(s.after.rms_weighted, 1.5);
  EXPECT_GT(s.after.rms_weighted, 0.5);
  EXPECT_EQ(cal.covariance.rows(), s.num_parameters);
  EXPECT_TRUE(cal.covariance.isApprox(cal.covariance.transpose()));
}

// Position-only measurements (a tracker with a plain reflector) with the paper's 10 repeated shots per pose,
// for the 5-axis grinder5 and the 6R ur5e: the fit converges at the noise level, every reported number is
// finite, and the calibrated model predicts the true tool point to a few noise sigmas.
TEST(IdentificationTest, PositionOnlyWithRepeatedShotsGrinder5AndUr5e) {
  for (const std::string preset : {"grinder5", "ur5e"}) {
    SCOPED_TRACE(preset);
    const RobotModel model = Preset(preset);
    VirtualCellOptions co;
    co.seed = 12;
    co.shots_per_pose = 10;
    VirtualCell cell(model, co);
    IdentificationOptions o;
    o.measurement_type = MeasurementType::kPosition;
    const Calibration cal = Identify(model, cell.MeasureAll(test::RandomConfigurations(model, 25, 13)), o);
    const IdentificationSummary& s = cal.summary;
    ASSERT_EQ(s.termination, Termination::kConvergence) << s.FullReport();
    EXPECT_EQ(s.num_parameters, preset == "grinder5" ? 17 : 27);
    EXPECT_EQ(s.num_poses, 25);
    EXPECT_EQ(s.num_measurements, 250);
    EXPECT_EQ(s.num_residuals, 750);
    EXPECT_TRUE(FitIsFinite(cal));
    // 723 or 733 degrees of freedom: sigma_hat of correctly weighted noise is 1 within a few percent.
    EXPECT_NEAR(s.sigma_hat, 1.0, 0.15);
    EXPECT_NEAR(s.after.rms_weighted, 1.0, 0.15);
    EXPECT_EQ(s.after.rms_orientation_rad, 0.0);
    for (const IdentifiedParameter& p : cal.parameters) EXPECT_GT(p.std, 0.0) << p.name;
    KinematicsWorkspace ws(model);
    for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 10, 14)) {
      const Eigen::Vector3d predicted = ForwardKinematics(cal.model, q, cal.errors, &ws).translation();
      // 250 shots of 0.015 mm average to a few um; the hidden errors are tenths of a mm.
      EXPECT_LT((predicted - cell.TruePose(q).translation()).norm(), 0.02);
    }
  }
}

TEST(IdentificationTest, SameSeedGivesTheSameResult) {
  const RobotModel model = Preset("puma560");
  const auto run = [&]() {
    VirtualCellOptions co;
    co.seed = 9;
    co.shots_per_pose = 2;
    VirtualCell cell(model, co);
    return Identify(model, cell.MeasureAll(test::RandomConfigurations(model, 15, 4)));
  };
  const Calibration a = run(), b = run();
  EXPECT_EQ(a.errors, b.errors);
  EXPECT_EQ(a.covariance, b.covariance);
  EXPECT_EQ(a.model.T_world_base().matrix(), b.model.T_world_base().matrix());
  EXPECT_EQ(a.summary.iterations, b.summary.iterations);
  EXPECT_EQ(a.summary.final_cost, b.summary.final_cost);
}

// Two shots at each of 15 puma560 poses: a fit that takes several iterations, for the progress tests.
std::vector<Measurement> PumaShotsForProgress(const RobotModel& model) {
  VirtualCellOptions co;
  co.seed = 9;
  co.shots_per_pose = 2;
  VirtualCell cell(model, co);
  return cell.MeasureAll(test::RandomConfigurations(model, 15, 4));
}

TEST(IdentificationTest, ProgressReturningFalseCancelsWithTheBestParametersSoFar) {
  const RobotModel model = Preset("puma560");
  const std::vector<Measurement> shots = PumaShotsForProgress(model);
  // One fit (the model error's refits and the robust rounds start from the last solution and take fewer
  // iterations): the one a cancel at the first iteration cuts short.
  IdentificationOptions once;
  once.estimate_model_error = false;
  once.reject_outliers = false;
  const Calibration full = Identify(model, shots, once);
  ASSERT_GT(full.summary.iterations, 1) << "the test needs a fit of more than one iteration";

  IdentificationOptions o;
  std::vector<double> fractions;
  o.progress = [&](double fraction) {
    fractions.push_back(fraction);
    return false;
  };
  const Calibration cal = Identify(model, shots, o);
  EXPECT_EQ(fractions, std::vector<double>{1.0 / o.max_iterations});
  EXPECT_EQ(cal.summary.termination, Termination::kNoConvergence);
  EXPECT_EQ(cal.summary.message, "cancelled");
  EXPECT_EQ(cal.summary.iterations, 1);
  EXPECT_TRUE(FitIsFinite(cal)) << cal.FullReport();
  EXPECT_TRUE(cal.errors.allFinite());
  ASSERT_EQ(cal.covariance.rows(), cal.summary.num_parameters);
  EXPECT_TRUE(cal.covariance.allFinite());
  EXPECT_LE(cal.summary.final_cost, cal.summary.initial_cost);
  EXPECT_GE(cal.summary.final_cost, full.summary.final_cost);
}

TEST(IdentificationTest, ProgressThatContinuesChangesNothing) {
  const RobotModel model = Preset("puma560");
  const std::vector<Measurement> shots = PumaShotsForProgress(model);
  const Calibration plain = Identify(model, shots);
  IdentificationOptions o;
  std::vector<double> fractions;
  o.progress = [&](double fraction) {
    fractions.push_back(fraction);
    return true;
  };
  const Calibration watched = Identify(model, shots, o);
  EXPECT_EQ(watched.summary.termination, plain.summary.termination);
  EXPECT_EQ(watched.summary.message, plain.summary.message);
  EXPECT_EQ(watched.summary.iterations, plain.summary.iterations);
  EXPECT_EQ(watched.errors, plain.errors);
  EXPECT_EQ(watched.covariance, plain.covariance);
  // Once per iteration that did not converge in its own step (the last one may have), of every fit Identify
  // makes (the model error's cycles, the robust rounds): never going back, and up to the first fit's
  // iterations over max_iterations at least.
  ASSERT_GE(static_cast<int>(fractions.size()), plain.summary.iterations - 1);
  for (size_t i = 0; i < fractions.size(); ++i) {
    EXPECT_GT(fractions[i], 0.0);
    EXPECT_LE(fractions[i], 1.0);
    if (i > 0) {
      EXPECT_GE(fractions[i], fractions[i - 1]);
    }
  }
  EXPECT_GE(fractions.back(), static_cast<double>(plain.summary.iterations - 1) / o.max_iterations);
}

TEST(IdentificationTest, ReportsCarryTheParameterTableAndTheDroppedParameters) {
  const RobotModel model = Preset("grinder5");
  VirtualCell cell(model, ExactCell(1));
  const Calibration cal = Identify(model, cell.MeasureAll(test::RandomConfigurations(model, 12, 8)));
  const std::string brief = cal.summary.BriefReport();
  const std::string full = cal.FullReport();
  EXPECT_THAT(brief, HasSubstr("CONVERGENCE"));
  EXPECT_THAT(brief, HasSubstr("20 parameters from 12 poses"));
  ASSERT_FALSE(cal.parameters.empty());
  EXPECT_THAT(full, HasSubstr(cal.parameters.front().name));
  EXPECT_THAT(full, HasSubstr(" mm\n"));
  EXPECT_THAT(full, HasSubstr(" rad\n"));
  ASSERT_FALSE(cal.summary.dropped.empty());
  EXPECT_THAT(full, HasSubstr(cal.summary.dropped.front().reason));
  EXPECT_THAT(full, HasSubstr("columns: column_norm"));
  // The estimated base and tool, as the issue asks of the report.
  EXPECT_THAT(full, HasSubstr("T_world_base : xyz"));
  EXPECT_THAT(full, HasSubstr("T_flange_tool: xyz"));
  // The summary's own report has the figures, not the estimates the calibration holds.
  EXPECT_THAT(cal.summary.FullReport(), Not(HasSubstr("T_world_base")));
}

TEST(IdentificationTest, ExplicitParametersAreTheOnlyOnesEstimated) {
  const RobotModel model = Preset("ur5e");
  VirtualCell cell(model, ExactCell(4));
  IdentificationOptions o;
  o.parameters = {model.ParameterIndex("joint2.rz"), model.ParameterIndex("joint3.rz")};
  const Calibration cal = Identify(model, cell.MeasureAll(test::RandomConfigurations(model, 10, 3)), o);
  ASSERT_NE(cal.summary.termination, Termination::kFailure) << cal.summary.FullReport();
  EXPECT_EQ(cal.parameters.size(), 2u);
  EXPECT_EQ(static_cast<int>(cal.summary.dropped.size()), model.num_error_parameters() - 2);
  EXPECT_EQ(cal.summary.dropped.front().reason, "not requested");
  for (int k = 0; k < model.num_error_parameters(); ++k) {
    if (k != o.parameters[0] && k != o.parameters[1]) {
      EXPECT_EQ(cal.errors[k], 0.0);
    }
  }
}

TEST(ResidualStatisticsTest, MatchesAKnownOffset) {
  const RobotModel model = Preset("ur5e");
  std::vector<Measurement> measurements;
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 5, 1)) {
    Transform t = ForwardKinematics(model, q);
    t.translation() += Eigen::Vector3d(3.0, 4.0, 0.0);
    t.linear() = RotZ(2e-3) * t.linear();
    measurements.push_back({q, t});
  }
  const MeasurementNoise noise{0.5, 1e-3};
  const ResidualStatistics pose =
      ComputeResidualStatistics(model, Eigen::VectorXd(), measurements, MeasurementType::kPose, noise);
  EXPECT_EQ(pose.num_measurements, 5);
  EXPECT_NEAR(pose.rms_position_mm, 5.0, 1e-9);
  EXPECT_NEAR(pose.max_position_mm, 5.0, 1e-9);
  EXPECT_NEAR(pose.rms_orientation_rad, 2e-3, 1e-12);
  // Rows: (6, 8, 0) and (0, 0, 2) weighted, over 6 rows per measurement.
  EXPECT_NEAR(pose.rms_weighted, std::sqrt((36.0 + 64.0 + 4.0) / 6.0), 1e-9);
  const ResidualStatistics position =
      ComputeResidualStatistics(model, Eigen::VectorXd(), measurements, MeasurementType::kPosition, noise);
  EXPECT_EQ(position.rms_orientation_rad, 0.0);
  EXPECT_NEAR(position.rms_weighted, std::sqrt(100.0 / 3.0), 1e-9);
  EXPECT_EQ(ComputeResidualStatistics(model, Eigen::VectorXd(), {}, MeasurementType::kPose, noise).rms_weighted, 0.0);
}

class IdentificationFailureTest : public ::testing::Test {
 protected:
  void ExpectFailure(const std::vector<Measurement>& measurements, const std::vector<std::string>& fragments,
                     IdentificationOptions o = {}) {
    const Calibration cal = Identify(model_, measurements, o);
    const IdentificationSummary& s = cal.summary;
    EXPECT_EQ(s.termination, Termination::kFailure);
    for (const std::string& f : fragments) EXPECT_THAT(s.message, HasSubstr(f));
    EXPECT_TRUE(cal.errors.isZero(0.0));
    EXPECT_EQ(cal.errors.size(), model_.num_error_parameters());
    EXPECT_EQ(cal.model.T_world_base().matrix(), model_.T_world_base().matrix());
    EXPECT_TRUE(cal.parameters.empty());
    EXPECT_TRUE(FitIsFinite(cal));
    EXPECT_THAT(cal.FullReport(), Not(HasSubstr("nan")));
  }

  std::vector<Measurement> Good(int poses) {
    VirtualCell cell(model_, ExactCell(2));
    return cell.MeasureAll(test::RandomConfigurations(model_, poses, 6));
  }

  RobotModel model_ = Preset("ur5e");
};

TEST_F(IdentificationFailureTest, TooFewPoses) {
  ExpectFailure(Good(3), {"too few distinct poses", "3 distinct", "30 parameters", "at least 6"});
  ExpectFailure({}, {"no measurements"});
  // 5 pose shots give exactly 30 rows: an interpolation with no redundancy, refused; 6 are enough.
  ExpectFailure(Good(5), {"too few distinct poses", "at least 6"});
  EXPECT_NE(Identify(model_, Good(6)).summary.termination, Termination::kFailure);
}

TEST_F(IdentificationFailureTest, AllPosesIdentical) {
  VirtualCellOptions co;
  co.shots_per_pose = 20;
  VirtualCell cell(model_, co);
  ExpectFailure(cell.Measure(test::RandomConfigurations(model_, 1, 6)[0]),
                {"too few distinct poses", "1 distinct", "20 measurements"});
}

TEST_F(IdentificationFailureTest, DegenerateConfigurations) {
  // Only the wrist's last joint moves: many distinct poses, but they cannot separate the arm's errors.
  std::vector<Eigen::VectorXd> configurations = test::RandomConfigurations(model_, 1, 6);
  for (int i = 1; i < 20; ++i) {
    configurations.push_back(configurations[0]);
    configurations.back()[5] += 0.3 * i;
  }
  VirtualCell cell(model_, ExactCell(2));
  const auto measurements = cell.MeasureAll(configurations);
  ExpectFailure(measurements, {"degenerate configurations", "rank-deficient", "undetermined"});
  IdentificationOptions fixed_base;
  fixed_base.register_base = false;
  ExpectFailure(measurements, {"degenerate configurations", "rank-deficient"}, fixed_base);
  // With the tool point on a line (one prismatic joint of a gantry moving) even registration is impossible.
  const RobotModel gantry = Preset("grinder5");
  std::vector<Measurement> line;
  Eigen::VectorXd q = test::RandomConfigurations(gantry, 1, 3)[0];
  VirtualCell gantry_cell(gantry, ExactCell(3));
  for (int i = 0; i < 10; ++i) {
    q[0] = gantry.lower_limits()[0] + 0.1 * i * (gantry.upper_limits()[0] - gantry.lower_limits()[0]);
    line.push_back({q, gantry_cell.TruePose(q)});
  }
  const Calibration cal = Identify(gantry, line);
  EXPECT_EQ(cal.summary.termination, Termination::kFailure);
  EXPECT_THAT(cal.summary.message, HasSubstr("collinear"));
}

TEST_F(IdentificationFailureTest, NonFiniteMeasurementIsNamed) {
  std::vector<Measurement> m = Good(10);
  m[7].T_world_tool.translation()[1] = NAN;
  ExpectFailure(m, {"measurements[7]", "non-finite position"});
  m = Good(10);
  m[3].joints[2] = INFINITY;
  ExpectFailure(m, {"measurements[3]", "non-finite joint"});
  m = Good(10);
  m[5].T_world_tool.linear()(0, 0) = NAN;
  ExpectFailure(m, {"measurements[5]", "non-finite orientation"});
  // Position measurements do not use the orientation, so a NaN there is not an error.
  IdentificationOptions position;
  position.measurement_type = MeasurementType::kPosition;
  EXPECT_NE(Identify(model_, m, position).summary.termination, Termination::kFailure);
}

TEST_F(IdentificationFailureTest, ProgrammerErrorsThrow) {
  std::vector<Measurement> m = Good(10);
  m[4].joints = Eigen::VectorXd::Zero(5);
  try {
    Identify(model_, m);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("measurements[4].joints"));
  }
  IdentificationOptions o;
  o.parameters = {1, 200};
  try {
    Identify(model_, Good(10), o);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("parameters[1] = 200"));
    EXPECT_THAT(e.what(), HasSubstr("has 48 error parameters"));
  }
}

TEST(IdentificationOptionsTest, InvalidOptionsAreRejectedByName) {
  const auto expect_rejected = [](const IdentificationOptions& o, const std::string& name) {
    std::string error;
    EXPECT_FALSE(o.IsValid(&error)) << name;
    EXPECT_THAT(error, HasSubstr(name));
    try {
      Identify(Preset("grinder5"), {}, o);
      ADD_FAILURE() << "no exception for " << name;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr(name));
    }
  };
  IdentificationOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error)) << error;
  o.noise.position_mm = 0.0;
  expect_rejected(o, "noise.position_mm");
  o = {};
  o.noise.orientation_rad = NAN;
  expect_rejected(o, "noise.orientation_rad");
  o = {};
  o.noise.tracker = TrackerUncertainty{};
  o.noise.tracker->transverse_um = 0.0;
  expect_rejected(o, "tracker.transverse_um");
  o.noise.tracker = TrackerUncertainty{};
  o.noise.tracker->radial_um_per_m = -0.1;
  expect_rejected(o, "tracker.radial_um_per_m");
  o.noise.tracker = TrackerUncertainty{};
  o.noise.tracker->mpe_sigmas = NAN;
  expect_rejected(o, "tracker.mpe_sigmas");
  o = {};
  o.outlier_probability = 0.0;
  expect_rejected(o, "outlier_probability");
  o.outlier_probability = 0.5;
  expect_rejected(o, "outlier_probability");
  o = {};
  o.parameters = {3, 1};
  expect_rejected(o, "parameters");
  o = {};
  o.function_tolerance = -1.0;
  expect_rejected(o, "function_tolerance");
  o = {};
  o.gradient_tolerance = INFINITY;
  expect_rejected(o, "gradient_tolerance");
  o = {};
  o.parameter_tolerance = NAN;
  expect_rejected(o, "parameter_tolerance");
  o = {};
  o.max_iterations = 0;
  expect_rejected(o, "max_iterations");
  o = {};
  o.identifiability.num_configurations = 0;
  expect_rejected(o, "identifiability.num_configurations");
}

}  // namespace
}  // namespace robocal
