// Wire types: validating parsers and serialisers.
#include "robocal/api/types.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include "robocal/api/convert.h"
#include "robocal/api/json_reader.h"
#include "robocal/core/observability.h"
#include "robocal/core/presets.h"
#include "robocal/core/transforms.h"

namespace robocal::api {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;
constexpr double kRadPerDeg = std::numbers::pi / 180.0;
// Values beyond this are typing mistakes, not geometry: 1000 km in mm, a million degrees.
constexpr double kMaxLengthMm = 1e9;
constexpr double kMaxAngleDeg = 1e6;

const std::vector<std::string> kMeasurementTypes = {"position", "position_axis", "pose"};

std::string UnitOf(const RobotModel& model, int joint) {
  return model.joint_type(joint) == JointType::kRevolute ? "deg" : "mm";
}

void ParseNoiseInto(const nlohmann::json* v, const std::string& path, Problems* problems, NoiseWire* out) {
  if (v == nullptr) return;
  ObjectReader n(*v, path, problems);
  n.Number("position_mm", false, &out->position_mm, 1e-9, 1e3);
  n.Number("orientation_deg", false, &out->orientation_deg, 1e-9, 90.0);
  n.RejectUnknown({"position_mm", "orientation_deg"});
}

}  // namespace

bool IsValidId(const std::string& id) {
  if (id.empty() || id.size() > 64) return false;
  for (std::size_t i = 0; i < id.size(); ++i) {
    const char c = id[i];
    const bool alnum = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
    if (!(alnum || (i > 0 && (c == '_' || c == '-' || c == '.')))) return false;
  }
  return true;
}

bool ParsePose(const nlohmann::json& value, const std::string& path, bool orientation_required,
               Problems* problems, PoseWire* out) {
  const std::size_t before = problems->size();
  ObjectReader r(value, path, problems);
  if (!r.ok()) return false;
  PoseWire pose;
  if (r.FixedNumbers("position_mm", true, pose.position_mm.data(), 3)) {
    for (int i = 0; i < 3; ++i) {
      if (std::abs(pose.position_mm[i]) > kMaxLengthMm) {
        problems->Add(IndexPath(JoinPath(path, "position_mm"), i), "implausibly large (limit 1e9 mm)");
      }
    }
  }
  const bool has_q = r.Has("quaternion"), has_rpy = r.Has("rpy_deg");
  if (has_q && has_rpy) {
    problems->Add(JoinPath(path, "rpy_deg"), "give either quaternion or rpy_deg, not both");
  } else if (has_q) {
    std::array<double, 4> q{};
    if (r.FixedNumbers("quaternion", true, q.data(), 4)) {
      const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (!(std::abs(norm - 1.0) < 1e-3)) {
        problems->Add(JoinPath(path, "quaternion"), "must be a unit quaternion [w,x,y,z] (norm " +
                                                        nlohmann::json(norm).dump() + ")");
      } else {
        for (int i = 0; i < 4; ++i) pose.quaternion[i] = q[i] / norm;
      }
    }
  } else if (has_rpy) {
    std::array<double, 3> rpy{};
    if (r.FixedNumbers("rpy_deg", true, rpy.data(), 3)) {
      bool ok = true;
      for (int i = 0; i < 3; ++i) {
        if (std::abs(rpy[i]) > 360.0) {
          problems->Add(IndexPath(JoinPath(path, "rpy_deg"), i), "must be in [-360, 360] degrees");
          ok = false;
        }
      }
      if (ok) {
        const Eigen::Quaterniond q(
            RotationFromRpy(Eigen::Vector3d(rpy[0], rpy[1], rpy[2]) * kRadPerDeg));
        pose.quaternion = {q.w(), q.x(), q.y(), q.z()};
      }
    }
  } else if (orientation_required) {
    problems->Add(JoinPath(path, "quaternion"), "required (or rpy_deg)");
  } else {
    pose.has_orientation = false;
  }
  r.RejectUnknown({"position_mm", "quaternion", "rpy_deg"});
  if (problems->size() != before) return false;
  *out = pose;
  return true;
}

