// Wire shapes of campaigns and their measurements: creating a campaign, the campaign resource (one shape for
// GET and for the items of the list), uploading a batch and its result, the stored measurements.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/batch_result.h"
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
template <>
struct WireFields<CampaignReflectorWire> {
  using S = CampaignReflectorWire;
  static constexpr auto fields =
      std::make_tuple(Field{"id", &S::id}.Mandatory().Size(0, 64).Rule(&IsValidId, kIdRule),
                      Field{"position_mm", &S::position_mm}.Mandatory(), Field{"fixed", &S::fixed});
  /// Within 10 m of the flange.
  static void CheckRequest(const S& reflector, const std::string& path, Problems* problems);
};
ROBOCAL_WIRE_DECLARE(CampaignReflectorWire);
std::vector<Reflector> ToCore(const std::vector<CampaignReflectorWire>& reflectors);
std::vector<CampaignReflectorWire> ToWire(const std::vector<Reflector>& reflectors);
/// A request's "reflectors" name each nest once.
void CheckReflectorIds(const std::vector<CampaignReflectorWire>& reflectors, Problems* problems);
/// The index of each measurement's reflector id among `reflectors` (-1 for none).
int ReflectorIndex(const std::vector<CampaignReflectorWire>& reflectors, const std::string& id);

/// POST /v1/campaigns, and the base of the campaign resource (CampaignDefinition): every field a client sets.
struct CreateCampaignRequest {
  std::string id;  // optional: generated when empty
  std::string description;
  std::string robot;
  /// Unset: the plan's measurement type when a plan is given, else position with reflectors, else pose. A
  /// campaign resource always has it (CampaignDefinition::type).
  std::optional<MeasurementType> measurement_type;
  /// The linked plan (its robot and measurement type must match); unset or empty: none.
  std::optional<std::string> plan;
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
/// The request sends what it sets; the resource (ResourceRows) writes and requires every field. Campaigns
/// stored before a field existed lack the Later() ones (read as no plan, tracker, repeatability, reflectors or
/// payload).
template <>
struct WireFields<CreateCampaignRequest> {
  using S = CreateCampaignRequest;
  static constexpr Presence kOmit = Presence::kOmitEmpty;
  static constexpr auto fields = std::make_tuple(
      Field{"id", &S::id, kOmit}.Rule(&IsValidId, kIdRule), Field{"description", &S::description, kOmit}.Size(0, 1024),
      Field{"robot", &S::robot}.Mandatory().Size(0, 64), Field{"measurement_type", &S::measurement_type, kOmit},
      Field{"plan", &S::plan, kOmit}.Size(0, 64).Later(), Field{"noise", &S::noise, kOmit},
      Field{"tracker", &S::tracker, kOmit}.Later(),
      Field{"repeatability_mm", &S::repeatability_mm, kOmit}.Range(0.0, 10.0).Later().Core(
          &MeasurementNoise::repeatability_mm),
      Field{"reflectors", &S::reflectors, kOmit}.Size(0, kMaxFitReflectors).Later(),
      Field{"payload", &S::payload, kOmit}.Later());
  static void CheckRequest(const S& request, const std::string& path, Problems* problems);
};
ROBOCAL_WIRE_DECLARE(CreateCampaignRequest);
CreateCampaignRequest ParseCreateCampaignRequest(const nlohmann::json& body);
/// The core's noise model of a campaign: its tracker model or isotropic noise, and what its rows link to the
/// core's MeasurementNoise (the robot's repeatability, ISO 9283 RP, shared by the shots of one configuration).
MeasurementNoise NoiseOf(const CreateCampaignRequest& campaign);

/// Stored measurements per role.
struct MeasurementCounts {
  std::int64_t calibration = 0;
  std::int64_t validation = 0;
  std::int64_t test = 0;
};
template <>
struct WireFields<MeasurementCounts> {
  static constexpr auto fields =
      std::make_tuple(Field{"calibration", &MeasurementCounts::calibration},
                      Field{"validation", &MeasurementCounts::validation}, Field{"test", &MeasurementCounts::test});
};
ROBOCAL_WIRE_DECLARE(MeasurementCounts);

/// What a campaign is, as POST /v1/campaigns fixed it: the request with every default filled in (an id, the
/// measurement type; a plan, tracker and payload null on the wire when none), and when it was created. The
/// members the campaign resource and its stored form (stored.h) share.
struct CampaignDefinition : CreateCampaignRequest {
  /// A campaign always has a measurement type: pose until it is set.
  CampaignDefinition() { measurement_type = MeasurementType::kPose; }

