// robocal experiment: the paper's simulated experiment, run locally by the core with robocal-experiment's flags.
#include "cli.h"
#include "command.h"
#include "experiment_flags.h"
#include "robocal/api/calibration.h"
#include "robocal/core/experiment.h"
#include "support.h"

namespace robocal::cli {

int Experiment(Invocation& in) {
  ExperimentOptions options;
  const std::string error = tools::ApplyExperimentFlags(in.own_flags, &options);
  if (!error.empty()) throw UsageError("experiment: " + error);
  std::ostream& err = in.err;
  options.progress = [&err](int done, int total) { err << "\rtrial " << done << " of " << total << std::flush; };
  const ExperimentResult result = RunExperiment(options);
  err << "\r" << Fixed(result.seconds, 1) << " s          \n";
  if (!in.json) {
    in.out << FormatExperimentReport(result);
    return kExitOk;
  }
  // The experiment's own report; its accuracies in the service's form (api::Accuracy: mm and degrees).
  nlohmann::json methods = nlohmann::json::array();
  for (const MethodResult& m : result.methods) {
    methods.push_back({{"method", m.method},
                       {"median_condition_number", api::Num(m.median_condition_number)},
                       {"after", api::ToWire(m.after)},
                       {"failed_trials", m.failed_trials},
                       {"unconverged_targets", m.unconverged_targets}});
  }
  PrintJson(in.out, nlohmann::json{{"robot", options.robot},
                                   {"measurement_type", options.measurement_type},
                                   {"num_configurations", options.num_configurations},
                                   {"trials", options.trials},
                                   {"num_validation", options.num_validation},
                                   {"seed", options.seed},
                                   {"before", api::ToWire(result.before)},
                                   {"methods", methods}});
  return kExitOk;
}

}  // namespace robocal::cli
