// A fit's diagnostics recomputed after the fact (fit_diagnostics.h, fit_linearization.h): the linearisation at a
// finished calibration equals the fit's own covariance and condition number (plain, robust with an outlier,
// tracker model with repeatability, free reflector nests), per-measurement residuals against a known offset,
// correlations by hand.
#include "robocal/core/fit_diagnostics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "fit_linearization.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"
#include "test_util.h"

namespace robocal {
namespace {

// Fits `data`, then recomputes the linearisation from what a stored calibration keeps (the calibration, the
// measurements less the outliers, the estimated indices) and compares with the fit's own figures.
void ExpectLinearizationMatchesTheFit(const RobotModel& model, const std::vector<Measurement>& data,
                                      IdentificationOptions fit, std::size_t expected_outliers) {
  const Calibration cal = Identify(model, data, fit);
  ASSERT_NE(cal.summary.termination, Termination::kFailure) << cal.summary.FullReport();
  ASSERT_EQ(cal.summary.outliers.size(), expected_outliers) << cal.summary.FullReport();
  std::vector<char> excluded(data.size(), 0);
  for (const OutlierMeasurement& o : cal.summary.outliers) excluded[o.measurement] = 1;
  std::vector<Measurement> used;
  for (std::size_t i = 0; i < data.size(); ++i)
    if (!excluded[i]) used.push_back(data[i]);
  fit.parameters.clear();
  for (const IdentifiedParameter& p : cal.parameters) fit.parameters.push_back(p.index);

  const FitLinearization lin = LinearizeFit(cal, used, fit);
  EXPECT_EQ(lin.parameters, fit.parameters);
  EXPECT_NEAR(lin.condition_number / cal.summary.condition_number, 1.0, 1e-9);
  EXPECT_NEAR(lin.sigma_hat / cal.summary.sigma_hat, 1.0, 1e-9);
  ASSERT_EQ(lin.covariance.rows(), cal.covariance.rows());
  const double scale = cal.covariance.diagonal().cwiseAbs().maxCoeff();
  EXPECT_LT((lin.covariance - cal.covariance).cwiseAbs().maxCoeff(), 1e-8 * scale);
  for (std::size_t k = 0; k < cal.parameters.size(); ++k) {
    EXPECT_NEAR(std::sqrt(lin.covariance(k, k)) / cal.parameters[k].std, 1.0, 1e-8) << cal.parameters[k].name;
  }
  ASSERT_EQ(lin.singular_values.size(), static_cast<Eigen::Index>(fit.parameters.size()));
  for (Eigen::Index k = 1; k < lin.singular_values.size(); ++k) {
    EXPECT_LE(lin.singular_values[k], lin.singular_values[k - 1]);
  }
}

TEST(LinearizeFitTest, EqualsTheFitsCovarianceWithAPlantedOutlier) {
  const RobotModel model = Preset("grinder5");
  VirtualCellOptions o;
  o.seed = 4;
  o.shots_per_pose = 1;
  VirtualCell cell(model, o);
  std::vector<Measurement> data = cell.MeasureAll(test::RandomConfigurations(model, 30, 7));
  data[7].T_world_tool.translation() += Eigen::Vector3d(1.2, -1.6, 0.0);  // 2 mm: excluded by the robust fit
  IdentificationOptions fit;
  fit.noise = o.noise;
  ExpectLinearizationMatchesTheFit(model, data, fit, 1);
}

TEST(LinearizeFitTest, EqualsTheFitsCovarianceWithATrackerModelAndRepeatability) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 9;
  o.shots_per_pose = 3;
  o.noise.tracker = TrackerUncertainty{};
  o.noise.repeatability_mm = 0.03;
  VirtualCell cell(model, o);
  IdentificationOptions fit;
  fit.measurement_type = MeasurementType::kPosition;
  fit.noise = o.noise;
  ExpectLinearizationMatchesTheFit(model, cell.MeasureAll(test::RandomConfigurations(model, 30, 11)), fit, 0);
}

TEST(LinearizeFitTest, EqualsTheFitsCovarianceWithFreeReflectorNests) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 12;
  o.shots_per_pose = 1;
  o.reflectors = {{"smr1", {60.0, 0.0, 20.0}, false}, {"smr2", {-30.0, 52.0, 20.0}, false},
                  {"smr3", {-30.0, -52.0, 20.0}, false}};
  VirtualCell cell(model, o);
  IdentificationOptions fit;
  fit.measurement_type = MeasurementType::kPosition;
  fit.noise = o.noise;
  fit.reflectors = o.reflectors;
  ExpectLinearizationMatchesTheFit(model, cell.MeasureAll(test::RandomConfigurations(model, 20, 5)), fit, 0);
}

