// The paper's experiment, simulated: plans by Solis & Wets, random selection and exchange, each measured and
// identified in a virtual cell, then compensated validation poses compared before and after calibration.
#include "robocal/core/experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "robocal/core/cell.h"
#include "robocal/core/compensation.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/model_choice.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"

namespace robocal {
namespace {

// Independent, well-mixed seeds from one: SplitMix64 of (seed, trial, purpose).
std::uint64_t DeriveSeed(std::uint64_t seed, int trial, int purpose) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (1 + 8 * static_cast<std::uint64_t>(trial) + purpose);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

enum Purpose { kCell = 0, kRandomPlan = 1, kSolisWets = 2, kExchange = 3, kValidation = 4 };

// A selection method: how it plans and what it minimises.
enum class Planner { kSolisWets, kRandom, kExchange, kRandomIgnoringCell };
struct Method {
  const char* name;
  Planner planner;
  ObservabilityIndex objective;
};
// The paper's three first (the order of the report and of MethodResult without a cell), then the cell's.
constexpr Method kMethods[] = {
    {"solis_wets", Planner::kSolisWets, ObservabilityIndex::kConditionNumber},
    {"random", Planner::kRandom, ObservabilityIndex::kConditionNumber},
    {"exchange", Planner::kExchange, ObservabilityIndex::kConditionNumber},
    {"random_ignoring_cell", Planner::kRandomIgnoringCell, ObservabilityIndex::kConditionNumber},
    {"solis_wets_log_det", Planner::kSolisWets, ObservabilityIndex::kLogDet},
    {"solis_wets_predicted_error", Planner::kSolisWets, ObservabilityIndex::kPredictedError},
    {"exchange_log_det", Planner::kExchange, ObservabilityIndex::kLogDet},
    {"exchange_predicted_error", Planner::kExchange, ObservabilityIndex::kPredictedError},
};
constexpr int kPaperMethods = 3;
constexpr int kAllMethods = sizeof(kMethods) / sizeof(kMethods[0]);

// Per-method pools over all trials.
struct Pool {
  std::vector<Transform> reached, target;
  std::vector<double> condition_numbers;
  int failed_trials = 0;
  int unconverged_targets = 0;
  int planned_poses = 0;
  int unmeasured_poses = 0;
};

// One improvement (ImprovementPercent) as the table shows it: "n/a" where there is none (a zero baseline, e.g. a
// noise-free cell whose random plan already reaches round-off) rather than inf or nan.
std::string Percent(double improvement_percent) {
  if (std::isnan(improvement_percent)) return "n/a";
  char text[32];
  std::snprintf(text, sizeof(text), "%+.1f %%", improvement_percent);
  return text;
}

// The improvement block of one planner over random selection: mean and RP of each error, and the plans'
// median condition numbers.
std::string Improvement(const MethodResult& planned, const MethodResult& random, const char* title) {
  std::ostringstream out;
  out << title << " against random selection (positive: " << title << " better)\n";
  const AccuracyImprovement x = ComputeImprovement(random.after, planned.after);
  out << "  E_xyz: mean " << Percent(x.e_xyz_mean) << ", RP " << Percent(x.e_xyz_rp) << "\n";
  out << "  E_cos: mean " << Percent(x.e_cos_mean) << ", RP " << Percent(x.e_cos_rp) << "\n";
  out << "  E_tot: mean " << Percent(x.e_tot_mean) << ", RP " << Percent(x.e_tot_rp) << "\n";
  char line[128];
  std::snprintf(line, sizeof(line), "  median cond %.4g (%s) against %.4g (random)\n",
                planned.median_condition_number, title, random.median_condition_number);
  out << line;
  return out.str();
}

}  // namespace

bool ExperimentOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    *error = message;
    return false;
  };
  if (models.empty()) return fail("models must name at least one model");
  for (const std::string& model : models) {
    JointErrorTerms terms;
    bool automatic = false;
    std::string why;
    if (!ParseModelName(model, &terms, &automatic, &why)) return fail("models: " + why);
  }
  const std::vector<std::string> presets = PresetNames();
  if (std::find(presets.begin(), presets.end(), robot) == presets.end()) {
    std::string names;
    for (const std::string& name : presets) names += (names.empty() ? "" : ", ") + name;
    return fail("robot must be one of " + names + " (got '" + robot + "')");
  }
  if (num_configurations < 1 || num_configurations > 1000) return fail("num_configurations must be in [1, 1000]");
  if (trials < 1 || trials > 10000) return fail("trials must be in [1, 10000]");
  if (num_validation < 1 || num_validation > 100000) return fail("num_validation must be in [1, 100000]");
  if (!(h_mm > 0.0) || !std::isfinite(h_mm)) return fail("h_mm must be positive and finite");
  std::string sub;
  if (!cell.IsValid(&sub)) return fail("cell." + sub);
  if (cell.measurement_cell) {
    try {
      Cell::Build(Preset(robot), *cell.measurement_cell);
    } catch (const std::invalid_argument& e) {
      return fail(std::string("cell.measurement_cell: ") + e.what());
    }
  }
  return true;
}

