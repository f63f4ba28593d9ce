// Robot resources on the wire.
#include "robocal/api/robots.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "robocal/api/json_reader.h"
#include "robocal/core/presets.h"

namespace robocal::api {
namespace {

const char* MinKey(JointType type) { return type == JointType::kRevolute ? "min_deg" : "min_mm"; }
const char* MaxKey(JointType type) { return type == JointType::kRevolute ? "max_deg" : "max_mm"; }

}  // namespace

// ---------------------------------------------------------------------------------------------- definitions

RegisterRobotRequest ParseRegisterRobotRequest(const nlohmann::json& body, const Limits&) {
  Problems problems;
  RegisterRobotRequest req;
  ObjectReader r(body, "", &problems);
  ReadRequest(r, &req);
  if (r.Has("from_preset")) {
    r.Enum("from_preset", true, PresetNames(), &req.from_preset);
    if (r.Has("joints")) problems.Add("joints", "give either from_preset or joints, not both");
  } else {
    r.Enum("convention", true, &req.convention);
    if (const nlohmann::json* joints = r.Array("joints", true, 1, kMaxJoints)) {
      for (std::size_t i = 0; i < joints->size(); ++i) {
        const std::string path = IndexPath("joints", i);
        ObjectReader jr((*joints)[i], path, &problems);
        JointWire j;
        // The convention picks the geometry keys read (the others are taken and left unused).
        j.convention = req.convention;
        ReadRequest(jr, &j);
        const bool revolute = j.type == JointType::kRevolute;
        const JointType other = revolute ? JointType::kPrismatic : JointType::kRevolute;
        if (jr.ok() && (jr.Has(MinKey(other)) || jr.Has(MaxKey(other)))) {
          problems.Add(path, std::string("limits of a ") + WireName(j.type) + " joint are given as " + MinKey(j.type) +
                                 "/" + MaxKey(j.type));
        }
        // Every geometry key is taken whatever the convention (the convention's are used).
        jr.RejectUnknown(WireFieldNames<JointWire>());
        req.joints.push_back(j);
      }
    }
  }
  r.RejectUnknown(WireFieldNames<RegisterRobotRequest>());
  problems.ThrowIfAny("invalid robot");
  (void)BuildModel(req);
  return req;
}

bool IsFromCalibration(const nlohmann::json& body) { return body.is_object() && body.contains("from_calibration"); }

RobotFromCalibrationRequest ParseRobotFromCalibrationRequest(const nlohmann::json& body) {
  Problems problems;
  RobotFromCalibrationRequest req;
  // The geometry is the calibration's: a table, preset, URDF, base or tool beside it would contradict it (unknown
  // keys).
  ReadRequestObject(body, "", &problems, &req);
  problems.ThrowIfAny("invalid robot");
  return req;
}

bool IsUrdfImport(const nlohmann::json& body) {
  return body.is_object() && (body.contains("urdf") || body.contains("base_link") || body.contains("tip_link"));
}

ImportUrdfRequest ParseImportUrdfRequest(const nlohmann::json& body, const Limits&) {
  Problems problems;
  ImportUrdfRequest req;
  ReadRequestObject(body, "", &problems, &req);
  problems.ThrowIfAny("invalid robot");
  return req;
}

RobotModelSpec ToSpec(const RegisterRobotRequest& req) {
  RobotModelSpec spec;
  if (!req.from_preset.empty()) {
    spec = PresetSpec(req.from_preset);
  } else {
    spec.convention = req.convention;
    for (std::size_t i = 0; i < req.joints.size(); ++i) {
      const JointWire& jw = req.joints[i];
      JointSpec js;
      WireToCore(jw, &js);
      js.name = jw.name.empty() ? "joint" + std::to_string(i + 1) : jw.name;
      // The limits are in the joint's unit: the table's row cannot say which.
      const double scale = js.type == JointType::kRevolute ? kRadPerDeg : 1.0;
      js.min = jw.min * scale;
      js.max = jw.max * scale;
      if (jw.error_map) {
        js.error_map.first_knot_rad = jw.error_map->first_knot_deg * kRadPerDeg;
        js.error_map.knot_spacing_rad = jw.error_map->knot_spacing_deg * kRadPerDeg;
        for (double c : jw.error_map->coefficients_deg) js.error_map.coefficients_rad.push_back(c * kRadPerDeg);
      }
      spec.joints.push_back(js);
    }
  }
  spec.name = req.id;
  if (req.base) spec.T_world_base = PoseToTransform(*req.base);
  if (req.tool) spec.T_flange_tool = PoseToTransform(*req.tool);
  if (req.flange) spec.T_lastjoint_flange = PoseToTransform(*req.flange);
  if (req.gravity) {
    const Eigen::Vector3d g((*req.gravity)[0], (*req.gravity)[1], (*req.gravity)[2]);
    // A zero vector stays zero, for the core to refuse by name ("gravity").
    spec.gravity_base = g.norm() > 0.0 ? Eigen::Vector3d(g.normalized()) : g;
  }
  return spec;
}

std::string ImplausibleJointTerms(const JointWire& joint) {
  std::ostringstream out;
  out << std::setprecision(4);
  if (std::abs(joint.compliance_deg_per_nm) > kMaxComplianceDegPerNm) {
    out << "compliance_deg_per_nm " << joint.compliance_deg_per_nm << " is beyond +-0.573 deg/(N*m) (0.01 rad/(N*m))";
  }
  for (std::size_t k = 0; k < joint.harmonics_deg.size(); ++k) {
    if (std::abs(joint.harmonics_deg[k]) <= kMaxHarmonicDeg) continue;
    out << (out.tellp() > 0 ? "; " : "") << "harmonics_deg[" << k << "] " << joint.harmonics_deg[k]
        << " is beyond +-0.573 deg (0.01 rad)";
  }
  if (joint.error_map) {
    for (std::size_t k = 0; k < joint.error_map->coefficients_deg.size(); ++k) {
      if (std::abs(joint.error_map->coefficients_deg[k]) <= kMaxHarmonicDeg) continue;
      out << (out.tellp() > 0 ? "; " : "") << "error_map.coefficients_deg[" << k << "] "
          << joint.error_map->coefficients_deg[k] << " is beyond +-0.573 deg (0.01 rad)";
      break;
    }
  }
  return out.str();
}

RobotModel BuildModel(const RegisterRobotRequest& req) {
  // The core checks the geometry as a whole (limits ordered, transforms valid); its field names are ours.
  try {
    return RobotModel::Build(ToSpec(req));
  } catch (const InvalidModelError& e) {
    std::vector<FieldViolation> details;
    for (const FieldError& f : e.errors()) details.push_back({f.field, f.reason});
    throw ApiError(Status::kInvalidArgument, std::string("invalid robot: ") + e.what(), details);
  }
}

// ---------------------------------------------------------------------------------------------- the resource

JointWire JointToWire(const JointSpec& js, GeometryConvention convention) {
  const double scale = js.type == JointType::kRevolute ? kDegPerRad : 1.0;
  JointWire jw;
  CoreToWire(js, &jw);
  jw.name = js.name;
  jw.convention = convention;
  jw.min = js.min * scale;
  jw.max = js.max * scale;
  if (!js.error_map.empty()) {
    JointMapWire map{.first_knot_deg = js.error_map.first_knot_rad * kDegPerRad,
                     .knot_spacing_deg = js.error_map.knot_spacing_rad * kDegPerRad,
                     .coefficients_deg = {}};
    for (double c : js.error_map.coefficients_rad) map.coefficients_deg.push_back(c * kDegPerRad);
    jw.error_map = std::move(map);
  }
  return jw;
}

RegisterRobotRequest DefinitionOf(const std::string& id, const RobotModelSpec& spec, const std::string& description) {
  RegisterRobotRequest req;
  req.id = id;
  req.description = description;
  req.convention = spec.convention;
  for (const JointSpec& js : spec.joints) req.joints.push_back(JointToWire(js, spec.convention));
  req.base = TransformToPose(spec.T_world_base);
  req.tool = TransformToPose(spec.T_flange_tool);
  if (spec.convention == GeometryConvention::kTransform) req.flange = TransformToPose(spec.T_lastjoint_flange);
  if (spec.gravity_base != Eigen::Vector3d(0.0, 0.0, -1.0)) {
    req.gravity = std::array<double, 3>{spec.gravity_base.x(), spec.gravity_base.y(), spec.gravity_base.z()};
  }
  return req;
}

Robot RobotFromModel(const std::string& id, const RobotModel& model, bool preset, const std::string& description) {
  const RobotModelSpec& spec = model.spec();
  Robot robot;
  robot.id = id;
  robot.preset = preset;
  robot.description = description;
  robot.convention = spec.convention;
  robot.num_joints = model.num_joints();
  for (int i = 0; i < model.num_joints(); ++i)
    robot.joints.push_back({JointToWire(spec.joints[i], spec.convention), JointUnit(model, i)});
  robot.base = TransformToPose(spec.T_world_base);
  robot.tool = TransformToPose(spec.T_flange_tool);
  robot.flange = TransformToPose(spec.T_lastjoint_flange);
  robot.gravity = {spec.gravity_base.x(), spec.gravity_base.y(), spec.gravity_base.z()};
  robot.has_masses = model.has_masses();
  robot.error_parameters = model.parameter_names();
  return robot;
}

// ---------------------------------------------------------------------------------------------- forward

ForwardRequest ParseForwardRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits) {
  return ParseJointsRequest(body, model, limits.max_array_length, "invalid forward request", true);
}

