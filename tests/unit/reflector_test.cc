// Several reflectors on the tool: the point Jacobian against finite differences, the identifiable sets with one
// and with three reflectors (three give a position-only tracker the tool's orientation), exact recovery from
// noise-free shots, and bad reflector data named.
#include <cmath>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "robocal/core/error_model.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/reflectors.h"
#include "robocal/core/virtual_cell.h"
#include "test_util.h"

namespace robocal {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Not;

// Three nests on a tool plate, 60 mm from the flange axis, 20 mm out: not on one line.
std::vector<Reflector> ThreeNests(bool fixed) {
  return {{"smr1", {60.0, 0.0, 20.0}, fixed}, {"smr2", {-30.0, 52.0, 20.0}, fixed}, {"smr3", {-30.0, -52.0, 20.0}, fixed}};
}

TEST(ReflectorGeometryTest, PointRowsMatchFiniteDifferences) {
  // A robot with a tool, so that the flange and the tool frame differ.
  RobotModelSpec spec = Preset("ur5e").spec();
  spec.T_flange_tool = TransformFromXyzRpy({10.0, -5.0, 120.0}, {0.1, -0.2, 0.3});
  const RobotModel model = RobotModel::Build(spec);
  Rng rng(3);
  const Eigen::VectorXd q = RandomConfiguration(model, &rng);
  const Eigen::VectorXd eps = test::RandomErrors(model, &rng);
  const std::vector<Reflector> reflectors = ThreeNests(false);
  const Eigen::VectorXd offsets = Eigen::Vector3d(0.2, -0.1, 0.3).replicate(3, 1);
  const int n = model.num_error_parameters();
  KinematicsWorkspace ws(model);
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE(k);
    const auto point = [&](const Eigen::VectorXd& x) {
      KinematicsWorkspace w(model);
      Eigen::VectorXd o = offsets;
      o.segment<3>(3 * k) += x.tail<3>();
      const Transform tool = ForwardKinematics(model, q, x.head(n), &w);
      return Eigen::VectorXd(AtReflector(tool, ReflectorsInTool(model, reflectors, o)[k]).translation());
    };
    Eigen::VectorXd x(n + 3);
    x << eps, Eigen::Vector3d::Zero();
    Eigen::VectorXd h(n + 3);
    for (int j = 0; j < n + 3; ++j) h[j] = j < n && !RobotModel::IsTranslationParameter(j) ? 1e-7 : 1e-5;
    const Eigen::MatrixXd numeric = test::CentralDifferences(point, x, h);
    Eigen::MatrixXd pose(6, n), rows(3, n);
    IdentificationJacobian(model, q, eps, MeasurementType::kPose, &ws, pose);
    ReflectorRows(ws.T_world_tool, ReflectorsInTool(model, reflectors, offsets)[k], pose, rows);
    EXPECT_LT(test::MaxRelativeColumnError(rows, numeric.leftCols(n)), 1e-6);
    EXPECT_LT((ReflectorOffsetRows(model, ws.T_world_tool) - numeric.rightCols<3>()).cwiseAbs().maxCoeff(), 1e-8);
  }
  // The names of the fit's index space.
  EXPECT_EQ(ParameterName(model, reflectors, n + 4), "reflector.smr2.dy");
  EXPECT_EQ(ParameterName(model, reflectors, 3), model.parameter_name(3));
  EXPECT_THROW(ParameterName(model, reflectors, n + 9), std::out_of_range);
}

