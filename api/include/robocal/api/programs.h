// Wire shapes of POST /v1/campaigns/{c}:compensate-program: a robot program in its controller's language in, the
// program compensated out, with a report per target (docs/programs.md).
#pragma once

#include <array>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "robocal/api/wire.h"
#include "robocal/programs/compensate_program.h"
#include "robocal/programs/program.h"

namespace robocal::api {

// The tables spelt out: GCC 12 takes an enumerator of another namespace in ROBOCAL_API_ENUM_TABLE's braced list
// for a type ("robocal::programs::Dialect::kKrl is not a type").
template <>
struct EnumTable<programs::Dialect> {
  static constexpr std::array<programs::Dialect, 5> values = {programs::Dialect::kKrl, programs::Dialect::kRapid,
                                                              programs::Dialect::kUrscript, programs::Dialect::kFanucLs,
                                                              programs::Dialect::kVal3};
  static const char* Name(programs::Dialect value);
};
template <>
struct EnumTable<programs::TargetKind> {
  static constexpr std::array<programs::TargetKind, 2> values = {programs::TargetKind::kJoint,
                                                                 programs::TargetKind::kCartesian};
  static const char* Name(programs::TargetKind value);
};
template <>
struct EnumTable<programs::OnFailure> {
  static constexpr std::array<programs::OnFailure, 2> values = {programs::OnFailure::kKeep,
                                                                programs::OnFailure::kRefuse};
  static const char* Name(programs::OnFailure value);
};

/// POST /v1/campaigns/{c}:compensate-program.
struct CompensateProgramRequest {
  /// The controller's language; unset: the files' extensions name it.
  std::optional<programs::Dialect> dialect;
  /// The program's files by name (a KRL program's .src and .dat, say), each its text byte for byte.
  std::map<std::string, std::string> files;
  /// The program's tools (T_flange_tool) and bases / work objects (in the robot base) by the number or name the
  /// program uses, each as the dialect writes a Cartesian target: x, y, z, then the rotation in its convention
  /// and units (docs/programs.md). A tool without an entry is the calibrated robot's own tool.
  std::map<std::string, std::vector<double>> tools;
  std::map<std::string, std::vector<double>> bases;
  /// Straight moves whose path leaves the programmed line by more than this get intermediate targets (mm, > 0).
  std::optional<double> max_path_deviation_mm;
  programs::OnFailure on_failure = programs::OnFailure::kKeep;
  /// The payload the robot carries; unset: the campaign's, or none.
  std::optional<PayloadWire> payload;
};
/// The request, validated: every violation with its field path (WireError / ApiError INVALID_ARGUMENT).
CompensateProgramRequest ParseCompensateProgramRequest(const nlohmann::json& body, const Limits& limits);
template <>
struct WireFields<CompensateProgramRequest> {
  using S = CompensateProgramRequest;
  static constexpr auto fields = std::make_tuple(
      Field{"dialect", &S::dialect, Presence::kOmitEmpty}, Field{"files", &S::files},
      Field{"tools", &S::tools, Presence::kOmitEmpty}, Field{"bases", &S::bases, Presence::kOmitEmpty},
      Field{"max_path_deviation_mm", &S::max_path_deviation_mm, Presence::kOmitEmpty}.Range(1e-6, 1000.0),
      Field{"on_failure", &S::on_failure, Presence::kOptionalOnRead},
      Field{"payload", &S::payload, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(CompensateProgramRequest);

/// One target of the program as compensated.
struct ProgramTargetWire {
  std::string file;
  /// 1-based line in the file as sent (an inserted target: the line of the move it precedes).
  int line = 0;
  /// The variable or point (KRL "XP1", FANUC "P[3]"); null for an inline target.
  std::optional<std::string> name;
  programs::TargetKind kind = programs::TargetKind::kJoint;
  /// An intermediate target inserted by the path check.
  bool inserted = false;
  /// The compensated joints (deg / mm); empty when none was found.
  std::vector<double> joints;
  /// How far the written target moved: the tool point (mm) and the tool's rotation (deg).
  double correction_mm = 0.0;
  double correction_deg = 0.0;
  /// The largest revolute joint change from the joints the controller would use for the target as written (deg;
  /// null without a solution).
  double joint_change_deg = 0.0;
  /// The compensated joints keep the configuration flags and turns of the target (false: kept as written).
  bool configuration_kept = true;
  /// Whether its numbers were rewritten.
  bool rewritten = false;
  /// 95 % bound on the position error the robot will have at the target (mm; null where not known).
  double predicted_error_mm = 0.0;
  Termination termination = Termination::kFailure;
  std::string message;
};
template <>
struct WireFields<ProgramTargetWire> {
  using S = ProgramTargetWire;
  static constexpr auto fields = std::make_tuple(
      Field{"file", &S::file}, Field{"line", &S::line}, Field{"name", &S::name}, Field{"kind", &S::kind},
      Field{"inserted", &S::inserted}, Field{"joints", &S::joints}, Field{"correction_mm", &S::correction_mm},
      Field{"correction_deg", &S::correction_deg}, Field{"joint_change_deg", &S::joint_change_deg},
      Field{"configuration_kept", &S::configuration_kept}, Field{"rewritten", &S::rewritten},
      Field{"predicted_error_mm", &S::predicted_error_mm}, Field{"termination", &S::termination},
      Field{"message", &S::message});
};
ROBOCAL_WIRE_DECLARE(ProgramTargetWire);

/// What happened to the program as a whole (programs::ProgramCompensationSummary).
struct ProgramSummaryWire {
  int targets = 0;
  int joint_targets = 0;
  int cartesian_targets = 0;
  int rewritten = 0;
  int failed = 0;
  int configuration_changes = 0;
  int inserted = 0;
  int segments_checked = 0;
  int segments_over_deviation = 0;
  double max_correction_mm = 0.0;
  /// Null where no target has a bound.
  double max_predicted_error_mm = 0.0;
  Termination termination = Termination::kFailure;
  std::string message;
};
template <>
struct WireFields<ProgramSummaryWire> {
  using S = ProgramSummaryWire;
  static constexpr auto fields = std::make_tuple(
      Field{"targets", &S::targets}, Field{"joint_targets", &S::joint_targets},
      Field{"cartesian_targets", &S::cartesian_targets}, Field{"rewritten", &S::rewritten}, Field{"failed", &S::failed},
      Field{"configuration_changes", &S::configuration_changes}, Field{"inserted", &S::inserted},
      Field{"segments_checked", &S::segments_checked}, Field{"segments_over_deviation", &S::segments_over_deviation},
      Field{"max_correction_mm", &S::max_correction_mm}, Field{"max_predicted_error_mm", &S::max_predicted_error_mm},
      Field{"termination", &S::termination}, Field{"message", &S::message});
};
ROBOCAL_WIRE_DECLARE(ProgramSummaryWire);

/// The reply of :compensate-program.
struct CompensateProgramResult {
  std::string campaign;
  programs::Dialect dialect = programs::Dialect::kKrl;
  /// Every file of the request, compensated.
  std::map<std::string, std::string> files;
  std::vector<ProgramTargetWire> targets;
  ProgramSummaryWire summary;
};
template <>
struct WireFields<CompensateProgramResult> {
  using S = CompensateProgramResult;
  static constexpr auto fields =
      std::make_tuple(Field{"campaign", &S::campaign}, Field{"dialect", &S::dialect}, Field{"files", &S::files},
                      Field{"targets", &S::targets}, Field{"summary", &S::summary});
};
ROBOCAL_WIRE_DECLARE(CompensateProgramResult);

/// The wire form of a compensated program (joints in deg / mm by the robot's joint types).
CompensateProgramResult ToWire(const RobotModel& model, const std::string& campaign,
                               const std::vector<programs::ProgramFile>& request_files,
                               const programs::ProgramCompensationResult& result);

}  // namespace robocal::api