ForwardRequest ParseJointsRequest(const nlohmann::json& body, const RobotModel& model, std::size_t max_vectors,
                                  const char* refusal, bool with_payload) {
  Problems problems;
  ForwardRequest req;
  ObjectReader r(body, "", &problems);
  if (const nlohmann::json* a = r.Array("joints", true, 1, max_vectors)) {
    req.joints.resize(a->size());
    for (std::size_t i = 0; i < a->size(); ++i) {
      ReadJointVector((*a)[i], IndexPath("joints", i), model, &problems, &req.joints[i]);
    }
  }
  PayloadWire payload;
  if (with_payload) {
    if (const nlohmann::json* v = r.Get("payload"); v && ReadRequestObject(*v, "payload", &problems, &payload)) {
      req.payload = payload;
    }
    r.RejectUnknown(WireFieldNames<ForwardRequest>());
  } else {
    r.RejectUnknown({"joints"});
  }
  problems.ThrowIfAny(refusal);
  return req;
}

// ---------------------------------------------------------------------------------------------- joints

Eigen::VectorXd JointsToCore(const RobotModel& model, const std::vector<double>& wire) {
  if (static_cast<int>(wire.size()) != model.num_joints()) throw std::invalid_argument("JointsToCore: size");
  Eigen::VectorXd q(model.num_joints());
  for (int i = 0; i < model.num_joints(); ++i) {
    q[i] = model.joint_type(i) == JointType::kRevolute ? wire[i] * kRadPerDeg : wire[i];
  }
  return q;
}

