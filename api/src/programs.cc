// The program compensation's wire shapes: the request's validation and the reply from the core's result.
#include "robocal/api/programs.h"

#include <cmath>

#include "robocal/api/json_reader.h"
#include "robocal/api/robots.h"
#include "robocal/core/units.h"
#include "robocal/programs/text_scan.h"

namespace robocal::api {

const char* EnumTable<programs::Dialect>::Name(programs::Dialect v) { return programs::ToString(v); }
const char* EnumTable<programs::TargetKind>::Name(programs::TargetKind v) { return programs::ToString(v); }
const char* EnumTable<programs::OnFailure>::Name(programs::OnFailure v) { return programs::ToString(v); }

namespace {

// Files of one program at most, and the longest name: a program is a handful of files, and names become file
// names on the client's disk.
constexpr std::size_t kMaxFiles = 64;
constexpr std::size_t kMaxFileName = 255;

// A name that is a plain file name: no directory, no control characters.
std::string FileNameProblem(const std::string& name) {
  if (name.empty()) return "a file name must not be empty";
  if (name.size() > kMaxFileName) return "a file name has at most 255 bytes";
  if (name == "." || name == "..") return "not a file name";
  for (const char c : name) {
    if (c == '/' || c == '\\') return "a file name names no directory ('/' or '\\')";
    if (static_cast<unsigned char>(c) < 0x20) return "a file name has no control characters";
  }
  return "";
}

// A map of names to Cartesian values (tools, bases): each an array of 6 numbers, or 7 for a quaternion dialect.
void ReadFrames(const nlohmann::json* value, const std::string& key, std::size_t count, Problems* problems,
                std::map<std::string, std::vector<double>>* out) {
  if (value == nullptr) return;
  if (!value->is_object()) {
    problems->Add(key, "expected an object of names to [x, y, z, rotation...] in the dialect's units");
    return;
  }
  if (value->size() > kMaxFiles * 4) {
    problems->Add(key, "at most " + std::to_string(kMaxFiles * 4) + " entries");
    return;
  }
  for (const auto& [name, values] : value->items()) {
    std::vector<double> numbers;
    const std::string path = key + "." + name;
    if (name.empty() || name.size() > 64) {
      problems->Add(path, "a name has 1 to 64 bytes");
      continue;
    }
    if (ReadNumberArray(values, path, problems, &numbers, count, count)) (*out)[name] = std::move(numbers);
  }
}

}  // namespace

CompensateProgramRequest ParseCompensateProgramRequest(const nlohmann::json& body, const Limits& limits) {
  Problems problems;
  CompensateProgramRequest req;
  ObjectReader r(body, "", &problems);
  programs::Dialect dialect{};
  if (r.Enum("dialect", false, &dialect)) req.dialect = dialect;
  if (const nlohmann::json* files = r.Get("files")) {
    if (!files->is_object() || files->empty()) {
      problems.Add("files", "expected an object of one or more file names to their text");
    } else if (files->size() > kMaxFiles) {
      problems.Add("files", "at most " + std::to_string(kMaxFiles) + " files");
    } else {
      // Controllers' file systems do not tell "weld.dat" from "WELD.DAT": two such names are one file there.
      std::map<std::string, std::string> folded;
      for (const auto& [name, text] : files->items()) {
        const std::string path = "files." + name;
        const auto [other, fresh] = folded.emplace(programs::LowerCase(name), name);
        if (const std::string why = FileNameProblem(name); !why.empty()) {
          problems.Add("files", why + " (" + name.substr(0, 64) + ")");
        } else if (!fresh) {
          problems.Add(path, "the same file name as " + other->second + " but for case");
        } else if (!text.is_string()) {
          problems.Add(path, "expected the file's text as a string");
        } else {
          req.files[name] = text.get<std::string>();
        }
      }
    }
  } else if (r.ok()) {
    problems.Add("files", "required");
  }
  // A dialect given and file names that say another: a mistake, not a program to read as something it is not.
  if (req.dialect && !req.files.empty() && problems.empty()) {
    std::vector<programs::ProgramFile> named;
    for (const auto& [name, text] : req.files) named.push_back({name, ""});
    if (const std::optional<programs::Dialect> said = programs::DialectOfFiles(named); said && *said != *req.dialect) {
      problems.Add("dialect", std::string("is ") + programs::ToString(*req.dialect) + ", but the file names are " +
                                  programs::ToString(*said) + " files");
    }
  }
  // The dialect the file names say, when the request does not.
  if (!req.dialect && !req.files.empty() && problems.empty()) {
    std::vector<programs::ProgramFile> named;
    for (const auto& [name, text] : req.files) named.push_back({name, ""});
    std::string why;
    if (const std::optional<programs::Dialect> d = programs::DialectOfFiles(named, &why)) {
      req.dialect = d;
    } else {
      problems.Add("dialect", "not given, and the file names do not say it: " + why);
    }
  }
  const std::size_t count =
      req.dialect && programs::SyntaxOf(*req.dialect).rotation == programs::RotationConvention::kQuaternionWxyz ? 7 : 6;
  ReadFrames(r.Get("tools"), "tools", count, &problems, &req.tools);
  ReadFrames(r.Get("bases"), "bases", count, &problems, &req.bases);
  double deviation = 0.0;
  if (r.Number("max_path_deviation_mm", false, &deviation, 1e-6, 1000.0)) req.max_path_deviation_mm = deviation;
  r.Enum("on_failure", false, &req.on_failure);
  PayloadWire payload;
  if (const nlohmann::json* v = r.Get("payload"); v && ReadRequestObject(*v, "payload", &problems, &payload)) {
    req.payload = payload;
  }
  (void)limits;
  r.RejectUnknown(WireFieldNames<CompensateProgramRequest>());
  problems.ThrowIfAny("invalid compensate-program request");
  return req;
}

CompensateProgramResult ToWire(const RobotModel& model, const std::string& campaign,
                               const std::vector<programs::ProgramFile>& request_files,
                               const programs::ProgramCompensationResult& result) {
  CompensateProgramResult out;
  out.campaign = campaign;
  out.dialect = result.dialect;
  for (const programs::ProgramFile& f : result.files) out.files[f.name] = f.text;
  out.targets.reserve(result.targets.size());
  for (const programs::CompensatedTarget& t : result.targets) {
    ProgramTargetWire w;
    w.file = request_files.at(static_cast<std::size_t>(t.file)).name;
    w.line = t.line;
    w.name = t.name;
    w.kind = t.kind;
    w.inserted = t.inserted;
    if (t.joints.size() == model.num_joints()) w.joints = JointsToWire(model, t.joints);
    w.correction_mm = t.correction_mm;
    w.correction_deg = t.correction_rad * kDegPerRad;
    w.joint_change_deg = t.joint_change_rad * kDegPerRad;
    w.configuration_kept = t.configuration_kept;
    w.rewritten = t.rewritten;
    w.predicted_error_mm = t.predicted_error_mm;
    w.termination = t.termination;
    w.message = t.message;
    out.targets.push_back(std::move(w));
  }
  const programs::ProgramCompensationSummary& s = result.summary;
  out.summary = ProgramSummaryWire{.targets = s.targets,
                                   .joint_targets = s.joint_targets,
                                   .cartesian_targets = s.cartesian_targets,
                                   .rewritten = s.rewritten,
                                   .failed = s.failed,
                                   .configuration_changes = s.configuration_changes,
                                   .inserted = s.inserted,
                                   .segments_checked = s.segments_checked,
                                   .segments_over_deviation = s.segments_over_deviation,
                                   .max_correction_mm = s.max_correction_mm,
                                   .max_predicted_error_mm = s.max_predicted_error_mm,
                                   .termination = s.termination,
                                   .message = s.message};
  return out;
}

ROBOCAL_WIRE_DEFINE(CompensateProgramRequest);
ROBOCAL_WIRE_DEFINE(ProgramTargetWire);
ROBOCAL_WIRE_DEFINE(ProgramSummaryWire);
ROBOCAL_WIRE_DEFINE(CompensateProgramResult);

}  // namespace robocal::api
