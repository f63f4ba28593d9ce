// robocal-plan-study: the planners' study of docs/planning.md as a command (RunPlanningStudy). Exit codes: 0 done,
// 1 the run failed, 2 bad command line (including options the study cannot run, e.g. too few configurations).
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "flags.h"
#include "robocal/core/error_model.h"
#include "robocal/core/planning_study.h"
#include "robocal/core/units.h"

namespace {

constexpr const char* kUsage = R"(usage: robocal-plan-study [options]

For every robot and measurement type: N random starting sets of M configurations (--seeds N, one set per
seed; --configurations M), each optimised by the paper's Solis & Wets preset with every k_max of --budgets,
and (unless --no-exchange) a plan by the exchange optimiser with log det as objective. Prints the median
condition numbers, the ratio random start / first budget, the gain share (the share of the best gain found,
by the last budget, in ln(cond) that the first budget reaches), and the predicted RMS position error after
calibration of each plan (tracker noise only). Then the objectives compared: per objective of --objectives a
plan by the paper preset (k_max: the first budget) and one by exchange, each judged by its predicted and its
simulated RMS error after calibration (measured in a virtual cell, identified, compared with the true robot).
Same flags, same figures.

options:
  --robots LIST             comma-separated presets (default grinder5,puma560,ur5e)
  --types LIST              comma-separated: position, position_axis, pose (default position,pose)
  --configurations M        configurations per plan (default 10, the paper's)
  --seeds N                 random starting sets per robot and type (default 20)
  --first-seed S            seeds S .. S+N-1 (default 1)
  --budgets LIST            k_max values, strictly ascending (default 100,1000,10000; 100 is the paper's)
  --scaling NAME            column_norm (default), expected_deviation or none
  --noise-mm SIGMA          tracker position noise per axis, 1-sigma, mm (default 0.015); weights E*'s rows
  --noise-deg SIGMA         tracker orientation noise per axis, 1-sigma, degrees (default 0.0057)
  --expected-mm SIZE        expected size of length errors for expected_deviation, mm (default 0.1)
  --expected-deg SIZE       expected size of angle errors for expected_deviation, degrees (default 0.0573)
  --validation N            validation configurations of the predicted accuracy (default 200)
  --exchange-candidates N   candidate pool of the exchange optimiser (default 2000)
  --no-exchange             skip the exchange optimiser
  --objectives LIST         objectives compared: condition_number, o1..o5, log_det, predicted_error
                            (default condition_number,log_det,predicted_error); "none" skips the comparison
  --objective-validation N  validation configurations predicted_error plans optimise (default 50)
  --no-simulation           compare the objectives on predicted accuracy only
  --threads N               worker threads, 1..256 (default: the machine's cores); results do not depend on it
  --help, -h                this text
)";

void Apply(const std::string& flag, const std::string& value, robocal::PlanningStudyOptions* o) {
  using namespace robocal::tools;
  if (flag == "--robots") {
    o->robots = SplitList(flag, value);
  } else if (flag == "--types") {
    o->measurement_types.clear();
    for (const std::string& item : SplitList(flag, value)) {
      robocal::MeasurementType type;
      if (!robocal::ParseMeasurementType(item, &type)) {
        throw BadFlag(flag + ": '" + item + "' is not position, position_axis or pose");
      }
      o->measurement_types.push_back(type);
    }
  } else if (flag == "--configurations") {
    o->num_configurations = static_cast<int>(ParseIntegerFlag(flag, value, 1, 1000));
  } else if (flag == "--seeds") {
    o->seeds = static_cast<int>(ParseIntegerFlag(flag, value, 1, 100000));
  } else if (flag == "--first-seed") {
    o->first_seed = ParseSeedFlag(flag, value);
  } else if (flag == "--budgets") {
    o->budgets.clear();
    for (const std::string& item : SplitList(flag, value)) {
      o->budgets.push_back(static_cast<int>(ParseIntegerFlag(flag, item, 1, 10000000)));
    }
  } else if (flag == "--scaling") {
    if (!robocal::ParseColumnScaling(value, &o->scaling)) {
      throw BadFlag(flag + ": '" + value + "' is not column_norm, expected_deviation or none");
    }
  } else if (flag == "--noise-mm") {
    o->noise.position_mm = ParseDoubleFlag(flag, value, 1e-12);
  } else if (flag == "--noise-deg") {
    o->noise.orientation_rad = ParseDoubleFlag(flag, value, 1e-12) * robocal::kRadPerDeg;
  } else if (flag == "--expected-mm") {
    o->expected_translation_mm = ParseDoubleFlag(flag, value, 1e-12);
  } else if (flag == "--expected-deg") {
    o->expected_rotation_rad = ParseDoubleFlag(flag, value, 1e-12) * robocal::kRadPerDeg;
  } else if (flag == "--validation") {
    o->num_validation = static_cast<int>(ParseIntegerFlag(flag, value, 1, 1000000));
  } else if (flag == "--exchange-candidates") {
    o->exchange_candidates = static_cast<int>(ParseIntegerFlag(flag, value, 1, 1000000));
  } else if (flag == "--no-exchange") {
    o->exchange = false;
  } else if (flag == "--objectives") {
    o->objectives.clear();
    if (value == "none") return;
    for (const std::string& item : SplitList(flag, value)) {
      robocal::ObservabilityIndex index;
      if (!robocal::ParseObservabilityIndex(item, &index)) {
        throw BadFlag(flag + ": '" + item + "' is not condition_number, o1..o5, log_det or predicted_error");
      }
      o->objectives.push_back(index);
    }
  } else if (flag == "--objective-validation") {
    o->objective_validation = static_cast<int>(ParseIntegerFlag(flag, value, 1, 100000));
  } else if (flag == "--no-simulation") {
    o->simulate = false;
  } else if (flag == "--threads") {
    o->threads = static_cast<int>(ParseIntegerFlag(flag, value, 1, 256));
  } else {
    throw BadFlag("unknown option '" + flag + "'");
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    }
  }
  robocal::PlanningStudyOptions options;
  options.threads = static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 256u));
  std::string error;
  try {
    const auto flags = robocal::tools::SplitFlags(args, {"--no-exchange", "--no-simulation"});
    for (const auto& [flag, value] : flags) Apply(flag, value, &options);
    if (options.exchange && options.exchange_candidates < options.num_configurations) {
      throw robocal::tools::BadFlag("--exchange-candidates: " + std::to_string(options.exchange_candidates) +
                                    " candidates cannot give " + std::to_string(options.num_configurations) +
                                    " configurations (--configurations)");
    }
    options.IsValid(&error);
  } catch (const robocal::tools::BadFlag& e) {
    error = e.what();
  }
  if (!error.empty()) {
    std::cerr << "robocal-plan-study: " << error << "\n(see robocal-plan-study --help)\n";
    return 2;
  }
  // The progress line is overwritten in place and cleared before the results.
  options.progress = [](int done, int total) { std::cerr << "\rrun " << done << " of " << total << std::flush; };
  try {
    const robocal::PlanningStudyResult result = robocal::RunPlanningStudy(options);
    std::cerr << "\r                              \r";
    std::cout << robocal::FormatPlanningStudy(result);
    std::fprintf(stderr, "%.1f s\n", result.seconds);
  } catch (const std::invalid_argument& e) {  // options the study cannot run, e.g. too few configurations
    std::cerr << "\nrobocal-plan-study: " << e.what() << "\n(see robocal-plan-study --help)\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "\nrobocal-plan-study: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
