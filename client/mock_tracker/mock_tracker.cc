// The mock tracker's workflow: plan, campaign, measure, upload, fit, validate with nominal and compensated
// joints, and the paper's tables.
#include "mock_tracker.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "robocal/api/calibration.h"
#include "robocal/api/robots.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"

namespace robocal::mock {
namespace {

using nlohmann::json;

// Offsets that separate the seeds of the cell, the validation poses and the plans, so that changing one
// (e.g. the number of validation poses) never changes another.
constexpr std::uint64_t kValidationSeedOffset = 7919;
constexpr std::uint64_t kRandomPlanSeedOffset = 104729;

void Log(std::ostream* log, const std::string& line) {
  if (log) *log << line << std::endl;
}

std::vector<std::vector<double>> ToWire(const RobotModel& model, const std::vector<Eigen::VectorXd>& qs) {
  std::vector<std::vector<double>> wire;
  for (const auto& q : qs) wire.push_back(api::JointsToWire(model, q));
  return wire;
}

CampaignOutcome RunCampaign(client::Client& client, VirtualCell* cell, const std::string* cell_id,
                            const MockTrackerOptions& options, api::Optimiser optimiser, std::uint64_t plan_seed,
                            const std::vector<Eigen::VectorXd>& validation, std::ostream* log) {
  const RobotModel& nominal = cell->nominal();
  CampaignOutcome out;

  api::PlanRequest plan_request;
  plan_request.robot = options.robot;
  plan_request.num_configurations = options.count;
  plan_request.measurement_type = options.measurement_type;
  plan_request.objective = options.objective;
  plan_request.optimiser = optimiser;
  plan_request.seed = plan_seed;
  if (cell_id != nullptr) plan_request.cell = *cell_id;
  plan_request.noise.position_mm = cell->options().noise.position_mm;
  plan_request.noise.orientation_deg = cell->options().noise.orientation_rad * kDegPerRad;
  if (const auto& t = cell->options().noise.tracker) {
    plan_request.tracker = api::TrackerModelWire{{t->radial_um, t->radial_um_per_m},
                                                 {t->transverse_um, t->transverse_um_per_m},
                                                 t->orientation_deg,
                                                 t->mpe_sigmas};
  }
  out.plan = client.CreatePlan(plan_request);
  Log(log, "plan " + out.plan.id + " (" + api::WireName(optimiser) + "): " + out.plan.summary.brief);

  api::CreateCampaignRequest campaign_request;
  campaign_request.robot = options.robot;
  campaign_request.measurement_type = options.measurement_type;
  campaign_request.plan = out.plan.id;
  campaign_request.noise = plan_request.noise;
  campaign_request.tracker = plan_request.tracker;
  campaign_request.repeatability_mm = cell->options().noise.repeatability_mm;
  campaign_request.reflectors = api::ToWire(cell->options().reflectors);
  campaign_request.description = "mock tracker, seed " + std::to_string(options.seed) + ", " + api::WireName(optimiser);
  out.campaign = client.CreateCampaign(campaign_request);
  Log(log, "campaign " + out.campaign.id);

  // "Move" the robot to each planned configuration and shoot it with the tracker (when it can see it).
  const int unmeasured_before = cell->unmeasured();
  const int shots_before = cell->shots();
  const std::size_t outliers_before = cell->outlier_shots().size();
  const api::MeasurementBatchRequest batch =
      MeasurementBatch(cell, out.plan.configurations, api::MeasurementRole::kCalibration, options);
  out.unmeasured_poses = cell->unmeasured() - unmeasured_before;
  if (out.unmeasured_poses > 0) {
    Log(log, std::to_string(out.unmeasured_poses) + " of " + std::to_string(out.plan.configurations.size()) +
                 " planned poses could not be measured");
  }
  const api::BatchResult uploaded = client.UploadMeasurements(out.campaign.id, batch);
  Log(log, "uploaded " + std::to_string(uploaded.count) + " calibration shots");
  for (std::size_t k = outliers_before; k < cell->outlier_shots().size(); ++k) {
    out.injected_outliers.push_back(uploaded.first_sequence + (cell->outlier_shots()[k] - shots_before));
  }

  out.calibration = client.Fit(out.campaign.id);
  Log(log, "fit: " + out.calibration.summary.brief);
  for (const api::OutlierWire& o : out.calibration.outliers) {
    out.outliers_found +=
        static_cast<int>(std::count(out.injected_outliers.begin(), out.injected_outliers.end(), o.sequence));
  }
  if (!out.injected_outliers.empty() || !out.calibration.outliers.empty()) {
    Log(log, "outliers: the cell injected " + std::to_string(out.injected_outliers.size()) + ", the fit excluded " +
                 std::to_string(out.calibration.outliers.size()) + " (" + std::to_string(out.outliers_found) +
                 " of them injected)");
  }

  // Validation: the nominal command lands where the true robot goes; the target is where the nominal model
  // says it should be, in the calibrated base frame (the frame compensation aims at).
  const std::vector<std::vector<double>> validation_wire = ToWire(nominal, validation);
  const std::vector<api::Compensation> compensated = client.CompensateJoints(out.campaign.id, validation_wire).results;
  const Transform T_world_base = api::PoseToTransform(out.calibration.base);
  std::vector<Transform> targets, reached_nominal, reached_compensated;
  for (std::size_t i = 0; i < validation.size(); ++i) {
    const Transform T_base_tool = nominal.T_world_base().inverse() * ForwardKinematics(nominal, validation[i]);
    targets.push_back(T_world_base * T_base_tool);
    reached_nominal.push_back(cell->Land(validation[i]));
    reached_compensated.push_back(cell->Land(api::JointsToCore(nominal, compensated[i].joints)));
  }
  out.before = ComputeAccuracy(reached_nominal, targets, options.h_mm);
  out.after = ComputeAccuracy(reached_compensated, targets, options.h_mm);
  out.targets = std::move(targets);
  out.reached_nominal = std::move(reached_nominal);
  out.reached_compensated = std::move(reached_compensated);

  // The service's own view: validation shots at the nominal commands, evaluated on the server.
  client.UploadMeasurements(out.campaign.id,
                            MeasurementBatch(cell, validation_wire, api::MeasurementRole::kValidation, options));
  api::EvaluateRequest evaluate;
  evaluate.h_mm = options.h_mm;
  out.evaluation = client.Evaluate(out.campaign.id, evaluate);
  return out;
}

json OutcomeJson(const CampaignOutcome& o) {
  return {{"plan", o.plan.id},
          {"campaign", o.campaign.id},
          {"planned_poses", o.plan.configurations.size()},
          {"unmeasured_poses", o.unmeasured_poses},
          {"condition_number", api::Num(o.plan.indices.condition_number)},
          {"fit", o.calibration.summary.brief},
          {"outliers_injected", o.injected_outliers.size()},
          {"outliers_excluded", o.calibration.outliers.size()},
          {"outliers_found", o.outliers_found},
          {"before", api::ToWire(o.before)},
          {"after", api::ToWire(o.after)},
          {"service_evaluation", o.evaluation}};
}

json PooledJson(const PooledAccuracy& p) {
  return {{"before", api::ToWire(p.before)}, {"after", api::ToWire(p.after)}};
}

// The validation errors of one method over all trials, as if one long validation run.
PooledAccuracy Pool(const std::vector<const CampaignOutcome*>& outcomes, double h_mm) {
  std::vector<Transform> targets, nominal, compensated;
  for (const CampaignOutcome* o : outcomes) {
    targets.insert(targets.end(), o->targets.begin(), o->targets.end());
    nominal.insert(nominal.end(), o->reached_nominal.begin(), o->reached_nominal.end());
    compensated.insert(compensated.end(), o->reached_compensated.begin(), o->reached_compensated.end());
  }
  return {ComputeAccuracy(nominal, targets, h_mm), ComputeAccuracy(compensated, targets, h_mm)};
}

}  // namespace

bool MockTrackerOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  const auto presets = PresetNames();
  if (std::find(presets.begin(), presets.end(), robot) == presets.end()) {
    return fail("--robot must be a preset (the mock cell simulates its nominal model): grinder5, puma560, ur5e");
  }
  if (count < 1 || count > 1000) return fail("--count must be in [1, 1000]");
  if (shots_per_pose < 1 || shots_per_pose > 100) return fail("--shots must be in [1, 100]");
  if (num_validation < 2 || num_validation > 10000) return fail("--validation must be in [2, 10000]");
  if (!(h_mm > 0)) return fail("--h-mm must be positive");
  if (trials < 1 || trials > 100) return fail("--trials must be in [1, 100]");
  if (outlier_rate && !(*outlier_rate >= 0.0 && *outlier_rate <= 0.5)) return fail("--outliers must be in [0, 0.5]");
  if (outlier_size_mm && !((*outlier_size_mm)[0] >= 0.0 && (*outlier_size_mm)[1] >= (*outlier_size_mm)[0] &&
                           (*outlier_size_mm)[1] <= 1000.0)) {
    return fail("--outlier-size must be MIN,MAX with 0 <= MIN <= MAX <= 1000 mm");
  }
  if (reflectors && (*reflectors < 0 || *reflectors > 3)) return fail("--reflectors must be in [0, 3]");
  if (NumReflectors() > 0 && measurement_type != MeasurementType::kPosition) {
    return fail("--reflectors needs --type position");
  }
  if (free_nests && NumReflectors() == 0) return fail("--free-nests needs reflectors (--reflectors N)");
  return true;
}

