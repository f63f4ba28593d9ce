// Joint errors beyond geometry: gravity torques against hand-computed cases, their derivatives and the new
// Jacobian columns against finite differences, recovery from a simulated cell, compensation under a payload the
// calibration never saw, and the model choice by cross-validation.
#include "robocal/core/joint_errors.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "robocal/core/compensation.h"
#include "robocal/core/dh_table.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/model_choice.h"
#include "robocal/core/presets.h"
#include "robocal/core/units.h"
#include "robocal/core/virtual_cell.h"
#include "test_util.h"

namespace robocal {
namespace {

// Two revolute joints about z in the base's x-y plane, gravity along -y: a planar arm in a vertical plane.
RobotModelSpec PlanarArm(double l1, double l2, double m1, double c1, double m2, double c2) {
  RobotModelSpec s;
  s.name = "planar";
  s.convention = GeometryConvention::kTransform;
  JointSpec a;
  a.name = "a";
  a.min = -M_PI;
  a.max = M_PI;
  a.mass_kg = m1;
  a.com_mm = {c1, 0, 0};
  JointSpec b = a;
  b.name = "b";
  b.xyz_mm = {l1, 0, 0};
  b.mass_kg = m2;
  b.com_mm = {c2, 0, 0};
  s.joints = {a, b};
  s.T_lastjoint_flange = Translation(l2, 0, 0);
  s.gravity_base = Eigen::Vector3d(0, -1, 0);
  return s;
}

TEST(GravityTorqueTest, PlanarArmMatchesTheHandComputedTorques) {
  const double l1 = 400, l2 = 300, m1 = 5, c1 = 180, m2 = 3, c2 = 120, mp = 2;
  const RobotModel model = RobotModel::Build(PlanarArm(l1, l2, m1, c1, m2, c2));
  const Payload payload{mp, Eigen::Vector3d::Zero()};
  const double g = kStandardGravity / 1000.0;  // N per kg, times mm -> N*m
  for (double q1 : {0.0, 0.3, -1.2, 2.5}) {
    for (double q2 : {0.0, 0.7, -2.0}) {
      const Eigen::VectorXd tau = GravityTorques(model, Eigen::Vector2d(q1, q2), payload);
      // Torque about +z of a weight -m g y at x: -m g x.
      const double x12 = std::cos(q1 + q2);
      const double tau2 = -g * (m2 * c2 * x12 + mp * l2 * x12);
      const double tau1 =
          -g * (m1 * c1 * std::cos(q1) + m2 * (l1 * std::cos(q1) + c2 * x12) + mp * (l1 * std::cos(q1) + l2 * x12));
      EXPECT_NEAR(tau[0], tau1, 1e-12) << q1 << " " << q2;
      EXPECT_NEAR(tau[1], tau2, 1e-12) << q1 << " " << q2;
    }
  }
  // Horizontal arm, straight out: the payload's 2 kg at 0.7 m and the links' weights.
  const Eigen::VectorXd tau = GravityTorques(model, Eigen::Vector2d::Zero(), payload);
  EXPECT_NEAR(tau[0], -kStandardGravity * (5 * 0.18 + 3 * 0.52 + 2 * 0.7), 1e-12);
}

TEST(GravityTorqueTest, DerivativesMatchFiniteDifferences) {
  for (const char* name : {"ur5e", "puma560", "grinder5"}) {
    const RobotModel model = Preset(name);
    const Payload payload{4.0, Eigen::Vector3d(20, -30, 60)};
    for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 10, 7)) {
      Eigen::MatrixXd analytic;
      GravityTorques(model, q, payload, &analytic);
      const Eigen::MatrixXd numeric =
          test::CentralDifferences([&](const Eigen::VectorXd& x) { return GravityTorques(model, x, payload); }, q,
                                   Eigen::VectorXd::Constant(q.size(), 1e-6));
      EXPECT_LT((analytic - numeric).cwiseAbs().maxCoeff(), 1e-6 * (1.0 + analytic.cwiseAbs().maxCoeff())) << name;
    }
  }
}

// Gravity torques are minus the derivatives of the potential energy of the links and the payload (each mass at its
// centre of mass, placed by the nominal chain and the link frames): an independent check of sign and frames.
TEST(GravityTorqueTest, TorquesAreMinusThePotentialEnergysDerivatives) {
  for (const char* name : {"ur5e", "puma560", "grinder5"}) {
    const RobotModel model = Preset(name);
    const Payload payload{3.0, Eigen::Vector3d(15, -25, 70)};
    const auto potential = [&](const Eigen::VectorXd& q) {  // N*m
      std::vector<Transform> joints(model.num_joints());
      Transform flange;
      NominalChainInBase(model, q, joints.data(), &flange);
      const Eigen::Vector3d g = kStandardGravity * model.spec().gravity_base;
      double v = -payload.mass_kg * g.dot(flange * payload.com_mm);
      for (int i = 0; i < model.num_joints(); ++i) {
        const JointSpec& j = model.spec().joints[i];
        const Transform motion = j.type == JointType::kRevolute ? Rotation(RotZ(q[i])) : Translation(0, 0, q[i]);
        v -= j.mass_kg * g.dot(joints[i] * motion * model.link_frame(i) * j.com_mm);
      }
      return Eigen::VectorXd::Constant(1, v / 1000.0);
    };
    for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 10, 8)) {
      const Eigen::VectorXd tau = GravityTorques(model, q, payload);
      const Eigen::MatrixXd dv = test::CentralDifferences(potential, q, Eigen::VectorXd::Constant(q.size(), 1e-6));
      for (int i = 0; i < model.num_joints(); ++i) {
        if (model.joint_type(i) != JointType::kRevolute) continue;  // a slide's force is not a joint torque
        EXPECT_NEAR(tau[i], -dv(0, i), 1e-6 * (1.0 + tau.cwiseAbs().maxCoeff())) << name << " joint " << i;
      }
    }
  }
}