// One reflector (the tool point) leaves the tool's orientation unobserved; three held at known positions
// observe it, so a position-only tracker identifies what pose measurements do; three free ones add their
// shape (3 of their 9 offsets), the tool frame taking their common motion.
TEST(ReflectorIdentifiabilityTest, ThreeReflectorsIdentifyTheOrientationDependentParameters) {
  for (const std::string preset : {"ur5e", "puma560"}) {
    SCOPED_TRACE(preset);
    const RobotModel model = Preset(preset);
    const int n = model.num_error_parameters();
    const IdentifiabilitySummary one = FindIdentifiableParameters(model, MeasurementType::kPosition);
    const IdentifiabilitySummary pose = FindIdentifiableParameters(model, MeasurementType::kPose);
    IdentifiabilityOptions held;
    held.reflectors = ThreeNests(true);
    const IdentifiabilitySummary three = FindIdentifiableParameters(model, MeasurementType::kPosition, held);
    IdentifiabilityOptions free;
    free.reflectors = ThreeNests(false);
    const IdentifiabilitySummary three_free = FindIdentifiableParameters(model, MeasurementType::kPosition, free);
    ASSERT_EQ(one.termination, Termination::kConvergence) << one.message;
    ASSERT_EQ(three.termination, Termination::kConvergence) << three.FullReport();
    ASSERT_EQ(three_free.termination, Termination::kConvergence) << three_free.FullReport();
    RecordProperty(preset + "_counts", std::to_string(one.identifiable.size()) + "/" +
                                           std::to_string(three.identifiable.size()) + "/" +
                                           std::to_string(three_free.identifiable.size()));
    // 6R: 4 R + 2 P + 6 = 30 with pose measurements, 3 fewer with one point (the tool's orientation).
    EXPECT_EQ(pose.identifiable.size(), 30u);
    EXPECT_EQ(one.identifiable.size(), 27u);
    EXPECT_EQ(three.identifiable.size(), pose.identifiable.size());
    EXPECT_EQ(three_free.identifiable.size(), pose.identifiable.size() + 3);
    // As many as pose measurements identify (the representatives of equivalent parameters the pivoting picks
    // may differ), the tool's tilts among them.
    for (const char* orientation : {"tool.rx", "tool.ry"}) {
      EXPECT_THAT(one.identifiable_names, Not(Contains(std::string(orientation))));
      EXPECT_THAT(three.identifiable_names, Contains(std::string(orientation)));
    }
    // The held reflectors' offsets are dropped as held, not as unobservable.
    int held_dropped = 0;
    for (const DroppedParameter& d : three.dropped) {
      if (d.index >= n) {
        ++held_dropped;
        EXPECT_EQ(d.reason, "held at its given position (fixed reflector)");
      }
    }
    EXPECT_EQ(held_dropped, 9);
  }
}

