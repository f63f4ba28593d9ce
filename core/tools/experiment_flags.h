// The command line flags of the simulated experiment, shared by `robocal-experiment` and `robocal experiment`
// so that both take the same flags with the same checks and messages.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "robocal/core/experiment.h"

namespace robocal::tools {

/// The flags' part of --help, one line per flag (without --help itself).
extern const char* const kExperimentFlagsHelp;

/// Parses "--flag value" and "--flag=value" pairs (args without the program or command name, --help already
/// removed) into *options, then checks them with ExperimentOptions::IsValid. Returns "" when they are valid,
/// else a message naming the first bad flag ("--trials: 0 is out of range [1, 10000]").
std::string ParseExperimentFlags(const std::vector<std::string>& args, ExperimentOptions* options);
/// The same for flags already split (tools::SplitFlags, SplitCommandLine), e.g. by a command line that also has
/// flags of its own.
std::string ApplyExperimentFlags(const std::vector<std::pair<std::string, std::string>>& flags,
                                 ExperimentOptions* options);

}  // namespace robocal::tools
