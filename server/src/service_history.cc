// A robot's calibration history and drift checks (docs/drift.md): the calibrations a robot has carried, checks of
// the one it carries, new calibrations and rollbacks, all entries of the robot's stored document.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "robocal/api/calibration.h"
#include "robocal/api/drift.h"
#include "robocal/api/history.h"
#include "robocal/api/json_reader.h"
#include "robocal/core/drift.h"
#include "robocal/core/fit_diagnostics.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;

// The entries of a robot stored before histories were kept, and of one registered from a calibration whose history
// is empty: its registration, the calibration it carries.
// `always`: also for a robot not registered from a calibration, whose first calibration then has the definition it
// had before to go back to.
void EnsureHistory(const Document& doc, api::StoredRobot* robot, bool always = false) {
  if (!robot->history.empty() || (!robot->definition.calibrated_from && !always)) return;
  api::StoredHistoryEntry first;
  first.entry = 1;
  first.kind = api::HistoryKind::kRegistered;
  first.at_unix_ms = doc.created_unix_ms;
  if (robot->definition.calibrated_from) {
    first.campaign = robot->definition.calibrated_from->campaign;
    first.note = "registered before its history was kept";
  } else {
    first.note = "registered without a calibration";
  }
  first.definition = robot->definition;
  robot->history.push_back(std::move(first));
}

api::RobotHistoryWire HistoryView(const std::string& id, const api::StoredRobot& robot) {
  api::RobotHistoryWire view;
  view.robot = id;
  view.current_entry = api::CurrentEntry(robot.history);
  if (robot.definition.calibrated_from) view.current_campaign = robot.definition.calibrated_from->campaign;
  for (const api::StoredHistoryEntry& e : robot.history) view.entries.push_back(e);
  return view;
}

api::StoredHistoryEntry NewEntry(const api::StoredRobot& robot, api::HistoryKind kind, const Caller& caller) {
  api::StoredHistoryEntry e;
  e.entry = robot.history.empty() ? 1 : robot.history.back().entry + 1;
  e.kind = kind;
  e.at_unix_ms = NowUnixMs();
  e.by = caller.name;
  return e;
}

}  // namespace

api::StoredRobot Service::UpdateRobot(const std::string& id,
                                      const std::function<void(const Document&, api::StoredRobot*)>& change) {
  // Optimistic: read, change, write if nobody wrote in between; a check and a rollback at once both land.
  for (int attempt = 0;; ++attempt) {
    auto [doc, robot] = LoadRobotDocument(id);
    EnsureHistory(doc, &robot, true);
    change(doc, &robot);
    try {
      storage_->Update(kRobots, id, nlohmann::json(robot).dump(), doc.version);
      return robot;
    } catch (const StorageError& e) {
      if (e.kind() != StorageError::Kind::kVersionConflict || attempt >= 20) throw;
    }
  }
}

api::RobotHistoryWire Service::RobotHistory(const std::string& id) {
  if (IsPresetRobot(id)) return {.robot = id, .current_entry = std::nullopt, .current_campaign = "", .entries = {}};
  auto [doc, robot] = LoadRobotDocument(id);
  EnsureHistory(doc, &robot);
  return HistoryView(id, robot);
}

api::RobotHistoryWire Service::CalibrateRobot(const std::string& id, const nlohmann::json& body, const Caller& caller) {
  if (IsPresetRobot(id)) {
    throw ApiError(Status::kFailedPrecondition, "presets carry no calibration: register the calibrated robot",
                   {{"robot", "a preset"}});
  }
  api::Problems problems;
  api::CalibrateRobotRequest req;
  api::ReadRequestObject(body, "", &problems, &req);
  problems.ThrowIfAny("invalid calibrate request");
  // One read of the robot: its definition and the definitions its history holds.
  const api::StoredRobot robot = LoadRobotDocument(id).second;
  // The same physical robot: a campaign of this robot, or of the robot it was calibrated from.
  const api::StoredCampaign campaign = [&] {
    try {
      return LoadCampaign(req.campaign);
    } catch (const ApiError& e) {
      if (e.status() != Status::kNotFound) throw;
      throw ApiError(Status::kInvalidArgument, "campaign \"" + req.campaign + "\" does not exist",
                     {{"from_calibration", "unknown campaign"}});
    }
  }();
  const std::string origin = robot.definition.calibrated_from ? robot.definition.calibrated_from->robot : id;
  if (campaign.robot != id && campaign.robot != origin) {
    const std::string reason = "campaign \"" + req.campaign + "\" measured robot " + campaign.robot + ", not " + id +
                               (origin != id ? " or " + origin + " (the robot it was calibrated from)" : "");
    throw ApiError(Status::kFailedPrecondition, reason, {{"from_calibration", reason}});
  }
  // The same robot, not an earlier one under the same id (deleted and registered again): the campaign measured a
  // definition this robot has carried, or the one its origin has now.
  {
    const nlohmann::json measured = campaign.robot_definition;
    bool carried = measured == nlohmann::json(robot.definition);
    if (campaign.robot == id) {
      for (const api::StoredHistoryEntry& e : robot.history) {
        carried = carried || (e.definition && measured == nlohmann::json(*e.definition));
      }
    } else {
      try {
        carried = measured == nlohmann::json(ResolveRobot(origin).definition);
      } catch (const ApiError&) {
        carried = false;
      }
    }
    if (!carried) {
      const std::string reason = "campaign \"" + req.campaign + "\" measured another definition of robot " +
                                 campaign.robot + " (one registered under that id before)";
      throw ApiError(Status::kFailedPrecondition, reason, {{"from_calibration", reason}});
    }
  }
  // The description says where the calibration came from, unless it was the user's own.
  const bool described = robot.definition.description.find(" as calibrated in campaign ") == std::string::npos;
  api::RegisterRobotRequest definition =
      DefinitionFromCalibration({id, described ? robot.definition.description : "", req.campaign});
  const api::StoredRobot updated = UpdateRobot(id, [&](const Document&, api::StoredRobot* stored) {
    api::StoredHistoryEntry e = NewEntry(*stored, api::HistoryKind::kCalibrated, caller);
    e.campaign = req.campaign;
    e.note = req.note;
    e.definition = definition;
    stored->definition = definition;
    stored->history.push_back(std::move(e));
  });
  return HistoryView(id, updated);
}

