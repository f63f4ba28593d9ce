// The planners' study: random starting sets against the paper preset and longer budgets, and what each buys in
// predicted accuracy (see planning_study.h).
#include "robocal/core/planning_study.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "robocal/core/accuracy.h"
#include "robocal/core/error_model.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/virtual_cell.h"

namespace robocal {
namespace {

// One robot and measurement type, set up once and shared read-only by the workers.
struct Case {
  RobotModel model;
  MeasurementType type;
  ObservabilityOptions observability;  // the study's scaling: the optimisers' objective
  std::vector<Eigen::VectorXd> validation;
};

// What the objective comparison records of one plan of one seed.
struct Figures {
  double cond = 0.0, predicted = 0.0, simulated = 0.0;
};

// Per seed of one case: condition numbers and predicted RMS position errors; the objective comparison.
struct SeedResult {
  double start_cond = 0.0, start_rms = 0.0;
  std::vector<double> cond, rms;
  double exchange_cond = 0.0, exchange_rms = 0.0;
  Figures start;
  std::vector<Figures> objectives;  // solis_wets per objective, then exchange per objective
};

// The plan measured in seed's virtual cell (one shot per pose, the study's noise) and identified: the RMS error of
// the calibrated model's tool pose against the true robot's at the validation configurations, weighted as the
// predicted_error index weighs it. NaN when the identification fails.
double SimulatedError(const Case& c, const PlanningStudyOptions& options, std::uint64_t seed,
                      const std::vector<Eigen::VectorXd>& plan) {
  VirtualCellOptions cell_options;
  cell_options.seed = seed + kPlanningStudySimulationSeedOffset;
  cell_options.noise = options.noise;
  cell_options.shots_per_pose = 1;
  VirtualCell cell(c.model, cell_options);
  IdentificationOptions identification;
  identification.measurement_type = c.type;
  identification.noise = options.noise;
  identification.parameters = c.observability.parameters;
  const Calibration calibration = Identify(c.model, cell.MeasureAll(plan), identification);
  if (calibration.summary.termination == Termination::kFailure) return std::nan("");
  const double h = c.type == MeasurementType::kPosition ? 0.0 : c.observability.orientation_length_mm;
  KinematicsWorkspace ws(calibration.model);
  double sum = 0.0;
  for (const Eigen::VectorXd& q : c.validation) {
    const Transform predicted = ForwardKinematics(calibration.model, q, calibration.errors, &ws);
    const Transform truth = cell.TruePose(q);
    const double angle_rad = Eigen::AngleAxisd(truth.linear().transpose() * predicted.linear()).angle();
    sum += (predicted.translation() - truth.translation()).squaredNorm() + h * h * angle_rad * angle_rad;
  }
  return std::sqrt(sum / static_cast<double>(c.validation.size()));
}

SeedResult RunSeed(const Case& c, const PlanningStudyOptions& options, std::uint64_t seed) {
  SeedResult r;
  // A plan that leaves E*'WE* singular predicts nothing (NaN, which the medians then show).
  auto predict = [&](const std::vector<Eigen::VectorXd>& plan) {
    return PredictAccuracy(c.model, c.observability, plan, c.validation);
  };
  auto rms = [&](const std::vector<Eigen::VectorXd>& plan) {
    const PredictedAccuracy predicted = predict(plan);
    return predicted.num_validation > 0 ? predicted.rms_position_mm : std::nan("");
  };
  auto judge = [&](const Plan& plan) {
    Figures f;
    f.cond = plan.summary.final.condition_number;
    const PredictedAccuracy predicted = predict(plan.configurations);
    f.predicted = predicted.num_validation > 0 ? predicted.rms_error_mm : std::nan("");
    f.simulated = options.simulate ? SimulatedError(c, options, seed, plan.configurations) : std::nan("");
    return f;
  };
  Plan paper;  // the first budget's plan: the paper preset with the condition number
  for (int k_max : options.budgets) {
    SolisWetsOptions sw = SolisWetsOptions::Paper();
    sw.k_max = k_max;
    sw.seed = seed;
    Plan plan = PlanSolisWets(c.model, options.num_configurations, c.observability, sw);
    if (r.cond.empty()) {
      // Same seed, same random starting set for every budget: the start is the first draw of the generator.
      r.start_cond = plan.summary.initial.condition_number;
      Rng rng(seed);
      const auto start = RandomConfigurations(c.model, options.num_configurations, &rng);
      r.start_rms = rms(start);
      if (!options.objectives.empty()) {
        Plan start_plan;
        start_plan.configurations = start;
        start_plan.summary.final.condition_number = r.start_cond;
        r.start = judge(start_plan);
      }
    }
    r.cond.push_back(plan.summary.final.condition_number);
    r.rms.push_back(rms(plan.configurations));
    if (r.cond.size() == 1) paper = std::move(plan);
  }
  Plan exchange_log_det;
  if (options.exchange) {
    ExchangeOptions ex;
    ex.objective = ObservabilityIndex::kLogDet;
    ex.num_candidates = options.exchange_candidates;
    ex.seed = seed;
    exchange_log_det = PlanExchange(c.model, options.num_configurations, c.observability, ex);
    r.exchange_cond = exchange_log_det.summary.final.condition_number;
    r.exchange_rms = rms(exchange_log_det.configurations);
  }
  // The objective comparison; the plans above are reused where they are the same plan.
  for (ObservabilityIndex objective : options.objectives) {
    if (objective == ObservabilityIndex::kConditionNumber) {
      r.objectives.push_back(judge(paper));
      continue;
    }
    SolisWetsOptions sw = SolisWetsOptions::Paper();
    sw.k_max = options.budgets.front();
    sw.seed = seed;
    sw.objective = objective;
    sw.num_validation = options.objective_validation;
    r.objectives.push_back(judge(PlanSolisWets(c.model, options.num_configurations, c.observability, sw)));
  }
  if (options.exchange) {
    for (ObservabilityIndex objective : options.objectives) {
      if (objective == ObservabilityIndex::kLogDet) {
        r.objectives.push_back(judge(exchange_log_det));
        continue;
      }
      ExchangeOptions ex;
      ex.objective = objective;
      ex.num_candidates = options.exchange_candidates;
      ex.seed = seed;
      ex.num_validation = options.objective_validation;
      r.objectives.push_back(judge(PlanExchange(c.model, options.num_configurations, c.observability, ex)));
    }
  }
  return r;
}

std::string Fixed(double value, int decimals) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

std::string Pad(const std::string& text, size_t width) {
  return text.size() >= width ? text : std::string(width - text.size(), ' ') + text;
}

}  // namespace

bool PlanningStudyOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (robots.empty()) return fail("robots: at least one robot is needed");
  const std::vector<std::string> names = PresetNames();
  for (size_t i = 0; i < robots.size(); ++i) {
    if (std::find(names.begin(), names.end(), robots[i]) == names.end()) {
      std::string known;
      for (const std::string& name : names) known += (known.empty() ? "" : ", ") + name;
      return fail("robots[" + std::to_string(i) + "]: unknown robot '" + robots[i] + "' (known: " + known + ")");
    }
    if (std::find(robots.begin(), robots.begin() + i, robots[i]) != robots.begin() + i) {
      return fail("robots[" + std::to_string(i) + "]: '" + robots[i] + "' is listed twice");
    }
  }
  if (measurement_types.empty()) return fail("measurement_types: at least one type is needed");
  for (size_t i = 0; i < measurement_types.size(); ++i) {
    const auto end = measurement_types.begin() + static_cast<std::ptrdiff_t>(i);
    if (std::find(measurement_types.begin(), end, measurement_types[i]) != end) {
      return fail("measurement_types[" + std::to_string(i) + "]: '" + ToString(measurement_types[i]) +
                  "' is listed twice");
    }
  }
  if (num_configurations < 1 || num_configurations > 1000) return fail("num_configurations must be in [1, 1000]");
  if (seeds < 1 || seeds > 100000) return fail("seeds must be in [1, 100000]");
  if (budgets.empty()) return fail("budgets: at least one k_max is needed");
  for (size_t i = 0; i < budgets.size(); ++i) {
    if (budgets[i] < 1 || budgets[i] > 10000000) {
      return fail("budgets[" + std::to_string(i) + "]: k_max must be in [1, 10000000]");
    }
    if (i > 0 && budgets[i] <= budgets[i - 1]) {
      return fail("budgets[" + std::to_string(i) + "]: budgets must be strictly ascending");
    }
  }
  if (num_validation < 1 || num_validation > 1000000) return fail("num_validation must be in [1, 1000000]");
  if (!(noise.position_mm > 0.0) || !(noise.orientation_rad > 0.0) || !std::isfinite(noise.position_mm) ||
      !std::isfinite(noise.orientation_rad)) {
    return fail("noise: position_mm and orientation_rad must be positive and finite");
  }
  if (!(expected_translation_mm > 0.0) || !(expected_rotation_rad > 0.0) || !std::isfinite(expected_translation_mm) ||
      !std::isfinite(expected_rotation_rad)) {
    return fail("expected_translation_mm and expected_rotation_rad must be positive and finite");
  }
  if (exchange && (exchange_candidates < num_configurations || exchange_candidates > 1000000)) {
    return fail("exchange_candidates: " + std::to_string(exchange_candidates) + " must be in [num_configurations (" +
                std::to_string(num_configurations) + "), 1000000]");
  }
  for (size_t i = 0; i < objectives.size(); ++i) {
    const auto end = objectives.begin() + static_cast<std::ptrdiff_t>(i);
    if (std::find(objectives.begin(), end, objectives[i]) != end) {
      return fail("objectives[" + std::to_string(i) + "]: '" + ToString(objectives[i]) + "' is listed twice");
    }
  }
  if (objective_validation < 1 || objective_validation > 100000) {
    return fail("objective_validation must be in [1, 100000]");
  }
  if (threads < 1 || threads > 256) return fail("threads must be in [1, 256]");
  return true;
}

