// The mock tracker's workflow: plan, campaign, measure, upload, fit, validate with nominal and compensated
// joints, and the paper's tables.
#include "mock_tracker.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <sstream>

#include "robocal/api/convert.h"
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

CampaignOutcome RunCampaign(client::Client& client, VirtualCell* cell, const MockTrackerOptions& options,
                            const std::string& optimiser, std::uint64_t plan_seed,
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
  plan_request.noise.position_mm = cell->options().noise.position_mm;
  plan_request.noise.orientation_deg = cell->options().noise.orientation_rad * 180.0 / std::numbers::pi;
  out.plan = client.CreatePlan(plan_request);
  Log(log, "plan " + out.plan.id + " (" + optimiser + "): " + out.plan.summary);

  api::CreateCampaignRequest campaign_request;
  campaign_request.robot = options.robot;
  campaign_request.measurement_type = options.measurement_type;
  campaign_request.plan = out.plan.id;
  campaign_request.noise = plan_request.noise;
  campaign_request.description = "mock tracker, seed " + std::to_string(options.seed) + ", " + optimiser;
  out.campaign = client.CreateCampaign(campaign_request);
  Log(log, "campaign " + out.campaign.id);

  // "Move" the robot to each planned configuration and shoot it with the tracker.
  const json calibration_batch = MeasurementBatch(cell, out.plan.configurations, "calibration", options);
  api::MeasurementBatchRequest batch;
  batch.request_id = calibration_batch.at("request_id");
  batch.role = "calibration";
  for (const json& m : calibration_batch.at("measurements")) batch.measurements.push_back(api::MeasurementFromJson(m));
  const client::UploadResult uploaded = client.UploadMeasurements(out.campaign.id, batch);
  Log(log, "uploaded " + std::to_string(uploaded.count) + " calibration shots");

  out.calibration = client.Fit(out.campaign.id);
  Log(log, "fit: " + out.calibration.brief);

  // Validation: the nominal command lands where the true robot goes; the target is where the nominal model
  // says it should be, in the calibrated base frame (the frame compensation aims at).
  const std::vector<std::vector<double>> validation_wire = ToWire(nominal, validation);
  const std::vector<client::Compensation> compensated = client.CompensateJoints(out.campaign.id, validation_wire);
  const Transform T_world_base = api::PoseToTransform(out.calibration.base);
  std::vector<Transform> targets, reached_nominal, reached_compensated;
  for (std::size_t i = 0; i < validation.size(); ++i) {
    const Transform T_base_tool = nominal.T_world_base().inverse() * ForwardKinematics(nominal, validation[i]);
    targets.push_back(T_world_base * T_base_tool);
    reached_nominal.push_back(cell->TruePose(validation[i]));
    reached_compensated.push_back(cell->TruePose(api::JointsToCore(nominal, compensated[i].joints)));
  }
  out.before = ComputeAccuracy(reached_nominal, targets, options.h_mm);
  out.after = ComputeAccuracy(reached_compensated, targets, options.h_mm);

  // The service's own view: validation shots at the nominal commands, evaluated on the server.
  const json validation_batch = MeasurementBatch(cell, validation_wire, "validation", options);
  api::MeasurementBatchRequest vbatch;
  vbatch.request_id = validation_batch.at("request_id");
  vbatch.role = "validation";
  for (const json& m : validation_batch.at("measurements")) vbatch.measurements.push_back(api::MeasurementFromJson(m));
  client.UploadMeasurements(out.campaign.id, vbatch);
  api::EvaluateRequest evaluate;
  evaluate.h_mm = options.h_mm;
  out.evaluation = client.Evaluate(out.campaign.id, evaluate);
  return out;
}

double Percent(double reference, double value) {
  return reference > 0 ? 100.0 * (reference - value) / reference : std::nan("");
}

json StatsJson(const ErrorStatistics& s, double scale) {
  return {{"mean", s.mean * scale}, {"std", s.std * scale}, {"max", s.max * scale}, {"rp", s.rp * scale}};
}

json AccuracyJson(const AccuracyReport& r) {
  return {{"e_xyz_mm", StatsJson(r.e_xyz_mm, 1.0)},
          {"e_cos_deg", StatsJson(r.e_cos_rad, 180.0 / std::numbers::pi)},
          {"e_tot_mm", StatsJson(r.e_tot_mm, 1.0)},
          {"h_mm", r.h_mm}};
}

json OutcomeJson(const CampaignOutcome& o) {
  return {{"plan", o.plan.id},
          {"campaign", o.campaign.id},
          {"condition_number", o.plan.indices.condition_number},
          {"fit", o.calibration.brief},
          {"before", AccuracyJson(o.before)},
          {"after", AccuracyJson(o.after)},
          {"service_evaluation", o.evaluation.raw}};
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
  if (measurement_type != "pose" && measurement_type != "position" && measurement_type != "position_axis") {
    return fail("--type must be pose, position_axis or position");
  }
  if (shots_per_pose < 1 || shots_per_pose > 100) return fail("--shots must be in [1, 100]");
  if (num_validation < 2 || num_validation > 10000) return fail("--validation must be in [2, 10000]");
  if (!(h_mm > 0)) return fail("--h-mm must be positive");
  return true;
}

VirtualCell MakeCell(const MockTrackerOptions& options) {
  VirtualCellOptions cell_options;
  cell_options.seed = options.seed;
  cell_options.shots_per_pose = options.shots_per_pose;
  return VirtualCell(Preset(options.robot), cell_options);
}