api::RobotHistoryWire Service::RollbackRobot(const std::string& id, const nlohmann::json& body, const Caller& caller) {
  if (IsPresetRobot(id)) throw ApiError(Status::kFailedPrecondition, "presets have no history", {{"robot", "a preset"}});
  api::Problems problems;
  api::RollbackRequest req;
  api::ReadRequestObject(body, "", &problems, &req);
  problems.ThrowIfAny("invalid rollback request");
  const api::StoredRobot updated = UpdateRobot(id, [&](const Document&, api::StoredRobot* stored) {
    const auto target = std::find_if(stored->history.begin(), stored->history.end(),
                                     [&](const api::StoredHistoryEntry& e) { return e.entry == req.entry; });
    if (target == stored->history.end()) {
      throw ApiError(Status::kInvalidArgument, "robot \"" + id + "\" has no history entry " + std::to_string(req.entry),
                     {{"entry", "no such entry (GET /v1/robots/" + id + "/calibrations lists them)"}});
    }
    if (!target->definition) {
      throw ApiError(Status::kInvalidArgument, "entry " + std::to_string(req.entry) + " is a check: it put no calibration on the robot",
                     {{"entry", "a check, not a calibration"}});
    }
    api::StoredHistoryEntry e = NewEntry(*stored, api::HistoryKind::kRollback, caller);
    e.campaign = target->campaign;
    e.rolled_back_to = req.entry;
    e.note = req.note;
    e.definition = target->definition;
    stored->definition = *target->definition;
    stored->history.push_back(std::move(e));
  });
  return HistoryView(id, updated);
}

namespace {

// The noise the calibration's fit weighted with: the tracker's (the request's or the campaign's), the robot's
// repeatability, and the model error the fit estimated, per row; and the request's own settings of the check.
DriftCheckOptions DriftCheckOptionsFor(const api::DriftCheckRequest& req, MeasurementType type,
                                       const api::StoredCampaign& campaign, const api::CalibrationResult& fit) {
  DriftCheckOptions options;
  options.measurement_type = type;
  // A tracker or a noise given replaces the campaign's model; neither keeps it.
  const std::optional<api::TrackerModelWire> tracker = req.tracker ? req.tracker
                                                       : req.noise ? std::nullopt
                                                                   : campaign.tracker;
  options.noise = api::ToCore(req.noise.value_or(campaign.noise), tracker);
  options.noise.repeatability_mm = req.repeatability_mm.value_or(campaign.repeatability_mm);
  if (fit.model_error.estimated) {
    options.noise.model_error_mm = fit.model_error.model_error_mm / std::sqrt(3.0);
    options.noise.model_error_rad = fit.model_error.model_error_deg * kRadPerDeg / std::sqrt(3.0);
  }
  options.register_frames = req.frames == api::CheckFrames::kRegister;
  options.false_alarm_rate = req.false_alarm_rate;
  options.seed = req.seed;
  return options;
}

// One measurement per pose: the shots of one pose (equal joints and payload) share its unmodelled error, and are
// averaged into one (positions and orientations averaged).
std::vector<Measurement> AveragedCheckShots(const RobotModel& model, const std::vector<api::MeasurementWire>& wire,
                                            const api::StoredCampaign& campaign) {
  std::vector<Measurement> shots;
  std::vector<int> count;
  for (const api::MeasurementWire& w : wire) {
    const Measurement m = MeasurementToCore(model, w, campaign);
    auto same = std::find_if(shots.begin(), shots.end(),
                             [&](const Measurement& s) { return s.joints == m.joints && s.payload == m.payload; });
    if (same == shots.end()) {
      shots.push_back(m);
      count.push_back(1);
      continue;
    }
    const std::size_t k = static_cast<std::size_t>(same - shots.begin());
    const double n = static_cast<double>(++count[k]);
    same->T_world_tool.translation() += (m.T_world_tool.translation() - same->T_world_tool.translation()) / n;
    // Small rotations apart: the mean's rotation vector, relative to the first shot's.
    const Eigen::Matrix3d delta = same->T_world_tool.linear().transpose() * m.T_world_tool.linear();
    const Eigen::Vector3d step = RotationVector(delta) / n;
    if (step.norm() > 0.0) {
      same->T_world_tool.linear() =
          same->T_world_tool.linear() * Eigen::AngleAxisd(step.norm(), step.normalized()).toRotationMatrix();
    }
  }
  return shots;
}

// The robot as it stands: its calibrated chain, at the calibration's registered base when the frames are kept.
RobotModel CheckedRobotModel(const RobotModel& robot, const DriftCheckOptions& options,
                             const Calibration& calibration) {
  if (options.register_frames) return robot;
  RobotModelSpec spec = robot.spec();
  spec.T_world_base = calibration.model.T_world_base();
  return RobotModel::Build(spec);
}

}  // namespace

