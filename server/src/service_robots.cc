// The service's robots: presets and registered robots, forward kinematics.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <set>
#include <vector>

#include "robocal/core/dh_table.h"
#include "robocal/core/presets.h"
#include "robocal/urdf/urdf_import.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;

}  // namespace

bool IsPresetRobot(const std::string& id) {
  const auto names = PresetNames();
  return std::find(names.begin(), names.end(), id) != names.end();
}

Service::Service(Storage* storage, ServiceOptions options)
    : storage_(storage),
      options_(std::move(options)),
      operations_(storage, &trimmer_,
                  OperationRunnerOptions{.max_running = options_.max_running_operations,
                                         .lease = options_.operation_lease,
                                         .owner = {}}) {}

Service::~Service() = default;

Service::ResolvedRobot Service::ResolveRobot(const std::string& id) {
  if (IsPresetRobot(id)) {
    api::RegisterRobotRequest definition;
    definition.id = id;
    definition.from_preset = id;
    return {Preset(id), definition};
  }
  api::RegisterRobotRequest definition = LoadRobotDocument(id).second.definition;
  return {api::BuildModel(definition), std::move(definition)};
}

std::pair<Document, api::StoredRobot> Service::LoadRobotDocument(const std::string& id) {
  CheckId(id, "robot");
  auto doc = storage_->Get(kRobots, id);
  if (!doc) throw ApiError(Status::kNotFound, "robot \"" + id + "\" not found", {{"robot", "unknown robot"}});
  api::StoredRobot robot = ReadStored<api::StoredRobot>(*doc);
  return {std::move(*doc), std::move(robot)};
}

api::RobotList Service::ListRobots(const std::string& page_size, const std::string& page_token) {
  const PageRequest page = ParsePageRequest(kRobots, page_size, page_token);
  // One ordering over presets then registered robots (whose ids never equal a preset's name), so a token is
  // simply the last id returned.
  const std::vector<std::string> presets = PresetNames();
  auto preset = std::find(presets.begin(), presets.end(), page.token);
  const bool in_presets = page.token.empty() || preset != presets.end();
  api::RobotList list;
  bool more = false;
  if (in_presets) {
    preset = page.token.empty() ? presets.begin() : std::next(preset);
    for (; preset != presets.end(); ++preset) {
      if (list.robots.size() == page.size) {
        more = true;
        break;
      }
      list.robots.push_back(api::RobotFromModel(*preset, Preset(*preset), true, PresetDescription(*preset)));
    }
  }
  if (!more) {
    const std::size_t room = page.size - list.robots.size();
    auto docs = storage_->List(kRobots, in_presets ? "" : page.token, static_cast<int>(room + 1));
    if (docs.size() > room) {
      more = true;
      docs.resize(room);
    }
    for (const Document& d : docs) {
      const api::RegisterRobotRequest definition = ReadStored<api::StoredRobot>(d).definition;
      list.robots.push_back(RobotResource(d.id, api::BuildModel(definition), definition));
    }
  }
  if (more) list.next_page_token = PageToken(kRobots, list.robots.back().id);
  return list;
}

