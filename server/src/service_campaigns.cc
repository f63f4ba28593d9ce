// The service's campaigns and their measurements.
#include <cmath>

#include "robocal/api/tracker_files.h"
#include "robocal/core/iso9283.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;

// A query integer in [0, max] (problem recorded at `field` otherwise); `fallback` when empty.
std::int64_t QueryInt(const std::string& text, const char* field, std::int64_t fallback, std::int64_t max,
                      api::Problems* problems) {
  if (text.empty()) return fallback;
  try {
    std::size_t used = 0;
    const long long v = std::stoll(text, &used);
    if (used == text.size() && v >= 0 && v <= max) return static_cast<std::int64_t>(v);
  } catch (const std::exception&) {
  }
  problems->Add(field, "expected an integer in [0, " + std::to_string(max) + "]");
  return fallback;
}

}  // namespace

api::StoredCampaign Service::LoadCampaign(const std::string& id) {
  CheckId(id, "campaign");
  const auto doc = storage_->Get(kCampaigns, id);
  if (!doc) throw ApiError(Status::kNotFound, "campaign \"" + id + "\" not found");
  return ReadStored<api::StoredCampaign>(*doc);
}

api::Campaign Service::CampaignResource(const api::StoredCampaign& s) {
  api::Campaign c;
  static_cast<api::CampaignDefinition&>(c) = s;
  c.counts.calibration = storage_->CountMeasurements(s.id, "calibration");
  c.counts.validation = storage_->CountMeasurements(s.id, "validation");
  c.counts.test = storage_->CountMeasurements(s.id, "test");
  c.calibrated = storage_->Get(kCalibrations, s.id).has_value();
  return c;
}

api::Campaign Service::CreateCampaign(const nlohmann::json& body) {
  api::StoredCampaign campaign;
  // The request is the campaign's base: what the client set, then the defaults filled in.
  static_cast<api::CreateCampaignRequest&>(campaign) = api::ParseCreateCampaignRequest(body);
  const api::CreateCampaignRequest& req = campaign;
  const std::optional<MeasurementType> requested_type = req.measurement_type;
  campaign.robot_definition = ResolveRobot(req.robot).definition;
  // Reflector nests are for a position tracker: with them the type defaults to position.
  campaign.measurement_type =
      requested_type.value_or(req.reflectors.empty() ? MeasurementType::kPose : MeasurementType::kPosition);
  if (campaign.plan && campaign.plan->empty()) campaign.plan.reset();
  if (campaign.plan) {
    const std::string& plan_id = *campaign.plan;
    const api::PlanResult plan = GetPlan(plan_id);
    if (plan.robot != req.robot) {
      throw ApiError(Status::kFailedPrecondition, "plan \"" + plan_id + "\" is for robot " + plan.robot,
                     {{"plan", "planned for another robot"}});
    }
    if (!requested_type) campaign.measurement_type = plan.measurement_type;
    if (!req.reflectors.empty() && !requested_type && plan.measurement_type != MeasurementType::kPosition) {
      throw ApiError(Status::kInvalidArgument, "invalid campaign: reflectors need position measurements",
                     {{"reflectors", "need position measurements; plan \"" + plan_id + "\" measures " +
                                         api::WireName(plan.measurement_type)}});
    }
  }
  if (campaign.id.empty()) campaign.id = NewId("c");
  if (!campaign.reflectors.empty() && campaign.type() != MeasurementType::kPosition) {
    throw ApiError(Status::kInvalidArgument, "invalid campaign: reflectors need position measurements",
                   {{"reflectors", std::string("need position measurements; measurement_type is ") +
                                       api::WireName(campaign.type())}});
  }
  campaign.created_unix_ms = NowUnixMs();
  try {
    storage_->Create(kCampaigns, campaign.id, nlohmann::json(campaign).dump());
  } catch (const StorageError& e) {
    if (e.kind() == StorageError::Kind::kAlreadyExists) {
      throw ApiError(Status::kAlreadyExists, "campaign \"" + campaign.id + "\" already exists",
                     {{"id", "already exists"}});
    }
    throw;
  }
  return CampaignResource(campaign);
}

