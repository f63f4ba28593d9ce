// The documents the server stores: their own versioned schema, not the request schema re-parsed. Reading a
// stored document checks its structure only (WireReader), never the request limits: tightening request
// validation must not make stored robots, plans, campaigns or calibrations unreadable.
//
// Versions: 1 is every document written before the field "schema_version" existed (the same members as version
// 2, without it; plans and fits recorded deadline_exceeded only when true); 2 adds "schema_version"; 3 adds
// cells, and plans gain "cell" and "configuration_checks"; 4 adds the campaign's "tracker" model and "repeatability_mm"
// and the fit's robust-fit members (outliers, parameters_with_outliers). A fit's state may hold
// "last_calibration_sequence" (optional, so version 4 still: a server that does not know it ignores it, and a fit
// without it reads as before). 5 adds to a fit's state what its wire result leaves out of the core's Calibration (the
// covariance, the singular values, the residual count, the outliers' measurement indices, the implausible joint terms),
// so that Restore returns the calibration whole; a fit of an older version restores without them. 6 adds a robot's
// calibration history ("history" beside its definition). A document of a version newer than kStoredSchemaVersion is
// refused by name rather than misread.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/cells.h"
#include "robocal/api/history.h"
#include "robocal/api/operations.h"
#include "robocal/api/plans.h"
#include "robocal/api/robots.h"
#include "robocal/core/identification.h"

namespace robocal::api {

inline constexpr int kStoredSchemaVersion = 6;

/// The schema version of a stored document (1 when it has none); WireError if newer than this server reads.
int StoredSchemaVersion(const nlohmann::json& document);

/// A registered robot: its definition.
struct StoredRobot {
  RegisterRobotRequest definition;
  /// Its calibration history (history.h), under the key "history" beside the definition's; empty for a robot not
  /// registered from a calibration, and in documents of versions before 6.
  std::vector<StoredHistoryEntry> history;
};
void to_json(nlohmann::json& j, const StoredRobot& robot);
void from_json(const nlohmann::json& j, StoredRobot& robot);

/// A campaign: what POST /v1/campaigns fixed (the members of the campaign resource, campaigns.h), with a copy of
/// its robot's definition (so that deleting or re-registering the robot never changes a campaign).
struct StoredCampaign : CampaignDefinition {
  RegisterRobotRequest robot_definition;
};
template <>
struct WireFields<StoredCampaign> {
  static constexpr auto fields = std::tuple_cat(
      WireFields<CampaignDefinition>::fields,
      std::make_tuple(Field{"robot_definition", &StoredCampaign::robot_definition}));
  static void Check(const StoredCampaign& campaign) { WireFields<CampaignDefinition>::Check(campaign); }
};
/// Written by the table with schema_version; read after filling in what older versions left out.
void to_json(nlohmann::json& j, const StoredCampaign& campaign);
void from_json(const nlohmann::json& j, StoredCampaign& campaign);

/// A plan: the resource as returned.
struct StoredPlan {
  PlanResult plan;
};
void to_json(nlohmann::json& j, const StoredPlan& plan);
void from_json(const nlohmann::json& j, StoredPlan& plan);

/// A campaign's calibration: the fit as returned, and the state compensation, forward kinematics and evaluation
/// restore the core's Calibration from.
struct StoredCalibration {
  CalibrationResult result;
  /// The base registration the fit started from (tracker -> nominal base). Full poses: the quaternion required
  /// when read (rpy_deg is written beside it, derived, and never read).
  PoseResultWire registered_base;
  /// Calibrated tracker -> base and flange -> tool.
  PoseResultWire T_world_base;
  PoseResultWire T_flange_tool;
  /// The identified error vector (RobotModel's parameter order; mm and rad).
  std::vector<double> errors;
  /// The sequence number of the last calibration measurement the fit saw; it saw every calibration measurement
  /// up to it and none after (measurements are append-only in sequence order), its outliers included. Absent in
  /// fits stored before it was recorded.
  std::optional<std::int64_t> last_calibration_sequence;
  /// Version 5 on (absent: a fit stored before): the estimated parameters' covariance (Calibration::covariance,
  /// rows in result.parameters' order; mm and rad), the singular values of the fit's scaled Jacobian
  /// (IdentificationSummary::singular_values), the number of residual rows, each outlier's index among the
  /// measurements the fit was given (result.outliers' order) and the implausible joint terms.
  std::optional<std::vector<std::vector<double>>> covariance;
  std::vector<double> singular_values;
  int num_residuals = 0;
  std::vector<int> outlier_measurements;
  std::vector<std::string> implausible_joint_terms;
};
template <>
struct WireFields<StoredCalibration> {
  using S = StoredCalibration;
  static constexpr bool (*kWithCovariance)(const S&) = +[](const S& c) { return c.covariance.has_value(); };
  static constexpr auto fields = std::make_tuple(
      Field{"result", &S::result},
      Nested{"state", std::make_tuple(
                          Field{"registered_base", &S::registered_base},
                          Field{"T_world_base", &S::T_world_base},
                          Field{"T_flange_tool", &S::T_flange_tool},
                          Field{"errors", &S::errors},
                          Field{"last_calibration_sequence", &S::last_calibration_sequence, Presence::kOmitEmpty},
                          // Version 5 on: the rest of the state comes with the covariance (a state without it is one
                          // stored before, also when written again by this version).
                          Field{"covariance", &S::covariance, Presence::kOmitEmpty},
                          Field{"singular_values", &S::singular_values}.When(kWithCovariance),
                          Field{"num_residuals", &S::num_residuals}.When(kWithCovariance),
                          Field{"outlier_measurements", &S::outlier_measurements}.When(kWithCovariance),
                          Field{"implausible_joint_terms", &S::implausible_joint_terms}.When(kWithCovariance))});
};
void to_json(nlohmann::json& j, const StoredCalibration& calibration);
void from_json(const nlohmann::json& j, StoredCalibration& calibration);
/// The stored form of a finished fit.
StoredCalibration ToStored(const Calibration& calibration, const CalibrationResult& result);
/// The core Calibration back from its stored form, on the campaign's nominal model: the calibrated model, its
/// errors, parameters, covariance, frames and reflectors, and its whole summary (a fit stored before version 5
/// without covariance and singular values, and with outliers whose measurement index is unknown: -1). WireError
/// when the stored fit does not fit the robot (error count, parameter names, covariance size).
Calibration Restore(const RobotModel& nominal, const StoredCalibration& stored);

/// A cell: the resource as returned (every default filled in), with a copy of its robot's definition, so that
/// re-registering the robot never changes what the cell means.
struct StoredCell {
  CellWire cell;
  RegisterRobotRequest robot_definition;
};
template <>
struct WireFields<StoredCell> {
  static constexpr auto fields = std::make_tuple(Field{"cell", &StoredCell::cell},
                                                 Field{"robot_definition", &StoredCell::robot_definition});
};
void to_json(nlohmann::json& j, const StoredCell& cell);
void from_json(const nlohmann::json& j, StoredCell& cell);

/// An operation: the resource as last written.
struct StoredOperation {
  Operation operation;
};
void to_json(nlohmann::json& j, const StoredOperation& op);
void from_json(const nlohmann::json& j, StoredOperation& op);

}  // namespace robocal::api
