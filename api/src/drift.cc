// Drift checks' and calibration histories' wire shapes (drift.h, history.h).
#include "robocal/api/drift.h"

#include "robocal/api/calibration.h"
#include "robocal/api/history.h"

namespace robocal::api {

const char* EnumTable<CheckFrames>::Name(CheckFrames v) { return v == CheckFrames::kKeep ? "keep" : "register"; }
const char* EnumTable<CheckVerdict>::Name(CheckVerdict v) { return v == CheckVerdict::kDrifted ? "drifted" : "holds"; }
const char* EnumTable<HistoryKind>::Name(HistoryKind v) {
  switch (v) {
    case HistoryKind::kRegistered:
      return "registered";
    case HistoryKind::kCalibrated:
      return "calibrated";
    case HistoryKind::kCheck:
      return "check";
    case HistoryKind::kRollback:
      return "rollback";
  }
  return "?";
}

std::optional<std::int64_t> CurrentEntry(const std::vector<StoredHistoryEntry>& entries) {
  for (auto it = entries.rbegin(); it != entries.rend(); ++it) {
    if (it->kind != HistoryKind::kCheck) return it->entry;
  }
  return std::nullopt;
}

DriftCheckWire ToWire(const DriftCheck& check, const RobotModel& model, const DriftCheckOptions& options) {
  std::vector<DriftSuspectWire> suspects;
  for (const DriftSuspect& s : check.suspects) {
    const ParameterUnit unit = model.parameter_unit(s.index);
    const double scale = ParameterUnitScale(unit);
    suspects.push_back({.parameter = s.name,
                        .joint_offset = model.IsJointOffsetParameter(s.index),
                        .unit = ParameterUnitName(unit),
                        .change = s.change * scale,
                        .std = s.std * scale,
                        .chi2_drop = s.chi2_drop,
                        .equivalent = s.equivalent});
  }
  return {.robot = "",
          .campaign = "",
          .verdict = check.drifted ? CheckVerdict::kDrifted : CheckVerdict::kHolds,
          .false_alarm_rate = options.false_alarm_rate,
          .statistic = check.statistic,
          .threshold = check.threshold,
          .p_value = check.p_value,
          .largest_drop = check.largest_drop,
          .drop_threshold = check.drop_threshold,
          .num_candidates = check.num_candidates,
          .suspects = std::move(suspects),
          .measurement_type = options.measurement_type,
          .num_measurements = check.num_measurements,
          .dof = check.dof,
          .rms_position_mm = check.rms_position_mm,
          .expected_rms_position_mm = check.expected_rms_position_mm,
          .frames = options.register_frames ? CheckFrames::kRegister : CheckFrames::kKeep,
          .base = TransformToPose(check.T_world_base),
          .tool = TransformToPose(check.T_flange_tool),
          .history_entry = 0,
          .message = check.message};
}

ROBOCAL_WIRE_DEFINE(DriftCheckRequest);
ROBOCAL_WIRE_DEFINE(DriftSuspectWire);
ROBOCAL_WIRE_DEFINE(DriftCheckWire);
ROBOCAL_WIRE_DEFINE(HistoryEntryWire);
ROBOCAL_WIRE_DEFINE(StoredHistoryEntry);
ROBOCAL_WIRE_DEFINE(RobotHistoryWire);
ROBOCAL_WIRE_DEFINE(CalibrateRobotRequest);
ROBOCAL_WIRE_DEFINE(RollbackRequest);

}  // namespace robocal::api