api::Campaign Service::GetCampaign(const std::string& id) { return CampaignResource(LoadCampaign(id)); }

api::CampaignList Service::ListCampaigns(const std::string& page_size, const std::string& page_token) {
  const PageRequest page = ParsePageRequest(kCampaigns, page_size, page_token);
  auto docs = storage_->List(kCampaigns, page.token, static_cast<int>(page.size + 1));
  const bool more = docs.size() > page.size;
  if (more) docs.resize(page.size);
  api::CampaignList list;
  for (const Document& d : docs) list.campaigns.push_back(CampaignResource(ReadStored<api::StoredCampaign>(d)));
  if (more) list.next_page_token = PageToken(kCampaigns, docs.back().id);
  return list;
}

namespace {

// A campaign with nests needs every imported point's nest.
void RequireNestColumn(const std::string& campaign_id, const api::StoredCampaign& campaign,
                       const api::ImportMeasurementsRequest& req) {
  if (!campaign.reflectors.empty() && req.columns.reflector.empty()) {
    throw ApiError(Status::kInvalidArgument,
                   "campaign \"" + campaign_id + "\" has reflectors: every point must name its nest",
                   {{"columns.reflector", "required for a campaign with reflectors (format csv)"}});
  }
}

// The joints of the campaign's robot, as its definition has them.
std::size_t RobotJoints(const api::StoredCampaign& campaign) {
  return campaign.robot_definition.joints.empty()
             ? static_cast<std::size_t>(api::BuildModel(campaign.robot_definition).num_joints())
             : campaign.robot_definition.joints.size();
}

// The shot stored last in a campaign, if any.
std::optional<Measurement> LastStored(Storage* storage, const api::StoredCampaign& campaign, const RobotModel& model) {
  const std::int64_t total = storage->CountMeasurements(campaign.id, "");
  if (total <= 0) return std::nullopt;
  const std::vector<StoredMeasurement> last = storage->ListMeasurements(campaign.id, "", total - 1, 1);
  if (last.empty()) return std::nullopt;
  return MeasurementToCore(model, ReadMeasurement(last.front()), campaign);
}

// The stale tracker readings (FlagStaleShots) among `measurements` in their order, the first against `before`.
std::vector<char> StaleFlags(const api::StoredCampaign& campaign, const RobotModel& model,
                             const std::vector<api::MeasurementWire>& measurements,
                             const std::optional<Measurement>& before) {
  std::vector<Measurement> shots;
  shots.reserve(measurements.size());
  for (const api::MeasurementWire& m : measurements) shots.push_back(MeasurementToCore(model, m, campaign));
  return FlagStaleShots(model, shots, campaign.type(), campaign.repeatability_mm, {}, before ? &*before : nullptr);
}

// The points of a tracker file; every bad line (and too many points for one batch) thrown as one error.
std::vector<api::TrackerPoint> ReadPoints(const api::ImportMeasurementsRequest& req, std::size_t max_points) {
  api::Problems problems;
  std::vector<api::TrackerPoint> points = api::ReadTrackerPoints(req, &problems);
  if (points.size() > max_points) {
    problems.Add("text", std::to_string(points.size()) +
                             " points exceed the server's limit max_array_length = " + std::to_string(max_points));
  }
  problems.ThrowIfAny("invalid tracker file");
  return points;
}

}  // namespace

