// The compensation of whole programs, independent of any controller's language: a test dialect of one target per
// line drives the engine. A calibration without errors gives the files back byte for byte; a calibration with
// errors compensates every target so that the calibrated robot lands on it (joint targets at the written joints'
// nominal pose, Cartesian targets where the controller's nominal inverse kinematics takes the written numbers);
// frames, failures, straight-move splitting, and the rotation conventions and number formats behind it.
#include "robocal/programs/compensate_program.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "robocal/core/arm_kinematics.h"
#include "robocal/core/error_model.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/units.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
namespace {

using ::testing::HasSubstr;

// The test dialect, one target per line, '#' starts a comment:
//   J name a1 .. a6                    a joint target (deg), no motion
//   P name x y z a b c s e w [tool=T] [base=B]   a Cartesian target (mm, KUKA's Z Y' X'' deg) with flags
//   L x y z a b c                      a straight move to an inline Cartesian target (no flags)
//   M name                             a joint move to a declared target
//   C x y z a b c ; x y z a b c        a circular move through an inline via point to an inline end
ParsedProgram ReadTest(const std::vector<ProgramFile>& files) {
  ParsedProgram program;
  for (std::size_t f = 0; f < files.size(); ++f) {
    const SourceText source(files[f], static_cast<int>(f));
    for (int line = 1; line <= source.line_count(); ++line) {
      const std::string_view text = source.Line(line);
      const std::size_t start = source.LineStart(line);
      std::size_t pos = SkipBlanks(text, 0);
      if (pos >= text.size() || text[pos] == '#') continue;
      const char kind = text[pos];
      pos = SkipBlanks(text, pos + 1);
      auto word = [&]() {
        const std::size_t begin = pos;
        while (pos < text.size() && text[pos] != ' ' && text[pos] != '\t') ++pos;
        const std::string w(text.substr(begin, pos - begin));
        pos = SkipBlanks(text, pos);
        return w;
      };
      if (kind == 'C') {
        // A circle: via point, ';', end point, each a Cartesian target of its own in one statement.
        for (int point = 0; point < 2; ++point) {
          ProgramTarget t;
          t.file = static_cast<int>(f);
          t.line = line;
          t.kind = TargetKind::kCartesian;
          t.motion = Motion::kCircular;
          const std::size_t reference_begin = start + pos;
          for (int k = 0; k < 6; ++k) {
            const std::optional<ScannedNumber> number = ScanNumber(text, pos);
            if (!number) source.Fail(start + pos, "expected a number");
            t.values.push_back(number->value);
            t.spans.push_back({static_cast<int>(f), start + number->offset, number->length});
            pos = SkipBlanks(text, pos + number->length);
          }
          t.column = source.ColumnOf(t.spans.front().offset);
          const std::size_t reference_end = start + pos - (pos > 0 && text[pos - 1] == ' ' ? 1 : 0);
          program.motions.push_back({static_cast<int>(program.targets.size()), Motion::kCircular, static_cast<int>(f),
                                     line, start, start + text.size(), reference_begin, reference_end});
          program.targets.push_back(std::move(t));
          if (point == 0) {
            if (pos >= text.size() || text[pos] != ';') source.Fail(start + pos, "expected ';'");
            pos = SkipBlanks(text, pos + 1);
          }
        }
        continue;
      }
      if (kind == 'M') {
        const std::string name = word();
        for (std::size_t i = 0; i < program.targets.size(); ++i) {
          if (program.targets[i].name == name) {
            program.motions.push_back(
                {static_cast<int>(i), Motion::kJoint, static_cast<int>(f), line, start, start + text.size(), 0, 0});
            if (program.targets[i].motion == Motion::kNone) program.targets[i].motion = Motion::kJoint;
          }
        }
        continue;
      }
      ProgramTarget t;
      t.file = static_cast<int>(f);
      t.line = line;
      t.kind = kind == 'J' ? TargetKind::kJoint : TargetKind::kCartesian;
      if (kind != 'L') t.name = word();
      const std::size_t reference_begin = start + pos;
      const int count = kind == 'P' || kind == 'L' ? 6 : 6;
      for (int k = 0; k < count; ++k) {
        const std::optional<ScannedNumber> number = ScanNumber(text, pos);
        if (!number) source.Fail(start + pos, "expected a number");
        t.values.push_back(number->value);
        t.spans.push_back({static_cast<int>(f), start + number->offset, number->length});
        pos = SkipBlanks(text, pos + number->length);
      }
      t.column = source.ColumnOf(t.spans.front().offset);
      const std::size_t reference_end = start + pos;
      if (kind == 'P') {
        int flags[3];
        for (int& flag : flags) {
          const std::optional<ScannedNumber> number = ScanNumber(text, pos);
          if (!number) source.Fail(start + pos, "expected a flag");
          flag = static_cast<int>(number->value);
          pos = SkipBlanks(text, pos + number->length);
        }
        t.configuration = {flags[0], flags[1], flags[2]};
        t.configuration_applies = true;
        while (pos < text.size()) {
          const std::string w = word();
          if (w.rfind("tool=", 0) == 0) t.tool = w.substr(5);
          if (w.rfind("base=", 0) == 0) t.base = w.substr(5);
        }
      }
      if (kind == 'L') {
        t.motion = Motion::kLinear;
        program.motions.push_back({static_cast<int>(program.targets.size()), Motion::kLinear, static_cast<int>(f), line,
                                   start, start + text.size(), reference_begin, reference_end});
      }
      program.targets.push_back(std::move(t));
    }
  }
  return program;
}

std::string InlineTest(const ProgramTarget&, const std::vector<ProgramFile>&, const std::vector<double>& v) {
  std::string out;
  for (std::size_t k = 0; k < v.size(); ++k) {
    out += (k ? " " : "") + FormatInserted(v[k], k < 3 ? NumberUnit::kMm : NumberUnit::kDeg);
  }
  return out;
}

DialectSyntax TestDialect() {
  DialectSyntax d;
  d.name = "test";
  d.rotation = RotationConvention::kZyxIntrinsicDeg;
  d.read = &ReadTest;
  d.inline_target = &InlineTest;
  return d;
}

// A calibration as identification hands it back: the robot placed in a tracker frame, errors on every site.
Calibration MakeCalibration(const RobotModel& nominal, double scale, std::uint64_t seed) {
  Rng rng(seed);
  Eigen::VectorXd errors(nominal.num_error_parameters());
  for (int k = 0; k < errors.size(); ++k) {
    errors[k] = scale * (RobotModel::IsTranslationParameter(k) ? 0.3 * rng.Normal() : 1e-3 * rng.Normal());
  }
  const int tool_site = 6 * (nominal.num_error_sites() - 1);
  return Calibration{.model = nominal,
                     .errors = errors,
                     .parameters = {},
                     .covariance = {},
                     .T_world_base = nominal.T_world_base() * ErrorTransform(errors.data()),
                     .T_flange_tool = nominal.T_flange_tool() * ErrorTransform(errors.data() + tool_site),
                     .reflectors = {},
                     .summary = {}};
}

RobotModel Nominal(const std::string& preset) {
  RobotModelSpec spec = PresetSpec(preset);
  spec.T_world_base = TransformFromXyzRpy({2500.0, -800.0, 400.0}, {0.02, -0.01, 1.2});
  return RobotModel::Build(spec);
}

std::string Fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

// The nominal tool pose at q in the robot base as the test dialect writes it: "x y z a b c", positions with
// `position_decimals` (mm), KUKA's Z Y' X'' angles with 4 (deg).
std::string PoseValues(const RobotModel& nominal, const Eigen::VectorXd& q, int position_decimals = 3) {
  const Transform pose = nominal.T_world_base().inverse() * ForwardKinematics(nominal, q);
  const Eigen::Matrix3d R = pose.linear();
  const double b = std::asin(-R(2, 0)), a = std::atan2(R(1, 0), R(0, 0)), c = std::atan2(R(2, 1), R(2, 2));
  const Eigen::Vector3d p = pose.translation();
  return Fixed(p.x(), position_decimals) + " " + Fixed(p.y(), position_decimals) + " " +
         Fixed(p.z(), position_decimals) + " " + Fixed(a * kDegPerRad, 4) + " " + Fixed(b * kDegPerRad, 4) + " " +
         Fixed(c * kDegPerRad, 4);
}

// Joints where the arm is near a singularity (the smallest singular value of its pose Jacobian, orientation rows
// at 100 mm per rad, below 5 % of the largest), where a calibrated robot need not reach what the nominal one does
// (docs/compensation.md): the programs here keep away from them.
bool NearSingular(const RobotModel& model, const Eigen::VectorXd& q) {
  KinematicsWorkspace ws(model);
  Eigen::MatrixXd J(6, 6);
  JointJacobian(model, q, Eigen::VectorXd::Zero(model.num_error_parameters()), MeasurementType::kPose, &ws, J);
  J.bottomRows(3) *= 100.0;
  const Eigen::VectorXd sigma = Eigen::JacobiSVD<Eigen::MatrixXd>(J).singularValues();
  return sigma.minCoeff() < 0.05 * sigma.maxCoeff();
}

// A program of `count` joint and `count` Cartesian targets at random reachable joints, with comments, blank
// lines, odd spacing and both line ends; Cartesian targets carry the flags of the joints they came from.
ProgramFile MakeProgram(const RobotModel& nominal, int count, std::uint64_t seed) {
  const ArmSolver arm = *ArmSolver::For(nominal);
  Rng rng(seed);
  std::string text = "# a test program\r\n\n";
  for (int i = 0; i < count; ++i) {
    Eigen::VectorXd q(6);
    // Within the limits, and away from the wrist's singularity.
    auto draw = [&](int k, double lo, double hi) {
      const double lower = std::max(lo, 0.9 * nominal.lower_limits()[k]);
      const double upper = std::min(hi, 0.9 * nominal.upper_limits()[k]);
      return rng.Uniform(lower, upper);
    };
    do {
      for (int k = 0; k < 6; ++k) q[k] = draw(k, -2.0, 2.0);
      q[4] = draw(4, 0.3, 1.4) * (i % 2 ? 1.0 : -1.0);
    } while (NearSingular(nominal, q));
    text += "J j" + std::to_string(i);
    for (int k = 0; k < 6; ++k) text += (k % 2 ? "  " : " ") + Fixed(q[k] * kDegPerRad, 3);
    text += i % 3 ? "\n" : "\r\n";
    do {
      for (int k = 0; k < 6; ++k) q[k] = draw(k, -1.5, 1.5);
      q[4] = draw(4, 0.3, 1.4) * (i % 2 ? -1.0 : 1.0);
    } while (NearSingular(nominal, q));
    const ArmConfiguration flags = arm.ConfigurationOf(q);
    text += "P p" + std::to_string(i) + "\t" + PoseValues(nominal, q, 2) + "   " + std::to_string(flags.shoulder) +
            " " + std::to_string(flags.elbow) + " " + std::to_string(flags.wrist) + "  # from q\n";
  }
  return {"main.test", text};
}

// The controller's joints for written Cartesian values with flags: the nominal solution with those flags nearest
// `near`.
Eigen::VectorXd ControllerIk(const RobotModel& nominal, const Transform& T_base_tool, const ArmConfiguration& flags,
                             const Eigen::VectorXd& near) {
  Eigen::VectorXd best;
  for (const ArmSolution& s : ArmSolver::For(nominal)->Solve(T_base_tool, near)) {
    if (s.configuration != flags || s.position_error_mm > 1e-6) continue;
    Eigen::VectorXd q = s.joints;
    for (int k = 0; k < 6; ++k)
      q[k] += 2.0 * std::numbers::pi * std::round((near[k] - q[k]) / (2.0 * std::numbers::pi));
    if (best.size() == 0 || (q - near).norm() < (best - near).norm()) best = q;
  }
  return best;
}

std::string Failures(const ProgramCompensationResult& r) {
  std::string out;
  for (const CompensatedTarget& t : r.targets) {
    if (t.termination != Termination::kConvergence || !t.configuration_kept) {
      out += "line " + std::to_string(t.line) + ": " + ToString(t.termination) + " " + t.message + "\n";
    }
  }
  return out;
}

class ProgramLandingTest : public ::testing::TestWithParam<const char*> {};

TEST_P(ProgramLandingTest, ACalibrationWithoutErrorsGivesTheFilesBackByteForByte) {
  const RobotModel nominal = Nominal(GetParam());
  const Calibration calibration = MakeCalibration(nominal, 0.0, 1);
  const std::vector<ProgramFile> files = {MakeProgram(nominal, 25, 7)};
  const ProgramCompensationResult r = CompensateProgram(calibration, nominal, TestDialect(), files);
  ASSERT_EQ(r.files.size(), 1u);
  EXPECT_EQ(r.files[0].text, files[0].text);
  EXPECT_EQ(r.summary.targets, 50);
  EXPECT_EQ(r.summary.failed, 0) << Failures(r);
  EXPECT_EQ(r.summary.rewritten, 0);
  EXPECT_EQ(r.summary.termination, Termination::kConvergence);
}

TEST_P(ProgramLandingTest, TheCalibratedRobotLandsOnEveryTarget) {
  const RobotModel nominal = Nominal(GetParam());
  const Calibration calibration = MakeCalibration(nominal, 1.0, 2);
  const std::vector<ProgramFile> files = {MakeProgram(nominal, 25, 8)};
  const ProgramCompensationResult r = CompensateProgram(calibration, nominal, TestDialect(), files);
  ASSERT_EQ(r.files.size(), 1u);
  EXPECT_EQ(r.summary.failed, 0) << Failures(r);
  const ParsedProgram before = ReadTest(files);
  const ParsedProgram after = ReadTest(r.files);
  ASSERT_EQ(after.targets.size(), before.targets.size());
  const Transform T_base_world_nominal = nominal.T_world_base().inverse();
  const Transform T_base_world_calibrated = calibration.T_world_base.inverse();
  KinematicsWorkspace ws(calibration.model);
  int cartesian = 0;
  for (std::size_t i = 0; i < before.targets.size(); ++i) {
    const ProgramTarget& b = before.targets[i];
    const ProgramTarget& a = after.targets[i];
    // The numbers' format: at least 3 decimals in mm and 4 in degrees once rewritten.
    for (const NumberSpan& s : a.spans) {
      const std::string number = r.files[0].text.substr(s.offset, s.length);
      EXPECT_GE(number.size() - number.find('.') - 1, 3u) << number;
    }
    Eigen::VectorXd q(6);
    Transform programmed;
    if (b.kind == TargetKind::kJoint) {
      for (int k = 0; k < 6; ++k) q[k] = a.values[static_cast<std::size_t>(k)] * kRadPerDeg;
      Eigen::VectorXd written(6);
      for (int k = 0; k < 6; ++k) written[k] = b.values[static_cast<std::size_t>(k)] * kRadPerDeg;
      programmed = T_base_world_nominal * ForwardKinematics(nominal, written);
      // Nearest the written joints: a few hundredths of a degree for errors of this size.
      EXPECT_LT((q - written).cwiseAbs().maxCoeff() * kDegPerRad, 2.0);
    } else {
      ++cartesian;
      programmed = PoseFromValues(TestDialect(), b.values);
      const Transform written = PoseFromValues(TestDialect(), a.values);
      Eigen::VectorXd near(6);
      near.setZero();
      ASSERT_EQ(r.targets[i].joints.size(), 6) << "target " << i;
      q = ControllerIk(nominal, written, a.configuration, r.targets[i].joints);
      ASSERT_EQ(q.size(), 6) << "target " << i;
      // The same joints, to the rounding of the written numbers (5e-4 mm, 5e-5 deg).
      EXPECT_LT((q - r.targets[i].joints).norm(), 1e-4);
      // The written values are the nominal pose at the compensated joints: the correction is what moved.
      EXPECT_NEAR(r.targets[i].correction_mm, (written.translation() - programmed.translation()).norm(), 2e-3);
    }
    const Transform reached =
        T_base_world_calibrated * ForwardKinematics(calibration.model, q, calibration.errors, &ws);
    // The numbers are written with 3 decimals (mm) and 4 (deg): the landing error is their rounding, at most
    // a few micrometres at the tool (1e-4 deg at a reach of 1 m is 1.7 um per angle).
    EXPECT_LT((reached.translation() - programmed.translation()).norm(), 0.02) << "target " << i;
    EXPECT_LT(Eigen::AngleAxisd(reached.linear().transpose() * programmed.linear()).angle(), 1e-5);
    EXPECT_GT(r.targets[i].correction_mm, 0.01) << "target " << i << ": the errors move every target";
  }
  EXPECT_EQ(cartesian, 25);
}

INSTANTIATE_TEST_SUITE_P(SixAxisPresets, ProgramLandingTest, ::testing::Values("puma560", "ur5e"));

TEST(ProgramCompensationTest, ToolsAndBasesPlaceTheTargetsAndAnUnknownBaseIsRefusedWithItsLine) {
  const RobotModel nominal = Nominal("ur5e");
  const Calibration calibration = MakeCalibration(nominal, 1.0, 3);
  const std::string line = "P p1 100 -300 500 10 170 5 1 1 1 tool=2 base=7\n";
  ProgramCompensationOptions options;
  try {
    CompensateProgram(calibration, nominal, TestDialect(), {{"a.test", "# x\n" + line}}, options);
    FAIL() << "expected ProgramError";
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "a.test");
    EXPECT_EQ(e.line(), 2);
    EXPECT_THAT(e.reason(), HasSubstr("base '7'"));
  }
  options.bases["7"] = {50.0, 20.0, 10.0, 30.0, 0.0, 0.0};
  options.tools["2"] = {0.0, 0.0, 120.0, 0.0, 0.0, 0.0};
  const ProgramCompensationResult r =
      CompensateProgram(calibration, nominal, TestDialect(), {{"a.test", line}}, options);
  ASSERT_EQ(r.targets.size(), 1u);
  ASSERT_EQ(r.targets[0].termination, Termination::kConvergence) << r.targets[0].message;
  // Where the calibrated robot's own tool goes: the program's tool 120 mm further along the tool axis, in base 7.
  const Transform T_base_frame = PoseFromValues(TestDialect(), options.bases["7"]);
  const Transform T_tool0_tool = nominal.T_flange_tool().inverse() * PoseFromValues(TestDialect(), options.tools["2"]);
  const Transform programmed =
      T_base_frame * PoseFromValues(TestDialect(), {100, -300, 500, 10, 170, 5}) * T_tool0_tool.inverse();
  KinematicsWorkspace ws(calibration.model);
  const Transform reached = calibration.T_world_base.inverse() *
                            ForwardKinematics(calibration.model, r.targets[0].joints, calibration.errors, &ws);
  EXPECT_LT((reached.translation() - programmed.translation()).norm(), 1e-6);
  // Written back in the program's frame and tool: the nominal pose there.
  const ProgramTarget after = ReadTest(r.files).targets[0];
  const Transform written = T_base_frame * PoseFromValues(TestDialect(), after.values) * T_tool0_tool.inverse();
  const Transform nominal_pose = nominal.T_world_base().inverse() * ForwardKinematics(nominal, r.targets[0].joints);
  EXPECT_LT((written.translation() - nominal_pose.translation()).norm(), 2e-3);
  // A tool entry of the wrong size names itself.
  options.tools["2"] = {1.0, 2.0};
  EXPECT_THAT(
      [&] {
        CompensateProgram(calibration, nominal, TestDialect(), {{"a.test", line}}, options);
      },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("tools.2")));
}

