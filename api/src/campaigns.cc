// Campaigns and measurements on the wire.
#include "robocal/api/campaigns.h"

#include <algorithm>
#include <cmath>

#include "robocal/api/json_reader.h"
#include "robocal/api/robots.h"
#include "robocal/core/iso9283.h"

namespace robocal::api {

// ---------------------------------------------------------------------------------------------- campaigns

std::vector<Reflector> ToCore(const std::vector<CampaignReflectorWire>& reflectors) {
  std::vector<Reflector> out;
  for (const CampaignReflectorWire& r : reflectors) {
    out.push_back({.id = r.id,
                   .position_mm = Eigen::Vector3d(r.position_mm[0], r.position_mm[1], r.position_mm[2]),
                   .fixed = r.fixed});
  }
  return out;
}

std::vector<CampaignReflectorWire> ToWire(const std::vector<Reflector>& reflectors) {
  std::vector<CampaignReflectorWire> out;
  for (const Reflector& r : reflectors) {
    out.push_back(
        {.id = r.id, .position_mm = {r.position_mm.x(), r.position_mm.y(), r.position_mm.z()}, .fixed = r.fixed});
  }
  return out;
}

int ReflectorIndex(const std::vector<CampaignReflectorWire>& reflectors, const std::string& id) {
  for (std::size_t k = 0; k < reflectors.size(); ++k) {
    if (reflectors[k].id == id) return static_cast<int>(k);
  }
  return -1;
}

void WireFields<CampaignReflectorWire>::CheckRequest(const S& reflector, const std::string& path, Problems* problems) {
  const auto& p = reflector.position_mm;
  if (std::hypot(p[0], p[1], p[2]) > 1e4) {
    problems->Add(JoinPath(path, "position_mm"), "must be within 10000 mm of the flange");
  }
}

void CheckReflectorIds(const std::vector<CampaignReflectorWire>& reflectors, Problems* problems) {
  for (std::size_t k = 0; k < reflectors.size(); ++k) {
    for (std::size_t i = 0; i < k; ++i) {
      if (reflectors[i].id == reflectors[k].id) {
        problems->Add(JoinPath(IndexPath("reflectors", k), "id"), "\"" + reflectors[k].id + "\" is given twice");
        break;
      }
    }
  }
}

void WireFields<CreateCampaignRequest>::CheckRequest(const S& req, const std::string&, Problems* problems) {
  CheckReflectorIds(req.reflectors, problems);
  if (!req.reflectors.empty() && req.measurement_type && *req.measurement_type != MeasurementType::kPosition) {
    problems->Add("reflectors", "need position measurements (a 6-DoF probe measures the tool's orientation itself)");
  }
}

CreateCampaignRequest ParseCreateCampaignRequest(const nlohmann::json& body) {
  Problems problems;
  CreateCampaignRequest req;
  ReadRequestObject(body, "", &problems, &req);
  problems.ThrowIfAny("invalid campaign");
  return req;
}

void WireFields<CampaignDefinition>::Check(const CampaignDefinition& campaign) {
  if (!campaign.measurement_type) throw WireError("measurement_type", "expected a string");
}

MeasurementNoise NoiseOf(const CreateCampaignRequest& campaign) {
  MeasurementNoise out = ToCore(campaign.noise, campaign.tracker);
  WireToCore(campaign, &out);
  return out;
}

// ---------------------------------------------------------------------------------------------- measurements

namespace {

// A test shot's pose and cycle: required with role test, refused with the others.
void ReadTestTags(ObjectReader& m, const std::string& path, MeasurementRole role, Problems* problems,
                  MeasurementWire* w) {
  const bool test = role == MeasurementRole::kTest;
  if (!test) {
    for (const char* key : {"test_pose", "cycle"}) {
      if (m.Get(key) != nullptr) problems->Add(JoinPath(path, key), "only shots of role test carry it");
    }
    return;
  }
  if (m.String("test_pose", true, &w->test_pose, 8) && Iso9283PoseIndex(w->test_pose) < 0) {
    problems->Add(JoinPath(path, "test_pose"), "must be one of P1, P2, P3, P4, P5 (the ISO 9283 poses)");
  }
  m.Int("cycle", true, &w->cycle, 1, kMaxTestCycles);
}

}  // namespace

void ReadMeasurements(const nlohmann::json& list, const std::string& at, const RobotModel& model, MeasurementType type,
                      const std::vector<CampaignReflectorWire>& reflectors, MeasurementRole role, Problems* problems,
                      std::vector<MeasurementWire>* out) {
  out->resize(list.size());
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = IndexPath(at, i);
    ObjectReader m(list[i], path, problems);
    MeasurementWire& w = (*out)[i];
    if (const nlohmann::json* q = m.Get("joints")) {
      ReadJointVector(*q, JoinPath(path, "joints"), model, problems, &w.joints);
    } else if (m.ok()) {
      problems->Add(JoinPath(path, "joints"), "required");
    }
    if (const nlohmann::json* p = m.Get("pose")) {
      ParsePose(*p, JoinPath(path, "pose"), type != MeasurementType::kPosition, problems, &w.pose);
    } else if (m.ok()) {
      problems->Add(JoinPath(path, "pose"), "required");
    }
    if (m.String("reflector", !reflectors.empty(), &w.reflector, 64)) {
      if (reflectors.empty()) {
        problems->Add(JoinPath(path, "reflector"), "the campaign has no reflectors");
      } else if (ReflectorIndex(reflectors, w.reflector) < 0) {
        std::string known;
        for (const CampaignReflectorWire& c : reflectors) known += (known.empty() ? "" : ", ") + c.id;
        problems->Add(JoinPath(path, "reflector"),
                      "unknown reflector \"" + w.reflector + "\" (the campaign has " + known + ")");
      }
    }
    ReadRequest(m, &w);  // the table's rows: the payload
    ReadTestTags(m, path, role, problems, &w);
    m.RejectUnknown(WireFieldNames<MeasurementWire>());
    // A batch with thousands of bad rows would produce an enormous error; the first 100 say enough.
    if (problems->size() > 100) break;
  }
}

