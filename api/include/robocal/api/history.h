// Wire shapes of a robot's calibration history (docs/drift.md, "History"): the calibrations a robot has carried,
// the checks of them, and rollbacks, each entry saying who did what when. Nothing is ever removed: a rollback is a
// new entry.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/drift.h"
#include "robocal/api/robots.h"
#include "robocal/api/wire.h"

namespace robocal::api {

/// What an entry records: the robot registered from a calibration, a new calibration put on it, a drift check, or
/// the robot put back on an earlier entry's calibration.
enum class HistoryKind { kRegistered, kCalibrated, kCheck, kRollback };
template <>
struct EnumTable<HistoryKind> {
  static constexpr std::array<HistoryKind, 4> values = {HistoryKind::kRegistered, HistoryKind::kCalibrated,
                                                        HistoryKind::kCheck, HistoryKind::kRollback};
  static const char* Name(HistoryKind value);
};

struct HistoryEntryWire {
  /// 1, 2, ... in order.
  std::int64_t entry = 0;
  HistoryKind kind = HistoryKind::kRegistered;
  std::int64_t at_unix_ms = 0;
  /// The bearer token's name that made it (null on a server without tokens).
  std::optional<std::string> by;
  /// The campaign of the calibration the entry is about (registered, calibrated, rolled back to, checked).
  std::string campaign;
  /// A check: its verdict, residual level and threshold, and the suspects' parameter names.
  std::optional<CheckVerdict> verdict;
  std::optional<double> statistic;
  std::optional<double> threshold;
  std::vector<std::string> suspects;
  /// A rollback: the entry whose calibration the robot carries again.
  std::optional<std::int64_t> rolled_back_to;
  std::string note;
};
template <>
struct WireFields<HistoryEntryWire> {
  using S = HistoryEntryWire;
  static constexpr auto fields = std::make_tuple(
      Field{"entry", &S::entry}, Field{"kind", &S::kind}, Field{"at_unix_ms", &S::at_unix_ms}, Field{"by", &S::by},
      Field{"campaign", &S::campaign}, Field{"verdict", &S::verdict, Presence::kOmitEmpty},
      Field{"statistic", &S::statistic, Presence::kOmitEmpty}, Field{"threshold", &S::threshold, Presence::kOmitEmpty},
      Field{"suspects", &S::suspects, Presence::kOmitEmpty},
      Field{"rolled_back_to", &S::rolled_back_to, Presence::kOmitEmpty}, Field{"note", &S::note});
};
ROBOCAL_WIRE_DECLARE(HistoryEntryWire);

/// The stored form of an entry that puts a calibration on the robot: the definition it carried from then on, so that
/// a rollback restores exactly that robot (the campaign's calibration may have been fitted again since).
struct StoredHistoryEntry : HistoryEntryWire {
  std::optional<RegisterRobotRequest> definition;
};
template <>
struct WireFields<StoredHistoryEntry> {
  static constexpr auto fields =
      std::tuple_cat(WireFields<HistoryEntryWire>::fields,
                     std::make_tuple(Field{"definition", &StoredHistoryEntry::definition, Presence::kOmitEmpty}));
};
ROBOCAL_WIRE_DECLARE(StoredHistoryEntry);

/// GET /v1/robots/{r}/calibrations, and the reply of :calibrate and :rollback.
struct RobotHistoryWire {
  std::string robot;
  /// The entry whose calibration the robot carries now (null: none, a robot not registered from a calibration).
  std::optional<std::int64_t> current_entry;
  std::string current_campaign;
  std::vector<HistoryEntryWire> entries;
};
template <>
struct WireFields<RobotHistoryWire> {
  using S = RobotHistoryWire;
  static constexpr auto fields =
      std::make_tuple(Field{"robot", &S::robot}, Field{"current_entry", &S::current_entry},
                      Field{"current_campaign", &S::current_campaign}, Field{"entries", &S::entries});
};
ROBOCAL_WIRE_DECLARE(RobotHistoryWire);

/// A note of a history entry: text without control characters (it is shown in reports and terminals).
inline bool IsNoteText(const std::string& text) {
  for (const char c : text) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) return false;
  }
  return true;
}
inline constexpr const char* kNoteRule = "must not contain control characters";

/// POST /v1/robots/{r}:calibrate: put a campaign's calibration on the robot (a new entry).
struct CalibrateRobotRequest {
  std::string campaign;
  std::string note;
};
template <>
struct WireFields<CalibrateRobotRequest> {
  using S = CalibrateRobotRequest;
  static constexpr auto fields =
      std::make_tuple(Field{"from_calibration", &S::campaign}.Mandatory().Size(0, 64).Rule(&IsValidId, kIdRule),
                      Field{"note", &S::note, Presence::kOmitEmpty}.Size(0, 1024).Rule(&IsNoteText, kNoteRule));
};
ROBOCAL_WIRE_DECLARE(CalibrateRobotRequest);

/// POST /v1/robots/{r}:rollback: put the robot back on the calibration of an earlier entry (a new entry).
struct RollbackRequest {
  std::int64_t entry = 0;
  std::string note;
};
template <>
struct WireFields<RollbackRequest> {
  using S = RollbackRequest;
  static constexpr auto fields =
      std::make_tuple(Field{"entry", &S::entry}.Mandatory().Range(1, 1e12),
                      Field{"note", &S::note, Presence::kOmitEmpty}.Size(0, 1024).Rule(&IsNoteText, kNoteRule));
};
ROBOCAL_WIRE_DECLARE(RollbackRequest);

/// The entry whose calibration the robot carries after `entries` (the last registered, calibrated or rollback
/// entry), or null.
std::optional<std::int64_t> CurrentEntry(const std::vector<StoredHistoryEntry>& entries);

}  // namespace robocal::api
