// `robocal`'s command line: splits it (tools::SplitCommandLine, the core tools' flag parser), finds the command
// in the table (commands.cc), refuses options the command does not take, and turns what a command throws into
// the exit codes.
#include "cli.h"

#include <set>
#include <sstream>

#include "command.h"

namespace robocal::cli {
namespace {

// Valid for every command.
const std::set<std::string> kGlobalValueOptions = {"--server", "--token", "--ca-cert"};
const std::set<std::string> kGlobalSwitches = {"--insecure", "--json", "--help"};

bool IsGlobal(const std::string& option) {
  return kGlobalValueOptions.count(option) > 0 || kGlobalSwitches.count(option) > 0;
}

// The options that take no value, of any command: the splitter must know them before it knows the command.
std::set<std::string> Switches() {
  std::set<std::string> switches = kGlobalSwitches;
  for (const Command& command : Commands()) {
    for (const OptionSpec& option : command.options) {
      if (!option.value) switches.insert(option.name);
    }
  }
  return switches;
}

std::vector<std::string> Words(const std::string& name) {
  std::vector<std::string> words;
  std::istringstream in(name);
  for (std::string word; in >> word;) words.push_back(word);
  return words;
}

bool StartsWith(const std::vector<std::string>& positional, const std::vector<std::string>& words) {
  if (positional.size() < words.size()) return false;
  for (std::size_t i = 0; i < words.size(); ++i) {
    if (positional[i] != words[i]) return false;
  }
  return true;
}

// Whether `count` positional arguments fit the command: as many as it names, or, when its last one is a list
// ("FILE..."), at least as many.
bool ArgumentsFit(const Command& command, std::size_t count) {
  const std::vector<std::string>& names = command.arguments;
  const bool list = !names.empty() && names.back().ends_with("...");
  return list ? count >= names.size() : count == names.size();
}

// The command the positional arguments name: of the commands whose words start them, the longest one whose
// argument count fits ("plan get P" is `plan get`, "plan get" plans for a robot named "get"), else the longest
// one (to report its usage); null if none.
const Command* Find(const std::vector<std::string>& positional) {
  const Command* fitting = nullptr;
  const Command* longest = nullptr;
  std::size_t fitting_words = 0, longest_words = 0;
  for (const Command& command : Commands()) {
    const std::vector<std::string> words = Words(command.name);
    if (!StartsWith(positional, words)) continue;
    if (words.size() > longest_words) longest = &command, longest_words = words.size();
    if (ArgumentsFit(command, positional.size() - words.size()) && words.size() > fitting_words) {
      fitting = &command, fitting_words = words.size();
    }
  }
  return fitting ? fitting : longest;
}

std::vector<const Command*> Family(const std::string& word) {
  std::vector<const Command*> family;
  for (const Command& command : Commands()) {
    if (Words(command.name)[0] == word) family.push_back(&command);
  }
  return family;
}

std::string MainHelp() {
  std::string text = help::kIntro;
  for (const Command& command : Commands()) {
    std::string line = "  " + command.name;
    for (const std::string& argument : command.arguments) line += " " + argument;
    if (command.local) line += " [options]";
    line += line.size() < 33 ? std::string(33 - line.size(), ' ') : "\n" + std::string(33, ' ');
    text += line + command.help->summary + "\n";
  }
  return text + help::kGlobal;
}

// `robocal WORDS --help`: a family's commands ("campaign"), one command ("campaign list"), else the main help.
std::string HelpFor(const std::vector<std::string>& positional) {
  if (positional.size() == 1) {
    std::string text;
    for (const Command* command : Family(positional[0])) {
      if (!text.empty()) text += "\n";
      text += CommandHelp(*command);
    }
    if (!text.empty()) return text;
  }
  const Command* command = Find(positional);
  return command ? CommandHelp(*command) : MainHelp();
}

std::string Usage(const Command& command) {
  const std::string help = CommandHelp(command);
  return help.substr(0, help.find('\n'));
}

// The command of a command line, with its arguments and options checked against its entry.
Invocation Resolve(const tools::CommandLine& line, std::ostream& out, std::ostream& err) {
  if (line.positional.empty()) throw UsageError("no command");
  const Command* command = Find(line.positional);
  if (!command) {
    std::string family;
    for (const Command* c : Family(line.positional[0])) {
      const std::vector<std::string> words = Words(c->name);
      // A command with two forms ("robot register FILE.json", "robot register --from-calibration") is named once.
      if (words.size() < 2 || (", " + family + ",").find(", " + words[1] + ",") != std::string::npos) continue;
      if (!family.empty()) family += ", ";
      family += words[1];
    }
    if (family.empty()) throw UsageError("unknown command " + line.positional[0]);
    throw UsageError("unknown command " + line.positional[0] + " " +
                     (line.positional.size() > 1 ? line.positional[1] : "") + " (" + line.positional[0] +
                     " commands: " + family + ")");
  }
  // Options first: an option the command does not take has taken the next argument as its value, so the
  // argument count would be wrong too, and the option is what to name.
  std::vector<std::pair<std::string, std::string>> own_flags;
  std::map<std::string, std::string> options;
  for (const auto& [flag, value] : line.flags) {
    if (IsGlobal(flag)) continue;
    if (command->local) {
      own_flags.emplace_back(flag, value);
      continue;
    }
    bool allowed = false;
    std::string names;
    for (const OptionSpec& option : command->options) {
      allowed = allowed || flag == option.name;
      if (!names.empty()) names += ", ";
      names += option.name;
    }
    if (!allowed) {
      throw UsageError(command->name + " does not take the option " + flag +
                       (names.empty() ? " (it takes only the global options)" : " (its options: " + names + ")"));
    }
    options[flag] = value;
  }
  const std::size_t words = Words(command->name).size();
  if (!ArgumentsFit(*command, line.positional.size() - words)) {
    throw UsageError("expected: " + Usage(*command).substr(std::string("Usage: ").size()));
  }
  Invocation in{*command, {line.positional.begin() + static_cast<long>(words), line.positional.end()}, {}, {},
                false, nullptr, out, err};
  in.own_flags = std::move(own_flags);
  in.options = std::move(options);
  return in;
}

std::string Last(const tools::CommandLine& line, const std::string& flag, const std::string& fallback) {
  std::string value = fallback;
  for (const auto& [name, v] : line.flags) {
    if (name == flag) value = v;
  }
  return value;
}

bool HasFlag(const tools::CommandLine& line, const std::string& flag) {
  for (const auto& entry : line.flags) {
    if (entry.first == flag) return true;
  }
  return false;
}

client::ClientOptions ClientOptionsOf(const tools::CommandLine& line, const std::map<std::string, std::string>& env,
                                      std::ostream& err) {
  client::ClientOptions options;
  if (auto it = env.find("ROBOCAL_SERVER"); it != env.end() && !it->second.empty()) options.server_url = it->second;
  if (auto it = env.find("ROBOCAL_TOKEN"); it != env.end()) options.bearer_token = it->second;
  if (auto it = env.find("ROBOCAL_CA_CERT"); it != env.end()) options.ca_cert_file = it->second;
  options.server_url = Last(line, "--server", options.server_url);
  options.bearer_token = Last(line, "--token", options.bearer_token);
  options.ca_cert_file = Last(line, "--ca-cert", options.ca_cert_file);
  if (HasFlag(line, "--insecure")) {
    options.verify_tls = false;
    err << "robocal: WARNING: --insecure: the server's TLS certificate is not verified; anyone on the network "
           "path can pose as the server and read the token\n";
  }
  std::string error;
  if (!options.IsValid(&error)) throw UsageError(error);
  return options;
}

}  // namespace

int Run(const std::vector<std::string>& raw, const std::map<std::string, std::string>& env, std::ostream& out,
        std::ostream& err) {
  try {
    std::vector<std::string> args = raw;
    for (std::string& a : args) {
      if (a == "-h") a = "--help";
      if (a == "-o") a = "--out";
    }
    const tools::CommandLine line = tools::SplitCommandLine(args, Switches());
    if (HasFlag(line, "--help")) {
      out << HelpFor(line.positional);
      return kExitOk;
    }
    Invocation in = Resolve(line, out, err);
    in.json = HasFlag(line, "--json");
    if (in.command.local) return in.command.run(in);  // no server
    client::Client client(ClientOptionsOf(line, env, err));
    in.client = &client;
    return in.command.run(in);
  } catch (const UsageError& e) {
    err << "robocal: " << e.what() << "\n(see robocal --help)\n";
    return kExitUsage;
  } catch (const tools::BadFlag& e) {
    err << "robocal: " << e.what() << "\n(see robocal --help)\n";
    return kExitUsage;
  } catch (const client::ServiceError& e) {
    err << "robocal: " << e.http_status() << " " << api::WireName(e.status()) << ": " << e.message() << "\n";
    for (const auto& d : e.details()) err << "  " << d.field << ": " << d.reason << "\n";
    return kExitServiceError;
  } catch (const client::ConnectionError& e) {
    err << "robocal: " << e.what() << "\n";
    return kExitConnection;
  } catch (const std::exception& e) {
    err << "robocal: " << e.what() << "\n";
    return kExitServiceError;
  }
}

}  // namespace robocal::cli
