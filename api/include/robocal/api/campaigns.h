// Wire shapes of campaigns and their measurements: creating a campaign, the campaign resource (one shape for
// GET and for the items of the list), uploading a batch and its result, the stored measurements.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/wire.h"
#include "robocal/core/reflectors.h"
#include "robocal/core/robot_model.h"

namespace robocal::api {

/// A reflector of a position campaign (docs/identification.md, "Several reflectors per pose"): its id (the
/// id rule), where it sits on the flange (mm, flange frame) and whether that position is known (fixed, held)
/// or its offset is identified. In a fit result: the identified position.
struct CampaignReflectorWire {
  std::string id;
  std::array<double, 3> position_mm{0.0, 0.0, 0.0};
  bool fixed = false;
};
void to_json(nlohmann::json& j, const CampaignReflectorWire& reflector);
void from_json(const nlohmann::json& j, CampaignReflectorWire& reflector);
std::vector<Reflector> ToCore(const std::vector<CampaignReflectorWire>& reflectors);
std::vector<CampaignReflectorWire> ToWire(const std::vector<Reflector>& reflectors);
class Problems;
/// Reads a request's "reflectors" (at most max_count; ids by the id rule and unique; positions finite within
/// 10 m of the flange), recording every problem.
void ParseReflectors(const nlohmann::json* value, Problems* problems, std::vector<CampaignReflectorWire>* out,
                     std::size_t max_count);
/// The index of each measurement's reflector id among `reflectors` (-1 for none).
int ReflectorIndex(const std::vector<CampaignReflectorWire>& reflectors, const std::string& id);

/// POST /v1/campaigns.
struct CreateCampaignRequest {
  std::string id;  // optional: generated when empty
  std::string description;
  std::string robot;
  /// Unset: the plan's measurement type when a plan is given, else pose.
  std::optional<MeasurementType> measurement_type;
  std::string plan;  // optional plan id (its robot and measurement type must match)
  NoiseWire noise;
  /// The tracker's uncertainty model; given, the fit whitens residuals by it and `noise` is unused.
  std::optional<TrackerModelWire> tracker;
  /// The robot's repeatability, ISO 9283 RP (mm, [0, 10]): the shots of one joint configuration share an error
  /// of this size, which the fit models (docs/identification.md, "Weighting"). 0: not modelled.
  double repeatability_mm = 0.0;
  /// Several reflectors on the tool (position campaigns, at most kMaxFitReflectors): every measurement then
  /// names the one it shot.
  std::vector<CampaignReflectorWire> reflectors;
  /// The payload the robot carries while it is measured (and, unless a target says otherwise, while it is
  /// compensated), for measurements that do not state their own; unset: none.
  std::optional<PayloadWire> payload;
};
CreateCampaignRequest ParseCreateCampaignRequest(const nlohmann::json& body);
void to_json(nlohmann::json& j, const CreateCampaignRequest& request);
void from_json(const nlohmann::json& j, CreateCampaignRequest& request);

/// Stored measurements per role.
struct MeasurementCounts {
  std::int64_t calibration = 0;
  std::int64_t validation = 0;
};
void to_json(nlohmann::json& j, const MeasurementCounts& counts);
void from_json(const nlohmann::json& j, MeasurementCounts& counts);

/// GET /v1/campaigns/{c}, the reply of POST /v1/campaigns, and each item of GET /v1/campaigns.
struct Campaign {
  std::string id;
  std::string description;
  std::string robot;
  MeasurementType measurement_type = MeasurementType::kPose;
  /// The linked plan (null on the wire when none).
  std::optional<std::string> plan;
  NoiseWire noise;
  /// Null on the wire when the campaign weights by `noise`.
  std::optional<TrackerModelWire> tracker;
  double repeatability_mm = 0.0;
  std::vector<CampaignReflectorWire> reflectors;
  /// The campaign's default payload (null on the wire when none).
  std::optional<PayloadWire> payload;
  std::int64_t created_unix_ms = 0;
  MeasurementCounts counts;
  /// Whether the campaign has a stored calibration (a fit that finished).
  bool calibrated = false;
};
void to_json(nlohmann::json& j, const Campaign& campaign);
void from_json(const nlohmann::json& j, Campaign& campaign);

/// GET /v1/campaigns: campaigns in id order; next_page_token when there are more.
struct CampaignList {
  std::vector<Campaign> campaigns;
  std::optional<std::string> next_page_token;
};
void to_json(nlohmann::json& j, const CampaignList& list);
void from_json(const nlohmann::json& j, CampaignList& list);

/// One tracker shot on the wire: {"joints":[...], "pose":{...}} (joints deg / mm, pose in the tracker frame).
/// Also the stored form of a measurement.
struct MeasurementWire {
  std::vector<double> joints;
  PoseWire pose;
  /// The reflector shot (a campaign with reflectors); empty (absent on the wire) otherwise.
  std::string reflector;
  /// The payload during the shot; unset (absent on the wire): the campaign's.
  std::optional<PayloadWire> payload;
};
void to_json(nlohmann::json& j, const MeasurementWire& measurement);
void from_json(const nlohmann::json& j, MeasurementWire& measurement);

/// POST /v1/campaigns/{c}/measurements.
struct MeasurementBatchRequest {
  std::string request_id;
  MeasurementRole role = MeasurementRole::kCalibration;
  std::vector<MeasurementWire> measurements;
};
/// Validates sizes, finiteness and joint limits against `model`; orientation is required unless `type` is
/// position; `reflector` is required and one of `reflectors` when the campaign has any, refused otherwise.
MeasurementBatchRequest ParseMeasurementBatchRequest(const nlohmann::json& body, const RobotModel& model,
                                                     MeasurementType type, const Limits& limits,
                                                     const std::vector<CampaignReflectorWire>& reflectors = {});
void to_json(nlohmann::json& j, const MeasurementBatchRequest& request);
void from_json(const nlohmann::json& j, MeasurementBatchRequest& request);

/// The reply of POST /v1/campaigns/{c}/measurements.
struct BatchResult {
  std::string campaign;
  std::string batch_id;
  std::string request_id;
  /// True if the server had this request_id with the same content already (nothing was written twice).
  bool replayed = false;
  std::int64_t first_sequence = 0;
  std::int64_t count = 0;
  std::int64_t campaign_total = 0;
};
void to_json(nlohmann::json& j, const BatchResult& result);
void from_json(const nlohmann::json& j, BatchResult& result);

/// One stored measurement of GET /v1/campaigns/{c}/measurements.
struct StoredMeasurementWire {
  std::int64_t sequence = 0;
  std::string batch_id;
  MeasurementRole role = MeasurementRole::kCalibration;
  MeasurementWire measurement;  // "joints" and "pose" beside the fields above
};
void to_json(nlohmann::json& j, const StoredMeasurementWire& measurement);
void from_json(const nlohmann::json& j, StoredMeasurementWire& measurement);

/// GET /v1/campaigns/{c}/measurements: one page; next_after (the sequence to continue after) when there may be
/// more.
struct MeasurementList {
  std::string campaign;
  std::vector<StoredMeasurementWire> measurements;
  std::optional<std::int64_t> next_after;
};
void to_json(nlohmann::json& j, const MeasurementList& list);
void from_json(const nlohmann::json& j, MeasurementList& list);

}  // namespace robocal::api
