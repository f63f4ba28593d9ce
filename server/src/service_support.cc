// What the service's parts share.
#include "service_support.h"

#include <set>

#include "robocal/core/kinematics.h"
#include "robocal/server/service.h"
#include "server/storage/storage_common.h"

namespace robocal::server {

using api::ApiError;
using api::Status;

void CheckId(const std::string& id, const std::string& what) {
  if (!api::IsValidId(id)) {
    throw ApiError(Status::kInvalidArgument, "invalid " + what + " id \"" + id + "\"", {{what, api::kIdRule}});
  }
}

namespace {
constexpr std::int64_t kMaxPageSize = 1000;
}  // namespace

std::string PageToken(const std::string& list, const std::string& last_id) {
  return last_id + "~" + api::ContentHash(list + "/" + last_id).substr(0, 8);
}

PageRequest ParsePageRequest(const std::string& list, const std::string& size_text, const std::string& token) {
  api::Problems problems;
  PageRequest page;
  if (!size_text.empty()) {
    std::size_t used = 0;
    long long v = 0;
    try {
      v = std::stoll(size_text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != size_text.size() || v < 1 || v > kMaxPageSize) {
      problems.Add("page_size", "expected an integer in [1, " + std::to_string(kMaxPageSize) + "], got \"" +
                                    size_text.substr(0, 32) + "\"");
    } else {
      page.size = static_cast<std::size_t>(v);
    }
  }
  if (!token.empty()) {
    const std::size_t mark = token.rfind('~');
    const std::string last = mark == std::string::npos ? "" : token.substr(0, mark);
    if (!api::IsValidId(last) || PageToken(list, last) != token) {
      problems.Add("page_token", "not a next_page_token of a previous page of this list");
    } else {
      page.token = last;
    }
  }
  problems.ThrowIfAny("invalid query");
  return page;
}

api::MeasurementWire ReadMeasurement(const StoredMeasurement& stored) {
  try {
    return api::FromWire<api::MeasurementWire>(nlohmann::json::parse(stored.json));
  } catch (const std::exception& e) {
    throw ApiError(Status::kInternal,
                   "stored measurement " + std::to_string(stored.sequence) + " is unreadable: " + e.what());
  }
}

void ForEachMeasurement(Storage* storage, const std::string& campaign_id, const std::string& role,
                        const std::function<void(const StoredMeasurement&)>& visit) {
  constexpr int kPage = 1000;
  std::int64_t after = 0;
  for (;;) {
    const std::vector<StoredMeasurement> page = storage->ListMeasurements(campaign_id, role, after, kPage);
    for (const StoredMeasurement& m : page) visit(m);
    if (static_cast<int>(page.size()) < kPage) return;
    after = page.back().sequence;
  }
}

std::vector<api::PoseResultWire> ForwardPoses(const RobotModel& model, const Eigen::VectorXd& errors,
                                              const api::ForwardRequest& req, const Payload& payload) {
  KinematicsWorkspace ws(model);
  std::vector<api::PoseResultWire> poses;
  poses.reserve(req.joints.size());
  for (const auto& q : req.joints) {
    poses.push_back(api::TransformToPose(ForwardKinematics(model, api::JointsToCore(model, q), errors, &ws, payload)));
  }
  return poses;
}

bool SeenByFit(const api::CalibrationResult& result, const std::optional<std::int64_t>& last_calibration_sequence,
               std::int64_t sequence, std::int64_t index) {
  if (last_calibration_sequence) return sequence <= *last_calibration_sequence;
  return index < result.summary.num_measurements + static_cast<std::int64_t>(result.outliers.size());
}

void ForEachUsedMeasurement(Storage* storage, const std::string& campaign_id, const api::CalibrationResult& result,
                            const std::optional<std::int64_t>& last_calibration_sequence,
                            const std::function<void(const api::MeasurementWire&)>& visit) {
  std::set<std::int64_t> excluded;
  for (const api::OutlierWire& o : result.outliers) excluded.insert(o.sequence);
  std::int64_t index = 0;
  ForEachMeasurement(storage, campaign_id, "calibration", [&](const StoredMeasurement& s) {
    const bool in_fit = SeenByFit(result, last_calibration_sequence, s.sequence, index++);
    if (in_fit && excluded.count(s.sequence) == 0) visit(ReadMeasurement(s));
  });
}

std::int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string NewId(const std::string& prefix) { return NewRandomId(prefix); }

api::Robot RobotResource(const std::string& id, const RobotModel& model, const api::RegisterRobotRequest& definition) {
  api::Robot robot = api::RobotFromModel(id, model, false, definition.description);
  if (definition.urdf) robot.urdf = *definition.urdf;  // its chain
  robot.calibrated_from = definition.calibrated_from;
  return robot;
}

Measurement MeasurementToCore(const RobotModel& model, const api::MeasurementWire& w,
                              const api::StoredCampaign& campaign) {
  Measurement m;
  m.joints = api::JointsToCore(model, w.joints);
  m.T_world_tool = api::PoseToTransform(w.pose);
  m.reflector = w.reflector.empty() ? -1 : api::ReflectorIndex(campaign.reflectors, w.reflector);
  m.stale = w.stale;
  if (w.payload) {
    m.payload = api::ToCore(*w.payload);
  } else if (campaign.payload) {
    m.payload = api::ToCore(*campaign.payload);
  }
  return m;
}

}  // namespace robocal::server
