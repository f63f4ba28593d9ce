// What several `robocal` commands share (see support.h).
#include "support.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "cli.h"
#include "robocal/api/text.h"
#include "robocal/client/csv.h"

namespace robocal::cli {

std::array<double, 3> Triple(const std::string& option, const std::string& text) {
  const std::vector<std::string> parts = tools::SplitList(option, text);
  if (parts.size() != 3) throw UsageError(option + ": expected X,Y,Z, got '" + text + "'");
  std::array<double, 3> v{};
  for (std::size_t k = 0; k < 3; ++k) {
    v[k] = tools::ParseDoubleFlag(option, parts[k], std::numeric_limits<double>::lowest());
  }
  return v;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError("cannot read " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

bool EndsWith(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

api::TrackerModelWire ParseTrackerFlag(const std::string& text) {
  api::TrackerModelWire tracker;
  if (text == "datasheet") return tracker;
  const std::vector<std::string> parts = tools::SplitList("--tracker", text);
  if (parts.size() < 4 || parts.size() > 6) {
    throw UsageError(
        "--tracker takes datasheet or RADIAL_UM,RADIAL_UM_PER_M,TRANSVERSE_UM,TRANSVERSE_UM_PER_M"
        "[,ORIENTATION_DEG[,MPE_SIGMAS]]");
  }
  std::vector<double> v;
  for (const std::string& p : parts) {
    v.push_back(tools::ParseDoubleFlag("--tracker", p, std::numeric_limits<double>::lowest()));
  }
  tracker.radial_um = {v[0], v[1]};
  tracker.transverse_um = {v[2], v[3]};
  if (v.size() > 4) tracker.orientation_deg = v[4];
  if (v.size() > 5) tracker.mpe_sigmas = v[5];
  return tracker;
}

std::vector<api::CampaignReflectorWire> ParseReflectorsFlag(const std::string& text) {
  const std::string usage = "--reflectors takes ID:X,Y,Z[:fixed]/ID:X,Y,Z[:fixed]/... (mm, flange frame)";
  std::vector<api::CampaignReflectorWire> out;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find('/', begin), text.size());
    const std::string item = text.substr(begin, end - begin);
    begin = end + 1;
    const std::size_t colon = item.find(':');
    if (colon == std::string::npos) throw UsageError(usage + "; \"" + item + "\" has no position");
    api::CampaignReflectorWire r;
    r.id = item.substr(0, colon);
    std::string position = item.substr(colon + 1);
    const std::size_t second = position.find(':');
    if (second != std::string::npos) {
      if (position.substr(second + 1) != "fixed") {
        throw UsageError(usage + "; \"" + item + "\" ends in neither a position nor :fixed");
      }
      r.fixed = true;
      position.resize(second);
    }
    if (position.empty()) throw UsageError(usage + "; \"" + item + "\" has no position");
    const std::vector<std::string> xyz = tools::SplitList("--reflectors", position);
    if (xyz.size() != 3) throw UsageError(usage + "; \"" + item + "\" needs three coordinates");
    for (int k = 0; k < 3; ++k) {
      r.position_mm[k] = tools::ParseDoubleFlag("--reflectors", xyz[k], std::numeric_limits<double>::lowest());
    }
    out.push_back(std::move(r));
  }
  return out;
}

api::PayloadWire ParsePayloadFlag(const std::string& text) {
  api::PayloadWire payload;
  const std::size_t at = text.find('@');
  payload.mass_kg =
      tools::ParseDoubleFlag("--payload", text.substr(0, at), std::numeric_limits<double>::lowest());
  if (at != std::string::npos) {
    const std::vector<std::string> xyz = tools::SplitList("--payload", text.substr(at + 1));
    if (xyz.size() != 3) throw UsageError("--payload takes KG or KG@X,Y,Z (mm, flange frame), got \"" + text + "\"");
    for (int k = 0; k < 3; ++k) {
      payload.com_mm[k] = tools::ParseDoubleFlag("--payload", xyz[k], std::numeric_limits<double>::lowest());
    }
  }
  return payload;
}

std::string Fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

Output::Output(const std::string& out_file, std::ostream& out) : out_(out) {
  if (out_file.empty()) return;
  file_.open(out_file);
  if (!file_) throw UsageError("cannot write " + out_file);
}

std::vector<std::vector<double>> ReadJointsFile(const std::string& path, const api::Robot& robot) {
  std::istringstream in(ReadFile(path));
  std::vector<std::vector<double>> rows;
  try {
    rows = client::ReadJointsCsv(in, static_cast<int>(robot.joints.size()));
  } catch (const std::runtime_error& e) {
    throw UsageError(path + ": " + e.what());
  }
  if (rows.empty()) throw UsageError(path + ": no rows");
  return rows;
}

int WriteForward(Invocation& in, const api::Robot& robot, const std::vector<std::vector<double>>& joints,
                 const api::ForwardResult& result) {
  Output target(in.Option("--out"), in.out);
  if (in.json) {
    PrintJson(target.stream(), result);
    return kExitOk;
  }
  std::vector<api::MeasurementWire> rows;
  for (std::size_t i = 0; i < joints.size() && i < result.poses.size(); ++i) {
    rows.push_back({.joints = joints[i], .pose = result.poses[i]});
  }
  client::WriteMeasurementsCsv(target.stream(), robot.joints, rows);
  return kExitOk;
}

namespace {

void ProgressBar(std::ostream& err, const api::Operation& op) {
  const int width = 30;
  const double progress = std::isfinite(op.progress) ? std::clamp(op.progress, 0.0, 1.0) : 0.0;
  const int filled = static_cast<int>(std::lround(progress * width));
  err << "\r" << op.id << " [" << std::string(filled, '#') << std::string(width - filled, ' ') << "] " << std::setw(3)
      << std::lround(progress * 100) << "% " << api::WireName(op.state) << std::flush;
}

}  // namespace

api::Operation WaitWithProgress(Invocation& in, const std::string& id) {
  std::ostream& err = in.err;
  const api::Operation done = in.Client().WaitOperation(id, [&err](const api::Operation& op) {
    ProgressBar(err, op);
    return true;
  });
  err << "\n";
  return done;
}

int ReportUnfinished(const api::Operation& done, std::ostream& err) {
  const std::string state = api::WireName(done.state);
  const std::string message =
      done.error ? std::string(api::WireName(done.error->status)) + ": " + done.error->message : state;
  err << "robocal: operation " << done.id << " " << state << ": " << message << "\n";
  return kExitServiceError;
}

namespace {

// A Latin-1 (ISO 8859-1) text as UTF-8: every byte is the code point of its value. By hand: iconv would do it
// too, but it is two lines, and the client library stays free of locale state.
std::string Latin1ToUtf8(const std::string& text) {
  std::string out;
  out.reserve(text.size() + text.size() / 8);
  for (unsigned char c : text) {
    if (c < 0x80) {
      out += static_cast<char>(c);
    } else {
      out += static_cast<char>(0xC0 | (c >> 6));
      out += static_cast<char>(0x80 | (c & 0x3F));
    }
  }
  return out;
}

// The comma-separated list of an option (empty items refused, naming the option).
std::vector<std::string> ListOption(Invocation& in, const char* option) {
  return tools::SplitList(option, in.Option(option));
}

}  // namespace

api::ImportMeasurementsRequest TrackerFileRequest(Invocation& in, const std::string& format, const std::string& path) {
  if (format != "sa" && format != "csv") throw UsageError("--format takes sa or csv, got '" + format + "'");
  api::ImportMeasurementsRequest request;
  request.format = Invocation::ParseEnum<api::TrackerFileFormat>("--format", format);
  request.text = ReadFile(path);
  if (request.text.empty()) throw UsageError(path + " is empty or not a file");
  // The text goes as JSON, which is UTF-8: a Latin-1 export (µ, ° in its header) is converted first.
  const std::string encoding = in.Option("--encoding", "auto");
  if (encoding != "auto" && encoding != "utf-8" && encoding != "latin-1") {
    throw UsageError("--encoding takes auto, utf-8 or latin-1, got '" + encoding + "'");
  }
  if (encoding == "latin-1" || (encoding == "auto" && !api::IsValidUtf8(request.text))) {
    request.text = Latin1ToUtf8(request.text);
    if (encoding == "auto") in.err << path << " is not UTF-8: read as Latin-1\n";
  }
  request.role = in.Enum("--role", request.role);
  request.request_id = in.Option("--request-id");
  request.plan = in.Option("--plan");
  if (in.Has("--unit")) request.unit = Invocation::ParseEnum<api::TrackerFileUnit>("--unit", in.Option("--unit"));
  request.match = in.Enum("--match", request.match);
  request.shots_per_configuration = static_cast<int>(in.Integer("--shots", 0, 1, 1000));
  if (in.Has("--columns")) {
    if (format != "csv") throw UsageError("--columns is for --format csv");
    // target=Name,x=X,y=Y,z=Z,reflector=Nest: the header names of the columns the import reads.
    std::istringstream list(in.Option("--columns"));
    std::string item;
    while (std::getline(list, item, ',')) {
      const std::size_t eq = item.find('=');
      const std::string key = item.substr(0, eq);
      std::string* out = key == "target"      ? &request.columns.target
                         : key == "x"         ? &request.columns.x
                         : key == "y"         ? &request.columns.y
                         : key == "z"         ? &request.columns.z
                         : key == "reflector" ? &request.columns.reflector
                                              : nullptr;
      if (eq == std::string::npos || out == nullptr) {
        throw UsageError("--columns takes KEY=HEADER,... with keys target, x, y, z, reflector; got '" + item + "'");
      }
      *out = item.substr(eq + 1);
    }
  }
  // A file that carries the joints (and the measured orientation): no plan; the service checks the columns and
  // names the field.
  if (in.Has("--joints")) {
    request.joints.columns = ListOption(in, "--joints");
    if (in.Option("--joint-unit").empty()) throw UsageError("--joints needs --joint-unit deg|rad");
    request.joints.unit = in.Enum("--joint-unit", request.joints.unit);
  } else if (in.Has("--joint-unit")) {
    throw UsageError("--joint-unit is for --joints");
  }
  const bool quaternion = in.Has("--quaternion-order"), euler = in.Has("--euler");
  if (quaternion && euler) throw UsageError("--quaternion-order and --euler exclude each other");
  if ((quaternion || euler) != in.Has("--orientation-columns")) {
    throw UsageError("--orientation-columns goes with --quaternion-order or --euler");
  }
  if (quaternion || euler) {
    api::OrientationColumns& o = request.orientation;
    o.representation =
        quaternion ? api::OrientationRepresentation::kQuaternion : api::OrientationRepresentation::kEuler;
    o.columns = ListOption(in, "--orientation-columns");
    if (quaternion) {
      o.order = in.Enum("--quaternion-order", o.order);
    } else {
      o.sequence = in.Option("--euler");
      if (in.Option("--euler-convention").empty() || in.Option("--angle-unit").empty()) {
        throw UsageError("--euler needs --euler-convention intrinsic|extrinsic and --angle-unit deg|rad");
      }
      o.convention = in.Enum("--euler-convention", o.convention);
      o.unit = in.Enum("--angle-unit", o.unit);
    }
  }
  if (in.Has("--delimiter")) {
    const std::string delimiter = in.Option("--delimiter");
    request.delimiter =
        Invocation::ParseEnum<api::TrackerFileDelimiter>("--delimiter", delimiter == "tab" ? "\t" : delimiter);
  }
  request.decimal = in.Enum("--decimal", request.decimal);
  if (in.Has("--payload")) request.payload = ParsePayloadFlag(in.Option("--payload"));

  return request;
}

}  // namespace robocal::cli
