// The model error: robot error the geometric model cannot express (here the virtual cell's joint harmonics),
// estimated beside the tracker's noise. Parameter std stay honest with it, the estimate matches the held-out
// scatter, clean shots are flagged at the rate asked for and gross errors still are.
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/identification.h"
#include "test_util.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"

namespace robocal {
namespace {

// 2e-4 rad per harmonic coefficient: about 0.02 deg per joint, a few tenths of a mm at the tool of a ur5e,
// ten times the tracker's noise.
constexpr double kHarmonicSigmaRad = 2e-4;

struct HonestyFigures {
  double mean_z2 = 0.0;
  // The same with the std the tracker's covariance alone gives (the fit's std over its sigma_hat).
  double mean_z2_tracker = 0.0;
  int count = 0;
};

// (estimate - truth) / std over the parameters and seeds. The truth is the geometric robot's reduced
// parameters (a fit to its exact, harmonic-free poses with the base fixed, as in identification_test.cc); the
// data carry the joint harmonics, which the geometric fit partly absorbs: a bias that differs from seed to seed
// and that the std must cover.
HonestyFigures NormalisedErrors(const std::string& preset, MeasurementType type, bool estimate) {
  const RobotModel model = Preset(preset);
  const std::vector<int> parameters = FindIdentifiableParameters(model, type).identifiable;
  HonestyFigures out;
  double sum = 0.0, sum_tracker = 0.0;
  for (int seed = 1; seed <= 30; ++seed) {
    VirtualCellOptions cell_options;
    cell_options.seed = static_cast<std::uint64_t>(seed);
    cell_options.shots_per_pose = 1;
    cell_options.joint_harmonic_sigma_rad = kHarmonicSigmaRad;
    VirtualCell cell(model, cell_options);
    const auto configurations = test::RandomConfigurations(model, 40, 2000 + seed);
    std::vector<Measurement> geometric;
    KinematicsWorkspace ws(cell.true_model());
    for (const Eigen::VectorXd& q : configurations) {
      geometric.push_back({q, ForwardKinematics(cell.true_model(), q, cell.true_errors(), &ws), -1, {}});
    }
    IdentificationOptions o;
    o.measurement_type = type;
    o.parameters = parameters;
    o.noise = cell_options.noise;
    o.estimate_model_error = estimate;
    o.reject_outliers = false;
    const Calibration registered = Identify(model, geometric, o);
    EXPECT_EQ(registered.summary.termination, Termination::kConvergence) << registered.summary.FullReport();
    o.register_base = false;
    const Calibration truth = Identify(registered.model, geometric, o);
    const Calibration fitted = Identify(registered.model, cell.MeasureAll(configurations), o);
    EXPECT_NE(fitted.summary.termination, Termination::kFailure) << fitted.summary.FullReport();
    if (fitted.parameters.size() != parameters.size()) continue;
    for (size_t k = 0; k < parameters.size(); ++k) {
      const double z = (fitted.parameters[k].value - truth.parameters[k].value) / fitted.parameters[k].std;
      sum += z * z;
      sum_tracker += z * z * fitted.summary.sigma_hat * fitted.summary.sigma_hat;
      ++out.count;
    }
  }
  out.mean_z2 = sum / std::max(out.count, 1);
  out.mean_z2_tracker = sum_tracker / std::max(out.count, 1);
  return out;
}

TEST(ModelErrorTest, ParameterStdStayHonestWithUnmodelledJointErrors) {
  for (const auto& [preset, type] : {std::pair{std::string("ur5e"), MeasurementType::kPose},
                                     std::pair{std::string("grinder5"), MeasurementType::kPosition}}) {
    SCOPED_TRACE(preset + " " + ToString(type));
    const HonestyFigures with = NormalisedErrors(preset, type, true);
    const HonestyFigures without = NormalisedErrors(preset, type, false);
    RecordProperty(preset + "_mean_z2_estimated", std::to_string(with.mean_z2));
    RecordProperty(preset + "_mean_z2_not_estimated", std::to_string(without.mean_z2));
    RecordProperty(preset + "_mean_z2_tracker_only", std::to_string(without.mean_z2_tracker));
    EXPECT_GT(with.count, 500);
    EXPECT_GT(with.mean_z2, 0.5);
    EXPECT_LT(with.mean_z2, 2.0);
    // The tracker's covariance alone, taken as the whole error, claims std far too small: the data do carry a
    // model error, and the test can fail.
    EXPECT_GT(without.mean_z2_tracker, 4.0);
  }
}

// The estimate against what validation sees: the RMS 3-D distance between the calibrated prediction and
// held-out shots (tracker noise, the model error and the fit's own uncertainty) within 20 %; a fit of clean,
// exactly geometric data calls its model error negligible against the tracker; both CONVERGENCE.
TEST(ModelErrorTest, TheEstimateMatchesTheHeldOutScatterAndIsSaid) {
  const RobotModel model = Preset("ur5e");
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    SCOPED_TRACE(seed);
    VirtualCellOptions cell_options;
    cell_options.seed = seed;
    cell_options.shots_per_pose = 1;
    cell_options.noise.tracker = TrackerUncertainty{};
    cell_options.joint_harmonic_sigma_rad = kHarmonicSigmaRad;
    VirtualCell cell(model, cell_options);
    IdentificationOptions o;
    o.noise = cell_options.noise;
    const Calibration cal = Identify(model, cell.MeasureAll(test::RandomConfigurations(model, 100, 300 + seed)), o);
    const IdentificationSummary& s = cal.summary;
    ASSERT_EQ(s.termination, Termination::kConvergence) << s.FullReport();
    EXPECT_TRUE(s.model_error.estimated);
    const std::vector<Measurement> held_out = cell.MeasureAll(test::RandomConfigurations(model, 400, 900 + seed));
    KinematicsWorkspace ws(cal.model);
    double sum = 0.0;
    for (const Measurement& m : held_out) {
      sum += (ForwardKinematics(cal.model, m.joints, cal.errors, &ws).translation() - m.T_world_tool.translation())
                 .squaredNorm();
    }
    const double held_out_rms = std::sqrt(sum / static_cast<double>(held_out.size()));
    RecordProperty("held_out_rms_mm_" + std::to_string(seed), std::to_string(held_out_rms));
    RecordProperty("model_error_mm_" + std::to_string(seed), std::to_string(s.model_error.model_error_mm));
    EXPECT_GT(held_out_rms, 5.0 * s.model_error.tracker_rms_mm) << "the model error dominates";
    EXPECT_NEAR(s.model_error.model_error_mm, held_out_rms, 0.2 * held_out_rms);
    EXPECT_GT(s.model_error.model_error_rad, 0.0);
    EXPECT_THAT(s.message, ::testing::HasSubstr("robot error the geometric model does not explain: "));
    EXPECT_LE(s.outliers.size(), 1u) << s.FullReport();

    cell_options.joint_harmonic_sigma_rad = 0.0;
    VirtualCell geometric(model, cell_options);
    const Calibration clean = Identify(model, geometric.MeasureAll(test::RandomConfigurations(model, 100, 300 + seed)), o);
    ASSERT_EQ(clean.summary.termination, Termination::kConvergence) << clean.summary.FullReport();
    EXPECT_LT(clean.summary.model_error.model_error_mm, clean.summary.model_error.tracker_rms_mm);
  }
}

// Without the estimate the same data are DEGRADED (the residuals scatter far beyond the tracker's noise); with
// it they are a calibration.
TEST(ModelErrorTest, DegradedOnlyWithoutTheEstimate) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions cell_options;
  cell_options.seed = 11;
  cell_options.shots_per_pose = 1;
  cell_options.noise.tracker = TrackerUncertainty{};
  cell_options.joint_harmonic_sigma_rad = kHarmonicSigmaRad;
  VirtualCell cell(model, cell_options);
  const std::vector<Measurement> data = cell.MeasureAll(test::RandomConfigurations(model, 60, 5));
  IdentificationOptions o;
  o.noise = cell_options.noise;
  const Calibration estimated = Identify(model, data, o);
  EXPECT_EQ(estimated.summary.termination, Termination::kConvergence) << estimated.summary.FullReport();
  o.estimate_model_error = false;
  const Calibration assumed = Identify(model, data, o);
  EXPECT_EQ(assumed.summary.termination, Termination::kDegraded) << assumed.summary.FullReport();
  EXPECT_THAT(assumed.summary.message, ::testing::HasSubstr("times what the noise model says"));
  EXPECT_FALSE(assumed.summary.model_error.estimated);
  EXPECT_EQ(assumed.summary.model_error.model_error_mm, 0.0);
}

