// The service's plans: measurement configurations chosen by the requested optimiser.
#include <cmath>
#include <memory>
#include <set>
#include <sstream>

#include "robocal/core/candidates.h"
#include "robocal/core/cell.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/observability.h"
#include "robocal/core/planning.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::FieldViolation;
using api::Problems;
using api::Status;

std::vector<std::vector<double>> ToWire(const RobotModel& model, const std::vector<Eigen::VectorXd>& configurations) {
  std::vector<std::vector<double>> out;
  out.reserve(configurations.size());
  for (const auto& q : configurations) out.push_back(api::JointsToWire(model, q));
  return out;
}

}  // namespace

void PlanHeader(const RobotModel& model, const api::PlanRequest& req, const std::string& plan_id,
                api::PlanResult* result) {
  result->id = plan_id;
  result->robot = req.robot;
  result->request = req;
  result->measurement_type = req.measurement_type;
  result->objective = api::PlanObjective(req);
  result->optimiser = req.optimiser;
  for (int i = 0; i < model.num_joints(); ++i) result->joint_units.emplace_back(api::JointUnit(model, i));
}

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

namespace {

// Joint values of the wire (deg / mm) in the core's units, whatever their count: a candidate with the wrong count is
// the planner's to reject (MalformedCandidates::kReject), so it is converted as given.
Eigen::VectorXd AnyJointsToCore(const RobotModel& model, const std::vector<double>& wire) {
  Eigen::VectorXd q(static_cast<Eigen::Index>(wire.size()));
  for (std::size_t i = 0; i < wire.size(); ++i) {
    const bool revolute =
        static_cast<int>(i) < model.num_joints() && model.joint_type(static_cast<int>(i)) == JointType::kRevolute;
    q[static_cast<Eigen::Index>(i)] = revolute ? wire[i] * kRadPerDeg : wire[i];
  }
  return q;
}

// Appends `joints` unless it repeats the last pose (shots of one pose in a row), with its `line` (0: none).
void AddPose(const std::vector<double>& joints, int line, std::vector<std::vector<double>>* poses,
             std::vector<int>* lines) {
  if (!poses->empty() && poses->back() == joints) return;
  poses->push_back(joints);
  if (line > 0) lines->push_back(line);
}

// The core's plan options beside the optimiser's own: the request's progress and stop, the cell, the evaluation
// budget, the candidates and the task.
struct PlanSetup {
  std::function<bool(const Eigen::VectorXd&)> feasible;
  PlanProgressCallback progress;
  int evaluation_limit = 0;
  CandidatePool pool;
  TaskConfigurations task;

