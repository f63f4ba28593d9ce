// Flag splitting and number parsing of the core's tools (see flags.h).
#include "flags.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace robocal::tools {

namespace {

// Splits `args`; arguments that are not flags go to *positional, or are refused when it is null.
std::vector<std::pair<std::string, std::string>> Split(const std::vector<std::string>& args,
                                                       const std::set<std::string>& switches,
                                                       std::vector<std::string>* positional) {
  std::vector<std::pair<std::string, std::string>> flags;
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string flag = args[i];
    if (flag.rfind("--", 0) != 0) {
      if (!positional) throw BadFlag("unexpected argument '" + flag + "'");
      positional->push_back(flag);
      continue;
    }
    const std::size_t equals = flag.find('=');
    if (equals != std::string::npos) {
      std::string value = flag.substr(equals + 1);
      flag = flag.substr(0, equals);
      if (switches.count(flag)) throw BadFlag(flag + " takes no value");
      flags.emplace_back(flag, value);
    } else if (switches.count(flag)) {
      flags.emplace_back(flag, "");
    } else if (i + 1 < args.size()) {
      flags.emplace_back(flag, args[++i]);
    } else {
      throw BadFlag(flag + " needs a value");
    }
  }
  return flags;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> SplitFlags(const std::vector<std::string>& args,
                                                            const std::set<std::string>& switches) {
  return Split(args, switches, nullptr);
}

CommandLine SplitCommandLine(const std::vector<std::string>& args, const std::set<std::string>& switches) {
  CommandLine line;
  line.flags = Split(args, switches, &line.positional);
  return line;
}

double ParseDoubleFlag(const std::string& flag, const std::string& text, double min) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno != 0 || !std::isfinite(value)) {
    throw BadFlag(flag + ": '" + text + "' is not a number");
  }
  if (value < min) throw BadFlag(flag + ": must be " + (min > 0.0 ? "positive" : "0 or more") + " (got " + text + ")");
  return value;
}

long long ParseIntegerFlag(const std::string& flag, const std::string& text, long long min, long long max) {
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno != 0) throw BadFlag(flag + ": '" + text + "' is not an integer");
  if (value < min || value > max) {
    throw BadFlag(flag + ": " + text + " is out of range [" + std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  return value;
}

std::uint64_t ParseSeedFlag(const std::string& flag, const std::string& text) {
  if (text.empty() || text[0] == '-') throw BadFlag(flag + ": '" + text + "' is not a non-negative integer");
  errno = 0;
  char* end = nullptr;
  const unsigned long long seed = std::strtoull(text.c_str(), &end, 10);
  if (*end != '\0' || errno != 0) throw BadFlag(flag + ": '" + text + "' is not a non-negative integer");
  return static_cast<std::uint64_t>(seed);
}

std::vector<std::string> SplitList(const std::string& flag, const std::string& text) {
  std::vector<std::string> items;
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = text.find(',', begin);
    const std::string item = text.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin);
    if (item.empty()) throw BadFlag(flag + ": '" + text + "' has an empty item");
    items.push_back(item);
    if (comma == std::string::npos) return items;
    begin = comma + 1;
  }
}

}  // namespace robocal::tools