nlohmann::json ToJson(const PoseWire& pose) {
  nlohmann::json j = {{"position_mm", pose.position_mm}};
  if (pose.has_orientation) j["quaternion"] = pose.quaternion;
  return j;
}

// ---------------------------------------------------------------------------------------------- robots

RegisterRobotRequest ParseRegisterRobotRequest(const nlohmann::json& body, const Limits&) {
  Problems problems;
  RegisterRobotRequest req;
  ObjectReader r(body, "", &problems);
  if (r.String("id", true, &req.id) && !IsValidId(req.id)) {
    problems.Add("id", "must match [a-z0-9][a-z0-9_.-]{0,63}");
  }
  r.String("description", false, &req.description, 1024);
  PoseWire pose;
  if (const nlohmann::json* v = r.Get("base"); v && ParsePose(*v, "base", true, &problems, &pose)) req.base = pose;
  if (const nlohmann::json* v = r.Get("tool"); v && ParsePose(*v, "tool", true, &problems, &pose)) req.tool = pose;
  if (r.Has("from_preset")) {
    std::vector<std::string> presets = PresetNames();
    r.Enum("from_preset", true, presets, &req.from_preset);
    if (r.Has("joints")) problems.Add("joints", "give either from_preset or joints, not both");
  } else {
    r.Enum("convention", true, {"dh", "mdh", "transform"}, &req.convention);
    if (const nlohmann::json* joints = r.Array("joints", true, 1, kMaxJoints)) {
      for (std::size_t i = 0; i < joints->size(); ++i) {
        const std::string path = IndexPath("joints", i);
        ObjectReader jr((*joints)[i], path, &problems);
        JointWire j;
        jr.String("name", false, &j.name, 64);
        jr.Enum("type", true, {"revolute", "prismatic"}, &j.type);
        jr.Number("a_mm", false, &j.a_mm, -kMaxLengthMm, kMaxLengthMm);
        jr.Number("alpha_deg", false, &j.alpha_deg, -360.0, 360.0);
        jr.Number("d_mm", false, &j.d_mm, -kMaxLengthMm, kMaxLengthMm);
        jr.Number("theta_deg", false, &j.theta_deg, -360.0, 360.0);
        jr.FixedNumbers("xyz_mm", false, j.xyz_mm.data(), 3);
        jr.FixedNumbers("rpy_deg", false, j.rpy_deg.data(), 3);
        const bool revolute = j.type != "prismatic";
        const char* min_key = revolute ? "min_deg" : "min_mm";
        const char* max_key = revolute ? "max_deg" : "max_mm";
        const double bound = revolute ? kMaxAngleDeg : kMaxLengthMm;
        jr.Number(min_key, true, &j.min, -bound, bound);
        jr.Number(max_key, true, &j.max, -bound, bound);
        if (jr.ok() && (jr.Has(revolute ? "min_mm" : "min_deg") || jr.Has(revolute ? "max_mm" : "max_deg"))) {
          problems.Add(path, std::string("limits of a ") + j.type + " joint are given as " + min_key + "/" +
                                 max_key);
        }
        jr.RejectUnknown({"name", "type", "a_mm", "alpha_deg", "d_mm", "theta_deg", "xyz_mm", "rpy_deg", "min_deg",
                          "max_deg", "min_mm", "max_mm"});
        req.joints.push_back(j);
      }
    }
  }
  r.RejectUnknown({"id", "description", "from_preset", "convention", "joints", "base", "tool"});
  problems.ThrowIfAny("invalid robot");
  // The core checks the geometry as a whole (limits ordered, transforms valid); its field names are ours.
  try {
    (void)RobotModel::Build(ToSpec(req));
  } catch (const InvalidModelError& e) {
    std::vector<FieldViolation> details;
    for (const FieldError& f : e.errors()) details.push_back({f.field, f.reason});
    throw ApiError(Status::kInvalidArgument, std::string("invalid robot: ") + e.what(), details);
  }
  return req;
}