api::BatchResult Service::ImportMeasurements(const std::string& campaign_id, const nlohmann::json& body) {
  const api::ImportMeasurementsRequest req = api::ParseImportMeasurementsRequest(body);
  const api::StoredCampaign campaign = LoadCampaign(campaign_id);
  if (!req.joints.columns.empty()) return ImportMeasurementsWithJoints(campaign_id, campaign, req);
  // A point export carries positions: the campaign must measure positions, with its nests named per point.
  if (campaign.type() != MeasurementType::kPosition) {
    throw ApiError(Status::kFailedPrecondition,
                   "campaign \"" + campaign_id + "\" measures " + api::WireName(campaign.type()) +
                       "; a tracker point export carries positions only",
                   {{"format", "points only: import into a position campaign"}});
  }
  RequireNestColumn(campaign_id, campaign, req);
  const std::string plan_id = !req.plan.empty() ? req.plan : campaign.plan.value_or("");
  if (plan_id.empty()) {
    throw ApiError(Status::kInvalidArgument, "no plan: the points are matched to a plan's configurations",
                   {{"plan", "required: the campaign was not created from a plan"}});
  }
  api::PlanResult plan;
  try {
    plan = GetPlan(plan_id);
  } catch (const ApiError& e) {
    if (e.status() != Status::kNotFound) throw;
    throw ApiError(Status::kInvalidArgument, "plan \"" + plan_id + "\" does not exist", {{"plan", "unknown plan"}});
  }
  if (plan.robot != campaign.robot) {
    throw ApiError(
        Status::kInvalidArgument,
        "plan \"" + plan_id + "\" is for robot \"" + plan.robot + "\", the campaign's is \"" + campaign.robot + "\"",
        {{"plan", "a plan of another robot"}});
  }
  const std::vector<api::TrackerPoint> points = ReadPoints(req, options_.limits.max_array_length);
  // A plan of a robot that was deleted and registered again with other joints matches no more.
  const std::size_t joints = RobotJoints(campaign);
  if (!plan.configurations.empty() && plan.configurations.front().size() != joints) {
    throw ApiError(Status::kInvalidArgument,
                   "plan \"" + plan_id + "\" has configurations of " +
                       std::to_string(plan.configurations.front().size()) + " joints, the campaign's robot " +
                       std::to_string(joints),
                   {{"plan", "made for another robot of this name"}});
  }
  api::Problems problems;
  api::MeasurementBatchRequest batch =
      api::MatchToConfigurations(req, points, plan.configurations, &problems, campaign.reflectors);
  problems.ThrowIfAny("invalid tracker file");
  for (api::MeasurementWire& m : batch.measurements) m.payload = req.payload;
  // The batch goes the way of every upload: the campaign's checks, one transaction, the request id's replay.
  return StoreImported(campaign, req, points, std::move(batch));
}

api::BatchResult Service::StoreImported(const api::StoredCampaign& campaign, const api::ImportMeasurementsRequest& req,
                                        const std::vector<api::TrackerPoint>& points,
                                        api::MeasurementBatchRequest batch) {
  const RobotModel model = api::BuildModel(campaign.robot_definition);
  // The campaign's checks, on every row (those not stored too: they are the same file).
  batch = api::ParseMeasurementBatchRequest(nlohmann::json(batch), model, campaign.type(), options_.limits,
                                            campaign.reflectors);
  // Stale readings in the file's own order; its first row against the shot stored last when every row is stored
  // (a file split by rows is compared within itself).
  const std::vector<char> flags =
      StaleFlags(campaign, model, batch.measurements,
                 req.rows.empty() ? LastStored(storage_, campaign, model) : std::optional<Measurement>());
  if (req.rows.empty()) return StoreBatch(campaign, model, std::move(batch), flags);
  // Only the rows asked for; each must be a data row of the file.
  std::vector<api::MeasurementWire> kept;
  std::vector<char> kept_flags;
  api::Problems problems;
  std::size_t p = 0;
  for (std::size_t k = 0; k < req.rows.size(); ++k) {
    while (p < points.size() && points[p].line < req.rows[k]) ++p;
    if (p == points.size() || points[p].line != req.rows[k]) {
      problems.Add(api::IndexPath("rows", k), "line " + std::to_string(req.rows[k]) + " is not a data row of the text");
      continue;
    }
    kept.push_back(batch.measurements[p]);
    kept_flags.push_back(flags[p]);
  }
  problems.ThrowIfAny("invalid measurement import");
  batch.measurements = std::move(kept);
  return StoreBatch(campaign, model, std::move(batch), kept_flags);
}