TEST(ProgramCompensationTest, ATargetOutOfReachIsKeptOrRefusesTheProgram) {
  const RobotModel nominal = Nominal("ur5e");
  const Calibration calibration = MakeCalibration(nominal, 1.0, 4);
  const std::vector<ProgramFile> files = {{"a.test", "P far 5000 0 0 0 0 0 1 1 1\nJ j 0 -90 90 0 90 0\n"}};
  const ProgramCompensationResult kept = CompensateProgram(calibration, nominal, TestDialect(), files);
  ASSERT_EQ(kept.targets.size(), 2u);
  EXPECT_EQ(kept.targets[0].termination, Termination::kFailure);
  EXPECT_THAT(kept.targets[0].message, HasSubstr("does not reach"));
  EXPECT_FALSE(kept.targets[0].rewritten);
  EXPECT_TRUE(kept.targets[1].rewritten);
  EXPECT_EQ(kept.summary.failed, 1);
  EXPECT_EQ(kept.summary.termination, Termination::kDegraded);
  // The far target's line is as it was; the joint target's is not.
  EXPECT_EQ(kept.files[0].text.substr(0, 27), "P far 5000 0 0 0 0 0 1 1 1\n");
  EXPECT_NE(kept.files[0].text, files[0].text);
  ProgramCompensationOptions refuse;
  refuse.on_failure = OnFailure::kRefuse;
  // A program without targets is no program compensated: DEGRADED, and said.
  const ProgramCompensationResult empty =
      CompensateProgram(calibration, nominal, TestDialect(), {{"a.test", "# nothing here\n"}});
  EXPECT_EQ(empty.summary.termination, Termination::kDegraded);
  EXPECT_THAT(empty.summary.message, HasSubstr("no target"));
  EXPECT_THAT(kept.summary.message, ::testing::Not(HasSubstr("max_path_deviation_mm")));
  const ProgramCompensationResult refused = CompensateProgram(calibration, nominal, TestDialect(), files, refuse);
  EXPECT_TRUE(refused.files.empty());
  EXPECT_EQ(refused.summary.termination, Termination::kFailure);
  EXPECT_THAT(refused.summary.message, HasSubstr("a.test:1 far"));
}