nlohmann::json ToJson(const RegisterRobotRequest& req) {
  nlohmann::json j = {{"id", req.id}};
  if (!req.description.empty()) j["description"] = req.description;
  if (!req.from_preset.empty()) {
    j["from_preset"] = req.from_preset;
  } else {
    j["convention"] = req.convention;
    nlohmann::json joints = nlohmann::json::array();
    for (const JointWire& jw : req.joints) {
      const bool revolute = jw.type != "prismatic";
      nlohmann::json o = {{"type", jw.type}};
      if (!jw.name.empty()) o["name"] = jw.name;
      if (req.convention == "transform") {
        o["xyz_mm"] = jw.xyz_mm;
        o["rpy_deg"] = jw.rpy_deg;
      } else {
        o["a_mm"] = jw.a_mm;
        o["alpha_deg"] = jw.alpha_deg;
        o["d_mm"] = jw.d_mm;
        o["theta_deg"] = jw.theta_deg;
      }
      o[revolute ? "min_deg" : "min_mm"] = jw.min;
      o[revolute ? "max_deg" : "max_mm"] = jw.max;
      joints.push_back(o);
    }
    j["joints"] = joints;
  }
  if (req.base) j["base"] = ToJson(*req.base);
  if (req.tool) j["tool"] = ToJson(*req.tool);
  return j;
}

RobotModelSpec ToSpec(const RegisterRobotRequest& req) {
  RobotModelSpec spec;
  if (!req.from_preset.empty()) {
    spec = PresetSpec(req.from_preset);
  } else {
    spec.convention = req.convention == "mdh"         ? GeometryConvention::kModifiedDh
                      : req.convention == "transform" ? GeometryConvention::kTransform
                                                      : GeometryConvention::kStandardDh;
    for (std::size_t i = 0; i < req.joints.size(); ++i) {
      const JointWire& jw = req.joints[i];
      JointSpec js;
      js.name = jw.name.empty() ? "joint" + std::to_string(i + 1) : jw.name;
      js.type = jw.type == "prismatic" ? JointType::kPrismatic : JointType::kRevolute;
      js.a_mm = jw.a_mm;
      js.alpha_rad = jw.alpha_deg * kRadPerDeg;
      js.d_mm = jw.d_mm;
      js.theta_rad = jw.theta_deg * kRadPerDeg;
      js.xyz_mm = Eigen::Vector3d(jw.xyz_mm[0], jw.xyz_mm[1], jw.xyz_mm[2]);
      js.rpy_rad = Eigen::Vector3d(jw.rpy_deg[0], jw.rpy_deg[1], jw.rpy_deg[2]) * kRadPerDeg;
      const double scale = js.type == JointType::kRevolute ? kRadPerDeg : 1.0;
      js.min = jw.min * scale;
      js.max = jw.max * scale;
      spec.joints.push_back(js);
    }
  }
  spec.name = req.id;
  if (req.base) spec.T_world_base = PoseToTransform(*req.base);
  if (req.tool) spec.T_flange_tool = PoseToTransform(*req.tool);
  return spec;
}

MeasurementNoise ToCore(const NoiseWire& noise) {
  return MeasurementNoise{noise.position_mm, noise.orientation_deg * kRadPerDeg};
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

bool CheckJoints(const RobotModel& model, const std::vector<double>& wire, const std::string& path,
                 Problems* problems) {
  if (static_cast<int>(wire.size()) != model.num_joints()) {
    problems->Add(path, "expected " + std::to_string(model.num_joints()) + " values, got " +
                            std::to_string(wire.size()));
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
                                            nlohmann::json(hi).dump() + "] " + UnitOf(model, i) + ": " +
                                            nlohmann::json(wire[i]).dump());
      ok = false;
    }
  }
  return ok;
}

namespace {
bool ReadJointVector(const nlohmann::json& value, const std::string& path, const RobotModel& model,
                     Problems* problems, std::vector<double>* out) {
  std::vector<double> q;
  // Size is checked by CheckJoints with a message naming the robot's joint count.
  if (!ReadNumberArray(value, path, problems, &q, 0, 64)) return false;
  if (!CheckJoints(model, q, path, problems)) return false;
  *out = std::move(q);
  return true;
}
}  // namespace