api::BatchResult Service::ImportMeasurementsWithJoints(const std::string& campaign_id,
                                                       const api::StoredCampaign& campaign,
                                                       const api::ImportMeasurementsRequest& req) {
  // An export with joints needs no plan; a 6-DoF campaign needs the measured orientation.
  if (campaign.type() != MeasurementType::kPosition && req.orientation.empty()) {
    throw ApiError(Status::kInvalidArgument,
                   "campaign \"" + campaign_id + "\" measures " + api::WireName(campaign.type()) +
                       ": the file's orientation columns are needed",
                   {{"orientation", std::string("required for a ") + api::WireName(campaign.type()) + " campaign"}});
  }
  RequireNestColumn(campaign_id, campaign, req);
  const std::size_t joints = RobotJoints(campaign);
  if (req.joints.columns.size() != joints) {
    throw ApiError(Status::kInvalidArgument,
                   "the file names " + std::to_string(req.joints.columns.size()) + " joint columns, robot \"" +
                       campaign.robot + "\" has " + std::to_string(joints) + " joints",
                   {{"joints.columns", "one column per joint of the robot, in its order"}});
  }
  const std::vector<api::TrackerPoint> points = ReadPoints(req, options_.limits.max_array_length);
  api::Problems problems;
  api::MeasurementBatchRequest batch = api::PointsWithJoints(req, points, &problems, campaign.reflectors);
  problems.ThrowIfAny("invalid tracker file");
  for (api::MeasurementWire& m : batch.measurements) m.payload = req.payload;
  // The batch goes the way of every upload: the campaign's checks (joint limits among them), one transaction,
  // the request id's replay.
  return StoreImported(campaign, req, points, std::move(batch));
}

api::BatchResult Service::AppendMeasurements(const std::string& campaign_id, const nlohmann::json& body) {
  const api::StoredCampaign campaign = LoadCampaign(campaign_id);
  const RobotModel model = api::BuildModel(campaign.robot_definition);
  const api::MeasurementBatchRequest req =
      api::ParseMeasurementBatchRequest(body, model, campaign.type(), options_.limits, campaign.reflectors);
  if (req.role == api::MeasurementRole::kTest) CheckTestShots(campaign, req);
  return StoreBatch(campaign, model, req, std::nullopt);
}

void Service::CheckTestShots(const api::StoredCampaign& campaign, const api::MeasurementBatchRequest& req) {
  if (!campaign.plan) return;
  const auto doc = storage_->Get(kPlans, *campaign.plan);
  if (!doc) return;
  const std::optional<api::Iso9283PlanWire> test = ReadStored<api::StoredPlan>(*doc).plan.test;
  if (!test) return;
  // A shot of a test plan's campaign is one of its visits: a cycle it has, at the joints it commands for the pose
  // (to 0.01 deg / mm: what a controller reports back of its command).
  constexpr double kCommandTolerance = 0.01;
  api::Problems problems;
  for (std::size_t i = 0; i < req.measurements.size(); ++i) {
    const api::MeasurementWire& m = req.measurements[i];
    const std::string path = api::IndexPath("measurements", i);
    if (m.cycle > test->cycles) {
      problems.Add(api::JoinPath(path, "cycle"),
                   "the test plan " + *campaign.plan + " has " + std::to_string(test->cycles) + " cycles");
    }
    const int pose = Iso9283PoseIndex(m.test_pose);
    if (pose < 0 || static_cast<std::size_t>(pose) >= test->poses.size()) continue;
    const std::vector<double>& command = test->poses[static_cast<std::size_t>(pose)].joints;
    bool same = command.size() == m.joints.size();
    for (std::size_t j = 0; same && j < command.size(); ++j)
      same = std::abs(command[j] - m.joints[j]) <= kCommandTolerance;
    if (!same) {
      problems.Add(api::JoinPath(path, "joints"), "not the joint commands of " + m.test_pose + " in the test plan " +
                                                      *campaign.plan + " (to 0.01 deg / mm)");
    }
    if (problems.size() > 100) break;
  }
  problems.ThrowIfAny("invalid test shots");
}

