// Drift checks' and calibration histories' wire shapes (drift.h, history.h).
#include "robocal/api/drift.h"

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

ROBOCAL_WIRE_DEFINE(DriftCheckRequest);
ROBOCAL_WIRE_DEFINE(DriftSuspectWire);
ROBOCAL_WIRE_DEFINE(DriftCheckWire);
ROBOCAL_WIRE_DEFINE(HistoryEntryWire);
ROBOCAL_WIRE_DEFINE(StoredHistoryEntry);
ROBOCAL_WIRE_DEFINE(RobotHistoryWire);
ROBOCAL_WIRE_DEFINE(CalibrateRobotRequest);
ROBOCAL_WIRE_DEFINE(RollbackRequest);

}  // namespace robocal::api