TEST(ProgramCompensationTest, AStraightMoveIsSplitUntilEveryPieceIsWithinTheDeviation) {
  const RobotModel nominal = Nominal("ur5e");
  // Large errors, so that the controller's straight line between compensated ends leaves the calibrated path.
  const Calibration calibration = MakeCalibration(nominal, 8.0, 5);
  // Two poses on one branch (front, up, noflip: the first target's, which has no previous), half a metre apart.
  auto line = [&](const Eigen::VectorXd& q) { return "L " + PoseValues(nominal, q) + "\r\n"; };
  Eigen::VectorXd q1(6), q2(6);
  q1 << 0.2, -1.3, 1.6, -1.8, 1.5, 0.2;
  q2 << 1.0, -0.9, 1.1, -1.6, 1.3, 0.6;
  const std::string program = line(q1) + line(q2);
  ProgramCompensationOptions options;
  options.max_path_deviation_mm = 0.05;
  const ProgramCompensationResult r =
      CompensateProgram(calibration, nominal, TestDialect(), {{"a.test", program}}, options);
  ASSERT_EQ(r.summary.failed, 0) << Failures(r);
  EXPECT_EQ(r.summary.segments_checked, 1);
  EXPECT_GT(r.summary.inserted, 0);
  EXPECT_EQ(r.summary.segments_over_deviation, 0);
  // The inserted lines are the dialect's own statements with the file's line end, before the move they split.
  const ParsedProgram after = ReadTest(r.files);
  ASSERT_EQ(static_cast<int>(after.targets.size()), 2 + r.summary.inserted);
  EXPECT_EQ(r.files[0].text.find("\n"), r.files[0].text.find("\r\n") + 1);
  EXPECT_EQ(std::count(r.files[0].text.begin(), r.files[0].text.end(), '\n'),
            std::count(r.files[0].text.begin(), r.files[0].text.end(), '\r'));
  // Every piece now within the deviation: checked at each piece's midpoint as the controller moves there.
  const ArmSolver arm = *ArmSolver::For(nominal);
  KinematicsWorkspace ws(calibration.model);
  const Transform first = PoseFromValues(TestDialect(), ReadTest({{"a", program}}).targets[0].values);
  const Transform last = PoseFromValues(TestDialect(), ReadTest({{"a", program}}).targets[1].values);
  Eigen::VectorXd previous = r.targets.front().joints;
  for (std::size_t i = 0; i + 1 < after.targets.size(); ++i) {
    const Transform a = PoseFromValues(TestDialect(), after.targets[i].values);
    const Transform b = PoseFromValues(TestDialect(), after.targets[i + 1].values);
    Transform mid = Transform::Identity();
    mid.translation() = 0.5 * (a.translation() + b.translation());
    mid.linear() = Eigen::Quaterniond(a.linear()).slerp(0.5, Eigen::Quaterniond(b.linear())).toRotationMatrix();
    const Eigen::VectorXd q = ControllerIk(nominal, mid, arm.ConfigurationOf(previous), previous);
    ASSERT_EQ(q.size(), 6);
    const Transform reached =
        calibration.T_world_base.inverse() * ForwardKinematics(calibration.model, q, calibration.errors, &ws);
    // The programmed path: the straight line from the first to the last target.
    const Eigen::Vector3d d = last.translation() - first.translation();
    const Eigen::Vector3d v = reached.translation() - first.translation();
    const double off_line = (v - v.dot(d) / d.squaredNorm() * d).norm();
    EXPECT_LT(off_line, 0.05 + 1e-3) << "piece " << i;
    previous = q;
  }
  // Without the option nothing is inserted.
  const ProgramCompensationResult plain = CompensateProgram(calibration, nominal, TestDialect(), {{"a.test", program}});
  EXPECT_EQ(plain.summary.inserted, 0);
  EXPECT_EQ(plain.summary.segments_checked, 0);
}