namespace {

// The fit's and the planners' options, the same in every trial.
struct ExperimentFits {
  ObservabilityOptions observability;
  IdentificationOptions identification;
};

ExperimentFits ExperimentFitOptions(const RobotModel& nominal, const ExperimentOptions& options) {
  // The identifiable set depends on the robot and the measurement type only: found once.
  // With reflector nests (a realistic position cell) every probe, plan and fit sees each of them.
  IdentifiabilityOptions identifiability;
  identifiability.reflectors = options.cell.reflectors;
  const IdentifiabilitySummary identifiable =
      FindIdentifiableParameters(nominal, options.measurement_type, identifiability);
  // Rows are weighted by the tracker's noise. A noise-free cell still needs weights: the defaults then only
  // set the balance of mm against rad.
  MeasurementNoise weights = options.cell.noise;
  if (!(weights.position_mm > 0.0)) weights.position_mm = MeasurementNoise{}.position_mm;
  if (!(weights.orientation_rad > 0.0)) weights.orientation_rad = MeasurementNoise{}.orientation_rad;
  ExperimentFits fits;
  ObservabilityOptions& observability = fits.observability;
  observability.measurement_type = options.measurement_type;
  observability.noise = weights;
  observability.parameters = identifiable.identifiable;
  observability.reflectors = options.cell.reflectors;
  IdentificationOptions& identification = fits.identification;
  identification.reflectors = options.cell.reflectors;
  identification.measurement_type = options.measurement_type;
  identification.noise = weights;
  identification.parameters = identifiable.identifiable;
  return fits;
}

// What the trials share: the options, the robot as planned and fitted, the cell's feasibility, the methods and the
// models (each model's joint error terms, or automatic: chosen by cross-validation).
struct ExperimentSetup {
  const ExperimentOptions& options;
  const RobotModel& nominal;
  const RobotModel& planning;
  const ExperimentFits& fits;
  const FeasibilityPredicate& feasible;
  int num_methods = 0;
  int num_models = 0;
  std::vector<JointErrorTerms> model_terms;
  std::vector<char> model_auto;
};

// Per (method, model) slot k * num_models + j, pooled over the trials; and the robot uncalibrated.
struct ExperimentPools {
  std::vector<Pool> pools;
  std::vector<Transform> before_reached, before_target;
};

// Each method's plan for one trial.
std::vector<Plan> PlanExperimentTrial(const ExperimentSetup& setup, int trial) {
  const ExperimentOptions& options = setup.options;
  const int m = options.num_configurations;
  const ObservabilityOptions& observability = setup.fits.observability;
  // The paper's baseline is one random set; Solis & Wets starts from that same set, so the two differ only by
  // the search. Each objective's planner gets the same seed.
  RandomSelectionOptions random_options;
  random_options.seed = DeriveSeed(options.seed, trial, kRandomPlan);
  random_options.feasible = setup.feasible;
  const Plan random = PlanRandom(setup.planning, m, observability, random_options);
  std::vector<Plan> plans;
  for (int k = 0; k < setup.num_methods; ++k) {
    const Method& method = kMethods[k];
    switch (method.planner) {
      case Planner::kRandom:
        plans.push_back(random);
        break;
      case Planner::kRandomIgnoringCell: {
        RandomSelectionOptions ignoring = random_options;
        ignoring.feasible = nullptr;
        plans.push_back(PlanRandom(setup.planning, m, observability, ignoring));
        break;
      }
      case Planner::kSolisWets: {
        SolisWetsOptions solis_wets_options = SolisWetsOptions::Paper();
        solis_wets_options.seed = DeriveSeed(options.seed, trial, kSolisWets);
        solis_wets_options.objective = method.objective;
        solis_wets_options.feasible = setup.feasible;
        // A failed random plan has no set to start from: Solis & Wets then draws its own.
        plans.push_back(PlanSolisWets(setup.planning, m, observability, solis_wets_options, random.configurations));
        break;
      }
      case Planner::kExchange: {
        ExchangeOptions exchange_options;
        exchange_options.seed = DeriveSeed(options.seed, trial, kExchange);
        exchange_options.objective = method.objective;
        exchange_options.feasible = setup.feasible;
        plans.push_back(PlanExchange(setup.planning, m, observability, exchange_options));
        break;
      }
    }
  }
  return plans;
}

// Each plan measured in the trial's cell and fitted with each model: the calibrations in *storage (reserved for
// all), calibrations[k * num_models + j] pointing at those that did not fail.
void CalibrateExperimentTrial(const ExperimentSetup& setup, const std::vector<Plan>& plans, VirtualCell* cell,
                              std::vector<Calibration>* storage, std::vector<const Calibration*>* calibrations,
                              ExperimentPools* out) {
  const int m = setup.options.num_configurations;
  const int num_models = setup.num_models;
  for (int k = 0; k < setup.num_methods; ++k) {
    const Plan& plan = plans[k];
    if (plan.summary.termination == Termination::kFailure) {
      for (int j = 0; j < num_models; ++j) {
        out->pools[k * num_models + j].planned_poses += m;
        ++out->pools[k * num_models + j].failed_trials;
      }
      continue;
    }
    std::vector<int> lost;
    const std::vector<Measurement> measurements = cell->MeasureAll(plan.configurations, 0, &lost);
    for (int j = 0; j < num_models; ++j) {
      Pool& pool = out->pools[k * num_models + j];
      pool.planned_poses += m;
      pool.condition_numbers.push_back(plan.summary.final.condition_number);
      pool.unmeasured_poses += static_cast<int>(lost.size());
      const bool geometric = !setup.model_auto[j] && setup.model_terms[j] == JointErrorTerms{};
      // The geometric fit estimates the planned set; a richer model chooses its own (its joint terms are tested
      // against these measurements).
      IdentificationOptions o = setup.fits.identification;
      if (!geometric) o.parameters.clear();
      storage->push_back(setup.model_auto[j] ? IdentifyWithModelChoice(setup.nominal, measurements, o)
                         : geometric         ? Identify(setup.nominal, measurements, o)
                                     : Identify(setup.nominal.WithErrorTerms(setup.model_terms[j]), measurements, o));
      if (storage->back().summary.termination == Termination::kFailure) {
        ++pool.failed_trials;
      } else {
        (*calibrations)[k * num_models + j] = &storage->back();
      }
    }
  }
}

// Validation: where the program wants the tool is where the nominal model puts it relative to the robot's
// base, and the base is where it truly stands in the cell (the workpiece does not move with the model).
// Targets are given to compensation in the tracker frame: the calibrated base frame is a convention
// wherever base errors are indistinguishable from joint offsets (e.g. grinder5's X slide zero against base
// x), but the world poses the calibrated model predicts are not.
void ValidateExperimentTrial(const ExperimentSetup& setup, int trial, VirtualCell* cell,
                             const std::vector<const Calibration*>& calibrations, ExperimentPools* out) {
  const ExperimentOptions& options = setup.options;
  const RobotModel& nominal = setup.nominal;
  const Transform T_world_true_base = cell->true_model().T_world_base() * ErrorTransform(cell->true_errors().data());
  Rng validation_rng(DeriveSeed(options.seed, trial, kValidation));
  for (int v = 0; v < options.num_validation; ++v) {
    const Eigen::VectorXd q = RandomConfiguration(setup.planning, &validation_rng);
    const Transform target = T_world_true_base * nominal.T_world_base().inverse() * ForwardKinematics(nominal, q);
    out->before_reached.push_back(cell->Land(q));
    out->before_target.push_back(target);
    for (int k = 0; k < setup.num_methods * setup.num_models; ++k) {
      if (calibrations[k] == nullptr) continue;
      const CompensationResult r = CompensatePose(*calibrations[k], target, TargetFrame::kTracker, q);
      // Not converged (a target beyond a singularity's fold, or a joint at its limit): the robot is still sent
      // to the best joints found, as a controller would, and the error counts.
      if (!r.converged) ++out->pools[k].unconverged_targets;
      out->pools[k].reached.push_back(cell->Land(r.joints));
      out->pools[k].target.push_back(target);
    }
  }
}

// One trial: a new cell with new hidden errors, each method's plan measured and fitted, and validated.
void RunExperimentTrial(const ExperimentSetup& setup, int trial, ExperimentPools* out) {
  VirtualCellOptions cell_options = setup.options.cell;
  cell_options.seed = DeriveSeed(setup.options.seed, trial, kCell);
  VirtualCell cell(setup.nominal, cell_options);
  const std::vector<Plan> plans = PlanExperimentTrial(setup, trial);
  std::vector<const Calibration*> calibrations(static_cast<size_t>(setup.num_methods * setup.num_models), nullptr);
  std::vector<Calibration> storage;
  storage.reserve(static_cast<size_t>(setup.num_methods * setup.num_models));
  CalibrateExperimentTrial(setup, plans, &cell, &storage, &calibrations, out);
  ValidateExperimentTrial(setup, trial, &cell, calibrations, out);
}

// The pools as the result's methods, in slot order.
std::vector<MethodResult> PooledMethods(const ExperimentSetup& setup, const ExperimentPools& pools) {
  const int num_models = setup.num_models;
  std::vector<MethodResult> methods;
  for (int k = 0; k < setup.num_methods * num_models; ++k) {
    const Pool& pool = pools.pools[k];
    MethodResult method;
    method.method = kMethods[k / num_models].name;
    method.model = setup.options.models[k % num_models];
    method.planned_poses = pool.planned_poses;
    method.unmeasured_poses = pool.unmeasured_poses;
    method.median_condition_number = Median(pool.condition_numbers);
    method.failed_trials = pool.failed_trials;
    method.unconverged_targets = pool.unconverged_targets;
    if (!pool.reached.empty()) method.after = ComputeAccuracy(pool.reached, pool.target, setup.options.h_mm);
    methods.push_back(std::move(method));
  }
  return methods;
}

}  // namespace