  template <typename Options>
  Options Apply(Options options) const {
    if constexpr (requires { options.max_evaluations; }) {
      if (options.max_evaluations == 0) options.max_evaluations = evaluation_limit;
    }
    options.progress = progress;
    options.feasible = feasible;
    options.candidates = pool;
    options.task = task;
    return options;
  }
};

Plan RunOptimiser(const RobotModel& model, const api::PlanRequest& req, int n, const ObservabilityOptions& obs,
                  const PlanSetup& setup) {
  switch (req.optimiser) {
    case api::Optimiser::kRandom:
      return PlanRandom(model, n, obs, setup.Apply(api::ToRandomSelectionOptions(req)));
    case api::Optimiser::kExchange:
      return PlanExchange(model, n, obs, setup.Apply(api::ToExchangeOptions(req)));
    case api::Optimiser::kSolisWets:
      break;
  }
  return PlanSolisWets(model, n, obs, setup.Apply(api::ToSolisWetsOptions(req)));
}

// "num_configurations": "auto": the predicted error on the task against N over the candidates (a drawn pool of
// options.num_candidates feasible configurations when the request gives none), and the smallest N that reaches the
// goal (the range's largest when none does).
api::PoseCountWire ChooseCount(const RobotModel& model, const api::PlanRequest& req, const ObservabilityOptions& obs,
                               PlanSetup setup, int* chosen, PoseCountPoint* chosen_set) {
  if (!setup.pool.given()) {
    Rng rng(req.seed + 3000017);
    FeasibleDraws draws;
    draws.max_draws = static_cast<std::int64_t>(kDefaultMaxDrawsPerConfiguration) * req.options.num_candidates;
    std::vector<Eigen::VectorXd> pool;
    DrawFeasibleConfigurations(model, req.options.num_candidates, setup.feasible, &rng, &draws, &pool);
    setup.pool.configurations = std::make_shared<const std::vector<Eigen::VectorXd>>(std::move(pool));
  }
  PoseCountOptions options;
  for (int n = req.min_configurations; n <= req.max_configurations; ++n) options.num_configurations.push_back(n);
  // The goal is a mean position error (as E_xyz's); the prediction an RMS.
  options.accuracy_goal_mm = *req.accuracy_goal_mm / kMeanOverRms3d;
  options.exchange = setup.Apply(api::ToExchangeOptions(req));
  options.exchange.objective = api::PlanObjective(req);
  const PoseCountCurve curve = PlanPoseCount(model, obs, options);
  if (curve.termination == Termination::kFailure) {
    throw ApiError(Status::kFailedPrecondition, "no pose count curve: " + curve.message,
                   {{"min_configurations", curve.message}});
  }
  api::PoseCountWire w;
  w.accuracy_goal_mm = *req.accuracy_goal_mm;
  w.model_error_mm = obs.model_error_mm;
  for (const PoseCountPoint& p : curve.points) {
    w.points.push_back({.num_configurations = p.num_configurations,
                        .predicted_error_mm = p.predicted_error_mm,
                        .predicted_mean_mm = kMeanOverRms3d * p.predicted_error_mm});
  }
  // Said in the goal's terms (a mean position error), as the points give it.
  const PoseCountPoint& point =
      curve.chosen >= 0 ? curve.points[static_cast<std::size_t>(curve.chosen)] : curve.points.back();
  std::ostringstream message;
  message.precision(4);
  if (curve.chosen >= 0) {
    w.chosen = point.num_configurations;
    message << "N = " << point.num_configurations << " is the fewest poses predicted to reach the goal of "
            << *req.accuracy_goal_mm << " mm (mean position error " << kMeanOverRms3d * point.predicted_error_mm
            << " mm)";
  } else {
    message << "no N up to " << point.num_configurations << " is predicted to reach the goal of "
            << *req.accuracy_goal_mm << " mm (at " << point.num_configurations << ": "
            << kMeanOverRms3d * point.predicted_error_mm << " mm, the robot's model error alone "
            << kMeanOverRms3d * obs.model_error_mm << " mm); the plan has " << point.num_configurations << " poses";
  }
  if (curve.termination == Termination::kDegraded) message << "; " << curve.message;
  w.message = message.str();
  *chosen = point.num_configurations;
  *chosen_set = point;
  return w;
}

}  // namespace