api::RegisterRobotRequest Service::DefinitionFromCalibration(const api::RobotFromCalibrationRequest& req) {
  const Calibrated loaded = [&] {
    try {
      return LoadCalibrated(req.campaign);
    } catch (const ApiError& e) {
      if (e.status() == Status::kNotFound) {
        throw ApiError(Status::kInvalidArgument, "campaign \"" + req.campaign + "\" does not exist",
                       {{"from_calibration", "unknown campaign"}});
      }
      if (e.status() == Status::kFailedPrecondition) {
        throw ApiError(Status::kFailedPrecondition, e.what(), {{"from_calibration", "the campaign is not calibrated"}});
      }
      throw;
    }
  }();
  // The calibrated chain from the nominal base (the tracker -> base registration belongs to the campaign's cell);
  // the tool as calibrated, a start for the next cell's frames fit; the joint terms held by the joints.
  const RobotModelSpec spec = CalibratedTransformSpec(
      loaded.model.WithErrorTerms(loaded.calibration.model.error_terms()), loaded.calibration.errors);
  const std::string description =
      !req.description.empty() ? req.description
                               : "robot " + loaded.campaign.robot + " as calibrated in campaign " + req.campaign;
  api::RegisterRobotRequest definition = api::DefinitionOf(req.id, spec, description);
  definition.calibrated_from = api::CalibrationSource{.campaign = req.campaign,
                                                     .robot = loaded.campaign.robot,
                                                     .created_unix_ms = loaded.result.created_unix_ms,
                                                     .joint_ranges = {}};
  // Where the calibration holds: the joint ranges of the measurements the fit used.
  std::vector<api::JointRangeWire>& ranges = definition.calibrated_from->joint_ranges;
  ForEachUsedMeasurement(storage_, req.campaign, loaded.result, loaded.last_calibration_sequence,
                         [&](const api::MeasurementWire& w) {
                           const std::vector<double>& joints = w.joints;
                           if (ranges.empty()) ranges.assign(joints.size(), {HUGE_VAL, -HUGE_VAL});
                           for (std::size_t i = 0; i < joints.size() && i < ranges.size(); ++i) {
                             ranges[i] = {std::min(ranges[i].min, joints[i]), std::max(ranges[i].max, joints[i])};
                           }
                         });
  // Joint terms beyond a robot joint's (a DEGRADED fit's) are refused by joint, in the wire's units.
  for (const api::JointWire& joint : definition.joints) {
    if (const std::string problem = api::ImplausibleJointTerms(joint); !problem.empty()) {
      const std::string reason = "its calibration's joint " + joint.name + ": " + problem + ", no robot joint's";
      throw ApiError(Status::kFailedPrecondition, "campaign \"" + req.campaign + "\": " + reason,
                     {{"from_calibration", reason}});
    }
  }
  try {
    (void)api::BuildModel(definition);
  } catch (const ApiError& e) {
    // E.g. an implausible joint term of a DEGRADED fit: no robot holds it.
    const std::string reason = std::string("its calibration is no robot definition: ") + e.what();
    throw ApiError(Status::kFailedPrecondition, "campaign \"" + req.campaign + "\": " + reason,
                   {{"from_calibration", reason}});
  }
  return definition;
}

api::Robot Service::CreateRobot(const nlohmann::json& body, const Caller& caller) {
  const api::RegisterRobotRequest req =
      api::IsFromCalibration(body) ? DefinitionFromCalibration(api::ParseRobotFromCalibrationRequest(body))
      : api::IsUrdfImport(body)    ? urdf::ImportUrdf(api::ParseImportUrdfRequest(body, options_.limits))
                                   : api::ParseRegisterRobotRequest(body, options_.limits);
  if (IsPresetRobot(req.id)) {
    throw ApiError(Status::kAlreadyExists, "\"" + req.id + "\" is a preset", {{"id", "taken by a preset"}});
  }
  const RobotModel model = api::BuildModel(req);
  // A robot registered from a calibration starts its history with it.
  api::StoredRobot stored{.definition = req, .history = {}};
  if (req.calibrated_from) {
    api::StoredHistoryEntry first;
    first.entry = 1;
    first.kind = api::HistoryKind::kRegistered;
    first.at_unix_ms = NowUnixMs();
    first.by = caller.name;
    first.campaign = req.calibrated_from->campaign;
    first.definition = req;
    stored.history.push_back(std::move(first));
  }
  try {
    storage_->Create(kRobots, req.id, nlohmann::json(stored).dump());
  } catch (const StorageError& e) {
    if (e.kind() == StorageError::Kind::kAlreadyExists) {
      throw ApiError(Status::kAlreadyExists, "robot \"" + req.id + "\" already exists", {{"id", "already exists"}});
    }
    throw;
  }
  return RobotResource(req.id, model, req);
}

api::Robot Service::GetRobot(const std::string& id) {
  const ResolvedRobot robot = ResolveRobot(id);
  const bool preset = IsPresetRobot(id);
  if (preset) return api::RobotFromModel(id, robot.model, true, PresetDescription(id));
  return RobotResource(id, robot.model, robot.definition);
}

void Service::DeleteRobot(const std::string& id) {
  if (IsPresetRobot(id))
    throw ApiError(Status::kFailedPrecondition, "presets cannot be deleted", {{"robot", "a preset"}});
  CheckId(id, "robot");
  // Campaigns keep a copy of their robot's definition, so deleting a robot never breaks one.
  if (!storage_->Delete(kRobots, id)) throw ApiError(Status::kNotFound, "robot \"" + id + "\" not found");
}

api::ForwardResult Service::RobotForward(const std::string& id, const nlohmann::json& body) {
  const RobotModel model = ResolveRobot(id).model;
  const api::ForwardRequest req = api::ParseForwardRequest(body, model, options_.limits);
  const TrimWhenDone trim(&trimmer_, req.joints.size() >= kLargeRequest);
  api::ForwardResult result;
  result.robot = id;
  result.frame = "world (nominal base)";
  // Under the request's payload (a robot holding compliances deflects under it).
  result.poses = ForwardPoses(model, Eigen::VectorXd(), req, req.payload ? api::ToCore(*req.payload) : Payload());
  return result;
}

}  // namespace robocal::server
