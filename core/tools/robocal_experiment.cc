// robocal-experiment: runs the paper's simulated experiment (plan, measure, identify, compensate, compare) and
// prints its table. Exit codes: 0 done, 1 the run failed, 2 bad command line.
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <string>

#include "robocal/core/experiment.h"

namespace {

constexpr const char* kUsage = R"(usage: robocal-experiment [options]

Simulates the paper's experiment in a virtual cell: per trial, a robot with new hidden geometric errors; M
measurement configurations planned by Solis & Wets, by random selection and by exchange; each plan measured
by a simulated laser tracker and identified; then random validation poses compensated on each calibration.
Prints E_xyz, E_cos and E_tot (mean, std, max, RP = mean + 3 std) before and after calibration, per
method, and the improvement of the planned configurations over random ones in percent.

options:
  --robot NAME           grinder5 (default), puma560 or ur5e
  --type TYPE            measurements: position, position_axis or pose (default pose)
  --configurations M     configurations per plan (default 10, the paper's)
  --trials N             independent trials, results pooled (default 10)
  --validation N         validation poses per trial (default 36, the paper's)
  --h-mm H               lever of E_tot = E_xyz + H * E_cos, mm (default 30)
  --seed S               seed of every random draw (default 1)
  --noise-mm SIGMA       tracker position noise per axis, 1-sigma, mm (default 0.015)
  --noise-deg SIGMA      tracker orientation noise per axis, 1-sigma, degrees (default 0.0057)
  --shots N              tracker shots per pose (default 10, the paper's)
  --help                 this text
)";

[[noreturn]] void Usage(const std::string& message) {
  std::cerr << "robocal-experiment: " << message << "\n(see robocal-experiment --help)\n";
  std::exit(2);
}

double ParseDouble(const std::string& flag, const std::string& text, double min) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno != 0 || !std::isfinite(value)) {
    Usage(flag + ": '" + text + "' is not a number");
  }
  if (value < min) Usage(flag + ": must be " + (min > 0.0 ? "positive" : "0 or more") + " (got " + text + ")");
  return value;
}

long long ParseInteger(const std::string& flag, const std::string& text, long long min, long long max) {
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno != 0) Usage(flag + ": '" + text + "' is not an integer");
  if (value < min || value > max) {
    Usage(flag + ": " + text + " is out of range [" + std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  return value;
}

}  // namespace

int main(int argc, char** argv) {
  robocal::ExperimentOptions options;
  for (int i = 1; i < argc; ++i) {
    std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") {
      std::cout << kUsage;
      return 0;
    }
    std::string value;
    const size_t equals = flag.find('=');
    if (flag.rfind("--", 0) == 0 && equals != std::string::npos) {
      value = flag.substr(equals + 1);
      flag = flag.substr(0, equals);
    } else if (i + 1 < argc) {
      value = argv[++i];
    } else {
      if (flag.rfind("--", 0) != 0) Usage("unexpected argument '" + flag + "'");
      Usage(flag + " needs a value");
    }
    if (flag == "--robot") {
      options.robot = value;
    } else if (flag == "--type") {
      if (!robocal::ParseMeasurementType(value, &options.measurement_type)) {
        Usage("--type: '" + value + "' is not position, position_axis or pose");
      }
    } else if (flag == "--configurations") {
      options.num_configurations = static_cast<int>(ParseInteger(flag, value, 1, 1000));
    } else if (flag == "--trials") {
      options.trials = static_cast<int>(ParseInteger(flag, value, 1, 10000));
    } else if (flag == "--validation") {
      options.num_validation = static_cast<int>(ParseInteger(flag, value, 1, 100000));
    } else if (flag == "--h-mm") {
      options.h_mm = ParseDouble(flag, value, 1e-9);
    } else if (flag == "--seed") {
      if (value.empty() || value[0] == '-') Usage("--seed: '" + value + "' is not a non-negative integer");
      errno = 0;
      char* end = nullptr;
      const unsigned long long seed = std::strtoull(value.c_str(), &end, 10);
      if (*end != '\0' || errno != 0) Usage("--seed: '" + value + "' is not a non-negative integer");
      options.seed = static_cast<std::uint64_t>(seed);
    } else if (flag == "--noise-mm") {
      options.cell.noise.position_mm = ParseDouble(flag, value, 0.0);
    } else if (flag == "--noise-deg") {
      options.cell.noise.orientation_rad = ParseDouble(flag, value, 0.0) * M_PI / 180.0;
    } else if (flag == "--shots") {
      options.cell.shots_per_pose = static_cast<int>(ParseInteger(flag, value, 1, 1000));
    } else {
      Usage("unknown option '" + flag + "'");
    }
  }
  std::string error;
  if (!options.IsValid(&error)) Usage(error);

  options.progress = [](int done, int total) { std::cerr << "\rtrial " << done << " of " << total << std::flush; };
  try {
    const robocal::ExperimentResult result = robocal::RunExperiment(options);
    std::cerr << "\r";
    std::cout << robocal::FormatExperimentReport(result);
    std::fprintf(stderr, "%.1f s\n", result.seconds);
  } catch (const std::exception& e) {
    std::cerr << "\nrobocal-experiment: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