// Error parameters with joint terms: geometric ones of realistic size, compliances of 1e-5 rad/(N*m) and
// harmonic amplitudes of 1e-4 rad.
Eigen::VectorXd RandomErrorsWithTerms(const RobotModel& model, Rng* rng) {
  Eigen::VectorXd eps = Eigen::VectorXd::Zero(model.num_error_parameters());
  eps.head(model.num_geometric_parameters()) = test::RandomErrors(model.WithErrorTerms({}), rng);
  for (int k = model.num_geometric_parameters(); k < model.num_error_parameters(); ++k) {
    eps[k] = (model.parameter_unit(k) == ParameterUnit::kRadPerNm ? 1e-5 : 1e-4) * rng->Normal();
  }
  return eps;
}

TEST(JointTermJacobianTest, IdentificationJacobianMatchesFiniteDifferences) {
  for (const char* name : {"ur5e", "puma560", "grinder5"}) {
    const RobotModel model = Preset(name).WithErrorTerms({.compliance = true, .joint_harmonics = 2});
    ASSERT_GT(model.joint_terms().size(), 0u);
    Rng rng(3);
    const Payload payload{6.0, Eigen::Vector3d(10, 40, 80)};
    for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 5, 11)) {
      const Eigen::VectorXd eps = RandomErrorsWithTerms(model, &rng);
      KinematicsWorkspace ws(model);
      Eigen::MatrixXd analytic(6, model.num_error_parameters());
      IdentificationJacobian(model, q, eps, MeasurementType::kPose, &ws, analytic, payload);
      const Transform at = ForwardKinematics(model, q, eps, &ws, payload);
      Eigen::VectorXd steps(eps.size());
      for (int k = 0; k < eps.size(); ++k) {
        steps[k] = model.parameter_unit(k) == ParameterUnit::kMm    ? 1e-3
                   : model.parameter_unit(k) == ParameterUnit::kRad ? 1e-6
                                                                    : 1e-8;
      }
      // residual(eps + d) ~= residual(eps) - J d: J is minus the residual's derivative against a fixed measurement.
      const Eigen::MatrixXd numeric = -test::CentralDifferences(
          [&](const Eigen::VectorXd& e) {
            KinematicsWorkspace w(model);
            Eigen::VectorXd r(6);
            MeasurementResidual(MeasurementType::kPose, at, ForwardKinematics(model, q, e, &w, payload), r);
            return r;
          },
          eps, steps);
      EXPECT_LT(test::MaxRelativeColumnError(analytic, numeric), 1e-5) << name;
    }
  }
}

TEST(JointTermJacobianTest, JointJacobianIncludesTheDeflectionsDependenceOnTheJoints) {
  const RobotModel model = Preset("ur5e").WithErrorTerms({.compliance = true, .joint_harmonics = 2});
  Rng rng(5);
  const Payload payload{6.0, Eigen::Vector3d(10, 40, 80)};
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 8, 13)) {
    // Large terms, so that the chain rule's part is far above the differences' error.
    Eigen::VectorXd eps = 100.0 * RandomErrorsWithTerms(model, &rng);
    eps.head(model.num_geometric_parameters()) /= 100.0;
    KinematicsWorkspace ws(model);
    Eigen::MatrixXd analytic(6, model.num_joints());
    JointJacobian(model, q, eps, MeasurementType::kPose, &ws, analytic, payload);
    const Transform at = ForwardKinematics(model, q, eps, &ws, payload);
    const Eigen::MatrixXd numeric = -test::CentralDifferences(
        [&](const Eigen::VectorXd& x) {
          KinematicsWorkspace w(model);
          Eigen::VectorXd r(6);
          MeasurementResidual(MeasurementType::kPose, at, ForwardKinematics(model, x, eps, &w, payload), r);
          return r;
        },
        q, Eigen::VectorXd::Constant(q.size(), 1e-6));
    EXPECT_LT(test::MaxRelativeColumnError(analytic, numeric), 1e-6);
    // Without the chain rule the Jacobian at the deflected joints alone differs by more than that.
    Eigen::MatrixXd at_deflected(6, model.num_joints());
    JointJacobian(model.WithErrorTerms({}), ws.q_effective, eps.head(model.num_geometric_parameters()),
                  MeasurementType::kPose, &ws, at_deflected);
    EXPECT_GT(test::MaxRelativeColumnError(at_deflected, numeric), 1e-5);
  }
}