int MockTrackerOptions::NumReflectors() const {
  if (reflectors) return *reflectors;
  return realistic && measurement_type == MeasurementType::kPosition ? 3 : 0;
}

VirtualCell MakeCell(const MockTrackerOptions& options, const std::optional<ResolvedCell>& cell) {
  VirtualCellOptions cell_options;
  cell_options.seed = options.seed;
  cell_options.shots_per_pose = options.shots_per_pose;
  if (cell) cell_options.measurement_cell = cell->spec;
  if (options.realistic) cell_options = Realistic(cell_options);
  if (options.outlier_rate) cell_options.outlier_rate = *options.outlier_rate;
  if (options.outlier_size_mm) {
    cell_options.outlier_min_mm = (*options.outlier_size_mm)[0];
    cell_options.outlier_max_mm = (*options.outlier_size_mm)[1];
  }
  // Three nests on a tool plate, 60 mm off the flange axis and 20 mm out: fixed at positions measured on the
  // plate, or (free_nests) known only as drawn, the cell hiding their offsets.
  std::vector<Reflector> nests = RealisticReflectors();
  for (Reflector& r : nests) r.fixed = !options.free_nests;
  cell_options.reflectors.assign(nests.begin(), nests.begin() + options.NumReflectors());
  return VirtualCell(Preset(options.robot), cell_options);
}