ForwardRequest ParseForwardRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits) {
  Problems problems;
  ForwardRequest req;
  ObjectReader r(body, "", &problems);
  if (const nlohmann::json* a = r.Array("joints", true, 1, limits.max_array_length)) {
    req.joints.resize(a->size());
    for (std::size_t i = 0; i < a->size(); ++i) {
      ReadJointVector((*a)[i], IndexPath("joints", i), model, &problems, &req.joints[i]);
    }
  }
  r.RejectUnknown({"joints"});
  problems.ThrowIfAny("invalid forward request");
  return req;
}

nlohmann::json ToJson(const ForwardRequest& req) { return {{"joints", req.joints}}; }

// ---------------------------------------------------------------------------------------------- plans

namespace {

constexpr int kMaxInt = std::numeric_limits<int>::max();

// The request fields that set a plan's work, and how they add up to it, for the reasons of a refused plan.
struct WorkTerms {
  std::vector<std::string> evaluation_fields;
  std::string evaluations;  // e.g. "(restarts + 1) x (2 k_max + 1)"
  std::vector<std::string> jacobian_fields;
  std::string jacobians;
};

WorkTerms WorkTermsOf(const PlanRequest& req) {
  if (req.optimiser == "random") {
    return {{"options.num_sets"},
            "num_sets",
            {"num_configurations", "options.num_sets", "num_validation"},
            "num_sets x num_configurations + 2 x num_validation"};
  }
  if (req.optimiser == "exchange") {
    return {{"options.max_iterations", "options.num_candidates", "options.screen"},
            "max_iterations x (num_candidates + min(screen, num_candidates - num_configurations)) + 1",
            {"options.num_candidates", "num_validation"},
            "num_candidates + 2 x num_validation"};
  }
  // A set max_evaluations caps the evaluations within their limit (it is checked on its own), not the product.
  std::vector<std::string> jacobian_fields = {"num_configurations", "options.k_max", "options.restarts"};
  if (req.max_evaluations > 0) jacobian_fields.push_back("options.max_evaluations");
  jacobian_fields.push_back("num_validation");
  return {{"options.k_max", "options.restarts"},
          "(restarts + 1) x (2 k_max + 1)",
          jacobian_fields,
          "evaluations x num_configurations + 2 x num_validation"};
}

// Refuses, before any work starts, a plan whose total work exceeds the limits, naming every field that sets it.
void CheckPlanWork(const PlanRequest& req, const Limits& limits, Problems* problems) {
  const PlanWork work = MaxWork(req);
  const WorkTerms terms = WorkTermsOf(req);
  if (work.evaluations > limits.max_plan_evaluations) {
    const std::string reason = OverLimit(work.evaluations, "objective evaluations (" + terms.evaluations + ")",
                                         "max_plan_evaluations", limits.max_plan_evaluations) +
                               "; lower them, or cap the plan with options.max_evaluations";
    for (const std::string& field : terms.evaluation_fields) problems->Add(field, reason);
  }
  if (work.jacobians > limits.max_plan_jacobians) {
    const std::string reason = OverLimit(work.jacobians, "configuration Jacobians (" + terms.jacobians + ")",
                                         "max_plan_jacobians", limits.max_plan_jacobians);
    for (const std::string& field : terms.jacobian_fields) problems->Add(field, reason);
  }
}

}  // namespace

std::string OverLimit(std::int64_t value, const std::string& what, const std::string& limit_name, std::int64_t limit) {
  return std::to_string(value) + " " + what + " exceed the server's limit " + limit_name + " = " +
         std::to_string(limit);
}

