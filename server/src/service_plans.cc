// The service's plans: measurement configurations chosen by the requested optimiser.
#include <cmath>
#include <memory>

#include "robocal/core/cell.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/observability.h"
#include "robocal/core/planning.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;

std::vector<std::vector<double>> ToWire(const RobotModel& model, const std::vector<Eigen::VectorXd>& configurations) {
  std::vector<std::vector<double>> out;
  out.reserve(configurations.size());
  for (const auto& q : configurations) out.push_back(api::JointsToWire(model, q));
  return out;
}

}  // namespace

// Refuses a cell that leaves (almost) nothing feasible before any search starts, naming the rule that rejects
// most of a sample of configurations and its share.
void Service::CheckCellLeavesRoom(const LoadedCell& cell, std::uint64_t seed) {
  constexpr int kSamples = 2000;
  // The planners draw at most 100 configurations per configuration they need (max_draws_per_configuration):
  // a cell must leave at least 1 in 100 feasible.
  constexpr double kMinFeasibleShare = 0.01;
  const FeasibilityCensus census = SampleFeasibility(cell.model, cell.cell, kSamples, seed);
  if (census.feasible >= kMinFeasibleShare * census.samples && census.feasible > 0) return;
  const std::string reason = std::to_string(census.feasible) + " of " + std::to_string(census.samples) +
                             " sampled configurations are feasible; " + ToString(census.dominant) + " rejects " +
                             std::to_string(static_cast<int>(std::lround(100.0 * census.dominant_share))) + " %";
  throw ApiError(Status::kFailedPrecondition, "cell \"" + cell.wire.id + "\" leaves almost nothing feasible: " + reason,
                 {{"cell", reason}});
}

api::PlanResult Service::RunPlan(const RobotModel& nominal, const api::PlanRequest& req, const std::string& plan_id,
                                 WorkControl& control, const LoadedCell* cell) {
  // In a cell: the joint limits narrowed to its ranges, and every configuration feasible in it.
  const RobotModel model = cell ? cell->cell.PlanningModel(nominal) : nominal;
  std::function<bool(const Eigen::VectorXd&)> feasible;
  if (cell) feasible = [cell](const Eigen::VectorXd& q) { return IsFeasible(cell->model, cell->cell, q); };
  IdentifiabilityOptions id_options;
  id_options.noise = api::ToCore(req.noise, req.tracker);
  id_options.reflectors = api::ToCore(req.reflectors);
  id_options.seed = req.seed;
  const IdentifiabilitySummary ident = FindIdentifiableParameters(model, req.measurement_type, id_options);
  if (ident.termination == Termination::kFailure || ident.identifiable.empty()) {
    throw ApiError(Status::kFailedPrecondition, "no identifiable parameters: " + ident.message);
  }
  ObservabilityOptions obs = api::ToObservabilityOptions(req);
  obs.parameters = ident.identifiable;
  // The cell's tracker (base frame) in the planning model's world frame: the rows of each configuration are
  // whitened by the tracker model at its distance and direction from there.
  if (cell) obs.tracker_position_mm = model.T_world_base() * cell->cell.spec().tracker.position_mm;
  // ParsePlanRequest refused plans whose work exceeds max_plan_evaluations; the limit is also the optimiser's
  // budget, so that no plan can count past it.
  const int evaluation_limit =
      static_cast<int>(std::min<std::int64_t>(options_.limits.max_plan_evaluations, INT32_MAX));
  // What every optimiser shares: the request's progress and stop, the cell, and the evaluation budget.
  const auto common = [&](auto options) {
    if constexpr (requires { options.max_evaluations; }) {
      if (options.max_evaluations == 0) options.max_evaluations = evaluation_limit;
    }
    options.progress = control.Callback();
    options.feasible = feasible;
    return options;
  };
  Plan plan;
  switch (req.optimiser) {
    case api::Optimiser::kRandom:
      plan = PlanRandom(model, req.num_configurations, obs, common(api::ToRandomSelectionOptions(req)));
      break;
    case api::Optimiser::kExchange:
      plan = PlanExchange(model, req.num_configurations, obs, common(api::ToExchangeOptions(req)));
      break;
    case api::Optimiser::kSolisWets:
      plan = PlanSolisWets(model, req.num_configurations, obs, common(api::ToSolisWetsOptions(req)));
      break;
  }

  if (cell && plan.summary.termination == Termination::kFailure) {
    throw ApiError(Status::kFailedPrecondition, "no plan within cell \"" + cell->wire.id + "\": " + plan.summary.message,
                   {{"cell", plan.summary.message}});
  }

  // The paper's baseline: one random set of the same size (seeded from the plan's seed), in the same cell.
  RandomSelectionOptions baseline_options;
  baseline_options.seed = req.seed + 1000003;
  baseline_options.objective = req.objective;
  baseline_options.feasible = feasible;
  // The census found at least 1 in 100 feasible: 500 draws per configuration leave a wide margin.
  constexpr int kDrawsPerConfiguration = 500;
  baseline_options.max_draws_per_configuration = kDrawsPerConfiguration;
  const Plan baseline = PlanRandom(model, req.num_configurations, obs, baseline_options);
  // The predicted accuracy's validation configurations: random, and in a cell feasible in it.
  Rng rng(req.seed + 2000003);
  std::vector<Eigen::VectorXd> validation;
  bool validation_drawn = true;
  if (feasible) {
    FeasibleDraws draws;
    draws.max_draws = static_cast<std::int64_t>(kDrawsPerConfiguration) * std::max(1, req.num_validation);
    validation_drawn = DrawFeasibleConfigurations(model, req.num_validation, feasible, &rng, &draws, &validation);
  } else {
    validation = RandomConfigurations(model, req.num_validation, &rng);
  }
  // A plan is never returned without its baseline or its validation sample.
  if (cell && (baseline.summary.termination == Termination::kFailure || !validation_drawn)) {
    const std::string what = !validation_drawn ? "the validation sample" : "the random baseline";
    throw ApiError(Status::kFailedPrecondition,
                   "cell \"" + cell->wire.id + "\" leaves too little feasible for " + what + ": " +
                       (validation_drawn ? baseline.summary.message : std::string("too few feasible draws")),
                   {{"cell", "too little feasible for " + what}});
  }

  api::PlanResult result;
  result.id = plan_id;
  result.robot = req.robot;
  result.request = req;
  result.measurement_type = req.measurement_type;
  result.objective = req.objective;
  result.optimiser = req.optimiser;
  for (int i = 0; i < model.num_joints(); ++i) result.joint_units.emplace_back(api::JointUnit(model, i));
  result.configurations = ToWire(model, plan.configurations);
  result.indices = api::ToWire(plan.summary.final);
  result.baseline.configurations = ToWire(model, baseline.configurations);
  result.baseline.indices = api::ToWire(baseline.summary.final);
  result.baseline.predicted_accuracy =
      api::ToWire(PredictAccuracy(model, obs, baseline.configurations, validation));
  result.identifiable_parameters = ident.identifiable_names;
  result.dropped_parameters = api::ToWire(ident.dropped);
  result.predicted_accuracy = api::ToWire(PredictAccuracy(model, obs, plan.configurations, validation));
  result.summary = api::ToWire(plan.summary);
  if (control.stop() != Stop::kNone) result.summary.message += "; stopped early with the best set so far";
  result.created_unix_ms = NowUnixMs();
  if (cell) {
    result.cell = cell->wire.id;
    for (const Eigen::VectorXd& q : plan.configurations) {
      result.configuration_checks.push_back(api::ToWire(CheckConfiguration(cell->model, cell->cell, q)));
    }
  }
  return result;
}

