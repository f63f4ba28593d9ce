// Campaigns and measurements on the wire.
#include "robocal/api/campaigns.h"

#include <algorithm>

#include "robocal/api/json_reader.h"
#include "robocal/api/robots.h"

namespace robocal::api {

// ---------------------------------------------------------------------------------------------- campaigns

CreateCampaignRequest ParseCreateCampaignRequest(const nlohmann::json& body) {
  Problems problems;
  CreateCampaignRequest req;
  ObjectReader r(body, "", &problems);
  if (r.String("id", false, &req.id) && !IsValidId(req.id)) problems.Add("id", kIdRule);
  r.String("description", false, &req.description, 1024);
  r.String("robot", true, &req.robot, 64);
  MeasurementType type = MeasurementType::kPose;
  if (r.Enum("measurement_type", false, &type)) req.measurement_type = type;
  r.String("plan", false, &req.plan, 64);
  ParseNoise(r.Get("noise"), "noise", &problems, &req.noise);
  ParseTrackerModel(r.Get("tracker"), "tracker", &problems, &req.tracker);
  r.Number("repeatability_mm", false, &req.repeatability_mm, 0.0, 10.0);
  r.RejectUnknown({"id", "description", "robot", "measurement_type", "plan", "noise", "tracker", "repeatability_mm"});
  problems.ThrowIfAny("invalid campaign");
  return req;
}

void to_json(nlohmann::json& j, const CreateCampaignRequest& req) {
  j = {{"robot", req.robot}, {"noise", req.noise}};
  if (req.measurement_type) j["measurement_type"] = *req.measurement_type;
  if (!req.id.empty()) j["id"] = req.id;
  if (!req.description.empty()) j["description"] = req.description;
  if (!req.plan.empty()) j["plan"] = req.plan;
  if (req.tracker) j["tracker"] = *req.tracker;
  if (req.repeatability_mm != 0.0) j["repeatability_mm"] = req.repeatability_mm;
}

void from_json(const nlohmann::json& j, CreateCampaignRequest& req) {
  const WireReader r(j);
  r.Required("robot", &req.robot);
  r.Optional("measurement_type", &req.measurement_type);
  r.Optional("id", &req.id);
  r.Optional("description", &req.description);
  r.Optional("plan", &req.plan);
  r.Optional("noise", &req.noise);
  r.Optional("tracker", &req.tracker);
  r.Optional("repeatability_mm", &req.repeatability_mm);
}

void to_json(nlohmann::json& j, const MeasurementCounts& c) {
  j = {{"calibration", c.calibration}, {"validation", c.validation}};
}

void from_json(const nlohmann::json& j, MeasurementCounts& c) {
  const WireReader r(j);
  r.Required("calibration", &c.calibration);
  r.Required("validation", &c.validation);
}

void to_json(nlohmann::json& j, const Campaign& c) {
  j = {{"id", c.id},
       {"description", c.description},
       {"robot", c.robot},
       {"measurement_type", c.measurement_type},
       {"plan", c.plan ? nlohmann::json(*c.plan) : nlohmann::json()},
       {"noise", c.noise},
       {"tracker", c.tracker ? nlohmann::json(*c.tracker) : nlohmann::json()},
       {"repeatability_mm", c.repeatability_mm},
       {"created_unix_ms", c.created_unix_ms},
       {"counts", c.counts},
       {"calibrated", c.calibrated}};
}

void from_json(const nlohmann::json& j, Campaign& c) {
  const WireReader r(j);
  r.Required("id", &c.id);
  r.Required("description", &c.description);
  r.Required("robot", &c.robot);
  r.Required("measurement_type", &c.measurement_type);
  r.Required("plan", &c.plan);
  r.Required("noise", &c.noise);
  r.Required("tracker", &c.tracker);
  r.Required("repeatability_mm", &c.repeatability_mm);
  r.Required("created_unix_ms", &c.created_unix_ms);
  r.Required("counts", &c.counts);
  r.Required("calibrated", &c.calibrated);
}

void to_json(nlohmann::json& j, const CampaignList& list) {
  j = {{"campaigns", list.campaigns}};
  if (list.next_page_token) j["next_page_token"] = *list.next_page_token;
}

void from_json(const nlohmann::json& j, CampaignList& list) {
  const WireReader r(j);
  r.Required("campaigns", &list.campaigns);
  r.Optional("next_page_token", &list.next_page_token);
}

// ---------------------------------------------------------------------------------------------- measurements

void to_json(nlohmann::json& j, const MeasurementWire& m) { j = {{"joints", m.joints}, {"pose", m.pose}}; }

void from_json(const nlohmann::json& j, MeasurementWire& m) {
  const WireReader r(j);
  r.Required("joints", &m.joints);
  r.Required("pose", &m.pose);
}

MeasurementBatchRequest ParseMeasurementBatchRequest(const nlohmann::json& body, const RobotModel& model,
                                                     MeasurementType type, const Limits& limits) {
  Problems problems;
  MeasurementBatchRequest req;
  ObjectReader r(body, "", &problems);
  // The idempotency key: an empty one would make every retry a new batch.
  if (r.String("request_id", true, &req.request_id, 128)) {
    if (req.request_id.empty()) {
      problems.Add("request_id", "must not be empty (it makes retries of this batch safe)");
    } else if (std::any_of(req.request_id.begin(), req.request_id.end(),
                           [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7F; })) {
      problems.Add("request_id", "must not contain control characters");
    }
  }
  r.Enum("role", false, &req.role);
  if (const nlohmann::json* a = r.Array("measurements", true, 1, limits.max_array_length)) {
    req.measurements.resize(a->size());
    for (std::size_t i = 0; i < a->size(); ++i) {
      const std::string path = IndexPath("measurements", i);
      ObjectReader m((*a)[i], path, &problems);
      MeasurementWire& w = req.measurements[i];
      if (const nlohmann::json* q = m.Get("joints")) {
        ReadJointVector(*q, JoinPath(path, "joints"), model, &problems, &w.joints);
      } else if (m.ok()) {
        problems.Add(JoinPath(path, "joints"), "required");
      }
      if (const nlohmann::json* p = m.Get("pose")) {
        ParsePose(*p, JoinPath(path, "pose"), type != MeasurementType::kPosition, &problems, &w.pose);
      } else if (m.ok()) {
        problems.Add(JoinPath(path, "pose"), "required");
      }
      m.RejectUnknown({"joints", "pose"});
      // A batch with thousands of bad rows would produce an enormous error; the first 100 say enough.
      if (problems.size() > 100) break;
    }
  }
  r.RejectUnknown({"request_id", "role", "measurements"});
  problems.ThrowIfAny("invalid measurement batch");
  return req;
}

void to_json(nlohmann::json& j, const MeasurementBatchRequest& req) {
  j = {{"request_id", req.request_id}, {"role", req.role}, {"measurements", req.measurements}};
}

void from_json(const nlohmann::json& j, MeasurementBatchRequest& req) {
  const WireReader r(j);
  r.Required("request_id", &req.request_id);
  r.Required("role", &req.role);
  r.Required("measurements", &req.measurements);
}

void to_json(nlohmann::json& j, const BatchResult& b) {
  j = {{"campaign", b.campaign},   {"batch_id", b.batch_id},       {"request_id", b.request_id},
       {"replayed", b.replayed},   {"first_sequence", b.first_sequence}, {"count", b.count},
       {"campaign_total", b.campaign_total}};
}

void from_json(const nlohmann::json& j, BatchResult& b) {
  const WireReader r(j);
  r.Required("campaign", &b.campaign);
  r.Required("batch_id", &b.batch_id);
  r.Required("request_id", &b.request_id);
  r.Required("replayed", &b.replayed);
  r.Required("first_sequence", &b.first_sequence);
  r.Required("count", &b.count);
  r.Required("campaign_total", &b.campaign_total);
}

void to_json(nlohmann::json& j, const StoredMeasurementWire& m) {
  j = {{"sequence", m.sequence},
       {"batch_id", m.batch_id},
       {"role", m.role},
       {"joints", m.measurement.joints},
       {"pose", m.measurement.pose}};
}

void from_json(const nlohmann::json& j, StoredMeasurementWire& m) {
  const WireReader r(j);
  r.Required("sequence", &m.sequence);
  r.Required("batch_id", &m.batch_id);
  r.Required("role", &m.role);
  from_json(j, m.measurement);
}

void to_json(nlohmann::json& j, const MeasurementList& list) {
  j = {{"campaign", list.campaign}, {"measurements", list.measurements}};
  if (list.next_after) j["next_after"] = *list.next_after;
}

void from_json(const nlohmann::json& j, MeasurementList& list) {
  const WireReader r(j);
  r.Required("campaign", &list.campaign);
  r.Required("measurements", &list.measurements);
  r.Optional("next_after", &list.next_after);
}

}  // namespace robocal::api