TEST(ProgramCompensationTest, ACircularMoveBeyondTheDeviationIsSplitInTwoCirclesOnTheProgrammedArc) {
  const RobotModel nominal = Nominal("ur5e");
  const Calibration calibration = MakeCalibration(nominal, 8.0, 5);
  auto values = [&](const Eigen::VectorXd& q) { return PoseValues(nominal, q); };
  // Three poses on one branch (front, up, noflip), on a wide arc.
  Eigen::VectorXd q1(6), q2(6), q3(6);
  q1 << 0.2, -1.3, 1.6, -1.8, 1.5, 0.2;
  q2 << 0.7, -1.0, 1.2, -1.7, 1.4, 0.4;
  q3 << 1.2, -1.3, 1.6, -1.8, 1.3, 0.6;
  const std::string program = "L " + values(q1) + "\r\nC " + values(q2) + " ; " + values(q3) + "\r\n";
  ProgramCompensationOptions options;
  options.max_path_deviation_mm = 0.05;
  const ProgramCompensationResult r =
      CompensateProgram(calibration, nominal, TestDialect(), {{"a.test", program}}, options);
  ASSERT_EQ(r.summary.failed, 0) << Failures(r);
  EXPECT_EQ(r.summary.segments_checked, 1);
  EXPECT_EQ(r.summary.inserted, 3);
  // Two circles now, the first inserted before the second, with the file's line end.
  const ParsedProgram after = ReadTest(r.files);
  ASSERT_EQ(after.targets.size(), 5u);
  EXPECT_EQ(std::count(r.files[0].text.begin(), r.files[0].text.end(), '\n'), 3);
  EXPECT_EQ(std::count(r.files[0].text.begin(), r.files[0].text.end(), '\r'), 3);
  // The programmed arc: the circle through the three programmed points. Every written point of the new circles
  // is the nominal pose of joints at which the calibrated robot lies on it.
  const ParsedProgram before = ReadTest({{"a", program}});
  Eigen::Vector3d p[3];
  for (int k = 0; k < 3; ++k)
    p[k] = PoseFromValues(TestDialect(), before.targets[static_cast<std::size_t>(k)].values).translation();
  const Eigen::Vector3d d1 = p[1] - p[0], d2 = p[2] - p[0], normal = d1.cross(d2);
  const Eigen::Vector3d centre =
      p[0] + (d2.squaredNorm() * normal.cross(d1) + d1.squaredNorm() * d2.cross(normal)) / (2.0 * normal.squaredNorm());
  const double radius = (p[0] - centre).norm();
  const ArmSolver arm = *ArmSolver::For(nominal);
  KinematicsWorkspace ws(calibration.model);
  for (std::size_t i = 1; i < after.targets.size(); ++i) {
    const Transform written = PoseFromValues(TestDialect(), after.targets[i].values);
    const Eigen::VectorXd q =
        ControllerIk(nominal, written, arm.ConfigurationOf(r.targets[1].joints), r.targets[1].joints);
    ASSERT_EQ(q.size(), 6);
    const Eigen::Vector3d reached =
        (calibration.T_world_base.inverse() * ForwardKinematics(calibration.model, q, calibration.errors, &ws))
            .translation();
    // On the programmed circle: in its plane and at its radius, to the rounding of the written numbers.
    EXPECT_LT(std::abs((reached - centre).dot(normal.normalized())), 0.01) << i;
    EXPECT_LT(std::abs((reached - centre).norm() - radius), 0.01) << i;
  }
}

