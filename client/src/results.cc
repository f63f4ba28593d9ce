// Parsing the service's response bodies into the client's typed results.
#include "robocal/client/results.h"

#include <limits>

namespace robocal::client {
namespace {

using nlohmann::json;

// The server writes non-finite numbers (an infinite condition number) as null.
double Number(const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || it->is_null()) return std::numeric_limits<double>::quiet_NaN();
  return it->get<double>();
}

std::string String(const json& j, const char* key) {
  const auto it = j.find(key);
  return it == j.end() || !it->is_string() ? std::string() : it->get<std::string>();
}

Residuals ParseResiduals(const json& j) {
  Residuals r;
  r.num_measurements = j.value("num_measurements", 0);
  r.rms_position_mm = Number(j, "rms_position_mm");
  r.max_position_mm = Number(j, "max_position_mm");
  r.rms_orientation_deg = Number(j, "rms_orientation_deg");
  r.max_orientation_deg = Number(j, "max_orientation_deg");
  return r;
}

PredictedAccuracy ParsePredicted(const json& j) {
  PredictedAccuracy a;
  a.num_validation = j.value("num_validation", 0);
  a.rms_position_mm = Number(j, "rms_position_mm");
  a.max_position_mm = Number(j, "max_position_mm");
  a.rms_orientation_deg = Number(j, "rms_orientation_deg");
  return a;
}

Statistics ParseStatistics(const json& j) {
  Statistics s;
  s.count = j.value("count", 0);
  s.mean = Number(j, "mean");
  s.std = Number(j, "std");
  s.max = Number(j, "max");
  s.rp = Number(j, "rp");
  return s;
}

Accuracy ParseAccuracy(const json& j) {
  Accuracy a;
  a.h_mm = Number(j, "h_mm");
  a.e_xyz_mm = ParseStatistics(j.at("e_xyz_mm"));
  a.e_cos_deg = ParseStatistics(j.at("e_cos_deg"));
  a.e_tot_mm = ParseStatistics(j.at("e_tot_mm"));
  return a;
}

}  // namespace

api::PoseWire ParsePoseResult(const json& j) {
  api::PoseWire p;
  p.position_mm = j.at("position_mm").get<std::array<double, 3>>();
  if (j.contains("quaternion")) {
    p.quaternion = j.at("quaternion").get<std::array<double, 4>>();
  } else {
    p.has_orientation = false;
  }
  return p;
}

RobotInfo ParseRobotInfo(const json& j) {
  RobotInfo r;
  r.id = j.at("id").get<std::string>();
  r.preset = j.value("preset", false);
  r.description = String(j, "description");
  r.convention = String(j, "convention");
  for (const json& joint : j.at("joints")) {
    JointInfo info;
    info.name = String(joint, "name");
    info.type = String(joint, "type");
    info.unit = String(joint, "unit");
    const bool degrees = info.unit == "deg";
    info.min = joint.at(degrees ? "min_deg" : "min_mm").get<double>();
    info.max = joint.at(degrees ? "max_deg" : "max_mm").get<double>();
    r.joints.push_back(info);
  }
  if (j.contains("base")) r.base = ParsePoseResult(j.at("base"));
  if (j.contains("tool")) r.tool = ParsePoseResult(j.at("tool"));
  r.error_parameters = j.value("error_parameters", std::vector<std::string>());
  r.raw = j;
  return r;
}

Indices ParseIndices(const json& j) {
  Indices x;
  x.num_configurations = j.value("num_configurations", 0);
  x.num_parameters = j.value("num_parameters", 0);
  x.condition_number = Number(j, "condition_number");
  x.o1 = Number(j, "o1");
  x.o2 = Number(j, "o2");
  x.o3 = Number(j, "o3");
  x.o4 = Number(j, "o4");
  x.o5 = Number(j, "o5");
  x.log_det = Number(j, "log_det");
  return x;
}

PlanResult ParsePlanResult(const json& j) {
  PlanResult p;
  p.id = j.at("id").get<std::string>();
  p.robot = String(j, "robot");
  p.measurement_type = String(j, "measurement_type");
  p.objective = String(j, "objective");
  p.optimiser = String(j, "optimiser");
  p.joint_units = j.value("joint_units", std::vector<std::string>());
  p.configurations = j.at("configurations").get<std::vector<std::vector<double>>>();
  p.indices = ParseIndices(j.at("indices"));
  if (j.contains("baseline")) {
    const json& b = j.at("baseline");
    if (b.contains("indices")) p.baseline_indices = ParseIndices(b.at("indices"));
    if (b.contains("predicted_accuracy")) p.baseline_predicted_accuracy = ParsePredicted(b.at("predicted_accuracy"));
  }
  if (j.contains("predicted_accuracy")) p.predicted_accuracy = ParsePredicted(j.at("predicted_accuracy"));
  p.identifiable_parameters = j.value("identifiable_parameters", std::vector<std::string>());
  if (j.contains("summary")) {
    p.termination = String(j.at("summary"), "termination");
    p.summary = String(j.at("summary"), "brief");
  }
  p.raw = j;
  return p;
}