double PlanningStudyRow::Ratio(int b) const { return start_condition_number / condition_number.at(b); }

double PlanningStudyRow::GainShare(int b) const {
  const double best = std::log(start_condition_number / condition_number.back());
  if (!(best > 0.0)) return std::nan("");
  return std::log(start_condition_number / condition_number.at(b)) / best;
}

namespace {

// One case per robot and measurement type: its identifiable parameters (std::invalid_argument when the
// configurations give too few rows for them) and its validation configurations.
std::vector<Case> PlanningStudyCases(const PlanningStudyOptions& options) {
  std::vector<Case> cases;
  for (const std::string& robot : options.robots) {
    for (MeasurementType type : options.measurement_types) {
      Case c{Preset(robot), type, {}, {}};
      c.observability.measurement_type = type;
      c.observability.noise = options.noise;
      c.observability.scaling = options.scaling;
      c.observability.expected_translation_mm = options.expected_translation_mm;
      c.observability.expected_rotation_rad = options.expected_rotation_rad;
      IdentifiabilityOptions identifiability;
      identifiability.noise = options.noise;
      c.observability.parameters = FindIdentifiableParameters(c.model, type, identifiability).identifiable;
      const int rows = options.num_configurations * MeasurementRows(type);
      const int parameters = static_cast<int>(c.observability.parameters.size());
      if (rows < parameters) {
        throw std::invalid_argument("PlanningStudyOptions: num_configurations: " +
                                    std::to_string(options.num_configurations) + " " + ToString(type) +
                                    " measurements give " + std::to_string(rows) + " rows for the " +
                                    std::to_string(parameters) + " identifiable parameters of " + robot);
      }
      Rng rng(options.first_seed + kPlanningStudyValidationSeedOffset);
      c.validation = RandomConfigurations(c.model, options.num_validation, &rng);
      cases.push_back(std::move(c));
    }
  }
  return cases;
}

// Every (case, seed) run, run i being case i / seeds with seed i % seeds, on options.threads threads; the first
// failure rethrown once all have stopped.
std::vector<SeedResult> RunPlanningStudySeeds(const std::vector<Case>& cases, const PlanningStudyOptions& options) {
  // Every (case, seed) run is independent and seeded by itself, so the workers' order does not matter.
  const int runs = static_cast<int>(cases.size()) * options.seeds;
  std::vector<SeedResult> results(runs);
  std::atomic<int> next{0};
  std::mutex mutex;  // guards done, failure and the progress callback
  int done = 0;
  std::exception_ptr failure;
  auto work = [&] {
    for (int i = next++; i < runs; i = next++) {
      try {
        results[i] = RunSeed(cases[i / options.seeds], options, options.first_seed + i % options.seeds);
        if (options.progress) {
          std::lock_guard<std::mutex> lock(mutex);
          options.progress(++done, runs);
        }
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!failure) failure = std::current_exception();
        next = runs;  // hand out no more runs; the others finish theirs
      }
    }
  };
  std::vector<std::thread> workers;
  for (int t = 1; t < std::min(options.threads, runs); ++t) workers.emplace_back(work);
  work();
  for (std::thread& w : workers) w.join();
  if (failure) std::rethrow_exception(failure);
  return results;
}