std::vector<Eigen::VectorXd> ValidationConfigurations(const VirtualCell& cell, const MockTrackerOptions& options) {
  Rng rng(options.seed + kValidationSeedOffset);
  const Cell* measurement_cell = cell.measurement_cell();
  if (measurement_cell == nullptr) return RandomConfigurations(cell.nominal(), options.num_validation, &rng);
  // Poses the tracker can see, so that the service's evaluation has its validation shots.
  const RobotModel planning = measurement_cell->PlanningModel(cell.nominal());
  FeasibleDraws account;
  account.max_draws = static_cast<std::int64_t>(kDefaultMaxDrawsPerConfiguration) * options.num_validation;
  std::vector<Eigen::VectorXd> out;
  if (!DrawFeasibleConfigurations(
          planning, options.num_validation, [&](const Eigen::VectorXd& q) { return cell.Measurable(q); }, &rng,
          &account, &out)) {
    throw std::runtime_error("validation poses: the cell leaves too little feasible: " + account.Describe());
  }
  return out;
}

std::optional<ResolvedCell> ResolveCell(client::Client& client, const MockTrackerOptions& options) {
  if (options.cell.empty()) return std::nullopt;
  const RobotModel model = Preset(options.robot);
  api::CellWire wire;
  if (options.cell == "preset") {
    const std::string id = "preset-" + options.robot;
    try {
      api::CellWire request = api::CellRequestOf(id, options.robot, PresetCellSpec(options.robot), model);
      request.description = "the preset cell of " + options.robot + " (docs/cells.md)";
      wire = client.CreateCell(request);
    } catch (const client::ServiceError& e) {
      if (e.status() != api::Status::kAlreadyExists) throw;
      wire = client.GetCell(id);  // made by an earlier run
    }
  } else {
    wire = client.GetCell(options.cell);
  }
  if (wire.robot != options.robot) {
    throw std::invalid_argument("cell '" + wire.id + "' is for robot '" + wire.robot + "', not '" + options.robot +
                                "'");
  }
  return ResolvedCell{wire.id, api::ToCell(wire, model).spec()};
}