// Two RAPID statements on one line: a target inserted before the second is a copy of the second alone, on a line of
// its own with the statement's indentation; the first statement is not copied with it.
TEST(ProgramCompensationTest, AnInsertedTargetCopiesItsStatementAloneWhenALineHoldsTwo) {
  const RobotModel nominal = Nominal("ur5e");
  const Calibration calibration = MakeCalibration(nominal, 8.0, 5);
  auto robtarget = [&](const Eigen::VectorXd& q) {
    const Transform pose = nominal.T_world_base().inverse() * ForwardKinematics(nominal, q);
    const Eigen::Quaterniond r(pose.linear());
    return "[[" + Fixed(pose.translation().x(), 3) + "," + Fixed(pose.translation().y(), 3) + "," +
           Fixed(pose.translation().z(), 3) + "],[" + Fixed(r.w(), 7) + "," + Fixed(r.x(), 7) + "," + Fixed(r.y(), 7) +
           "," + Fixed(r.z(), 7) + "],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]";
  };
  Eigen::VectorXd q1(6), q2(6);
  q1 << 0.2, -1.3, 1.6, -1.8, 1.5, 0.2;
  q2 << 1.0, -0.9, 1.1, -1.6, 1.3, 0.6;
  std::string start = "[[";
  for (int k = 0; k < 6; ++k) start += (k ? "," : "") + Fixed(q1[k] * kDegPerRad, 4);
  start += "],[9E9,9E9,9E9,9E9,9E9,9E9]]";
  const std::string module = "MODULE m\r\n  PROC main()\r\n    ConfL \\Off;\r\n    MoveAbsJ " + start +
                             ", v100, fine, tool0;\r\n    MoveL " + robtarget(q1) + ", v100, z10, tool0; MoveL " +
                             robtarget(q2) + ", v100, z10, tool0; ! two\r\n  ENDPROC\r\nENDMODULE\r\n";
  ProgramCompensationOptions options;
  options.max_path_deviation_mm = 0.05;
  const ProgramCompensationResult r =
      CompensateProgram(calibration, nominal, Dialect::kRapid, {{"m.mod", module}}, options);
  ASSERT_EQ(r.summary.failed, 0) << Failures(r);
  ASSERT_GT(r.summary.inserted, 0);
  const std::string& out = r.files[0].text;
  // One MoveL per target: the original two and one per inserted target, none repeating the first statement.
  std::size_t moves = 0;
  for (std::size_t at = out.find("MoveL "); at != std::string::npos; at = out.find("MoveL ", at + 1)) ++moves;
  EXPECT_EQ(moves, 2u + static_cast<std::size_t>(r.summary.inserted)) << out;
  // The first statement keeps its line (with the line's start), the inserted ones stand on lines of their own
  // indented as the line was, and the second statement follows them with its comment.
  const ParsedProgram after = SyntaxOf(Dialect::kRapid).read(r.files);
  ASSERT_EQ(after.motions.size(), 3u + static_cast<std::size_t>(r.summary.inserted));
  const SourceText source(r.files[0], 0);
  EXPECT_EQ(source.Line(after.motions[1].line).substr(0, 10), "    MoveL ");
  EXPECT_EQ(source.Line(after.motions[1].line).find("MoveL", 5), std::string_view::npos);
  for (std::size_t m = 2; m + 1 < after.motions.size(); ++m) {
    const std::string_view line = source.Line(after.motions[m].line);
    EXPECT_EQ(line.substr(0, 10), "    MoveL ") << line;
    EXPECT_EQ(line.substr(line.size() - 1), ";") << line;
  }
  EXPECT_NE(source.Line(after.motions.back().line).find("! two"), std::string::npos);
}