ErrorInfo ParseErrorInfo(const json& j) {
  ErrorInfo e;
  e.code = j.value("code", 0);
  e.status = String(j, "status");
  e.message = String(j, "message");
  if (j.contains("details") && j.at("details").is_array()) {
    for (const json& d : j.at("details")) e.details.push_back({String(d, "field"), String(d, "reason")});
  }
  return e;
}

Operation ParseOperation(const json& j) {
  Operation op;
  op.id = j.at("id").get<std::string>();
  op.kind = String(j, "kind");
  op.state = String(j, "state");
  op.done = j.value("done", false);
  op.progress = j.contains("progress") && j.at("progress").is_number() ? j.at("progress").get<double>() : 0.0;
  if (j.contains("result") && j.at("result").is_object()) {
    op.plan = String(j.at("result"), "plan");
    if (op.kind == "fit") op.fit = ParseCalibrationResult(j.at("result"));
  }
  if (j.contains("error") && j.at("error").is_object()) op.error = ParseErrorInfo(j.at("error"));
  op.raw = j;
  return op;
}

Campaign ParseCampaign(const json& j) {
  Campaign c;
  c.id = j.at("id").get<std::string>();
  c.description = String(j, "description");
  c.robot = String(j, "robot");
  c.measurement_type = String(j, "measurement_type");
  c.plan = String(j, "plan");
  if (j.contains("noise")) {
    c.noise.position_mm = j.at("noise").value("position_mm", c.noise.position_mm);
    c.noise.orientation_deg = j.at("noise").value("orientation_deg", c.noise.orientation_deg);
  }
  if (j.contains("counts")) {
    c.calibration_count = j.at("counts").value("calibration", std::int64_t{0});
    c.validation_count = j.at("counts").value("validation", std::int64_t{0});
  }
  c.calibrated = j.value("calibrated", false);
  c.raw = j;
  return c;
}

UploadResult ParseUploadResult(const json& j) {
  UploadResult u;
  u.batch_id = j.at("batch_id").get<std::string>();
  u.request_id = String(j, "request_id");
  u.replayed = j.value("replayed", false);
  u.first_sequence = j.value("first_sequence", std::int64_t{0});
  u.count = j.value("count", std::int64_t{0});
  u.campaign_total = j.value("campaign_total", std::int64_t{0});
  u.raw = j;
  return u;
}

MeasurementPage ParseMeasurementPage(const json& j) {
  MeasurementPage page;
  for (const json& m : j.at("measurements")) {
    StoredMeasurement s;
    s.sequence = m.at("sequence").get<std::int64_t>();
    s.batch_id = String(m, "batch_id");
    s.role = String(m, "role");
    s.measurement = api::MeasurementFromJson(m);
    page.measurements.push_back(std::move(s));
  }
  if (j.contains("next_after") && j.at("next_after").is_number()) {
    page.next_after = j.at("next_after").get<std::int64_t>();
  }
  page.raw = j;
  return page;
}

CalibrationResult ParseCalibrationResult(const json& j) {
  CalibrationResult c;
  for (const json& p : j.at("parameters")) {
    c.parameters.push_back({String(p, "name"), String(p, "unit"), Number(p, "value"), Number(p, "std")});
  }
  if (j.contains("dropped")) {
    for (const json& d : j.at("dropped")) c.dropped.push_back({String(d, "name"), String(d, "reason")});
  }
  c.base = ParsePoseResult(j.at("base"));
  c.tool = ParsePoseResult(j.at("tool"));
  if (j.contains("registered_base")) c.registered_base = ParsePoseResult(j.at("registered_base"));
  if (j.contains("residuals_before")) c.residuals_before = ParseResiduals(j.at("residuals_before"));
  if (j.contains("residuals_after")) c.residuals_after = ParseResiduals(j.at("residuals_after"));
  c.condition_number = Number(j, "condition_number");
  if (j.contains("summary")) {
    const json& s = j.at("summary");
    c.termination = String(s, "termination");
    c.message = String(s, "message");
    c.iterations = s.value("iterations", 0);
    c.brief = String(s, "brief");
    c.deadline_exceeded = s.value("deadline_exceeded", false);
  }
  c.stored = j.value("stored", true);
  c.raw = j;
  return c;
}

Compensation ParseCompensation(const json& j) {
  Compensation c;
  for (const json& v : j.at("joints")) {
    c.joints.push_back(v.is_null() ? std::numeric_limits<double>::quiet_NaN() : v.get<double>());
  }
  c.position_error_mm = Number(j, "position_error_mm");
  c.orientation_error_deg = Number(j, "orientation_error_deg");
  c.free_rotation_deg = Number(j, "free_rotation_deg");
  c.converged = j.value("converged", false);
  c.iterations = j.value("iterations", 0);
  c.message = String(j, "message");
  return c;
}

Evaluation ParseEvaluation(const json& j) {
  Evaluation e;
  e.num_validation = j.value("num_validation", 0);
  e.h_mm = Number(j, "h_mm");
  e.nominal = ParseAccuracy(j.at("nominal"));
  e.calibrated = ParseAccuracy(j.at("calibrated"));
  if (j.contains("improvement_percent")) {
    for (const auto& [key, value] : j.at("improvement_percent").items()) {
      e.improvement_percent[key] = value.is_number() ? value.get<double>() : std::numeric_limits<double>::quiet_NaN();
    }
  }
  e.raw = j;
  return e;
}

}  // namespace robocal::client
