// The documents the server stores: their own versioned schema, not the request schema re-parsed. Reading a
// stored document checks its structure only (WireReader), never the request limits: tightening request
// validation must not make stored robots, plans, campaigns or calibrations unreadable.
//
// Versions: 1 is every document written before the field "schema_version" existed (the same members as version
// 2, without it; plans and fits recorded deadline_exceeded only when true); 2 adds "schema_version"; 3 adds
// cells, and plans gain "cell" and "configuration_checks"; 4 adds the campaign's "tracker" model and "repeatability_mm" and the fit's
// robust-fit members (outliers, parameters_with_outliers). A fit's state may hold "last_calibration_sequence"
// (optional, so version 4 still: a server that does not know it ignores it, and a fit without it reads as before).
// A document of a version newer than kStoredSchemaVersion is refused by name rather than misread.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/cells.h"
#include "robocal/api/operations.h"
#include "robocal/api/plans.h"
#include "robocal/api/robots.h"
#include "robocal/core/identification.h"

namespace robocal::api {

inline constexpr int kStoredSchemaVersion = 4;

/// The schema version of a stored document (1 when it has none); WireError if newer than this server reads.
int StoredSchemaVersion(const nlohmann::json& document);

/// A registered robot: its definition.
struct StoredRobot {
  RegisterRobotRequest definition;
};
void to_json(nlohmann::json& j, const StoredRobot& robot);
void from_json(const nlohmann::json& j, StoredRobot& robot);

/// A campaign: what POST /v1/campaigns fixed, with a copy of its robot's definition (so that deleting or
/// re-registering the robot never changes a campaign).
struct StoredCampaign {
  std::string id;
  std::string description;
  std::string robot;
  RegisterRobotRequest robot_definition;
  MeasurementType measurement_type = MeasurementType::kPose;
  std::optional<std::string> plan;
  NoiseWire noise;
  std::optional<TrackerModelWire> tracker;
  double repeatability_mm = 0.0;
  std::vector<CampaignReflectorWire> reflectors;
  std::optional<PayloadWire> payload;
  std::int64_t created_unix_ms = 0;
};
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
  /// The base registration the fit started from (tracker -> nominal base).
  PoseWire registered_base;
  /// Calibrated tracker -> base and flange -> tool.
  PoseWire T_world_base;
  PoseWire T_flange_tool;
  /// The identified error vector (RobotModel's parameter order; mm and rad).
  std::vector<double> errors;
  /// The sequence number of the last calibration measurement the fit saw; it saw every calibration measurement
  /// up to it and none after (measurements are append-only in sequence order), its outliers included. Absent in
  /// fits stored before it was recorded.
  std::optional<std::int64_t> last_calibration_sequence;
};
void to_json(nlohmann::json& j, const StoredCalibration& calibration);
void from_json(const nlohmann::json& j, StoredCalibration& calibration);
/// The stored form of a finished fit.
StoredCalibration ToStored(const Calibration& calibration, const CalibrationResult& result);
/// The core Calibration back from its stored form, on the campaign's nominal model; its summary keeps the
/// stored fit's termination and message.
Calibration Restore(const RobotModel& nominal, const StoredCalibration& stored);

/// A cell: the resource as returned (every default filled in), with a copy of its robot's definition, so that
/// re-registering the robot never changes what the cell means.
struct StoredCell {
  CellWire cell;
  RegisterRobotRequest robot_definition;
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