PlanReply Service::CreatePlan(const nlohmann::json& body) {
  const api::PlanRequest req = api::ParsePlanRequest(body, options_.limits);
  const RobotModel model = ResolveRobot(req.robot).model;  // NOT_FOUND before any work or operation is created
  std::shared_ptr<const LoadedCell> cell;
  if (!req.cell.empty()) {
    cell = std::make_shared<const LoadedCell>(LoadCell(req.cell));
    if (cell->wire.robot != req.robot) {
      throw ApiError(Status::kFailedPrecondition,
                     "cell \"" + req.cell + "\" is a cell of robot " + cell->wire.robot + ", not of " + req.robot,
                     {{"cell", "a cell of another robot"}});
    }
    // The cell was validated against its copy of the robot; a robot re-registered since is another robot.
    if (nlohmann::json(cell->robot_definition) != nlohmann::json(ResolveRobot(req.robot).definition)) {
      throw ApiError(Status::kFailedPrecondition,
                     "cell \"" + req.cell + "\" was made for an earlier definition of robot " + req.robot +
                         "; create the cell again for the robot as it is registered now",
                     {{"cell", "made for another definition of the robot"}});
    }
    CheckCellLeavesRoom(*cell, req.seed);
  }
  // With a cell, the plan is made on the robot as the cell knows it (its copy of the robot's definition).
  const RobotModel& planned = cell ? cell->model : model;
  const std::string plan_id = NewId("plan");
  if (!req.async) {
    const TrimWhenDone trim(&trimmer_, true);
    WorkControl control(std::chrono::steady_clock::now() + options_.request_deadline);
    api::PlanResult plan = RunPlan(planned, req, plan_id, control, cell.get());
    if (control.stop() == Stop::kDeadline) {
      DescribeDeadlineStop(options_.request_deadline, "the best set so far", "use async: true for longer searches",
                           &plan.summary);
    }
    storage_->Create(kPlans, plan_id, nlohmann::json(api::StoredPlan{plan}).dump());
    return plan;
  }
  api::Operation op;
  op.id = NewId("op");
  op.kind = api::OperationKind::kPlan;
  op.plan_request = req;
  return operations_.Start(op, [this, planned, req, plan_id, cell](WorkControl& control, api::Operation* done) {
    const api::PlanResult plan = RunPlan(planned, req, plan_id, control, cell.get());
    if (!control.StillOwned()) return;  // taken over and marked FAILED: nothing of it is stored
    storage_->Create(kPlans, plan_id, nlohmann::json(api::StoredPlan{plan}).dump());
    done->plan = plan_id;
  });
}

api::PlanResult Service::GetPlan(const std::string& id) {
  CheckId(id, "plan");
  const auto doc = storage_->Get(kPlans, id);
  if (!doc) throw ApiError(Status::kNotFound, "plan \"" + id + "\" not found");
  return ReadStored<api::StoredPlan>(*doc).plan;
}

}  // namespace robocal::server
