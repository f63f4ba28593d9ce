// Plans on the wire.
#include "robocal/api/plans.h"

#include <algorithm>
#include <limits>

#include "robocal/api/json_reader.h"

namespace robocal::api {
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
  if (req.optimiser == Optimiser::kRandom) {
    return {{"options.num_sets"},
            "num_sets",
            {"num_configurations", "options.num_sets", "num_validation"},
            "num_sets x num_configurations + 2 x num_validation"};
  }
  if (req.optimiser == Optimiser::kExchange) {
    return {{"options.max_iterations", "options.num_candidates", "options.screen"},
            "max_iterations x (num_candidates + min(screen, num_candidates - num_configurations)) + 1",
            {"options.num_candidates", "num_validation"},
            "num_candidates + 2 x num_validation"};
  }
  // A set max_evaluations caps the evaluations within their limit (it is checked on its own), not the product.
  std::vector<std::string> jacobian_fields = {"num_configurations", "options.k_max", "options.restarts"};
  if (req.options.max_evaluations > 0) jacobian_fields.push_back("options.max_evaluations");
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

void WireFields<TaskBoxWire>::CheckRequest(const S& box, const std::string& path, Problems* problems) {
  for (std::size_t i = 0; i < 3; ++i) {
    if (box.min_mm[i] > box.max_mm[i]) {
      problems->Add(IndexPath(JoinPath(path, "max_mm"), i), "must not be below min_mm[" + std::to_string(i) + "]");
    }
  }
}

void WireFields<PlanRequest>::CheckRequest(const S& req, const std::string&, Problems* problems) {
  CheckReflectorIds(req.reflectors, problems);
  if (!req.reflectors.empty() && req.measurement_type != MeasurementType::kPosition) {
    problems->Add("reflectors",
                  std::string("need position measurements; measurement_type is ") + WireName(req.measurement_type));
  }
  if (req.num_configurations_auto && !req.accuracy_goal_mm) {
    problems->Add("accuracy_goal_mm", "required with \"num_configurations\": \"auto\" (the accuracy the plan is for)");
  }
  if (!req.num_configurations_auto && req.accuracy_goal_mm) {
    problems->Add("accuracy_goal_mm", "only with \"num_configurations\": \"auto\"");
  }
  if (req.min_configurations > req.max_configurations && req.num_configurations_auto) {
    problems->Add("max_configurations",
                  "must not be below min_configurations (" + std::to_string(req.min_configurations) + ")");
  }
  if (req.task && req.task->joints.empty() == !req.task->box) {
    problems->Add("task", "give exactly one of joints (joint vectors) or box");
  }
  if (req.objective == ObservabilityIndex::kPredictedError && req.task && req.num_validation != 100) {
    problems->Add("num_validation", "the task is predicted_error's sample: leave out num_validation");
  }
  // A check plan: a few well-spread poses of a calibrated robot.
  if (req.purpose == PlanPurpose::kCheck) {
    if (req.num_configurations_auto || req.num_configurations < kMinCheckPoses ||
        req.num_configurations > kMaxCheckPoses) {
      problems->Add("num_configurations", "a check plan has " + std::to_string(kMinCheckPoses) + " to " +
                                              std::to_string(kMaxCheckPoses) + " poses");
    }
    if (req.test) problems->Add("purpose", "a test plan is no check plan");
    if (!req.reflectors.empty()) problems->Add("reflectors", "a check measures the tool point");
  }
  // A test plan's configurations are the test's poses: nothing chooses them.
  if (req.test) {
    if (req.candidates) problems->Add("candidates", "not with a test: the test's poses are its configurations");
    if (req.task) problems->Add("task", "not with a test: the test's poses are its configurations");
    if (req.num_configurations_auto) problems->Add("num_configurations", "not \"auto\" with a test");
    if (!req.reflectors.empty()) problems->Add("reflectors", "not with a test: ISO 9283 measures the tool point");
  }
}

const char* EnumTable<PlanPurpose>::Name(PlanPurpose v) { return v == PlanPurpose::kCheck ? "check" : "calibration"; }

ObservabilityIndex PlanObjective(const PlanRequest& req) {
  if (req.objective) return *req.objective;
  if (req.purpose == PlanPurpose::kCheck && !req.task) return ObservabilityIndex::kLogDet;
  if (req.task) return ObservabilityIndex::kPredictedError;
  return req.candidates || req.num_configurations_auto ? ObservabilityIndex::kLogDet
                                                       : ObservabilityIndex::kConditionNumber;
}

namespace detail {
bool WriteNumConfigurations(const PlanRequest& req, nlohmann::json* value) {
  *value = req.num_configurations_auto ? nlohmann::json("auto") : nlohmann::json(req.num_configurations);
  return true;
}
void ReadNumConfigurations(const nlohmann::json* value, const std::string& path, PlanRequest* req) {
  if (value == nullptr) ThrowWire(path, "required");
  if (value->is_string() && value->get<std::string>() == "auto") {
    req->num_configurations_auto = true;
  } else {
    ReadWire(*value, path, &req->num_configurations);
  }
}
}  // namespace detail

namespace {

// A list of joint vectors at `path`: arrays of finite numbers (their count and limits are the robot's, checked
// when the plan is made).
void ReadJointLists(const nlohmann::json& value, const std::string& path, std::size_t max_count, Problems* problems,
                    std::vector<std::vector<double>>* out) {
  if (!value.is_array()) {
    problems->Add(path, std::string("expected an array of joint vectors, got ") + value.type_name());
    return;
  }
  if (value.empty() || value.size() > max_count) {
    problems->Add(path, value.empty() ? "must not be empty"
                                      : "too many elements: " + std::to_string(value.size()) + " (limit " +
                                            std::to_string(max_count) + ")");
    return;
  }
  out->resize(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    ReadNumberArray(value[i], IndexPath(path, i), problems, &(*out)[i], 1, static_cast<std::size_t>(kMaxJoints));
    if (problems->size() > 100) return;
  }
}

// "candidates": a list of joint vectors, or {"joints" | "campaign" | "file", "malformed"}.
void ReadCandidates(const nlohmann::json& value, const Limits& limits, Problems* problems,
                    std::optional<PlanCandidatesWire>* out) {
  PlanCandidatesWire c;
  if (value.is_array()) {
    ReadJointLists(value, "candidates", limits.max_array_length, problems, &c.joints);
    *out = std::move(c);
    return;
  }
  ObjectReader r(value, "candidates", problems);
  if (!r.ok()) return;
  ReadRequest(r, &c);
  if (const nlohmann::json* joints = r.Get("joints")) {
    ReadJointLists(*joints, "candidates.joints", limits.max_array_length, problems, &c.joints);
  }
  if (const nlohmann::json* file = r.Get("file")) {
    // An import request's members, read by the import's own parser (request_id only makes an import idempotent).
    nlohmann::json body = *file;
    if (body.is_object()) body["request_id"] = "candidates";
    try {
      c.file = ParseImportMeasurementsRequest(body);
      if (c.file->joints.empty()) problems->Add("candidates.file.joints", "required: candidates are joint vectors");
    } catch (const ApiError& e) {
      for (const FieldViolation& v : e.details()) problems->Add(JoinPath("candidates.file", v.field), v.reason);
    }
  }
  r.RejectUnknown(WireFieldNames<PlanCandidatesWire>());
  const int sources = (c.joints.empty() ? 0 : 1) + (c.campaign.empty() ? 0 : 1) + (c.file ? 1 : 0);
  if (sources != 1 && r.ok() && problems->empty()) {
    problems->Add("candidates", "give exactly one of joints, campaign or file");
  }
  *out = std::move(c);
}

}  // namespace

PlanRequest ParsePlanRequest(const nlohmann::json& body, const Limits& limits) {
  Problems problems;
  PlanRequest req;
  ObjectReader r(body, "", &problems);
  problems.ThrowIfAny("invalid plan request");
  if (const nlohmann::json* n = r.Get("num_configurations")) {
    if (n->is_string() && n->get<std::string>() == "auto") {
      req.num_configurations_auto = true;
    } else {
      r.Int("num_configurations", false, &req.num_configurations, 1, std::numeric_limits<int>::max());
    }
  }
  if (const nlohmann::json* c = r.Get("candidates")) ReadCandidates(*c, limits, &problems, &req.candidates);
  ReadRequest(r, &req);
  if (const nlohmann::json* t = r.Get("task"); req.task && t->contains("joints")) {
    ReadJointLists((*t)["joints"], "task.joints", 10000, &problems, &req.task->joints);
  }
  r.RejectUnknown(WireFieldNames<PlanRequest>());
  for (const char* key : {"min_configurations", "max_configurations"}) {
    if (r.Has(key) && !req.num_configurations_auto) {
      problems.Add(key, "only with \"num_configurations\": \"auto\"");
    }
  }
  if (problems.empty()) WireFields<PlanRequest>::CheckRequest(req, "", &problems);
  if (req.test) {
    // Nothing of a calibration plan's search applies: set to anything but its default, refused rather than ignored
    // (a client that writes every member writes the defaults).
    const PlanRequest defaults;
    const std::pair<const char*, bool> set[] = {
        {"num_configurations", !req.num_configurations_auto && req.num_configurations != defaults.num_configurations},
        {"objective", req.objective.has_value()},
        {"optimiser", req.optimiser != defaults.optimiser},
        {"scaling", req.scaling != defaults.scaling},
        {"options", nlohmann::json(req.options) != nlohmann::json(defaults.options)},
        {"num_validation", req.num_validation != defaults.num_validation}};
    for (const auto& [key, given] : set) {
      if (given) problems.Add(key, "not with a test: the test's poses and cycles are the plan");
    }
    const int configurations = kIso9283Poses * req.test->iso9283.cycles;
    if (configurations > limits.max_plan_configurations) {
      problems.Add("test.iso9283.cycles", OverLimit(configurations, "configurations (5 per cycle)",
                                                    "max_plan_configurations", limits.max_plan_configurations));
    }
  }
  const int largest = req.num_configurations_auto ? req.max_configurations : req.num_configurations;
  if (largest > limits.max_plan_configurations) {
    problems.Add(req.num_configurations_auto ? "max_configurations" : "num_configurations",
                 OverLimit(largest, "configurations", "max_plan_configurations", limits.max_plan_configurations));
  }
  if (req.options.max_evaluations > limits.max_plan_evaluations) {
    problems.Add("options.max_evaluations", OverLimit(req.options.max_evaluations, "evaluations",
                                                      "max_plan_evaluations", limits.max_plan_evaluations));
  }
  // Only the chosen optimiser's options count (clients may send every option with its default).
  if (req.optimiser == Optimiser::kExchange && req.options.num_candidates > limits.max_plan_candidates) {
    problems.Add("options.num_candidates", OverLimit(req.options.num_candidates, "candidates", "max_plan_candidates",
                                                     limits.max_plan_candidates));
  } else if (req.optimiser == Optimiser::kExchange && !req.candidates &&
             req.options.num_candidates < req.num_configurations) {
    problems.Add("options.num_candidates", "the pool (" + std::to_string(req.options.num_candidates) +
                                               ") must hold at least num_configurations (" +
                                               std::to_string(req.num_configurations) + ")");
  }
  if (problems.empty()) CheckPlanWork(req, limits, &problems);
  problems.ThrowIfAny("invalid plan request");
  return req;
}

SolisWetsOptions ToSolisWetsOptions(const PlanRequest& req) {
  SolisWetsOptions o = SolisWetsOptions::Paper();
  o.k_max = req.options.k_max;
  o.restarts = req.options.restarts;
  o.max_evaluations = req.options.max_evaluations;
  o.step_fraction = req.options.step_fraction;
  o.objective = PlanObjective(req);
  o.seed = req.seed;
  return o;
}

RandomSelectionOptions ToRandomSelectionOptions(const PlanRequest& req) {
  RandomSelectionOptions o;
  o.num_sets = req.options.num_sets;
  o.objective = PlanObjective(req);
  o.seed = req.seed;
  return o;
}

ExchangeOptions ToExchangeOptions(const PlanRequest& req) {
  ExchangeOptions o;
  o.num_candidates = req.options.num_candidates;
  o.screen = req.options.screen;
  o.max_iterations = req.options.max_iterations;
  o.max_evaluations = req.options.max_evaluations;
  o.objective = PlanObjective(req);
  o.seed = req.seed;
  return o;
}

PlanWork MaxWork(const PlanRequest& req) {
  const int m = req.num_configurations_auto ? req.max_configurations : req.num_configurations;
  PlanWork work = req.optimiser == Optimiser::kRandom     ? MaxPlanWork(m, ToRandomSelectionOptions(req))
                  : req.optimiser == Optimiser::kExchange ? MaxPlanWork(m, ToExchangeOptions(req))
                                                : MaxPlanWork(m, ToSolisWetsOptions(req));
  work.jacobians = std::min(work.jacobians, std::numeric_limits<std::int64_t>::max() - 2 * req.num_validation) +
                   2 * static_cast<std::int64_t>(req.num_validation);
  return work;
}

ObservabilityOptions ToObservabilityOptions(const PlanRequest& req) {
  ObservabilityOptions o;
  o.measurement_type = req.measurement_type;
  o.noise = ToCore(req.noise, req.tracker);
  o.scaling = req.scaling;
  o.reflectors = ToCore(req.reflectors);
  return o;
}

// ---------------------------------------------------------------------------------------------- the resource

Indices ToWire(const ObservabilityIndices& x) {
  return {.num_configurations = x.num_configurations,
          .num_parameters = x.num_parameters,
          .condition_number = x.condition_number,
          .o1 = x.o1,
          .o2 = x.o2,
          .o3 = x.o3,
          .o4 = x.o4,
          .o5 = x.o5,
          .log_det = x.log_det,
          .predicted_error_mm = x.predicted_error_mm,
          .singular_values =
              std::vector<double>(x.singular_values.data(), x.singular_values.data() + x.singular_values.size()),
          .scaling = x.scaling};
}

PredictedAccuracyWire ToWire(const PredictedAccuracy& a) {
  return {.num_validation = a.num_validation,
          .rms_position_mm = a.rms_position_mm,
          .max_position_mm = a.max_position_mm,
          .rms_orientation_deg =
              a.has_orientation ? a.rms_orientation_rad * kDegPerRad : std::numeric_limits<double>::quiet_NaN(),
          .rms_error_mm = a.rms_error_mm};
}

CandidateAccountWire ToWire(const CandidateAccount& account) {
  CandidateAccountWire w{.num_candidates = account.num_candidates, .num_usable = account.num_usable, .rejected = {}};
  for (const CandidateRejections& r : account.rejected) {
    w.rejected.push_back({.reason = r.reason, .count = r.count, .first_indices = r.first_indices});
  }
  return w;
}

CoverageWire ToWire(const RobotModel& model, const CandidateCoverage& coverage) {
  CoverageWire w;
  for (std::size_t i = 0; i < coverage.joints.size(); ++i) {
    const JointCoverage& j = coverage.joints[i];
    // The joint's wire unit: degrees for a revolute joint.
    const double scale = model.joint_type(static_cast<int>(i)) == JointType::kRevolute ? kDegPerRad : 1.0;
    w.joints.push_back({.joint = j.name,
                        .min = j.min * scale,
                        .max = j.max * scale,
                        .lower_limit = j.lower_limit * scale,
                        .upper_limit = j.upper_limit * scale,
                        .fraction = j.fraction,
                        .too_narrow = j.too_narrow});
  }
  for (int k : coverage.poorly_determined) {
    const ParameterDetermination& p = coverage.parameters[static_cast<std::size_t>(k)];
    w.poorly_determined.push_back({.parameter = p.name, .std_ratio = p.std_ratio});
  }
  w.warning = coverage.warning;
  return w;
}

PlanSummaryWire ToWire(const PlanSummary& s) {
  PlanSummaryWire w;
  w.termination = s.termination;
  w.message = s.message;
  w.method = s.method;
  w.objective = s.objective;
  w.iterations = s.iterations;
  w.evaluations = s.evaluations;
  w.seconds = s.seconds;
  w.initial = ToWire(s.initial);
  w.brief = s.BriefReport();
  return w;
}

// The shapes' to_json / from_json, instantiated here once (ROBOCAL_WIRE_DECLARE).
ROBOCAL_WIRE_DEFINE(PlanCandidatesWire);
ROBOCAL_WIRE_DEFINE(TaskBoxWire);
ROBOCAL_WIRE_DEFINE(PlanTaskWire);
ROBOCAL_WIRE_DEFINE(CandidateRejectionWire);
ROBOCAL_WIRE_DEFINE(CandidateAccountWire);
ROBOCAL_WIRE_DEFINE(JointCoverageWire);
ROBOCAL_WIRE_DEFINE(PoorlyDeterminedWire);
ROBOCAL_WIRE_DEFINE(CoverageWire);
ROBOCAL_WIRE_DEFINE(PoseCountPointWire);
ROBOCAL_WIRE_DEFINE(PoseCountWire);
ROBOCAL_WIRE_DEFINE(PlanOptionsWire);
ROBOCAL_WIRE_DEFINE(PlanRequest);
ROBOCAL_WIRE_DEFINE(Indices);
ROBOCAL_WIRE_DEFINE(PredictedAccuracyWire);
ROBOCAL_WIRE_DEFINE(PlanSummaryWire);
ROBOCAL_WIRE_DEFINE(PlanBaseline);
ROBOCAL_WIRE_DEFINE(PlanResult);

}  // namespace robocal::api