TEST(JointTermJacobianTest, FoldedChainDeflectsAsForwardKinematics) {
  const RobotModel model = Preset("puma560").WithErrorTerms({.compliance = true, .joint_harmonics = 1});
  Rng rng(9);
  const Eigen::VectorXd eps = RandomErrorsWithTerms(model, &rng);
  const Payload payload{3.0, Eigen::Vector3d(0, 25, 50)};
  const FoldedChain chain(model, eps, payload);
  EXPECT_TRUE(chain.deflects());
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 20, 17)) {
    KinematicsWorkspace ws(model);
    const Transform expected = ForwardKinematics(model, q, eps, &ws, payload);
    EXPECT_LT((chain.Forward(q, nullptr).matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    const Transform unloaded = ForwardKinematics(model, q, eps, &ws);
    EXPECT_LT((chain.WithPayload(Payload()).Forward(q, nullptr).matrix() - unloaded.matrix()).cwiseAbs().maxCoeff(),
              1e-9);
  }
}

// Configurations under one payload each, measured by the cell.
std::vector<Measurement> MeasureUnder(VirtualCell* cell, const RobotModel& model, int count, std::uint64_t seed,
                                      const Payload& payload) {
  return cell->MeasureAll(test::RandomConfigurations(model, count, seed), 0, nullptr, payload);
}

const Payload kPayloadA{0.0, Eigen::Vector3d::Zero()};
const Payload kPayloadB{5.0, Eigen::Vector3d(0, 30, 60)};
const Payload kPayloadC{2.5, Eigen::Vector3d(40, -20, 90)};  // never in a calibration

// A noise-free cell whose robot has compliance (0.3 mm of deflection) and joint harmonics of orders 1 and 2.
VirtualCellOptions NoiseFreeCompliantCell(std::uint64_t seed) {
  VirtualCellOptions o;
  o.seed = seed;
  o.noise.position_mm = 0.0;
  o.noise.orientation_rad = 0.0;
  o.shots_per_pose = 1;
  o.compliance_deflection_mm = 0.3;
  o.joint_harmonic_sigma_rad = 5e-5;
  o.joint_harmonic_min_order = 1;
  o.joint_harmonic_max_order = 2;
  return o;
}

// The fit with compliance and harmonics 2 of 80 unloaded and 80 loaded (payload B) poses measured by `cell`
// (configurations from `seed` and seed + 1), every shot kept, no model error.
Calibration FitCompliantly(VirtualCell* cell, const RobotModel& nominal, std::uint64_t seed) {
  std::vector<Measurement> shots = MeasureUnder(cell, nominal, 80, seed, kPayloadA);
  const std::vector<Measurement> loaded = MeasureUnder(cell, nominal, 80, seed + 1, kPayloadB);
  shots.insert(shots.end(), loaded.begin(), loaded.end());
  IdentificationOptions options;
  options.reject_outliers = false;
  options.estimate_model_error = false;
  return Identify(nominal.WithErrorTerms({.compliance = true, .joint_harmonics = 2}), shots, options);
}

TEST(JointTermRecoveryTest, NoiseFreeRecoversComplianceHarmonicsAndGeometryAndCompensatesUnderANewPayload) {
  const RobotModel nominal = Preset("ur5e");
  VirtualCell cell(nominal, NoiseFreeCompliantCell(21));
  const Calibration c = FitCompliantly(&cell, nominal, 100);
  ASSERT_NE(c.summary.termination, Termination::kFailure) << c.summary.message;
  EXPECT_LT(c.summary.after.max_position_mm, 1e-6) << c.summary.FullReport();
  const RobotModel& model = c.model;
  int compliances = 0, harmonics = 0;
  for (const IdentifiedParameter& p : c.parameters) {
    if (p.index < model.num_geometric_parameters()) continue;
    const JointTermParameter& term = model.joint_terms()[p.index - model.num_geometric_parameters()];
    if (term.kind == JointTermParameter::Kind::kCompliance) {
      EXPECT_NEAR(p.value, cell.true_compliance()[term.joint], 1e-6 * cell.true_compliance().maxCoeff()) << p.name;
      ++compliances;
    } else {
      const Eigen::MatrixXd& truth =
          term.kind == JointTermParameter::Kind::kSin ? cell.true_harmonic_sin() : cell.true_harmonic_cos();
      EXPECT_NEAR(p.value, truth(term.joint, term.order - 1), 1e-9) << p.name;
      ++harmonics;
    }
  }
  // Joint 1 turns about gravity (no torque) and joint 6 carries its payloads on its axis: 4 compliances.
  EXPECT_EQ(compliances, 4);
  EXPECT_EQ(harmonics, 24);
  // Geometry: the calibrated robot is the true one, on configurations and under a payload the fit never saw.
  KinematicsWorkspace ws(model);
  for (const Eigen::VectorXd& q : test::RandomConfigurations(nominal, 50, 102)) {
    const Transform truth = cell.TruePose(q, kPayloadC);
    const Transform predicted = ForwardKinematics(model, q, c.errors, &ws, kPayloadC);
    EXPECT_LT((truth.translation() - predicted.translation()).norm(), 1e-6);
    // Compensation under that payload: the loaded true robot lands on the target.
    CompensationTarget target;
    target.pose = truth;
    target.start = q;
    target.payload = kPayloadC;
    const CompensationResult r = Compensate(c, nominal, target);
    ASSERT_EQ(r.termination, Termination::kConvergence) << r.message;
    const Transform landed = cell.TruePose(r.joints, kPayloadC);
    EXPECT_LT((landed.translation() - truth.translation()).norm(), 1e-6);
  }
}

// The cell of the noisy cases: a tracker of 15 um per axis, one shot per pose, compliance of a few tenths of a mm.
VirtualCellOptions NoisyCell(std::uint64_t seed, double compliance_mm) {
  VirtualCellOptions o;
  o.seed = seed;
  o.shots_per_pose = 1;
  o.compliance_deflection_mm = compliance_mm;
  return o;
}

double HeldOutMean(const Calibration& c, const std::vector<Measurement>& held_out) {
  KinematicsWorkspace ws(c.model);
  double sum = 0.0;
  for (const Measurement& m : held_out) {
    sum += (m.T_world_tool.translation() - ForwardKinematics(c.model, m.joints, c.errors, &ws, m.payload).translation())
               .norm();
  }
  return sum / static_cast<double>(held_out.size());
}

TEST(JointTermRecoveryTest, CompliantFitIsNearTheNoiseFloorUnderAThirdPayload) {
  const RobotModel nominal = Preset("ur5e");
  VirtualCell cell(nominal, NoisyCell(31, 0.4));
  std::vector<Measurement> shots = MeasureUnder(&cell, nominal, 100, 200, kPayloadA);
  const std::vector<Measurement> loaded = MeasureUnder(&cell, nominal, 100, 201, kPayloadB);
  shots.insert(shots.end(), loaded.begin(), loaded.end());
  const std::vector<Measurement> held_out = MeasureUnder(&cell, nominal, 200, 202, kPayloadC);
  double floor = 0.0;
  for (const Measurement& m : held_out)
    floor += (m.T_world_tool.translation() - cell.TruePose(m.joints, kPayloadC).translation()).norm();
  floor /= static_cast<double>(held_out.size());
  const Calibration compliant = Identify(nominal.WithErrorTerms({.compliance = true, .joint_harmonics = 0}), shots);
  const Calibration geometric = Identify(nominal, shots);
  ASSERT_NE(compliant.summary.termination, Termination::kFailure) << compliant.summary.message;
  const double with = HeldOutMean(compliant, held_out), without = HeldOutMean(geometric, held_out);
  EXPECT_LT(with, 1.5 * floor) << "floor " << floor << ", geometric " << without;
  EXPECT_GT(without, with);
  // The compliances are recovered within their std.
  for (const IdentifiedParameter& p : compliant.parameters) {
    if (p.index < compliant.model.num_geometric_parameters()) continue;
    const int joint = compliant.model.joint_terms()[p.index - compliant.model.num_geometric_parameters()].joint;
    EXPECT_LT(std::abs(p.value - cell.true_compliance()[joint]), 4.0 * p.std) << p.name;
  }
}

TEST(ModelChoiceTest, AutoPicksTheGeometricModelWhenTheRobotHasNoCompliance) {
  const RobotModel nominal = Preset("ur5e");
  VirtualCell cell(nominal, NoisyCell(41, 0.0));
  std::vector<Measurement> shots = MeasureUnder(&cell, nominal, 60, 300, kPayloadA);
  const std::vector<Measurement> loaded = MeasureUnder(&cell, nominal, 60, 301, kPayloadB);
  shots.insert(shots.end(), loaded.begin(), loaded.end());
  const std::vector<Measurement> held_out = MeasureUnder(&cell, nominal, 200, 302, kPayloadC);
  const Calibration automatic = IdentifyWithModelChoice(nominal, shots, {});
  const Calibration geometric = Identify(nominal, shots);
  ASSERT_NE(automatic.summary.termination, Termination::kFailure) << automatic.summary.message;
  ASSERT_EQ(automatic.summary.model_candidates.size(), 6u);
  EXPECT_GE(automatic.summary.model_chosen, 0);
  EXPECT_LE(HeldOutMean(automatic, held_out), 1.05 * HeldOutMean(geometric, held_out))
      << automatic.summary.FullReport();
  // Fitted anyway, the compliances are consistent with zero.
  const Calibration compliant = Identify(nominal.WithErrorTerms({.compliance = true, .joint_harmonics = 0}), shots);
  for (const IdentifiedParameter& p : compliant.parameters) {
    if (p.index >= compliant.model.num_geometric_parameters()) {
      EXPECT_LT(std::abs(p.value), 3.5 * p.std) << p.name;
    }
  }
}

TEST(ModelChoiceTest, AutoPicksComplianceWhenTheRobotHasIt) {
  const RobotModel nominal = Preset("ur5e");
  VirtualCell cell(nominal, NoisyCell(51, 0.5));
  std::vector<Measurement> shots = MeasureUnder(&cell, nominal, 60, 400, kPayloadA);
  const std::vector<Measurement> loaded = MeasureUnder(&cell, nominal, 60, 401, kPayloadB);
  shots.insert(shots.end(), loaded.begin(), loaded.end());
  ModelChoiceOptions choice;
  choice.seed = 3;
  const ModelChoice mc = ChooseModel(nominal, shots, {}, choice);
  ASSERT_GE(mc.chosen, 0) << mc.message;
  EXPECT_TRUE(mc.candidates[mc.chosen].terms.compliance) << mc.message;
  EXPECT_LT(mc.candidates[mc.chosen].cv_mean_mm, mc.candidates[0].cv_mean_mm);
  // Reproducible from the seed.
  const ModelChoice again = ChooseModel(nominal, shots, {}, choice);
  EXPECT_EQ(again.chosen, mc.chosen);
  EXPECT_EQ(again.candidates[mc.chosen].cv_mean_mm, mc.candidates[mc.chosen].cv_mean_mm);
}

// A compliance no robot joint has (here put into exact data on purpose, as a term the poses hardly drive ends up
// after fitting the noise) makes the fit DEGRADED, says which, and keeps its model from being chosen.
TEST(ModelChoiceTest, ImplausibleJointTermsAreDegradedAndNotChosen) {
  const RobotModel model = Preset("ur5e").WithErrorTerms({.compliance = true, .joint_harmonics = 0});
  Eigen::VectorXd eps = Eigen::VectorXd::Zero(model.num_error_parameters());
  const int wrist = model.ParameterIndex("joint4.compliance");
  ASSERT_GE(wrist, 0);
  eps[wrist] = 5.0 * kImplausibleComplianceRadPerNm;
  std::vector<Measurement> shots;
  KinematicsWorkspace ws(model);
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 80, 600)) {
    Measurement m;
    m.joints = q;
    m.payload = kPayloadB;
    m.T_world_tool = ForwardKinematics(model, q, eps, &ws, m.payload);
    shots.push_back(m);
  }
  IdentificationOptions options;
  options.reject_outliers = false;
  const Calibration c = Identify(model, shots, options);
  EXPECT_EQ(c.summary.termination, Termination::kDegraded);
  ASSERT_EQ(c.summary.implausible_joint_terms.size(), 1u);
  EXPECT_THAT(c.summary.implausible_joint_terms[0], ::testing::HasSubstr("joint4.compliance"));
  EXPECT_THAT(c.summary.message, ::testing::HasSubstr("implausible joint terms"));
  ModelChoiceOptions choice;
  choice.max_joint_harmonics = 0;
  const ModelChoice mc = ChooseModel(Preset("ur5e"), shots, options, choice);
  ASSERT_EQ(mc.candidates.size(), 2u);
  EXPECT_EQ(mc.candidates[1].failed_folds, choice.folds);
  EXPECT_THAT(mc.candidates[1].note, ::testing::HasSubstr("implausible"));
  EXPECT_EQ(mc.chosen, 0);
}