Service::PlanInputs Service::ResolvePlanInputs(const api::PlanRequest& req, const ResolvedRobot& robot) {
  const RobotModel& model = robot.model;
  PlanInputs inputs;
  Problems problems;
  const bool refuse = !req.candidates || req.candidates->malformed == MalformedCandidates::kThrow;
  if (req.candidates) {
    const api::PlanCandidatesWire& c = *req.candidates;
    std::vector<std::vector<double>> poses;
    std::string path = "candidates.joints";
    if (!c.joints.empty()) {
      poses = c.joints;
    } else if (!c.campaign.empty()) {
      path = "candidates.campaign";
      const api::StoredCampaign campaign = LoadCampaign(c.campaign);
      if (campaign.robot != req.robot) {
        throw ApiError(Status::kFailedPrecondition,
                       "campaign \"" + c.campaign + "\" measured robot " + campaign.robot + ", not " + req.robot,
                       {{"candidates.campaign", "a campaign of another robot"}});
      }
      for (const char* role : {"calibration", "validation"}) {
        ForEachMeasurement(storage_, c.campaign, role, [&](const StoredMeasurement& m) {
          AddPose(ReadMeasurement(m).joints, 0, &poses, &inputs.candidate_lines);
        });
      }
      if (poses.empty()) {
        throw ApiError(Status::kFailedPrecondition, "campaign \"" + c.campaign + "\" has no measurements",
                       {{"candidates.campaign", "no measurements"}});
      }
    } else if (c.file) {
      path = "candidates.file";
      Problems read;
      const std::vector<api::TrackerPoint> points = api::ReadTrackerPoints(*c.file, &read);
      for (const FieldViolation& v : read.list()) problems.Add(api::JoinPath("candidates.file", v.field), v.reason);
      problems.ThrowIfAny("invalid plan request");
      const std::set<int> rows(c.file->rows.begin(), c.file->rows.end());
      // Every row named must be a data row, as the import says of its own rows.
      std::set<int> data_lines;
      for (const api::TrackerPoint& p : points) data_lines.insert(p.line);
      for (std::size_t k = 0; k < c.file->rows.size(); ++k) {
        if (data_lines.count(c.file->rows[k]) == 0) {
          problems.Add(api::IndexPath("candidates.file.rows", k),
                       "line " + std::to_string(c.file->rows[k]) + " is not a data row of the text");
        }
      }
      problems.ThrowIfAny("invalid plan request");
      for (const api::TrackerPoint& p : points) {
        if (!rows.empty() && rows.count(p.line) == 0) continue;
        AddPose(p.joints_deg, p.line, &poses, &inputs.candidate_lines);
      }
    }
    std::vector<Eigen::VectorXd> configurations;
    configurations.reserve(poses.size());
    for (std::size_t i = 0; i < poses.size(); ++i) {
      // A malformed candidate refused names its place (the planner, under kReject, counts it).
      if (refuse && !api::CheckJoints(model, poses[i], api::IndexPath(path, i), &problems)) continue;
      configurations.push_back(AnyJointsToCore(model, poses[i]));
    }
    inputs.candidates = std::make_shared<const std::vector<Eigen::VectorXd>>(std::move(configurations));
  }
  if (req.task && !req.task->joints.empty()) {
    std::vector<Eigen::VectorXd> task;
    for (std::size_t i = 0; i < req.task->joints.size(); ++i) {
      if (api::CheckJoints(model, req.task->joints[i], api::IndexPath("task.joints", i), &problems)) {
        task.push_back(api::JointsToCore(model, req.task->joints[i]));
      }
    }
    inputs.task = std::make_shared<const std::vector<Eigen::VectorXd>>(std::move(task));
  }
  problems.ThrowIfAny("invalid plan request");
  // A robot registered from a calibration carries its model error: the part of the robot's error no plan
  // removes, where the predicted error flattens.
  if (robot.definition.calibrated_from) {
    try {
      const api::CalibrationResult calibration = GetCalibration(robot.definition.calibrated_from->campaign);
      if (calibration.model_error.estimated) {
        inputs.model_error_mm = calibration.model_error.model_error_mm;
        inputs.model_error_deg = calibration.model_error.model_error_deg;
      }
    } catch (const ApiError&) {
      // The campaign or its calibration is gone: the plan predicts without a model error.
    }
  }
  return inputs;
}