// A case's row: the medians over its seeds' results (options.seeds of them from `first`).
PlanningStudyRow PlanningStudyRowOf(const Case& c, const std::string& robot,
                                    std::vector<SeedResult>::const_iterator first,
                                    const PlanningStudyOptions& options) {
  auto median = [&](auto field) {
    std::vector<double> values;
    for (auto it = first; it != first + options.seeds; ++it) values.push_back(field(*it));
    return Median(values);
  };
  PlanningStudyRow row;
  row.robot = robot;
  row.measurement_type = c.type;
  row.num_parameters = static_cast<int>(c.observability.parameters.size());
  row.start_condition_number = median([](const SeedResult& r) { return r.start_cond; });
  row.start_rms_position_mm = median([](const SeedResult& r) { return r.start_rms; });
  for (size_t b = 0; b < options.budgets.size(); ++b) {
    row.condition_number.push_back(median([b](const SeedResult& r) { return r.cond[b]; }));
    row.rms_position_mm.push_back(median([b](const SeedResult& r) { return r.rms[b]; }));
  }
  if (options.exchange) {
    row.exchange_condition_number = median([](const SeedResult& r) { return r.exchange_cond; });
    row.exchange_rms_position_mm = median([](const SeedResult& r) { return r.exchange_rms; });
  }
  if (!options.objectives.empty()) {
    row.start_predicted_rms_error_mm = median([](const SeedResult& r) { return r.start.predicted; });
    row.start_simulated_rms_error_mm = median([](const SeedResult& r) { return r.start.simulated; });
  }
  const size_t nobj = options.objectives.size();
  for (size_t k = 0; k < nobj * (options.exchange ? 2 : 1); ++k) {
    ObjectivePlanResult plan;
    plan.objective = options.objectives[k % nobj];
    plan.method = k < nobj ? "solis_wets" : "exchange";
    plan.condition_number = median([k](const SeedResult& r) { return r.objectives[k].cond; });
    plan.predicted_rms_error_mm = median([k](const SeedResult& r) { return r.objectives[k].predicted; });
    plan.simulated_rms_error_mm = median([k](const SeedResult& r) { return r.objectives[k].simulated; });
    row.objectives.push_back(std::move(plan));
  }
  return row;
}

}  // namespace

