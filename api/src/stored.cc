// The stored documents and their versions.
#include "robocal/api/stored.h"

namespace robocal::api {
namespace {

constexpr const char* kVersionKey = "schema_version";

nlohmann::json Versioned(nlohmann::json j) {
  j[kVersionKey] = kStoredSchemaVersion;
  return j;
}

// Version 1 wrote deadline_exceeded only when it was true.
void DefaultFalse(nlohmann::json* object, const char* key) {
  if (object->is_object() && !object->contains(key)) (*object)[key] = false;
}

}  // namespace

int StoredSchemaVersion(const nlohmann::json& document) {
  const WireReader r(document);
  int version = 1;
  r.Optional(kVersionKey, &version);
  if (version < 1 || version > kStoredSchemaVersion) {
    throw WireError(kVersionKey, "version " + std::to_string(version) + " is not one this server reads (1.." +
                                     std::to_string(kStoredSchemaVersion) + ")");
  }
  return version;
}

void to_json(nlohmann::json& j, const StoredRobot& robot) { j = Versioned(robot.definition); }

void from_json(const nlohmann::json& j, StoredRobot& robot) {
  (void)StoredSchemaVersion(j);
  from_json(j, robot.definition);
}

void to_json(nlohmann::json& j, const StoredCampaign& c) {
  j = Versioned({{"id", c.id},
                 {"description", c.description},
                 {"robot", c.robot},
                 {"robot_definition", c.robot_definition},
                 {"measurement_type", c.measurement_type},
                 {"plan", c.plan ? nlohmann::json(*c.plan) : nlohmann::json()},
                 {"noise", c.noise},
                 {"created_unix_ms", c.created_unix_ms}});
  if (c.tracker) j["tracker"] = *c.tracker;
  if (c.repeatability_mm != 0.0) j["repeatability_mm"] = c.repeatability_mm;
  if (!c.reflectors.empty()) j["reflectors"] = c.reflectors;
  if (c.payload) j["payload"] = *c.payload;
}

void from_json(const nlohmann::json& j, StoredCampaign& c) {
  (void)StoredSchemaVersion(j);
  const WireReader r(j);
  r.Required("id", &c.id);
  r.Required("description", &c.description);
  r.Required("robot", &c.robot);
  r.Required("robot_definition", &c.robot_definition);
  r.Required("measurement_type", &c.measurement_type);
  r.Optional("plan", &c.plan);
  r.Required("noise", &c.noise);
  r.Optional("tracker", &c.tracker);
  r.Optional("repeatability_mm", &c.repeatability_mm);
  r.Optional("reflectors", &c.reflectors);
  r.Optional("payload", &c.payload);
  r.Required("created_unix_ms", &c.created_unix_ms);
}

void to_json(nlohmann::json& j, const StoredPlan& plan) { j = Versioned(plan.plan); }

void from_json(const nlohmann::json& j, StoredPlan& plan) {
  const int version = StoredSchemaVersion(j);
  if (version >= 3) {
    ReadWire(j, "", &plan.plan);
    return;
  }
  // Plans before cells had neither a cell nor configuration checks, nor the predicted_error figures.
  nlohmann::json doc = j;
  for (nlohmann::json* indices : {&doc["indices"], &doc["baseline"]["indices"], &doc["summary"]["initial"]}) {
    if (indices->is_object() && !indices->contains("predicted_error_mm")) (*indices)["predicted_error_mm"] = nullptr;
  }
  for (nlohmann::json* accuracy : {&doc["predicted_accuracy"], &doc["baseline"]["predicted_accuracy"]}) {
    if (accuracy->is_object() && !accuracy->contains("rms_error_mm")) (*accuracy)["rms_error_mm"] = nullptr;
  }
  if (doc.is_object() && !doc.contains("cell")) doc["cell"] = nullptr;
  if (doc.is_object() && !doc.contains("configuration_checks")) doc["configuration_checks"] = nlohmann::json::array();
  if (version == 1 && doc.contains("summary")) DefaultFalse(&doc["summary"], "deadline_exceeded");
  ReadWire(doc, "", &plan.plan);
}

void to_json(nlohmann::json& j, const StoredCalibration& c) {
  j = Versioned({{"result", c.result},
                 {"state",
                  {{"registered_base", c.registered_base},
                   {"T_world_base", c.T_world_base},
                   {"T_flange_tool", c.T_flange_tool},
                   {"errors", c.errors}}}});
  if (c.last_calibration_sequence) j["state"]["last_calibration_sequence"] = *c.last_calibration_sequence;
}

void from_json(const nlohmann::json& j, StoredCalibration& c) {
  nlohmann::json doc = j;
  if (StoredSchemaVersion(j) == 1 && doc.contains("result") && doc["result"].contains("summary")) {
    DefaultFalse(&doc["result"]["summary"], "deadline_exceeded");
  }
  const WireReader r(doc);
  r.Required("result", &c.result);
  const WireReader state(r.Member("state"), "state");
  ReadResultPose(state, "registered_base", &c.registered_base);
  ReadResultPose(state, "T_world_base", &c.T_world_base);
  ReadResultPose(state, "T_flange_tool", &c.T_flange_tool);
  state.Required("errors", &c.errors);
  std::int64_t last = 0;
  if (state.Optional("last_calibration_sequence", &last)) c.last_calibration_sequence = last;
}

StoredCalibration ToStored(const Calibration& calibration, const CalibrationResult& result) {
  StoredCalibration s;
  s.result = result;
  s.registered_base = TransformToPose(calibration.model.T_world_base());
  s.T_world_base = TransformToPose(calibration.T_world_base);
  s.T_flange_tool = TransformToPose(calibration.T_flange_tool);
  s.errors.assign(calibration.errors.data(), calibration.errors.data() + calibration.errors.size());
  return s;
}

Calibration Restore(const RobotModel& geometric, const StoredCalibration& stored) {
  // The model the fit estimated: the campaign's robot with the fit's joint terms (none in older fits).
  const RobotModel nominal = geometric.WithErrorTerms(ToCore(stored.result.model));
  if (static_cast<int>(stored.errors.size()) != nominal.num_error_parameters()) {
    throw WireError("state.errors", "expected " + std::to_string(nominal.num_error_parameters()) +
                                        " values for the campaign's robot, got " +
                                        std::to_string(stored.errors.size()));
  }
  RobotModelSpec spec = nominal.spec();
  spec.T_world_base = PoseToTransform(stored.registered_base);
  Calibration c{RobotModel::Build(spec),
                Eigen::Map<const Eigen::VectorXd>(stored.errors.data(), static_cast<Eigen::Index>(stored.errors.size())),
                {},
                {},
                PoseToTransform(stored.T_world_base),
                PoseToTransform(stored.T_flange_tool),
                ToCore(stored.result.reflectors),
                {}};
  c.summary.termination = stored.result.summary.termination;
  c.summary.message = stored.result.summary.message;
  c.summary.measurement_type = stored.result.measurement_type;
  const ModelErrorWire& model_error = stored.result.model_error;
  c.summary.model_error_estimated = model_error.estimated;
  c.summary.model_error_mm = model_error.model_error_mm;
  c.summary.model_error_rad = model_error.model_error_deg / kDegPerRad;
  c.summary.tracker_rms_mm = model_error.tracker_rms_mm;
  c.summary.tracker_rms_rad = model_error.tracker_rms_deg / kDegPerRad;
  return c;
}

void to_json(nlohmann::json& j, const StoredCell& c) {
  j = Versioned({{"cell", c.cell}, {"robot_definition", c.robot_definition}});
}

void from_json(const nlohmann::json& j, StoredCell& c) {
  (void)StoredSchemaVersion(j);
  const WireReader r(j);
  r.Required("cell", &c.cell);
  r.Required("robot_definition", &c.robot_definition);
}

void to_json(nlohmann::json& j, const StoredOperation& op) { j = Versioned(op.operation); }

void from_json(const nlohmann::json& j, StoredOperation& op) {
  if (StoredSchemaVersion(j) == 1) {
    nlohmann::json doc = j;
    DefaultFalse(&doc, "cancel_requested");
    if (doc.contains("result") && doc["result"].contains("summary")) {
      DefaultFalse(&doc["result"]["summary"], "deadline_exceeded");
    }
    ReadWire(doc, "", &op.operation);
    return;
  }
  ReadWire(j, "", &op.operation);
}

}  // namespace robocal::api
