// The `robocal` command line: every subcommand, kept apart from main() so that it reads its arguments,
// environment and streams as parameters.
#pragma once

#include <map>
#include <ostream>
#include <string>
#include <vector>

namespace robocal::cli {

/// Exit codes (documented in --help and docs/client.md).
inline constexpr int kExitOk = 0;
inline constexpr int kExitServiceError = 1;
inline constexpr int kExitUsage = 2;
inline constexpr int kExitConnection = 3;

/// Runs one command line (args without argv[0]); env supplies ROBOCAL_SERVER, ROBOCAL_TOKEN and
/// ROBOCAL_CA_CERT. Results go to `out`, messages and progress to `err`. Returns the exit code.
int Run(const std::vector<std::string>& args, const std::map<std::string, std::string>& env, std::ostream& out,
        std::ostream& err);

}  // namespace robocal::cli
