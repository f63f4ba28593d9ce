// The `robocal` command table's types: one Command per subcommand (its words, positional arguments, options,
// help and the function that runs it), the Invocation a command runs with, and the commands of each family
// (robot_commands.cc, plan_commands.cc, campaign_commands.cc, calibration_commands.cc,
// experiment_command.cc). The table itself is in commands.cc, the help texts in help.cc.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "flags.h"
#include "help.h"
#include "robocal/api/wire.h"
#include "robocal/client/client.h"

namespace robocal::cli {

/// A command line the table refuses (exit 2); what() is the message for the user.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// An option of a command: "--count" with value name "M", or a switch (value nullptr) such as "--async".
struct OptionSpec {
  const char* name;
  const char* value = nullptr;
};

struct Invocation;

/// One subcommand: everything the parser, the help and the dispatcher know about it.
struct Command {
  /// Its words: "robots", "robot register", "plan get".
  std::string name;
  /// Its positional arguments after the words, by the names the usage line gives them.
  std::vector<std::string> arguments;
  /// The options it takes besides the global ones; any other option is a usage error naming it.
  std::vector<OptionSpec> options;
  const HelpText* help;
  int (*run)(Invocation&);
  /// Runs without a server, and takes the flags of its own parser instead of `options` (the experiment, whose
  /// flags are robocal-experiment's: tools::ApplyExperimentFlags checks them).
  bool local = false;
  /// The help of those flags (appended to its help).
  const char* const* flags_help = nullptr;
};

/// The table, in the order of `robocal --help`.
const std::vector<Command>& Commands();

/// "Usage: robocal plan ROBOT [--count M] ..." followed by the command's help text.
std::string CommandHelp(const Command& command);

/// One run of a command: its arguments and options as given, the client (null for a local command), the
/// streams.
struct Invocation {
  const Command& command;
  /// The positional arguments after the command's words (as many as command.arguments).
  std::vector<std::string> args;
  /// The command's options as given (a switch's value is ""); the last of a repeated option wins.
  std::map<std::string, std::string> options;
  /// A local command's flags, in order, for its own parser.
  std::vector<std::pair<std::string, std::string>> own_flags;
  /// --json: print the typed resource instead of a table.
  bool json = false;
  client::Client* client = nullptr;
  std::ostream& out;
  std::ostream& err;

  bool Has(const std::string& option) const { return options.count(option) > 0; }
  std::string Option(const std::string& option, const std::string& fallback = "") const;
  /// An integer in [min, max], fallback when absent (tools::ParseIntegerFlag: a message naming the option).
  long long Integer(const std::string& option, long long fallback, long long min, long long max) const;
  /// A finite number >= min, fallback when absent.
  double Number(const std::string& option, double fallback, double min) const;
  std::uint64_t Seed(const std::string& option, std::uint64_t fallback) const;
  /// The value of an enum option by its wire name ("--type pose"), fallback when absent; a usage error naming
  /// the option and the names it takes otherwise.
  template <typename E>
  E Enum(const std::string& option, E fallback) const {
    return Has(option) ? ParseEnum<E>(option, Option(option)) : fallback;
  }
  client::Client& Client() const;

  /// `text` (an argument or option value) read as the wire name of an enum; a usage error naming `what`.
  template <typename E>
  static E ParseEnum(const std::string& what, const std::string& text) {
    E value{};
    if (api::FromWireName(text, &value)) return value;
    std::string names;
    for (const std::string& n : api::WireNames<E>()) names += (names.empty() ? "" : ", ") + n;
    throw UsageError(what + ": '" + text + "' is not one of " + names);
  }
};

/// Prints `resource` as the API's JSON (its to_json: the same shape the service sends).
template <typename T>
void PrintJson(std::ostream& out, const T& resource) {
  out << nlohmann::json(resource).dump(2) << "\n";
}

// The commands, by family.
int Robots(Invocation& in);
int RobotRegister(Invocation& in);
int RobotFromCalibration(Invocation& in);
int RobotImport(Invocation& in);
int Export(Invocation& in);
int RobotGet(Invocation& in);
int RobotDelete(Invocation& in);
int RobotForward(Invocation& in);
int CellCreate(Invocation& in);
int CellList(Invocation& in);
int CellGet(Invocation& in);
int CellDelete(Invocation& in);
int CellCheck(Invocation& in);
int Plan(Invocation& in);
int PlanGet(Invocation& in);
int OperationWait(Invocation& in);
int OperationGet(Invocation& in);
int OperationCancel(Invocation& in);
int CampaignCreate(Invocation& in);
int CampaignList(Invocation& in);
int CampaignGet(Invocation& in);
int CampaignForward(Invocation& in);
int Upload(Invocation& in);
int Measurements(Invocation& in);
int Fit(Invocation& in);
int Compensate(Invocation& in);
int CompensateProgram(Invocation& in);
int Evaluate(Invocation& in);
int Report(Invocation& in);
int Iso9283Plan(Invocation& in);
int Check(Invocation& in);
int RobotHistory(Invocation& in);
int RobotCalibrate(Invocation& in);
int RobotRollback(Invocation& in);
int Iso9283Report(Invocation& in);
int Experiment(Invocation& in);

}  // namespace robocal::cli
