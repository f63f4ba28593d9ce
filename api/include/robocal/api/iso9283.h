// Wire shapes of the ISO 9283 pose test (docs/iso9283.md): the test a plan lays out ("test": {"iso9283": ...}
// of POST /v1/plans, and the plan's "test"), and the characteristics GET /v1/campaigns/{c}/iso9283 computes from
// a campaign's test shots.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/campaigns.h"
#include "robocal/api/json_reader.h"
#include "robocal/api/wire.h"
#include "robocal/core/iso9283.h"

namespace robocal::api {

/// The test cube: its centre in the robot's base frame and its edge (mm); the edges run along the base axes.
struct Iso9283CubeWire {
  std::array<double, 3> center_mm{0.0, 0.0, 0.0};
  double size_mm = 0.0;
};
template <>
struct WireFields<Iso9283CubeWire> {
  using S = Iso9283CubeWire;
  static constexpr auto fields =
      std::make_tuple(Field{"center_mm", &S::center_mm}.Mandatory().Range(-kMaxLengthMm, kMaxLengthMm),
                      Field{"size_mm", &S::size_mm}.Mandatory().Range(1.0, kMaxLengthMm));
};
ROBOCAL_WIRE_DECLARE(Iso9283CubeWire);
Iso9283Cube ToCore(const Iso9283CubeWire& cube);
Iso9283CubeWire ToWire(const Iso9283Cube& cube);

/// The most cycles a planned test may have (the standard asks for 30).
inline constexpr int kMaxPlanCycles = 1000;

/// A plan request's "test": {"iso9283": {...}}: the cube (an object, or "auto": the largest the robot reaches, in
/// the plan's cell when it has one), the cycles, the tool's orientation at every pose (fixed-axis roll, pitch,
/// yaw in degrees, R = Rz(y) Ry(p) Rx(r), base frame; default the tool pointing down), and the campaign whose
/// calibration compensates the joint commands (empty: the nominal robot's).
struct Iso9283TestWire {
  std::optional<Iso9283CubeWire> cube;
  bool cube_auto = false;
  int cycles = 30;
  std::array<double, 3> orientation_rpy_deg{180.0, 0.0, 0.0};
  std::string compensated_by;
};
namespace detail {
bool WriteTestCube(const Iso9283TestWire& test, nlohmann::json* value);
void ReadTestCube(const nlohmann::json* value, const std::string& path, Iso9283TestWire* test);
}  // namespace detail
template <>
struct WireFields<Iso9283TestWire> {
  using S = Iso9283TestWire;
  static constexpr auto fields = std::make_tuple(
      // An object or "auto": read by its own reader.
      Computed<S>{"cube", &detail::WriteTestCube, &detail::ReadTestCube, true, true},
      Field{"cycles", &S::cycles}.Range(2, kMaxPlanCycles),
      Field{"orientation_rpy_deg", &S::orientation_rpy_deg}.Range(-360.0, 360.0),
      Field{"compensated_by", &S::compensated_by, Presence::kOmitEmpty}.Size(0, 64).Rule(&IsValidId, kIdRule));
};
ROBOCAL_WIRE_DECLARE(Iso9283TestWire);
/// Reads the table's rows and the cube (an object or "auto").
template <>
struct RequestReader<Iso9283TestWire> {
  static bool Read(const nlohmann::json& value, const std::string& path, Problems* problems, Iso9283TestWire* out);
};

/// A plan request's "test": the standard test the plan lays out.
struct PlanTestWire {
  Iso9283TestWire iso9283;
};
template <>
struct WireFields<PlanTestWire> {
  static constexpr auto fields = std::make_tuple(Field{"iso9283", &PlanTestWire::iso9283}.Mandatory());
};
ROBOCAL_WIRE_DECLARE(PlanTestWire);

/// One pose of a planned test: its name, the tool pose in the base frame, and the joint commands (deg / mm).
struct Iso9283PlannedPoseWire {
  std::string name;
  std::array<double, 3> position_mm{0.0, 0.0, 0.0};
  std::array<double, 3> orientation_rpy_deg{0.0, 0.0, 0.0};
  std::vector<double> joints;
};
template <>
struct WireFields<Iso9283PlannedPoseWire> {
  using S = Iso9283PlannedPoseWire;
  static constexpr auto fields = std::make_tuple(Field{"name", &S::name}, Field{"position_mm", &S::position_mm},
                                                 Field{"orientation_rpy_deg", &S::orientation_rpy_deg},
                                                 Field{"joints", &S::joints});
};
ROBOCAL_WIRE_DECLARE(Iso9283PlannedPoseWire);

/// A shot's place in the test: the tags its measurement carries.
struct TestTagWire {
  std::string test_pose;
  int cycle = 1;
};
template <>
struct WireFields<TestTagWire> {
  static constexpr auto fields =
      std::make_tuple(Field{"test_pose", &TestTagWire::test_pose}, Field{"cycle", &TestTagWire::cycle});
};
ROBOCAL_WIRE_DECLARE(TestTagWire);

/// A test plan's "test": the cube, the poses with their joint commands, and each configuration's tags (the
/// plan's configurations are P1..P5 repeated `cycles` times).
struct Iso9283PlanWire {
  Iso9283CubeWire cube;
  int cycles = 0;
  std::array<double, 3> orientation_rpy_deg{0.0, 0.0, 0.0};
  /// The campaign whose calibration compensated the commands (null: the nominal robot's commands).
  std::optional<std::string> compensated_by;
  /// The branch every pose is reached on ("shoulder front, elbow up, wrist noflip"; empty for a robot without
  /// named branches).
  std::string configuration;
  std::vector<Iso9283PlannedPoseWire> poses;
  std::vector<TestTagWire> tags;
  std::string message;
};
template <>
struct WireFields<Iso9283PlanWire> {
  using S = Iso9283PlanWire;
  static constexpr auto fields = std::make_tuple(
      Field{"cube", &S::cube}, Field{"cycles", &S::cycles}, Field{"orientation_rpy_deg", &S::orientation_rpy_deg},
      Field{"compensated_by", &S::compensated_by}, Field{"configuration", &S::configuration},
      Field{"poses", &S::poses}, Field{"tags", &S::tags}, Field{"message", &S::message});
};
ROBOCAL_WIRE_DECLARE(Iso9283PlanWire);

/// One pose's characteristics (Iso9283PoseFigures in wire units). Orientation figures are null for shots without
/// orientation; repeatability (rp*) is null with fewer than 2 cycles: not measurable, never 0.
struct Iso9283PoseWire {
  std::string pose;
  int cycles = 0;
  std::array<double, 3> command_mm{0.0, 0.0, 0.0};
  double ap_mm = 0.0;
  double apx_mm = 0.0, apy_mm = 0.0, apz_mm = 0.0;
  double apa_deg = 0.0, apb_deg = 0.0, apc_deg = 0.0;
  double rpl_mm = 0.0;
  double rpa_deg = 0.0, rpb_deg = 0.0, rpc_deg = 0.0;
};
template <>
struct WireFields<Iso9283PoseWire> {
  using S = Iso9283PoseWire;
  static constexpr auto fields = std::make_tuple(
      Field{"pose", &S::pose}, Field{"cycles", &S::cycles}, Field{"command_mm", &S::command_mm},
      Field{"ap_mm", &S::ap_mm}, Field{"apx_mm", &S::apx_mm}, Field{"apy_mm", &S::apy_mm}, Field{"apz_mm", &S::apz_mm},
      Field{"apa_deg", &S::apa_deg}, Field{"apb_deg", &S::apb_deg}, Field{"apc_deg", &S::apc_deg},
      Field{"rpl_mm", &S::rpl_mm}, Field{"rpa_deg", &S::rpa_deg}, Field{"rpb_deg", &S::rpb_deg},
      Field{"rpc_deg", &S::rpc_deg});
};
ROBOCAL_WIRE_DECLARE(Iso9283PoseWire);

/// The distance characteristics between two poses (Iso9283Distance); rd_mm null with fewer than 2 cycles.
struct Iso9283DistanceWire {
  std::string from;
  std::string to;
  int cycles = 0;
  double command_mm = 0.0;
  double ad_mm = 0.0;
  double adx_mm = 0.0, ady_mm = 0.0, adz_mm = 0.0;
  double rd_mm = 0.0;
};
template <>
struct WireFields<Iso9283DistanceWire> {
  using S = Iso9283DistanceWire;
  static constexpr auto fields = std::make_tuple(
      Field{"from", &S::from}, Field{"to", &S::to}, Field{"cycles", &S::cycles}, Field{"command_mm", &S::command_mm},
      Field{"ad_mm", &S::ad_mm}, Field{"adx_mm", &S::adx_mm}, Field{"ady_mm", &S::ady_mm},
      Field{"adz_mm", &S::adz_mm}, Field{"rd_mm", &S::rd_mm});
};
ROBOCAL_WIRE_DECLARE(Iso9283DistanceWire);

/// The characteristics of one set of commands: every pose measured, and the distances.
struct Iso9283FiguresWire {
  std::vector<Iso9283PoseWire> poses;
  std::vector<Iso9283DistanceWire> distances;
};
template <>
struct WireFields<Iso9283FiguresWire> {
  static constexpr auto fields = std::make_tuple(Field{"poses", &Iso9283FiguresWire::poses},
                                                 Field{"distances", &Iso9283FiguresWire::distances});
};
ROBOCAL_WIRE_DECLARE(Iso9283FiguresWire);
Iso9283FiguresWire ToWire(const Iso9283Result& result);

/// Where a test's commanded poses come from: the campaign's test plan (its poses P1..P5), or the campaign robot's
/// model at each shot's joints (the pose its controller commanded).
enum class TestCommands { kPlan, kRobotModel };
/// How the tracker frame was tied to the robot's base: the campaign's calibration, or registered on the test shots
/// themselves (a rigid fit of the attained positions to the commanded ones, which absorbs a rigid part of the
/// robot's error).
enum class TestFrames { kCalibration, kRegisteredOnTest };
template <>
struct EnumTable<TestCommands> {
  static constexpr std::array<TestCommands, 2> values = {TestCommands::kPlan, TestCommands::kRobotModel};
  static const char* Name(TestCommands value);
};
template <>
struct EnumTable<TestFrames> {
  static constexpr std::array<TestFrames, 2> values = {TestFrames::kCalibration, TestFrames::kRegisteredOnTest};
  static const char* Name(TestFrames value);
};

/// GET /v1/campaigns/{c}/iso9283.
struct Iso9283ReportWire {
  std::string campaign;
  MeasurementType measurement_type = MeasurementType::kPose;
  int num_shots = 0;
  /// The most cycles at any pose.
  int cycles = 0;
  TestCommands commands = TestCommands::kRobotModel;
  /// The test plan the commands came from (null: none).
  std::optional<std::string> plan;
  TestFrames frames = TestFrames::kCalibration;
  /// The tracker -> base transform the attained poses were expressed with.
  PoseResultWire base;
  /// The test as the robot ran it: attained against commanded poses.
  Iso9283FiguresWire measured;
  /// A calibrated campaign: the attained poses against the calibrated model's at each shot's joints, the
  /// accuracy the robot shows with commands compensated by this calibration (null: not calibrated).
  std::optional<Iso9283FiguresWire> calibrated;
  /// What the figures do not say (repeatability not measurable, frames registered on the test).
  std::vector<std::string> notes;
};
template <>
struct WireFields<Iso9283ReportWire> {
  using S = Iso9283ReportWire;
  static constexpr auto fields = std::make_tuple(
      Field{"campaign", &S::campaign}, Field{"measurement_type", &S::measurement_type},
      Field{"num_shots", &S::num_shots}, Field{"cycles", &S::cycles}, Field{"commands", &S::commands},
      Field{"plan", &S::plan}, Field{"frames", &S::frames}, Field{"base", &S::base}, Field{"measured", &S::measured},
      Field{"calibrated", &S::calibrated}, Field{"notes", &S::notes});
};
ROBOCAL_WIRE_DECLARE(Iso9283ReportWire);

/// The report as CSV (docs/iso9283.md): one row per pose and per distance pair of each set ("measured",
/// "calibrated"), the standard's symbols as columns, empty where a row has no such figure or it is not measurable.
std::string Iso9283Csv(const Iso9283ReportWire& report);

}  // namespace robocal::api