// Noise-free shots of three reflectors at 20 poses: the calibrated robot predicts every reflector and, with the
// reflectors held, the tool's orientation on fresh configurations; one reflector cannot give the orientation.
TEST(ReflectorRecoveryTest, NoiseFreeShotsOfThreeReflectorsRecoverTheTool) {
  const RobotModel model = Preset("ur5e");
  const std::vector<Eigen::VectorXd> fresh = test::RandomConfigurations(model, 20, 77);
  const auto orientation_error = [&](const Calibration& cal, const VirtualCell& cell) {
    KinematicsWorkspace ws(cal.model);
    double worst = 0.0;
    for (const Eigen::VectorXd& q : fresh) {
      const Transform& predicted = ForwardKinematics(cal.model, q, cal.errors, &ws);
      worst = std::max(worst, RotationVector(predicted.linear() * cell.TruePose(q).linear().transpose()).norm());
    }
    return worst;
  };
  const auto reflector_error = [&](const Calibration& cal, const VirtualCell& cell) {
    KinematicsWorkspace ws(cal.model);
    const std::vector<Eigen::Vector3d> fitted = ReflectorsInTool(model, cal.reflectors, Eigen::VectorXd());
    const std::vector<Eigen::Vector3d> truth =
        ReflectorsInTool(model, cell.options().reflectors, cell.true_reflector_errors());
    double worst = 0.0;
    for (const Eigen::VectorXd& q : fresh) {
      const Transform& predicted = ForwardKinematics(cal.model, q, cal.errors, &ws);
      for (size_t k = 0; k < fitted.size(); ++k) {
        worst = std::max(worst, (predicted * fitted[k] - cell.TruePose(q) * truth[k]).norm());
      }
    }
    return worst;
  };
  for (const bool fixed : {true, false}) {
    SCOPED_TRACE(fixed ? "held" : "free");
    VirtualCellOptions o;
    o.seed = 12;
    o.noise = {0.0, 0.0, std::nullopt};
    o.shots_per_pose = 1;
    o.reflectors = ThreeNests(fixed);
    VirtualCell cell(model, o);
    const std::vector<Measurement> shots = cell.MeasureAll(test::RandomConfigurations(model, 20, 5));
    ASSERT_EQ(shots.size(), 60u);
    EXPECT_EQ(shots[4].reflector, 1);
    IdentificationOptions fit;
    fit.measurement_type = MeasurementType::kPosition;
    fit.reflectors = o.reflectors;
    const Calibration cal = Identify(model, shots, fit);
    ASSERT_EQ(cal.summary.termination, Termination::kConvergence) << cal.summary.FullReport();
    EXPECT_LT(reflector_error(cal, cell), 1e-6);
    if (fixed) {
      EXPECT_EQ(cal.summary.num_parameters, 30);
      EXPECT_LT(orientation_error(cal, cell), 1e-9);
    } else {
      EXPECT_EQ(cal.summary.num_parameters, 33);
      // Free offsets: the identified positions are where the true nests are, seen from the calibrated tool.
      ASSERT_EQ(cal.reflectors.size(), 3u);
    }
  }
  // One reflector: its point is matched, the tool's orientation is not observed.
  VirtualCellOptions o;
  o.seed = 12;
  o.noise = {0.0, 0.0, std::nullopt};
  o.shots_per_pose = 1;
  VirtualCell cell(model, o);
  IdentificationOptions fit;
  fit.measurement_type = MeasurementType::kPosition;
  const Calibration one = Identify(model, cell.MeasureAll(test::RandomConfigurations(model, 20, 5)), fit);
  ASSERT_EQ(one.summary.termination, Termination::kConvergence) << one.summary.FullReport();
  EXPECT_GT(orientation_error(one, cell), 1e-4);
}