// Clean campaigns of the realistic cell (tracker model, repeatability, 3 shots per pose; pose and position
// measurements), 20 seeds each: clean shots are flagged at no more than twice the rate asked for. With 2 % gross
// errors of 1-5 mm added, every one of them is flagged.
TEST(ModelErrorTest, CleanShotsAreFlaggedAtTheAskedRateAndGrossErrorsAlways) {
  const RobotModel model = Preset("ur5e");
  for (const MeasurementType type : {MeasurementType::kPose, MeasurementType::kPosition}) {
    SCOPED_TRACE(ToString(type));
    int clean_shots = 0, false_alarms = 0, injected = 0, found = 0;
    const double probability = 0.01;  // large enough to count: 20 x 180 shots give 36 expected
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
      VirtualCellOptions cell_options;
      cell_options.seed = seed;
      cell_options.shots_per_pose = 3;
      cell_options = Realistic(cell_options);
      cell_options.outlier_rate = 0.0;
      const auto configurations = test::RandomConfigurations(model, 60, 40 + seed);
      IdentificationOptions o;
      o.measurement_type = type;
      o.noise = cell_options.noise;
      o.outlier_probability = probability;
      VirtualCell clean_cell(model, cell_options);
      const std::vector<Measurement> clean = clean_cell.MeasureAll(configurations);
      const Calibration fit = Identify(model, clean, o);
      ASSERT_EQ(fit.summary.termination, Termination::kConvergence) << fit.summary.FullReport();
      clean_shots += static_cast<int>(clean.size());
      false_alarms += static_cast<int>(fit.summary.outliers.size());

      cell_options.outlier_rate = kRealisticOutlierRate;
      VirtualCell dirty_cell(model, cell_options);
      const std::vector<Measurement> dirty = dirty_cell.MeasureAll(configurations);
      o.outlier_probability = 1e-3;
      const Calibration robust = Identify(model, dirty, o);
      ASSERT_NE(robust.summary.termination, Termination::kFailure) << robust.summary.FullReport();
      std::set<int> flagged;
      for (const OutlierMeasurement& m : robust.summary.outliers) flagged.insert(m.measurement);
      for (int i : dirty_cell.outlier_shots()) {
        ++injected;
        if (flagged.count(i)) ++found;
      }
    }
    const double rate = static_cast<double>(false_alarms) / clean_shots;
    RecordProperty(std::string("false_alarm_rate_") + ToString(type), std::to_string(rate));
    EXPECT_LE(rate, 2.0 * probability) << false_alarms << " of " << clean_shots;
    EXPECT_GT(injected, 20);
    EXPECT_EQ(found, injected);
  }
}

}  // namespace
}  // namespace robocal