std::vector<Eigen::VectorXd> ValidationConfigurations(const RobotModel& model, const MockTrackerOptions& options) {
  Rng rng(options.seed + kValidationSeedOffset);
  return RandomConfigurations(model, options.num_validation, &rng);
}

json MeasurementBatch(VirtualCell* cell, const std::vector<std::vector<double>>& configurations,
                      const std::string& role, const MockTrackerOptions& options) {
  const RobotModel& nominal = cell->nominal();
  json measurements = json::array();
  for (const auto& wire_q : configurations) {
    const Eigen::VectorXd q = api::JointsToCore(nominal, wire_q);
    // One shot per validation pose; the planned poses get the cell's shots per pose, as the paper measures.
    for (const Measurement& m : cell->Measure(q, role == "validation" ? 1 : 0)) {
      api::MeasurementWire w;
      w.joints = wire_q;
      w.pose = api::TransformToPose(m.T_world_tool);
      measurements.push_back(api::ToJson(w));
    }
  }
  return {{"request_id", "mock-" + std::to_string(options.seed) + "-" + role},
          {"role", role},
          {"measurements", measurements}};
}

MockTrackerReport RunMockTracker(client::Client& client, const MockTrackerOptions& options, std::ostream* log) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument(error);
  VirtualCell cell = MakeCell(options);
  const std::vector<Eigen::VectorXd> validation = ValidationConfigurations(cell.nominal(), options);
  MockTrackerReport report;
  report.planned = RunCampaign(client, &cell, options, options.optimiser, options.seed, validation, log);
  if (options.compare_random) {
    // The same cell (same hidden errors), calibrated from random configurations: the paper's comparison.
    MockTrackerOptions random_options = options;
    random_options.seed = options.seed + kRandomPlanSeedOffset;  // distinct request ids for the second campaign
    report.random =
        RunCampaign(client, &cell, random_options, "random", options.seed + kRandomPlanSeedOffset, validation, log);
  }
  const CampaignOutcome& p = report.planned;
  report.improved = p.after.e_tot_mm.mean < p.before.e_tot_mm.mean && p.after.e_xyz_mm.mean < p.before.e_xyz_mm.mean;
  return report;
}

std::string FormatReport(const MockTrackerReport& report, const MockTrackerOptions& options) {
  std::ostringstream out;
  auto tables = [&](const CampaignOutcome& o, const std::string& label) {
    out << "\n"
        << label << ": plan " << o.plan.id << " (condition number " << std::setprecision(4)
        << o.plan.indices.condition_number << "), campaign " << o.campaign.id << "\n";
    out << FormatAccuracyTable(o.before, "before calibration (nominal joints), " +
                                             std::to_string(options.num_validation) + " validation poses");
    out << FormatAccuracyTable(o.after, "after calibration (compensated joints)");
    out << std::fixed << std::setprecision(1) << "improvement: E_xyz mean "
        << Percent(o.before.e_xyz_mm.mean, o.after.e_xyz_mm.mean) << " %, E_tot mean "
        << Percent(o.before.e_tot_mm.mean, o.after.e_tot_mm.mean) << " %, E_tot RP "
        << Percent(o.before.e_tot_mm.rp, o.after.e_tot_mm.rp) << " %\n"
        << std::defaultfloat;
  };
  out << "robot " << options.robot << ", " << options.count << " " << options.measurement_type
      << " configurations, seed " << options.seed << ", h = " << options.h_mm << " mm\n";
  tables(report.planned, options.optimiser);
  if (report.random) {
    tables(*report.random, "random");
    const AccuracyReport& a = report.planned.after;
    const AccuracyReport& r = report.random->after;
    out << std::fixed << std::setprecision(1) << "\n"
        << options.optimiser
        << " over random, after calibration (percent lower error; negative: random did better): E_xyz mean "
        << Percent(r.e_xyz_mm.mean, a.e_xyz_mm.mean) << " %, E_xyz RP " << Percent(r.e_xyz_mm.rp, a.e_xyz_mm.rp)
        << " %, E_tot mean " << Percent(r.e_tot_mm.mean, a.e_tot_mm.mean) << " %, E_tot RP "
        << Percent(r.e_tot_mm.rp, a.e_tot_mm.rp) << " %\n";
  }
  out << (report.improved ? "\ncalibration improved accuracy\n" : "\ncalibration did NOT improve accuracy\n");
  return out.str();
}

json ReportToJson(const MockTrackerReport& report) {
  json j = {{"planned", OutcomeJson(report.planned)}, {"improved", report.improved}};
  if (report.random) {
    j["random"] = OutcomeJson(*report.random);
    const AccuracyReport& a = report.planned.after;
    const AccuracyReport& r = report.random->after;
    j["improvement_over_random_percent"] = {{"e_xyz_mean", api::Num(Percent(r.e_xyz_mm.mean, a.e_xyz_mm.mean))},
                                            {"e_xyz_rp", api::Num(Percent(r.e_xyz_mm.rp, a.e_xyz_mm.rp))},
                                            {"e_tot_mean", api::Num(Percent(r.e_tot_mm.mean, a.e_tot_mm.mean))},
                                            {"e_tot_rp", api::Num(Percent(r.e_tot_mm.rp, a.e_tot_mm.rp))}};
  }
  return j;
}

}  // namespace robocal::mock
