// Joint errors beyond geometry: gravity torques against hand-computed cases, their derivatives and the new
// Jacobian columns against finite differences, recovery from a simulated cell, compensation under a payload the
// calibration never saw, and the model choice by cross-validation.
#include <cmath>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/compensation.h"
#include "robocal/core/identification.h"
#include "robocal/core/joint_errors.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/model_choice.h"
#include "robocal/core/presets.h"
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
      const double tau1 = -g * (m1 * c1 * std::cos(q1) + m2 * (l1 * std::cos(q1) + c2 * x12) +
                                mp * (l1 * std::cos(q1) + l2 * x12));
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
      const Eigen::MatrixXd numeric = test::CentralDifferences(
          [&](const Eigen::VectorXd& x) { return GravityTorques(model, x, payload); }, q,
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
  eps.head(model.num_geometric_parameters()) =
      test::RandomErrors(model.WithErrorTerms({}), rng);
  for (int k = model.num_geometric_parameters(); k < model.num_error_parameters(); ++k) {
    eps[k] = (model.parameter_unit(k) == ParameterUnit::kRadPerNm ? 1e-5 : 1e-4) * rng->Normal();
  }
  return eps;
}

TEST(JointTermJacobianTest, IdentificationJacobianMatchesFiniteDifferences) {
  for (const char* name : {"ur5e", "puma560", "grinder5"}) {
    const RobotModel model = Preset(name).WithErrorTerms({true, 2});
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
        steps[k] = model.parameter_unit(k) == ParameterUnit::kMm ? 1e-3
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
  const RobotModel model = Preset("ur5e").WithErrorTerms({true, 2});
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
  const RobotModel model = Preset("puma560").WithErrorTerms({true, 1});
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

TEST(JointTermRecoveryTest, NoiseFreeRecoversComplianceHarmonicsAndGeometryAndCompensatesUnderANewPayload) {
  const RobotModel nominal = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 21;
  o.noise.position_mm = 0.0;
  o.noise.orientation_rad = 0.0;
  o.shots_per_pose = 1;
  o.compliance_deflection_mm = 0.3;
  o.joint_harmonic_sigma_rad = 5e-5;
  o.joint_harmonic_min_order = 1;
  o.joint_harmonic_max_order = 2;
  VirtualCell cell(nominal, o);
  std::vector<Measurement> shots = MeasureUnder(&cell, nominal, 80, 100, kPayloadA);
  const std::vector<Measurement> loaded = MeasureUnder(&cell, nominal, 80, 101, kPayloadB);
  shots.insert(shots.end(), loaded.begin(), loaded.end());
  IdentificationOptions options;
  options.reject_outliers = false;
  options.estimate_model_error = false;
  const Calibration c = Identify(nominal.WithErrorTerms({true, 2}), shots, options);
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
  for (const Measurement& m : held_out) floor += (m.T_world_tool.translation() - cell.TruePose(m.joints, kPayloadC).translation()).norm();
  floor /= static_cast<double>(held_out.size());
  const Calibration compliant = Identify(nominal.WithErrorTerms({true, 0}), shots);
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
  const Calibration compliant = Identify(nominal.WithErrorTerms({true, 0}), shots);
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
  const RobotModel model = Preset("ur5e").WithErrorTerms({true, 0});
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
  const Calibration c = Identify(massless.WithErrorTerms({true, 0}), shots);
  EXPECT_EQ(c.summary.termination, Termination::kFailure);
  EXPECT_THAT(c.summary.message, ::testing::HasSubstr("model.compliance"));
  EXPECT_EQ(ModelCandidates(massless, {}).size(), 3u);  // no compliance candidates without masses
  VirtualCellOptions o = NoisyCell(62, 0.3);
  EXPECT_THROW(VirtualCell(massless, o), std::invalid_argument);
  std::string error;
  EXPECT_FALSE((Payload{-2.0, Eigen::Vector3d::Zero()}.IsValid("payload", &error)));
  EXPECT_EQ(error.rfind("payload.mass_kg", 0), 0u);
}

}  // namespace
}  // namespace robocal