  std::int64_t created_unix_ms = 0;

  /// The measurement type, which a campaign always has (the server sets it on creation).
  MeasurementType type() const { return measurement_type.value(); }
};
template <>
struct WireFields<CampaignDefinition> {
  static constexpr auto fields =
      std::tuple_cat(ResourceRows(WireFields<CreateCampaignRequest>::fields),
                     std::make_tuple(Field{"created_unix_ms", &CampaignDefinition::created_unix_ms}));
  /// A campaign has a measurement type: null is no campaign's (the request's optional member is the resource's).
  static void Check(const CampaignDefinition& campaign);
};
ROBOCAL_WIRE_DECLARE(CampaignDefinition);

/// GET /v1/campaigns/{c}, the reply of POST /v1/campaigns, and each item of GET /v1/campaigns.
struct Campaign : CampaignDefinition {
  MeasurementCounts counts;
  /// Whether the campaign has a stored calibration (a fit that finished).
  bool calibrated = false;
};
template <>
struct WireFields<Campaign> {
  static constexpr auto fields =
      std::tuple_cat(WireFields<CampaignDefinition>::fields,
                     std::make_tuple(Field{"counts", &Campaign::counts}, Field{"calibrated", &Campaign::calibrated}));
  static void Check(const Campaign& campaign) { WireFields<CampaignDefinition>::Check(campaign); }
};
ROBOCAL_WIRE_DECLARE(Campaign);

/// GET /v1/campaigns: campaigns in id order; next_page_token when there are more.
struct CampaignList {
  std::vector<Campaign> campaigns;
  std::optional<std::string> next_page_token;
};
template <>
struct WireFields<CampaignList> {
  static constexpr auto fields =
      std::make_tuple(Field{"campaigns", &CampaignList::campaigns},
                      Field{"next_page_token", &CampaignList::next_page_token, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(CampaignList);

/// The most cycles an ISO 9283 test may have (the standard asks for 30).
inline constexpr int kMaxTestCycles = 10000;

/// One tracker shot on the wire: {"joints":[...], "pose":{...}} (joints deg / mm, pose in the tracker frame).
/// Also the stored form of a measurement.
struct MeasurementWire {
  std::vector<double> joints;
  PoseWire pose;
  /// The reflector shot (a campaign with reflectors); empty (absent on the wire) otherwise.
  std::string reflector{};
  /// The payload during the shot; unset (absent on the wire): the campaign's.
  std::optional<PayloadWire> payload{};
  /// Set by the server on upload: a stale tracker reading (it repeats the shot before it although the robot
  /// moved); fits leave it out.
  bool stale = false;
  /// A shot of role "test": the ISO 9283 pose ("P1".."P5") and the cycle (from 1) it belongs to; absent otherwise.
  std::string test_pose{};
  int cycle = 0;
};
template <>
struct WireFields<MeasurementWire> {
  using S = MeasurementWire;
  static constexpr auto fields =
      // Joints and pose need the robot and the campaign's measurement type: the batch's parser reads them.
      // The reflector must be one of the campaign's: the batch's parser reads it.
      std::make_tuple(Field{"joints", &S::joints}.Mandatory().Apart(), Field{"pose", &S::pose}.Mandatory().Apart(),
                      Field{"reflector", &S::reflector, Presence::kOmitEmpty}.Apart().Size(0, 64),
                      Field{"payload", &S::payload, Presence::kOmitEmpty},
                      Field{"stale", &S::stale, Presence::kServerOnly},
                      // Required with role "test" and refused otherwise: the batch's parser reads them.
                      Field{"test_pose", &S::test_pose, Presence::kOmitEmpty}.Apart(),
                      Field{"cycle", &S::cycle, Presence::kOmitEmpty}.Apart().Range(1, kMaxTestCycles));
};
ROBOCAL_WIRE_DECLARE(MeasurementWire);

/// POST /v1/campaigns/{c}/measurements.
struct MeasurementBatchRequest {
  std::string request_id;
  MeasurementRole role = MeasurementRole::kCalibration;
  std::vector<MeasurementWire> measurements;
};
template <>
struct WireFields<MeasurementBatchRequest> {
  using S = MeasurementBatchRequest;
  static constexpr auto fields = std::make_tuple(
      Field{"request_id", &S::request_id}.Mandatory().Size(0, 128).Rule(&IsValidRequestId, kRequestIdRule),
      Field{"role", &S::role}, Field{"measurements", &S::measurements}.Mandatory().Size(1, 0).Apart());
};
ROBOCAL_WIRE_DECLARE(MeasurementBatchRequest);
/// Reads the measurements of the list at `at` (each problem named by its path): joints within `model`'s limits,
/// the pose (orientation required unless `type` is position), the reflector (required and one of `reflectors` when
/// there are any, refused otherwise), the payload, and the test tags (required with role test, refused otherwise).
void ReadMeasurements(const nlohmann::json& list, const std::string& at, const RobotModel& model, MeasurementType type,
                      const std::vector<CampaignReflectorWire>& reflectors, MeasurementRole role, Problems* problems,
                      std::vector<MeasurementWire>* out);
/// Validates sizes, finiteness and joint limits against `model`; orientation is required unless `type` is
/// position; `reflector` is required and one of `reflectors` when the campaign has any, refused otherwise.
MeasurementBatchRequest ParseMeasurementBatchRequest(const nlohmann::json& body, const RobotModel& model,
                                                     MeasurementType type, const Limits& limits,
                                                     const std::vector<CampaignReflectorWire>& reflectors = {});

/// The reply of POST /v1/campaigns/{c}/measurements (batch_result.h: also what the storage's append returns).
template <>
struct WireFields<BatchResult> {
  using S = BatchResult;
  static constexpr auto fields = std::make_tuple(
      Field{"campaign", &S::campaign}, Field{"batch_id", &S::batch_id}, Field{"request_id", &S::request_id},
      Field{"replayed", &S::replayed}, Field{"first_sequence", &S::first_sequence}, Field{"count", &S::count},
      Field{"campaign_total", &S::campaign_total},
      Field{"stale", &S::stale, Presence::kOmitEmpty}.Range(1, RequestRule::kNoBound));
};
ROBOCAL_WIRE_DECLARE(BatchResult);

/// One stored measurement of GET /v1/campaigns/{c}/measurements: its place and role, beside the measurement's own
/// members ("joints", "pose", ...).
struct StoredMeasurementWire : MeasurementWire {
  std::int64_t sequence = 0;
  std::string batch_id;
  MeasurementRole role = MeasurementRole::kCalibration;
};
template <>
struct WireFields<StoredMeasurementWire> {
  using S = StoredMeasurementWire;
  static constexpr auto fields = std::tuple_cat(
      std::make_tuple(Field{"sequence", &S::sequence}, Field{"batch_id", &S::batch_id}, Field{"role", &S::role}),
      WireFields<MeasurementWire>::fields);
};
ROBOCAL_WIRE_DECLARE(StoredMeasurementWire);

/// GET /v1/campaigns/{c}/measurements: one page; next_after (the sequence to continue after) when there may be
/// more.
struct MeasurementList {
  std::string campaign;
  std::vector<StoredMeasurementWire> measurements;
  std::optional<std::int64_t> next_after;
};
template <>
struct WireFields<MeasurementList> {
  using S = MeasurementList;
  static constexpr auto fields =
      std::make_tuple(Field{"campaign", &S::campaign}, Field{"measurements", &S::measurements},
                      Field{"next_after", &S::next_after, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(MeasurementList);

}  // namespace robocal::api