TEST(JointTermInputTest, BadMassesOrdersAndMissingMassesAreRefusedByField) {
  RobotModelSpec spec = PresetSpec("ur5e");
  spec.joints[2].mass_kg = -1.0;
  try {
    RobotModel::Build(spec);
    FAIL() << "negative mass accepted";
  } catch (const InvalidModelError& e) {
    EXPECT_EQ(e.errors().at(0).field, "joints[2].mass_kg");
  }
  spec = PresetSpec("ur5e");
  spec.error_terms.joint_harmonics = 3;
  try {
    RobotModel::Build(spec);
    FAIL() << "harmonic order 3 accepted";
  } catch (const InvalidModelError& e) {
    EXPECT_EQ(e.errors().at(0).field, "model.joint_harmonics");
  }
  spec = PresetSpec("ur5e");
  for (JointSpec& j : spec.joints) j.mass_kg = 0.0;
  const RobotModel massless = RobotModel::Build(spec);
  EXPECT_FALSE(massless.has_masses());
  VirtualCell cell(Preset("ur5e"), NoisyCell(61, 0.0));
  const std::vector<Measurement> shots = MeasureUnder(&cell, massless, 40, 500, kPayloadB);
  const Calibration c = Identify(massless.WithErrorTerms({.compliance = true, .joint_harmonics = 0}), shots);
  EXPECT_EQ(c.summary.termination, Termination::kFailure);
  EXPECT_THAT(c.summary.message, ::testing::HasSubstr("model.compliance"));
  EXPECT_EQ(ModelCandidates(massless, {}).size(), 3u);  // no compliance candidates without masses
  VirtualCellOptions o = NoisyCell(62, 0.3);
  EXPECT_THROW(VirtualCell(massless, o), std::invalid_argument);
  std::string error;
  EXPECT_FALSE((Payload{-2.0, Eigen::Vector3d::Zero()}.IsValid("payload", &error)));
  EXPECT_EQ(error.rfind("payload.mass_kg", 0), 0u);
}

