// robocal-experiment: runs the paper's simulated experiment (plan, measure, identify, compensate, compare) and
// prints its table. Exit codes: 0 done, 1 the run failed, 2 bad command line. The flags are shared with
// `robocal experiment` (experiment_flags.h).
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "experiment_flags.h"
#include "robocal/core/experiment.h"

namespace {

constexpr const char* kUsage = R"(usage: robocal-experiment [options]

Simulates the paper's experiment in a virtual cell: per trial, a robot with new hidden geometric errors; M
measurement configurations planned by Solis & Wets, by random selection and by exchange; each plan measured
by a simulated laser tracker and identified; then random validation poses compensated on each calibration.
Prints E_xyz, E_cos and E_tot (mean, std, max, RP = mean + 3 std) before and after calibration, per
method, and the improvement of the planned configurations over random ones in percent.

options:
)";

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") {
      std::cout << kUsage << robocal::tools::kExperimentFlagsHelp << "  --help                 this text\n";
      return 0;
    }
  }
  robocal::ExperimentOptions options;
  const std::string error = robocal::tools::ParseExperimentFlags(args, &options);
  if (!error.empty()) {
    std::cerr << "robocal-experiment: " << error << "\n(see robocal-experiment --help)\n";
    return 2;
  }

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