TEST(ProgramCompensationTest, InvalidOptionsAreNamed) {
  const RobotModel nominal = Nominal("ur5e");
  const Calibration calibration = MakeCalibration(nominal, 1.0, 6);
  ProgramCompensationOptions options;
  options.max_path_deviation_mm = -1.0;
  EXPECT_THAT(
      [&] {
        CompensateProgram(calibration, nominal, TestDialect(), {{"a.test", ""}}, options);
      },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("max_path_deviation_mm")));
  DialectSyntax no_insert = TestDialect();
  no_insert.inline_target = nullptr;
  options.max_path_deviation_mm = 0.1;
  EXPECT_THAT(
      [&] {
        CompensateProgram(calibration, nominal, no_insert, {{"a.test", ""}}, options);
      },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("cannot take inserted targets")));
}

// The rotation conventions against hand-computed cases, and back to the numbers as written.
TEST(ProgramPosesTest, EachConventionAgainstHandComputedRotations) {
  auto syntax = [](RotationConvention c, double mm) {
    DialectSyntax d;
    d.rotation = c;
    d.mm_per_length_unit = mm;
    return d;
  };
  const double s = std::sqrt(0.5);
  // KUKA: A about z first, then B about the new y, then C about the newest x.
  Transform t = PoseFromValues(syntax(RotationConvention::kZyxIntrinsicDeg, 1.0), {1, 2, 3, 90, 0, 0});
  EXPECT_TRUE(
      t.linear().isApprox(Eigen::Matrix3d(Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ())), 1e-12));
  EXPECT_TRUE(t.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  // A = 90, C = 90: the tool's x axis along base y, its y axis along base z.
  t = PoseFromValues(syntax(RotationConvention::kZyxIntrinsicDeg, 1.0), {0, 0, 0, 90, 0, 90});
  EXPECT_TRUE(t.linear().col(0).isApprox(Eigen::Vector3d(0, 1, 0), 1e-12));
  EXPECT_TRUE(t.linear().col(1).isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
  // FANUC W = 90, R = 90 (fixed axes: first about base x, then about base z): the same matrix as KUKA's above.
  const Transform f = PoseFromValues(syntax(RotationConvention::kXyzFixedDeg, 1.0), {0, 0, 0, 90, 0, 90});
  EXPECT_TRUE(f.linear().isApprox(t.linear(), 1e-12));
  // Staubli Rx = 90 then Rz = 90 about the new z: the tool's x axis along base z.
  const Transform v = PoseFromValues(syntax(RotationConvention::kXyzIntrinsicDeg, 1.0), {0, 0, 0, 90, 0, 90});
  EXPECT_TRUE(v.linear().col(0).isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
  // ABB: w first; [s, 0, 0, s] is 90 deg about z.
  const Transform q = PoseFromValues(syntax(RotationConvention::kQuaternionWxyz, 1.0), {0, 0, 0, s, 0, 0, s});
  EXPECT_TRUE(q.linear().col(0).isApprox(Eigen::Vector3d(0, 1, 0), 1e-12));
  EXPECT_THROW(PoseFromValues(syntax(RotationConvention::kQuaternionWxyz, 1.0), {0, 0, 0, 1, 1, 0, 0}),
               std::invalid_argument);
  // UR: metres and a rotation vector; [0, 0, pi/2] is 90 deg about z.
  const Transform u = PoseFromValues(syntax(RotationConvention::kRotationVectorRad, 1000.0),
                                     {0.1, -0.2, 0.3, 0, 0, std::numbers::pi / 2});
  EXPECT_TRUE(u.translation().isApprox(Eigen::Vector3d(100, -200, 300), 1e-12));
  EXPECT_TRUE(u.linear().col(0).isApprox(Eigen::Vector3d(0, 1, 0), 1e-12));
}

TEST(ProgramPosesTest, ValuesComeBackNearestTheNumbersAsWritten) {
  auto syntax = [](RotationConvention c) {
    DialectSyntax d;
    d.rotation = c;
    return d;
  };
  // Every convention round-trips random rotations, written near their own numbers.
  Rng rng(11);
  for (RotationConvention c :
       {RotationConvention::kZyxIntrinsicDeg, RotationConvention::kXyzFixedDeg, RotationConvention::kXyzIntrinsicDeg,
        RotationConvention::kQuaternionWxyz, RotationConvention::kRotationVectorRad}) {
    for (int i = 0; i < 200; ++i) {
      std::vector<double> values = {rng.Uniform(-900, 900), rng.Uniform(-900, 900), rng.Uniform(-900, 900)};
      if (c == RotationConvention::kQuaternionWxyz) {
        Eigen::Vector4d w(rng.Normal(), rng.Normal(), rng.Normal(), rng.Normal());
        w.normalize();
        for (int k = 0; k < 4; ++k) values.push_back(w[k]);
      } else if (c == RotationConvention::kRotationVectorRad) {
        for (int k = 0; k < 3; ++k) values.push_back(rng.Uniform(-1.7, 1.7));
      } else {
        values.push_back(rng.Uniform(-179, 179));
        values.push_back(rng.Uniform(-89, 89));
        values.push_back(rng.Uniform(-179, 179));
      }
      const Transform pose = PoseFromValues(syntax(c), values);
      const std::vector<double> back = ValuesFromPose(syntax(c), pose, values);
      for (std::size_t k = 0; k < values.size(); ++k) EXPECT_NEAR(back[k], values[k], 1e-8) << ToString(c);
    }
  }
  // KUKA's two Euler sets of one rotation: each comes back as written.
  const DialectSyntax kuka = syntax(RotationConvention::kZyxIntrinsicDeg);
  const std::vector<double> one = {0, 0, 0, 30, 20, 10}, other = {0, 0, 0, -150, 160, -170};
  EXPECT_TRUE(PoseFromValues(kuka, one).linear().isApprox(PoseFromValues(kuka, other).linear(), 1e-12));
  EXPECT_NEAR(ValuesFromPose(kuka, PoseFromValues(kuka, one), other)[3], -150, 1e-9);
  EXPECT_NEAR(ValuesFromPose(kuka, PoseFromValues(kuka, one), one)[3], 30, 1e-9);
  // An angle written as 180 stays 180 (not -180) for a rotation a hair away.
  const std::vector<double> flat = {0, 0, 0, 180, 0, 180};
  std::vector<double> moved = flat;
  moved[5] = 179.99999;
  EXPECT_NEAR(ValuesFromPose(kuka, PoseFromValues(kuka, moved), flat)[5], 179.99999, 1e-8);
  moved[5] = -179.99999;
  EXPECT_NEAR(ValuesFromPose(kuka, PoseFromValues(kuka, moved), flat)[5], 180.00001, 1e-8);
  // Gimbal lock: the first angle keeps its written value.
  const std::vector<double> locked = {0, 0, 0, 25, 90, 40};
  const std::vector<double> back = ValuesFromPose(kuka, PoseFromValues(kuka, locked), locked);
  EXPECT_NEAR(back[3], 25, 1e-6);
  EXPECT_NEAR(back[5], 40, 1e-6);
  // The quaternion's sign as written.
  const DialectSyntax abb = syntax(RotationConvention::kQuaternionWxyz);
  const std::vector<double> negative = {0, 0, 0, -0.5, -0.5, -0.5, -0.5};
  EXPECT_NEAR(ValuesFromPose(abb, PoseFromValues(abb, negative), negative)[3], -0.5, 1e-12);
}

TEST(NumberFormatTest, ARewrittenNumberKeepsItsFormat) {
  EXPECT_EQ(FormatLike("100.5", 100.51234, NumberUnit::kMm), "100.512");
  EXPECT_EQ(FormatLike("100.50000", 100.51234, NumberUnit::kMm), "100.51234");
  EXPECT_EQ(FormatLike("+12.5", 12.6, NumberUnit::kDeg), "+12.6000");
  EXPECT_EQ(FormatLike(".5", 0.25, NumberUnit::kDeg), ".2500");
  EXPECT_EQ(FormatLike("-.5", -0.25, NumberUnit::kDeg), "-.2500");
  EXPECT_EQ(FormatLike("0", 0.00012, NumberUnit::kDeg), "0.0001");
  EXPECT_EQ(FormatLike("1.5E+02", 150.123, NumberUnit::kMm), "150.123");
  EXPECT_EQ(FormatLike("0.1", 0.1000004, NumberUnit::kM), "0.1");  // the change does not show at 6 decimals
  EXPECT_EQ(FormatLike("0.1", 0.100004, NumberUnit::kM), "0.100004");
  EXPECT_EQ(FormatLike("10", 10.0000000001, NumberUnit::kDeg), "10");
  EXPECT_EQ(FormatLike("-0.0", -0.00001, NumberUnit::kMm), "-0.0");
  EXPECT_EQ(FormatLike("1.0", -0.00001, NumberUnit::kMm), "0.000");
  EXPECT_EQ(FormatInserted(-1.23456789, NumberUnit::kQuaternion), "-1.2345679");
  EXPECT_EQ(MinimumDecimals(NumberUnit::kRad), 6);
  // A number of 300 digits is written whole (it once overran a fixed buffer).
  EXPECT_EQ(FormatInserted(1e300, NumberUnit::kMm).size(), 301u + 4u);
}

TEST(NumberFormatTest, ScanNumberFindsExactlyTheNumber) {
  EXPECT_EQ(ScanNumber("  -12.5e+3,", 2)->length, 8u);
  EXPECT_DOUBLE_EQ(ScanNumber("-12.5e+3", 0)->value, -12500.0);
  EXPECT_DOUBLE_EQ(ScanNumber("+.5}", 0)->value, 0.5);
  EXPECT_FALSE(ScanNumber("12abc", 0));
  EXPECT_FALSE(ScanNumber("1.2.3", 0));
  EXPECT_FALSE(ScanNumber("-", 0));
  EXPECT_FALSE(ScanNumber("1e", 0));
  EXPECT_FALSE(ScanNumber("1e999", 0));  // not finite
  EXPECT_FALSE(ScanNumber("", 0));
  EXPECT_EQ(ScanNumber("9E9]", 0)->length, 3u);
}

TEST(NumberFormatTest, LinesAndColumnsOfEveryLineEnd) {
  const ProgramFile file{"x", "a\r\nbb\rccc\nd"};
  const SourceText source(file, 0);
  EXPECT_EQ(source.line_count(), 4);
  EXPECT_EQ(source.Line(2), "bb");
  EXPECT_EQ(source.Line(3), "ccc");
  EXPECT_EQ(source.LineOf(7), 3);
  EXPECT_EQ(source.ColumnOf(7), 2);
  try {
    source.Fail(10, "why");
    FAIL();
  } catch (const ProgramError& e) {
    EXPECT_STREQ(e.what(), "x:4:1: why");
  }
}

}  // namespace
}  // namespace robocal::programs