// ---------------------------------------------------------------------------------------------- fixed joint terms

double LargestPoseDifference(const Transform& a, const Transform& b) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff();
}

// The registered robot's gravity torques come from its own nominal chain, the calibrated one, where the
// calibration's came from the nominal robot's (the geometric errors tilt the links by up to 3e-3 rad here): with
// compliances it is the calibration at joints shifted by compliance times that difference of the torques (a few
// microradians). Geometry and harmonics carry over exactly.
TEST(FixedJointTermTest, ACalibrationsSpecHoldsItsJointTermsAndMovesAsTheCalibration) {
  for (const char* name : {"ur5e", "puma560", "grinder5"}) {
    for (const JointErrorTerms& terms : {JointErrorTerms{.compliance = false, .joint_harmonics = 2},
                                         JointErrorTerms{.compliance = true, .joint_harmonics = 2}}) {
      SCOPED_TRACE(std::string(name) + " " + terms.Describe());
      const RobotModel model = Preset(name).WithErrorTerms(terms);
      Rng rng(41);
      const Eigen::VectorXd eps = RandomErrorsWithTerms(model, &rng);
      const RobotModelSpec spec = CalibratedTransformSpec(model, eps);
      EXPECT_EQ(spec.error_terms, JointErrorTerms());
      const RobotModel robot = RobotModel::Build(spec);
      EXPECT_TRUE(robot.has_fixed_joint_terms());
      EXPECT_TRUE(robot.deflects());
      EXPECT_TRUE(robot.joint_terms().empty());
      // Every term's parameter is in its joint.
      for (size_t t = 0; t < model.joint_terms().size(); ++t) {
        const JointTermParameter& term = model.joint_terms()[t];
        const Eigen::Index k = model.num_geometric_parameters() + static_cast<Eigen::Index>(t);
        const JointSpec& joint = spec.joints[static_cast<size_t>(term.joint)];
        const double held = term.kind == JointTermParameter::Kind::kCompliance ? joint.compliance_rad_per_nm
                            : term.kind == JointTermParameter::Kind::kSin ? joint.harmonics_rad[2 * (term.order - 1)]
                                                                          : joint.harmonics_rad[2 * term.order - 1];
        EXPECT_EQ(held, eps[k]) << model.parameter_name(static_cast<int>(k));
      }
      Eigen::VectorXd compliance(model.num_joints());
      for (int i = 0; i < model.num_joints(); ++i) {
        compliance[i] = spec.joints[static_cast<size_t>(i)].compliance_rad_per_nm;
      }
      const FoldedChain chain(robot, Eigen::VectorXd());
      EXPECT_TRUE(chain.deflects());
      for (const Payload& payload : {kPayloadA, kPayloadB, kPayloadC}) {
        for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 10, 43)) {
          KinematicsWorkspace ws(model), robot_ws(robot);
          const Eigen::VectorXd shift =
              compliance.cwiseProduct(GravityTorques(robot, q, payload) - GravityTorques(model, q, payload));
          EXPECT_LE(shift.cwiseAbs().maxCoeff(), terms.compliance ? 1e-5 : 0.0);
          const Transform calibrated = ForwardKinematics(model, q + shift, eps, &ws, payload);
          Eigen::MatrixXd expected(6, model.num_joints()), held(6, model.num_joints());
          JointJacobian(model, q + shift, eps, MeasurementType::kPose, &ws, expected, payload);
          // Second order in the shift (its own deflection's change, c dtau/dq shift): 1e-3 of the first-order 1e-3 mm.
          const double tolerance = terms.compliance ? 1e-5 : 1e-9;
          EXPECT_LT(
              LargestPoseDifference(ForwardKinematics(robot, q, Eigen::VectorXd(), &robot_ws, payload), calibrated),
              tolerance);
          EXPECT_LT(LargestPoseDifference(chain.WithPayload(payload).Forward(q, nullptr), calibrated), tolerance);
          JointJacobian(robot, q, Eigen::VectorXd(), MeasurementType::kPose, &robot_ws, held, payload);
          EXPECT_LT((expected - held).cwiseAbs().maxCoeff(), terms.compliance ? 1e-2 : 1e-9);
        }
      }
    }
  }
}