std::vector<double> JointsToWire(const RobotModel& model, const Eigen::VectorXd& q) {
  std::vector<double> wire(q.size());
  for (int i = 0; i < q.size(); ++i) {
    wire[i] = model.joint_type(i) == JointType::kRevolute ? q[i] * kDegPerRad : q[i];
  }
  return wire;
}

const char* JointUnit(const RobotModel& model, int joint) {
  return model.joint_type(joint) == JointType::kRevolute ? "deg" : "mm";
}

bool CheckJoints(const RobotModel& model, const std::vector<double>& wire, const std::string& path,
                 Problems* problems) {
  if (static_cast<int>(wire.size()) != model.num_joints()) {
    problems->Add(path,
                  "expected " + std::to_string(model.num_joints()) + " values, got " + std::to_string(wire.size()));
    return false;
  }
  bool ok = true;
  for (int i = 0; i < model.num_joints(); ++i) {
    const double scale = model.joint_type(i) == JointType::kRevolute ? kDegPerRad : 1.0;
    const double lo = model.lower_limits()[i] * scale, hi = model.upper_limits()[i] * scale;
    // A hair of tolerance so that limits round-tripped through degrees are still inside.
    const double tol = 1e-9 * std::max(1.0, hi - lo);
    if (wire[i] < lo - tol || wire[i] > hi + tol) {
      problems->Add(IndexPath(path, i), "joint " + std::to_string(i + 1) + " (" + model.joint_name(i) +
                                            ") outside its limits [" + nlohmann::json(lo).dump() + ", " +
                                            nlohmann::json(hi).dump() + "] " + JointUnit(model, i) + ": " +
                                            nlohmann::json(wire[i]).dump());
      ok = false;
    }
  }
  return ok;
}

bool ReadJointVector(const nlohmann::json& value, const std::string& path, const RobotModel& model, Problems* problems,
                     std::vector<double>* out) {
  std::vector<double> q;
  // Size is checked by CheckJoints with a message naming the robot's joint count.
  if (!ReadNumberArray(value, path, problems, &q, 0, 64)) return false;
  if (!CheckJoints(model, q, path, problems)) return false;
  *out = std::move(q);
  return true;
}

// The shapes' to_json / from_json, instantiated here once (ROBOCAL_WIRE_DECLARE).
ROBOCAL_WIRE_DEFINE(JointMapWire);
ROBOCAL_WIRE_DEFINE(JointWire);
ROBOCAL_WIRE_DEFINE(UrdfChainWire);
ROBOCAL_WIRE_DEFINE(UrdfSource);
ROBOCAL_WIRE_DEFINE(CalibrationSource);
ROBOCAL_WIRE_DEFINE(RegisterRobotRequest);
ROBOCAL_WIRE_DEFINE(ImportUrdfRequest);
ROBOCAL_WIRE_DEFINE(RobotFromCalibrationRequest);
ROBOCAL_WIRE_DEFINE(RobotJoint);
ROBOCAL_WIRE_DEFINE(Robot);
ROBOCAL_WIRE_DEFINE(RobotList);
ROBOCAL_WIRE_DEFINE(ForwardRequest);
ROBOCAL_WIRE_DEFINE(ForwardResult);

}  // namespace robocal::api