TEST(LinearizeFitTest, RefusesWhatCannotBeLinearized) {
  const RobotModel model = Preset("grinder5");
  VirtualCellOptions o;
  o.seed = 4;
  VirtualCell cell(model, o);
  const std::vector<Measurement> data = cell.MeasureAll(test::RandomConfigurations(model, 12, 3));
  IdentificationOptions fit;
  fit.noise = o.noise;
  const Calibration cal = Identify(model, data, fit);
  ASSERT_NE(cal.summary.termination, Termination::kFailure);
  EXPECT_THROW(LinearizeFit(cal, data, fit), std::invalid_argument) << "no parameters named";
  fit.parameters = {3, 1};
  EXPECT_THROW(LinearizeFit(cal, data, fit), std::invalid_argument) << "not ascending";
  fit.parameters = {0, model.num_error_parameters()};
  EXPECT_THROW(LinearizeFit(cal, data, fit), std::invalid_argument) << "beyond the model without reflectors";
  fit.parameters.clear();
  for (const IdentifiedParameter& p : cal.parameters) fit.parameters.push_back(p.index);
  EXPECT_THROW(LinearizeFit(cal, {data[0]}, fit), std::invalid_argument) << "too few rows";
}

TEST(MeasurementResidualsTest, EachMeasurementAgainstAKnownOffset) {
  const RobotModel model = Preset("ur5e");
  std::vector<Measurement> measurements;
  int i = 0;
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 4, 1)) {
    Transform t = ForwardKinematics(model, q);
    // Measurement i is off by (3, 4, 0) i mm and turned by 1e-3 i rad about the tracker's z.
    t.translation() += static_cast<double>(i) * Eigen::Vector3d(3.0, 4.0, 0.0);
    t.linear() = RotZ(1e-3 * i) * t.linear();
    measurements.push_back({.joints = q, .T_world_tool = t});
    ++i;
  }
  MeasurementNoise noise;
  noise.position_mm = 0.5;
  noise.orientation_rad = 1e-3;
  const std::vector<MeasurementResidualNorms> pose =
      ComputeMeasurementResiduals(model, Eigen::VectorXd(), measurements, MeasurementType::kPose, noise);
  ASSERT_EQ(pose.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_NEAR(pose[k].position_mm, 5.0 * k, 1e-9);
    EXPECT_NEAR(pose[k].orientation_rad, 1e-3 * k, 1e-12);
    // Rows (6k, 8k, 0) and (0, 0, k) in sigmas.
    EXPECT_NEAR(pose[k].weighted, std::sqrt(101.0) * k, 1e-6);
  }
  // The statistics are the summary of exactly these values.
  const ResidualStatistics stats =
      ComputeResidualStatistics(model, Eigen::VectorXd(), measurements, MeasurementType::kPose, noise);
  EXPECT_NEAR(stats.rms_position_mm, std::sqrt((0.0 + 25.0 + 100.0 + 225.0) / 4.0), 1e-9);
  EXPECT_NEAR(stats.max_position_mm, 15.0, 1e-9);
  const std::vector<MeasurementResidualNorms> position =
      ComputeMeasurementResiduals(model, Eigen::VectorXd(), measurements, MeasurementType::kPosition, noise);
  EXPECT_EQ(position[3].orientation_rad, 0.0);
  EXPECT_NEAR(position[3].weighted, 30.0, 1e-9);
}

TEST(CorrelationTest, HandComputedCoefficients) {
  Eigen::Matrix3d c;
  c << 4.0, 3.0, 0.0,  //
      3.0, 9.0, -6.0,  //
      0.0, -6.0, 16.0;
  const Eigen::MatrixXd rho = CorrelationOf(c);
  EXPECT_DOUBLE_EQ(rho(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(rho(0, 1), 3.0 / (2.0 * 3.0));
  EXPECT_DOUBLE_EQ(rho(1, 2), -6.0 / (3.0 * 4.0));
  EXPECT_DOUBLE_EQ(rho(2, 1), rho(1, 2));
  EXPECT_DOUBLE_EQ(rho(0, 2), 0.0);
  Eigen::Matrix2d zero_variance;
  zero_variance << 0.0, 0.0, 0.0, 1.0;
  EXPECT_EQ(CorrelationOf(zero_variance)(0, 1), 0.0);
}

}  // namespace
}  // namespace robocal