PlanningStudyResult RunPlanningStudy(const PlanningStudyOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("PlanningStudyOptions: " + error);
  const auto start_time = std::chrono::steady_clock::now();
  const std::vector<Case> cases = PlanningStudyCases(options);
  const std::vector<SeedResult> results = RunPlanningStudySeeds(cases, options);

  PlanningStudyResult result;
  result.options = options;
  result.options.progress = nullptr;
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    const auto first = results.begin() + static_cast<std::ptrdiff_t>(ci) * options.seeds;
    result.rows.push_back(
        PlanningStudyRowOf(cases[ci], options.robots[ci / options.measurement_types.size()], first, options));
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return result;
}

std::string FormatPlanningStudy(const PlanningStudyResult& result) {
  const PlanningStudyOptions& o = result.options;
  const size_t nb = o.budgets.size();
  ObservabilityOptions scaling;
  scaling.noise = o.noise;
  scaling.scaling = o.scaling;
  scaling.expected_translation_mm = o.expected_translation_mm;
  scaling.expected_rotation_rad = o.expected_rotation_rad;
  std::ostringstream out;
  out << "Planning study: M = " << o.num_configurations << ", medians over " << o.seeds << " seeds (from "
      << o.first_seed << "), " << scaling.ScalingDescription() << "; paper preset with k_max";
  for (int k : o.budgets) out << " " << k;
  out << "\n\nCondition number of E* (random start -> k_max ...)";
  if (o.exchange) out << "; exchange with log det as objective";
  out << "\n" << Pad("robot", 10) << Pad("type", 15) << Pad("L", 4) << Pad("start", 10);
  for (int k : o.budgets) out << Pad("k=" + std::to_string(k), 10);
  if (o.exchange) out << Pad("exch", 10);
  out << Pad("ratio", 8) << Pad("gain share", 12) << "\n";
  for (const PlanningStudyRow& row : result.rows) {
    out << Pad(row.robot, 10) << Pad(ToString(row.measurement_type), 15) << Pad(std::to_string(row.num_parameters), 4)
        << Pad(Fixed(row.start_condition_number, 2), 10);
    for (size_t b = 0; b < nb; ++b) out << Pad(Fixed(row.condition_number[b], 2), 10);
    if (o.exchange) out << Pad(Fixed(row.exchange_condition_number, 2), 10);
    const double ratio = row.Ratio(0), share = nb > 1 ? row.GainShare(0) : std::nan("");
    out << Pad(std::isfinite(ratio) ? Fixed(ratio, 2) + "x" : "-", 8);
    out << Pad(std::isfinite(share) ? Fixed(100.0 * share, 0) + " %" : "-", 12) << "\n";
  }
  out << "ratio: random start / k_max " << o.budgets.front() << ".";
  if (nb > 1) {
    out << " gain share: ln(start / k_max " << o.budgets.front() << ") / ln(start / k_max " << o.budgets.back()
        << "), the share of the best gain found that k_max " << o.budgets.front() << " reaches.";
  }
  out << "\n";

  out << "\nPredicted RMS position error after calibration, um (tracker noise only, " << o.num_validation
      << " random validation configurations)\n";
  out << Pad("robot", 10) << Pad("type", 15) << Pad("start", 10);
  for (int k : o.budgets) out << Pad("k=" + std::to_string(k), 10);
  if (o.exchange) out << Pad("exch", 10);
  out << "\n";
  for (const PlanningStudyRow& row : result.rows) {
    out << Pad(row.robot, 10) << Pad(ToString(row.measurement_type), 15)
        << Pad(Fixed(1000.0 * row.start_rms_position_mm, 1), 10);
    for (size_t b = 0; b < nb; ++b) out << Pad(Fixed(1000.0 * row.rms_position_mm[b], 1), 10);
    if (o.exchange) out << Pad(Fixed(1000.0 * row.exchange_rms_position_mm, 1), 10);
    out << "\n";
  }
  if (o.objectives.empty()) return out.str();

  // The objectives compared: "predicted / simulated" per plan, um.
  auto um = [](double mm) { return std::isfinite(mm) ? Fixed(1000.0 * mm, 1) : std::string("-"); };
  auto pair = [&](double predicted, double simulated) {
    return o.simulate ? um(predicted) + " / " + um(simulated) : um(predicted);
  };
  const size_t width = o.simulate ? 15 : 9;
  out << "\nObjectives compared: RMS error after calibration at the " << o.num_validation
      << " validation configurations, um, " << (o.simulate ? "predicted / simulated" : "predicted")
      << " (position; types that observe orientation add 30 mm x orientation)\n";
  out << Pad("robot", 10) << Pad("type", 15) << Pad("random", width);
  for (const ObjectivePlanResult& plan : result.rows.front().objectives) {
    const std::string method = plan.method == "exchange" ? "ex " : "sw ";
    out << Pad(method + ToString(plan.objective),
               std::max<size_t>(width, 4 + std::string(ToString(plan.objective)).size()));
  }
  out << "\n";
  for (const PlanningStudyRow& row : result.rows) {
    out << Pad(row.robot, 10) << Pad(ToString(row.measurement_type), 15)
        << Pad(pair(row.start_predicted_rms_error_mm, row.start_simulated_rms_error_mm), width);
    for (const ObjectivePlanResult& plan : row.objectives) {
      out << Pad(pair(plan.predicted_rms_error_mm, plan.simulated_rms_error_mm),
                 std::max<size_t>(width, 4 + std::string(ToString(plan.objective)).size()));
    }
    out << "\n";
  }
  out << "sw: the paper preset (k_max " << o.budgets.front() << ") with that objective; ex: the exchange optimiser ("
      << o.exchange_candidates << " candidates). predicted_error plans optimise " << o.objective_validation
      << " validation configurations of their own.";
  if (o.simulate) {
    out << " Simulated: one virtual cell per seed, one shot per pose, the plan identified, the calibrated model against"
           " the true robot.";
  }
  out << "\n";
  return out.str();
}

}  // namespace robocal