api::DriftCheckWire Service::CheckRobot(const std::string& id, const nlohmann::json& body, const Caller& caller) {
  const ResolvedRobot robot = ResolveRobot(id);
  if (!robot.definition.calibrated_from) {
    throw ApiError(Status::kFailedPrecondition,
                   "robot \"" + id + "\" carries no calibration: register it from a calibrated campaign (from_calibration)",
                   {{"robot", "carries no calibration"}});
  }
  const std::string source = robot.definition.calibrated_from->campaign;
  const Calibrated loaded = [&] {
    try {
      return LoadCalibrated(source);
    } catch (const ApiError& e) {
      throw ApiError(Status::kFailedPrecondition,
                     "the calibration robot \"" + id + "\" carries (campaign \"" + source + "\") is gone: " + e.what(),
                     {{"robot", "its calibration's campaign or fit is gone"}});
    }
  }();
  if (!loaded.campaign.reflectors.empty()) {
    throw ApiError(Status::kFailedPrecondition, "checks measure the tool point; the calibration used reflectors",
                   {{"robot", "calibrated with reflectors"}});
  }
  const api::DriftCheckRequest req =
      api::ParseDriftCheckRequest(body, robot.model, loaded.campaign.type(), options_.limits);
  const MeasurementType type = req.measurement_type.value_or(loaded.campaign.type());
  DriftCheckOptions options = DriftCheckOptionsFor(req, type, loaded.campaign, loaded.result);

  // The calibration's own scatter: the measurements its fit used, against it (with the robot's joints: the
  // calibration campaign's robot has the same joints).
  std::vector<Measurement> calibration_shots;
  ForEachUsedMeasurement(storage_, source, loaded.result, loaded.last_calibration_sequence,
                         [&](const api::MeasurementWire& w) {
                           calibration_shots.push_back(MeasurementToCore(loaded.model, w, loaded.campaign));
                         });
  options.reference_T_world_base = loaded.calibration.model.T_world_base();
  const double rows = static_cast<double>(MeasurementRows(type) * calibration_shots.size());
  const double parameters = static_cast<double>(loaded.calibration.parameters.size());
  options.reference = std::move(calibration_shots);
  if (options.reference.size() < static_cast<std::size_t>(2 * MeasurementRows(type)) || rows <= parameters) {
    throw ApiError(Status::kFailedPrecondition, "the calibration of campaign \"" + source + "\" has too few measurements left to compare with",
                   {{"robot", "its calibration's measurements are too few"}});
  }
  options.null_correction = (rows + parameters) / (rows - parameters);

  const RobotModel model = CheckedRobotModel(robot.model, options, loaded.calibration);
  const DriftCheck check = CheckDrift(model, AveragedCheckShots(model, req.measurements, loaded.campaign), options);

  api::DriftCheckWire out = api::ToWire(check, model, options);
  out.robot = id;
  out.campaign = source;
  if (loaded.result.created_unix_ms != robot.definition.calibrated_from->created_unix_ms) {
    out.message += "; campaign \"" + source + "\" was fitted again after this calibration was put on the robot: its "
                   "current fit's scatter is the reference";
  }
  if (!std::isfinite(check.statistic)) {
    throw ApiError(Status::kFailedPrecondition, check.message, {{"measurements", check.message}});
  }
  const api::StoredRobot updated = UpdateRobot(id, [&](const Document&, api::StoredRobot* stored) {
    // A calibration or rollback that came in while the check ran: the check was of the robot as it was.
    if (nlohmann::json(stored->definition) != nlohmann::json(robot.definition)) {
      throw ApiError(Status::kAborted,
                     "robot \"" + id + "\" was given another calibration while it was checked: check it again",
                     {{"robot", "its calibration changed during the check"}});
    }
    api::StoredHistoryEntry e = NewEntry(*stored, api::HistoryKind::kCheck, caller);
    e.campaign = source;
    e.verdict = out.verdict;
    e.statistic = out.statistic;
    e.threshold = out.threshold;
    for (const api::DriftSuspectWire& s : out.suspects) e.suspects.push_back(s.parameter);
    stored->history.push_back(std::move(e));
  });
  out.history_entry = updated.history.back().entry;
  return out;
}

}  // namespace robocal::server