// The UR5e holding compliances and harmonics of the largest plausible size, so that their dependence on the joints is
// far above finite differences' error, with compliance and harmonics of order 2 to fit on top.
RobotModelSpec HeldAndFittedTerms() {
  RobotModelSpec spec = PresetSpec("ur5e");
  for (size_t i = 0; i < spec.joints.size(); ++i) {
    spec.joints[i].compliance_rad_per_nm = (i % 2 == 0 ? 0.5 : -0.3) * kImplausibleComplianceRadPerNm / 10.0;
    spec.joints[i].harmonics_rad = Eigen::Vector4d(3e-3, -2e-3, 1e-3, 4e-3) * (1.0 + 0.1 * static_cast<double>(i));
  }
  spec.error_terms = {.compliance = true, .joint_harmonics = 2};
  return spec;
}

TEST(FixedJointTermTest, FittedTermsStackOnHeldOnesAndTheJacobiansMatchFiniteDifferences) {
  // Held terms, fitted terms and geometric errors on top.
  const RobotModelSpec spec = HeldAndFittedTerms();
  const RobotModel model = RobotModel::Build(spec);
  Rng rng(45);
  const Payload payload{6.0, Eigen::Vector3d(10, 40, 80)};
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 5, 47)) {
    const Eigen::VectorXd eps = RandomErrorsWithTerms(model, &rng);
    KinematicsWorkspace ws(model);
    Eigen::MatrixXd analytic(6, model.num_error_parameters()), joints(6, model.num_joints());
    IdentificationJacobian(model, q, eps, MeasurementType::kPose, &ws, analytic, payload);
    JointJacobian(model, q, eps, MeasurementType::kPose, &ws, joints, payload);
    const Transform at = ForwardKinematics(model, q, eps, &ws, payload);
    auto residual = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& e) {
      KinematicsWorkspace w(model);
      Eigen::VectorXd r(6);
      MeasurementResidual(MeasurementType::kPose, at, ForwardKinematics(model, x, e, &w, payload), r);
      return r;
    };
    Eigen::VectorXd steps(eps.size());
    for (int k = 0; k < eps.size(); ++k) {
      steps[k] = model.parameter_unit(k) == ParameterUnit::kMm    ? 1e-3
                 : model.parameter_unit(k) == ParameterUnit::kRad ? 1e-6
                                                                  : 1e-8;
    }
    const Eigen::MatrixXd numeric =
        -test::CentralDifferences([&](const Eigen::VectorXd& e) { return residual(q, e); }, eps, steps);
    EXPECT_LT(test::MaxRelativeColumnError(analytic, numeric), 1e-5);
    const Eigen::MatrixXd numeric_joints = -test::CentralDifferences(
        [&](const Eigen::VectorXd& x) { return residual(x, eps); }, q, Eigen::VectorXd::Constant(q.size(), 1e-6));
    EXPECT_LT(test::MaxRelativeColumnError(joints, numeric_joints), 1e-6);
    // The held terms deflect the joints as fitted terms of the same values would.
    RobotModelSpec bare = spec;
    for (JointSpec& j : bare.joints) {
      j.compliance_rad_per_nm = 0.0;
      j.harmonics_rad.setZero();
    }
    const RobotModel fitted_only = RobotModel::Build(bare);
    Eigen::VectorXd sum = eps;
    for (size_t t = 0; t < model.joint_terms().size(); ++t) {
      const JointTermParameter& term = model.joint_terms()[t];
      const JointSpec& joint = spec.joints[static_cast<size_t>(term.joint)];
      sum[model.num_geometric_parameters() + static_cast<Eigen::Index>(t)] +=
          term.kind == JointTermParameter::Kind::kCompliance ? joint.compliance_rad_per_nm
          : term.kind == JointTermParameter::Kind::kSin      ? joint.harmonics_rad[2 * (term.order - 1)]
                                                             : joint.harmonics_rad[2 * term.order - 1];
    }
    KinematicsWorkspace bare_ws(fitted_only);
    EXPECT_LT(LargestPoseDifference(ForwardKinematics(fitted_only, q, sum, &bare_ws, payload), at), 1e-9);
  }
}