MeasurementBatchRequest ParseMeasurementBatchRequest(const nlohmann::json& body, const RobotModel& model,
                                                     MeasurementType type, const Limits& limits,
                                                     const std::vector<CampaignReflectorWire>& reflectors) {
  Problems problems;
  MeasurementBatchRequest req;
  ObjectReader r(body, "", &problems);
  ReadRequest(r, &req);  // the table's rows: the idempotency key (an empty one would make every retry a new batch)
  if (req.role == MeasurementRole::kTest && !reflectors.empty()) {
    problems.Add("role", "ISO 9283 measures the tool point: a campaign with reflectors takes no test shots");
  }
  if (const nlohmann::json* a = r.Array("measurements", true, 1, limits.max_array_length)) {
    ReadMeasurements(*a, "measurements", model, type, reflectors, req.role, &problems, &req.measurements);
  }
  r.RejectUnknown(WireFieldNames<MeasurementBatchRequest>());
  problems.ThrowIfAny("invalid measurement batch");
  return req;
}

// The shapes' to_json / from_json, instantiated here once (ROBOCAL_WIRE_DECLARE).
ROBOCAL_WIRE_DEFINE(CampaignReflectorWire);
ROBOCAL_WIRE_DEFINE(CreateCampaignRequest);
ROBOCAL_WIRE_DEFINE(MeasurementCounts);
ROBOCAL_WIRE_DEFINE(CampaignDefinition);
ROBOCAL_WIRE_DEFINE(Campaign);
ROBOCAL_WIRE_DEFINE(CampaignList);
ROBOCAL_WIRE_DEFINE(MeasurementWire);
ROBOCAL_WIRE_DEFINE(MeasurementBatchRequest);
ROBOCAL_WIRE_DEFINE(BatchResult);
ROBOCAL_WIRE_DEFINE(StoredMeasurementWire);
ROBOCAL_WIRE_DEFINE(MeasurementList);

}  // namespace robocal::api