api::MeasurementBatchRequest MeasurementBatch(VirtualCell* cell, const std::vector<std::vector<double>>& configurations,
                                              api::MeasurementRole role, const MockTrackerOptions& options,
                                              const std::vector<api::TestTagWire>& tags) {
  if (role == api::MeasurementRole::kTest && tags.size() != configurations.size()) {
    throw std::invalid_argument("a test batch needs one tag per configuration (the test plan's test.tags)");
  }
  const RobotModel& nominal = cell->nominal();
  api::MeasurementBatchRequest batch;
  batch.request_id = "mock-" + std::to_string(options.seed) + "-" + api::WireName(role);
  batch.role = role;
  for (std::size_t i = 0; i < configurations.size(); ++i) {
    const std::vector<double>& wire_q = configurations[i];
    const Eigen::VectorXd q = api::JointsToCore(nominal, wire_q);
    // One shot per validation pose and test visit; the planned poses get the cell's shots per pose, as the paper
    // measures.
    for (const Measurement& m : cell->Measure(q, role == api::MeasurementRole::kCalibration ? 0 : 1)) {
      const std::string reflector = m.reflector >= 0 ? cell->options().reflectors[m.reflector].id : std::string();
      api::MeasurementWire w{.joints = wire_q, .pose = api::TransformToPose(m.T_world_tool), .reflector = reflector};
      if (role == api::MeasurementRole::kTest) {
        w.test_pose = tags[i].test_pose;
        w.cycle = tags[i].cycle;
      }
      batch.measurements.push_back(std::move(w));
    }
  }
  return batch;
}

MockTrackerReport RunMockTracker(client::Client& client, const MockTrackerOptions& options, std::ostream* log) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument(error);
  MockTrackerReport report;
  const std::optional<ResolvedCell> resolved = ResolveCell(client, options);
  const std::string* cell_id = resolved ? &resolved->id : nullptr;
  if (resolved) Log(log, "cell " + resolved->id);
  std::vector<const CampaignOutcome*> planned, random;
  for (int t = 0; t < options.trials; ++t) {
    // Trial t is the one-trial run of seed + t: a new cell, plan and validation poses.
    MockTrackerOptions trial_options = options;
    trial_options.seed = options.seed + static_cast<std::uint64_t>(t);
    if (options.trials > 1) Log(log, "trial " + std::to_string(t + 1) + " of " + std::to_string(options.trials));
    VirtualCell cell = MakeCell(trial_options, resolved);
    const std::vector<Eigen::VectorXd> validation = ValidationConfigurations(cell, trial_options);
    TrialOutcome trial;
    trial.seed = trial_options.seed;
    trial.planned =
        RunCampaign(client, &cell, cell_id, trial_options, options.optimiser, trial_options.seed, validation, log);
    if (options.compare_random) {
      // The same cell (same hidden errors), calibrated from random configurations: the paper's comparison.
      MockTrackerOptions random_options = trial_options;
      random_options.seed = trial_options.seed + kRandomPlanSeedOffset;  // distinct request ids for this campaign
      trial.random = RunCampaign(client, &cell, cell_id, random_options, api::Optimiser::kRandom, random_options.seed,
                                 validation, log);
    }
    report.trials.push_back(std::move(trial));
  }
  for (const TrialOutcome& t : report.trials) {
    planned.push_back(&t.planned);
    if (t.random) random.push_back(&*t.random);
  }
  report.planned = Pool(planned, options.h_mm);
  if (options.compare_random) report.random = Pool(random, options.h_mm);
  const PooledAccuracy& p = report.planned;
  report.improved = p.after.e_tot_mm.mean < p.before.e_tot_mm.mean && p.after.e_xyz_mm.mean < p.before.e_xyz_mm.mean;
  return report;
}

