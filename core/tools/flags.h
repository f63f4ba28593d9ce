// Command line flags of the core's tools: "--flag value" / "--flag=value" splitting and number parsing with
// messages that name the flag. Shared by robocal-experiment, robocal-plan-study and the `robocal` CLI.
#pragma once

#include <cstdint>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace robocal::tools {

/// A bad flag; what() is the message for the user, naming the flag.
struct BadFlag : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Splits args (without the program name) into (flag, value) pairs. A flag in `switches` takes no value (its
/// value is ""); every other flag takes the next argument or the text after '='. Throws BadFlag for a
/// positional argument, a missing value or a value given to a switch.
std::vector<std::pair<std::string, std::string>> SplitFlags(const std::vector<std::string>& args,
                                                            const std::set<std::string>& switches = {});

/// A command line whose positional arguments and flags mix ("plan grinder5 --count 10 --json").
struct CommandLine {
  /// Arguments that are neither a flag nor a flag's value, in order.
  std::vector<std::string> positional;
  /// (flag, value) pairs in order, as SplitFlags splits them.
  std::vector<std::pair<std::string, std::string>> flags;
};
/// Splits args as SplitFlags does, taking every argument that does not start with "--" (and is not a flag's
/// value) as positional. Throws BadFlag for a missing value or a value given to a switch.
CommandLine SplitCommandLine(const std::vector<std::string>& args, const std::set<std::string>& switches = {});

/// A finite number >= min. Throws BadFlag naming `flag`.
double ParseDoubleFlag(const std::string& flag, const std::string& text, double min);
/// An integer in [min, max]. Throws BadFlag naming `flag`.
long long ParseIntegerFlag(const std::string& flag, const std::string& text, long long min, long long max);
/// A non-negative 64-bit integer. Throws BadFlag naming `flag`.
std::uint64_t ParseSeedFlag(const std::string& flag, const std::string& text);
/// Comma-separated items ("a,b,c"); empty items are an error. Throws BadFlag naming `flag`.
std::vector<std::string> SplitList(const std::string& flag, const std::string& text);

}  // namespace robocal::tools