ExperimentResult RunExperiment(const ExperimentOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("ExperimentOptions: " + error);
  const auto start = std::chrono::steady_clock::now();
  const RobotModel nominal = Preset(options.robot);
  ExperimentFits fits = ExperimentFitOptions(nominal, options);

  // In a measurement cell the planners sample its joint ranges and keep only feasible configurations.
  std::optional<Cell> measurement_cell;
  if (options.cell.measurement_cell) measurement_cell = Cell::Build(nominal, *options.cell.measurement_cell);
  // With a tracker model the planners whiten each configuration's rows as the fit will: from where the cell's
  // tracker stands (nominal world frame).
  if (measurement_cell) {
    fits.observability.tracker_position_mm = nominal.T_world_base() * measurement_cell->spec().tracker.position_mm;
  }
  const RobotModel planning = measurement_cell ? measurement_cell->PlanningModel(nominal) : nominal;
  FeasibilityPredicate feasible;
  if (measurement_cell) {
    feasible = [&](const Eigen::VectorXd& q) { return IsFeasible(nominal, *measurement_cell, q); };
  }
  const int num_models = static_cast<int>(options.models.size());
  std::vector<JointErrorTerms> model_terms(num_models);
  std::vector<char> model_auto(num_models, 0);
  for (int j = 0; j < num_models; ++j) {
    bool automatic = false;
    std::string error;
    ParseModelName(options.models[j], &model_terms[j], &automatic, &error);  // checked by IsValid
    model_auto[j] = automatic ? 1 : 0;
  }
  const ExperimentSetup setup{.options = options,
                              .nominal = nominal,
                              .planning = planning,
                              .fits = fits,
                              .feasible = feasible,
                              .num_methods = measurement_cell ? kAllMethods : kPaperMethods,
                              .num_models = num_models,
                              .model_terms = std::move(model_terms),
                              .model_auto = std::move(model_auto)};

  ExperimentPools pools;
  pools.pools.resize(static_cast<size_t>(kAllMethods * num_models));
  for (int trial = 0; trial < options.trials; ++trial) {
    RunExperimentTrial(setup, trial, &pools);
    if (options.progress) options.progress(trial + 1, options.trials);
  }

  ExperimentResult result;
  result.options = options;
  result.options.progress = nullptr;
  result.before = ComputeAccuracy(pools.before_reached, pools.before_target, options.h_mm);
  result.methods = PooledMethods(setup, pools);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

std::string FormatExperimentReport(const ExperimentResult& result) {
  const ExperimentOptions& o = result.options;
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof(line),
                "robot %s, %s measurements, M = %d configurations, %d trials x %d validation poses, seed %llu\n",
                o.robot.c_str(), ToString(o.measurement_type), o.num_configurations, o.trials, o.num_validation,
                static_cast<unsigned long long>(o.seed));
  out << line;
  // The tracker's noise: its uncertainty model where the cell has one, else one sigma per axis.
  if (o.cell.noise.tracker) {
    const TrackerUncertainty& t = *o.cell.noise.tracker;
    std::snprintf(line, sizeof(line),
                  "tracker model: radial %g um + %g um/m, transverse %g um + %g um/m, orientation %g deg MPE, "
                  "MPE = %g sigma",
                  t.radial_um, t.radial_um_per_m, t.transverse_um, t.transverse_um_per_m, t.orientation_deg,
                  t.mpe_sigmas);
  } else {
    std::snprintf(line, sizeof(line), "tracker noise %g mm, %g rad per axis", o.cell.noise.position_mm,
                  o.cell.noise.orientation_rad);
  }
  out << line;
  std::snprintf(line, sizeof(line), ", %d shots per pose; E_tot = E_xyz + %g mm * E_cos\n\n", o.cell.shots_per_pose,
                o.h_mm);
  out << line;
  if (o.cell.noise.repeatability_mm > 0.0 || o.cell.outlier_rate > 0.0) {
    std::snprintf(line, sizeof(line),
                  "robot repeatability %g mm (ISO 9283 RP); outliers %g %% of shots, %g-%g mm; robust fit\n",
                  o.cell.noise.repeatability_mm, 100.0 * o.cell.outlier_rate, o.cell.outlier_min_mm, o.cell.outlier_max_mm);
    out << line;
  }
  if (o.cell.compliance_deflection_mm > 0.0 || o.cell.joint_harmonic_sigma_rad > 0.0) {
    std::snprintf(line, sizeof(line),
                  "simulated robot beyond geometry: joint compliance %g mm at the largest gravity torque, joint "
                  "harmonics %g rad per coefficient (orders %d-%d)\n",
                  o.cell.compliance_deflection_mm, o.cell.joint_harmonic_sigma_rad, o.cell.joint_harmonic_min_order,
                  o.cell.joint_harmonic_max_order);
    out << line;
  }
  if (!o.cell.reflectors.empty()) {
    out << o.cell.reflectors.size() << " reflector nests shot at every pose (";
    for (size_t k = 0; k < o.cell.reflectors.size(); ++k) {
      const Reflector& r = o.cell.reflectors[k];
      out << (k ? ", " : "") << r.id << " at " << r.position_mm.x() << " " << r.position_mm.y() << " "
          << r.position_mm.z() << " mm" << (r.fixed ? " held" : " free");
    }
    out << "); planned, fitted and validated with them\n";
  }
  if (o.cell.noise.tracker || o.cell.noise.repeatability_mm > 0.0 || o.cell.outlier_rate > 0.0) out << "\n";
  if (o.cell.measurement_cell) {
    const TrackerSpec& tracker = o.cell.measurement_cell->tracker;
    std::snprintf(line, sizeof(line),
                  "in a measurement cell: tracker at (%.0f, %.0f, %.0f) mm, %zu obstacles; every planner but "
                  "random_ignoring_cell plans in it\n\n",
                  tracker.position_mm.x(), tracker.position_mm.y(), tracker.position_mm.z(),
                  o.cell.measurement_cell->obstacles.size());
    out << line;
  }
  out << FormatAccuracyTable(result.before, "Before calibration, nominal commands") << "\n";
  const MethodResult* solis_wets = nullptr;
  const MethodResult* random = nullptr;
  const MethodResult* exchange = nullptr;
  const bool several_models = o.models.size() > 1 || o.models.front() != "geometric";
  for (const MethodResult& m : result.methods) {
    // The planners are compared on the first model's fits.
    if (m.model == o.models.front()) {
      if (m.method == "solis_wets") solis_wets = &m;
      if (m.method == "random") random = &m;
      if (m.method == "exchange") exchange = &m;
    }
    std::string title = "After calibration, " + m.method + " configurations";
    if (several_models) title += ", model " + m.model;
    if (o.cell.measurement_cell) {
      std::snprintf(line, sizeof(line), "%s: %d of %d planned poses could not be measured\n", m.method.c_str(),
                    m.unmeasured_poses, m.planned_poses);
      out << line;
    }
    if (m.after.e_xyz_mm.count == 0) {
      out << title << ": every identification failed\n\n";
      continue;
    }
    out << FormatAccuracyTable(m.after, title);
    std::snprintf(line, sizeof(line),
                  "  median cond %.4g; identification failed in %d of %d trials; %d of %d targets not converged\n\n",
                  m.median_condition_number, m.failed_trials, o.trials, m.unconverged_targets, m.after.e_xyz_mm.count);
    out << line;
  }
  // The paper's comparison is Solis & Wets against random selection; exchange, the other planner, is compared
  // the same way.
  const auto usable = [](const MethodResult* m) { return m != nullptr && m->after.e_xyz_mm.count > 0; };
  if (usable(random) && usable(solis_wets)) out << Improvement(*solis_wets, *random, "Solis & Wets");
  if (usable(random) && usable(exchange)) out << "\n" << Improvement(*exchange, *random, "Exchange");
  return out.str();
}

}  // namespace robocal
