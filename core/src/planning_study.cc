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
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"

namespace robocal {
namespace {

// One robot and measurement type, set up once and shared read-only by the workers.
struct Case {
  RobotModel model;
  MeasurementType type;
  ObservabilityOptions observability;  // the study's scaling: the optimisers' objective
  std::vector<Eigen::VectorXd> validation;
};

// Per seed of one case: condition numbers and predicted RMS position errors.
struct SeedResult {
  double start_cond = 0.0, start_rms = 0.0;
  std::vector<double> cond, rms;
  double exchange_cond = 0.0, exchange_rms = 0.0;
};

SeedResult RunSeed(const Case& c, const PlanningStudyOptions& options, std::uint64_t seed) {
  SeedResult r;
  // A plan that leaves E*'WE* singular predicts nothing (NaN, which the medians then show).
  auto rms = [&](const std::vector<Eigen::VectorXd>& plan) {
    const PredictedAccuracy predicted = PredictAccuracy(c.model, c.observability, plan, c.validation);
    return predicted.num_validation > 0 ? predicted.rms_position_mm : std::nan("");
  };
  for (int k_max : options.budgets) {
    SolisWetsOptions sw = SolisWetsOptions::Paper();
    sw.k_max = k_max;
    sw.seed = seed;
    const Plan plan = PlanSolisWets(c.model, options.num_configurations, c.observability, sw);
    if (r.cond.empty()) {
      // Same seed, same random starting set for every budget: the start is the first draw of the generator.
      r.start_cond = plan.summary.initial.condition_number;
      Rng rng(seed);
      r.start_rms = rms(RandomConfigurations(c.model, options.num_configurations, &rng));
    }
    r.cond.push_back(plan.summary.final.condition_number);
    r.rms.push_back(rms(plan.configurations));
  }
  if (options.exchange) {
    ExchangeOptions ex;
    ex.objective = ObservabilityIndex::kLogDet;
    ex.num_candidates = options.exchange_candidates;
    ex.seed = seed;
    const Plan plan = PlanExchange(c.model, options.num_configurations, c.observability, ex);
    r.exchange_cond = plan.summary.final.condition_number;
    r.exchange_rms = rms(plan.configurations);
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
  if (threads < 1 || threads > 256) return fail("threads must be in [1, 256]");
  return true;
}

double PlanningStudyRow::Ratio(int b) const { return start_condition_number / condition_number.at(b); }

double PlanningStudyRow::GainShare(int b) const {
  const double best = std::log(start_condition_number / condition_number.back());
  if (!(best > 0.0)) return std::nan("");
  return std::log(start_condition_number / condition_number.at(b)) / best;
}

PlanningStudyResult RunPlanningStudy(const PlanningStudyOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("PlanningStudyOptions: " + error);
  const auto start_time = std::chrono::steady_clock::now();

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

  PlanningStudyResult result;
  result.options = options;
  result.options.progress = nullptr;
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    const auto first = results.begin() + static_cast<std::ptrdiff_t>(ci) * options.seeds;
    auto median = [&](auto field) {
      std::vector<double> values;
      for (auto it = first; it != first + options.seeds; ++it) values.push_back(field(*it));
      return Median(values);
    };
    PlanningStudyRow row;
    row.robot = options.robots[ci / options.measurement_types.size()];
    row.measurement_type = cases[ci].type;
    row.num_parameters = static_cast<int>(cases[ci].observability.parameters.size());
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
    result.rows.push_back(std::move(row));
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
  return out.str();
}

}  // namespace robocal
