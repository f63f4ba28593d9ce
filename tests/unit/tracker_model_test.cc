// The tracker's uncertainty model against hand-computed covariances, the chi-square tail the robust fit uses
// against tabulated values, and the virtual cell's draws from the model (anisotropic noise, outliers,
// repeatability) against their configured sizes.
#include <cmath>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/error_model.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"

namespace robocal {
namespace {

using ::testing::HasSubstr;

TEST(TrackerUncertaintyTest, SigmasAreTheDatasheetFiguresOverTheirSigmas) {
  const TrackerUncertainty t;  // +-(10 um + 0.3 um/m) radial, +-(15 um + 6 um/m) transverse, MPE = 2 sigma
  // 3 m: (10 + 0.9) / 2 um and (15 + 18) / 2 um.
  EXPECT_DOUBLE_EQ(t.RadialSigmaMm(3000.0), 0.00545);
  EXPECT_DOUBLE_EQ(t.TransverseSigmaMm(3000.0), 0.0165);
  EXPECT_DOUBLE_EQ(t.RadialSigmaMm(0.0), 0.005);
  EXPECT_NEAR(t.OrientationSigmaRad(), 0.005 * M_PI / 180.0, 1e-18);
  TrackerUncertainty one_sigma = t;
  one_sigma.mpe_sigmas = 1.0;
  EXPECT_DOUBLE_EQ(one_sigma.TransverseSigmaMm(3000.0), 0.033);
}

TEST(TrackerUncertaintyTest, CovarianceIsRadialAlongTheBeamAndTransverseAcrossIt) {
  const TrackerUncertainty t;
  // Along x at 3 m: diagonal.
  const Eigen::Matrix3d c1 = t.PositionCovariance({3000.0, 0.0, 0.0});
  EXPECT_NEAR(c1(0, 0), 0.00545 * 0.00545, 1e-15);
  EXPECT_NEAR(c1(1, 1), 0.0165 * 0.0165, 1e-15);
  EXPECT_NEAR(c1(2, 2), 0.0165 * 0.0165, 1e-15);
  EXPECT_NEAR(c1(0, 1), 0.0, 1e-18);
  // (0, 3, 4) m, 5 m away: s_r = 11.5 / 2 um, s_t = 45 / 2 um, u = (0, 0.6, 0.8).
  const double r2 = 0.00575 * 0.00575, t2 = 0.0225 * 0.0225;
  const Eigen::Matrix3d c2 = t.PositionCovariance({0.0, 3000.0, 4000.0});
  EXPECT_NEAR(c2(0, 0), t2, 1e-15);
  EXPECT_NEAR(c2(1, 1), 0.36 * r2 + 0.64 * t2, 1e-15);  // 3.3590250e-4
  EXPECT_NEAR(c2(2, 2), 0.64 * r2 + 0.36 * t2, 1e-15);
  EXPECT_NEAR(c2(1, 2), 0.48 * (r2 - t2), 1e-15);       // -2.271300e-4
  EXPECT_NEAR(c2(1, 2), -2.2713e-4, 1e-9);
  EXPECT_NEAR(c2(0, 1), 0.0, 1e-18);
  EXPECT_TRUE(c2.isApprox(c2.transpose()));
  // The square root draws with this covariance and the whitening undoes it.
  const Eigen::Vector3d p(-1200.0, 2500.0, 900.0);
  const Eigen::Matrix3d c = t.PositionCovariance(p), l = t.PositionSqrt(p), w = t.PositionWhitening(p);
  EXPECT_TRUE((l * l.transpose()).isApprox(c, 1e-12));
  EXPECT_TRUE((w.transpose() * w * c).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  // At the tracker's own origin there is no beam direction: transverse everywhere.
  EXPECT_TRUE(t.PositionCovariance(Eigen::Vector3d::Zero()).isApprox(0.0075 * 0.0075 * Eigen::Matrix3d::Identity()));
}

TEST(TrackerUncertaintyTest, InvalidFiguresAreNamed) {
  const struct {
    double TrackerUncertainty::*field;
    double value;
    const char* name;
  } cases[] = {{&TrackerUncertainty::radial_um, 0.0, "tracker.radial_um"},
               {&TrackerUncertainty::radial_um_per_m, -1.0, "tracker.radial_um_per_m"},
               {&TrackerUncertainty::radial_um, 1e-150, "tracker.radial_um"},
               {&TrackerUncertainty::transverse_um, 1e-4, "tracker.transverse_um"},
               {&TrackerUncertainty::mpe_sigmas, 20.0, "tracker.mpe_sigmas"},
               {&TrackerUncertainty::orientation_deg, 91.0, "tracker.orientation_deg"},
               {&TrackerUncertainty::transverse_um, NAN, "tracker.transverse_um"},
               {&TrackerUncertainty::transverse_um_per_m, INFINITY, "tracker.transverse_um_per_m"},
               {&TrackerUncertainty::orientation_deg, -0.01, "tracker.orientation_deg"},
               {&TrackerUncertainty::mpe_sigmas, 0.0, "tracker.mpe_sigmas"}};
  for (const auto& c : cases) {
    TrackerUncertainty t;
    t.*c.field = c.value;
    std::string error;
    EXPECT_FALSE(t.IsValid(&error)) << c.name;
    EXPECT_THAT(error, HasSubstr(c.name));
  }
  TrackerUncertainty zero_slopes;
  zero_slopes.radial_um_per_m = 0.0;
  zero_slopes.transverse_um_per_m = 0.0;
  std::string error;
  EXPECT_TRUE(zero_slopes.IsValid(&error)) << error;
}

TEST(MeasurementNoiseTest, WhiteningIsTheTrackerModelOrTheConstantWeights) {
  const Eigen::Vector3d p(2000.0, -1000.0, 500.0);
  MeasurementNoise isotropic{0.02, 2e-4, std::nullopt};
  Eigen::MatrixXd w(6, 6);
  isotropic.Whitening(MeasurementType::kPose, p, w);
  EXPECT_TRUE(w.isApprox(Eigen::MatrixXd(isotropic.RowWeights(MeasurementType::kPose).asDiagonal())));
  MeasurementNoise tracker = isotropic;
  tracker.tracker = TrackerUncertainty{};
  Eigen::MatrixXd w5(5, 5);
  tracker.Whitening(MeasurementType::kPositionAxis, p, w5);
  EXPECT_TRUE(w5.block(0, 0, 3, 3).isApprox(tracker.tracker->PositionWhitening(p)));
  EXPECT_DOUBLE_EQ(w5(3, 3), 1.0 / tracker.tracker->OrientationSigmaRad());
  EXPECT_DOUBLE_EQ(w5(4, 4), 1.0 / tracker.tracker->OrientationSigmaRad());
  EXPECT_EQ(w5.block(0, 3, 3, 2).norm(), 0.0);
  // Without a place, the isotropic equivalent at 3 m: sqrt((5.45^2 + 2 * 16.5^2) / 3) um.
  const Eigen::VectorXd rows = tracker.RowWeights(MeasurementType::kPosition);
  EXPECT_NEAR(1.0 / rows[0], std::sqrt((0.00545 * 0.00545 + 2 * 0.0165 * 0.0165) / 3.0), 1e-15);
}

TEST(ChiSquareTest, SurvivalAndQuantilesMatchTables) {
  // exp(-x/2) for 2 dof; erfc(sqrt(x/2)) for 1 dof.
  EXPECT_NEAR(ChiSquareSurvival(2, 3.0), std::exp(-1.5), 1e-15);
  EXPECT_NEAR(ChiSquareSurvival(1, 3.841458820694124), 0.05, 1e-12);
  // Tabulated upper 0.1 % points and medians (Abramowitz & Stegun, table 26.8).
  EXPECT_NEAR(ChiSquareQuantile(3, 1e-3), 16.266, 1e-3);
  EXPECT_NEAR(ChiSquareQuantile(5, 1e-3), 20.515, 1e-3);
  EXPECT_NEAR(ChiSquareQuantile(6, 1e-3), 22.458, 1e-3);
  EXPECT_NEAR(ChiSquareQuantile(3, 0.5), 2.366, 1e-3);
  EXPECT_NEAR(ChiSquareQuantile(6, 0.5), 5.348, 1e-3);
  EXPECT_NEAR(ChiSquareSurvival(3, ChiSquareQuantile(3, 0.01)), 0.01, 1e-12);
}

Eigen::VectorXd MidConfiguration(const RobotModel& model) {
  Rng rng(3);
  return RandomConfiguration(model, &rng);
}

TEST(VirtualCellTrackerTest, ShotNoiseFollowsTheBeam) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 5;
  o.noise.tracker = TrackerUncertainty{};
  VirtualCell cell(model, o);
  const Eigen::VectorXd q = MidConfiguration(model);
  const Transform truth = cell.TruePose(q);
  const Eigen::Vector3d p = truth.translation();
  const Eigen::Vector3d u = p.normalized();
  const int shots = 4000;
  double sum_r2 = 0.0, sum_t2 = 0.0, sum_w2 = 0.0;
  for (const Measurement& m : cell.Measure(q, shots)) {
    const Eigen::Vector3d dp = m.T_world_tool.translation() - p;
    const double along = u.dot(dp);
    sum_r2 += along * along;
    sum_t2 += (dp - along * u).squaredNorm();
    sum_w2 += RotationVector(m.T_world_tool.linear() * truth.linear().transpose()).squaredNorm();
  }
  const TrackerUncertainty& t = *o.noise.tracker;
  // Standard error of a sample sigma from 4000 draws: 1.1 % (radial), 0.8 % (transverse, two axes).
  EXPECT_NEAR(std::sqrt(sum_r2 / shots), t.RadialSigmaMm(p.norm()), 0.05 * t.RadialSigmaMm(p.norm()));
  EXPECT_NEAR(std::sqrt(sum_t2 / (2 * shots)), t.TransverseSigmaMm(p.norm()), 0.05 * t.TransverseSigmaMm(p.norm()));
  EXPECT_NEAR(std::sqrt(sum_w2 / (3 * shots)), t.OrientationSigmaRad(), 0.05 * t.OrientationSigmaRad());
}

TEST(VirtualCellTrackerTest, OutliersHaveTheConfiguredRateAndSizeAndAreRecorded) {
  const RobotModel model = Preset("grinder5");
  VirtualCellOptions o;
  o.seed = 8;
  o.noise = {0.0, 0.0, std::nullopt};
  o.outlier_rate = 0.05;
  o.outlier_min_mm = 1.0;
  o.outlier_max_mm = 5.0;
  VirtualCell cell(model, o);
  const Eigen::VectorXd q = MidConfiguration(model);
  const Transform truth = cell.TruePose(q);
  const int shots = 4000;
  const std::vector<Measurement> measured = cell.Measure(q, shots);
  std::vector<int> moved;
  for (int i = 0; i < shots; ++i) {
    const double d = (measured[i].T_world_tool.translation() - truth.translation()).norm();
    if (d > 0.0) {
      moved.push_back(i);
      EXPECT_GE(d, 1.0 - 1e-9);
      EXPECT_LE(d, 5.0 + 1e-9);
    }
  }
  EXPECT_EQ(moved, cell.outlier_shots());
  // Binomial(4000, 0.05): 200 +- 14.
  EXPECT_NEAR(static_cast<double>(moved.size()), 200.0, 50.0);
}

TEST(VirtualCellTrackerTest, RepeatabilityMovesEveryShotOfAVisitTogether) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 9;
  o.noise = {0.0, 0.0, std::nullopt};
  o.noise.repeatability_mm = 0.03;
  VirtualCell cell(model, o);
  const Eigen::VectorXd q = MidConfiguration(model);
  const Transform truth = cell.TruePose(q);
  const int visits = 3000;
  std::vector<double> distances;
  for (int v = 0; v < visits; ++v) {
    const std::vector<Measurement> shots = cell.Measure(q, 3);
    const Eigen::Vector3d first = shots[0].T_world_tool.translation();
    for (const Measurement& m : shots) EXPECT_EQ(m.T_world_tool.translation(), first);
    distances.push_back((first - truth.translation()).norm());
  }
  // ISO 9283: RP = mean + 3 std of the distances (here to the true mean position).
  double mean = 0.0, square = 0.0;
  for (double d : distances) mean += d / visits;
  for (double d : distances) square += (d - mean) * (d - mean) / (visits - 1);
  EXPECT_NEAR(mean + 3.0 * std::sqrt(square), 0.03, 0.0015);
}

TEST(VirtualCellTrackerTest, InvalidSettingsAreNamed) {
  const RobotModel model = Preset("grinder5");
  const auto rejected = [&](const VirtualCellOptions& o, const std::string& name) {
    std::string error;
    EXPECT_FALSE(o.IsValid(&error)) << name;
    EXPECT_THAT(error, HasSubstr(name));
  };
  VirtualCellOptions o;
  o.outlier_rate = 1.5;
  rejected(o, "outlier_rate");
  o = {};
  o.outlier_max_mm = 0.5;
  rejected(o, "outlier_max_mm");
  o = {};
  o.noise.repeatability_mm = -0.01;
  rejected(o, "noise.repeatability_mm");
  o = {};
  o.noise.tracker = TrackerUncertainty{};
  o.noise.tracker->radial_um = -1.0;
  rejected(o, "noise.tracker.radial_um");
}

}  // namespace
}  // namespace robocal
