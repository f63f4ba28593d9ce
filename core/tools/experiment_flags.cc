// Flag parsing of the simulated experiment (see experiment_flags.h).
#include "experiment_flags.h"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <numbers>
#include <stdexcept>

namespace robocal::tools {
namespace {

// A bad flag: its message, returned by ParseExperimentFlags.
struct BadFlag : std::runtime_error {
  using std::runtime_error::runtime_error;
};

double ParseDouble(const std::string& flag, const std::string& text, double min) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno != 0 || !std::isfinite(value)) {
    throw BadFlag(flag + ": '" + text + "' is not a number");
  }
  if (value < min) throw BadFlag(flag + ": must be " + (min > 0.0 ? "positive" : "0 or more") + " (got " + text + ")");
  return value;
}

long long ParseInteger(const std::string& flag, const std::string& text, long long min, long long max) {
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno != 0) throw BadFlag(flag + ": '" + text + "' is not an integer");
  if (value < min || value > max) {
    throw BadFlag(flag + ": " + text + " is out of range [" + std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  return value;
}

std::uint64_t ParseSeed(const std::string& text) {
  if (text.empty() || text[0] == '-') throw BadFlag("--seed: '" + text + "' is not a non-negative integer");
  errno = 0;
  char* end = nullptr;
  const unsigned long long seed = std::strtoull(text.c_str(), &end, 10);
  if (*end != '\0' || errno != 0) throw BadFlag("--seed: '" + text + "' is not a non-negative integer");
  return static_cast<std::uint64_t>(seed);
}

void Apply(const std::string& flag, const std::string& value, ExperimentOptions* options) {
  if (flag == "--robot") {
    options->robot = value;
  } else if (flag == "--type") {
    if (!ParseMeasurementType(value, &options->measurement_type)) {
      throw BadFlag("--type: '" + value + "' is not position, position_axis or pose");
    }
  } else if (flag == "--configurations") {
    options->num_configurations = static_cast<int>(ParseInteger(flag, value, 1, 1000));
  } else if (flag == "--trials") {
    options->trials = static_cast<int>(ParseInteger(flag, value, 1, 10000));
  } else if (flag == "--validation") {
    options->num_validation = static_cast<int>(ParseInteger(flag, value, 1, 100000));
  } else if (flag == "--h-mm") {
    options->h_mm = ParseDouble(flag, value, 1e-9);
  } else if (flag == "--seed") {
    options->seed = ParseSeed(value);
  } else if (flag == "--noise-mm") {
    options->cell.noise.position_mm = ParseDouble(flag, value, 0.0);
  } else if (flag == "--noise-deg") {
    options->cell.noise.orientation_rad = ParseDouble(flag, value, 0.0) * std::numbers::pi / 180.0;
  } else if (flag == "--shots") {
    options->cell.shots_per_pose = static_cast<int>(ParseInteger(flag, value, 1, 1000));
  } else {
    throw BadFlag("unknown option '" + flag + "'");
  }
}

}  // namespace

const char* const kExperimentFlagsHelp = R"(  --robot NAME           grinder5 (default), puma560 or ur5e
  --type TYPE            measurements: position, position_axis or pose (default pose)
  --configurations M     configurations per plan (default 10, the paper's)
  --trials N             independent trials, results pooled (default 10)
  --validation N         validation poses per trial (default 36, the paper's)
  --h-mm H               lever of E_tot = E_xyz + H * E_cos, mm (default 30)
  --seed S               seed of every random draw (default 1)
  --noise-mm SIGMA       tracker position noise per axis, 1-sigma, mm (default 0.015)
  --noise-deg SIGMA      tracker orientation noise per axis, 1-sigma, degrees (default 0.0057)
  --shots N              tracker shots per pose (default 10, the paper's)
)";

std::string ParseExperimentFlags(const std::vector<std::string>& args, ExperimentOptions* options) {
  try {
    for (std::size_t i = 0; i < args.size(); ++i) {
      std::string flag = args[i];
      std::string value;
      const std::size_t equals = flag.find('=');
      if (flag.rfind("--", 0) == 0 && equals != std::string::npos) {
        value = flag.substr(equals + 1);
        flag = flag.substr(0, equals);
      } else if (flag.rfind("--", 0) != 0) {
        throw BadFlag("unexpected argument '" + flag + "'");
      } else if (i + 1 < args.size()) {
        value = args[++i];
      } else {
        throw BadFlag(flag + " needs a value");
      }
      Apply(flag, value, options);
    }
  } catch (const BadFlag& e) {
    return e.what();
  }
  std::string error;
  if (!options->IsValid(&error)) return error;
  return "";
}

}  // namespace robocal::tools