namespace {

// The census (CheckCellLeavesRoom) found at least 1 in 100 feasible: 500 draws per configuration leave a wide margin.
constexpr int kPlanDrawsPerConfiguration = 500;

// The error parameters a plan of `model` can identify; FAILED_PRECONDITION when there are none.
IdentifiabilitySummary IdentifyPlanParameters(const RobotModel& model, const api::PlanRequest& req) {
  IdentifiabilityOptions id_options;
  id_options.noise = api::ToCore(req.noise, req.tracker);
  id_options.reflectors = api::ToCore(req.reflectors);
  id_options.seed = req.seed;
  IdentifiabilitySummary ident = FindIdentifiableParameters(model, req.measurement_type, id_options);
  if (ident.termination == Termination::kFailure || ident.identifiable.empty()) {
    throw ApiError(Status::kFailedPrecondition, "no identifiable parameters: " + ident.message);
  }
  return ident;
}

// The configurations of the request's task box (its orientations, its count); FAILED_PRECONDITION when the robot
// reaches none.
TaskSample SampleTaskBox(const RobotModel& model, const api::PlanRequest& req) {
  const api::TaskBoxWire& box = *req.task->box;
  TaskBox core_box;
  core_box.min_mm = Eigen::Vector3d(box.min_mm[0], box.min_mm[1], box.min_mm[2]);
  core_box.max_mm = Eigen::Vector3d(box.max_mm[0], box.max_mm[1], box.max_mm[2]);
  for (const auto& rpy : box.orientations_rpy_deg) {
    api::PoseWire pose;
    Problems ignored;
    api::ParsePose({{"position_mm", {0, 0, 0}}, {"rpy_deg", {rpy[0], rpy[1], rpy[2]}}}, "", true, &ignored, &pose);
    core_box.orientations.push_back(api::PoseToTransform(pose).linear());
  }
  TaskSample sample = SampleTaskConfigurations(model, core_box, box.count, req.seed + 4000037);
  if (sample.configurations.empty()) {
    throw ApiError(Status::kFailedPrecondition, "task box out of reach: " + sample.message,
                   {{"task.box", "no configuration of the robot reaches it: " + sample.message}});
  }
  return sample;
}

// The given candidates the planner can use, as its check finds them (within the limits, feasible).
std::vector<Eigen::VectorXd> UsablePlanCandidates(const RobotModel& model, const PlanSetup& setup) {
  std::vector<Eigen::VectorXd> usable;
  for (const Eigen::VectorXd& q : *setup.pool.configurations) {
    if (q.size() == model.num_joints() && q.allFinite() && model.WithinLimits(q) &&
        (!setup.feasible || setup.feasible(q))) {
      usable.push_back(q);
    }
  }
  return usable;
}

// The requested optimiser's plan of n configurations; FAILED_PRECONDITION when it finds none from the candidates
// or within the cell (`cell_id`, null without one).
Plan OptimisePlan(const RobotModel& model, const api::PlanRequest& req, int n, const ObservabilityOptions& obs,
                  const PlanSetup& setup, const std::string* cell_id) {
  Plan plan;
  try {
    plan = RunOptimiser(model, req, n, obs, setup);
  } catch (const std::invalid_argument& e) {
    // What the request could not have caught before the planner saw the candidates or the task.
    throw ApiError(Status::kInvalidArgument, std::string("invalid plan request: ") + e.what(),
                   {{req.candidates ? "candidates" : "task", e.what()}});
  }
  if (plan.summary.termination == Termination::kFailure) {
    if (setup.pool.given()) {
      throw ApiError(Status::kFailedPrecondition, "no plan from the candidates: " + plan.summary.message,
                     {{"num_configurations", plan.summary.message}});
    }
    if (cell_id) {
      throw ApiError(Status::kFailedPrecondition, "no plan within cell \"" + *cell_id + "\": " + plan.summary.message,
                     {{"cell", plan.summary.message}});
    }
  }
  return plan;
}

// The paper's baseline: one random set of the same size (seeded from the plan's seed), in the same cell, from
// the same candidates.
Plan RandomBaselinePlan(const RobotModel& model, const api::PlanRequest& req, int n, const ObservabilityOptions& obs,
                        const PlanSetup& setup) {
  RandomSelectionOptions baseline_options;
  baseline_options.seed = req.seed + 1000003;
  baseline_options.objective = api::PlanObjective(req);
  baseline_options.feasible = setup.feasible;
  baseline_options.candidates = setup.pool;
  baseline_options.task = setup.task;
  baseline_options.max_draws_per_configuration = kPlanDrawsPerConfiguration;
  return PlanRandom(model, n, obs, baseline_options);
}

// The predicted accuracy's validation configurations: the task, or random (in a cell feasible in it). `drawn`:
// false when a cell left too few feasible draws.
std::vector<Eigen::VectorXd> PlanValidationSample(const RobotModel& model, const api::PlanRequest& req,
                                                  const PlanSetup& setup, bool* drawn) {
  Rng rng(req.seed + 2000003);
  std::vector<Eigen::VectorXd> validation;
  *drawn = true;
  if (setup.task) {
    validation = *setup.task;
  } else if (setup.feasible) {
    FeasibleDraws draws;
    draws.max_draws = static_cast<std::int64_t>(kPlanDrawsPerConfiguration) * std::max(1, req.num_validation);
    *drawn = DrawFeasibleConfigurations(model, req.num_validation, setup.feasible, &rng, &draws, &validation);
  } else {
    validation = RandomConfigurations(model, req.num_validation, &rng);
  }
  return validation;
}

// A set's predicted accuracy as a plan reports it: on the planning model with its observability options, over
// the validation configurations.
struct PlanPredictor {
  const RobotModel& model;
  const ObservabilityOptions& obs;
  const std::vector<Eigen::VectorXd>& validation;
  PredictedAccuracy operator()(const std::vector<Eigen::VectorXd>& configurations) const {
    return PredictAccuracy(model, obs, configurations, validation);
  }
};

// "auto": the plan reaches the goal by the prediction the count was chosen by. The optimiser's own set of N is kept
// when it does (on real data a better prediction need not be a better set); when it does not (random selection's
// may miss it), the set the pose count judged at N is the plan. Without a goal reached, the better of the two.
void PreferPoseCountSet(const PlanPredictor& predict, const api::PoseCountWire& pose_count,
                        const PoseCountPoint& counted, bool from_candidates, Plan* plan) {
  const double planned = predict(plan->configurations).rms_error_mm;
  const double judged = predict(counted.configurations).rms_error_mm;
  const double goal_rms = pose_count.accuracy_goal_mm / kMeanOverRms3d;
  const bool misses = pose_count.chosen ? !(planned <= goal_rms) : !(planned <= judged);
  if (misses && judged < planned) {
    plan->configurations = counted.configurations;
    plan->candidate_indices = from_candidates ? counted.candidate_indices : std::vector<int>{};
    plan->summary.final = ComputeIndicesBySvd(predict.model, plan->configurations, predict.obs);
    plan->summary.message += "; the pose count's set of " + std::to_string(counted.num_configurations) +
                             " poses predicts less error on the task than the optimiser's, and is the plan";
  }
}

// The plan's and the baseline's sets with their indices and predicted accuracy, and the parameters they serve.
void WritePlanSets(const PlanPredictor& predict, const IdentifiabilitySummary& ident, const Plan& plan,
                   const Plan& baseline, api::PlanResult* result) {
  const RobotModel& model = predict.model;
  result->configurations = ToWire(model, plan.configurations);
  result->indices = api::ToWire(plan.summary.final);
  result->baseline.configurations = ToWire(model, baseline.configurations);
  result->baseline.indices = api::ToWire(baseline.summary.final);
  result->baseline.predicted_accuracy = api::ToWire(predict(baseline.configurations));
  result->identifiable_parameters = ident.identifiable_names;
  result->dropped_parameters = api::ToWire(ident.dropped);
  result->predicted_accuracy = api::ToWire(predict(plan.configurations));
  result->summary = api::ToWire(plan.summary);
}

// A plan from candidates: the ones it took (with their file lines), the planner's census of them, and the coverage
// of the usable ones.
void WritePlanCandidates(const PlanPredictor& predict, const Plan& plan, const std::vector<int>& candidate_lines,
                         const std::vector<Eigen::VectorXd>& usable, api::PlanResult* result) {
  result->candidate_indices = plan.candidate_indices;
  for (int k : plan.candidate_indices) {
    if (static_cast<std::size_t>(k) < candidate_lines.size()) {
      result->candidate_lines.push_back(candidate_lines[static_cast<std::size_t>(k)]);
    }
  }
  result->candidates = api::ToWire(plan.summary.candidates);
  if (usable.empty()) return;
  result->coverage = api::ToWire(predict.model, AnalyseCoverage(predict.model, predict.obs, usable));
}

// The observability options of a plan: the request's, over the identifiable parameters, with the robot's model
// error, and in a cell (null: none) its tracker's position.
ObservabilityOptions PlanObservability(const RobotModel& model, const api::PlanRequest& req,
                                       const IdentifiabilitySummary& ident, double model_error_mm,
                                       double model_error_deg, const Cell* cell) {
  ObservabilityOptions obs = api::ToObservabilityOptions(req);
  obs.parameters = ident.identifiable;
  obs.model_error_mm = model_error_mm;
  // The model error is also each pose's error the fit will see beside the tracker's (the fit weights its rows by
  // both: FittedNoise), and it spreads into the parameters as that noise does: the rows are weighted as the fit
  // will weight them, per position axis and orientation row (RMS over sqrt(3)).
  obs.noise.model_error_mm = model_error_mm / std::sqrt(3.0);
  obs.noise.model_error_rad = model_error_deg * kRadPerDeg / std::sqrt(3.0);
  // The cell's tracker (base frame) in the planning model's world frame: the rows of each configuration are
  // whitened by the tracker model at its distance and direction from there.
  if (cell) obs.tracker_position_mm = model.T_world_base() * cell->spec().tracker.position_mm;
  return obs;
}

}  // namespace

