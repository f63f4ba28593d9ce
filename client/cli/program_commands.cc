// robocal compensate-program: a robot program in its controller's language, compensated on a campaign's
// calibration (docs/programs.md).
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "command.h"
#include "robocal/api/programs.h"
#include "robocal/api/text.h"
#include "support.h"

namespace robocal::cli {
namespace {

// --tools / --bases FILE.json: an object of names to the dialect's Cartesian values.
std::map<std::string, std::vector<double>> ReadFramesFile(const std::string& option, const std::string& path) {
  nlohmann::json value;
  try {
    value = nlohmann::json::parse(ReadFile(path));
  } catch (const nlohmann::json::parse_error& e) {
    throw UsageError(option + " " + path + ": not JSON (" + e.what() + ")");
  }
  if (!value.is_object()) throw UsageError(option + " " + path + ": expected an object of names to [x, y, z, ...]");
  std::map<std::string, std::vector<double>> frames;
  for (const auto& [name, values] : value.items()) {
    if (!values.is_array()) throw UsageError(option + " " + path + ": " + name + " is not an array of numbers");
    std::vector<double> numbers;
    for (const nlohmann::json& v : values) {
      if (!v.is_number()) throw UsageError(option + " " + path + ": " + name + " is not an array of numbers");
      numbers.push_back(v.get<double>());
    }
    frames[name] = std::move(numbers);
  }
  return frames;
}

void PrintTargets(std::ostream& out, const api::CompensateProgramResult& r) {
  out << "file:line  name  kind  correction_mm  correction_deg  joint_change_deg  predicted_error_mm  result\n";
  for (const api::ProgramTargetWire& t : r.targets) {
    out << t.file << ":" << t.line << "  " << (t.inserted ? "(inserted)" : t.name.value_or("(inline)")) << "  "
        << api::WireName(t.kind) << "  " << Fixed(t.correction_mm, 3) << "  " << Fixed(t.correction_deg, 4) << "  "
        << Fixed(t.joint_change_deg, 3) << "  " << Fixed(t.predicted_error_mm, 3) << "  "
        << (t.termination == Termination::kConvergence && t.configuration_kept ? "ok" : "KEPT AS WRITTEN: ")
        << (t.termination == Termination::kConvergence && t.configuration_kept ? "" : t.message) << "\n";
  }
  const api::ProgramSummaryWire& s = r.summary;
  out << api::WireName(r.dialect) << ": " << s.targets << " targets (" << s.joint_targets << " joint, "
      << s.cartesian_targets << " Cartesian), " << s.rewritten << " rewritten, " << s.failed << " kept as written";
  if (s.segments_checked > 0) {
    out << ", " << s.segments_checked << " straight segments checked, " << s.inserted << " targets inserted";
  }
  out << "; largest correction " << Fixed(s.max_correction_mm, 3) << " mm";
  if (std::isfinite(s.max_predicted_error_mm))
    out << ", largest predicted error " << Fixed(s.max_predicted_error_mm, 3) << " mm";
  out << "\n";
  if (!s.message.empty()) out << s.message << "\n";
}

}  // namespace

int CompensateProgram(Invocation& in) {
  api::CompensateProgramRequest request;
  for (std::size_t i = 1; i < in.args.size(); ++i) {
    const std::string name = std::filesystem::path(in.args[i]).filename().string();
    if (request.files.count(name)) throw UsageError("two files named " + name);
    std::string text = ReadFile(in.args[i]);
    // The request carries the text as a JSON string, which is UTF-8: a program saved in another encoding (a
    // Windows code page's umlauts in a comment) must be converted first, and the file is named here.
    if (!api::IsValidUtf8(text)) {
      throw UsageError(in.args[i] + " is not UTF-8 text; convert it first (iconv -f WINDOWS-1252 -t UTF-8, say)");
    }
    request.files[name] = std::move(text);
  }
  if (in.Has("--dialect"))
    request.dialect = Invocation::ParseEnum<programs::Dialect>("--dialect", in.Option("--dialect"));
  if (in.Has("--tools")) request.tools = ReadFramesFile("--tools", in.Option("--tools"));
  if (in.Has("--bases")) request.bases = ReadFramesFile("--bases", in.Option("--bases"));
  if (in.Has("--max-path-deviation")) request.max_path_deviation_mm = in.Number("--max-path-deviation", 0.0, 0.0);
  request.on_failure = in.Enum("--on-failure", programs::OnFailure::kKeep);
  if (in.Has("--payload")) request.payload = ParsePayloadFlag(in.Option("--payload"));
  const std::string out_dir = in.Option("--out");
  if (out_dir.empty() && request.files.size() > 1 && !in.json) {
    throw UsageError("several files: give --out DIR for the compensated files");
  }
  const api::CompensateProgramResult result = in.Client().CompensateProgram(in.args[0], request);
  if (!out_dir.empty()) {
    std::error_code error;
    std::filesystem::create_directories(out_dir, error);
    if (error) throw UsageError("--out " + out_dir + ": " + error.message());
    for (const auto& [name, text] : result.files) {
      const std::filesystem::path path = std::filesystem::path(out_dir) / name;
      // Binary: the line ends come back as they were sent.
      std::ofstream file(path, std::ios::binary);
      file << text;
      if (!file) throw UsageError("cannot write " + path.string());
    }
  }
  if (in.json) {
    PrintJson(in.out, result);
  } else if (out_dir.empty()) {
    // One file and no directory: the file to stdout, the report to stderr.
    in.out << result.files.begin()->second;
    PrintTargets(in.err, result);
  } else {
    PrintTargets(in.out, result);
  }
  return kExitOk;
}

}  // namespace robocal::cli