api::BatchResult Service::StoreBatch(const api::StoredCampaign& campaign, const RobotModel& model,
                                     api::MeasurementBatchRequest req, std::optional<std::vector<char>> stale) {
  const TrimWhenDone trim(&trimmer_, req.measurements.size() >= kLargeRequest);
  // Against the shot stored last (a concurrent upload may come between: then against the one stored last at the
  // time of this one), then the batch's own in order.
  if (!stale) stale = StaleFlags(campaign, model, req.measurements, LastStored(storage_, campaign, model));
  // The request id's replay compares the client's content: the texts without the server's stale flags (a flag is
  // written only when set, so only a flagged measurement's text is written again with it).
  const std::string role = api::WireName(req.role);
  std::string all = role;
  std::vector<std::string> texts;
  texts.reserve(req.measurements.size());
  for (std::size_t i = 0; i < req.measurements.size(); ++i) {
    api::MeasurementWire& m = req.measurements[i];
    m.stale = false;
    texts.push_back(nlohmann::json(m).dump());
    all += "\n" + texts.back();
    if (i < stale->size() && (*stale)[i] != 0) {
      m.stale = true;
      texts.back() = nlohmann::json(m).dump();
    }
  }
  BatchResult r;
  try {
    r = storage_->AppendMeasurements(campaign.id, req.request_id, api::ContentHash(all), role, texts,
                                     options_.max_measurements_per_campaign);
  } catch (const StorageError& e) {
    if (e.kind() == StorageError::Kind::kAlreadyExists) {
      throw ApiError(Status::kAlreadyExists, "request_id \"" + req.request_id + "\" was used before with other content",
                     {{"request_id", "reused with different content"}});
    }
    if (e.kind() == StorageError::Kind::kResourceExhausted) {
      const std::string limit = std::to_string(options_.max_measurements_per_campaign);
      throw ApiError(Status::kResourceExhausted,
                     "the campaign would exceed max_measurements_per_campaign (" + limit + ")",
                     {{"measurements", "limit max_measurements_per_campaign = " + limit}});
    }
    throw;
  }
  // The batch's stale readings as stored (a replay's: as the first time).
  if (r.replayed) {
    for (const StoredMeasurement& m :
         storage_->ListMeasurements(campaign.id, "", r.first_sequence - 1, static_cast<int>(r.count))) {
      if (ReadMeasurement(m).stale) r.stale.push_back(m.sequence);
    }
  } else {
    for (std::size_t i = 0; i < stale->size(); ++i) {
      if ((*stale)[i]) r.stale.push_back(r.first_sequence + static_cast<std::int64_t>(i));
    }
  }
  return r;
}

api::MeasurementList Service::ListMeasurements(const std::string& campaign_id, const std::string& role,
                                               const std::string& after, const std::string& limit) {
  (void)LoadCampaign(campaign_id);
  api::Problems problems;
  api::MeasurementRole parsed_role{};
  if (!role.empty() && !api::FromWireName(role, &parsed_role)) {
    problems.Add("role", "expected calibration or validation");
  }
  const std::int64_t after_seq = QueryInt(after, "after", 0, INT64_MAX, &problems);
  const std::int64_t page =
      QueryInt(limit, "limit", 1000, static_cast<std::int64_t>(options_.limits.max_array_length), &problems);
  problems.ThrowIfAny("invalid query");
  const auto stored = storage_->ListMeasurements(campaign_id, role, after_seq, static_cast<int>(page));
  api::MeasurementList list;
  list.campaign = campaign_id;
  for (const StoredMeasurement& m : stored) {
    api::StoredMeasurementWire w;
    w.sequence = m.sequence;
    w.batch_id = m.batch_id;
    if (!api::FromWireName(m.role, &w.role)) {
      throw ApiError(Status::kInternal, "stored measurement " + std::to_string(m.sequence) + " has role " + m.role);
    }
    static_cast<api::MeasurementWire&>(w) = ReadMeasurement(m);
    list.measurements.push_back(std::move(w));
  }
  if (static_cast<std::int64_t>(stored.size()) == page && page > 0) list.next_after = stored.back().sequence;
  return list;
}

}  // namespace robocal::server