TEST(FixedJointTermTest, APreparedDeflectionMovesTheChainExactlyAsTheCommandAndPayloadDo) {
  // A fit prepares each pose's deflection once (PrepareDeflection) and evaluates it at many error parameters: the
  // same numbers, bit for bit, as deflecting from the command and payload each time. (The identification Jacobian
  // from a payload prepares it too: FittedTermsStackOnHeldOnes... checks it against finite differences.)
  const RobotModel model = RobotModel::Build(HeldAndFittedTerms());
  Rng rng(51);
  const Payload payload{6.0, Eigen::Vector3d(10, 40, 80)};
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 4, 53)) {
    const PreparedDeflection prepared = PrepareDeflection(model, q, payload);
    for (const Eigen::VectorXd& eps : {Eigen::VectorXd(), RandomErrorsWithTerms(model, &rng)}) {
      EXPECT_EQ(JointDeflection(model, prepared, eps), JointDeflection(model, q, eps, payload));
      KinematicsWorkspace a(model), b(model);
      EXPECT_EQ(ForwardKinematics(model, q, eps, &a, prepared).matrix(),
                ForwardKinematics(model, q, eps, &b, payload).matrix());
      EXPECT_EQ(a.q_effective, b.q_effective);
    }
    EXPECT_THROW(JointDeflection(model, prepared, Eigen::VectorXd::Zero(3)), std::invalid_argument);
  }
  // A robot that does not deflect prepares nothing and moves as its commands say.
  const RobotModel rigid = RobotModel::Build(PresetSpec("ur5e"));
  for (const Eigen::VectorXd& q : test::RandomConfigurations(rigid, 2, 55)) {
    const PreparedDeflection prepared = PrepareDeflection(rigid, q, payload);
    EXPECT_EQ(prepared.held.size(), 0);
    const Eigen::VectorXd eps = Eigen::VectorXd::Constant(rigid.num_error_parameters(), 1e-3);
    EXPECT_EQ(JointDeflection(rigid, prepared, eps), JointDeflection(rigid, q, eps, payload));
    KinematicsWorkspace a(rigid), b(rigid);
    EXPECT_EQ(ForwardKinematics(rigid, q, eps, &a, prepared).matrix(),
              ForwardKinematics(rigid, q, eps, &b, payload).matrix());
  }
}

