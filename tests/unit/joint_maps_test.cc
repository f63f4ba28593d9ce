// Joint error maps (JointMap, JointMapTerms): the cubic B-spline basis against hand-computed values, the map
// columns and a held map's joint derivative against finite differences, a simulated robot's fine joint error
// recovered exactly without noise and within its reported std with noise, the penalty's effect, and the terms a
// model refuses by field.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "robocal/core/identification.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/model_choice.h"
#include "robocal/core/presets.h"
#include "robocal/core/units.h"
#include "robocal/core/virtual_cell.h"
#include "test_util.h"

namespace robocal {
namespace {

TEST(MapBasisTest, UniformCubicBasisAtKnotsAndMidpointsAsComputedByHand) {
  double b[4], db[4];
  // At a knot (t = 0): 1/6, 4/6, 1/6, 0; at the middle of an interval: 1/48, 23/48, 23/48, 1/48.
  EXPECT_EQ(MapBasis(0.0, 0.125, 10, 0.375, b, db), 3);
  EXPECT_NEAR(b[0], 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(b[1], 4.0 / 6.0, 1e-15);
  EXPECT_NEAR(b[2], 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(b[3], 0.0, 1e-15);
  // Derivatives at t = 0: -1/2, 0, 1/2, 0 per interval, i.e. per 0.125 rad.
  EXPECT_NEAR(db[0], -4.0, 1e-12);
  EXPECT_NEAR(db[1], 0.0, 1e-12);
  EXPECT_NEAR(db[2], 4.0, 1e-12);
  EXPECT_NEAR(db[3], 0.0, 1e-12);
  EXPECT_EQ(MapBasis(0.0, 0.125, 10, 0.5625, b, db), 4);
  EXPECT_NEAR(b[0], 1.0 / 48.0, 1e-15);
  EXPECT_NEAR(b[1], 23.0 / 48.0, 1e-15);
  EXPECT_NEAR(b[2], 23.0 / 48.0, 1e-15);
  EXPECT_NEAR(b[3], 1.0 / 48.0, 1e-15);
  // Beyond the knots: the end values, and no slope.
  EXPECT_EQ(MapBasis(0.0, 0.1, 10, -2.0, b, db), 0);
  EXPECT_NEAR(b[1], 4.0 / 6.0, 1e-15);
  EXPECT_EQ(db[0], 0.0);
  EXPECT_EQ(db[2], 0.0);
  EXPECT_EQ(MapBasis(0.0, 0.1, 10, 7.0, b, db), 9);
  EXPECT_NEAR(b[3], 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(b[2], 4.0 / 6.0, 1e-15);
  EXPECT_EQ(db[3], 0.0);
}

TEST(MapBasisTest, MapsReproduceConstantsAndLinesAndTheirSlopeMatchesFiniteDifferences) {
  JointMap map{.first_knot_rad = -0.4, .knot_spacing_rad = 0.05, .coefficients_rad = {}};
  // c_k = first + (k - 1) h reproduces q itself inside the knots (uniform cubic B-splines reproduce lines).
  for (int k = 0; k < 23; ++k) map.coefficients_rad.push_back(-0.4 + (k - 1) * 0.05);
  for (double q = -0.39; q <= 0.6; q += 0.0137) {
    double slope = 0.0;
    EXPECT_NEAR(MapValue(map, q, &slope), q, 1e-14) << q;
    EXPECT_NEAR(slope, 1.0, 1e-12) << q;
  }
  EXPECT_NEAR(MapValue(map, 2.0), MapValue(map, map.last_knot_rad()), 1e-15);
  Rng rng(4);
  for (double& c : map.coefficients_rad) c = 1e-4 * rng.Normal();
  for (double q = -0.38; q < 0.6; q += 0.0311) {
    double slope = 0.0;
    MapValue(map, q, &slope);
    const double numeric = (MapValue(map, q + 1e-7) - MapValue(map, q - 1e-7)) / 2e-7;
    EXPECT_NEAR(slope, numeric, 1e-8) << q;
  }
}

// Maps on the given joints (0-based) with a grid over [from, to].
JointErrorTerms MapsOn(std::vector<int> joints, double from, double to, double spacing) {
  JointErrorTerms terms;
  terms.maps.joints = joints;
  terms.maps.knot_spacing_rad = spacing;
  terms.maps.smoothness = 0.0;
  for (size_t k = 0; k < joints.size(); ++k) {
    terms.maps.first_knot_rad.push_back(from);
    terms.maps.intervals.push_back(static_cast<int>(std::lround((to - from) / spacing)));
  }
  return terms;
}

TEST(MapJacobianTest, MapColumnsAndAHeldMapsJointDerivativeMatchFiniteDifferences) {
  RobotModelSpec spec = Preset("ur5e").spec();
  Rng rng(8);
  // A held map on joint 3, so that the joint Jacobian's chain rule takes its slope.
  spec.joints[2].error_map = {.first_knot_rad = -2.0, .knot_spacing_rad = 0.1, .coefficients_rad = {}};
  for (int k = 0; k < 43; ++k) spec.joints[2].error_map.coefficients_rad.push_back(2e-3 * rng.Normal());
  spec.error_terms = MapsOn({0, 1, 4}, -1.5, 1.5, 0.05);
  const RobotModel model = RobotModel::Build(spec);
  ASSERT_EQ(model.num_error_parameters(), model.num_geometric_parameters() + 3 * 63);
  for (Eigen::VectorXd q : test::RandomConfigurations(model, 5, 19)) {
    q = q.cwiseMax(-1.4).cwiseMin(1.4);
    Eigen::VectorXd eps = Eigen::VectorXd::Zero(model.num_error_parameters());
    eps.head(model.num_geometric_parameters()) = test::RandomErrors(model.WithErrorTerms({}), &rng);
    for (int k = model.num_geometric_parameters(); k < eps.size(); ++k) eps[k] = 1e-4 * rng.Normal();
    KinematicsWorkspace ws(model);
    Eigen::MatrixXd analytic(6, model.num_error_parameters());
    IdentificationJacobian(model, q, eps, MeasurementType::kPose, &ws, analytic);
    const Transform at = ForwardKinematics(model, q, eps, &ws);
    Eigen::VectorXd steps(eps.size());
    for (int k = 0; k < eps.size(); ++k) steps[k] = model.parameter_unit(k) == ParameterUnit::kMm ? 1e-3 : 1e-6;
    const auto residual = [&](const Eigen::VectorXd& e) {
      KinematicsWorkspace w(model);
      Eigen::VectorXd r(6);
      MeasurementResidual(MeasurementType::kPose, at, ForwardKinematics(model, q, e, &w), r);
      return r;
    };
    const Eigen::MatrixXd numeric = -test::CentralDifferences(residual, eps, steps);
    EXPECT_LT(test::MaxRelativeColumnError(analytic, numeric), 1e-5);
    // Exactly four coefficients of each map move the tool at q.
    for (int joint : {0, 1, 4}) {
      const int first = model.map_parameter(joint);
      int moving = 0;
      for (int k = 0; k < 63; ++k) moving += analytic.col(first + k).norm() > 0.0 ? 1 : 0;
      EXPECT_EQ(moving, 4) << "joint " << joint + 1;
    }
    Eigen::MatrixXd joints(6, model.num_joints());
    JointJacobian(model, q, eps, MeasurementType::kPose, &ws, joints);
    const Eigen::MatrixXd numeric_joints = -test::CentralDifferences(
        [&](const Eigen::VectorXd& x) {
          KinematicsWorkspace w(model);
          Eigen::VectorXd r(6);
          MeasurementResidual(MeasurementType::kPose, at, ForwardKinematics(model, x, eps, &w), r);
          return r;
        },
        q, Eigen::VectorXd::Constant(q.size(), 1e-6));
    EXPECT_LT(test::MaxRelativeColumnError(joints, numeric_joints), 1e-6);
  }
}

constexpr double kFrom = -2.0, kTo = -0.4, kSpacing = 0.5 * kRadPerDeg;

// Joint 2 of a UR5e errs by `amplitude` (rad) times a sine of period `period` (rad), held as a map on a 0.5-degree
// grid over [kFrom, kTo] (the robot of the cell); the nominal robot holds a zero map there, so that a fit's map of
// that spacing takes the same grid.
RobotModel WithJoint2Map(double amplitude, double period, double spacing) {
  RobotModelSpec spec = Preset("ur5e").spec();
  JointMap& map = spec.joints[1].error_map;
  map = {.first_knot_rad = kFrom, .knot_spacing_rad = spacing, .coefficients_rad = {}};
  const int intervals = static_cast<int>(std::lround((kTo - kFrom) / spacing));
  for (int k = 0; k < intervals + 3; ++k) {
    map.coefficients_rad.push_back(amplitude * std::sin(2.0 * M_PI * (kFrom + (k - 1) * spacing) / period));
  }
  return RobotModel::Build(spec);
}

// Configurations with joint 2 spread evenly over the map's range.
std::vector<Eigen::VectorXd> SpreadOverTheMap(const RobotModel& model, int count, std::uint64_t seed) {
  std::vector<Eigen::VectorXd> out = test::RandomConfigurations(model, count, seed);
  for (size_t p = 0; p < out.size(); ++p) out[p][1] = kFrom + (kTo - kFrom) * (p + 0.5) / out.size();
  return out;
}

struct MapFit {
  Calibration calibration;
  RobotModel truth;
};

MapFit FitJoint2Map(double position_noise_mm, double angle_noise_rad, double smoothness, std::uint64_t seed) {
  const double amplitude = 0.01 * kRadPerDeg, period = 5.0 * kRadPerDeg;
  VirtualCellOptions o;
  o.seed = seed;
  o.noise.position_mm = position_noise_mm;
  o.noise.orientation_rad = angle_noise_rad;
  o.shots_per_pose = 1;
  VirtualCell cell(WithJoint2Map(amplitude, period, kSpacing), o);
  const RobotModel nominal = WithJoint2Map(0.0, period, kSpacing);
  const std::vector<Measurement> shots = cell.MeasureAll(SpreadOverTheMap(nominal, 400, seed + 1));
  IdentificationOptions options;
  options.measurement_type = MeasurementType::kPose;
  options.reject_outliers = false;
  options.estimate_model_error = false;
  if (position_noise_mm > 0.0) {
    options.noise.position_mm = position_noise_mm;
    options.noise.orientation_rad = angle_noise_rad;
  }
  JointErrorTerms terms;
  terms.maps.joints = {1};
  terms.maps.knot_spacing_rad = kSpacing;
  terms.maps.smoothness = smoothness;
  const RobotModel model = WithTermsFor(nominal, terms, shots);
  return {Identify(model, shots, options), cell.true_model()};
}

TEST(MapRecoveryTest, NoiseFreeRecoversAFiveDegreeJointErrorExactly) {
  const MapFit fit = FitJoint2Map(0.0, 0.0, 0.0, 31);
  const Calibration& c = fit.calibration;
  ASSERT_NE(c.summary.termination, Termination::kFailure) << c.summary.message;
  EXPECT_LT(c.summary.after.max_position_mm, 1e-6) << c.summary.BriefReport();
  // The fitted map is the true one less its mean (the offset, which the geometric parameters take).
  const int first = c.model.map_parameter(1);
  ASSERT_GE(first, 0);
  const std::vector<double>& truth = fit.truth.spec().joints[1].error_map.coefficients_rad;
  Eigen::VectorXd difference(static_cast<Eigen::Index>(truth.size()));
  for (size_t k = 0; k < truth.size(); ++k) difference[k] = c.errors[first + static_cast<int>(k)] - truth[k];
  // A constant difference (the offset), the same for every coefficient to 1e-6 of the amplitude.
  const double amplitude = 0.01 * kRadPerDeg;
  EXPECT_LT((difference.array() - difference.mean()).abs().maxCoeff(), 1e-6 * amplitude)
      << "offset " << difference.mean();
  // The fitted map carries no offset: its coefficients sum to zero.
  double sum = 0.0;
  for (size_t k = 0; k < truth.size(); ++k) sum += c.errors[first + static_cast<int>(k)];
  EXPECT_LT(std::abs(sum) / truth.size(), 1e-6 * amplitude);
}

TEST(MapRecoveryTest, WithNoiseTheMapIsRecoveredWithinItsReportedStd) {
  const MapFit fit = FitJoint2Map(0.01, 2e-5, 0.0, 41);
  const Calibration& c = fit.calibration;
  ASSERT_NE(c.summary.termination, Termination::kFailure) << c.summary.message;
  const std::vector<double>& truth = fit.truth.spec().joints[1].error_map.coefficients_rad;
  // Judged on the map's shape (its values less their mean, the offset the map carries), at the middle of each
  // interval, against the std of that difference from the covariance.
  const int first = c.model.map_parameter(1);
  std::vector<int> index;  // reduced index of each coefficient
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    for (size_t p = 0; p < c.parameters.size(); ++p) {
      if (c.parameters[p].index == first + k) index.push_back(static_cast<int>(p));
    }
  }
  ASSERT_EQ(index.size(), truth.size());
  const int intervals = static_cast<int>(truth.size()) - 3;
  // Each midpoint's value minus the mean of all midpoints: a linear function a' x of the coefficients.
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(intervals, static_cast<Eigen::Index>(truth.size()));
  for (int j = 0; j < intervals; ++j) {
    double b[4];
    MapBasis(kFrom, kSpacing, intervals, kFrom + (j + 0.5) * kSpacing, b);
    for (int r = 0; r < 4; ++r) a(j, j + r) = b[r];
  }
  const Eigen::RowVectorXd mean = a.colwise().mean();
  a.rowwise() -= mean;
  Eigen::VectorXd fitted(static_cast<Eigen::Index>(truth.size())), true_c(fitted.size());
  Eigen::MatrixXd covariance(fitted.size(), fitted.size());
  for (Eigen::Index k = 0; k < fitted.size(); ++k) {
    fitted[k] = c.errors[first + k];
    true_c[k] = truth[static_cast<size_t>(k)];
    for (Eigen::Index l = 0; l < fitted.size(); ++l) covariance(k, l) = c.covariance(index[k], index[l]);
  }
  const Eigen::VectorXd error = a * (fitted - true_c);
  const Eigen::MatrixXd value_covariance = a * covariance * a.transpose();
  int within_two = 0;
  double worst = 0.0;
  for (int j = 0; j < intervals; ++j) {
    const double z = std::abs(error[j]) / std::sqrt(value_covariance(j, j));
    within_two += z < 2.0 ? 1 : 0;
    worst = std::max(worst, z);
  }
  // Gaussian errors: about 95 % within 2 sigma; the values are correlated, so allow a margin.
  EXPECT_GE(within_two, static_cast<int>(0.8 * intervals)) << within_two << " of " << intervals;
  EXPECT_LT(worst, 4.5);
  // And the error is a small part of the amplitude (0.01 deg): the map is resolved, not noise.
  EXPECT_LT(error.cwiseAbs().maxCoeff(), 0.3 * 0.01 * kRadPerDeg);
}

TEST(MapPenaltyTest, AStrongPenaltyStraightensTheMap) {
  const MapFit free_fit = FitJoint2Map(0.01, 2e-5, 0.0, 51);
  const MapFit stiff_fit = FitJoint2Map(0.01, 2e-5, 1e4, 51);
  ASSERT_NE(free_fit.calibration.summary.termination, Termination::kFailure);
  ASSERT_NE(stiff_fit.calibration.summary.termination, Termination::kFailure);
  const auto curvature = [](const Calibration& c) {
    const int first = c.model.map_parameter(1);
    const int count = c.model.error_terms().maps.intervals[0] + 3;
    double worst = 0.0;
    for (int k = 0; k + 2 < count; ++k) {
      worst = std::max(worst, std::abs(c.errors[first + k] - 2.0 * c.errors[first + k + 1] + c.errors[first + k + 2]));
    }
    return worst;
  };
  EXPECT_LT(curvature(stiff_fit.calibration), 0.01 * curvature(free_fit.calibration));
  // Its std shrinks with the penalty (the penalty is information), and the straight map leaves the sine's error
  // in the residuals.
  EXPECT_GT(stiff_fit.calibration.summary.after.rms_position_mm,
            2.0 * free_fit.calibration.summary.after.rms_position_mm);
}

TEST(MapTermsTest, AModelRefusesMapsItCannotTakeByField) {
  const RobotModel ur = Preset("ur5e");
  const auto refused = [&](JointErrorTerms terms) {
    try {
      ur.WithErrorTerms(terms);
    } catch (const InvalidModelError& e) {
      std::string fields;
      for (const FieldError& f : e.errors()) fields += f.field + ";";
      return fields;
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refused(MapsOn({1}, -1, 1, 0.4 * kRadPerDeg)), "model.joint_maps.knot_spacing_deg;");
  EXPECT_EQ(refused(MapsOn({1}, -1, 1, 91 * kRadPerDeg)), "model.joint_maps.knot_spacing_deg;");
  EXPECT_EQ(refused(MapsOn({6}, -1, 1, 0.1)), "model.joint_maps.joints[0];");
  EXPECT_EQ(refused(MapsOn({2, 1}, -1, 1, 0.1)), "model.joint_maps.joints[1];");
  JointErrorTerms negative = MapsOn({1}, -1, 1, 0.1);
  negative.maps.smoothness = -1.0;
  EXPECT_EQ(refused(negative), "model.joint_maps.smoothness;");
  JointErrorTerms with_harmonics = MapsOn({1}, -1, 1, 0.1);
  with_harmonics.joint_harmonics = 1;
  EXPECT_EQ(refused(with_harmonics), "model.joint_maps;");
  JointErrorTerms unplaced;
  unplaced.maps.joints = {1};
  unplaced.maps.knot_spacing_rad = 0.1;
  EXPECT_EQ(refused(unplaced), "model.joint_maps;");
  EXPECT_EQ(refused(MapsOn({1}, -1, 1, 0.1)), "accepted");
  // A prismatic joint takes no map.
  RobotModelSpec gantry = Preset("ur5e").spec();
  gantry.joints[0].type = JointType::kPrismatic;
  gantry.joints[0].min = 0;
  gantry.joints[0].max = 1000;
  gantry.error_terms = MapsOn({0}, -1, 1, 0.1);
  try {
    RobotModel::Build(gantry);
    ADD_FAILURE() << "a prismatic joint's map was accepted";
  } catch (const InvalidModelError& e) {
    EXPECT_EQ(e.errors().at(0).field, "model.joint_maps.joints[0]");
    EXPECT_NE(e.errors().at(0).reason.find("prismatic"), std::string::npos);
  }
}

}  // namespace
}  // namespace robocal

namespace robocal {
namespace {

TEST(MapChoiceTest, ARobotWithoutFineJointErrorsChoosesNoMaps) {
  // Geometric errors and tracker noise only: maps every 8 deg (and compliance) are a candidate, evaluated on every
  // fold, and not chosen.
  const RobotModel nominal = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 61;
  o.shots_per_pose = 1;
  VirtualCell cell(nominal, o);
  std::vector<Eigen::VectorXd> configurations = test::RandomConfigurations(nominal, 150, 62);
  for (Eigen::VectorXd& q : configurations) q = q.cwiseMax(-2.0).cwiseMin(2.0);
  const std::vector<Measurement> shots = cell.MeasureAll(configurations);
  IdentificationOptions options;
  options.measurement_type = MeasurementType::kPose;
  ModelChoiceOptions choice;
  choice.folds = 3;
  choice.max_joint_harmonics = 0;
  choice.map_knot_spacings_rad = {8.0 * kRadPerDeg};
  const ModelChoice mc = ChooseModel(nominal, shots, options, choice);
  ASSERT_GE(mc.chosen, 0) << mc.message;
  ASSERT_FALSE(mc.candidates.empty());
  const ModelCandidate& maps = mc.candidates.back();
  ASSERT_FALSE(maps.terms.maps.empty());
  EXPECT_EQ(maps.failed_folds, 0) << maps.note;
  EXPECT_TRUE(mc.candidates[mc.chosen].terms.maps.empty()) << mc.message;
}

}  // namespace
}  // namespace robocal

namespace robocal {
namespace {

TEST(MapRangeTest, AJointBeyondItsMapsKnotsIsNamed) {
  RobotModelSpec spec = Preset("ur5e").spec();
  spec.joints[1].error_map = {.first_knot_rad = -1.0, .knot_spacing_rad = 0.1, .coefficients_rad = {}};
  spec.joints[1].error_map.coefficients_rad.assign(23, 1e-4);
  spec.error_terms = MapsOn({3}, 0.0, 1.0, 0.1);
  const RobotModel model = RobotModel::Build(spec);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  q[1] = 0.5;
  q[3] = 0.5;
  EXPECT_EQ(BeyondMapKnots(model, q), "");
  q[1] = 1.5;   // beyond the held map's last knot (1.0 rad)
  q[3] = -0.2;  // before the fitted map's first knot (0 rad)
  const std::string said = BeyondMapKnots(model, q);
  EXPECT_NE(
      said.find("joint " + model.joint_name(1) + " at 85.94 deg lies beyond its error map's knots (-57.3 .. 57.3 deg)"),
      std::string::npos)
      << said;
  EXPECT_NE(said.find("joint " + model.joint_name(3) + " at -11.46 deg"), std::string::npos) << said;
  EXPECT_NE(said.find("where the map holds its end value"), std::string::npos);
}

}  // namespace
}  // namespace robocal