PlanRequest ParsePlanRequest(const nlohmann::json& body, const Limits& limits) {
  Problems problems;
  PlanRequest req;
  ObjectReader r(body, "", &problems);
  r.String("robot", true, &req.robot, 64);
  if (r.Int("num_configurations", false, &req.num_configurations, 1, kMaxInt) &&
      req.num_configurations > limits.max_plan_configurations) {
    problems.Add("num_configurations", OverLimit(req.num_configurations, "configurations", "max_plan_configurations",
                                                 limits.max_plan_configurations));
  }
  r.Enum("measurement_type", false, kMeasurementTypes, &req.measurement_type);
  r.Enum("objective", false, {"condition_number", "o1", "o2", "o3", "o4", "o5", "log_det"}, &req.objective);
  r.Enum("optimiser", false, {"solis_wets", "random", "exchange"}, &req.optimiser);
  r.Enum("scaling", false, {"column_norm", "expected_deviation", "none"}, &req.scaling);
  ParseNoiseInto(r.Get("noise"), "noise", &problems, &req.noise);
  std::int64_t seed = 1;
  if (r.Int("seed", false, &seed, 0, INT64_MAX)) req.seed = static_cast<std::uint64_t>(seed);
  r.Int("num_validation", false, &req.num_validation, 1, 10000);
  r.Bool("async", false, &req.async);
  if (const nlohmann::json* o = r.Get("options")) {
    ObjectReader opt(*o, "options", &problems);
    // Each option within the core's own range; what they add up to is checked against the limits below.
    opt.Int("k_max", false, &req.k_max, 1, 10000000);
    opt.Int("restarts", false, &req.restarts, 0, 10000);
    if (opt.Int("max_evaluations", false, &req.max_evaluations, 0, kMaxInt) &&
        req.max_evaluations > limits.max_plan_evaluations) {
      problems.Add("options.max_evaluations",
                   OverLimit(req.max_evaluations, "evaluations", "max_plan_evaluations", limits.max_plan_evaluations));
    }
    opt.Number("step_fraction", false, &req.step_fraction, 1e-6, 1.0);
    opt.Int("num_sets", false, &req.num_sets, 1, 10000000);
    opt.Int("num_candidates", false, &req.num_candidates, 1, 1000000);
    opt.Int("screen", false, &req.screen, 1, 1000000);
    opt.Int("max_iterations", false, &req.max_iterations, 1, 10000000);
    opt.RejectUnknown({"k_max", "restarts", "max_evaluations", "step_fraction", "num_sets", "num_candidates",
                       "screen", "max_iterations"});
  }
  r.RejectUnknown({"robot", "num_configurations", "measurement_type", "objective", "optimiser", "scaling", "noise",
                   "seed", "num_validation", "async", "options"});
  // Only the chosen optimiser's options count (clients may send every option with its default).
  if (req.optimiser == "exchange" && req.num_candidates > limits.max_plan_candidates) {
    problems.Add("options.num_candidates",
                 OverLimit(req.num_candidates, "candidates", "max_plan_candidates", limits.max_plan_candidates));
  } else if (req.optimiser == "exchange" && req.num_candidates < req.num_configurations) {
    problems.Add("options.num_candidates", "the pool (" + std::to_string(req.num_candidates) +
                                               ") must hold at least num_configurations (" +
                                               std::to_string(req.num_configurations) + ")");
  }
  if (problems.empty()) CheckPlanWork(req, limits, &problems);
  problems.ThrowIfAny("invalid plan request");
  return req;
}

SolisWetsOptions ToSolisWetsOptions(const PlanRequest& req) {
  SolisWetsOptions o = SolisWetsOptions::Paper();
  o.k_max = req.k_max;
  o.restarts = req.restarts;
  o.max_evaluations = req.max_evaluations;
  o.step_fraction = req.step_fraction;
  ParseObservabilityIndex(req.objective, &o.objective);
  o.seed = req.seed;
  return o;
}

RandomSelectionOptions ToRandomSelectionOptions(const PlanRequest& req) {
  RandomSelectionOptions o;
  o.num_sets = req.num_sets;
  ParseObservabilityIndex(req.objective, &o.objective);
  o.seed = req.seed;
  return o;
}

ExchangeOptions ToExchangeOptions(const PlanRequest& req) {
  ExchangeOptions o;
  o.num_candidates = req.num_candidates;
  o.screen = req.screen;
  o.max_iterations = req.max_iterations;
  o.max_evaluations = req.max_evaluations;
  ParseObservabilityIndex(req.objective, &o.objective);
  o.seed = req.seed;
  return o;
}

PlanWork MaxWork(const PlanRequest& req) {
  const int m = req.num_configurations;
  PlanWork work = req.optimiser == "random"     ? MaxPlanWork(m, ToRandomSelectionOptions(req))
                  : req.optimiser == "exchange" ? MaxPlanWork(m, ToExchangeOptions(req))
                                                : MaxPlanWork(m, ToSolisWetsOptions(req));
  work.jacobians = std::min(work.jacobians, std::numeric_limits<std::int64_t>::max() - 2 * req.num_validation) +
                   2 * static_cast<std::int64_t>(req.num_validation);
  return work;
}