TEST(FixedJointTermTest, ARegisteredCompliantCalibrationNeedsNoJointTermsOfItsOwn) {
  // Noise-free truth with compliance and harmonics; calibrated once with them, the result registered as a robot;
  // a geometric fit of that robot on new measurements then explains them (to round-off) and finds nothing left.
  const RobotModel nominal = Preset("ur5e");
  VirtualCell cell(nominal, NoiseFreeCompliantCell(51));
  const Calibration first = FitCompliantly(&cell, nominal, 300);
  ASSERT_NE(first.summary.termination, Termination::kFailure) << first.summary.message;
  RobotModelSpec spec = CalibratedTransformSpec(first.model, first.errors);
  spec.name = "ur5e-calibrated";
  const RobotModel robot = RobotModel::Build(spec);
  const std::vector<Measurement> fresh = MeasureUnder(&cell, robot, 60, 302, kPayloadC);
  IdentificationOptions options;
  options.reject_outliers = false;
  options.estimate_model_error = false;
  const Calibration again = Identify(robot, fresh, options);
  ASSERT_NE(again.summary.termination, Termination::kFailure) << again.summary.message;
  // Left: the torques' chain (see above), some 1e-3 mm against deflections of 0.3 mm; a hundredth of them here.
  EXPECT_LT(again.summary.before.max_position_mm, 3e-3) << again.summary.FullReport();
  EXPECT_LT(again.errors.head(again.model.num_geometric_parameters()).cwiseAbs().maxCoeff(), 3e-3);
  // The same robot without its held terms is off by the deflections (tenths of a mm).
  RobotModelSpec rigid = spec;
  for (JointSpec& j : rigid.joints) {
    j.compliance_rad_per_nm = 0.0;
    j.harmonics_rad.setZero();
  }
  const Calibration without = Identify(RobotModel::Build(rigid), fresh, options);
  EXPECT_GT(without.summary.before.max_position_mm, 0.05) << without.summary.FullReport();
}

// The implausibility of a joint term is judged on the joint's whole term, held + fitted: a large correction of a
// held term to a plausible total is fine, a plausible correction to an implausible total is not.
TEST(FixedJointTermTest, ImplausibleJointTermsAreJudgedOnHeldPlusFitted) {
  const auto fit = [](double held_deg, double correction_deg) {
    RobotModelSpec spec = PresetSpec("ur5e");
    spec.joints[1].harmonics_rad[0] = held_deg * kRadPerDeg;
    const RobotModel robot = RobotModel::Build(spec).WithErrorTerms({.compliance = false, .joint_harmonics = 1});
    Eigen::VectorXd truth = Eigen::VectorXd::Zero(robot.num_error_parameters());
    truth[robot.ParameterIndex(robot.joint_name(1) + ".sin1")] = correction_deg * kRadPerDeg;
    std::vector<Measurement> shots;
    for (const Eigen::VectorXd& q : test::RandomConfigurations(robot, 60, 61)) {
      KinematicsWorkspace ws(robot);
      shots.push_back({q, ForwardKinematics(robot, q, truth, &ws), -1, Payload()});
    }
    IdentificationOptions options;
    options.reject_outliers = false;
    options.estimate_model_error = false;
    return Identify(robot, shots, options);
  };
  const Calibration plausible = fit(-0.3, 0.8);  // total 0.5 deg
  ASSERT_NE(plausible.summary.termination, Termination::kFailure) << plausible.summary.message;
  EXPECT_TRUE(plausible.summary.implausible_joint_terms.empty()) << plausible.summary.FullReport();
  EXPECT_EQ(plausible.summary.termination, Termination::kConvergence) << plausible.summary.message;
  const Calibration implausible = fit(0.5, 0.4);  // total 0.9 deg, beyond 0.573
  ASSERT_EQ(implausible.summary.implausible_joint_terms.size(), 1u) << implausible.summary.FullReport();
  EXPECT_THAT(implausible.summary.implausible_joint_terms[0], ::testing::HasSubstr("held 0.5"));
  EXPECT_EQ(implausible.summary.termination, Termination::kDegraded);
}

TEST(FixedJointTermTest, BadHeldTermsAreRefusedByField) {
  auto refused_field = [](const RobotModelSpec& spec) -> std::string {
    try {
      RobotModel::Build(spec);
    } catch (const InvalidModelError& e) {
      return e.errors().at(0).field;
    }
    return "accepted";
  };
  RobotModelSpec spec = PresetSpec("ur5e");
  spec.joints[1].compliance_rad_per_nm = 2.0 * kImplausibleComplianceRadPerNm;
  EXPECT_EQ(refused_field(spec), "joints[1].compliance");
  spec = PresetSpec("ur5e");
  spec.joints[1].compliance_rad_per_nm = std::nan("");
  EXPECT_EQ(refused_field(spec), "joints[1].compliance");
  spec = PresetSpec("ur5e");
  spec.joints[4].harmonics_rad[2] = -2.0 * kImplausibleHarmonicRad;
  EXPECT_EQ(refused_field(spec), "joints[4].harmonics");
  spec = PresetSpec("ur5e");
  spec.joints[4].harmonics_rad[0] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(refused_field(spec), "joints[4].harmonics");
  spec = PresetSpec("ur5e");
  for (JointSpec& j : spec.joints) j.mass_kg = 0.0;
  spec.joints[1].compliance_rad_per_nm = 1e-5;
  EXPECT_EQ(refused_field(spec), "joints");
  spec.joints[1].compliance_rad_per_nm = 0.0;
  spec.joints[1].harmonics_rad[0] = 1e-4;  // a harmonic needs no masses
  EXPECT_EQ(refused_field(spec), "accepted");
  spec = PresetSpec("grinder5");
  int prismatic = -1;
  for (size_t i = 0; i < spec.joints.size(); ++i) {
    if (spec.joints[i].type == JointType::kPrismatic) prismatic = static_cast<int>(i);
  }
  ASSERT_GE(prismatic, 0);
  spec.joints[static_cast<size_t>(prismatic)].harmonics_rad[1] = 1e-4;
  EXPECT_EQ(refused_field(spec), "joints[" + std::to_string(prismatic) + "].type");
}

}  // namespace
}  // namespace robocal