// Free nests leave the tool frame's place among them open (a gauge freedom): what moves every nest rigidly
// with the flange is explained by their offsets, and the tool site stays nominal. Then a robot whose true tool
// sits where the nominal says is calibrated at its tool point from nest shots alone; the fit says how it chose.
TEST(ReflectorGaugeTest, FreeNestsKeepTheToolSiteNominal) {
  const RobotModel model = Preset("ur5e");
  const int n = model.num_error_parameters();
  IdentifiabilityOptions free;
  free.reflectors = ThreeNests(false);
  const IdentifiabilitySummary id = FindIdentifiableParameters(model, MeasurementType::kPosition, free);
  ASSERT_EQ(id.termination, Termination::kConvergence) << id.FullReport();
  EXPECT_EQ(id.identifiable.size(), 33u);
  for (int k = 0; k < 9; ++k) EXPECT_THAT(id.identifiable, Contains(n + k));
  for (const DroppedParameter& d : id.dropped) {
    SCOPED_TRACE(d.name);
    EXPECT_LT(d.index, n);
    if (d.name.rfind("tool.", 0) == 0) {
      EXPECT_THAT(d.reason, HasSubstr("reflector."));
    }
  }
  for (const char* site : {"tool.dx", "tool.dy", "tool.dz", "tool.rx", "tool.ry", "tool.rz"}) {
    EXPECT_THAT(id.identifiable_names, Not(Contains(std::string(site))));
  }

  // Shots of a true robot whose errors leave alone what the nests take over (the tool site, the last joint's
  // offset along and turn about its axis), with hidden nest offsets.
  Rng rng(21);
  Eigen::VectorXd truth = test::RandomErrors(model, &rng, 0.2, 3.5e-4);  // the virtual cell's magnitudes
  for (const char* held : {"joint6.dz", "joint6.rz", "tool.dx", "tool.dy", "tool.dz", "tool.rx", "tool.ry", "tool.rz"}) {
    truth[model.ParameterIndex(held)] = 0.0;
  }
  Eigen::VectorXd offsets(9);
  for (int k = 0; k < 9; ++k) offsets[k] = 0.5 * rng.Normal();
  const std::vector<Eigen::Vector3d> true_nests = ReflectorsInTool(model, free.reflectors, offsets);
  KinematicsWorkspace ws(model);
  std::vector<Measurement> shots;
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 20, 5)) {
    const Transform tool = ForwardKinematics(model, q, truth, &ws);
    for (int k = 0; k < 3; ++k) {
      Measurement m;
      m.joints = q;
      m.T_world_tool = AtReflector(tool, true_nests[k]);
      m.reflector = k;
      shots.push_back(m);
    }
  }
  IdentificationOptions fit;
  fit.measurement_type = MeasurementType::kPosition;
  fit.reflectors = free.reflectors;
  const Calibration cal = Identify(model, shots, fit);
  ASSERT_EQ(cal.summary.termination, Termination::kConvergence) << cal.summary.FullReport();
  EXPECT_THAT(cal.summary.message, HasSubstr("not the tool point: joint6.dz, joint6.rz, tool.dx"));
  // The nests are matched exactly (residual ~1e-13 mm); the tool point and the nests' positions to second
  // order in the errors: the kept parameters stand for the dropped equivalent ones (joint6.dy for joint5.dz,
  // ...) exactly only to first order, and the nests take up the rest (0.2 mm x 3.5e-4 rad ~ 0.1 um here). An
  // arbitrary gauge is off by the size of the errors themselves (tens of um).
  double worst = 0.0;
  for (const Eigen::VectorXd& q : test::RandomConfigurations(model, 20, 77)) {
    const Eigen::Vector3d predicted = ForwardKinematics(cal.model, q, cal.errors, &ws).translation();
    worst = std::max(worst, (predicted - ForwardKinematics(model, q, truth, &ws).translation()).norm());
  }
  RecordProperty("tool_point_error_mm", std::to_string(worst));
  EXPECT_LT(worst, 5e-4);
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT((cal.reflectors[k].position_mm - free.reflectors[k].position_mm - offsets.segment<3>(3 * k)).norm(), 5e-4);
  }
}

// Two held nests observe the tool's turn about every axis but the line through them: the fit says so.
TEST(ReflectorGaugeTest, TwoHeldNestsSayWhatTheyLeaveUnobserved) {
  const RobotModel model = Preset("ur5e");
  VirtualCellOptions o;
  o.seed = 5;
  o.noise = {0.0, 0.0, std::nullopt};
  o.shots_per_pose = 1;
  o.reflectors = {ThreeNests(true)[0], ThreeNests(true)[1]};
  VirtualCell cell(model, o);
  IdentificationOptions fit;
  fit.measurement_type = MeasurementType::kPosition;
  fit.reflectors = o.reflectors;
  const Calibration two = Identify(model, cell.MeasureAll(test::RandomConfigurations(model, 20, 5)), fit);
  ASSERT_EQ(two.summary.termination, Termination::kConvergence) << two.summary.FullReport();
  EXPECT_THAT(two.summary.message,
              HasSubstr("the reflector nests do not observe the tool's full orientation (29 parameters against 30"));
  // Three not on one line: nothing to say.
  o.reflectors = ThreeNests(true);
  VirtualCell three_cell(model, o);
  fit.reflectors = o.reflectors;
  const Calibration three = Identify(model, three_cell.MeasureAll(test::RandomConfigurations(model, 20, 5)), fit);
  EXPECT_THAT(three.summary.message, Not(HasSubstr("do not observe")));
}

