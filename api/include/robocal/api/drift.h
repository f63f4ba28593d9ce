// Wire shapes of a drift check (POST /v1/robots/{r}:check, docs/drift.md): a few poses measured now against the
// calibration the robot carries, and the verdict with its statistics and suspects.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/campaigns.h"
#include "robocal/api/wire.h"
#include "robocal/core/drift.h"

namespace robocal::api {

/// Whether a check registers the tracker and tool frames on its shots, or keeps the calibration's.
enum class CheckFrames { kRegister, kKeep };
template <>
struct EnumTable<CheckFrames> {
  static constexpr std::array<CheckFrames, 2> values = {CheckFrames::kRegister, CheckFrames::kKeep};
  static const char* Name(CheckFrames value);
};

/// The most shots a check takes: a check is a few poses (a check plan's 8-15), not a campaign.
inline constexpr std::size_t kMaxCheckShots = 200;

/// POST /v1/robots/{r}:check.
struct DriftCheckRequest {
  /// Unset: the calibration campaign's.
  std::optional<MeasurementType> measurement_type;
  /// The shots, as uploads give them (joints deg / mm, poses in the tracker frame).
  std::vector<MeasurementWire> measurements;
  /// The tracker's noise: its uncertainty model or a noise, unset: the calibration campaign's.
  std::optional<TrackerModelWire> tracker;
  std::optional<NoiseWire> noise;
  /// The robot's repeatability RP (mm); unset: the calibration campaign's.
  std::optional<double> repeatability_mm;
  CheckFrames frames = CheckFrames::kRegister;
  double false_alarm_rate = 0.05;
  std::uint64_t seed = 1;
};
template <>
struct WireFields<DriftCheckRequest> {
  using S = DriftCheckRequest;
  static constexpr auto fields = std::make_tuple(
      Field{"measurement_type", &S::measurement_type, Presence::kOmitEmpty},
      // Read by the parser with the robot's joints and the measurement type.
      Field{"measurements", &S::measurements}.Mandatory().Size(1, 0).Apart(),
      Field{"tracker", &S::tracker, Presence::kOmitEmpty}, Field{"noise", &S::noise, Presence::kOmitEmpty},
      Field{"repeatability_mm", &S::repeatability_mm, Presence::kOmitEmpty}.Range(0.0, 10.0),
      Field{"frames", &S::frames}, Field{"false_alarm_rate", &S::false_alarm_rate}.Range(1e-4, 0.25),
      Field{"seed", &S::seed});
};
ROBOCAL_WIRE_DECLARE(DriftCheckRequest);
/// Validates a check's body for the checked robot `model` whose calibration measured `calibrated`: the table's
/// members, a measurement type no richer than the calibration's, and 1..kMaxCheckShots measurements as uploads
/// give them (ReadMeasurements). INVALID_ARGUMENT naming every problem.
DriftCheckRequest ParseDriftCheckRequest(const nlohmann::json& body, const RobotModel& model,
                                         MeasurementType calibrated, const Limits& limits);

/// A parameter that explains a check's residuals (DriftSuspect in wire units: change and std in the parameter's
/// unit, deg or mm).
struct DriftSuspectWire {
  std::string parameter;
  bool joint_offset = false;
  std::string unit;
  double change = 0.0;
  double std = 0.0;
  double chi2_drop = 0.0;
  /// The parameters the check's poses cannot tell from it (DriftSuspect::equivalent).
  std::vector<std::string> equivalent;
};
template <>
struct WireFields<DriftSuspectWire> {
  using S = DriftSuspectWire;
  static constexpr auto fields =
      std::make_tuple(Field{"parameter", &S::parameter}, Field{"joint_offset", &S::joint_offset},
                      Field{"unit", &S::unit}, Field{"change", &S::change}, Field{"std", &S::std},
                      Field{"chi2_drop", &S::chi2_drop}, Field{"equivalent", &S::equivalent});
};
ROBOCAL_WIRE_DECLARE(DriftSuspectWire);

enum class CheckVerdict { kHolds, kDrifted };
template <>
struct EnumTable<CheckVerdict> {
  static constexpr std::array<CheckVerdict, 2> values = {CheckVerdict::kHolds, CheckVerdict::kDrifted};
  static const char* Name(CheckVerdict value);
};

/// The reply of POST /v1/robots/{r}:check.
struct DriftCheckWire {
  std::string robot;
  /// The calibration checked: its campaign.
  std::string campaign;
  CheckVerdict verdict = CheckVerdict::kHolds;
  double false_alarm_rate = 0.0;
  /// The residual level test (DriftCheck::statistic, threshold, p_value).
  double statistic = 0.0;
  double threshold = 0.0;
  double p_value = 0.0;
  /// The single-parameter test.
  double largest_drop = 0.0;
  double drop_threshold = 0.0;
  int num_candidates = 0;
  std::vector<DriftSuspectWire> suspects;
  MeasurementType measurement_type = MeasurementType::kPose;
  int num_measurements = 0;
  int dof = 0;
  double rms_position_mm = 0.0;
  double expected_rms_position_mm = 0.0;
  CheckFrames frames = CheckFrames::kRegister;
  PoseResultWire base;
  PoseResultWire tool;
  /// The robot's history entry that records the check.
  std::int64_t history_entry = 0;
  std::string message;
};
template <>
struct WireFields<DriftCheckWire> {
  using S = DriftCheckWire;
  static constexpr auto fields = std::make_tuple(
      Field{"robot", &S::robot}, Field{"campaign", &S::campaign}, Field{"verdict", &S::verdict},
      Field{"false_alarm_rate", &S::false_alarm_rate}, Field{"statistic", &S::statistic},
      Field{"threshold", &S::threshold}, Field{"p_value", &S::p_value}, Field{"largest_drop", &S::largest_drop},
      Field{"drop_threshold", &S::drop_threshold}, Field{"num_candidates", &S::num_candidates},
      Field{"suspects", &S::suspects}, Field{"measurement_type", &S::measurement_type},
      Field{"num_measurements", &S::num_measurements}, Field{"dof", &S::dof},
      Field{"rms_position_mm", &S::rms_position_mm}, Field{"expected_rms_position_mm", &S::expected_rms_position_mm},
      Field{"frames", &S::frames}, Field{"base", &S::base}, Field{"tool", &S::tool},
      Field{"history_entry", &S::history_entry}, Field{"message", &S::message});
};
ROBOCAL_WIRE_DECLARE(DriftCheckWire);
/// A check of `model` (the checked robot) with `options` in wire units; the robot, campaign and history entry are the
/// service's to fill in.
DriftCheckWire ToWire(const DriftCheck& check, const RobotModel& model, const DriftCheckOptions& options);

}  // namespace robocal::api