nlohmann::json ToJson(const PlanRequest& req) {
  return {{"robot", req.robot},
          {"num_configurations", req.num_configurations},
          {"measurement_type", req.measurement_type},
          {"objective", req.objective},
          {"optimiser", req.optimiser},
          {"scaling", req.scaling},
          {"noise", {{"position_mm", req.noise.position_mm}, {"orientation_deg", req.noise.orientation_deg}}},
          {"seed", req.seed},
          {"num_validation", req.num_validation},
          {"async", req.async},
          {"options",
           {{"k_max", req.k_max},
            {"restarts", req.restarts},
            {"max_evaluations", req.max_evaluations},
            {"step_fraction", req.step_fraction},
            {"num_sets", req.num_sets},
            {"num_candidates", req.num_candidates},
            {"screen", req.screen},
            {"max_iterations", req.max_iterations}}}};
}

// ---------------------------------------------------------------------------------------------- campaigns

CreateCampaignRequest ParseCreateCampaignRequest(const nlohmann::json& body) {
  Problems problems;
  CreateCampaignRequest req;
  ObjectReader r(body, "", &problems);
  if (r.String("id", false, &req.id) && !IsValidId(req.id)) {
    problems.Add("id", "must match [a-z0-9][a-z0-9_.-]{0,63}");
  }
  r.String("description", false, &req.description, 1024);
  r.String("robot", true, &req.robot, 64);
  r.Enum("measurement_type", false, kMeasurementTypes, &req.measurement_type);
  r.String("plan", false, &req.plan, 64);
  ParseNoiseInto(r.Get("noise"), "noise", &problems, &req.noise);
  r.RejectUnknown({"id", "description", "robot", "measurement_type", "plan", "noise"});
  problems.ThrowIfAny("invalid campaign");
  return req;
}

nlohmann::json ToJson(const CreateCampaignRequest& req) {
  nlohmann::json j = {{"robot", req.robot},
                      {"measurement_type", req.measurement_type},
                      {"noise", {{"position_mm", req.noise.position_mm},
                                 {"orientation_deg", req.noise.orientation_deg}}}};
  if (!req.id.empty()) j["id"] = req.id;
  if (!req.description.empty()) j["description"] = req.description;
  if (!req.plan.empty()) j["plan"] = req.plan;
  return j;
}

nlohmann::json ToJson(const MeasurementWire& m) { return {{"joints", m.joints}, {"pose", ToJson(m.pose)}}; }

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
  r.Enum("role", false, {"calibration", "validation"}, &req.role);
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

nlohmann::json ToJson(const MeasurementBatchRequest& req) {
  nlohmann::json list = nlohmann::json::array();
  for (const MeasurementWire& m : req.measurements) list.push_back(ToJson(m));
  return {{"request_id", req.request_id}, {"role", req.role}, {"measurements", list}};
}

MeasurementWire MeasurementFromJson(const nlohmann::json& value) {
  MeasurementWire m;
  m.joints = value.at("joints").get<std::vector<double>>();
  const nlohmann::json& p = value.at("pose");
  m.pose.position_mm = p.at("position_mm").get<std::array<double, 3>>();
  if (p.contains("quaternion")) {
    m.pose.quaternion = p.at("quaternion").get<std::array<double, 4>>();
  } else {
    m.pose.has_orientation = false;
  }
  return m;
}

// ---------------------------------------------------------------------------------------------- fit etc.