// A nest the campaign never shot is dropped by name; the others are fitted.
TEST(ReflectorGaugeTest, AnUnmeasuredNestIsDroppedByName) {
  const RobotModel model = Preset("ur5e");
  const int n = model.num_error_parameters();
  VirtualCellOptions o;
  o.seed = 4;
  o.noise = {0.0, 0.0, std::nullopt};
  o.shots_per_pose = 1;
  o.reflectors = ThreeNests(true);
  VirtualCell cell(model, o);
  std::vector<Measurement> shots;
  for (const Measurement& m : cell.MeasureAll(test::RandomConfigurations(model, 20, 5))) {
    if (m.reflector != 2) shots.push_back(m);
  }
  IdentificationOptions fit;
  fit.measurement_type = MeasurementType::kPosition;
  fit.reflectors = o.reflectors;
  fit.reflectors[2].fixed = false;
  const Calibration cal = Identify(model, shots, fit);
  ASSERT_EQ(cal.summary.termination, Termination::kConvergence) << cal.summary.FullReport();
  int unmeasured = 0;
  for (const DroppedParameter& d : cal.summary.dropped) {
    if (d.index >= n + 6) {
      ++unmeasured;
      EXPECT_EQ(d.reason, "reflector 'smr3' has no measurements");
    }
  }
  EXPECT_EQ(unmeasured, 3);
  // As many parameters as the two measured nests identify on their own.
  IdentifiabilityOptions two;
  two.reflectors = {o.reflectors[0], o.reflectors[1]};
  EXPECT_EQ(cal.summary.num_parameters,
            static_cast<int>(FindIdentifiableParameters(model, MeasurementType::kPosition, two).identifiable.size()));
  EXPECT_EQ(cal.reflectors[2].position_mm, o.reflectors[2].position_mm);
}

TEST(ReflectorFailureTest, BadReflectorDataIsNamed) {
  const RobotModel model = Preset("ur5e");
  IdentificationOptions fit;
  fit.measurement_type = MeasurementType::kPosition;
  fit.reflectors = ThreeNests(false);
  std::string error;
  ASSERT_TRUE(fit.IsValid(&error)) << error;
  IdentificationOptions pose = fit;
  pose.measurement_type = MeasurementType::kPose;
  EXPECT_FALSE(pose.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("reflectors need position measurements"));
  IdentificationOptions twice = fit;
  twice.reflectors[2].id = "smr1";
  EXPECT_FALSE(twice.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("reflectors[2].id \"smr1\" is given twice"));
  IdentificationOptions unnamed = fit;
  unnamed.reflectors[1].id = "";
  EXPECT_FALSE(unnamed.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("reflectors[1].id"));
  IdentificationOptions nan = fit;
  nan.reflectors[0].position_mm.x() = NAN;
  EXPECT_FALSE(nan.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("reflectors[0].position_mm"));

  VirtualCellOptions o;
  o.noise = {0.0, 0.0, std::nullopt};
  o.shots_per_pose = 1;
  o.reflectors = fit.reflectors;
  VirtualCell cell(model, o);
  std::vector<Measurement> shots = cell.MeasureAll(test::RandomConfigurations(model, 15, 5));
  shots[7].reflector = 3;
  Calibration cal = Identify(model, shots, fit);
  EXPECT_EQ(cal.summary.termination, Termination::kFailure);
  EXPECT_THAT(cal.summary.message, HasSubstr("measurements[7]: reflector 3 is not one of the 3 reflectors"));
  shots[7].reflector = 0;
  fit.reflectors.clear();
  cal = Identify(model, shots, fit);
  EXPECT_EQ(cal.summary.termination, Termination::kFailure);
  EXPECT_THAT(cal.summary.message, HasSubstr("but the fit has no reflectors"));
}

}  // namespace
}  // namespace robocal