api::PlanResult Service::RunPlan(const RobotModel& nominal, const api::PlanRequest& req, const PlanInputs& inputs,
                                 const std::string& plan_id, WorkControl& control, const LoadedCell* cell) {
  if (req.test) return RunTestPlan(nominal, req, plan_id, cell);
  // In a cell: the joint limits narrowed to its ranges, and every configuration feasible in it. Candidates are
  // checked against the robot's own limits, so that the cell's ranges reject them by its rule (joint_range).
  const RobotModel model = cell && !inputs.candidates ? cell->cell.PlanningModel(nominal) : nominal;
  PlanSetup setup;
  if (cell) setup.feasible = [cell](const Eigen::VectorXd& q) { return IsFeasible(cell->model, cell->cell, q); };
  const IdentifiabilitySummary ident = IdentifyPlanParameters(model, req);
  const ObservabilityOptions obs =
      PlanObservability(model, req, ident, inputs.model_error_mm, inputs.model_error_deg, cell ? &cell->cell : nullptr);
  // ParsePlanRequest refused plans whose work exceeds max_plan_evaluations; the limit is also the optimiser's
  // budget, so that no plan can count past it.
  setup.evaluation_limit = static_cast<int>(std::min<std::int64_t>(options_.limits.max_plan_evaluations, INT32_MAX));
  setup.progress = control.Callback();
  // Candidates: the robot's own limits check them (the cell's ranges then count as the cell's rejections, by
  // rule, rather than as malformed candidates).
  if (inputs.candidates) {
    setup.pool.configurations = inputs.candidates;
    setup.pool.malformed = req.candidates->malformed;
    if (cell) {
      setup.pool.infeasibility_reasons = CellRuleReasons(cell->model, cell->cell);
      setup.feasible = [cell](const Eigen::VectorXd& q) { return IsFeasible(cell->model, cell->cell, q); };
    }
  }
  api::PlanResult result;
  setup.task = inputs.task;
  if (req.task && req.task->box) {
    const TaskSample sample = SampleTaskBox(model, req);
    result.task_method = sample.method;
    setup.task = std::make_shared<const std::vector<Eigen::VectorXd>>(sample.configurations);
  }

  // The candidates the planner can use (as its check finds them): their coverage, and without a task what a plan
  // from them predicts over, since the poses the cell reaches are where it works (a prediction over the whole
  // joint space would extrapolate far beyond them).
  std::vector<Eigen::VectorXd> usable;
  if (setup.pool.given()) {
    usable = UsablePlanCandidates(model, setup);
    if (!setup.task && !usable.empty()) setup.task = std::make_shared<const std::vector<Eigen::VectorXd>>(usable);
  }
  int n = req.num_configurations;
  PoseCountPoint counted;
  if (req.num_configurations_auto) result.pose_count = ChooseCount(model, req, obs, setup, &n, &counted);
  Plan plan = OptimisePlan(model, req, n, obs, setup, cell ? &cell->wire.id : nullptr);
  const Plan baseline = RandomBaselinePlan(model, req, n, obs, setup);
  bool validation_drawn = true;
  const std::vector<Eigen::VectorXd> validation = PlanValidationSample(model, req, setup, &validation_drawn);
  // A plan is never returned without its baseline or its validation sample.
  if (cell && (baseline.summary.termination == Termination::kFailure || !validation_drawn)) {
    const std::string what = !validation_drawn ? "the validation sample" : "the random baseline";
    throw ApiError(Status::kFailedPrecondition,
                   "cell \"" + cell->wire.id + "\" leaves too little feasible for " + what + ": " +
                       (validation_drawn ? baseline.summary.message : std::string("too few feasible draws")),
                   {{"cell", "too little feasible for " + what}});
  }

  const PlanPredictor predict{model, obs, validation};
  if (req.num_configurations_auto && !counted.configurations.empty() &&
      plan.summary.termination != Termination::kFailure) {
    PreferPoseCountSet(predict, *result.pose_count, counted, setup.pool.given(), &plan);
  }

  PlanHeader(model, req, plan_id, &result);
  WritePlanSets(predict, ident, plan, baseline, &result);
  if (control.stop() != Stop::kNone) result.summary.message += "; stopped early with the best set so far";
  result.created_unix_ms = NowUnixMs();
  if (cell) {
    result.cell = cell->wire.id;
    for (const Eigen::VectorXd& q : plan.configurations) {
      result.configuration_checks.push_back(api::ToWire(CheckConfiguration(cell->model, cell->cell, q)));
    }
  }
  if (setup.pool.given()) WritePlanCandidates(predict, plan, inputs.candidate_lines, usable, &result);
  return result;
}

PlanReply Service::CreatePlan(const nlohmann::json& body) {
  const api::PlanRequest req = api::ParsePlanRequest(body, options_.limits);
  const ResolvedRobot robot = ResolveRobot(req.robot);  // NOT_FOUND before any work or operation is created
  if (req.purpose == api::PlanPurpose::kCheck && !robot.definition.calibrated_from) {
    throw ApiError(
        Status::kFailedPrecondition,
        "robot \"" + req.robot + "\" carries no calibration to check: register it from a calibrated campaign",
        {{"purpose", "a check plan is for a robot registered from a calibration"}});
  }
  const RobotModel& model = robot.model;
  const PlanInputs inputs = ResolvePlanInputs(req, robot);
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
    api::PlanResult plan = RunPlan(planned, req, inputs, plan_id, control, cell.get());
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
  return operations_.Start(op, [this, planned, req, inputs, plan_id, cell](WorkControl& control, api::Operation* done) {
    const api::PlanResult plan = RunPlan(planned, req, inputs, plan_id, control, cell.get());
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
