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

void WireFields<PlanRequest>::CheckRequest(const S& req, const std::string&, Problems* problems) {
  CheckReflectorIds(req.reflectors, problems);
  if (!req.reflectors.empty() && req.measurement_type != MeasurementType::kPosition) {
    problems->Add("reflectors",
                  std::string("need position measurements; measurement_type is ") + WireName(req.measurement_type));
  }
}

PlanRequest ParsePlanRequest(const nlohmann::json& body, const Limits& limits) {
  Problems problems;
  PlanRequest req;
  ReadRequestObject(body, "", &problems, &req);
  if (req.num_configurations > limits.max_plan_configurations) {
    problems.Add("num_configurations", OverLimit(req.num_configurations, "configurations", "max_plan_configurations",
                                                 limits.max_plan_configurations));
  }
  if (req.options.max_evaluations > limits.max_plan_evaluations) {
    problems.Add("options.max_evaluations", OverLimit(req.options.max_evaluations, "evaluations",
                                                      "max_plan_evaluations", limits.max_plan_evaluations));
  }
  // Only the chosen optimiser's options count (clients may send every option with its default).
  if (req.optimiser == Optimiser::kExchange && req.options.num_candidates > limits.max_plan_candidates) {
    problems.Add("options.num_candidates", OverLimit(req.options.num_candidates, "candidates", "max_plan_candidates",
                                                     limits.max_plan_candidates));
  } else if (req.optimiser == Optimiser::kExchange && req.options.num_candidates < req.num_configurations) {
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
  o.objective = req.objective;
  o.seed = req.seed;
  return o;
}

RandomSelectionOptions ToRandomSelectionOptions(const PlanRequest& req) {
  RandomSelectionOptions o;
  o.num_sets = req.options.num_sets;
  o.objective = req.objective;
  o.seed = req.seed;
  return o;
}

ExchangeOptions ToExchangeOptions(const PlanRequest& req) {
  ExchangeOptions o;
  o.num_candidates = req.options.num_candidates;
  o.screen = req.options.screen;
  o.max_iterations = req.options.max_iterations;
  o.max_evaluations = req.options.max_evaluations;
  o.objective = req.objective;
  o.seed = req.seed;
  return o;
}

PlanWork MaxWork(const PlanRequest& req) {
  const int m = req.num_configurations;
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
  return {x.num_configurations,
          x.num_parameters,
          x.condition_number,
          x.o1,
          x.o2,
          x.o3,
          x.o4,
          x.o5,
          x.log_det,
          x.predicted_error_mm,
          std::vector<double>(x.singular_values.data(), x.singular_values.data() + x.singular_values.size()),
          x.scaling};
}

PredictedAccuracyWire ToWire(const PredictedAccuracy& a) {
  return {a.num_validation, a.rms_position_mm, a.max_position_mm,
          a.has_orientation ? a.rms_orientation_rad * kDegPerRad : std::numeric_limits<double>::quiet_NaN(),
          a.rms_error_mm};
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
ROBOCAL_WIRE_DEFINE(PlanOptionsWire);
ROBOCAL_WIRE_DEFINE(PlanRequest);
ROBOCAL_WIRE_DEFINE(Indices);
ROBOCAL_WIRE_DEFINE(PredictedAccuracyWire);
ROBOCAL_WIRE_DEFINE(PlanSummaryWire);
ROBOCAL_WIRE_DEFINE(PlanBaseline);
ROBOCAL_WIRE_DEFINE(PlanResult);

}  // namespace robocal::api
