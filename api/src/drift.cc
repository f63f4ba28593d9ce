// Drift checks' and calibration histories' wire shapes (drift.h, history.h).
#include "robocal/api/drift.h"

#include <algorithm>

#include "robocal/api/calibration.h"
#include "robocal/api/history.h"
#include "robocal/api/json_reader.h"

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

DriftCheckRequest ParseDriftCheckRequest(const nlohmann::json& body, const RobotModel& model,
                                         MeasurementType calibrated, const Limits& limits) {
  Problems problems;
  DriftCheckRequest req;
  ReadRequestObject(body, "", &problems, &req);
  const MeasurementType type = req.measurement_type.value_or(calibrated);
  if (MeasurementRows(type) > MeasurementRows(calibrated)) {
    problems.Add("measurement_type", std::string("the calibration measured ") + WireName(calibrated) +
                                         ": a check compares no more than its calibration saw");
  }
  if (body.is_object() && !body.contains("measurements")) problems.Add("measurements", "required");
  if (const auto list = body.is_object() ? body.find("measurements") : body.end();
      body.is_object() && list != body.end()) {
    const std::size_t most = std::min(limits.max_array_length, kMaxCheckShots);
    if (!list->is_array() || list->empty() || list->size() > most) {
      problems.Add("measurements", "expected an array of 1.." + std::to_string(most) +
                                       " measurements (a check is a few poses: a check plan's 8-15)");
    } else {
      ReadMeasurements(*list, "measurements", model, type, {}, MeasurementRole::kCalibration, &problems,
                       &req.measurements);
    }
  }
  problems.ThrowIfAny("invalid check request");
  return req;
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