FitRequest ParseFitRequest(const nlohmann::json& body, const RobotModel& model, const Limits&) {
  Problems problems;
  FitRequest req;
  ObjectReader r(body, "", &problems);
  if (const nlohmann::json* a = r.Array("parameters", false, 0, model.parameter_names().size())) {
    for (std::size_t i = 0; i < a->size(); ++i) {
      const nlohmann::json& v = (*a)[i];
      if (!v.is_string()) {
        problems.Add(IndexPath("parameters", i), "expected a parameter name");
      } else if (model.ParameterIndex(v.get<std::string>()) < 0) {
        problems.Add(IndexPath("parameters", i), "unknown parameter \"" + v.get<std::string>() +
                                                     "\" (e.g. joint2.dz, base.rx, tool.dx)");
      } else {
        req.parameters.push_back(v.get<std::string>());
      }
    }
  }
  r.Bool("register_base", false, &req.register_base);
  r.Int("max_iterations", false, &req.max_iterations, 1, 1000);
  r.Bool("async", false, &req.async);
  r.RejectUnknown({"parameters", "register_base", "max_iterations", "async"});
  problems.ThrowIfAny("invalid fit request");
  return req;
}

nlohmann::json ToJson(const FitRequest& req) {
  return {{"parameters", req.parameters}, {"register_base", req.register_base},
          {"max_iterations", req.max_iterations}, {"async", req.async}};
}

CompensateRequest ParseCompensateRequest(const nlohmann::json& body, const RobotModel& model,
                                         const Limits& limits) {
  Problems problems;
  CompensateRequest req;
  ObjectReader r(body, "", &problems);
  if (const nlohmann::json* a = r.Array("targets", true, 1, limits.max_array_length)) {
    req.targets.resize(a->size());
    for (std::size_t i = 0; i < a->size(); ++i) {
      const std::string path = IndexPath("targets", i);
      ObjectReader t((*a)[i], path, &problems);
      CompensationTargetWire& w = req.targets[i];
      const bool has_joints = t.Has("joints"), has_pose = t.Has("pose");
      if (t.ok() && has_joints == has_pose) {
        problems.Add(path, "give exactly one of joints (nominal joint command) or pose");
      } else if (has_joints) {
        ReadJointVector(*t.Get("joints"), JoinPath(path, "joints"), model, &problems, &w.joints);
        if (t.Has("frame") || t.Has("start_joints")) {
          problems.Add(path, "frame and start_joints apply to pose targets only");
        }
      } else if (has_pose) {
        PoseWire p;
        if (ParsePose(*t.Get("pose"), JoinPath(path, "pose"), true, &problems, &p)) w.pose = p;
        t.Enum("frame", false, {"tracker", "base"}, &w.frame);
        if (const nlohmann::json* s = t.Get("start_joints")) {
          ReadJointVector(*s, JoinPath(path, "start_joints"), model, &problems, &w.start_joints);
        }
      }
      t.RejectUnknown({"joints", "pose", "frame", "start_joints"});
      if (problems.size() > 100) break;
    }
  }
  r.RejectUnknown({"targets"});
  problems.ThrowIfAny("invalid compensation request");
  return req;
}

nlohmann::json ToJson(const CompensateRequest& req) {
  nlohmann::json list = nlohmann::json::array();
  for (const CompensationTargetWire& t : req.targets) {
    if (t.pose) {
      nlohmann::json o = {{"pose", ToJson(*t.pose)}, {"frame", t.frame}};
      if (!t.start_joints.empty()) o["start_joints"] = t.start_joints;
      list.push_back(o);
    } else {
      list.push_back({{"joints", t.joints}});
    }
  }
  return {{"targets", list}};
}

EvaluateRequest ParseEvaluateRequest(const nlohmann::json& body) {
  Problems problems;
  EvaluateRequest req;
  ObjectReader r(body, "", &problems);
  r.Number("h_mm", false, &req.h_mm, 1e-9, 1e6);
  r.RejectUnknown({"h_mm"});
  problems.ThrowIfAny("invalid evaluate request");
  return req;
}

nlohmann::json ToJson(const EvaluateRequest& req) { return {{"h_mm", req.h_mm}}; }

// FNV-1a (64 bit) rather than std::hash: it must give the same digits on every platform and in every run,
// because the server stores it and compares a retried batch's hash with it. Not a security property: a
// request_id is the caller's own.
std::string ContentHash(const std::string& text) {
  std::uint64_t h = 14695981039346656037ULL;  // FNV-1a 64-bit offset basis
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;  // FNV-1a 64-bit prime
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

}  // namespace robocal::api