std::string FormatReport(const MockTrackerReport& report, const MockTrackerOptions& options) {
  std::ostringstream out;
  const int poses = options.num_validation * static_cast<int>(report.trials.size());
  auto tables = [&](const PooledAccuracy& a, const std::string& label, bool random) {
    out << "\n" << label << ":";
    for (const TrialOutcome& t : report.trials) {
      const CampaignOutcome& o = random ? *t.random : t.planned;
      out << (report.trials.size() > 1 ? "\n  trial seed " + std::to_string(t.seed) + ":" : "") << " plan " << o.plan.id
          << " (condition number " << std::setprecision(4) << o.plan.indices.condition_number << "), campaign "
          << o.campaign.id;
      if (!options.cell.empty()) {
        out << ", " << o.unmeasured_poses << " of " << o.plan.configurations.size()
            << " planned poses could not be measured";
      }
    }
    out << "\n";
    out << FormatAccuracyTable(
        a.before,
        "before calibration (nominal joints), " + std::to_string(poses) + " validation poses" +
            (report.trials.size() > 1 ? " (" + std::to_string(report.trials.size()) + " trials pooled)" : ""));
    out << FormatAccuracyTable(a.after, "after calibration (compensated joints)");
    const api::Improvement improvement = api::ImprovementOf(a.before, a.after);
    out << std::fixed << std::setprecision(1) << "improvement: E_xyz mean " << improvement.e_xyz_mean
        << " %, E_tot mean " << improvement.e_tot_mean << " %, E_tot RP " << improvement.e_tot_rp << " %\n"
        << std::defaultfloat;
  };
  out << "robot " << options.robot << ", " << options.count << " " << api::WireName(options.measurement_type)
      << " configurations, seed " << options.seed << ", " << report.trials.size() << " trial"
      << (report.trials.size() > 1 ? "s" : "") << ", h = " << options.h_mm << " mm"
      << (options.cell.empty()
              ? ""
              : ", measured in cell " + (options.cell == "preset" ? "preset-" + options.robot : options.cell))
      << "\n";
  tables(report.planned, api::WireName(options.optimiser), false);
  if (report.random) {
    tables(*report.random, "random", true);
    const api::Improvement over = api::ImprovementOf(report.random->after, report.planned.after);
    out << std::fixed << std::setprecision(1) << "\n"
        << api::WireName(options.optimiser)
        << " over random, after calibration (percent lower error; negative: random did better): E_xyz mean "
        << over.e_xyz_mean << " %, E_xyz RP " << over.e_xyz_rp << " %, E_tot mean " << over.e_tot_mean
        << " %, E_tot RP " << over.e_tot_rp << " %\n";
    if (report.trials.size() == 1) {
      out << "note: one trial compares one planned with one random set of " << options.count << " configurations on "
          << options.num_validation
          << " poses; tracker noise and the draw of the random set dominate that difference. Use --trials N "
             "(e.g. 5) to pool N cells.\n";
    }
  }
  out << (report.improved ? "\ncalibration improved accuracy\n" : "\ncalibration did NOT improve accuracy\n");
  return out.str();
}

json ReportToJson(const MockTrackerReport& report) {
  json trials = json::array();
  for (const TrialOutcome& t : report.trials) {
    json trial = {{"seed", t.seed}, {"planned", OutcomeJson(t.planned)}};
    if (t.random) trial["random"] = OutcomeJson(*t.random);
    trials.push_back(std::move(trial));
  }
  json j = {{"trials", trials}, {"planned", PooledJson(report.planned)}, {"improved", report.improved}};
  if (report.random) {
    j["random"] = PooledJson(*report.random);
    j["improvement_over_random_percent"] = api::ImprovementOf(report.random->after, report.planned.after);
  }
  return j;
}

}  // namespace robocal::mock
